//! The virtual robot (thesis 5.2, 6.2): a true model (nominal + deviations) with non-geometric
//! errors, measured at random configurations with Gaussian noise.

pub mod deviations;
pub mod nongeometric;

pub use deviations::Deviations;
pub use nongeometric::NonGeometric;

use crate::data::measurement::Layout;
use crate::data::{Measurement, MeasurementSet};
use crate::error::{Error, Location, Result};
use crate::geometry::rotation::from_rotation_vector;
use crate::kinematics::{Frames, Pose, tool_pose};
use crate::model::Robot;
use nalgebra::Vector3;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use serde::Deserialize;
use std::path::{Path, PathBuf};

/// What the virtual sensor reports.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Observe {
    /// Position and orientation.
    Pose,
    /// Position only.
    Position,
    /// Orientation only.
    Orientation,
}

/// Joint ranges to draw configurations from, in internal units (rad or mm).
#[derive(Debug, Clone, PartialEq)]
pub struct Region(pub Vec<[f64; 2]>);

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RegionFile {
    /// Kept with their spans: a message names the line of the range at fault.
    ranges: toml::Spanned<Vec<toml::Spanned<Vec<f64>>>>,
}

impl Region {
    /// The robot's joint limits.
    pub fn limits(robot: &Robot) -> Self {
        Region(robot.joints().iter().map(|j| j.limits_internal()).collect())
    }

    /// Reads a region file: `ranges = [[min, max], ...]`, one per joint, deg (mm for
    /// prismatic joints). Each range must lie within the joint's limits.
    pub fn read(path: impl AsRef<Path>, robot: &Robot) -> Result<Self> {
        let path = path.as_ref();
        let text = crate::io::read_text(path)?;
        let f: RegionFile = crate::io::parse_toml(&text, path)?;
        let line = |at: usize| crate::io::line_of(&text, at);
        let bad = |at: usize, m: String| Error::input(Location::at(path, line(at), "ranges"), m);
        let ranges = f.ranges.get_ref();
        if ranges.len() != robot.dof() {
            return Err(bad(
                f.ranges.span().start,
                format!(
                    "{} ranges for a robot with {} joints",
                    ranges.len(),
                    robot.dof()
                ),
            ));
        }
        let mut out = Vec::with_capacity(ranges.len());
        for (i, (r, j)) in ranges.iter().zip(robot.joints()).enumerate() {
            let at = r.span().start;
            let &[lo, hi] = r.get_ref().as_slice() else {
                return Err(bad(
                    at,
                    format!(
                        "joint {}: a range is [min, max], 2 numbers (got {})",
                        i + 1,
                        r.get_ref().len()
                    ),
                ));
            };
            if !(lo.is_finite() && hi.is_finite())
                || lo > hi
                || lo < j.limits[0]
                || hi > j.limits[1]
            {
                return Err(bad(
                    at,
                    format!(
                        "joint {}: range [{lo}, {hi}] must be ordered and within the limits [{}, {}]",
                        i + 1,
                        j.limits[0],
                        j.limits[1]
                    ),
                ));
            }
            out.push([lo, hi].map(|v| j.joint_type.to_internal(v)));
        }
        Ok(Region(out))
    }
}

/// The true robot's tool pose (mm) at commanded joints `q` (rad, mm) approached from
/// `previous`: the non-geometric joint deflections, then the true model's FK.
pub fn actual_pose(
    truth: &Robot,
    nongeometric: &NonGeometric,
    q: &[f64],
    previous: &[f64],
    ws: &mut Frames,
) -> Pose {
    let mut dq = vec![0.0; q.len()];
    nongeometric.deflection(truth, q, previous, ws, &mut dq);
    let actual: Vec<f64> = q.iter().zip(&dq).map(|(a, b)| a + b).collect();
    tool_pose(truth, &actual)
}

/// What the virtual sensor reports of the true tool `pose` at joints `q`: the measured row
/// (position plus Gaussian noise of `sigma_position_mm` per coordinate, orientation turned by
/// a rotation vector of `sigma_rotation_rad` per component, with those sigmas) and the
/// noise-free row, as `observe` says. Six standard normal draws from `rng` every time (three
/// for position, then three for rotation), whatever is observed, so that the stream stays
/// aligned with the rows.
pub fn reading(
    pose: &Pose,
    q: &[f64],
    observe: Observe,
    sigma_position_mm: f64,
    sigma_rotation_rad: f64,
    rng: &mut impl Rng,
) -> (Measurement, Measurement) {
    let mut draw3 = |s: f64| {
        let mut z = || -> f64 { StandardNormal.sample(&mut *rng) };
        Vector3::new(z(), z(), z()) * s
    };
    let np = draw3(sigma_position_mm);
    let nr = draw3(sigma_rotation_rad);
    let mut t = Measurement::new(q.to_vec());
    let mut m = t.clone();
    if observe != Observe::Orientation {
        t.position = Some(pose.translation.vector);
        m.position = Some(pose.translation.vector + np);
        if sigma_position_mm > 0.0 {
            m.sigma_position = Some(Vector3::repeat(sigma_position_mm));
        }
    }
    if observe != Observe::Position {
        t.rotation = Some(pose.rotation);
        m.rotation = Some(from_rotation_vector(&nr) * pose.rotation);
        if sigma_rotation_rad > 0.0 {
            m.sigma_rotation = Some(Vector3::repeat(sigma_rotation_rad));
        }
    }
    (m, t)
}

/// Where the virtual robot is measured.
#[derive(Debug, Clone, Copy)]
pub enum Configurations<'a> {
    /// `count` configurations drawn uniformly in `region` (rad or mm).
    Drawn {
        /// Joint ranges the configurations are drawn from (rad or mm).
        region: &'a Region,
        /// Number of configurations (rows) to simulate.
        count: usize,
    },
    /// The given configurations, in their order (rad or mm, one value per joint): a
    /// measurement plan rehearsed, the robot approaching each from the one before (backlash).
    Given(&'a [Vec<f64>]),
}

impl Configurations<'_> {
    /// Number of configurations (rows) to simulate.
    pub fn count(&self) -> usize {
        match self {
            Configurations::Drawn { count, .. } => *count,
            Configurations::Given(q) => q.len(),
        }
    }
}

/// A simulation run.
#[derive(Debug, Clone)]
pub struct Simulation<'a> {
    /// The true robot (nominal model plus deviations).
    pub truth: &'a Robot,
    /// Non-geometric errors of the true robot (compliance, gears, backlash).
    pub nongeometric: &'a NonGeometric,
    /// Where the robot is measured: drawn configurations or given ones.
    pub configurations: Configurations<'a>,
    /// Seed of the configuration and noise streams.
    pub seed: u64,
    /// Noise on each position coordinate (mm).
    pub sigma_position_mm: f64,
    /// Noise on each rotation-vector component (rad).
    pub sigma_rotation_rad: f64,
    /// What the virtual sensor reports.
    pub observe: Observe,
}

/// Measured rows and their noise-free truth (same configurations, same order).
#[derive(Debug, Clone)]
pub struct SimOutput {
    /// The rows as the sensor reports them: true pose plus noise, with their sigmas.
    pub measured: MeasurementSet,
    /// The noise-free poses of the true robot.
    pub truth: MeasurementSet,
}

impl Simulation<'_> {
    /// Draws the configurations (uniform in the region) or takes the given ones, applies the
    /// non-geometric joint deflections, runs the true model's FK, and adds noise.
    /// Configurations and noise come from separate streams of one seed, so changing the noise
    /// leaves the configurations. Rows are numbered 1, 2, ... in their `id`.
    /// [`Simulation::run`] row by row: `emit(measured, truth)` for each configuration in
    /// order, nothing kept (the same rows as `run`, from the same streams).
    pub fn run_each(
        &self,
        mut emit: impl FnMut(Measurement, Measurement) -> Result<()>,
    ) -> Result<()> {
        let robot = self.truth;
        let n = robot.dof();
        // Built in code, the errors meet the checks a file's reader makes (a gear of joint 0
        // indexed out of bounds; a NaN amplitude gave NaN poses).
        self.nongeometric
            .check(robot)
            .map_err(|f| Error::Invalid(format!("non-geometric errors: {}: {f}", f.key)))?;
        match self.configurations {
            Configurations::Drawn { region, .. } if region.0.len() != n => {
                return Err(Error::Invalid("region does not match the robot".into()));
            }
            Configurations::Drawn { region, .. } => {
                if let Some(j) = (region.0.iter())
                    .position(|&[lo, hi]| !(lo.is_finite() && hi.is_finite() && lo <= hi))
                {
                    return Err(Error::Invalid(format!(
                        "region: joint {}: range {:?} must be finite and ordered",
                        j + 1,
                        region.0[j]
                    )));
                }
            }
            Configurations::Given(given) => {
                if let Some(k) = given.iter().position(|q| q.len() != n) {
                    return Err(Error::Invalid(format!(
                        "configuration {}: {} joint values for a robot with {n} joints",
                        k + 1,
                        given[k].len()
                    )));
                }
                if let Some(k) = given.iter().position(|q| q.iter().any(|v| !v.is_finite())) {
                    return Err(Error::Invalid(format!(
                        "configuration {}: a joint value is not finite",
                        k + 1
                    )));
                }
            }
        }
        for s in [self.sigma_position_mm, self.sigma_rotation_rad] {
            if !s.is_finite() || s < 0.0 {
                return Err(Error::Invalid(format!(
                    "noise sigma {s} must be finite and >= 0"
                )));
            }
        }
        let mut rng_q = ChaCha8Rng::seed_from_u64(self.seed);
        let mut rng_noise = ChaCha8Rng::seed_from_u64(self.seed);
        rng_noise.set_stream(1);
        let mut ws = Frames::new(robot);
        let mut previous = vec![0.0; n];
        for k in 0..self.configurations.count() {
            // Configurations and noise come from separate streams: drawing them in turn
            // gives the rows drawing all configurations first gave.
            let q: Vec<f64> = match self.configurations {
                Configurations::Drawn { region, .. } => (region.0.iter())
                    .map(|&[lo, hi]| {
                        if lo < hi {
                            rng_q.random_range(lo..hi)
                        } else {
                            lo
                        }
                    })
                    .collect(),
                Configurations::Given(given) => given[k].clone(),
            };
            let pose = actual_pose(robot, self.nongeometric, &q, &previous, &mut ws);
            let (mut m, mut t) = reading(
                &pose,
                &q,
                self.observe,
                self.sigma_position_mm,
                self.sigma_rotation_rad,
                &mut rng_noise,
            );
            t.id = Some((k + 1).to_string());
            m.id = t.id.clone();
            previous = q.clone();
            // The bound a measurement file's positions have: the data must read back.
            let far = crate::model::MAX_LENGTH_MM;
            if pose
                .translation
                .vector
                .iter()
                .any(|v| !v.is_finite() || v.abs() > far)
            {
                return Err(Error::Invalid(format!(
                    "configuration {}: the simulated tool is not finite or lies beyond {far} \
                     mm, the bound of a measured position",
                    k + 1
                )));
            }
            emit(m, t)?;
        }
        Ok(())
    }

    /// The columns of the measured and the true rows [`Simulation::run_each`] gives.
    pub fn layouts(&self) -> (Layout, Layout) {
        let pos = self.observe != Observe::Orientation;
        let rot = self.observe != Observe::Position;
        let truth = Layout {
            id: true,
            position: pos,
            rotation: rot,
            ..Layout::default()
        };
        let measured = Layout {
            sigma_position: pos && self.sigma_position_mm > 0.0,
            sigma_rotation: rot && self.sigma_rotation_rad > 0.0,
            ..truth.clone()
        };
        (measured, truth)
    }

    /// All rows of [`Simulation::run_each`] in memory, both sets naming `source` as their
    /// file.
    pub fn run(&self, source: PathBuf) -> Result<SimOutput> {
        let mut measured = Vec::with_capacity(self.configurations.count());
        let mut truth = Vec::with_capacity(self.configurations.count());
        self.run_each(|m, t| {
            measured.push(m);
            truth.push(t);
            Ok(())
        })?;
        let set = |rows| MeasurementSet {
            source: source.clone(),
            rows,
            extra_columns: Vec::new(),
            chain_breaks: Vec::new(),
            other_case_pair_columns: [None, None],
        };
        Ok(SimOutput {
            measured: set(measured),
            truth: set(truth),
        })
    }
}
