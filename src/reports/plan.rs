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
}
