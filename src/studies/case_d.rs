//! Case D end to end (thesis 6.4, Table 6.6) and the same protocol on the shipped
//! non-geometric robot.
//!
//! Protocol (thesis notes): identify on the 30 calibration poses (joint offsets as the thesis
//! does, and the full identifiable set), train the compensator on the 150 training poses, and
//! report every model on the unseen test poses, against the noise-free truth and against the
//! noisy measurements. A compensator refines the parameters its model was identified with
//! together with the network ([`CompensatorOptions::refine`]): "offsets + network" re-estimates
//! the offsets only, "full geometric + network" the full set.

use super::thesis;
use crate::data::{MeasurementSet, read_canonical};
use crate::error::Result;
use crate::evaluate::{ErrorStats, RowError, row_errors, summarize};
use crate::identify::{Measure, Options, identify};
use crate::kinematics::tool_pose;
use crate::model::Robot;
use crate::neural::compensator::{Compensator, CompensatorOptions, Refine};
use crate::neural::fit::CompensatorReport;
use crate::neural::predict::PredictWorkspace;
use std::path::Path;

/// One shipped data set of the protocol.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Robotset {
    /// `datasets/case_d`: Table 6.1 deviations, the focused region.
    CaseD,
    /// `datasets/nongeometric_robot`: Table 6.1 deviations plus gravity compliance and gear
    /// errors, the full joint ranges. Named in reports by its folder, as the page names it
    /// (reports written before 2026-12-02 named it `non_geometric`, still read).
    #[serde(rename = "nongeometric_robot", alias = "non_geometric")]
    NonGeometric,
}

impl Robotset {
    /// Both sets, Case D first.
    pub const ALL: [Robotset; 2] = [Robotset::CaseD, Robotset::NonGeometric];

    /// The set's folder under `datasets/`.
    pub fn folder(self) -> &'static str {
        match self {
            Robotset::CaseD => "case_d",
            Robotset::NonGeometric => "nongeometric_robot",
        }
    }

    /// A one-line title for reports.
    pub fn title(self) -> &'static str {
        match self {
            Robotset::CaseD => "Case D (Table 6.1 deviations, focused region)",
            Robotset::NonGeometric => {
                "non-geometric robot (Table 6.1 + gravity compliance + gear errors, full ranges)"
            }
        }
    }
}

/// A model of the protocol.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Stage {
    /// The nominal robot, uncalibrated.
    Nominal,
    /// Joint offsets identified on the calibration poses.
    Offsets,
    /// The joint-offset model with a compensator trained on the training poses.
    OffsetsNetwork,
    /// The full identifiable parameter set identified on the calibration poses.
    Full,
    /// The full geometric model with a compensator trained on the training poses.
    FullNetwork,
    /// The full set with the mass-free joint compliances (non-geometric robot only).
    FullCompliance,
    /// The full set with the joint compliances of known masses (non-geometric robot only).
    FullComplianceMasses,
    /// The mass-free compliant model with a compensator trained on the training poses.
    FullComplianceNetwork,
}

impl Stage {
    /// Every stage, in the order of the result table.
    pub const ALL: [Stage; 8] = [
        Stage::Nominal,
        Stage::Offsets,
        Stage::OffsetsNetwork,
        Stage::Full,
        Stage::FullNetwork,
        Stage::FullCompliance,
        Stage::FullComplianceMasses,
        Stage::FullComplianceNetwork,
    ];

    /// The stage's name in reports, e.g. "joint offsets + network".
    pub fn label(self) -> &'static str {
        match self {
            Stage::Nominal => "nominal model",
            Stage::Offsets => "joint offsets",
            Stage::OffsetsNetwork => "joint offsets + network",
            Stage::Full => "full geometric",
            Stage::FullNetwork => "full geometric + network",
            Stage::FullCompliance => "full + compliance",
            Stage::FullComplianceMasses => "full + compliance (masses)",
            Stage::FullComplianceNetwork => "full + compliance + network",
        }
    }

    /// The thesis's Table 6.6 (Case D only): mean position (mm) and orientation (deg)
    /// errors, which match per-coordinate means against the measurements (thesis notes).
    pub fn thesis(self, set: Robotset) -> Option<(f64, f64)> {
        match (set, self) {
            (Robotset::CaseD, Stage::Nominal) => Some(thesis::TABLE_6_6_NOMINAL),
            (Robotset::CaseD, Stage::Offsets) => Some(thesis::TABLE_6_6_OFFSETS),
            (Robotset::CaseD, Stage::OffsetsNetwork) => Some(thesis::TABLE_6_6_OFFSETS_NETWORK),
            _ => None,
        }
    }
}

/// One row of the result.
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
pub struct Row {
    /// The data set.
    pub set: Robotset,
    /// The model evaluated.
    pub stage: Stage,
    /// Test set against its noise-free truth.
    pub truth: ErrorStats,
    /// Test set against the noisy measurements.
    pub measured: ErrorStats,
    /// The compensator's training, for the network rows.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub training: Option<CompensatorReport>,
    /// Every test row's error against the truth (for plots).
    #[serde(skip)]
    pub truth_errors: Vec<RowError>,
    /// The set's calibration rows (identification), as read: the protocol's 30 in the
    /// shipped files.
    #[serde(skip)]
    pub calibration_rows: usize,
    /// The set's training rows (compensators), as read: the protocol's 150 in the shipped
    /// files.
    #[serde(skip)]
    pub training_rows: usize,
}

/// The shipped files of one set.
pub struct SetData {
    /// The 30 calibration poses (`calibration.csv`), for identification.
    pub calibration: MeasurementSet,
    /// The 150 training poses (`training.csv`), for the compensators.
    pub training: MeasurementSet,
    /// The unseen test poses as measured, with noise (`test.csv`).
    pub test: MeasurementSet,
    /// The same test poses without noise (`test_truth.csv`).
    pub test_truth: MeasurementSet,
}

/// Reads a set's four files from `datasets/<folder>/`.
pub fn load(datasets: &Path, set: Robotset, nominal: &Robot) -> Result<SetData> {
    let dir = datasets.join(set.folder());
    let read = |name: &str| read_canonical(&dir.join(name), nominal);
    let data = SetData {
        calibration: read("calibration.csv")?,
        training: read("training.csv")?,
        test: read("test.csv")?,
        test_truth: read("test_truth.csv")?,
    };
    super::reproduce::same_configurations(&data.test, &data.test_truth)?;
    Ok(data)
}

/// The warnings of a set's files as [`load`] read them: rows that repeat an earlier row to
/// the last digit ([`crate::identify::plausibility::copied_warning`]), which count one
/// reading twice, as `identify` and `train` warn.
pub fn copied_warnings(data: &SetData) -> Vec<String> {
    [&data.calibration, &data.training, &data.test]
        .into_iter()
        .filter_map(crate::identify::plausibility::copied_warning)
        .collect()
}

/// Runs the protocol on one set; `opts.refine` is set per row (the parameters the model was
/// identified with, kept where cross-validation favours them; the geometric ones for the
/// compliant model). `with_masses`, for the non-geometric robot, is the nominal with the
/// simulator's masses: the compliance rows run on that set only.
pub fn run_set(
    nominal: &Robot,
    set: Robotset,
    data: &SetData,
    opts: &CompensatorOptions,
    with_masses: Option<&Robot>,
) -> Result<Vec<Row>> {
    type Stats = (ErrorStats, ErrorStats, Vec<RowError>);
    let stats = |f: &mut dyn FnMut(&[f64]) -> crate::Pose| -> Result<Stats> {
        let truth = row_errors(&data.test_truth, Measure::Pose, &mut *f)?;
        Ok((
            summarize(&truth),
            summarize(&row_errors(&data.test, Measure::Pose, &mut *f)?),
            truth,
        ))
    };
    let identified_from = |nominal: &Robot, params: &str| {
        identify(
            nominal,
            &data.calibration,
            &Options {
                params: params.into(),
                measure: Some(Measure::Pose),
                ..Default::default()
            },
        )
    };
    let identified = |params: &str| identified_from(nominal, params);
    let mut rows = Vec::new();
    let mut push = |stage, (truth, measured, truth_errors): Stats, training| {
        rows.push(Row {
            set,
            stage,
            truth,
            measured,
            training,
            truth_errors,
            calibration_rows: data.calibration.rows.len(),
            training_rows: data.training.rows.len(),
        })
    };
    push(Stage::Nominal, stats(&mut |q| tool_pose(nominal, q))?, None);
    let compliant = with_masses.is_some();
    for (params, plain, with) in [
        ("offsets", Stage::Offsets, Stage::OffsetsNetwork),
        ("full", Stage::Full, Stage::FullNetwork),
        (
            "full,compliance",
            Stage::FullCompliance,
            Stage::FullComplianceNetwork,
        ),
    ] {
        if plain == Stage::FullCompliance && !compliant {
            continue;
        }
        let model = identified(params)?.robot;
        push(plain, stats(&mut |q| tool_pose(&model, q))?, None);
        if let (Stage::FullCompliance, Some(m)) = (plain, with_masses) {
            let known = identified_from(m, params)?.robot;
            push(
                Stage::FullComplianceMasses,
                stats(&mut |q| tool_pose(&known, q))?,
                None,
            );
        }
        // Auto: each row refines its own parameters, its compliances only when asked.
        let o = match &opts.refine {
            Refine::Auto => CompensatorOptions {
                refine: Refine::Params(params.trim_end_matches(",compliance").into()),
                compliance: Some(opts.compliance.unwrap_or(false)),
                ..opts.clone()
            },
            _ => opts.clone(),
        };
        let (c, report) = Compensator::train(&model, &data.training, &o, &|_, _| {})?;
        let mut ws = PredictWorkspace::default();
        push(with, stats(&mut |q| c.predict(q, &mut ws))?, Some(report));
    }
    Ok(rows)
}

/// Both shipped sets' files, as [`load`] reads them.
pub fn load_all(datasets: &Path) -> Result<Vec<(Robotset, SetData)>> {
    let nominal = thesis::fanuc(datasets)?;
    (Robotset::ALL.into_iter())
        .map(|set| Ok((set, load(datasets, set, &nominal)?)))
        .collect()
}

/// Runs the protocol on both shipped sets; the nominal robot is [`thesis::FANUC`].
pub fn run(datasets: &Path, opts: &CompensatorOptions) -> Result<Vec<Row>> {
    run_loaded(datasets, &load_all(datasets)?, opts)
}

/// [`run`] on the sets [`load_all`] read from `datasets`.
pub fn run_loaded(
    datasets: &Path,
    sets: &[(Robotset, SetData)],
    opts: &CompensatorOptions,
) -> Result<Vec<Row>> {
    let nominal = thesis::fanuc(datasets)?;
    let with_masses = crate::model::read_robot(datasets.join(thesis::NONGEOMETRIC_MASSES))?;
    let mut rows = Vec::new();
    for (set, data) in sets {
        let masses = (*set == Robotset::NonGeometric).then_some(&with_masses);
        rows.extend(run_set(&nominal, *set, data, opts, masses)?);
    }
    Ok(rows)
}

/// The row of `stage` on `set`.
pub fn find(rows: &[Row], set: Robotset, stage: Stage) -> Option<&Row> {
    rows.iter().find(|r| r.set == set && r.stage == stage)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_set_is_named_by_its_folder_and_the_old_name_still_reads() {
        for set in Robotset::ALL {
            let json = serde_json::to_string(&set).unwrap();
            assert_eq!(json, format!("\"{}\"", set.folder()));
            assert_eq!(serde_json::from_str::<Robotset>(&json).unwrap(), set);
        }
        let old: Robotset = serde_json::from_str("\"non_geometric\"").unwrap();
        assert_eq!(old, Robotset::NonGeometric);
    }
}
