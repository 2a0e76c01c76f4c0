//! The report of `train`.

use super::Accuracy;
use crate::data::shared_readings::SharedReading;
use crate::neural::compensator::Compensator;
use crate::neural::fit::CompensatorReport;
use crate::neural::rbf::Kernel;
use serde::{Deserialize, Serialize};

/// The RBF network of a compensator, as `train` shows it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RbfSummary {
    /// Units: one per training row, or at most `--rbf-units` on a choice of them (the
    /// training report's `rbf_centred_on` then gives the final fit's rows).
    pub units: usize,
    /// The Gaussian processes, in output order (one per output: dx, dy, dz in mm and rx, ry,
    /// rz in mrad, in the robot's base frame, standardised), each with its width per input
    /// (standardised inputs) and its noise and signal variances (standardised outputs).
    pub kernels: Vec<Kernel>,
}

/// What `train` did and found.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct TrainReport {
    /// The model's robot file.
    pub robot: String,
    /// The training measurements.
    pub data: String,
    /// Their rows.
    pub rows: usize,
    /// The validation measurements, if given.
    pub validation_data: Option<String>,
    /// The compensator file written.
    pub compensator: String,
    /// The settings used, in one line (`pose/gravity/64 penalty 0.333 x4 + rbf start 1`).
    pub settings: String,
    /// Input encoding of the networks.
    pub encoding: String,
    /// MLP shape: inputs, hidden units, outputs.
    pub shape: [usize; 3],
    /// The RBF network, if the compensator has one.
    pub rbf: Option<RbfSummary>,
    /// Wall time of the whole training (s).
    pub seconds: f64,
    /// The model's errors and the compensated ones (`+net`), training and validation rows,
    /// and on the same rows but those that carry another configuration's reading
    /// (`training clean`, `validation clean`) where there are any.
    pub accuracy: Vec<Accuracy>,
    /// Cross-validation, refinement and every network's training (with the training rows
    /// that carry another configuration's reading, `training.shared_readings`).
    pub training: CompensatorReport,
    /// Validation rows that carry another configuration's reading, of another validation row
    /// or of a training row (`other_source` the training file), under the robot file's model
    /// ([`crate::data::shared_readings::shared_readings_with`]). Empty when there are none
    /// (then left out of the file, and in reports written before it).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub validation_shared_readings: Vec<SharedReading>,
    /// The validation rows of largest position error with the compensator and those whose
    /// error it raises most (mm); None without validation rows with positions, and in
    /// reports written before it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub validation_worst_rows: Option<crate::evaluate::WorstRows>,
    /// Lines of the validation rows outside the compensator's training domain (as
    /// `evaluate`'s `lines_outside_domain`); empty when there are none (then left out of the
    /// file, and in reports written before it).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub validation_lines_outside_domain: Vec<usize>,
    /// Every warning `train` printed, in order (those of reading the files, of the selection
    /// and of the fit); empty in reports written before it.
    #[serde(default)]
    pub warnings: Vec<String>,
}

impl TrainReport {
    /// The parts that come from the compensator `c` and its training `report`; files, rows,
    /// time and accuracy are the caller's.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        c: &Compensator,
        report: CompensatorReport,
        robot: String,
        data: String,
        rows: usize,
        validation_data: Option<String>,
        compensator: String,
        seconds: f64,
        accuracy: Vec<Accuracy>,
    ) -> TrainReport {
        TrainReport {
            robot,
            data,
            rows,
            validation_data,
            compensator,
            settings: report.settings.describe(),
            encoding: c.encoding.name().into(),
            shape: [c.inputs(), c.hidden(), c.outputs()],
            rbf: c.rbf.as_ref().map(|r| RbfSummary {
                units: r.units(),
                kernels: r.kernels.clone(),
            }),
            seconds,
            accuracy,
            training: report,
            validation_shared_readings: Vec::new(),
            validation_worst_rows: None,
            validation_lines_outside_domain: Vec::new(),
            warnings: Vec::new(),
        }
    }
}
