//! Does planning pay? Planned against random configurations on simulated robots, over seeds.
//!
//! Per seed: a pool of candidates drawn uniformly within the joint limits, a validation cloud
//! of other configurations, N units planned from the pool and the pool's first
//! units as the random choice (the pool is already a uniform draw). The true robot is
//! measured at both with the thesis's noise (0.033 mm, 0.174 mrad), `full` is identified from
//! each, and the error is the mean tool position error against the truth over the cloud. The
//! prediction is [`crate::plan::predict()`]'s mean for the same units, made before measuring.

use crate::data::MeasurementSet;
use crate::error::Result;
use crate::identify::problem::{Measure, Sigmas};
use crate::identify::{Options, identify};
use crate::kinematics::{Frames, Pose, tool_pose};
use crate::model::Robot;
use crate::plan::{Constraints, Criterion, Design, choose, pool, predict};
use crate::sim::{NonGeometric, Observe, Region, actual_pose, reading};
use crate::stats::median;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use std::path::Path;

/// The simulated robot: its nominal model, its truth and its non-geometric errors.
#[derive(Debug, Clone)]
pub struct Case {
    /// What the rows of the report call it.
    pub name: String,
    /// The model identified (and planned with).
    pub nominal: Robot,
    /// The true robot's geometry.
    pub truth: Robot,
    /// Its errors beyond geometry (none for a complete model).
    pub nongeometric: NonGeometric,
}

impl Case {
    /// The FANUC with thesis Table 6.1's deviations (a model that is complete), from the
    /// repository's `datasets` folder.
    pub fn table_6_1(datasets: &Path) -> Result<Case> {
        let nominal = super::thesis::fanuc(datasets)?;
        let truth =
            crate::sim::Deviations::read(datasets.join("deviations/table_6_1.toml"), &nominal)?
                .apply(&nominal)?;
        Ok(Case {
            name: "Table 6.1".into(),
            nominal,
            truth,
            nongeometric: NonGeometric::default(),
        })
    }

    /// The shipped non-geometric robot: its true geometry, gravity compliance and gear
    /// errors, which `full` cannot represent.
    pub fn nongeometric(datasets: &Path) -> Result<Case> {
        let nominal = super::thesis::fanuc(datasets)?;
        let truth = crate::model::read_robot(datasets.join("nongeometric_robot/true_robot.toml"))?;
        let nongeometric = NonGeometric::read(
            datasets.join("nongeometric/fanuc_compliance_gear.toml"),
            &truth,
        )?;
        Ok(Case {
            name: "non-geometric".into(),
            nominal,
            truth,
            nongeometric,
        })
    }
}

/// How the study runs.
#[derive(Debug, Clone)]
pub struct Setup {
    /// Seeds (each a pool, a cloud, a noise draw).
    pub seeds: usize,
    /// Candidate units per pool.
    pub pool: usize,
    /// Validation configurations per seed.
    pub cloud: usize,
    /// Numbers of units planned.
    pub planned: Vec<usize>,
    /// Numbers of random units tried (the first of each pool), to find where random matches
    /// planned.
    pub random: Vec<usize>,
    /// How the robot is measured: pose or position.
    pub measure: Measure,
    /// What the plan maximises.
    pub criterion: Criterion,
}

/// The errors of one number of units over the seeds.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Series {
    /// Units.
    pub units: usize,
    /// Realised mean position error against the truth (mm), per seed.
    pub realised: Vec<f64>,
    /// Predicted mean position error (mm), per seed.
    pub predicted: Vec<f64>,
}

impl Series {
    fn new(units: usize) -> Self {
        Series {
            units,
            realised: Vec::new(),
            predicted: Vec::new(),
        }
    }
}

/// Planned and random, per number of units.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Outcome {
    /// Per entry of [`Setup::planned`].
    pub planned: Vec<Series>,
    /// Per entry of [`Setup::random`].
    pub random: Vec<Series>,
}

/// The smallest and the largest of `v` (mm): the range over the seeds.
pub fn range(v: &[f64]) -> (f64, f64) {
    (
        v.iter().copied().fold(f64::INFINITY, f64::min),
        v.iter().copied().fold(f64::NEG_INFINITY, f64::max),
    )
}

/// The header of [`Outcome::table_row`]'s table (Markdown).
pub const TABLE_HEADER: &str = "| robot | measure | planned N=20: median (range) mm | predicted | random N=20: median (range) | predicted | planned lower by | random N matching planned N=20 |\n|---|---|---|---|---|---|---|---|";

impl Outcome {
    /// The Markdown row of planned against random at 20 units (mean position error against
    /// the truth, mm: median and range over the seeds, median prediction), how much lower
    /// planned is, and the number of random units that matches it; None without both series
    /// at 20.
    pub fn table_row(&self, robot: &str, measure: &str) -> Option<String> {
        let (p, r) = (self.planned_at(20)?, self.random_at(20)?);
        let range = |v: &[f64]| {
            let (lo, hi) = range(v);
            format!("{lo:.4}-{hi:.4}")
        };
        Some(format!(
            "| {robot} | {measure} | {:.4} ({}) | {:.4} | {:.4} ({}) | {:.4} | {:.1}% | {} |",
            median(&p.realised),
            range(&p.realised),
            median(&p.predicted),
            median(&r.realised),
            range(&r.realised),
            median(&r.predicted),
            100.0 * (1.0 - median(&p.realised) / median(&r.realised)),
            match (self.random_matching(20), self.random.first()) {
                (None, _) => "beyond the largest tried".to_string(),
                // Already the fewest tried: not an interpolation.
                (Some(n), Some(first)) if n == first.units as f64 => format!("<= {n:.0}"),
                (Some(n), _) => format!("{n:.0}"),
            },
        ))
    }

    /// The planned series of `units`.
    pub fn planned_at(&self, units: usize) -> Option<&Series> {
        self.planned.iter().find(|s| s.units == units)
    }

    /// The random series of `units`.
    pub fn random_at(&self, units: usize) -> Option<&Series> {
        self.random.iter().find(|s| s.units == units)
    }

    /// The number of random units whose median error equals the median of `units` planned
    /// ones, linearly interpolated between the numbers tried; None when no number tried
    /// reaches it.
    pub fn random_matching(&self, units: usize) -> Option<f64> {
        let target = median(&self.planned_at(units)?.realised);
        let meds: Vec<(usize, f64)> = self
            .random
            .iter()
            .map(|s| (s.units, median(&s.realised)))
            .collect();
        if meds.first().is_some_and(|(_, e)| *e <= target) {
            return Some(meds[0].0 as f64);
        }
        meds.windows(2).find_map(|w| {
            let ((n0, e0), (n1, e1)) = (w[0], w[1]);
            (e1 <= target).then(|| n0 as f64 + (e0 - target) / (e0 - e1) * (n1 - n0) as f64)
        })
    }
}

/// The true tool poses at `qs` (rad, mm), approached in order, as the virtual sensor reports
/// them with the thesis's noise (seeded by `rng`); position only for `Measure::Position`.
fn measure(case: &Case, qs: &[Vec<f64>], measure: Measure, rng: &mut ChaCha8Rng) -> MeasurementSet {
    let s = Sigmas::default();
    let observe = match measure {
        Measure::Position => Observe::Position,
        _ => Observe::Pose,
    };
    let mut ws = Frames::new(&case.truth);
    let mut previous = vec![0.0; case.truth.dof()];
    let rows = qs
        .iter()
        .map(|q| {
            let pose = actual_pose(&case.truth, &case.nongeometric, q, &previous, &mut ws);
            previous = q.clone();
            reading(&pose, q, observe, s.position_mm, s.rotation_rad, rng).0
        })
        .collect();
    MeasurementSet::from_rows(rows)
}

/// Mean position error (mm) of `model` against the `truth` poses at `cloud`.
fn error(model: &Robot, cloud: &[Vec<f64>], truth: &[Pose]) -> f64 {
    cloud
        .iter()
        .zip(truth)
        .map(|(q, t)| (tool_pose(model, q).translation.vector - t.translation.vector).norm())
        .sum::<f64>()
        / cloud.len() as f64
}

/// Runs the study on `case`; `progress` is told each finished seed.
pub fn run(case: &Case, setup: &Setup, progress: &mut dyn FnMut(usize)) -> Result<Outcome> {
    let nominal = &case.nominal;
    let region = Region::limits(nominal);
    let free = Constraints::default();
    let mut out = Outcome {
        planned: setup.planned.iter().map(|&n| Series::new(n)).collect(),
        random: setup.random.iter().map(|&n| Series::new(n)).collect(),
    };
    let largest = setup.random.iter().copied().max().unwrap_or(0);
    for seed in 0..setup.seeds as u64 {
        let pool = pool::draw(
            nominal,
            &region,
            &free,
            setup.pool.max(largest),
            1,
            1000 + seed,
        )?;
        let cloud =
            pool::draw(nominal, &region, &free, setup.cloud, 1, 5000 + seed)?.into_configurations();
        let mut ws = Frames::new(&case.truth);
        let truth: Vec<Pose> = cloud
            .iter()
            .map(|q| actual_pose(&case.truth, &case.nongeometric, q, q, &mut ws))
            .collect();
        let design = Design::new(
            nominal,
            "full",
            setup.measure,
            Sigmas::default(),
            &pool,
            cloud.clone(),
            crate::identify::identifiability::RANK_TOL,
        )?;
        // Each choice's noise from its own stream of the seed (planned or random, and its
        // number of units): a study that tries other numbers draws the same noise for these.
        let noise = |random: bool, units: usize| {
            let mut rng = ChaCha8Rng::seed_from_u64(9000 + seed);
            rng.set_stream(2 * units as u64 + u64::from(random));
            rng
        };
        let opts = Options {
            params: "full".into(),
            measure: Some(setup.measure),
            ..Default::default()
        };
        let realise = |units: &[usize], rng: &mut ChaCha8Rng| -> Result<f64> {
            let qs: Vec<Vec<f64>> = units.iter().map(|&u| pool.units[u][0].clone()).collect();
            let set = measure(case, &qs, setup.measure, rng);
            Ok(error(
                &identify(nominal, &set, &opts)?.robot,
                &cloud,
                &truth,
            ))
        };
        for series in out.planned.iter_mut() {
            let chosen = choose(&design, series.units, setup.criterion, &[])?;
            series
                .realised
                .push(realise(&chosen.units, &mut noise(false, series.units))?);
            series.predicted.push(
                predict(&design, &chosen.units, seed)
                    .and_then(|p| p.position_mm)
                    .map_or(f64::NAN, |s| s.mean),
            );
        }
        for series in out.random.iter_mut() {
            let units: Vec<usize> = (0..series.units).collect();
            series
                .realised
                .push(realise(&units, &mut noise(true, series.units))?);
            series.predicted.push(
                predict(&design, &units, seed)
                    .and_then(|p| p.position_mm)
                    .map_or(f64::NAN, |s| s.mean),
            );
        }
        progress(seed as usize + 1);
    }
    Ok(out)
}
