//! Initial base (measurement frame) and tool estimates for data taken in an unknown frame,
//! such as a laser tracker's: rigid point-set registration, then joint identification starts
//! from there.
//!
//! With the base and tool rows as 6-DOF transforms, a measured position is
//! m_i = R_b (P_i + R_i t_t) + t_b, where (R_i, P_i) is the flange pose of row i (the model
//! with identity base and tool). Alternating, a few times:
//! 1. Kabsch/Horn: the rotation R_b and translation t_b that best map the model's tool
//!    positions P_i + R_i t_t onto the measured ones (SVD of the cross-covariance, with the
//!    determinant fixed to +1);
//! 2. with R_b fixed the model is linear in (t_t, t_b): least squares for both (when the tool
//!    is free).
//!
//! With orientations, the tool rotation is then the chordal mean of (R_b R_i)^T R_meas,i, the
//! rotation nearest (SVD projection) to their sum.

use crate::data::MeasurementSet;
use crate::error::{Error, Result};
use crate::geometry::rotation::rotation_to_zyx;
use crate::kinematics::{Pose, tool_pose};
use crate::model::ParamId;
use crate::model::{Convention, Field, Robot, Slot};
use nalgebra::{Matrix3, Matrix6, Rotation3, Vector3, Vector6};

/// What the registration found.
#[derive(Debug, Clone)]
pub struct Registration {
    /// Base transform (mm, ZYX rad) written into the model.
    pub base: Pose,
    /// Tool transform, when the tool was registered too.
    pub tool: Option<Pose>,
    /// RMS position residual after registration (mm).
    pub rms_mm: f64,
}

/// The rotation nearest to `m` (polar decomposition by SVD), with determinant +1.
pub fn nearest_rotation(m: &Matrix3<f64>) -> Rotation3<f64> {
    let svd = m.svd(true, true);
    let (u, vt) = (
        svd.u.unwrap_or_else(Matrix3::identity),
        svd.v_t.unwrap_or_else(Matrix3::identity),
    );
    let d = (u * vt).determinant().signum();
    let fix = Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, d));
    Rotation3::from_matrix_unchecked(u * fix * vt)
}

/// Kabsch: R, t minimising sum |R a_i + t - b_i|^2.
pub fn kabsch(a: &[Vector3<f64>], b: &[Vector3<f64>]) -> (Rotation3<f64>, Vector3<f64>) {
    let n = a.len() as f64;
    let ca = a.iter().sum::<Vector3<f64>>() / n;
    let cb = b.iter().sum::<Vector3<f64>>() / n;
    let h: Matrix3<f64> = a
        .iter()
        .zip(b)
        .map(|(x, y)| (y - cb) * (x - ca).transpose())
        .sum();
    let r = nearest_rotation(&h);
    (r, cb - r * ca)
}

fn set_transform(robot: &Robot, slot: Slot, p: &Pose) -> Result<Robot> {
    let t = p.translation.vector;
    let [rz, ry, rx] = rotation_to_zyx(&p.rotation);
    let values = [
        (Field::X, t.x),
        (Field::Y, t.y),
        (Field::Z, t.z),
        (Field::Rz, rz),
        (Field::Ry, ry),
        (Field::Rx, rx),
    ]
    .map(|(field, v)| (ParamId { slot, field }, v));
    robot.with_params(&values)
}

/// Least RMS distance (mm) of the measured positions from their best-fitting line for a
/// registration: a tracker measures to hundredths of a millimetre, so points a micron off one
/// line are on it.
pub const MIN_SPREAD_MM: f64 = 1e-3;

/// The scatter matrix of `points` about their centroid (mm^2): sum of (p - mean)(p - mean)^T.
fn centred_scatter(points: &[Vector3<f64>]) -> Matrix3<f64> {
    let n = points.len().max(1) as f64;
    let mean = points.iter().sum::<Vector3<f64>>() / n;
    points
        .iter()
        .map(|p| (p - mean) * (p - mean).transpose())
        .sum()
}

/// RMS distance (mm) of `points` from their best-fitting line: the square root of the sum of
/// the two smaller eigenvalues of the centred scatter matrix, over the count.
fn spread_across_line(points: &[Vector3<f64>]) -> f64 {
    if points.len() < 2 {
        return 0.0;
    }
    let mut ev: Vec<f64> = (centred_scatter(points).symmetric_eigenvalues().iter())
        .copied()
        .collect();
    ev.sort_by(|a, b| b.total_cmp(a));
    ((ev[1] + ev[2]).max(0.0) / points.len() as f64).sqrt()
}

/// RMS distance (mm) of `points` from their centroid: the square root of the centred
/// scatter's trace over the count.
fn spread_about_centre(points: &[Vector3<f64>]) -> f64 {
    (centred_scatter(points).trace() / points.len().max(1) as f64).sqrt()
}

/// The least spread (mm RMS about their centre) of the model's tool positions at which the
/// scale of the measured positions is checked ([`check_position_scale`]): closer together,
/// a tool the model lacks could change the spread by more than [`SCALE_LIMIT`].
pub const SCALE_MIN_SPREAD_MM: f64 = 100.0;

/// How many times larger or smaller the measured positions' spread may be than the model's
/// before the file is refused ([`check_position_scale`]): a frame moves and turns the points,
/// which keeps their spread, and a calibration changes it by millimetres; a long tool the
/// nominal model lacks can change it a few times over, a wrong unit by 25.4 or 1000.
pub const SCALE_LIMIT: f64 = 8.0;

/// The reach (mm) under which an arm whose tool positions barely spread is taken to be a
/// robot file in metres, where its rows spread far beyond it: the shipped FANUC in metres
/// reaches 3.87 "mm", the UR10 1.54; a pan-tilt unit 50 mm (its probe, which the model may
/// lack, can spread its rows 10 times as far).
pub const METRES_REACH_MM: f64 = 10.0;

/// How many times farther than a small arm reaches (under [`METRES_REACH_MM`]) the
/// measured positions may spread before the robot file is taken to be in metres: positions
/// spread less than the arm reaches plus the tool, so only a tool the model lacks nine times
/// longer than the arm could do it. A FANUC in metres reaches 3.87 "mm", and Case D's rows
/// spread 93 times as far (rows spread over a fraction of the reach).
pub const TINY_MODEL_RATIO: f64 = 10.0;

/// Refuses measured positions whose spread about their centre differs from the model's tool
/// positions at the same joints by more than [`SCALE_LIMIT`] times: positions in metres
/// (1/1000) or inches (1/25.4) instead of mm, which a registration and the identified
/// lengths would otherwise silently absorb (a robot a thousand times smaller). Where the
/// model's positions spread less than [`SCALE_MIN_SPREAD_MM`], only an arm that reaches less
/// than [`METRES_REACH_MM`] (but more than nothing), [`TINY_MODEL_RATIO`] times less than its
/// rows spread, is refused (a robot file in metres).
pub fn check_position_scale(robot: &Robot, set: &MeasurementSet) -> Result<()> {
    let (measured, model): (Vec<Vector3<f64>>, Vec<Vector3<f64>>) = set
        .rows
        .iter()
        .filter_map(|m| Some((m.position?, tool_pose(robot, &m.q).translation.vector)))
        .unzip();
    let (ours, theirs) = (spread_about_centre(&model), spread_about_centre(&measured));
    if measured.len() < 3 {
        return Ok(());
    }
    // A model whose tool positions spread less than [`SCALE_MIN_SPREAD_MM`] is a small arm or
    // device (a pan-tilt unit), rows that barely move its tool (a circle of joint 6 about the
    // flange), each perhaps with a probe the model lacks, or a robot file in metres: only the
    // last is an arm of more than no length that reaches less than [`METRES_REACH_MM`], with
    // rows spread [`TINY_MODEL_RATIO`] times as far.
    if ours < SCALE_MIN_SPREAD_MM {
        let reach = crate::kinematics::Reach::of(robot).bound_mm;
        let metres = reach > 1e-6 && reach < METRES_REACH_MM;
        if !metres || theirs < TINY_MODEL_RATIO * reach {
            return Ok(());
        }
        return Err(Error::Invalid(format!(
            "{}: the model's arm reaches at most {reach:.4} mm, and the measured positions \
             (columns x, y, z) spread {theirs:.1} mm RMS about their centre: is the robot \
             file in metres? Its lengths (a, d, base and tool x, y, z) must be in mm",
            set.source.display(),
        )));
    }
    let ratio = theirs / ours;
    if (1.0 / SCALE_LIMIT..=SCALE_LIMIT).contains(&ratio) {
        return Ok(());
    }
    Err(Error::Invalid(format!(
        "{}: the measured positions (columns x, y, z) spread {theirs:.4} mm RMS about their \
         centre, the model's tool positions at the same joints {ours:.1} mm: {ratio:.4} times \
         as far (positions in metres give 0.001, in inches 0.0394; a measured point that \
         stays put while the flange moves, near 0). Positions must be in mm: convert the \
         file (a profile with length_unit = \"m\" imports metres), or measure a point that \
         moves with the tool",
        set.source.display()
    )))
}

/// Registers the base (and, with `tool`, the tool) of `robot` to the positions of `set`; with
/// `orientations`, the tool's rotation to the rows' measured orientations too, else it keeps
/// `robot`'s (a position-only identification, whose data then leave it unobserved, must not
/// take it from columns it was told to ignore). The base (and tool) must be 6-DOF transform
/// rows; needs at least 3 rows with positions that are not collinear.
pub fn register(
    robot: &Robot,
    set: &MeasurementSet,
    tool: bool,
    orientations: bool,
) -> Result<(Robot, Registration)> {
    if robot.base().convention() != Convention::Transform {
        return Err(Error::Invalid(
            "registration needs a 6-DOF transform base row".into(),
        ));
    }
    let tool = tool && robot.tool().convention() == Convention::Transform;
    let rows: Vec<_> = set.rows.iter().filter(|m| m.position.is_some()).collect();
    let measured: Vec<Vector3<f64>> = rows.iter().filter_map(|m| m.position).collect();
    // Points on one line (or one point measured again and again) leave the rotation about
    // that line free: the fit would return an arbitrary base.
    let across = spread_across_line(&measured);
    if rows.len() < 3 || across < MIN_SPREAD_MM {
        return Err(Error::Invalid(format!(
            "{}: registration needs at least 3 measured positions that are not on one line \
             ({} positions, {across:.2e} mm RMS off their best line; at least {MIN_SPREAD_MM} \
             mm needed): more measurements of distinct configurations are needed",
            set.source.display(),
            rows.len()
        )));
    }
    let mut model = set_transform(robot, Slot::Base, &Pose::identity())?;
    let tool_t0 = if tool {
        model = set_transform(&model, Slot::Tool, &Pose::identity())?;
        Some(robot.tool().transform())
    } else {
        None
    };
    // Flange (or, without tool registration, tool) poses in the base frame.
    let flange: Vec<Pose> = rows.iter().map(|m| tool_pose(&model, &m.q)).collect();
    let mut t_tool = tool_t0.map_or(Vector3::zeros(), |t| t.translation.vector);
    let mut base = Pose::identity();
    for _ in 0..8 {
        let pts: Vec<Vector3<f64>> = flange
            .iter()
            .map(|f| f.translation.vector + f.rotation * t_tool)
            .collect();
        let (r, t) = kabsch(&pts, &measured);
        base = Pose::from_parts(t.into(), r);
        if !tool {
            break;
        }
        // Linear least squares for (t_tool, t_base) with R_b fixed.
        let mut a = Matrix6::<f64>::zeros();
        let mut g = Vector6::<f64>::zeros();
        for (f, m) in flange.iter().zip(&measured) {
            let rr = (r * f.rotation).into_inner();
            let mut j = nalgebra::Matrix3x6::<f64>::zeros();
            j.fixed_view_mut::<3, 3>(0, 0).copy_from(&rr);
            j.fixed_view_mut::<3, 3>(0, 3)
                .copy_from(&Matrix3::identity());
            let rhs = m - r * f.translation.vector;
            a += j.transpose() * j;
            g += j.transpose() * rhs;
        }
        match a.cholesky() {
            Some(c) => {
                let s = c.solve(&g);
                t_tool = s.fixed_rows::<3>(0).into();
            }
            None => break,
        }
    }
    let rms = (flange
        .iter()
        .zip(&measured)
        .map(|(f, m)| {
            (base.rotation * (f.translation.vector + f.rotation * t_tool) + base.translation.vector
                - m)
                .norm_squared()
        })
        .sum::<f64>()
        / measured.len() as f64)
        .sqrt();
    if !rms.is_finite() {
        return Err(Error::NotConverged(
            "registration failed: non-finite residual".into(),
        ));
    }
    let mut out = set_transform(robot, Slot::Base, &base)?;
    let mut tool_pose_out = None;
    if let Some(t0) = tool_t0 {
        let with_rot: Vec<_> = rows
            .iter()
            .zip(&flange)
            .filter(|(m, _)| orientations && m.rotation.is_some())
            .collect();
        let rot = if with_rot.is_empty() {
            t0.rotation
        } else {
            let sum: Matrix3<f64> = with_rot
                .iter()
                .filter_map(|(m, f)| {
                    m.rotation
                        .map(|rm| ((base.rotation * f.rotation).inverse() * rm).into_inner())
                })
                .sum();
            nearest_rotation(&sum)
        };
        let tp = Pose::from_parts(t_tool.into(), rot);
        out = set_transform(&out, Slot::Tool, &tp)?;
        tool_pose_out = Some(tp);
    }
    Ok((
        out,
        Registration {
            base,
            tool: tool_pose_out,
            rms_mm: rms,
        },
    ))
}
