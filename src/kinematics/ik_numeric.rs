//! Numerical inverse kinematics for any model (calibrated ones have no closed form):
//! Levenberg-Marquardt on the pose error, seeded from a given joint vector.
//!
//! Residual: e = [p_target - p(q); L * rotvec(R_target R(q)^T)] (mm), with L a length (mm per
//! rad) that puts orientation on the scale of position. Step: (J^T J + lambda diag(J^T J))
//! dq = J^T e with J the geometric Jacobian (orientation rows scaled by L). A solve either
//! meets both tolerances or returns [`Error::NotConverged`] with the error it reached; but an
//! arm of fewer than six joints, which cannot turn its tool about every axis, meets the
//! position and leaves the orientation as near as its joints allow (the least-squares point,
//! then Gauss-Newton on the position alone), its orientation error in the solution, where
//! that error is within [`REACHABLE_TURN_RAD`].
//!
//! The solver works on any [`ToolModel`] (a pose and its geometric Jacobian): the robot's
//! kinematic model, rigid or compliant ([`solve_numeric`]), or a model with a neural
//! compensator in series (see `compensation`).
//! An approximate Jacobian only slows convergence; the tolerances are checked on the model's
//! own pose.

use super::Pose;
use super::fk::{Frames, frames};
use super::jacobian::joint_jacobian;
use crate::error::{Error, Result};
use crate::geometry::rotation::rotation_vector;
use crate::model::{JointType, LIMIT_TOL, Robot};
use nalgebra::{DMatrix, DVector, Matrix3, Matrix6xX, Vector3, Vector6};
use std::f64::consts::PI;

/// What the tool must reach.
#[derive(Debug, Clone, Copy)]
pub enum IkTarget {
    /// Position and orientation.
    Pose(Pose),
    /// Position only (mm); the orientation is left free.
    Position(Vector3<f64>),
}

/// Tolerances and limits of a numerical solve.
#[derive(Debug, Clone, Copy)]
pub struct IkOptions {
    /// Largest accepted position error (mm).
    pub tol_position_mm: f64,
    /// Largest accepted orientation error (rad).
    pub tol_rotation_rad: f64,
    /// Orientation weight L (mm per rad) in the least-squares residual.
    pub length_scale_mm: f64,
    /// Most LM iterations.
    pub max_iterations: usize,
}

impl Default for IkOptions {
    fn default() -> Self {
        IkOptions {
            tol_position_mm: 1e-9,
            tol_rotation_rad: 1e-12,
            length_scale_mm: 1000.0,
            max_iterations: 100,
        }
    }
}

/// A converged solution.
#[derive(Debug, Clone)]
pub struct IkSolution {
    /// Joints (rad or mm). Revolute joints are moved by multiples of 2 pi into their limits
    /// where that is possible.
    pub q: Vec<f64>,
    /// LM iterations run.
    pub iterations: usize,
    /// Remaining position error (mm).
    pub position_error_mm: f64,
    /// Remaining orientation error (rad); 0 for position targets.
    pub rotation_error_rad: f64,
    /// 0-based joints that are outside their limits even after 2 pi shifts.
    pub outside_limits: Vec<usize>,
}

/// A forward model that numerical IK can invert.
pub trait ToolModel {
    /// The robot whose joints (types, limits) the model moves.
    fn robot(&self) -> &Robot;
    /// The tool pose (mm) at joints `q` (rad or mm).
    fn pose(&mut self, q: &[f64]) -> Pose;
    /// The geometric Jacobian at `q` into `jac` (6 x N): rows 0-2 the tool origin's velocity
    /// (mm per rad or per mm), rows 3-5 its angular velocity (rad per rad or per mm), world.
    fn jacobian(&mut self, q: &[f64], jac: &mut Matrix6xX<f64>);
}

/// The robot's kinematic model (rigid, or compliant when the robot has compliances) as a [`ToolModel`], with its frames.
pub struct RobotModel<'a> {
    robot: &'a Robot,
    frames: Frames,
}

impl<'a> RobotModel<'a> {
    /// The kinematic model of `robot`.
    pub fn new(robot: &'a Robot) -> Self {
        RobotModel {
            robot,
            frames: Frames::new(robot),
        }
    }
}

impl ToolModel for RobotModel<'_> {
    fn robot(&self) -> &Robot {
        self.robot
    }

    fn pose(&mut self, q: &[f64]) -> Pose {
        frames(self.robot, q, &mut self.frames);
        self.frames.tool
    }

    fn jacobian(&mut self, q: &[f64], jac: &mut Matrix6xX<f64>) {
        frames(self.robot, q, &mut self.frames);
        joint_jacobian(self.robot, &self.frames, jac);
    }
}

/// The kinematic model over a workspace's frames ([`solve_numeric`]).
struct WorkspaceModel<'a> {
    robot: &'a Robot,
    frames: &'a mut Frames,
}

impl ToolModel for WorkspaceModel<'_> {
    fn robot(&self) -> &Robot {
        self.robot
    }

    fn pose(&mut self, q: &[f64]) -> Pose {
        frames(self.robot, q, self.frames);
        self.frames.tool
    }

    fn jacobian(&mut self, q: &[f64], jac: &mut Matrix6xX<f64>) {
        frames(self.robot, q, self.frames);
        joint_jacobian(self.robot, self.frames, jac);
    }
}

/// Scratch space for numerical IK, reused across solves of one robot: the kinematic model's
/// frames (used by [`solve_numeric`] only) and the LM solver's matrices and vectors, so that
/// a solve allocates only the joints it returns.
#[derive(Debug, Clone)]
pub struct IkWorkspace {
    frames: Frames,
    lm: LmBuffers,
}

/// The LM solver's matrices and vectors.
#[derive(Debug, Clone)]
struct LmBuffers {
    jac: Matrix6xX<f64>,
    q: Vec<f64>,
    trial: Vec<f64>,
    /// J^T J (N x N).
    a: DMatrix<f64>,
    /// J^T e (N).
    g: DVector<f64>,
    /// The damped normal matrix, then its Cholesky factor (N x N).
    m: DMatrix<f64>,
    /// The step (N).
    dq: DVector<f64>,
}

impl LmBuffers {
    fn new(n: usize) -> Self {
        LmBuffers {
            jac: Matrix6xX::zeros(n),
            q: vec![0.0; n],
            trial: vec![0.0; n],
            a: DMatrix::zeros(n, n),
            g: DVector::zeros(n),
            m: DMatrix::zeros(n, n),
            dq: DVector::zeros(n),
        }
    }
}

impl IkWorkspace {
    /// A workspace for `robot`'s joints.
    pub fn new(robot: &Robot) -> Self {
        IkWorkspace {
            frames: Frames::new(robot),
            lm: LmBuffers::new(robot.dof()),
        }
    }
}

/// Residual (6 components, mm; orientation scaled by L) at `q`.
fn residual<M: ToolModel>(model: &mut M, target: &IkTarget, q: &[f64], scale: f64) -> Vector6<f64> {
    let t = model.pose(q);
    match target {
        IkTarget::Pose(g) => {
            let dp = g.translation.vector - t.translation.vector;
            let dr = rotation_vector(&(g.rotation * t.rotation.inverse())) * scale;
            Vector6::new(dp.x, dp.y, dp.z, dr.x, dr.y, dr.z)
        }
        IkTarget::Position(p) => {
            let dp = p - t.translation.vector;
            Vector6::new(dp.x, dp.y, dp.z, 0.0, 0.0, 0.0)
        }
    }
}

/// Solves for joints that put the tool of the robot's kinematic model on `target`, starting from `seed`
/// (rad or mm).
pub fn solve_numeric(
    robot: &Robot,
    target: &IkTarget,
    seed: &[f64],
    opts: &IkOptions,
    ws: &mut IkWorkspace,
) -> Result<IkSolution> {
    if ws.frames.joint.len() != robot.dof() {
        *ws = IkWorkspace::new(robot);
    }
    let mut model = WorkspaceModel {
        robot,
        frames: &mut ws.frames,
    };
    solve_lm(&mut model, target, seed, opts, &mut ws.lm)
}

/// Solves for joints that put the tool of `model` on `target`, starting from `seed`
/// (rad or mm).
pub fn solve_model<M: ToolModel>(
    model: &mut M,
    target: &IkTarget,
    seed: &[f64],
    opts: &IkOptions,
    ws: &mut IkWorkspace,
) -> Result<IkSolution> {
    solve_lm(model, target, seed, opts, &mut ws.lm)
}

fn solve_lm<M: ToolModel>(
    model: &mut M,
    target: &IkTarget,
    seed: &[f64],
    opts: &IkOptions,
    ws: &mut LmBuffers,
) -> Result<IkSolution> {
    let n = model.robot().dof();
    if ws.q.len() != n {
        *ws = LmBuffers::new(n);
    }
    if seed.len() != n {
        return Err(Error::Invalid(format!(
            "seed has {} joints, the robot {n}",
            seed.len()
        )));
    }
    let position_only = matches!(target, IkTarget::Position(_));
    let l = opts.length_scale_mm;
    ws.q.copy_from_slice(seed);
    let mut e = residual(model, target, &ws.q, l);
    let mut cost = e.norm_squared();
    let mut lambda = 1e-3;
    // The iteration at which no step lowered the error, where one did not.
    let mut stalled = None;
    let errors = |e: &Vector6<f64>| {
        let pos = e.fixed_rows::<3>(0).norm();
        let rot = e.fixed_rows::<3>(3).norm() / l;
        (pos, rot)
    };
    for iter in 0..=opts.max_iterations {
        let (pos, rot) = errors(&e);
        if pos <= opts.tol_position_mm && rot <= opts.tol_rotation_rad {
            return Ok(finish(model.robot(), &ws.q, iter, pos, rot));
        }
        if iter == opts.max_iterations {
            break;
        }
        model.jacobian(&ws.q, &mut ws.jac);
        if position_only {
            ws.jac.fixed_rows_mut::<3>(3).fill(0.0);
        } else {
            ws.jac.fixed_rows_mut::<3>(3).scale_mut(l);
        }
        ws.a.gemm_tr(1.0, &ws.jac, &ws.jac, 0.0);
        ws.g.gemv_tr(1.0, &ws.jac, &e, 0.0);
        // Inner loop: raise lambda until a step lowers the cost.
        let mut improved = false;
        while lambda < 1e12 {
            ws.m.copy_from(&ws.a);
            for k in 0..n {
                ws.m[(k, k)] += lambda * ws.a[(k, k)].max(1e-9);
            }
            // The factorisation takes the matrix and gives it back, so no step allocates
            // (except after a failed factorisation, which consumed it).
            let m = std::mem::replace(&mut ws.m, DMatrix::zeros(0, 0));
            let Some(chol) = m.cholesky() else {
                ws.m = DMatrix::zeros(n, n);
                lambda *= 10.0;
                continue;
            };
            ws.dq.copy_from(&ws.g);
            chol.solve_mut(&mut ws.dq);
            ws.m = chol.unpack_dirty();
            for k in 0..n {
                ws.trial[k] = ws.q[k] + ws.dq[k];
            }
            let e_new = residual(model, target, &ws.trial, l);
            let c_new = e_new.norm_squared();
            if c_new.is_finite() && c_new < cost {
                std::mem::swap(&mut ws.q, &mut ws.trial);
                e = e_new;
                cost = c_new;
                lambda = (lambda / 10.0).max(1e-12);
                improved = true;
                break;
            }
            lambda *= 10.0;
        }
        if !improved {
            stalled = Some(iter);
            break;
        }
    }
    // An arm of fewer than six joints cannot turn its tool about every axis: where its
    // calibrated axes tilt, the target's orientation is out of reach by a little (a SCARA's
    // by the tilt), and the least-squares point trades micrometres of position for it. The
    // position is met exactly from there, the orientation left as near as the joints allow
    // (its error is the solution's).
    let iterations = stalled.unwrap_or(opts.max_iterations);
    if n < 6
        && !position_only
        && let Some((pos, rot)) = meet_position(model, target, &mut e, opts, l, ws)
    {
        return within_reach(n, rot).map(|()| finish(model.robot(), &ws.q, iterations, pos, rot));
    }
    // The caller gets the error at the best point.
    if let Some(iter) = stalled {
        let (pos, rot) = errors(&e);
        return Err(Error::NotConverged(format!(
            "numerical IK stalled after {iter} iterations (no step lowers the error): \
             position error {pos:.3e} mm, orientation error {:.3e} deg; \
             the target may be out of reach",
            rot.to_degrees()
        )));
    }
    let (pos, rot) = errors(&e);
    Err(Error::NotConverged(format!(
        "numerical IK did not converge in {} iterations: position error {pos:.3e} mm, \
         orientation error {:.3e} deg",
        opts.max_iterations,
        rot.to_degrees()
    )))
}

/// Orientation error (rad) an arm of fewer than six joints may leave with the position met
/// (`meet_position`): a calibrated arm's tilts leave milliradians of the nominal's
/// orientation out of its reach; a target farther off in orientation is one the arm cannot
/// take (a SCARA's tool tilted by 20 deg), and its solve fails.
pub const REACHABLE_TURN_RAD: f64 = 0.01;

/// Ok where the orientation error `rot` (rad) that an arm of `n` joints leaves with the
/// position met is within [`REACHABLE_TURN_RAD`], else the error that says so.
fn within_reach(n: usize, rot: f64) -> Result<()> {
    if rot <= REACHABLE_TURN_RAD {
        return Ok(());
    }
    Err(Error::NotConverged(format!(
        "the position is met, but the arm's {n} joints leave the tool {:.4} deg from the \
         target's orientation, more than the {:.4} deg a calibrated arm's tilts leave: an arm \
         of fewer than six joints cannot turn its tool about every axis, and this orientation \
         is out of its reach",
        rot.to_degrees(),
        REACHABLE_TURN_RAD.to_degrees()
    )))
}

/// Steps of [`meet_position`] at most.
const POSITION_STEPS: usize = 20;

/// From the least-squares point `ws.q` of an arm of fewer than six joints (its residual in
/// `e`), Gauss-Newton on the position alone with the smallest joint step (dq = J_p^T (J_p
/// J_p^T)^-1 e_p, J_p the 3 x N position rows), which leaves the orientation where the
/// least squares put it but for a change of second order: the position and orientation
/// errors (mm, rad) once the position is within tolerance, None where it does not get there
/// (fewer than three joints move the tool's origin independently, or the target is out of
/// reach). `ws.q` and `e` hold the last point either way.
fn meet_position<M: ToolModel>(
    model: &mut M,
    target: &IkTarget,
    e: &mut Vector6<f64>,
    opts: &IkOptions,
    l: f64,
    ws: &mut LmBuffers,
) -> Option<(f64, f64)> {
    let n = ws.q.len();
    for _ in 0..POSITION_STEPS {
        let pos = e.fixed_rows::<3>(0).norm();
        if pos <= opts.tol_position_mm {
            return Some((pos, e.fixed_rows::<3>(3).norm() / l));
        }
        model.jacobian(&ws.q, &mut ws.jac);
        let jp = ws.jac.fixed_rows::<3>(0);
        let a: Matrix3<f64> = jp * jp.transpose();
        let y = a.cholesky()?.solve(&e.fixed_rows::<3>(0).into_owned());
        for k in 0..n {
            ws.trial[k] = ws.q[k] + jp.column(k).dot(&y);
        }
        let e_new = residual(model, target, &ws.trial, l);
        // A NaN miss is no progress either.
        if e_new.fixed_rows::<3>(0).norm().partial_cmp(&pos) != Some(std::cmp::Ordering::Less) {
            return None;
        }
        std::mem::swap(&mut ws.q, &mut ws.trial);
        *e = e_new;
    }
    let pos = e.fixed_rows::<3>(0).norm();
    (pos <= opts.tol_position_mm).then(|| (pos, e.fixed_rows::<3>(3).norm() / l))
}

fn finish(robot: &Robot, q: &[f64], iterations: usize, pos: f64, rot: f64) -> IkSolution {
    let mut q = q.to_vec();
    for (v, j) in q.iter_mut().zip(robot.joints()) {
        if j.joint_type != JointType::Revolute {
            continue;
        }
        let [lo, hi] = j.limits_internal();
        // Within the limits' rounding allowance a joint stays: a solution on a limit of
        // +-180 deg that ends 1e-12 rad past it is not the copy at the other end, a turn away
        // from the seed (a helper's finding).
        if *v < lo - LIMIT_TOL || *v > hi + LIMIT_TOL {
            // The copy nearest the middle of the range, if one fits.
            let mid = 0.5 * (lo + hi);
            let shifted = *v - ((*v - mid) / (2.0 * PI)).round() * 2.0 * PI;
            if shifted >= lo - LIMIT_TOL && shifted <= hi + LIMIT_TOL {
                *v = shifted;
            }
        }
    }
    let outside_limits = robot.joints_outside_limits(&q);
    IkSolution {
        q,
        iterations,
        position_error_mm: pos,
        rotation_error_rad: rot,
        outside_limits,
    }
}
