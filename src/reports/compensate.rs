//! The report of `compensate`.

use serde::{Deserialize, Serialize};

/// A target without a command.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TargetFailure {
    /// Its line in the target file.
    pub line: usize,
    /// The status column's code (`unreachable`, `not-converged`, ...).
    pub status: String,
    /// Why, in words.
    pub message: String,
}

/// What `compensate` did.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct CompensateReport {
    /// The controller's nominal robot file.
    pub nominal: String,
    /// The calibrated robot file.
    pub robot: String,
    /// The compensator file, if one was inverted.
    pub compensator: Option<String>,
    /// The target file.
    pub targets: String,
    /// The commands file written (none: standard output).
    pub output: Option<String>,
    /// Target rows.
    pub total: usize,
    /// Targets with a command.
    pub solved: usize,
    /// Mean distance between commanded and desired tool positions (mm), over the solved.
    #[serde(with = "crate::io::json_number::option")]
    pub shift_mean_mm: Option<f64>,
    /// Largest such distance (mm).
    #[serde(with = "crate::io::json_number::option")]
    pub shift_max_mm: Option<f64>,
    /// Targets without a command, and why.
    pub failures: Vec<TargetFailure>,
    /// Lines of the solved targets outside the compensator's training domain.
    pub lines_outside_domain: Vec<usize>,
    /// Notes on the compensator, one per line: the model it runs with, if it is not the
    /// robot file's; that it has no network, if so.
    pub note: Option<String>,
    /// Where the calibrated base lies far from the nominal's (a base registered to a
    /// tracker): the change of frame the shifts above include.
    #[serde(default)]
    pub frame_change: Option<FrameChange>,
    /// Where the nominal's and the calibrated model's tools differ beyond a calibration's
    /// millimetres: the largest difference of the distances between tool positions at the
    /// same joints (mm; their flanges' differ less). None where they agree, and in reports
    /// written before it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tool_gap_mm: Option<f64>,
    /// With `--decimals`: the largest miss of a target (mm, and deg) by the calibrated robot
    /// given the command as written, rounded, and the line of the largest position miss
    /// (none without `--decimals`, and in reports written before it).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub written_miss: Option<WrittenMiss>,
    /// Solved targets whose commands depend on parameters the model's calibration did not
    /// observe (none: left out of the file, and absent in reports written before it).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub unchecked: Option<UncheckedLines>,
    /// Lines of the targets without seed joints solved on another branch than the one
    /// nearest the middle of the ranges, whose calibrated solution failed (none: left out).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub other_branch_lines: Vec<usize>,
    /// Every warning `compensate` printed, in order; empty in reports written before it.
    #[serde(default)]
    pub warnings: Vec<String>,
}

/// How far rounding the commands to the output's decimals moves what the robot reaches.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct WrittenMiss {
    /// Decimals the commands were written with.
    pub decimals: usize,
    /// Largest position miss of a target (mm).
    #[serde(with = "crate::io::json_number")]
    pub max_mm: f64,
    /// Line of the target with the largest position miss.
    pub max_line: usize,
    /// Largest orientation miss of a target (deg).
    #[serde(with = "crate::io::json_number")]
    pub max_deg: f64,
    /// Lines of the solved targets whose miss is not known: the nominal's solve of the
    /// rounded command from q* did not converge (a command at its singularity).
    pub unchecked: Vec<usize>,
}

/// Results that depend on parameters a calibration did not observe
/// ([`crate::kinematics::unobserved`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct UncheckedLines {
    /// The model's unobserved parameters (`tool.rz`, ...).
    pub unobserved: Vec<String>,
    /// Lines whose position depends on one.
    pub position_lines: Vec<usize>,
    /// Lines whose orientation depends on one (pose targets only).
    pub orientation_lines: Vec<usize>,
}

/// The calibrated model's base against the nominal's, and the shift of the commands from the
/// targets carried into the nominal frame (B_n B_c^-1 T): the correction without the change
/// of frame.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FrameChange {
    /// Distance between the two bases' origins (mm).
    pub base_offset_mm: f64,
    /// Rotation between them (deg).
    pub base_rotation_deg: f64,
    /// Mean shift of the commands from the carried targets (mm), over the solved.
    pub carried_shift_mean_mm: f64,
    /// Largest such shift (mm).
    pub carried_shift_max_mm: f64,
}
