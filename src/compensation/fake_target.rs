//! Fake targets for an unmodified controller (thesis 2.7): for a desired tool pose T, the
//! joints q* at which the calibrated model reaches T, and the pose FK_nominal(q*) to command.
//!
//! Per target, with the IK strategy `ik` shares ([`crate::kinematics::ik`]):
//! 1. the nominal closed form (App. B) gives the start q0: the solution on the seed joints'
//!    branch nearest them (without a seed: the solution nearest the middle of the joint
//!    ranges), within the limits if one is; its [`Branch`] is the configuration the
//!    controller is asked to keep. Out of the nominal's reach, the
//!    row's seed joints start the solve instead. Without a seed, where the calibrated
//!    solution on that branch fails (beyond a limit the nominal's was within, not converged,
//!    or on another branch), the other branches are tried in the same order;
//! 2. numerical IK of the calibrated model from q0 (LM, `kinematics::ik_numeric`) gives q*;
//! 3. q* must lie within the limits, and the nominal closed form of F = FK_nominal(q*) on the
//!    seed's branch must return q* itself: that is what the controller will compute from F.
//!    A target failing any step is a [`Failure`], never a command.
//!
//! A controller of the UR class (axes 2, 3 and 4 parallel; Universal Robots') takes no
//! configuration flags: it runs its analytic solution nearest the joints it is given
//! (URScript's `get_inverse_kin(pose, qnear)`), and no branch is reported. So does, here, a
//! controller model robocal has no closed form for. Each target then needs seed joints (the
//! configuration it was taught in): q* is the calibrated model's solution nearest the seed
//! (step 2, from the seed and, for the UR class, from every nominal closed-form solution),
//! within the limits, and the nominal model's solution of F nearest the seed must be q*
//! (step 3's check, the controller's view: the nearest of the nominal closed form's
//! solutions; without a closed form, near the seed the nominal's numerical solve from it, far
//! from it a search of the nominal's solutions). Where it is another configuration, q* is
//! moved to the one the controller would run (`solve_from_seed`); where they do not settle,
//! the next nearest calibrated solutions are checked the same way, and where none passes the
//! target is a [`Failure::ControllerDiffers`].

use super::model::CalibratedModel;
use crate::data::Target;
use crate::error::{Error, Result};
use crate::geometry::rotation::angle_between;
use crate::kinematics::{
    Branch, ClosedFormIk, IkFailure, IkOptions, IkSolution, IkSolver, IkStart, IkTarget,
    IkWorkspace, Pose, ToolModel, another_arm, solve_numeric, tool_pose,
};
use crate::model::{JointType, Robot, joint_distance};
use nalgebra::Translation3;
use std::f64::consts::PI;

/// Largest difference (rad) between q* and the controller's solution for F on the same branch.
const SAME_JOINTS_RAD: f64 = 1e-6;

/// Joint distance (rad, mm) from its seed beyond which a command solved from the closed-form
/// start may be another configuration than the seed's (a wrist turned half a turn: 3 rad and
/// more; near the singularity q4 and q6 swung by tens of degrees), not the seed's own moved by
/// the calibration (hundredths of a radian): the seed then starts a solve too, and the
/// nearer command is kept ([`FakeTargetSolver::solve`]).
const SEED_FAR_RAD: f64 = 0.1;

/// Pose change (mm, rad) below which the calibrated robot counts as reaching the same pose with
/// another split of q4 + s q6 at a straight wrist (checked by `FakeTargetSolver::command`, at
/// the solution put on the nominal's singularity).
const SPLIT_FREE_MM: f64 = 1e-6;
const SPLIT_FREE_RAD: f64 = 1e-9;

/// Largest miss (mm, rad) of the calibrated model, at a command's joints, from its target
/// (or twice the solve's own residual, where that is larger; the solve stops at 1e-6 mm and
/// 1e-9 rad): checked for every command ([`FakeTargetSolver::solve`]), and where a controller
/// would run other joints than the solution's, at those ([`runs`]).
const LANDS_MM: f64 = 1e-4;
const LANDS_RAD: f64 = 1e-7;

/// Why a target has no start: no closed-form solution on the seed's branch, and a seed at a
/// singularity (no branch) that cannot start the solve.
const SEED_AT_SINGULARITY: &str =
    "out of the nominal model's reach, and the seed is at a singularity";

/// A solved target.
#[derive(Debug, Clone)]
pub struct Command {
    /// The pose solved for (for a position target: with the seed's orientation) (mm).
    pub desired: Pose,
    /// Joints (rad, mm) at which the calibrated model reaches `desired`.
    pub q: Vec<f64>,
    /// The fake target FK_nominal(q) to give the controller (mm).
    pub fake: Pose,
    /// The nominal closed form's branch of q (the seed's); None for a controller that
    /// solves near the seed joints instead (the UR class, or a nominal model without a closed
    /// form).
    pub branch: Option<Branch>,
    /// Without seed joints, where the calibrated solution on the branch nearest the middle
    /// of the ranges failed and the command is on another: that branch. None otherwise.
    pub instead_of: Option<Branch>,
    /// LM iterations.
    pub iterations: usize,
    /// Remaining position error of the calibrated model at q (mm).
    pub position_residual_mm: f64,
    /// Remaining orientation error of the calibrated model at q (rad).
    pub rotation_residual_rad: f64,
}

/// Why a target has no command.
#[derive(Debug, Clone, PartialEq)]
pub enum Failure {
    /// A position-only target without seed joints (its orientation is undefined).
    NoSeed,
    /// A target without seed joints for a controller that solves near the joints it is
    /// given (the UR class, or a nominal model without a closed form): no branch says which
    /// configuration it keeps.
    NoSeedToSolveNear,
    /// Seed joints that do not fit the robot.
    BadSeed(String),
    /// Neither the nominal closed form nor a seed gives a start.
    Unreachable(String),
    /// The calibrated model's numerical IK did not reach the pose.
    NotConverged(String),
    /// q* leaves the limits of these 0-based joints.
    OutsideLimits(Vec<usize>),
    /// The controller would not return q* for the fake target on the seed's branch.
    BranchChanged(String),
    /// Without a nominal closed form: the nominal model solved for the fake target from the
    /// seed does not return q*, so a controller solving near the seed would not either.
    ControllerDiffers(String),
}

impl Failure {
    /// A short code for the status column.
    pub fn code(&self) -> &'static str {
        match self {
            Failure::NoSeed | Failure::NoSeedToSolveNear => "no-seed",
            Failure::BadSeed(_) => "bad-seed",
            Failure::Unreachable(_) => "unreachable",
            Failure::NotConverged(_) => "not-converged",
            Failure::OutsideLimits(_) => "outside-limits",
            Failure::BranchChanged(_) => "branch-changed",
            Failure::ControllerDiffers(_) => "controller-differs",
        }
    }
}

impl std::fmt::Display for Failure {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Failure::NoSeed => write!(
                f,
                "no-seed: a position-only target needs seed joints for its orientation"
            ),
            Failure::NoSeedToSolveNear => write!(
                f,
                "no-seed: the controller runs the nominal model's solution nearest the joints \
                 it is given (no configuration flags), so each target needs seed joints (the \
                 configuration it was taught in)"
            ),
            Failure::OutsideLimits(j) => write!(
                f,
                "outside-limits: the calibrated solution leaves the limits of joint(s) {}",
                j.iter()
                    .map(|j| (j + 1).to_string())
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
            Failure::Unreachable(m)
            | Failure::NotConverged(m)
            | Failure::BranchChanged(m)
            | Failure::ControllerDiffers(m)
            | Failure::BadSeed(m) => {
                write!(f, "{}: {m}", self.code())
            }
        }
    }
}

/// The per-target solver: the shared IK strategy ([`IkSolver::from_nearest_start`], started
/// by the nominal closed form, or [`IkSolver::nearest`] from the seed without one) over the
/// calibrated model, with reused buffers.
pub struct FakeTargetSolver<'a> {
    nominal: &'a Robot,
    /// The nominal model without its joint compliances (the nominal itself where it has
    /// none): the geometry whose closed form names a configuration's branch.
    rigid_nominal: Robot,
    controller: Controller<'a>,
    ik: IkSolver<CalibratedModel<'a>>,
    sols: Vec<(Branch, [f64; 6])>,
    /// Scratch of the nominal model's solves in [`FakeTargetSolver::miss_as_written`].
    nominal_ws: IkWorkspace,
}

/// How the controller turns a command back into joints, as the solver checks it.
// One per solver, built once per run: the variants' sizes do not matter.
#[allow(clippy::large_enum_variant)]
enum Controller<'a> {
    /// The nominal closed form, on the seed's branch.
    ClosedForm(ClosedFormIk),
    /// The solution nearest the seed (`why`: a UR-class arm, or no closed form): the
    /// nominal model solved by `ik`, exactly by its closed form where it has one (a rigid
    /// nominal; a compliant one is solved from its rigid arm's).
    Nearest {
        why: String,
        ik: IkSolver<CalibratedModel<'a>>,
    },
}

/// Whether a miss of `dp` mm and `dr` rad lands on the target, for a solve that left
/// `residual` (mm, rad): within [`LANDS_MM`] and [`LANDS_RAD`], or twice the residual.
fn lands((dp, dr): (f64, f64), residual: (f64, f64)) -> bool {
    dp <= LANDS_MM.max(2.0 * residual.0) && dr <= LANDS_RAD.max(2.0 * residual.1)
}

/// The joints (0-based) of `sol` beyond the calibrated model's limits (as the solve found
/// them) or the controller's (`nominal`'s; usually the same), in order.
fn outside_either(sol: &IkSolution, nominal: &Robot) -> Vec<usize> {
    let mut outside = sol.outside_limits.clone();
    for j in nominal.joints_outside_limits(&sol.q) {
        if !outside.contains(&j) {
            outside.push(j);
        }
    }
    outside.sort_unstable();
    outside
}

/// How far (mm, rad) `model` at joints `q` lies from `target`.
fn miss<M: ToolModel>(model: &mut M, target: &Pose, q: &[f64]) -> (f64, f64) {
    let at = model.pose(q);
    (
        (at.translation.vector - target.translation.vector).norm(),
        angle_between(&at.rotation, &target.rotation),
    )
}

/// The solution a controller runs for the command of calibrated solution `sol` of `target`
/// when it computes joints `run` from the command: `sol` itself where `run` is `sol`'s joints
/// (to [`SAME_JOINTS_RAD`]); else `run`, where the calibrated model reaches the target there
/// all the same (within [`LANDS_MM`] and [`LANDS_RAD`], and `run` within `nominal`'s limits),
/// as on a redundant arm, whose solutions of one pose form a continuum through which a
/// controller's solve and the calibrated model's drift apart by a few nanometres; None where
/// the controller would run another configuration.
fn runs(
    ik: &mut IkSolver<CalibratedModel<'_>>,
    nominal: &Robot,
    target: &Pose,
    run: &[f64],
    sol: &IkSolution,
) -> Option<IkSolution> {
    if joint_distance(run, &sol.q) < SAME_JOINTS_RAD {
        return Some(sol.clone());
    }
    if !nominal.joints_outside_limits(run).is_empty() {
        return None;
    }
    let (dp, dr) = miss(ik.model(), target, run);
    lands((dp, dr), (sol.position_error_mm, sol.rotation_error_rad)).then(|| IkSolution {
        q: run.to_vec(),
        position_error_mm: dp,
        rotation_error_rad: dr,
        ..sol.clone()
    })
}

/// Distance (rad, mm) from `a` to `b`, joints of `robot`, with each revolute joint's
/// difference wrapped to [-pi, pi] (a prismatic joint's taken as it is): whether two joint
/// vectors are one configuration of the controller.
fn wrapped_distance(robot: &Robot, a: &[f64], b: &[f64]) -> f64 {
    (robot.joints().iter().zip(a.iter().zip(b)))
        .map(|(joint, (x, y))| {
            let d = match joint.joint_type {
                JointType::Revolute => (x - y + PI).rem_euclid(2.0 * PI) - PI,
                JointType::Prismatic => x - y,
            };
            d * d
        })
        .sum::<f64>()
        .sqrt()
}

/// How far joints `a` and `b` (rad, mm) of `robot` lie apart, for a message: the largest
/// difference in file units (deg, mm) and its joint, e.g. "up to 12.3 deg (joint 4)".
fn joints_apart(robot: &Robot, a: &[f64], b: &[f64]) -> String {
    let (j, d) = (robot.joints().iter().zip(a.iter().zip(b)).enumerate())
        .map(|(j, (joint, (x, y)))| (j, joint.joint_type.to_file((x - y).abs())))
        .fold(
            (0, 0.0),
            |best, this| if this.1 > best.1 { this } else { best },
        );
    let unit = match robot.joints().get(j).map(|joint| joint.joint_type) {
        Some(JointType::Prismatic) => "mm",
        _ => "deg",
    };
    // Fixed decimals would print a gap of 1e-6 rad, which the checks tell apart, as 0.0000.
    if d >= 0.01 {
        format!("up to {d:.4} {unit} (joint {})", j + 1)
    } else {
        format!("up to {d:.3e} {unit} (joint {})", j + 1)
    }
}

impl<'a> FakeTargetSolver<'a> {
    /// `nominal` is the controller's model; `model` the calibrated one. Both must have the
    /// same joints. For a controller solving near the seed (a UR-class nominal, or one
    /// without a closed form) every target needs seed joints.
    pub fn new(nominal: &'a Robot, model: CalibratedModel<'a>) -> Result<Self> {
        // A branch (configuration flags) is the arm's geometry's: a nominal model with joint
        // compliances has its rigid arm's closed form, and solves its deflected poses from it
        // (the deflection turns the joints by far less than a branch lies away). Its own
        // closed form missed them: every target was branch-changed.
        let rigid_nominal = nominal.rigid();
        let closed = ClosedFormIk::new(&rigid_nominal);
        if !model.robot().same_joints(nominal) {
            return Err(Error::Invalid(
                "the calibrated model's joints differ from the nominal model's".into(),
            ));
        }
        if let Some(gap) = another_arm(nominal, model.robot()) {
            return Err(Error::Invalid(format!(
                "the calibrated model is not a calibration of the nominal one: {gap}: give the \
                 calibrated model of this robot"
            )));
        }
        let opts = IkOptions {
            tol_position_mm: 1e-6,
            tol_rotation_rad: 1e-9,
            ..IkOptions::default()
        };
        let (start, controller) = match closed {
            // The starts in the calibrated model's world frame, the controller's view in the
            // nominal's.
            Ok(c) if !c.is_ur_class() => (
                IkStart::Nominal(c.placed_as(&rigid_nominal, model.robot())),
                Controller::ClosedForm(c),
            ),
            Ok(c) => (
                IkStart::Nominal(c.placed_as(&rigid_nominal, model.robot())),
                Controller::Nearest {
                    why: "a UR-class arm (axes 2, 3 and 4 parallel), whose controller takes no \
                          configuration flags"
                        .into(),
                    ik: IkSolver::new(
                        CalibratedModel::identified(nominal),
                        // The rigid arm's closed form is exact for the nominal only
                        // without compliances; with them it starts the solves.
                        if nominal.is_compliant() {
                            IkStart::Nominal(c)
                        } else {
                            IkStart::Exact(c)
                        },
                        IkOptions::default(),
                    ),
                },
            ),
            Err(e) => {
                let why = e.to_string();
                // F = FK_nominal(q*) is reached exactly at q*: the default tolerances, so
                // that near a singularity a loose solve does not land 1e-6 rad away.
                let ik = IkSolver::new(
                    CalibratedModel::identified(nominal),
                    IkStart::Seed(why.clone()),
                    IkOptions::default(),
                );
                (IkStart::Seed(why.clone()), Controller::Nearest { why, ik })
            }
        };
        Ok(FakeTargetSolver {
            nominal,
            rigid_nominal,
            ik: IkSolver::new(model, start, opts),
            controller,
            sols: Vec::with_capacity(8),
            nominal_ws: IkWorkspace::new(nominal),
        })
    }

    /// How far (mm, rad) the calibrated robot (model, and network) misses `command`'s
    /// desired pose when the controller is given `written` instead of `command.fake`: the
    /// command as a file holds it, rounded to its decimals. The controller's joints for
    /// `written` are the nominal model's solution of it nearest q* (a numerical solve from
    /// q*: a rounding moves them by far less than a branch or a turn lies away). The rounded
    /// pose itself is reached, but at other joints, where the calibrated robot's error is
    /// another: micrometres, but next to a singularity, where a rounding moves the joints
    /// far, tenths of a millimetre (a reviewer's FANUC target at 0.01 mm and 0.01 deg: joint
    /// 1 moved 2.15 deg, 0.32 mm). None where that solve does not converge.
    pub fn miss_as_written(&mut self, command: &Command, written: &Pose) -> Option<(f64, f64)> {
        let run = solve_numeric(
            self.nominal,
            &IkTarget::Pose(*written),
            &command.q,
            &IkOptions::default(),
            &mut self.nominal_ws,
        )
        .ok()?;
        Some(miss(self.ik.model(), &command.desired, &run.q))
    }

    /// Why the controller solves near the seed joints (a UR-class arm, or a nominal model
    /// without a closed form): every target then needs seed joints and has no branch; None
    /// for a controller that keeps the seed's branch.
    pub fn solves_near_seed(&self) -> Option<&str> {
        match &self.controller {
            Controller::ClosedForm(_) => None,
            Controller::Nearest { why, .. } => Some(why),
        }
    }

    /// Every branch of the nominal closed form that returns `q` (mod 2 pi) for
    /// FK_nominal(q) (of the rigid nominal, where it has joint compliances): one, or more at
    /// a singularity where branches merge (none without a closed form). At a wrist
    /// singularity, where the closed form splits q4 + s q6 as its arithmetic falls, a
    /// solution counts as `q` where it is `q` split otherwise.
    pub fn branches_of(&mut self, q: &[f64]) -> Vec<Branch> {
        let f = tool_pose(&self.rigid_nominal, q);
        let Controller::ClosedForm(closed) = &self.controller else {
            return Vec::new();
        };
        closed.solve_branches(&f, &mut self.sols);
        let mut found: Vec<Branch> = (self.sols.iter())
            .filter(|(_, s)| {
                wrapped_distance(self.nominal, &closed.wrist_split_nearest(s, q), q)
                    < SAME_JOINTS_RAD
            })
            .map(|(b, _)| *b)
            .collect();
        // A straight wrist is on both wrist flips, whether the closed form listed the two
        // (equal to its rounding) or one.
        if let Ok(q) = <[f64; 6]>::try_from(q)
            && closed.straight_wrist(&q).is_some()
        {
            for b in found.clone() {
                let flip = Branch {
                    wrist: 1 - b.wrist,
                    ..b
                };
                if !found.contains(&flip) {
                    found.push(flip);
                }
            }
        }
        found
    }

    /// The command for one desired pose; `seed` (rad, mm) chooses the branch and turns (with
    /// a nominal closed form) or starts the solve (without one: then it is required). A pose
    /// the nominal closed form has no solution for, which the calibrated model's solve from
    /// the seed does not reach either, is `Unreachable`, as `ik` says it (not `NotConverged`).
    pub fn solve(
        &mut self,
        desired: &Target,
        seed: Option<&[f64]>,
    ) -> std::result::Result<Command, Failure> {
        // The closed-form path checks its solutions as it goes (`command`), so that a miss
        // lets the seed start another solve.
        let out = self.solve_seeded(desired, seed).and_then(|command| {
            if matches!(self.controller, Controller::Nearest { .. }) {
                let residual = (command.position_residual_mm, command.rotation_residual_rad);
                self.landed(&command.desired, &command.q, residual)?;
            }
            Ok(command)
        });
        let Err(Failure::NotConverged(why)) = &out else {
            return out;
        };
        if !matches!(self.controller, Controller::ClosedForm(_)) {
            return out;
        }
        // The nominal closed form placed as the calibrated model (its base and tool), in
        // whose frame the target is: the controller's own works in the nominal's frame,
        // which a base registered to a tracker's lies metres from.
        let Some(closed) = self.ik.start().closed_form() else {
            return out;
        };
        let target = match desired {
            Target::Pose(p) => *p,
            Target::Position(_) => return out,
        };
        closed.solve_branches(&target, &mut self.sols);
        if !self.sols.is_empty() {
            return out;
        }
        Err(Failure::Unreachable(format!(
            "out of the nominal model's reach (its closed form has no solution), and the \
             calibrated model's solve from the seed does not reach it either: {why}"
        )))
    }

    /// Whether the calibrated model at joints `q` reaches `target` (a position target's
    /// pose with the seed's orientation, as solved) within [`LANDS_MM`] and [`LANDS_RAD`] (or
    /// twice the solve's `residual`, mm and rad). The solve's residual is that of the joints
    /// it converged to; a joint moved by a whole turn after it (into the limits, or to the
    /// turn nearest the seed) reaches the same pose for a model and a compensator whose
    /// inputs are periodic, but not for one whose inputs are the angles themselves.
    fn landed(
        &mut self,
        target: &Pose,
        q: &[f64],
        residual: (f64, f64),
    ) -> std::result::Result<(), Failure> {
        let (dp, dr) = miss(self.ik.model(), target, q);
        if lands((dp, dr), residual) {
            return Ok(());
        }
        Err(Failure::NotConverged(format!(
            "the calibrated model misses the target by {dp:.3e} mm and {:.3e} deg at the \
             solution's joints, put on the turns the limits or the seed ask for (the solve \
             converged a whole turn away, which a compensator with angle inputs tells apart)",
            dr.to_degrees()
        )))
    }

    /// [`FakeTargetSolver::solve`] before a failed solve is told apart from an unreachable pose.
    fn solve_seeded(
        &mut self,
        desired: &Target,
        seed: Option<&[f64]>,
    ) -> std::result::Result<Command, Failure> {
        let n = self.nominal.dof();
        if let Some(s) = seed
            && s.len() != n
        {
            return Err(Failure::BadSeed(format!(
                "{} seed joints for a robot with {n}",
                s.len()
            )));
        }
        let target = match desired {
            Target::Pose(p) => *p,
            Target::Position(x) => {
                let s = seed.ok_or(Failure::NoSeed)?;
                let r = self.ik.model().pose(s).rotation;
                Pose::from_parts(Translation3::from(*x), r)
            }
        };
        if let Controller::Nearest { ik: controller, .. } = &mut self.controller {
            return solve_from_seed(&mut self.ik, controller, self.nominal, target, seed);
        }
        // A seed fixes the branch (the configuration the robot program was taught in); a seed
        // where branches merge (a straight wrist) admits each of them.
        let seed_branches = seed.map_or_else(Vec::new, |s| self.branches_of(s));
        let seed_branch = match seed_branches[..] {
            [b] => Some(b),
            _ => None,
        };
        let first = self
            .ik
            .from_nearest_start(&target, seed, &seed_branches)
            .map_err(|e| match e {
                IkFailure::NotConverged(m) => Failure::NotConverged(m),
                IkFailure::BadSeed(m) => Failure::BadSeed(m),
                IkFailure::OutOfReach(m) => Failure::Unreachable(m),
                // No closed-form start on the seed's branch, and the seed could not start
                // the solve either: there is none, or it is at a singularity (no branch).
                _ if seed.is_none() => Failure::Unreachable(
                    "out of the nominal model's reach; seed joints would let the calibrated \
                     model try"
                        .into(),
                ),
                _ => Failure::Unreachable(SEED_AT_SINGULARITY.into()),
            })
            .and_then(|solved| {
                let allowed: Vec<Branch> = if seed_branches.len() > 1 {
                    seed_branches.clone()
                } else {
                    solved.branch.or(seed_branch).into_iter().collect()
                };
                if allowed.is_empty() {
                    return Err(Failure::Unreachable(SEED_AT_SINGULARITY.into()));
                }
                self.command(target, solved.solution, &allowed)
            });
        // Without a seed no branch is the user's: where the calibrated solution on the branch
        // nearest the middle of the ranges fails (a reviewer's ABB arm: the nominal's shoulder
        // at -94.8 deg within its -95 limit, the calibrated model's at -95.4 beyond it), the
        // other branches are tried in the same order, and the first command stands.
        let first = match first {
            Err(
                Failure::OutsideLimits(_) | Failure::NotConverged(_) | Failure::BranchChanged(_),
            ) if seed.is_none() => {
                let branches = self.ik.start_branches(&target);
                let middle = branches.first().copied();
                (branches.into_iter().skip(1))
                    .find_map(|b| {
                        let solved = self.ik.from_nearest_start(&target, None, &[b]).ok()?;
                        let mut c = self.command(target, solved.solution, &[b]).ok()?;
                        c.instead_of = middle;
                        Some(c)
                    })
                    .map_or(first, Ok)
            }
            first => first,
        };
        // Near a wrist singularity the closed-form start on the seed's branch can lie on the
        // other side of it (q5 of the other sign, q4 and q6 half a turn away) when the
        // calibrated model puts the seed's q5 on one side and the nominal on the other. Its
        // solve then fails, or lands on a wrist configuration far from the seed's. The seed
        // itself then starts a solve too, and its command is kept if it keeps the seed's
        // branch and lies nearer the seed; else the first outcome stands.
        let Some(s) = seed.filter(|_| !seed_branches.is_empty()) else {
            return first;
        };
        let retry = match &first {
            Ok(c) => joint_distance(&c.q, s) > SEED_FAR_RAD,
            Err(f) => !matches!(f, Failure::BadSeed(_)),
        };
        if !retry {
            return first;
        }
        let from_seed = self
            .ik
            .from_start(&target, s)
            .ok()
            .and_then(|sol| self.command(target, sol, &seed_branches).ok());
        match (first, from_seed) {
            (Ok(c), Some(d)) if joint_distance(&d.q, s) < joint_distance(&c.q, s) => Ok(d),
            (Err(_), Some(d)) => Ok(d),
            (first, _) => first,
        }
    }

    /// The command of the calibrated solution `sol` for `target` on one of the controller's
    /// branches `allowed` (the seed's; more than one where the seed lies where they merge): a
    /// failure where `sol` leaves the limits (the calibrated model's or the controller's) or
    /// where the controller's closed form would return it on none of them.
    fn command(
        &mut self,
        target: Pose,
        sol: IkSolution,
        allowed: &[Branch],
    ) -> std::result::Result<Command, Failure> {
        let outside = outside_either(&sol, self.nominal);
        if !outside.is_empty() {
            return Err(Failure::OutsideLimits(outside));
        }
        // At a singularity where branches merge (a straight wrist: both flips), the solution
        // is on each of them: the controller asked for any of them returns it.
        let found = self.branches_of(&sol.q);
        let seeds: Vec<String> = allowed.iter().map(Branch::to_string).collect();
        let seeds = seeds.join(" or ");
        let branch = match (found.iter().find(|b| allowed.contains(b)), &found[..]) {
            (Some(b), _) => *b,
            (None, [b]) => {
                return Err(Failure::BranchChanged(format!(
                    "the seed is on branch {seeds}, the calibrated solution on {b}"
                )));
            }
            (None, _) => {
                return Err(Failure::BranchChanged(format!(
                    "the calibrated solution is at a singularity of the nominal model, where \
                     branch {seeds} is ambiguous"
                )));
            }
        };
        // There the controller splits q4 + s q6 by a rule of its own: the command holds only
        // where the calibrated robot reaches the same pose with every split (a calibration
        // whose wrist is straight there too), not where a calibrated q5 offset turns it.
        if let Controller::ClosedForm(closed) = &self.controller
            && let Ok(q) = <[f64; 6]>::try_from(&sol.q[..])
            && let Some(s) = closed.straight_wrist(&q)
        {
            // On the singularity itself (a numerical solution lies up to WRIST_ALIGNED off
            // it, where a split turns the tool by that much times the split).
            let q = closed.wrist_split_nearest(&q, &q);
            let at = self.ik.model().pose(&q);
            for turn in [0.5, 2.0] {
                let mut other = q;
                other[3] += turn;
                other[5] -= s * turn;
                let p = self.ik.model().pose(&other);
                let dp = (p.translation.vector - at.translation.vector).norm();
                let dr = angle_between(&p.rotation, &at.rotation);
                if dp > SPLIT_FREE_MM || dr > SPLIT_FREE_RAD {
                    return Err(Failure::BranchChanged(format!(
                        "the calibrated solution is at a wrist singularity of the nominal model \
                         (branch {seeds}), where the controller splits q4 and q6 by its own \
                         rule, and the calibrated robot reaches other poses with other splits \
                         ({dp:.3e} mm for {turn} rad)"
                    )));
                }
            }
        }
        self.landed(
            &target,
            &sol.q,
            (sol.position_error_mm, sol.rotation_error_rad),
        )?;
        let fake = tool_pose(self.nominal, &sol.q);
        Ok(Command::new(target, fake, Some(branch), sol))
    }
}

impl Command {
    /// The command of solution `sol` for `desired`, `fake` = FK_nominal(sol.q).
    fn new(desired: Pose, fake: Pose, branch: Option<Branch>, sol: IkSolution) -> Command {
        Command {
            desired,
            fake,
            branch,
            instead_of: None,
            iterations: sol.iterations,
            position_residual_mm: sol.position_error_mm,
            rotation_residual_rad: sol.rotation_error_rad,
            q: sol.q,
        }
    }
}

/// Rounds in which [`solve_from_seed`] moves a far command to the configuration the
/// controller would run; beyond them the target is a [`Failure::ControllerDiffers`].
const SETTLE_ROUNDS: usize = 3;

/// [`FakeTargetSolver::solve`] for a controller solving near the seed: q* nearest the seed
/// by `ik` (the calibrated model). The controller takes the nominal model's solution of F =
/// FK_nominal(q*) nearest the seed, whole turns included; it must be q*:
/// - with a closed form (the UR class), `controller` gives that solution (exactly, or from
///   the rigid arm's closed form for a nominal with joint compliances);
/// - without one, q* within [`SEED_FAR_RAD`] of the seed: `controller` (the nominal model)
///   solved for F from the seed must return q* (no other solution lies that near); farther,
///   where the solve from the seed may have run past a nearer configuration, the nominal's
///   solutions of F are searched ([`super::nearest`]).
///
/// Where the controller's solution is another configuration, q* is solved again from it (the
/// calibrated solution of the configuration the controller would run, its turns nearest the
/// seed), for up to [`SETTLE_ROUNDS`] rounds.
fn solve_from_seed(
    ik: &mut IkSolver<CalibratedModel<'_>>,
    controller: &mut IkSolver<CalibratedModel<'_>>,
    nominal: &Robot,
    target: Pose,
    seed: Option<&[f64]>,
) -> std::result::Result<Command, Failure> {
    let seed = seed.ok_or(Failure::NoSeedToSolveNear)?;
    let failure = |e: IkFailure| match e {
        IkFailure::BadSeed(m) => Failure::BadSeed(m),
        IkFailure::OutOfReach(m) | IkFailure::Unreachable(m) => Failure::Unreachable(m),
        IkFailure::OutsideLimits(j) => Failure::OutsideLimits(j),
        e => Failure::NotConverged(e.to_string()),
    };
    let nearest = ik.nearest(&target, Some(seed)).map_err(failure)?.solution;
    let first = nearest.q.clone();
    let failed = match settle(ik, controller, nominal, target, seed, nearest) {
        Ok(command) => return Ok(command),
        Err(failed) => failed,
    };
    // The nearest calibrated solution is not one a controller given the seed runs (next to a
    // fold the calibrated arm's and the nominal's solutions can lie on either side of it, and
    // the solve from the controller's slides back): the next nearest may be, as long as the
    // same check holds for it.
    if let Ok(mut others) = ik.ranked(&target, Some(seed)) {
        others.retain(|o| {
            let apart = joint_distance(&o.q, &first);
            (SAME_JOINTS_RAD..=TWIN_RAD).contains(&apart)
        });
        for other in others.into_iter().take(OTHER_SOLUTIONS) {
            if let Ok(command) = settle(ik, controller, nominal, target, seed, other) {
                return Ok(command);
            }
        }
    }
    Err(failed)
}

/// Calibrated solutions, after the nearest the seed, that [`solve_from_seed`] tries, nearest
/// first, where the nearest's command is not one the controller runs.
const OTHER_SOLUTIONS: usize = 3;

/// Largest joint distance (rad, from the solution nearest the seed) of the other solutions
/// [`solve_from_seed`] tries: those across a fold of it ([`crate::kinematics::fold`], whose
/// reflections reach twice [`crate::kinematics::fold::FOLD_NEAR_RAD`]), the same configuration
/// on the other side of a straight elbow or the shoulder's cylinder. A solution farther is
/// another configuration (a reviewer's: without the bound, a shoulder flip 287 deg from a seed
/// 2.6 deg from its target's nearest solution was written as the command): the row then
/// stays `controller-differs`, asking for seed joints nearer the taught configuration.
const TWIN_RAD: f64 = 2.0 * crate::kinematics::fold::FOLD_NEAR_RAD;

/// [`solve_from_seed`]'s check of calibrated solution `sol` of `target`: its command, where a
/// controller given `seed` runs `sol`, or after [`SETTLE_ROUNDS`] rounds of moving `sol` to
/// the configuration the controller would run, the failure.
fn settle(
    ik: &mut IkSolver<CalibratedModel<'_>>,
    controller: &mut IkSolver<CalibratedModel<'_>>,
    nominal: &Robot,
    target: Pose,
    seed: &[f64],
    mut sol: IkSolution,
) -> std::result::Result<Command, Failure> {
    let exact = controller.start().closed_form().is_some();
    let mut apart = String::new();
    for _ in 0..=SETTLE_ROUNDS {
        let outside = nominal.joints_outside_limits(&sol.q);
        if !outside.is_empty() {
            return Err(Failure::OutsideLimits(outside));
        }
        let fake = tool_pose(nominal, &sol.q);
        let run = if exact {
            match controller.nearest(&fake, Some(seed)) {
                Ok(run) => run.solution.q,
                Err(e) => {
                    return Err(Failure::ControllerDiffers(format!(
                        "the nominal model's closed-form solve does not solve the command within \
                         its limits: {e}"
                    )));
                }
            }
        } else if joint_distance(&sol.q, seed) <= SEED_FAR_RAD {
            return near_seed_check(ik, controller, nominal, target, fake, seed, sol);
        } else {
            let found = super::nearest::nearest_solution(controller, nominal, &fake, seed, &sol.q);
            let Some(run) = found else {
                return Err(Failure::ControllerDiffers(
                    "the nominal model solves the command within its limits from no start".into(),
                ));
            };
            run
        };
        if let Some(runs) = runs(ik, nominal, &target, &run, &sol) {
            return Ok(Command::new(target, fake, None, runs));
        }
        apart = joints_apart(nominal, &run, &sol.q);
        // The controller would run `run`: the calibrated solution of that configuration.
        // Near a singularity where two configurations lie a fraction of a degree apart, the
        // solve from `run` can slide back to q*: a start as far beyond `run` then tries the
        // configuration on its side.
        // Where it cannot, the controller would run a configuration in which the calibrated
        // robot misses the target: that is what fails, not the solve.
        let differs = |e: IkFailure| {
            Failure::ControllerDiffers(format!(
                "a controller taking the nominal model's solution nearest the seed would run \
                 another configuration, its joints {} from the calibrated solution's, in which \
                 the calibrated model does not reach the target ({e}): give seed joints nearer \
                 the taught configuration",
                joints_apart(nominal, &run, &sol.q)
            ))
        };
        let mut next = ik.from_start(&target, &run).map_err(differs)?;
        if wrapped_distance(nominal, &next.q, &sol.q) < SAME_JOINTS_RAD {
            let beyond: Vec<f64> = (run.iter().zip(&sol.q)).map(|(r, q)| 2.0 * r - q).collect();
            if let Ok(other) = ik.from_start(&target, &beyond) {
                next = other;
            }
        }
        if !next.outside_limits.is_empty() {
            return Err(Failure::OutsideLimits(next.outside_limits));
        }
        let calibrated = ik.model().robot();
        let Some(q) = calibrated.turns_near(&next.q, seed) else {
            return Err(Failure::OutsideLimits(
                calibrated.joints_outside_limits(&next.q),
            ));
        };
        sol = IkSolution { q, ..next };
    }
    Err(Failure::ControllerDiffers(format!(
        "the seed lies far from the command's joints, and a controller taking the nominal \
         model's solution nearest the seed would run another configuration, its joints \
         {apart} from the calibrated solution's, through {SETTLE_ROUNDS} rounds: give seed \
         joints nearer the taught configuration"
    )))
}

/// The check of a command `sol` within [`SEED_FAR_RAD`] of its seed: `controller` (the
/// nominal model) solved for `fake` from the seed returns `sol`, or joints that hold it
/// ([`runs`]). Where it returns other joints, `sol` is solved again from them, for up to
/// [`SETTLE_ROUNDS`] rounds: on a redundant arm the controller's solve and the calibrated
/// model's drift apart along the pose's continuum of solutions (a track moved by 0.03 mm,
/// where the calibrated model misses by 1e-4 mm), and the calibrated solution from the
/// controller's joints is the command the controller runs.
fn near_seed_check(
    ik: &mut IkSolver<CalibratedModel<'_>>,
    controller: &mut IkSolver<CalibratedModel<'_>>,
    nominal: &Robot,
    target: Pose,
    mut fake: Pose,
    seed: &[f64],
    mut sol: IkSolution,
) -> std::result::Result<Command, Failure> {
    let mut round = 0;
    loop {
        let back = match controller.nearest(&fake, Some(seed)) {
            Ok(back) => back.solution.q,
            Err(e) => {
                return Err(Failure::ControllerDiffers(format!(
                    "the nominal model does not solve the command from the seed: {e}"
                )));
            }
        };
        if let Some(runs) = runs(ik, nominal, &target, &back, &sol) {
            return Ok(Command::new(target, fake, None, runs));
        }
        let next = ik
            .from_start(&target, &back)
            .ok()
            .filter(|_| round < SETTLE_ROUNDS);
        if let Some(next) = &next {
            // The calibrated model's limits and the controller's, as `settle` holds them.
            let outside = outside_either(next, nominal);
            if !outside.is_empty() {
                return Err(Failure::OutsideLimits(outside));
            }
        }
        let Some(next) = next else {
            let apart = joints_apart(nominal, &back, &sol.q);
            let (dp, dr) = miss(ik.model(), &target, &back);
            return Err(Failure::ControllerDiffers(format!(
                "the nominal model solves the command from the seed at joints {apart} from the \
                 calibrated solution's, where the calibrated model misses the target by \
                 {dp:.3e} mm and {:.3e} deg: a controller solving near the seed would take those",
                dr.to_degrees()
            )));
        };
        sol = next;
        fake = tool_pose(nominal, &sol.q);
        round += 1;
    }
}

#[cfg(test)]
mod tests {
    use super::joints_apart;
    use crate::model::test_fanuc;

    #[test]
    fn joints_apart_names_the_largest_difference_in_degrees() {
        let r = test_fanuc();
        let a = [0.1, 0.2, 0.3, 0.4, 0.5, 0.6];
        let mut b = a;
        b[1] -= 0.01;
        b[3] += 1.0;
        assert_eq!(joints_apart(&r, &a, &b), "up to 57.2958 deg (joint 4)");
        b = a;
        b[5] += 2e-6;
        assert_eq!(joints_apart(&r, &a, &b), "up to 1.146e-4 deg (joint 6)");
    }

    #[test]
    fn a_whole_turn_is_no_distance_for_a_revolute_joint_only() {
        let robot = crate::model::test_rpr_arm();
        let turn = 2.0 * std::f64::consts::PI;
        let d = |a: [f64; 3], b: [f64; 3]| super::wrapped_distance(&robot, &a, &b);
        assert!(d([0.3, 5.0, -1.0], [0.3 + turn, 5.0, -1.0 - turn]) < 1e-12);
        // The prismatic joint 2 pi mm on is 2 pi mm away (it was wrapped to nothing).
        assert!((d([0.3, 5.0, -1.0], [0.3, 5.0 + turn, -1.0]) - turn).abs() < 1e-12);
        assert!((d([0.3, 5.0, -1.0], [0.4, 5.0, -1.0]) - 0.1).abs() < 1e-12);
    }
}
