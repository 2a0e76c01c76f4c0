//! What a compensator's network is trained on: for a model, a measurement set, a form and an
//! encoding, the normalised inputs, the unit-scale targets (and maps) and both normalisations.
//!
//! The model's error of row k is e_k = [dp; dr]: measured minus model position (mm) and the
//! rotation vector of R_measured R_model^T (rad). Residual components are weighted by
//! W = diag(1/s_p, 1/s_p, 1/s_p, 1/s_r, 1/s_r, 1/s_r), s_p and s_r the RMS of the model's
//! position and orientation error components over the set: position errors count as a
//! Euclidean distance, orientation errors as an angle, and both kinds weigh alike. (The
//! tracker's own sigmas are far below what a kinematic model misses, so weighting by them would
//! favour arbitrary directions.)
//!
//! - Pose form: targets are W e_k expressed in the robot's base frame (where gravity acts),
//!   centred; the network's outputs are dp (mm) and dr (mrad) in that frame.
//! - Joint form: the network gives joint corrections dq = C y (C = diag(c_j)), seen through
//!   the model's joint Jacobian: r_k = W e_k - W J(q_k) C y(x_k); c_j is the correction joint
//!   j alone would need, sqrt(sum_k |W e_k|^2 / sum_k |W J_k e_j|^2).

use super::encoding::Encoding;
use super::samples::Samples;
use super::settings::Form;
use super::weights::Affine;
use crate::data::{Measurement, MeasurementSet};
use crate::error::{Error, Location, Result};
use crate::geometry::rotation::rotation_vector;
use crate::kinematics::{Frames, frames, joint_jacobian};
use crate::model::Robot;
use nalgebra::{DMatrix, Matrix3, Matrix6xX, Vector3};

/// A network's training problem.
#[derive(Debug, Clone)]
pub struct Problem {
    /// Normalised inputs, unit-scale targets, maps (joint form) and configuration groups.
    pub samples: Samples,
    /// Standardisation of the encoded input features.
    pub input_norm: Affine,
    /// Map from unit-scale outputs to raw outputs: pose form dp (mm), dr (mrad); joint form
    /// dq (mrad, or um for prismatic joints).
    pub output_norm: Affine,
}

/// The rotation of the robot's base row: world (measurement) frame from robot base frame.
pub fn base_rotation(robot: &Robot) -> Matrix3<f64> {
    *robot.base().transform().rotation.matrix()
}

/// The model's error at one measured row: position (mm) and, when the row has an orientation,
/// rotation vector (rad), both in the world frame. None without a position.
pub fn model_error(
    robot: &Robot,
    m: &Measurement,
    ws: &mut Frames,
) -> Option<(Vector3<f64>, Option<Vector3<f64>>)> {
    frames(robot, &m.q, ws);
    let t = &ws.tool;
    let dp = m.position? - t.translation.vector;
    let dr = m
        .rotation
        .map(|r| rotation_vector(&(r * t.rotation.inverse())));
    Some((dp, dr))
}

/// The standardised network inputs of every row, the standardisation fitted on them (each
/// scale at least its floor, [`Encoding::scale_floors`]), and each input's resolution in
/// standardised units (its floor over its scale, [`Samples::resolution`]).
fn inputs(
    robot: &Robot,
    set: &MeasurementSet,
    encoding: Encoding,
) -> (Vec<Vec<f64>>, Affine, Vec<f64>) {
    let mut ws = Frames::new(robot);
    let mut xs: Vec<Vec<f64>> = set
        .rows
        .iter()
        .map(|m| {
            let mut feat = Vec::new();
            encoding.features(robot, &m.q, &mut ws, &mut feat);
            feat
        })
        .collect();
    let floors = encoding.scale_floors(robot);
    let norm = Affine::standardise(&xs).floored(&floors);
    let resolution = (floors.iter().zip(&norm.scale))
        .map(|(floor, scale)| (floor / scale).min(1.0))
        .collect();
    let mut scaled = Vec::new();
    for x in xs.iter_mut() {
        scaled.resize(x.len(), 0.0);
        norm.apply(x, &mut scaled);
        x.copy_from_slice(&scaled);
    }
    (xs, norm, resolution)
}

/// The least RMS position error (mm) the outputs are scaled by: a nanometre, below any
/// measurement; a model that misses by less leaves nothing to learn.
const POSITION_SCALE_FLOOR_MM: f64 = 1e-6;
/// The least RMS orientation error (rad) the outputs are scaled by.
const ROTATION_SCALE_FLOOR_RAD: f64 = 1e-9;
/// The least joint correction (rad; mm for a prismatic joint) a joint-form output is scaled
/// by.
const JOINT_SCALE_FLOOR: f64 = 1e-9;

/// Refuses a set with a row that has no measured position, naming the first such row's line
/// and its `x` column: training learns the position error of every row.
pub fn check_positions(set: &MeasurementSet) -> Result<()> {
    match set.rows.iter().find(|m| m.position.is_none()) {
        Some(m) => Err(Error::input(
            Location::at(&set.source, m.line, "x"),
            "training needs a measured position in every row",
        )),
        None => Ok(()),
    }
}

/// Builds the training problem of `form` for `robot` on `set`.
pub fn build(
    robot: &Robot,
    set: &MeasurementSet,
    form: Form,
    encoding: Encoding,
) -> Result<Problem> {
    let kinds = set.rows.iter().map(|m| m.rotation.is_some());
    if kinds.clone().any(|k| k) && kinds.clone().any(|k| !k) {
        return Err(Error::Invalid(format!(
            "{}: some rows have orientations and some not",
            set.source.display()
        )));
    }
    check_positions(set)?;
    let mut ws = Frames::new(robot);
    let mut errors = Vec::with_capacity(set.rows.len());
    for m in &set.rows {
        // (Every row has a position: checked above.)
        errors.extend(model_error(robot, m, &mut ws));
    }
    let rms = |v: &mut dyn Iterator<Item = Vector3<f64>>| {
        let (sum, n) = v.fold((0.0, 0usize), |(s, n), e| (s + e.norm_squared(), n + 3));
        (sum / n.max(1) as f64).sqrt()
    };
    let s_p = rms(&mut errors.iter().map(|e| e.0));
    let with_rotation = errors.first().is_some_and(|e| e.1.is_some());
    let s_r = rms(&mut errors.iter().filter_map(|e| e.1));
    if !(s_p > 0.0 && s_p.is_finite()) || (with_rotation && !(s_r > 0.0 && s_r.is_finite())) {
        return Err(Error::Invalid(format!(
            "{}: the model fits every row exactly (or not at all: RMS error {s_p} mm, {s_r} rad); \
             there is nothing to train on",
            set.source.display()
        )));
    }
    // A model refined on noise-free data misses by rounding alone (1e-11 mm): scaled by
    // that, the normalisation could not be stored (nor would the network learn anything).
    let (s_p, s_r) = (
        s_p.max(POSITION_SCALE_FLOOR_MM),
        s_r.max(ROTATION_SCALE_FLOOR_RAD),
    );
    let rows = if with_rotation { 6 } else { 3 };
    // W e_k, world frame.
    let weighted: Vec<Vec<f64>> = errors
        .iter()
        .map(|(dp, dr)| {
            let mut v: Vec<f64> = (dp / s_p).iter().copied().collect();
            if let Some(r) = dr {
                v.extend((r / s_r).iter());
            }
            v
        })
        .collect();
    let (x, input_norm, resolution) = inputs(robot, set, encoding);
    let groups = super::repeats::configuration_groups(robot, set);
    let (samples, output_norm) = match form {
        Form::Pose => {
            let rb = base_rotation(robot).transpose();
            let local: Vec<Vec<f64>> = weighted
                .iter()
                .map(|v| {
                    let mut out = Vec::with_capacity(rows);
                    for block in v.chunks(3) {
                        out.extend((rb * Vector3::from_column_slice(block)).iter());
                    }
                    out
                })
                .collect();
            let centre = Affine::standardise(&local).offset;
            let b = local
                .iter()
                .map(|v| v.iter().zip(&centre).map(|(a, c)| a - c).collect())
                .collect();
            // Raw outputs: mm and mrad, y_raw = (y + centre) s.
            let unit = |r: usize| if r < 3 { s_p } else { s_r * 1e3 };
            let norm = Affine {
                offset: (0..rows).map(|r| centre[r] * unit(r)).collect(),
                scale: (0..rows).map(unit).collect(),
            };
            (
                Samples {
                    x,
                    b,
                    maps: None,
                    groups,
                    resolution,
                },
                norm,
            )
        }
        Form::Joint => {
            let n = robot.dof();
            let mut jac = Matrix6xX::zeros(n);
            let mut maps: Vec<DMatrix<f64>> = Vec::with_capacity(set.rows.len());
            for m in &set.rows {
                frames(robot, &m.q, &mut ws);
                joint_jacobian(robot, &ws, &mut jac);
                maps.push(DMatrix::from_fn(rows, n, |r, c| {
                    jac[(r, c)] / if r < 3 { s_p } else { s_r }
                }));
            }
            let total: f64 = weighted.iter().flatten().map(|v| v * v).sum();
            let scale: Vec<f64> = (0..n)
                .map(|j| {
                    let col: f64 = maps.iter().map(|a| a.column(j).norm_squared()).sum();
                    if col > 0.0 {
                        (total / col).sqrt().max(JOINT_SCALE_FLOOR)
                    } else {
                        1.0
                    }
                })
                .collect();
            for a in maps.iter_mut() {
                for (j, s) in scale.iter().enumerate() {
                    a.column_mut(j).scale_mut(*s);
                }
            }
            // Raw outputs in mrad (um for prismatic joints).
            let norm = Affine::scaling(scale.iter().map(|s| s * 1e3).collect());
            (
                Samples {
                    x,
                    b: weighted,
                    maps: Some(maps),
                    groups,
                    resolution,
                },
                norm,
            )
        }
    };
    Ok(Problem {
        samples,
        input_norm,
        output_norm,
    })
}
