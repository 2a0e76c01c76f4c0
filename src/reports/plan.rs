//! The report of `plan`.

use crate::plan::pool::Refused;
use crate::plan::predict::Prediction;
use serde::{Deserialize, Serialize};

/// What `plan` chose and predicts.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct PlanReport {
    /// The robot file planned for.
    pub robot: String,
    /// The parameter selection planned (as for `identify --params`).
    pub params: String,
    /// What each unit measures: `pose`, `position`, `orientation`, `relative` or
    /// `distance`.
    pub measure: String,
    /// The design criterion.
    pub criterion: String,
    /// What the plan was drawn from and held to, so that it can be run again: its inputs
    /// (absent in reports written before 2026-12-02).
    #[serde(default)]
    pub inputs: PlanInputs,
    /// The tracker's position noise per coordinate (mm).
    pub sigma_position_mm: f64,
    /// Its orientation noise (mrad).
    pub sigma_rotation_mrad: f64,
    /// Candidate units drawn within the constraints.
    pub candidate_units: usize,
    /// How many drawn configurations each constraint refused.
    pub refused: Refused,
    /// The parameters the candidates identify.
    pub identifiable: Vec<String>,
    /// The parameters they cannot.
    pub not_identifiable: Vec<String>,
    /// Units chosen.
    pub units: usize,
    /// The chosen configurations (joints in the file's units, deg or mm).
    pub rows: Vec<Vec<f64>>,
    /// The criterion's value of the choice.
    pub value: Option<f64>,
    /// The criterion's value of the greedy choice before the exchanges.
    pub greedy_value: Option<f64>,
    /// Exchanges that improved the greedy choice.
    pub exchanges: Option<usize>,
    /// What the chosen units predict.
    pub prediction: Prediction,
    /// What as many random units predict.
    pub random_prediction: Option<Prediction>,
    /// The warnings `plan` printed, in order (absent in reports written before 2026-12-02).
    #[serde(default)]
    pub warnings: Vec<String>,
}

/// The inputs of a plan besides the robot, parameters, measure and criterion.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct PlanInputs {
    /// The seed of the candidate pool, the validation cloud and the prediction's draws.
    pub seed: u64,
    /// The list evaluated (`--evaluate`), if any.
    pub evaluate: Option<String>,
    /// The candidate file (`--candidates`), if any.
    pub candidates: Option<String>,
    /// The region file the pool and cloud were drawn from (`--region`), if any.
    pub region: Option<String>,
    /// Candidate units drawn (`--pool`), where they were drawn.
    pub pool: Option<usize>,
    /// The planned count (`--count`) or the mean position error aimed at (`--target-mm`, mm).
    pub count: Option<usize>,
    /// See `count` (mm).
    pub target_mm: Option<f64>,
    /// The angle kept from every revolute joint's limits (deg).
    pub margin_deg: f64,
    /// The tool origin's lowest height (mm), if any.
    pub floor_mm: Option<f64>,
    /// The box the tool origin stays out of (xmin, ymin, zmin, xmax, ymax, zmax; mm), if any.
    pub forbid_mm: Option<[f64; 6]>,
    /// Validation configurations the prediction averages over.
    pub validation: usize,
}
