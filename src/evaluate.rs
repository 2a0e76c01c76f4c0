//! Accuracy of a model on a measurement set: per-row errors and their mean, RMS and max.
//!
//! - Position error: the Euclidean norm of measured minus predicted position (mm), as ISO 9283.
//!   The thesis's tables match the mean of |dx|, |dy|, |dz| over all coordinates better (about
//!   half the Euclidean mean); it is reported too, as `position_per_coordinate_mean_mm`.
//! - Orientation error: the angle of R_meas R_pred^T (deg).
//! - Relative and distance data: the error of the displacement's length,
//!   | |p_a - p_b|_meas - |p_a - p_b|_pred | (mm), as thesis Table 6.5 compares distances.
//!
//! Against simulated data the same function gives errors against the noise-free truth when
//! given the truth file: say which one a figure uses.

use crate::data::MeasurementSet;
use crate::data::measurement::list_lines;
use crate::data::pairs::{Pair, distance, pairs};
use crate::error::Result;
use crate::geometry::rotation::angle_between;
use crate::identify::problem::Measure;
use crate::kinematics::{Pose, tool_pose};
use crate::model::Robot;
use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

/// Mean, RMS, 95th percentile and max of a list of errors.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Summary {
    /// Mean error (in the unit of the errors: mm or deg).
    #[serde(with = "crate::io::json_number")]
    pub mean: f64,
    /// Root mean square error (unit of the errors).
    #[serde(with = "crate::io::json_number")]
    pub rms: f64,
    /// The 95th percentile (nearest rank: the smallest error that at least 95 % of the errors
    /// do not exceed).
    #[serde(with = "crate::io::json_number")]
    pub p95: f64,
    /// Largest error (unit of the errors; 0 or more).
    #[serde(with = "crate::io::json_number")]
    pub max: f64,
}

impl Summary {
    /// The summary of the errors `v` (non-negative, mm or deg); None when `v` is empty.
    pub fn of(v: &[f64]) -> Option<Summary> {
        if v.is_empty() {
            return None;
        }
        let n = v.len() as f64;
        let mut sorted = v.to_vec();
        sorted.sort_by(f64::total_cmp);
        let rank = ((0.95 * n).ceil() as usize).clamp(1, v.len());
        Some(Summary {
            mean: v.iter().sum::<f64>() / n,
            rms: (v.iter().map(|x| x * x).sum::<f64>() / n).sqrt(),
            p95: sorted[rank - 1],
            // NaN propagates as in mean and rms (f64::max would drop it).
            max: if v.iter().any(|x| x.is_nan()) {
                f64::NAN
            } else {
                v.iter().copied().fold(0.0, f64::max)
            },
        })
    }
}

/// Statistics of one model on one set.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ErrorStats {
    /// Rows (or pairs) evaluated.
    pub count: usize,
    /// Position error (mm): Euclidean norm, or the displacement-length error for pairs.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub position_mm: Option<Summary>,
    /// Mean of |dx|, |dy|, |dz| over all coordinates (mm): the thesis's figure.
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        with = "crate::io::json_number::option"
    )]
    pub position_per_coordinate_mean_mm: Option<f64>,
    /// Orientation error (deg).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub orientation_deg: Option<Summary>,
}

impl ErrorStats {
    /// Mean position error (mm); NaN when the rows have no position.
    pub fn position_mean_mm(&self) -> f64 {
        self.position_mm.map_or(f64::NAN, |p| p.mean)
    }

    /// RMS position error (mm); NaN when the rows have no position.
    pub fn position_rms_mm(&self) -> f64 {
        self.position_mm.map_or(f64::NAN, |p| p.rms)
    }

    /// Mean per-coordinate position error |dx|, |dy|, |dz| (mm, the thesis's figure); NaN
    /// when the rows have no position.
    pub fn per_coordinate_mm(&self) -> f64 {
        self.position_per_coordinate_mean_mm.unwrap_or(f64::NAN)
    }

    /// Mean orientation error (deg); NaN when the rows have no orientation.
    pub fn orientation_mean_deg(&self) -> f64 {
        self.orientation_deg.map_or(f64::NAN, |o| o.mean)
    }
}

/// The error of one row (or pair).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RowError {
    /// Line of the row (of row b for a pair).
    pub line: usize,
    /// Position error (mm): norm of measured minus predicted position, or for a pair the
    /// error of the displacement's length; None when not measured.
    pub position_mm: Option<f64>,
    /// |dx|, |dy|, |dz| of the position (or displacement) error (mm); None for distances.
    pub abs_xyz_mm: Option<[f64; 3]>,
    /// Orientation error (deg): angle of R_meas R_pred^T; None when not measured.
    pub orientation_deg: Option<f64>,
}

/// Errors of a predictor (joints in rad/mm -> tool pose) on every row or pair of `set`.
pub fn row_errors(
    set: &MeasurementSet,
    measure: Measure,
    mut predict: impl FnMut(&[f64]) -> Pose,
) -> Result<Vec<RowError>> {
    let mut out = Vec::new();
    match measure {
        Measure::Pose | Measure::Position | Measure::Orientation => {
            for m in &set.rows {
                let p = predict(&m.q);
                let dp = m
                    .position
                    .filter(|_| measure != Measure::Orientation)
                    .map(|x| x - p.translation.vector);
                let dr = m
                    .rotation
                    .filter(|_| measure != Measure::Position)
                    .map(|r| angle_between(&r, &p.rotation).to_degrees());
                out.push(RowError {
                    line: m.line,
                    position_mm: dp.map(|d| d.norm()),
                    abs_xyz_mm: dp.map(|d| [d.x.abs(), d.y.abs(), d.z.abs()]),
                    orientation_deg: dr,
                });
            }
        }
        Measure::Relative | Measure::Distance => {
            for Pair { a, b } in pairs(set)? {
                let d_pred = predict(&set.rows[a].q).translation.vector
                    - predict(&set.rows[b].q).translation.vector;
                let (len_err, abs) = if measure == Measure::Relative {
                    let d_meas = set.rows[a].position.unwrap_or_default()
                        - set.rows[b].position.unwrap_or_default();
                    let e = d_meas - d_pred;
                    (
                        (d_meas.norm() - d_pred.norm()).abs(),
                        Some([e.x.abs(), e.y.abs(), e.z.abs()]),
                    )
                } else {
                    let meas = distance(set, Pair { a, b }).unwrap_or(0.0);
                    ((meas - d_pred.norm()).abs(), None)
                };
                out.push(RowError {
                    line: set.rows[b].line,
                    position_mm: Some(len_err),
                    abs_xyz_mm: abs,
                    orientation_deg: None,
                });
            }
        }
    }
    Ok(out)
}

/// Statistics of row errors.
pub fn summarize(rows: &[RowError]) -> ErrorStats {
    let pos: Vec<f64> = rows.iter().filter_map(|r| r.position_mm).collect();
    let rot: Vec<f64> = rows.iter().filter_map(|r| r.orientation_deg).collect();
    let coords: Vec<f64> = rows.iter().filter_map(|r| r.abs_xyz_mm).flatten().collect();
    ErrorStats {
        count: rows.len(),
        position_mm: Summary::of(&pos),
        position_per_coordinate_mean_mm: (!coords.is_empty())
            .then(|| coords.iter().sum::<f64>() / coords.len() as f64),
        orientation_deg: Summary::of(&rot),
    }
}

/// Rows named by [`worst_rows`] (each list at most this long).
pub const WORST_ROWS: usize = 3;

/// Least rise of a row's error (mm) that [`worst_rows`] counts as raised by a compensator:
/// a tenth of a micrometre, below any tracker's resolution, so that rounding in the last
/// bits of a model the compensator reproduces is not counted as its doing.
pub const RAISED_MM: f64 = 1e-4;

/// One row's error under the model and with a compensator (mm): the position error, or for
/// a pair (relative and distance measures) the error of the displacement's length.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct RowComparison {
    /// Line of the row (of row b for a pair).
    pub line: usize,
    /// The model's error (mm).
    #[serde(with = "crate::io::json_number")]
    pub model_mm: f64,
    /// The error with the compensator (mm); None when none was evaluated.
    #[serde(
        default,
        with = "crate::io::json_number::option",
        skip_serializing_if = "Option::is_none"
    )]
    pub compensated_mm: Option<f64>,
}

/// Where a set's largest errors lie, and where a compensator adds error: the rows behind a
/// max, which a mean or an RMS does not name. Errors as [`RowComparison`]'s (mm).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct WorstRows {
    /// The rows of largest error (the compensator's where one was evaluated, else the
    /// model's), largest first.
    pub largest: Vec<RowComparison>,
    /// With a compensator: the rows whose error it raises most over the model's (by
    /// [`RAISED_MM`] or more), largest rise first; empty when it raises none.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub raised: Vec<RowComparison>,
    /// With a compensator: how many rows' error it raises by [`RAISED_MM`] or more (0
    /// without one).
    #[serde(default)]
    pub rows_raised: usize,
    /// Rows (or pairs) compared: those with a position or length error.
    pub rows: usize,
}

/// The [`WORST_ROWS`] rows of largest error and, given the compensator's errors
/// `compensated` (row for row with `model`: the same set and measure), the rows whose error it
/// raises most; None when no row has a position or length error (measure orientation), there
/// being nothing to name. Rows without one are skipped; ties go to the earlier line. Errors
/// are finite where the files are (both are checked on reading); a not-a-number error would
/// rank first, as the worst a row can have.
pub fn worst_rows(
    model: &[RowError],
    compensated: Option<&[RowError]>,
) -> Result<Option<WorstRows>> {
    if let Some(c) = compensated
        && c.len() != model.len()
    {
        return Err(crate::error::Error::Invalid(format!(
            "worst rows: {} compensated row errors for {} model row errors",
            c.len(),
            model.len()
        )));
    }
    let rows: Vec<RowComparison> = model
        .iter()
        .enumerate()
        .filter_map(|(i, m)| {
            Some(RowComparison {
                line: m.line,
                model_mm: m.position_mm?,
                compensated_mm: match compensated {
                    Some(c) => Some(c[i].position_mm?),
                    None => None,
                },
            })
        })
        .collect();
    if rows.is_empty() {
        return Ok(None);
    }
    let worst_first = |v: f64| if v.is_nan() { f64::INFINITY } else { v };
    let error = |r: &RowComparison| worst_first(r.compensated_mm.unwrap_or(r.model_mm));
    let rise = |r: &RowComparison| worst_first(r.compensated_mm.map_or(0.0, |c| c - r.model_mm));
    // Without a compensator every rise is 0: nothing is raised.
    let raised = |r: &RowComparison| rise(r) >= RAISED_MM;
    let top = |key: &dyn Fn(&RowComparison) -> f64, keep: &dyn Fn(&RowComparison) -> bool| {
        let mut v: Vec<RowComparison> = rows.iter().copied().filter(|r| keep(r)).collect();
        v.sort_by(|a, b| key(b).total_cmp(&key(a)).then(a.line.cmp(&b.line)));
        v.truncate(WORST_ROWS);
        v
    };
    Ok(Some(WorstRows {
        largest: top(&error, &|_| true),
        raised: top(&rise, &raised),
        rows_raised: rows.iter().filter(|r| raised(r)).count(),
        rows: rows.len(),
    }))
}

/// Median position error (mm) of a model on a set's rows beyond which `evaluate` and `train`
/// say the model is not one of the robot in the rows' frame ([`misplaced_model_warning`]):
/// ten times what a nominal model of an industrial robot misses by (the thesis's Table 6.1
/// deviations leave 10.8 mm mean), a little less than a tool the model lacks (a gripper,
/// a tracker's reflector on an arm) or a frame not registered (metres).
pub const MISPLACED_MEDIAN_MM: f64 = 100.0;

/// The median position error (mm) of `robot` over the rows of `set` with a position, and
/// their count, where it exceeds [`MISPLACED_MEDIAN_MM`]: another robot's model, a tool it
/// lacks, or rows in a frame it does not know. The median, not the RMS, so that a few rows
/// far off (listed elsewhere as such) do not raise it; None within it or without positions.
pub fn misplaced_median(robot: &Robot, set: &MeasurementSet) -> Option<(f64, usize)> {
    let errors: Vec<f64> = placed(robot, set).iter().map(Placed::error).collect();
    let median = crate::stats::median(&errors);
    (!errors.is_empty() && median > MISPLACED_MEDIAN_MM).then_some((median, errors.len()))
}

/// A row with a position as a model places it: (row index, the model's tool position, the
/// measured position), mm.
struct Placed(usize, Vector3<f64>, Vector3<f64>);

impl Placed {
    /// The position error (mm).
    fn error(&self) -> f64 {
        (self.2 - self.1).norm()
    }
}

/// The rows of `set` with a position, placed by `robot` (each row's FK once).
fn placed(robot: &Robot, set: &MeasurementSet) -> Vec<Placed> {
    (set.rows.iter().enumerate())
        .filter_map(|(i, m)| {
            Some(Placed(
                i,
                tool_pose(robot, &m.q).translation.vector,
                m.position?,
            ))
        })
        .collect()
}

/// Fewer rows than this fraction within [`MISPLACED_MEDIAN_MM`] make a model misplaced
/// ([`Misfit::Misplaced`]); from it on, the rows beyond are the set's, not the model's
/// ([`Misfit::FarRows`]). A quarter, not a half: a model in another frame can still pass near
/// a few rows, and a set whose every other row is off (two set-ups mixed) holds half its rows
/// that fit, which the median alone called "not a model of this robot".
pub const MISPLACED_FIT_FRACTION: f64 = 0.25;

/// Largest position error (mm) of every row after one rigid motion of the rows' frame under
/// which a model that misses some rows by more than [`MISPLACED_MEDIAN_MM`] is in a turned
/// frame ([`Misfit::Frame`]): twice what a nominal model misses by. Not the 100 mm itself: a
/// least-squares motion spreads one row 100.5 mm off over the others, and brought it to 93.
pub const FRAME_FIT_MM: f64 = 20.0;

/// The 90th percentile of the position errors (mm) of the rows a model misses by less than
/// [`MISPLACED_MEDIAN_MM`] above which the model is off every row ([`Misfit::Misplaced`]),
/// not some rows off the model ([`Misfit::FarRows`]): a model off every row by about 100 mm
/// (a tool 100 mm off) splits its rows at random about the line.
pub const NEAR_LINE_MM: f64 = 80.0;

/// How a model misses a set's rows by more than [`MISPLACED_MEDIAN_MM`] ([`misfit`]).
#[derive(Debug, Clone, PartialEq)]
pub enum Misfit {
    /// Most rows are missed by more (fewer than [`MISPLACED_FIT_FRACTION`] of them fit), or,
    /// no rigid motion of the frame fitting them ([`Misfit::Frame`]), the rows within run up
    /// to the line (their 90th percentile above [`NEAR_LINE_MM`]): the model is not one of
    /// the robot in the rows' frame.
    Misplaced {
        /// Median position error (mm) over the rows with a position.
        median_mm: f64,
        /// Rows missed by more than [`MISPLACED_MEDIAN_MM`]: (file line, row index).
        far: Vec<(usize, usize)>,
        /// Rows with a position.
        rows: usize,
    },
    /// The model misses some rows by more, but the rigid motion of the rows' frame that fits
    /// the rows within [`MISPLACED_MEDIAN_MM`] brings some of them, and every other row but
    /// those still beyond it, within [`FRAME_FIT_MM`]: a frame moved or turned against the
    /// model's (which misses the far-reaching rows most), and the rows still beyond, rows of
    /// their own.
    Frame {
        /// Rows missed by more than [`MISPLACED_MEDIAN_MM`].
        far: usize,
        /// Rows with a position.
        rows: usize,
        /// Largest position error (mm) after the rigid motion (Kabsch, least squares, fitted
        /// to the rows within [`MISPLACED_MEDIAN_MM`]) of the rows it brings within
        /// [`FRAME_FIT_MM`].
        registered_max_mm: f64,
        /// Rows still missed by more than [`MISPLACED_MEDIAN_MM`] after that motion: rows of
        /// their own, (file line, row index).
        still_far: Vec<(usize, usize)>,
    },
    /// The model misses these rows by more than [`MISPLACED_MEDIAN_MM`] and keeps clear of
    /// that line on the others (their 90th percentile within [`NEAR_LINE_MM`]), and no rigid
    /// motion of the frame brings the far rows within: rows of another set-up, tool or robot
    /// mixed in, or mis-measured.
    FarRows {
        /// The far rows: (file line, 0 for a row built in code; row index), in file order.
        far: Vec<(usize, usize)>,
        /// Rows with a position.
        rows: usize,
        /// Median position error (mm) of the other rows.
        near_median_mm: f64,
    },
}

impl Misfit {
    /// Whether the model, not some of the rows, is off: misplaced, or in a turned frame.
    pub fn is_the_model(&self) -> bool {
        !matches!(self, Misfit::FarRows { .. })
    }
}

/// Whether `robot` misses rows of `set` by more than [`MISPLACED_MEDIAN_MM`] in position, and
/// how ([`Misfit`]); None where it misses none so (or the set has no positions).
pub fn misfit(robot: &Robot, set: &MeasurementSet) -> Option<Misfit> {
    let points = placed(robot, set);
    let errors: Vec<f64> = points.iter().map(Placed::error).collect();
    // A NaN error (joints the model cannot place) is not a distance: it counts as far.
    let far = |e: f64| e.is_nan() || e > MISPLACED_MEDIAN_MM;
    let near: Vec<f64> = errors.iter().copied().filter(|&e| !far(e)).collect();
    if near.len() == errors.len() {
        return None;
    }
    let rows = errors.len();
    // (file line, row index) of the points whose error `e` is far.
    let named = |e: &[f64]| -> Vec<(usize, usize)> {
        (points.iter().zip(e))
            .filter(|(_, e)| far(**e))
            .map(|(p, _)| (set.rows[p.0].line, p.0))
            .collect()
    };
    let far_rows = named(&errors);
    let misplaced = Misfit::Misplaced {
        median_mm: crate::stats::median(&errors),
        far: far_rows.clone(),
        rows,
    };
    if (near.len() as f64) < MISPLACED_FIT_FRACTION * rows as f64 {
        return Some(misplaced);
    }
    // A frame moved or turned by a little misses the rows far from its origin by more, the
    // others by less: the rigid motion that fits the rows within 100 mm (as registration
    // finds it) then fits every row. Fitted to the near rows alone, so that a row far off is
    // not spread over the others (a cluster of three rows and one 150 mm off had passed for
    // a turned frame).
    let (model, measured): (Vec<Vector3<f64>>, Vec<Vector3<f64>>) = (points.iter().zip(&errors))
        .filter(|(_, e)| !far(**e))
        .map(|(p, _)| (p.1, p.2))
        .unzip();
    if model.len() >= 3 {
        let (r, t) = crate::identify::register::kabsch(&model, &measured);
        let moved: Vec<f64> = points.iter().map(|p| (r * p.1 + t - p.2).norm()).collect();
        // After the motion, every row fits within FRAME_FIT_MM or is still far off (a row of
        // its own), and some far row came within: the frame, not the rows, was off.
        let fits = |e: f64| e <= FRAME_FIT_MM;
        let still_far = named(&moved);
        if moved.iter().all(|&m| fits(m) || far(m)) && still_far.len() < far_rows.len() {
            return Some(Misfit::Frame {
                far: far_rows.len(),
                rows,
                registered_max_mm: moved
                    .iter()
                    .copied()
                    .filter(|&m| fits(m))
                    .fold(0.0, f64::max),
                still_far,
            });
        }
    }
    // The rows beyond are the rows' own where the rows within keep clear of the line: a
    // model off every row by about 100 mm (a tool 100 mm off) splits its rows at random, and
    // those named were good ones. A model 20 or 50 mm off (a short tool error, a frame turned
    // a degree) with a few rows far off still has those rows named.
    if crate::stats::percentile(&near, 90.0) > NEAR_LINE_MM {
        return Some(misplaced);
    }
    Some(Misfit::FarRows {
        far: far_rows,
        rows,
        near_median_mm: crate::stats::median(&near),
    })
}

/// The warning `evaluate` and `train` give where [`misfit`] finds that the model `robot`
/// (named so) misses rows of `set` by more than [`MISPLACED_MEDIAN_MM`], and the misfit.
pub fn misplaced_model_warning(
    robot_name: &str,
    robot: &Robot,
    set: &MeasurementSet,
) -> Option<(String, Misfit)> {
    let found = misfit(robot, set)?;
    // "lines 2, 5" of a file, or "rows 1, 4" (1-based) of a set built in code.
    let which = |rows: &[(usize, usize)]| {
        if rows.iter().all(|f| f.0 > 0) {
            let lines: Vec<usize> = rows.iter().map(|f| f.0).collect();
            let noun = if lines.len() == 1 { "line" } else { "lines" };
            format!("{noun} {}", list_lines(&lines))
        } else {
            let index: Vec<usize> = rows.iter().map(|f| f.1 + 1).collect();
            let noun = if index.len() == 1 { "row" } else { "rows" };
            format!("{noun} {}", list_lines(&index))
        }
    };
    let source = set.source.display();
    let text = match &found {
        Misfit::Misplaced {
            median_mm,
            far,
            rows,
        } => {
            // Where some rows fit, the ones beyond are named too: a few of them may be the
            // rows' own beside a model that is off.
            let beyond = if far.len() == *rows {
                "all of them".to_string()
            } else {
                format!("{} of them, {}", far.len(), which(far))
            };
            format!(
                "{robot_name} misses the positions of {source} by {median_mm:.1} mm (median \
                 over {}; {beyond}, by more than {MISPLACED_MEDIAN_MM} mm, ten times what \
                 a nominal model misses by): it is not a model of this robot in the rows' frame. \
                 Is it this robot's file, does it carry the tool (the reflector's offset), and \
                 are the rows in its base frame (a model identified with the base selected \
                 registers the tracker's frame)?",
                plural(*rows, "row")
            )
        }
        Misfit::Frame {
            far,
            rows,
            registered_max_mm,
            still_far,
        } => {
            let brought = rows - still_far.len();
            let mut text = format!(
                "{robot_name} misses {far} of the {rows} rows of {source} with a position by \
                 more than {MISPLACED_MEDIAN_MM} mm, but one rigid motion of their frame brings \
                 {brought} of them within {registered_max_mm:.1} mm: the rows are in a frame \
                 moved or turned against the model's. Are the rows in its base frame (a model \
                 identified with the base selected registers the tracker's frame)?"
            );
            if !still_far.is_empty() {
                text.push_str(&format!(
                    " After that motion {} still off by more than {MISPLACED_MEDIAN_MM} mm ({}): \
                     rows of their own (mixed in, or mis-measured)",
                    if still_far.len() == 1 {
                        "one row is"
                    } else {
                        "these rows are"
                    },
                    which(still_far)
                ));
            }
            text
        }
        Misfit::FarRows {
            far,
            rows,
            near_median_mm,
        } => format!(
            "{robot_name} misses {} of the {rows} rows of {source} with a position by more than \
             {MISPLACED_MEDIAN_MM} mm ({}), and the other {} by {near_median_mm:.1} mm (median): \
             those rows are not readings of their joints in the frame the others share (another \
             set-up, tool or robot mixed in, or mis-measured); fix or remove them",
            far.len(),
            which(far),
            rows - far.len()
        ),
    };
    Some((text, found))
}

/// "1 line", "2 lines".
fn plural(n: usize, what: &str) -> String {
    if n == 1 {
        format!("1 {what}")
    } else {
        format!("{n} {what}s")
    }
}

/// Statistics of a kinematic model on a set.
pub fn evaluate_model(robot: &Robot, set: &MeasurementSet, measure: Measure) -> Result<ErrorStats> {
    set.check_rows(robot)?;
    Ok(summarize(&row_errors(set, measure, |q| {
        tool_pose(robot, q)
    })?))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A set of `n` rows of the FANUC's model at seeded joints, row k moved `shift(k)` mm along
    /// x, read from lines 2.. of a file.
    fn moved_rows(n: usize, shift: impl Fn(usize) -> f64) -> (Robot, MeasurementSet) {
        use rand::{Rng, SeedableRng};
        let robot = crate::model::test_fanuc();
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
        let rows = (0..n)
            .map(|k| {
                let q: Vec<f64> = (0..6).map(|_| rng.random_range(-1.0..1.0)).collect();
                let mut m = crate::data::Measurement::new(q);
                let p = tool_pose(&robot, &m.q).translation.vector;
                m.position = Some(p + nalgebra::Vector3::new(0.5 + shift(k), 0.0, 0.0));
                m.line = k + 2;
                m
            })
            .collect();
        (robot, MeasurementSet::from_rows(rows))
    }

    #[test]
    fn a_model_off_most_rows_is_misplaced_and_rows_off_a_fitting_model_are_named() {
        // Every row 0.5 mm off: nothing to say.
        let (robot, set) = moved_rows(40, |_| 0.0);
        assert_eq!(misfit(&robot, &set), None);
        // One row 100.5 mm off, or every other row 500 mm: those rows, by line; the others'
        // median is theirs alone (0.5 mm). The median of all had called the second a
        // misplaced model.
        for (every, far) in [(40, vec![2]), (2, (2..42).step_by(2).collect::<Vec<_>>())] {
            let (robot, set) = moved_rows(40, |k| if k % every == 0 { 100.0 } else { 0.0 });
            let lines = |f: &[(usize, usize)]| f.iter().map(|r| r.0).collect::<Vec<_>>();
            match misfit(&robot, &set) {
                Some(Misfit::FarRows {
                    far: f,
                    rows: 40,
                    near_median_mm,
                }) => {
                    assert_eq!(lines(&f), far);
                    assert!((near_median_mm - 0.5).abs() < 1e-9, "{near_median_mm}");
                }
                other => panic!("{other:?}"),
            }
        }
        // 100 mm itself is not beyond.
        let (robot, set) = moved_rows(40, |k| if k == 3 { 99.5 } else { 0.0 });
        assert_eq!(misfit(&robot, &set), None);
        // Fewer than a quarter of the rows fit (9 of 40): misplaced, by the median of all.
        let (robot, set) = moved_rows(40, |k| if k < 31 { 1000.0 } else { 0.0 });
        match misfit(&robot, &set) {
            Some(Misfit::Misplaced {
                median_mm,
                far,
                rows: 40,
            }) => {
                assert!((median_mm - 1000.5).abs() < 1e-9, "{median_mm}");
                assert_eq!(far.len(), 31);
            }
            other => panic!("{other:?}"),
        }
        // A quarter fits (10 of 40): the rows beyond are named.
        let (robot, set) = moved_rows(40, |k| if k < 30 { 1000.0 } else { 0.0 });
        assert!(
            matches!(misfit(&robot, &set), Some(Misfit::FarRows { ref far, .. }) if far.len() == 30)
        );
        let (w, _) = misplaced_model_warning("m.toml", &robot, &set).unwrap();
        assert!(
            w.contains("misses 30 of the 40 rows of") && w.contains("(lines 2, 3, 4,"),
            "{w}"
        );
    }

    /// Rows in a frame turned by a few degrees about their centre: the model misses the rows
    /// far from it by more than 100 mm and fits the near ones, as rows mixed in would look,
    /// but one rigid motion fits them all: the frame is said to be off, not the rows.
    #[test]
    fn rows_in_a_turned_frame_are_the_frames_doing_not_the_rows() {
        let (robot, mut set) = moved_rows(60, |_| 0.0);
        let centre = set
            .rows
            .iter()
            .map(|m| m.position.unwrap())
            .sum::<Vector3<f64>>()
            / 60.0;
        let turn = nalgebra::Rotation3::from_euler_angles(0.0, 0.0, 6f64.to_radians());
        for m in &mut set.rows {
            m.position = Some(centre + turn * (m.position.unwrap() - centre));
        }
        match misfit(&robot, &set) {
            Some(Misfit::Frame {
                far,
                rows: 60,
                registered_max_mm,
                still_far,
            }) => {
                assert!((1..45).contains(&far), "{far} rows far");
                // The rows' own 0.5 mm, turned: a rigid motion fits them to well within it.
                assert!(registered_max_mm < 1.0, "{registered_max_mm}");
                assert!(still_far.is_empty());
            }
            other => panic!("{other:?}"),
        }
        let (w, found) = misplaced_model_warning("m.toml", &robot, &set).unwrap();
        assert!(
            found.is_the_model() && w.contains("one rigid motion of their frame brings 60 of"),
            "{w}"
        );
        // The same frame with one row of its own 500 mm off: the frame, and that row named
        // (a single row off had made the motion miss, and the model was called misplaced).
        let mut one_off = set.clone();
        let p = one_off.rows[7].position.unwrap();
        one_off.rows[7].position = Some(p + Vector3::new(0.0, 500.0, 0.0));
        match misfit(&robot, &one_off) {
            Some(Misfit::Frame { still_far, .. }) => assert_eq!(still_far, vec![(9, 7)]),
            other => panic!("{other:?}"),
        }
        let (w, _) = misplaced_model_warning("m.toml", &robot, &one_off).unwrap();
        assert!(
            w.contains("brings 59 of them") && w.contains("one row is still off"),
            "{w}"
        );
        assert!(w.contains("(line 9): rows of their own"), "{w}");
        // A model off every row by about 100 mm, this way or that (a tool 100 mm off, not a
        // motion of the frame): the rows within 100 mm do not fit either, so the model is
        // misplaced, not the rows beyond (which were named before).
        let (robot, set) = moved_rows(60, |k| if k % 2 == 0 { 99.0 } else { -101.0 });
        assert!(
            matches!(
                misfit(&robot, &set),
                Some(Misfit::Misplaced {
                    ref far,
                    rows: 60,
                    ..
                }) if far.len() == 30
            ),
            "{:?}",
            misfit(&robot, &set)
        );
        let (w, _) = misplaced_model_warning("m.toml", &robot, &set).unwrap();
        assert!(
            w.contains("(median over 60 rows; 30 of them, lines 3, 5, 7,")
                && w.contains("it is not a model of this robot"),
            "{w}"
        );
        // Rows moved one by one are not a frame: still named.
        let (robot, set) = moved_rows(60, |k| if k % 3 == 0 { 500.0 } else { 0.0 });
        assert!(matches!(misfit(&robot, &set), Some(Misfit::FarRows { .. })));
        // Three rows close together and a fourth 150 mm off: a motion fitted to all four
        // spread the fourth's error over the three (16 mm) and passed for a frame; fitted to
        // the three, it leaves the fourth off, named.
        let (robot, mut set) = moved_rows(4, |k| if k == 3 { 150.0 } else { 0.0 });
        for (k, q) in [
            [0.0; 6],
            [0.02, 0.0, 0.0, 0.0, 0.0, 0.0],
            [0.0, 0.02, 0.0, 0.0, 0.0, 0.0],
        ]
        .iter()
        .enumerate()
        {
            set.rows[k].q = q.to_vec();
            let p = tool_pose(&robot, q).translation.vector;
            set.rows[k].position = Some(p + Vector3::new(0.5, 0.0, 0.0));
        }
        match misfit(&robot, &set) {
            Some(Misfit::FarRows { far, .. }) => assert_eq!(far, vec![(5, 3)]),
            other => panic!("{other:?}"),
        }
        // A model 30 mm off every row (a short tool error) beside 5 rows moved 500 mm: those
        // rows are named, not the model called misplaced (the rows within keep clear of the
        // 100 mm line).
        let (robot, set) = moved_rows(40, |k| if k % 8 == 0 { 500.0 } else { 0.0 });
        let a = (robot.parameters().into_iter())
            .find(|p| p.slot == crate::model::Slot::Tool && p.field == crate::model::Field::A)
            .unwrap();
        let tool = robot.with_param(a, robot.param(a) + 30.0).unwrap();
        match misfit(&tool, &set) {
            Some(Misfit::FarRows { far, .. }) => assert_eq!(far.len(), 5),
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn a_summary_of_a_nan_is_nan_throughout() {
        let s = Summary::of(&[1.0, 3.0, 2.0]).unwrap();
        assert_eq!((s.mean, s.max), (2.0, 3.0));
        let s = Summary::of(&[f64::NAN, 1.0, 2.0]).unwrap();
        assert!(s.mean.is_nan() && s.rms.is_nan() && s.max.is_nan(), "{s:?}");
    }

    fn row(line: usize, mm: Option<f64>) -> RowError {
        RowError {
            line,
            position_mm: mm,
            abs_xyz_mm: None,
            orientation_deg: None,
        }
    }

    #[test]
    fn worst_rows_rank_by_the_compensated_error_and_by_its_rise() {
        // Lines 2..7: model and compensated errors (mm, exact in binary so that ties are
        // ties); line 4 has no position.
        let table = [
            (2, Some(1.0), Some(0.125)),
            (3, Some(0.25), Some(0.625)),
            (4, None, None),
            (5, Some(0.75), Some(1.25)),
            (6, Some(0.5), Some(0.625)),
            (7, Some(0.25), Some(0.625)),
        ];
        let model: Vec<RowError> = table.iter().map(|&(l, m, _)| row(l, m)).collect();
        let net: Vec<RowError> = table.iter().map(|&(l, _, n)| row(l, n)).collect();
        let worst = |c: Option<&[RowError]>| worst_rows(&model, c).unwrap().unwrap();
        let w = worst(Some(&net));
        let lines = |v: &[RowComparison]| v.iter().map(|r| r.line).collect::<Vec<_>>();
        // 1.25 (5), then 0.625 three times: ties to the earlier line (3, 6; 7 is fourth).
        assert_eq!(lines(&w.largest), vec![5, 3, 6]);
        assert_eq!(w.largest[0].model_mm, 0.75);
        assert_eq!(w.largest[0].compensated_mm, Some(1.25));
        // Rises: 5 +0.5, 3 and 7 +0.375 (the earlier first), 6 +0.125; line 2 falls.
        assert_eq!(lines(&w.raised), vec![5, 3, 7]);
        assert_eq!((w.rows_raised, w.rows), (4, 5));
        // The model alone: its own largest, nothing raised.
        let alone = worst(None);
        assert_eq!(lines(&alone.largest), vec![2, 5, 6]);
        assert!(alone.largest.iter().all(|r| r.compensated_mm.is_none()));
        assert!(alone.raised.is_empty());
        assert_eq!((alone.rows_raised, alone.rows), (0, 5));
        // A compensator that lowers every error raises none.
        let lower: Vec<RowError> = model
            .iter()
            .map(|r| row(r.line, r.position_mm.map(|e| e / 2.0)))
            .collect();
        let w = worst(Some(&lower));
        assert!(w.raised.is_empty());
        assert_eq!(w.rows_raised, 0);
        assert_eq!(lines(&w.largest), vec![2, 5, 6]);
        // A rise below RAISED_MM (the last bits of a model reproduced) is not counted.
        let same: Vec<RowError> = model
            .iter()
            .map(|r| row(r.line, r.position_mm.map(|e| e + RAISED_MM / 2.0)))
            .collect();
        let w = worst(Some(&same));
        assert_eq!((w.rows_raised, w.raised.len()), (0, 0));
        // A not-a-number error is the worst.
        let mut broken = net.clone();
        broken[5].position_mm = Some(f64::NAN);
        let w = worst(Some(&broken));
        assert_eq!((w.largest[0].line, w.raised[0].line), (7, 7));
        // Row errors of different sets are refused.
        assert!(worst_rows(&model, Some(&net[..3])).is_err());
        // No position at all: nothing to name.
        assert_eq!(worst_rows(&[row(2, None)], None).unwrap(), None);
    }
}
