//! The reports of `case-d` and `reproduce`.

use super::Accuracy;
use crate::evaluate::ErrorStats;
use crate::neural::fit::CompensatorReport;
use crate::studies::case_d::{Robotset, Row, Stage, find};
use crate::studies::reproduce::{
    Case, CaseData, CaseRun, figures, median_range, seed_figures, thesis_figures,
};
use serde::{Deserialize, Serialize};

/// One model of the Case D protocol on one set.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct CaseDRow {
    /// The model.
    pub stage: Stage,
    /// The model in words.
    pub label: String,
    /// Thesis Table 6.6: mean position error (mm), where the thesis has one.
    #[serde(with = "crate::io::json_number::option")]
    pub thesis_mm: Option<f64>,
    /// Thesis Table 6.6: mean orientation error (deg).
    #[serde(with = "crate::io::json_number::option")]
    pub thesis_deg: Option<f64>,
    /// Test poses against their noise-free truth (mm, deg).
    pub truth: ErrorStats,
    /// Test poses against the noisy measurements (mm, deg).
    pub measured: ErrorStats,
    /// The compensator's settings, for the network rows.
    pub settings: Option<String>,
    /// The compensator's training, for the network rows.
    pub training: Option<CompensatorReport>,
}

/// One data set of the Case D protocol.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct CaseDSet {
    /// The set.
    pub set: Robotset,
    /// The set in words.
    pub title: String,
    /// Its unseen test poses.
    pub test_rows: usize,
    /// Its calibration poses (identification), as read: the protocol's 30 in the shipped
    /// files. 0 in reports written before it.
    #[serde(default)]
    pub calibration_rows: usize,
    /// Its training poses (compensators), as read: the protocol's 150 in the shipped files.
    /// 0 in reports written before it.
    #[serde(default)]
    pub training_rows: usize,
    /// Every model, nominal to full geometric + network.
    pub rows: Vec<CaseDRow>,
    /// Mean position error vs truth, offsets over offsets + network (times).
    #[serde(with = "crate::io::json_number::option")]
    pub gain_after_offsets: Option<f64>,
    /// The same after full identification (times).
    #[serde(with = "crate::io::json_number::option")]
    pub gain_after_full: Option<f64>,
    /// The same after full + compliance (times; the non-geometric robot only).
    #[serde(default, with = "crate::io::json_number::option")]
    pub gain_after_compliance: Option<f64>,
}

/// A row's label: its stage's, but for a network stage whose training kept no network
/// (cross-validation chose the model alone), which says what the row is instead: the model
/// refined on the training poses ("full geometric, refined"), or as identified ("full
/// geometric (no network)"), and not "+ network" for an error no network made.
fn row_label(r: &Row) -> String {
    let label = r.stage.label();
    let plain = label.trim_end_matches(" + network");
    match kept_no_network(r.training.as_ref()) {
        Some(true) => format!("{plain}, refined"),
        Some(false) => format!("{plain} (no network)"),
        None => label.into(),
    }
}

/// For a network stage whose `training` kept no network (cross-validation chose the model
/// alone): whether it refined the model on the training poses; None where a network was
/// kept, or for a stage without training.
pub fn kept_no_network(training: Option<&CompensatorReport>) -> Option<bool> {
    training
        .filter(|t| !t.settings.has_network())
        .map(|t| !t.refined.is_empty())
}

/// What `case-d` found.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct CaseDReport {
    /// The training seed.
    pub seed: u64,
    /// Case D, then the non-geometric robot.
    pub sets: Vec<CaseDSet>,
}

impl CaseDReport {
    /// The report of the protocol's `rows` (from `studies::case_d::run`).
    pub fn new(seed: u64, rows: &[Row]) -> CaseDReport {
        let sets = Robotset::ALL
            .iter()
            .map(|&set| {
                let gain = |a: Stage, b: Stage| -> Option<f64> {
                    Some(
                        find(rows, set, a)?.truth.position_mean_mm()
                            / find(rows, set, b)?.truth.position_mean_mm(),
                    )
                };
                let mine: Vec<&Row> = rows.iter().filter(|r| r.set == set).collect();
                CaseDSet {
                    set,
                    title: set.title().into(),
                    test_rows: mine.first().map_or(0, |r| r.truth.count),
                    calibration_rows: mine.first().map_or(0, |r| r.calibration_rows),
                    training_rows: mine.first().map_or(0, |r| r.training_rows),
                    rows: mine
                        .iter()
                        .map(|r| CaseDRow {
                            stage: r.stage,
                            label: row_label(r),
                            thesis_mm: r.stage.thesis(set).map(|t| t.0),
                            thesis_deg: r.stage.thesis(set).map(|t| t.1),
                            truth: r.truth,
                            measured: r.measured,
                            settings: r.training.as_ref().map(|t| t.settings.describe()),
                            training: r.training.clone(),
                        })
                        .collect(),
                    gain_after_offsets: gain(Stage::Offsets, Stage::OffsetsNetwork),
                    gain_after_full: gain(Stage::Full, Stage::FullNetwork),
                    gain_after_compliance: gain(
                        Stage::FullCompliance,
                        Stage::FullComplianceNetwork,
                    ),
                }
            })
            .collect();
        CaseDReport { seed, sets }
    }

    /// Every model's errors against the truth, then against the measurements, per set.
    pub fn accuracy(&self) -> Vec<Accuracy> {
        let mut out = Vec::new();
        for s in &self.sets {
            for (what, pick) in [("test vs truth", true), ("test vs measured", false)] {
                for r in &s.rows {
                    out.push(Accuracy::new(
                        &format!("{}: {what}", s.set.folder()),
                        &r.label,
                        if pick { r.truth } else { r.measured },
                    ));
                }
            }
        }
        out
    }
}

/// One of the thesis's published figures.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ThesisFigure {
    /// What it measures.
    pub figure: String,
    /// Before identification.
    pub before: f64,
    /// After identification.
    pub after: f64,
}

/// One of our figures beside the thesis's.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ReproduceFigure {
    /// What it measures (unit in the text).
    pub figure: String,
    /// The nominal model against the measurements.
    #[serde(with = "crate::io::json_number")]
    pub before: f64,
    /// The identified model against the measurements.
    #[serde(with = "crate::io::json_number")]
    pub after: f64,
    /// The identified model against the noise-free truth, where the protocol has one.
    #[serde(with = "crate::io::json_number::option")]
    pub after_vs_truth: Option<f64>,
}

/// One case study on its shipped set.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct ReproduceCase {
    /// `A`, `B-sim`, `C` or `D`.
    pub case: String,
    /// Calibration rows.
    pub calibration_rows: usize,
    /// Validation (Case D: test) rows.
    pub validation_rows: usize,
    /// The fit's a-posteriori variance factor.
    #[serde(with = "crate::io::json_number")]
    pub variance_factor: f64,
    /// The thesis's figures.
    pub thesis: Vec<ThesisFigure>,
    /// Ours.
    pub figures: Vec<ReproduceFigure>,
}

impl ReproduceCase {
    /// The report of `run` on the shipped `data`.
    pub fn new(data: &CaseData, run: &CaseRun) -> ReproduceCase {
        ReproduceCase {
            case: run.case.name().into(),
            calibration_rows: data.calibration.rows.len(),
            validation_rows: data.validation.rows.len(),
            variance_factor: run.variance_factor,
            thesis: thesis_figures(run.case)
                .iter()
                .map(|(f, b, a)| ThesisFigure {
                    figure: (*f).into(),
                    before: *b,
                    after: *a,
                })
                .collect(),
            figures: figures(run)
                .into_iter()
                .map(|(f, b, a, t)| ReproduceFigure {
                    figure: f.into(),
                    before: b,
                    after: a,
                    after_vs_truth: (!t.is_nan()).then_some(t),
                })
                .collect(),
        }
    }
}

/// A figure of a protocol repeated over seeds.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SeedFigure {
    /// The case.
    pub case: String,
    /// What it measures (unit in the text).
    pub figure: String,
    /// Median over the seeds.
    #[serde(with = "crate::io::json_number")]
    pub median: f64,
    /// Smallest.
    #[serde(with = "crate::io::json_number")]
    pub min: f64,
    /// Largest.
    #[serde(with = "crate::io::json_number")]
    pub max: f64,
}

impl SeedFigure {
    /// The figures of `case` over `runs` (one run per seed).
    pub fn of(case: Case, runs: &[CaseRun]) -> Vec<SeedFigure> {
        seed_figures(case, runs)
            .into_iter()
            .map(|(f, v)| {
                let (median, min, max) = median_range(&v);
                SeedFigure {
                    case: case.name().into(),
                    figure: f.into(),
                    median,
                    min,
                    max,
                }
            })
            .collect()
    }
}

/// What `reproduce` found.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct ReproduceReport {
    /// Each case on its shipped set.
    pub cases: Vec<ReproduceCase>,
    /// Seeds of the repeated protocols (1..=seeds).
    pub seeds: u64,
    /// The repeated protocols' figures.
    pub over_seeds: Vec<SeedFigure>,
}
