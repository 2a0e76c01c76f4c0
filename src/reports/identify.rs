//! The reports of `identify` and `evaluate`.

use super::Accuracy;
use crate::data::shared_readings::SharedReading;
use crate::identify::identifiability::DropReason;
use crate::identify::outliers::Outlier;
use crate::identify::run::{ParamReport, file_value};
use crate::identify::{Identified, Measure, Method, Options, RobustLoss, StopReason};
use crate::model::Field;
use crate::neural::repeats::Repeats;
use serde::{Deserialize, Serialize};

/// A candidate parameter left out of the identifiable set.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DroppedParam {
    /// Its name (`a3`, `tool.rz`, ...).
    pub name: String,
    /// `no effect` (its Jacobian column is zero), `regroups` (a combination of others) or
    /// `not significant` (a compliance whose change from its start value was within the
    /// significance level).
    pub reason: String,
    /// The kept parameters it moves with, for `regroups`.
    pub regroups_with: Vec<Regroup>,
    /// Its estimate's change from its start value over its standard deviation when it was
    /// dropped, for `not significant`.
    #[serde(default)]
    pub estimate_over_std: Option<f64>,
    /// The value it is held at, for `not significant`: its start value (zero unless the
    /// robot file gave one), in `unit`.
    #[serde(default)]
    pub held_at: Option<f64>,
    /// Its file unit (`mm`, `deg`, `mrad/kNm`, ...).
    #[serde(default)]
    pub unit: String,
}

/// One term of a regrouping: a change of the dropped parameter acts as coefficient times
/// that change of each of these kept parameters.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Regroup {
    /// The kept parameter.
    pub name: String,
    /// Its coefficient in file units: the kept parameter's per the dropped one's (`unit`).
    pub coefficient: f64,
    /// The coefficient's unit, the kept parameter's per the dropped one's (`mm per deg`,
    /// `mrad/kNm*kg*m per mrad/kNm*kg`).
    #[serde(default)]
    pub unit: String,
}

/// Two identified parameters whose estimates are strongly correlated (|r| > 0.9).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Correlation {
    /// The first parameter.
    pub a: String,
    /// The second parameter.
    pub b: String,
    /// Their correlation coefficient (-1 to 1).
    pub correlation: f64,
}

/// What `identify` did and found.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct IdentifyReport {
    /// The nominal robot file.
    pub robot: String,
    /// The calibration measurements.
    pub data: String,
    /// Their rows.
    pub rows: usize,
    /// The validation measurements, if given.
    pub validation_data: Option<String>,
    /// How measurements were compared with the model.
    pub measure: Measure,
    /// The solver.
    pub method: Method,
    /// The parameter selection asked for.
    pub params: String,
    /// Errors before (nominal) and after (identified), calibration and validation.
    pub accuracy: Vec<Accuracy>,
    /// RMS of the registration of the tracker's frame (mm), when it was registered.
    #[serde(with = "crate::io::json_number::option")]
    pub registration_rms_mm: Option<f64>,
    /// Whether the registration also fitted the tool.
    pub registration_tool: bool,
    /// Candidate parameters.
    pub candidates: usize,
    /// Rank of the candidates' scaled Jacobian (SVD).
    pub rank: usize,
    /// Its rank from QR with column pivoting.
    pub rank_pivoted_qr: usize,
    /// Condition number of all candidates' scaled Jacobian (`inf` when rank-deficient).
    #[serde(with = "crate::io::json_number")]
    pub condition_number_all_candidates: f64,
    /// Parameters identified (the identifiable set).
    pub identifiable: usize,
    /// Condition number of the identifiable set's scaled Jacobian.
    #[serde(with = "crate::io::json_number")]
    pub condition_number: f64,
    /// Candidates left out, and why.
    pub dropped: Vec<DroppedParam>,
    /// Iterations of the last solve (the one `stop_reason` ends).
    pub iterations: usize,
    /// Nonlinear solves run, the first, robust reweighting rounds and solves again counted
    /// ([`crate::identify::run::Effort`]); 0 in reports written before it.
    #[serde(default)]
    pub solves: usize,
    /// Iterations of all those solves, summed; 0 in reports written before it.
    #[serde(default)]
    pub total_iterations: usize,
    /// Why the solver stopped.
    pub stop_reason: StopReason,
    /// The same, in words.
    pub stop: String,
    /// A-posteriori variance factor s^2 (1 when the residuals are the stated noise).
    #[serde(with = "crate::io::json_number")]
    pub variance_factor: f64,
    /// The unmodelled error added to the rows' own sigmas, by kind
    /// ([`crate::identify::unmodelled`]): tau of positions (mm) and orientations (rad).
    /// Left out of the file where none was added (and absent in reports written before it).
    #[serde(default, skip_serializing_if = "unmodelled_is_none")]
    pub unmodelled: crate::identify::Unmodelled,
    /// Every identified parameter: nominal, estimate, standard deviation (file units).
    pub parameters: Vec<ParamReport>,
    /// Strongly correlated pairs (|r| > 0.9).
    pub correlations: Vec<Correlation>,
    /// The outlier cut (robust sigmas; `inf`: none are listed).
    #[serde(with = "crate::io::json_number")]
    pub outlier_k: f64,
    /// Rows beyond the cut.
    pub outliers: Vec<Outlier>,
    /// Calibration rows that carry another configuration's reading under the identified
    /// model ([`crate::data::shared_readings`]; pose and position measures), left in the fit
    /// as outliers are; `identify` fills it, [`IdentifyReport::new`] leaves it empty. Empty
    /// when there are none (then left out of the file, and in reports written before it).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub shared_readings: Vec<SharedReading>,
    /// The validation rows of largest position error under the identified model (mm);
    /// `identify` fills it where validation rows with positions were given,
    /// [`IdentifyReport::new`] leaves it None. None then left out of the file (and in reports
    /// written before it).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub validation_worst_rows: Option<crate::evaluate::WorstRows>,
    /// The robust loss, if one was used.
    pub robust: Option<RobustLoss>,
    /// Reweighting rounds of the robust loss.
    pub robust_rounds: usize,
    /// Singular values of the candidates' scaled Jacobian, largest first.
    pub singular_values: Vec<f64>,
    /// Notes (frames completed, parameters converted, ...).
    pub notes: Vec<String>,
    /// Warnings (ill-conditioning, outliers, ...).
    pub warnings: Vec<String>,
    /// The robot file written.
    pub output: String,
}

/// The files an identification read and wrote, as the user named them.
#[derive(Debug, Clone, Default)]
pub struct IdentifyFiles {
    /// The nominal robot file.
    pub robot: String,
    /// The calibration measurements.
    pub data: String,
    /// The validation measurements.
    pub validation: Option<String>,
    /// The robot file written.
    pub output: String,
}

impl IdentifyReport {
    /// The report of `id`, found with `opts` on `rows` rows; `accuracy` the before/after
    /// table.
    pub fn new(
        id: &Identified,
        opts: &Options,
        files: IdentifyFiles,
        rows: usize,
        accuracy: Vec<Accuracy>,
    ) -> IdentifyReport {
        let params = id.robot.parameters();
        let ident = &id.identifiability;
        let dropped = ident
            .dropped
            .iter()
            .map(|d| {
                let p = params[d.param];
                let mut dropped = DroppedParam {
                    name: p.name(),
                    reason: String::new(),
                    regroups_with: Vec::new(),
                    estimate_over_std: None,
                    held_at: None,
                    unit: p.field.file_unit().into(),
                };
                match &d.reason {
                    DropReason::NoEffect => dropped.reason = "no effect".into(),
                    DropReason::NotSignificant(t) => {
                        dropped.reason = "not significant".into();
                        dropped.estimate_over_std = Some(*t);
                        dropped.held_at = Some(file_value(&p, id.robot.param(p)));
                    }
                    DropReason::Regroups(g) => {
                        dropped.reason = "regroups".into();
                        // Internal units (mm per rad) to file units (mm per deg): the
                        // kept parameter's file units per the dropped one's.
                        let per_file = |f: Field| f.to_file(1.0);
                        dropped.regroups_with = (g.iter())
                            .map(|(q, c)| {
                                let kept = params[*q].field;
                                Regroup {
                                    name: params[*q].name(),
                                    coefficient: c * per_file(kept) / per_file(p.field),
                                    unit: format!(
                                        "{} per {}",
                                        kept.file_unit(),
                                        p.field.file_unit()
                                    ),
                                }
                            })
                            .collect();
                    }
                }
                dropped
            })
            .collect();
        IdentifyReport {
            robot: files.robot,
            data: files.data,
            rows,
            validation_data: files.validation,
            measure: id.measure,
            method: opts.solve.method,
            params: opts.params.clone(),
            accuracy,
            registration_rms_mm: id.registration.as_ref().map(|r| r.rms_mm),
            registration_tool: id.registration.as_ref().is_some_and(|r| r.tool.is_some()),
            candidates: ident.candidates.len(),
            rank: ident.rank,
            rank_pivoted_qr: ident.rank_pivoted_qr,
            condition_number_all_candidates: ident.condition_number,
            identifiable: ident.selected.len(),
            condition_number: ident.selected_condition_number,
            dropped,
            iterations: id.solution.iterations,
            solves: id.effort.solves,
            total_iterations: id.effort.iterations,
            stop_reason: id.solution.stop,
            stop: id.solution.stop.describe().into(),
            variance_factor: id.variance_factor,
            unmodelled: id.unmodelled,
            parameters: id.parameters.clone(),
            correlations: id
                .correlations
                .iter()
                .map(|(a, b, r)| Correlation {
                    a: a.clone(),
                    b: b.clone(),
                    correlation: *r,
                })
                .collect(),
            outlier_k: opts.outlier_k,
            outliers: id.outliers.clone(),
            shared_readings: Vec::new(),
            validation_worst_rows: None,
            robust: opts.robust,
            robust_rounds: id.effort.robust_rounds,
            singular_values: ident.singular_values.clone(),
            notes: id.notes.clone(),
            warnings: (id.warnings.iter())
                .chain(&id.variance_warning)
                .cloned()
                .collect(),
            output: files.output,
        }
    }
}

/// What `evaluate` measured.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct EvaluateReport {
    /// The robot file.
    pub robot: String,
    /// The compensator file, if one was evaluated.
    pub compensator: Option<String>,
    /// The measurements.
    pub data: String,
    /// Their rows.
    pub rows: usize,
    /// How measurements were compared with the model.
    pub measure: Measure,
    /// The model's errors, and with the compensator (`+net`).
    pub accuracy: Vec<Accuracy>,
    /// Lines of the rows outside the compensator's training domain.
    pub lines_outside_domain: Vec<usize>,
    /// Notes on the compensator, one per line: the model it runs with, if it is not the
    /// robot file's; that it has no network, if so.
    pub note: Option<String>,
    /// The data's configurations measured more than once, under the robot file's model: how
    /// far their position residuals differ (mm), the floor of any compensator, and the two
    /// lines that differ most (a mis-measured row among them decides the max error). None
    /// when no configuration has two rows with positions (then left out of the file, as in
    /// `train`'s report), and in reports written before it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub repeats: Option<Repeats>,
    /// Rows that carry another configuration's reading under the robot file's model
    /// ([`crate::data::shared_readings`]; pose and position measures), a row of the data or of
    /// `check_against`'s: the `data clean` accuracy rows leave them out. Empty when there are
    /// none (then left out of the file, and in reports written before it).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub shared_readings: Vec<SharedReading>,
    /// The measurements the data's readings were checked against besides their own
    /// (`--check-against`), if any.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub check_against: Option<String>,
    /// The rows of largest position error and those whose error the compensator raises most
    /// (mm); None without position errors (measure orientation), and in reports written
    /// before it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub worst_rows: Option<crate::evaluate::WorstRows>,
    /// Every warning `evaluate` printed, in order (those of reading the files included);
    /// empty in reports written before it.
    #[serde(default)]
    pub warnings: Vec<String>,
}

fn unmodelled_is_none(u: &crate::identify::Unmodelled) -> bool {
    !u.any()
}
