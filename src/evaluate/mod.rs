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
use crate::data::pairs::{Pair, distance, pairs};
use crate::error::Result;
use crate::geometry::rotation::angle_between;
use crate::identify::problem::Measure;
use crate::kinematics::{Pose, tool_pose};
use crate::model::Robot;
use serde::{Deserialize, Serialize};

mod misfit;
mod worst;

pub use misfit::{
    FRAME_FIT_MM, MISPLACED_FIT_FRACTION, MISPLACED_MEDIAN_MM, Misfit, NEAR_LINE_MM, misfit,
    misplaced_median, misplaced_model_warning,
};
pub use worst::{RAISED_MM, RowComparison, WORST_ROWS, WorstRows, worst_rows};

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

    #[test]
    fn a_summary_of_a_nan_is_nan_throughout() {
        let s = Summary::of(&[1.0, 3.0, 2.0]).unwrap();
        assert_eq!((s.mean, s.max), (2.0, 3.0));
        let s = Summary::of(&[f64::NAN, 1.0, 2.0]).unwrap();
        assert!(s.mean.is_nan() && s.rms.is_nan() && s.max.is_nan(), "{s:?}");
    }
}
