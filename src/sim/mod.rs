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
use rand_distr::{Distribution, Normal};
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

/// A simulation run.
#[derive(Debug, Clone)]
pub struct Simulation<'a> {
    /// The true robot (nominal model plus deviations).
    pub truth: &'a Robot,
    /// Non-geometric errors of the true robot (compliance, gears, backlash).
    pub nongeometric: &'a NonGeometric,
    /// Joint ranges the configurations are drawn from (rad or mm).
    pub region: &'a Region,
    /// Number of configurations (rows) to simulate.
    pub count: usize,
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
    /// Draws the configurations (uniform in the region), applies the non-geometric joint
    /// deflections, runs the true model's FK, and adds noise. Configurations and noise come
    /// from separate streams of one seed, so changing the noise leaves the configurations.
    /// [`Simulation::run`] row by row: `emit(measured, truth)` for each configuration in
    /// order, nothing kept (the same rows as `run`, from the same streams).
    pub fn run_each(
        &self,
        mut emit: impl FnMut(Measurement, Measurement) -> Result<()>,
    ) -> Result<()> {
        let robot = self.truth;
        let n = robot.dof();
        if self.region.0.len() != n {
            return Err(Error::Invalid("region does not match the robot".into()));
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
        let unit = Normal::new(0.0, 1.0).map_err(|e| Error::Invalid(e.to_string()))?;
        let mut ws = Frames::new(robot);
        let mut previous = vec![0.0; n];
        for k in 0..self.count {
            // Configurations and noise come from separate streams: drawing them in turn
            // gives the rows drawing all configurations first gave.
            let q: Vec<f64> = self
                .region
                .0
                .iter()
                .map(|&[lo, hi]| {
                    if lo < hi {
                        rng_q.random_range(lo..hi)
                    } else {
                        lo
                    }
                })
                .collect();
            let pose = actual_pose(robot, self.nongeometric, &q, &previous, &mut ws);
            let mut draw3 = |s: f64| {
                Vector3::new(
                    unit.sample(&mut rng_noise),
                    unit.sample(&mut rng_noise),
                    unit.sample(&mut rng_noise),
                ) * s
            };
            let np = draw3(self.sigma_position_mm);
            let nr = draw3(self.sigma_rotation_rad);
            let mut t = Measurement::new(q.clone());
            t.id = Some((k + 1).to_string());
            let mut m = t.clone();
            if self.observe != Observe::Orientation {
                t.position = Some(pose.translation.vector);
                m.position = Some(pose.translation.vector + np);
                if self.sigma_position_mm > 0.0 {
                    m.sigma_position = Some(Vector3::repeat(self.sigma_position_mm));
                }
            }
            if self.observe != Observe::Position {
                t.rotation = Some(pose.rotation);
                m.rotation = Some(from_rotation_vector(&nr) * pose.rotation);
                if self.sigma_rotation_rad > 0.0 {
                    m.sigma_rotation = Some(Vector3::repeat(self.sigma_rotation_rad));
                }
            }
            previous = q.clone();
            // The bound a measurement file's positions have: the data must read back.
            let far = crate::model::MAX_LENGTH_MM;
            if pose.translation.vector.iter().any(|v| v.abs() > far) {
                return Err(Error::Invalid(format!(
                    "configuration {}: the simulated tool lies beyond {far} mm, the bound of a \
                     measured position",
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
        let mut measured = Vec::with_capacity(self.count);
        let mut truth = Vec::with_capacity(self.count);
        self.run_each(|m, t| {
            measured.push(m);
            truth.push(t);
            Ok(())
        })?;
        let set = |rows| MeasurementSet {
            source: source.clone(),
            rows,
            extra_columns: Vec::new(),
        };
        Ok(SimOutput {
            measured: set(measured),
            truth: set(truth),
        })
    }
}
