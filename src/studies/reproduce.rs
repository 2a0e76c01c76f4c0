//! The thesis's case studies A-D (identification part) on the shipped data sets, and the same
//! protocols over many seeds, so that one lucky draw proves nothing.
//!
//! Protocols (thesis 6.2-6.4 and the thesis notes): the FANUC R-2000iB/210F with thesis
//! Table 6.1 deviations, the LTD500 + T-Mac noise ([`thesis::tracker_noise`]), configurations
//! uniform within the joint ranges (Case D: its focused region), `full` identification by LM:
//! - A: 20 position-only calibration + 15 validation measurements, measure position;
//! - B-sim: 20 full-pose calibration + 50 validation measurements, measure pose;
//! - C: 16 calibration configurations (15 relative measurements) + 11 validation (10),
//!   measure relative;
//! - D: 30 full-pose calibration + 250 test measurements in the focused region, `offsets`.
//!
//! For seed s the calibration set uses simulation seed 1000 s + 1 and the validation set
//! 1000 s + 2; s runs over 1..=N, fixed in advance.

use super::thesis;
use crate::data::MeasurementSet;
use crate::error::Result;
use crate::evaluate::{ErrorStats, evaluate_model};
use crate::identify::{Measure, Options, identify};
use crate::model::Robot;
use crate::sim::{Configurations, Deviations, NonGeometric, Observe, Region, Simulation};
use std::path::{Path, PathBuf};

/// One case study's protocol.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Case {
    /// Case A: position-only measurements, identification by position.
    A,
    /// Case B simulated: full-pose measurements, identification by pose.
    BSim,
    /// Case C: positions of consecutive configurations, identification by relative position.
    C,
    /// Case D: full poses in the focused region, joint offsets only.
    D,
}

impl Case {
    /// Every case, in thesis order.
    pub const ALL: [Case; 4] = [Case::A, Case::BSim, Case::C, Case::D];

    /// The case's name in reports: `A`, `B-sim`, `C`, `D`.
    pub fn name(self) -> &'static str {
        match self {
            Case::A => "A",
            Case::BSim => "B-sim",
            Case::C => "C",
            Case::D => "D",
        }
    }

    /// Folder of the shipped set under `datasets/`.
    pub fn folder(self) -> &'static str {
        match self {
            Case::A => "case_a",
            Case::BSim => "case_b_sim",
            Case::C => "case_c",
            Case::D => "case_d",
        }
    }

    /// (calibration rows, validation rows, sensor, comparison, parameters).
    fn design(self) -> (usize, usize, Observe, Measure, &'static str) {
        match self {
            Case::A => (20, 15, Observe::Position, Measure::Position, "full"),
            Case::BSim => (20, 50, Observe::Pose, Measure::Pose, "full"),
            Case::C => (16, 11, Observe::Position, Measure::Relative, "full"),
            Case::D => (30, 250, Observe::Pose, Measure::Pose, "offsets"),
        }
    }

    /// The validation file's name in the shipped folder.
    fn validation_name(self) -> &'static str {
        if self == Case::D {
            "test"
        } else {
            "validation"
        }
    }
}

/// A calibration and validation set with the truth of the validation rows.
#[derive(Debug, Clone)]
pub struct CaseData {
    /// The measured calibration rows, for identification.
    pub calibration: MeasurementSet,
    /// The measured validation rows (Case D: the test rows), with noise.
    pub validation: MeasurementSet,
    /// The same validation rows without noise.
    pub validation_truth: MeasurementSet,
}

/// The outcome of one protocol run.
#[derive(Debug, Clone)]
pub struct CaseRun {
    /// The case run.
    pub case: Case,
    /// The nominal model on the calibration rows.
    pub calibration_before: ErrorStats,
    /// The identified model on the calibration rows.
    pub calibration_after: ErrorStats,
    /// The nominal model against the noisy validation measurements.
    pub validation_before: ErrorStats,
    /// The identified model against the noisy validation measurements.
    pub validation_after: ErrorStats,
    /// Against the noise-free truth of the validation rows.
    pub validation_truth_after: ErrorStats,
    /// The noise alone: measured vs truth on the validation rows (the floor of any model).
    pub validation_noise_floor: ErrorStats,
    /// a-posteriori variance factor of the fit (1 when the residuals are pure noise).
    pub variance_factor: f64,
}

/// Loads a shipped case from `datasets` (the repository's `datasets/` folder).
pub fn load_shipped(datasets: &Path, case: Case, robot: &Robot) -> Result<CaseData> {
    let dir = datasets.join(case.folder());
    let read = |name: &str| crate::data::read_canonical(&dir.join(name), robot);
    let v = case.validation_name();
    let data = CaseData {
        calibration: read("calibration.csv")?,
        validation: read(&format!("{v}.csv"))?,
        validation_truth: read(&format!("{v}_truth.csv"))?,
    };
    same_configurations(&data.validation, &data.validation_truth)?;
    Ok(data)
}

/// Refuses a truth file that does not hold `measured`'s configurations row for row (the same
/// joints to the last bit, in the same order): its figures would come from other poses.
pub fn same_configurations(measured: &MeasurementSet, truth: &MeasurementSet) -> Result<()> {
    let bits = |q: &[f64]| q.iter().map(|v| v.to_bits()).collect::<Vec<u64>>();
    let why = match (measured.rows.iter().zip(&truth.rows)).find(|(m, t)| bits(&m.q) != bits(&t.q))
    {
        Some((m, t)) => format!(
            "line {} of the truth has other joints than line {} of the measurements",
            t.line, m.line
        ),
        None if measured.rows.len() != truth.rows.len() => format!(
            "{} rows against {} measured",
            truth.rows.len(),
            measured.rows.len()
        ),
        None => return Ok(()),
    };
    Err(crate::error::Error::Invalid(format!(
        "{}: not the truth of {} ({why}): a truth file holds the measured configurations row \
         for row",
        truth.source.display(),
        measured.source.display(),
    )))
}

/// Simulates a case's data for one seed (see the module docs for the seeds).
pub fn simulate_case(nominal: &Robot, datasets: &Path, case: Case, seed: u64) -> Result<CaseData> {
    let truth = Deviations::read(datasets.join(thesis::TABLE_6_1), nominal)?.apply(nominal)?;
    let region = match case {
        Case::D => Region::read(datasets.join(thesis::CASE_D_REGION), nominal)?,
        _ => Region::limits(nominal),
    };
    let (n_cal, n_val, observe, _, _) = case.design();
    let ng = NonGeometric::default();
    let noise = thesis::tracker_noise();
    let sim = |count, seed| {
        Simulation {
            truth: &truth,
            nongeometric: &ng,
            configurations: Configurations::Drawn {
                region: &region,
                count,
            },
            seed,
            sigma_position_mm: noise.position_mm,
            sigma_rotation_rad: noise.rotation_rad,
            observe,
        }
        .run(PathBuf::from(format!("case_{}_seed_{seed}", case.name())))
    };
    let cal = sim(n_cal, 1000 * seed + 1)?;
    let val = sim(n_val, 1000 * seed + 2)?;
    Ok(CaseData {
        calibration: cal.measured,
        validation: val.measured,
        validation_truth: val.truth,
    })
}

/// Runs a case's identification and evaluation on `data`.
pub fn run_case(nominal: &Robot, case: Case, data: &CaseData) -> Result<CaseRun> {
    let (_, _, _, measure, params) = case.design();
    let opts = Options {
        params: params.into(),
        measure: Some(measure),
        ..Default::default()
    };
    let id = identify(nominal, &data.calibration, &opts)?;
    let eval = |r: &Robot, s: &MeasurementSet| evaluate_model(r, s, measure);
    // The noise floor: the truth file's poses taken as a "model" of the measurements.
    let floor = noise_floor(&data.validation, &data.validation_truth, measure)?;
    Ok(CaseRun {
        case,
        calibration_before: eval(nominal, &data.calibration)?,
        calibration_after: eval(&id.robot, &data.calibration)?,
        validation_before: eval(nominal, &data.validation)?,
        validation_after: eval(&id.robot, &data.validation)?,
        validation_truth_after: eval(&id.robot, &data.validation_truth)?,
        validation_noise_floor: floor,
        variance_factor: id.variance_factor,
    })
}

/// Errors of the noise-free truth against the measurements: what a perfect model shows.
/// The truth file has the same configurations as the measured one.
pub fn noise_floor(
    measured: &MeasurementSet,
    truth: &MeasurementSet,
    measure: Measure,
) -> Result<ErrorStats> {
    use crate::geometry::Pose;
    let key = |q: &[f64]| q.iter().map(|v| v.to_bits()).collect::<Vec<u64>>();
    let poses: std::collections::HashMap<Vec<u64>, Pose> = truth
        .rows
        .iter()
        .map(|t| {
            let p = Pose::from_parts(
                t.position.unwrap_or_default().into(),
                t.rotation.unwrap_or_default(),
            );
            (key(&t.q), p)
        })
        .collect();
    let rows = crate::evaluate::row_errors(measured, measure, |q| {
        poses.get(&key(q)).copied().unwrap_or_else(Pose::identity)
    })?;
    Ok(crate::evaluate::summarize(&rows))
}

/// The figure each case is judged by, as in the issue and the thesis's tables:
/// A: validation mean per-coordinate position error against the truth (mm);
/// B-sim: the fit's variance factor chi^2 / (m - n), 1 at the noise floor;
/// C: validation RMS of the relative-distance error against the truth (mm);
/// D: test mean position error against the truth (mm).
pub fn headline(run: &CaseRun) -> f64 {
    let t = &run.validation_truth_after;
    match run.case {
        Case::A => t.per_coordinate_mm(),
        Case::BSim => run.variance_factor,
        Case::C => t.position_rms_mm(),
        Case::D => t.position_mean_mm(),
    }
}

/// Median, minimum and maximum.
pub fn median_range(v: &[f64]) -> (f64, f64, f64) {
    let mut s = v.to_vec();
    s.sort_by(|a, b| a.total_cmp(b));
    let n = s.len();
    let med = if n % 2 == 1 {
        s[n / 2]
    } else {
        0.5 * (s[n / 2 - 1] + s[n / 2])
    };
    (med, s[0], s[n - 1])
}

/// Runs of a case over seeds 1..=n.
pub fn runs_over_seeds(
    nominal: &Robot,
    datasets: &Path,
    case: Case,
    n: u64,
) -> Result<Vec<CaseRun>> {
    (1..=n)
        .map(|s| {
            let data = simulate_case(nominal, datasets, case, s)?;
            run_case(nominal, case, &data)
        })
        .collect()
}

/// Headline figures of a case over seeds 1..=n.
pub fn over_seeds(nominal: &Robot, datasets: &Path, case: Case, n: u64) -> Result<Vec<f64>> {
    Ok(runs_over_seeds(nominal, datasets, case, n)?
        .iter()
        .map(headline)
        .collect())
}

/// The thesis's figures (thesis notes, "The thesis's results"): (what, before, after). They
/// are means over the measurements of |difference| per coordinate (per component for
/// orientation) against the (noisy) measurements; Case B's are of real FANUC data.
pub fn thesis_figures(case: Case) -> &'static [(&'static str, f64, f64)] {
    match case {
        Case::A => &[
            ("calibration position mm", 4.0715, 0.0179),
            ("validation position mm", 4.3464, 0.0279),
        ],
        Case::BSim => &[
            ("calibration position mm", 3.2970, 0.0182),
            ("calibration orientation deg", 0.5503, 0.0039),
        ],
        Case::C => &[("validation RMS distance mm", 3.0457, 0.1079)],
        Case::D => &[
            (
                "position mm (offsets)",
                thesis::TABLE_6_6_NOMINAL.0,
                thesis::TABLE_6_6_OFFSETS.0,
            ),
            (
                "orientation deg (offsets)",
                thesis::TABLE_6_6_NOMINAL.1,
                thesis::TABLE_6_6_OFFSETS.1,
            ),
        ],
    }
}

/// The figures of a shipped run that match the thesis's: (what, ours before vs measured,
/// ours after vs measured, ours after vs truth; NaN where the thesis's protocol has none).
pub fn figures(run: &CaseRun) -> Vec<(&'static str, f64, f64, f64)> {
    // The figures of one statistics block (NaN where the rows lack them).
    let (pc, pos, rms, rot) = (
        ErrorStats::per_coordinate_mm,
        ErrorStats::position_mean_mm,
        ErrorStats::position_rms_mm,
        ErrorStats::orientation_mean_deg,
    );
    let (cb, ca, vb, va, vt) = (
        &run.calibration_before,
        &run.calibration_after,
        &run.validation_before,
        &run.validation_after,
        &run.validation_truth_after,
    );
    let na = f64::NAN;
    match run.case {
        Case::A => vec![
            (
                "calibration position, mean per coordinate mm",
                pc(cb),
                pc(ca),
                na,
            ),
            (
                "validation position, mean per coordinate mm",
                pc(vb),
                pc(va),
                pc(vt),
            ),
            (
                "validation position, mean Euclidean mm",
                pos(vb),
                pos(va),
                pos(vt),
            ),
        ],
        Case::BSim => vec![
            (
                "calibration position, mean per coordinate mm",
                pc(cb),
                pc(ca),
                na,
            ),
            (
                "calibration orientation, mean angle deg",
                rot(cb),
                rot(ca),
                na,
            ),
            (
                "validation position, mean Euclidean mm",
                pos(vb),
                pos(va),
                pos(vt),
            ),
            (
                "validation orientation, mean angle deg",
                rot(vb),
                rot(va),
                rot(vt),
            ),
        ],
        Case::C => vec![(
            "validation RMS distance error mm",
            rms(vb),
            rms(va),
            rms(vt),
        )],
        Case::D => vec![
            (
                "test position, mean per coordinate mm",
                pc(vb),
                pc(va),
                pc(vt),
            ),
            (
                "test position, mean Euclidean mm",
                pos(vb),
                pos(va),
                pos(vt),
            ),
            (
                "test orientation, mean angle deg",
                rot(vb),
                rot(va),
                rot(vt),
            ),
        ],
    }
}

/// The figures the repeated protocol reports for `case` over its runs: (what, one value per
/// run). Case D is not repeated (its shipped run is the thesis's comparison).
pub fn seed_figures(case: Case, runs: &[CaseRun]) -> Vec<(&'static str, Vec<f64>)> {
    // The figures of one statistics block (NaN where the rows lack them).
    let (pc, pos, rms) = (
        ErrorStats::per_coordinate_mm,
        ErrorStats::position_mean_mm,
        ErrorStats::position_rms_mm,
    );
    let of = |f: &dyn Fn(&CaseRun) -> f64| runs.iter().map(f).collect::<Vec<f64>>();
    match case {
        Case::A => vec![(
            "validation mean per-coordinate error vs truth mm",
            of(&|r| pc(&r.validation_truth_after)),
        )],
        Case::BSim => vec![
            (
                "variance factor (1 = noise floor)",
                of(&|r| r.variance_factor),
            ),
            (
                "validation mean position error vs truth mm",
                of(&|r| pos(&r.validation_truth_after)),
            ),
            (
                "validation mean position error vs measured mm",
                of(&|r| pos(&r.validation_after)),
            ),
            (
                "noise floor: truth vs measured mm",
                of(&|r| pos(&r.validation_noise_floor)),
            ),
        ],
        Case::C => vec![(
            "validation RMS distance error vs truth mm",
            of(&|r| rms(&r.validation_truth_after)),
        )],
        Case::D => Vec::new(),
    }
}
