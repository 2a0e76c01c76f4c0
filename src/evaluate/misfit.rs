//! Whether a model fits a set's rows at all: a model of another robot, of another tool or in
//! another frame (misplaced), a frame moved or turned against the model's, or a few rows far
//! off a model that fits the rest ([`misfit`]).

use crate::data::MeasurementSet;
use crate::data::measurement::list_lines;
use crate::kinematics::tool_pose;
use crate::model::Robot;
use nalgebra::Vector3;

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
}
