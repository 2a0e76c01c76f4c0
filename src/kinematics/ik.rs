//! The inverse-kinematics strategy shared by `robocal ik` and target compensation: where a
//! solve starts and which solution is returned. Joints in internal units (rad, mm).
//!
//! 1. A model with a closed form of its own ([`IkStart::Exact`], thesis App. B) is solved by
//!    it; no numerical solve.
//! 2. Else the closed form of a nearby model (the nominal, [`IkStart::Nominal`], placed at the
//!    model's base and tool: [`ClosedFormIk::placed_as`]) gives the starts: each of its
//!    solutions in the whole-turn copy nearest the reference joints
//!    ([`ClosedFormIk::nearest_copy`]), copies within the limits first, then by
//!    [`joint_distance`] to the reference, and each carried onto the model's solution on its
//!    branch ([`IkSolver`]'s `tracked`: the nominal's closed form on the target corrected by
//!    the model's difference from the nominal, to a fixed point). A branch the nominal does
//!    not reach at the pose (the calibrated arm reaches millimetres farther) starts from its
//!    nearest, carried the same way. Numerical IK of the model ([`solve_model`]) refines
//!    them, each solution in its whole-turn copy nearest the reference.
//! 3. The caller's seed joints start a numerical solve too, and the only one where no closed
//!    form gives a start ([`IkStart::Seed`], or a pose out of the nominal's reach on every
//!    branch, where its solutions of the pose pulled a little toward the base start them
//!    too).
//! 4. Each solution found within [`super::fold::FOLD_NEAR_RAD`] of a fold of the model (a
//!    straight elbow, the shoulder's cylinder) starts a solve from its reflection across the
//!    fold ([`across_fold`]): the pose's other solution there, which the nominal's starts
//!    of a calibrated arm, whose fold lies off the nominal's, may not lead to.
//! 5. Where every solution the solves found leaves the limits, each moved within them
//!    ([`Robot::moved_within_limits`]) starts a solve too.
//! 6. Where a nominal's closed form gave the starts and no solve from them converged within
//!    the limits, where no branch of the nominal reaches the pose (its starts are then only
//!    the pulled and nearest ones), or where they found fewer distinct solutions than the
//!    nominal has branches at the pose, starts spread over the joints' turns around the
//!    reference ([`super::spread::around`]) are tried too: next to a singularity a
//!    calibrated arm can have solutions no branch's start leads to.
//!
//! The reference is the seed when one is given, else the middle of the joint ranges.
//! [`IkSolver::nearest`] (`robocal ik`) refines the seed and every start and returns the
//! converged solution within the limits nearest the reference; [`IkSolver::all`] every
//! distinct one; [`IkSolver::from_nearest_start`] (target compensation) solves once from the
//! nearest start on a given branch, the configuration the controller keeps.

use super::fold::across_fold;
use super::ik_closed::{Branch, ClosedFormIk, MAX_SOLUTIONS};
use super::ik_numeric::{IkOptions, IkSolution, IkTarget, IkWorkspace, ToolModel, solve_model};
use super::spread::around;
use super::subproblems::wrap;
use super::{Pose, Reach};
use crate::error::{Error, Result};
use crate::geometry::rotation::angle_between;
use crate::model::Robot;
pub use crate::model::joint_distance;
use nalgebra::Matrix6xX;

/// Two solutions closer than this in every joint (rad or mm) are one. Next to a fold a solve
/// that reaches the pose to 1e-9 mm can still end up to about 1e-6 rad along the direction
/// in which the pose barely moves (the error is quadratic there), so one configuration solved
/// from several starts came back as several solutions at 1e-7 (a reviewer: up to 8 rows for a
/// UR10 pose on its calibrated elbow's fold); no encoder tells apart configurations 1e-6 rad
/// apart (the closed form's [`super::ik_closed`] roots are merged at the same distance).
const SAME_SOLUTION: f64 = 1e-6;

/// Whether joints `a` and `b` (rad, mm) are one solution: within [`SAME_SOLUTION`] in every
/// joint.
fn same_solution(a: &[f64], b: &[f64]) -> bool {
    a.iter().zip(b).all(|(x, y)| (x - y).abs() < SAME_SOLUTION)
}

/// Where the solves start.
#[derive(Debug, Clone)]
pub enum IkStart {
    /// The model's own closed form: exact solutions, no numerical solve.
    Exact(ClosedFormIk),
    /// A rigid model's closed form starts numerical solves of the model: the nominal's
    /// (placed at the model's base and tool), or for a compliant robot its own without the
    /// compliances.
    Nominal(ClosedFormIk),
    /// Only the caller's seed starts the numerical solve; the text says why the model has no
    /// closed form.
    Seed(String),
}

impl IkStart {
    /// The model's own closed form when it has one; for a compliant robot, the closed form
    /// of its rigid self as the start of numerical solves; else `nominal`'s (an error when
    /// that has none or other joints); else the seed.
    pub fn choose(robot: &Robot, nominal: Option<&Robot>) -> Result<IkStart> {
        let own = if robot.is_compliant() {
            ClosedFormIk::new(&robot.rigid()).map(IkStart::Nominal)
        } else {
            ClosedFormIk::new(robot).map(IkStart::Exact)
        };
        match own {
            Ok(start) => Ok(start),
            Err(why) => match nominal {
                Some(nom) => {
                    if !nom.same_joints(robot) {
                        return Err(Error::Invalid(format!(
                            "the nominal model's joints differ from the robot's in number or type ({} and {} joints)",
                            nom.dof(),
                            robot.dof()
                        )));
                    }
                    let ik = ClosedFormIk::new(nom).map_err(|e| {
                        Error::Invalid(format!("the nominal model has no closed form: {e}"))
                    })?;
                    Ok(IkStart::Nominal(ik.placed_as(nom, robot)))
                }
                None => Ok(IkStart::Seed(why.to_string())),
            },
        }
    }

    /// The closed form that gives starts or solutions, if any.
    pub fn closed_form(&self) -> Option<&ClosedFormIk> {
        match self {
            IkStart::Exact(ik) | IkStart::Nominal(ik) => Some(ik),
            IkStart::Seed(_) => None,
        }
    }
}

/// Why a target has no solution.
#[derive(Debug, Clone, PartialEq)]
pub enum IkFailure {
    /// Numerical IK needs seed joints and none were given.
    NoSeed,
    /// Seed joints that do not fit the robot.
    BadSeed(String),
    /// The closed form has no solution: the pose is out of the arm's reach (or of its wrist's).
    Unreachable(String),
    /// The target lies beyond the arm's reach ([`Reach`], with [`REACH_MARGIN`]): how far.
    OutOfReach(String),
    /// More than [`MAX_SOLUTIONS`] solutions within the limits (ranges of many turns).
    TooMany,
    /// No numerical solve converged; the last one's report.
    NotConverged(String),
    /// Every solution found leaves the limits; the nearest the seed (or the middle of the
    /// ranges) leaves those of these 0-based joints.
    OutsideLimits(Vec<usize>),
}

impl IkFailure {
    /// A short code for a status column: `no-seed`, `bad-seed`, `unreachable`, `too-many`,
    /// `not-converged` or `outside-limits`.
    pub fn code(&self) -> &'static str {
        match self {
            IkFailure::NoSeed => "no-seed",
            IkFailure::BadSeed(_) => "bad-seed",
            IkFailure::Unreachable(_) | IkFailure::OutOfReach(_) => "unreachable",
            IkFailure::TooMany => "too-many",
            IkFailure::NotConverged(_) => "not-converged",
            IkFailure::OutsideLimits(_) => "outside-limits",
        }
    }
}

impl std::fmt::Display for IkFailure {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            IkFailure::NoSeed => write!(f, "no seed joints to start the numerical solve"),
            IkFailure::BadSeed(m) => write!(f, "bad seed: {m}"),
            IkFailure::Unreachable(m) | IkFailure::OutOfReach(m) => write!(f, "unreachable: {m}"),
            IkFailure::TooMany => write!(
                f,
                "more than {MAX_SOLUTIONS} solutions within the joint limits (ranges of many \
                 turns)"
            ),
            IkFailure::NotConverged(m) => write!(f, "{m}"),
            IkFailure::OutsideLimits(j) => write!(
                f,
                "the nearest solution leaves the limits of joint{} {}",
                if j.len() == 1 { "" } else { "s" },
                j.iter()
                    .map(|j| (j + 1).to_string())
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
        }
    }
}

/// An exact closed form without a solution: no branch reaches the pose.
fn out_of_reach() -> IkFailure {
    IkFailure::Unreachable(
        "the pose is out of the arm's reach (the closed form has no solution)".into(),
    )
}

/// A solution and the closed form's branch it comes from (none for a seeded solve).
#[derive(Debug, Clone)]
pub struct Solved {
    /// The solution (joints rad or mm, remaining errors, joints outside the limits).
    pub solution: IkSolution,
    /// The closed form's branch of the solution or of its start.
    pub branch: Option<Branch>,
}

/// The strategy over a model `M` (the robot's kinematic model, or a compensator in series with one),
/// with its reused buffers.
pub struct IkSolver<M: ToolModel> {
    model: M,
    start: IkStart,
    opts: IkOptions,
    ws: IkWorkspace,
    branches: Vec<(Branch, [f64; 6])>,
    copies: Vec<[f64; 6]>,
    mid: Vec<f64>,
    reach: Reach,
    /// Scratch of [`across_fold`] (6 x N).
    jac: Matrix6xX<f64>,
}

/// Largest joint change (rad, mm) a polish of a closed-form solution may make: the closed
/// form near a singularity is off by the square root of the rounding (1e-8), never by this.
const POLISH_STEP: f64 = 1e-3;

/// Fractions of a target's distance from the reach's anchor by which a pose the nominal
/// closed form cannot reach is moved toward (or away from) the anchor, in turn, to find
/// starts ([`IkSolver::pulled_starts`]). A calibration changes an arm's length by millimetres
/// in metres, about 1e-3, but a start moved that little lies at the nominal's stretched
/// elbow, a singularity from which the solve cannot bend it back (it stalled there, 18 mm off,
/// where a start moved by 1 % converges).
const PULLS: [f64; 3] = [1e-2, 3e-2, 1e-1];

/// Starts of the last-resort search ([`IkSolver`]'s `refined`), spread over the turn around
/// the reference ([`around`]): where no start a nominal's closed form gives converges within
/// the limits, where no branch of the nominal reaches the pose, or where two branches' starts
/// led to one solution. Next to a singularity a calibrated arm's solutions can lie where no branch's
/// start leads (next to the shoulder singularity of a UR10 with four times a real
/// calibration's deviations, 20 of 3000 poses had no solution without it, and 172 did not
/// list their own configuration; 95 with it). Where a start converges one time in three (as
/// there), 16 all fail one time in 650. Only such poses pay for it, each solve at most
/// [`SEARCH_ITERATIONS`] iterations: 1.7 % of random poses of a calibrated UR10, but 27 % of
/// poses made by the nominal with its wrist straight (q5 = 0: its two wrist flips give one
/// start, and the arm's flip is found in one search of nine, 0.45 ms each); a pose no start
/// reaches (inside the shoulder's cylinder) costs 16 short solves, about 1 ms on a rigid
/// model. A pose whose every solution leaves the limits pays it too (after the solves from
/// those solutions moved within the limits, [`LIMIT_INSET`]): on a calibrated FANUC drawn 15 %
/// of each range beyond its limits, 2940 such poses of 5000 took 1.7 s instead of 0.5 s.
const SEARCH_STARTS: usize = 16;

/// Iterations of a search solve at most: from the spread starts, solves that converged took 8
/// to 34 iterations but for 2 of 74 (72 and 74), on the UR10 with four times a calibration's
/// deviations next to its shoulder singularity; a start that needs more is one of many.
const SEARCH_ITERATIONS: usize = 40;

/// How far inside its limits (a fraction of its range) a joint of a solution outside them is
/// moved to start a solve that should end within them ([`Robot::moved_within_limits`]): next
/// to a straight elbow a calibrated arm's two elbow solutions can lie a few degrees apart, one
/// just inside a limit and the other just outside it, and every closed-form start led to the
/// one outside. On a UR10 with four times a calibration's deviations, its elbow within [0,
/// 160] deg, 23 of 20,000 configurations drawn within the limits read outside-limits before;
/// the spread search alone solved 19 of them, these starts alone 20, both all 23.
const LIMIT_INSET: f64 = 0.01;

/// The solutions a run of solves found, and the failure to report where there are none.
struct Found {
    /// Distinct solutions within the limits.
    sols: Vec<IkSolution>,
    /// The joint distance from the reference of the nearest solution outside the limits
    /// (infinite where there is none).
    nearest_outside: f64,
    /// The failure where `sols` is empty.
    failure: IkFailure,
    /// Distinct solutions outside the limits (joints, rad or mm).
    outside: Vec<Vec<f64>>,
}

/// The closed form's branches: 2 shoulders x 2 elbows x 2 wrists.
const BRANCHES: usize = 8;

/// Iterations of [`IkSolver::tracked`] at most: it contracts by about a calibration's
/// relative size (1e-3) each step, so a few settle it; near a singularity of the branch it
/// slows, and a start it has not settled is used as the closed form gave it.
const TRACK_ITERATIONS: usize = 50;

/// How near the target (mm, rad) a settled [`IkSolver::tracked`] point must bring the tool
/// to start a numerical solve. A settled step of 1e-9 rad leaves about 1e-6 mm at 1 m; a fixed
/// point where the branch's nearest stood in for a solution misses by the gap. On a
/// calibrated UR10, gaps of 0.02-0.4 mm next to a straight elbow led the solve to solutions a
/// multistart found, and gaps of 6-230 mm (branches out of reach) to failed solves, which
/// cost a numerical solve's every iteration each.
const TRACK_REACHED_MM: f64 = 1.0;
const TRACK_REACHED_RAD: f64 = 1e-3;

/// Largest joint change (rad) of a settled [`IkSolver::tracked`] step: the numerical solve
/// that follows converges from there in one or two iterations.
const TRACK_STEP: f64 = 1e-9;

/// How far beyond the model's [`Reach`] a target must lie to be refused before any solve: a
/// compensator's correction (millimetres) moves the tool beyond its robot's bound by far less.
pub const REACH_MARGIN: f64 = 1.1;

impl<M: ToolModel> IkSolver<M> {
    /// A solver of `model` starting as `start` says, numerical solves to `opts`.
    pub fn new(model: M, start: IkStart, opts: IkOptions) -> Self {
        let robot = model.robot();
        let ws = IkWorkspace::new(robot);
        let mid = robot.mid_joints();
        let reach = Reach::of(robot);
        let jac = Matrix6xX::zeros(robot.dof());
        IkSolver {
            model,
            start,
            opts,
            ws,
            branches: Vec::with_capacity(8),
            copies: Vec::new(),
            mid,
            reach,
            jac,
        }
    }

    /// A target beyond [`REACH_MARGIN`] times the model's reach as a failure saying how far.
    fn check_reach(&self, target: &Pose) -> std::result::Result<(), IkFailure> {
        let d = self.reach.distance_mm(&target.translation.vector);
        let bound = self.reach.bound_mm;
        if d > REACH_MARGIN * bound {
            return Err(IkFailure::OutOfReach(format!(
                "the target is {d:.0} mm from the robot's base and the arm reaches at most \
                 {bound:.0} mm from it"
            )));
        }
        Ok(())
    }

    /// The model solved for.
    pub fn model(&mut self) -> &mut M {
        &mut self.model
    }

    /// Where the solves start.
    pub fn start(&self) -> &IkStart {
        &self.start
    }

    /// The middle of the model's joint ranges (rad, mm): the reference without a seed.
    pub fn mid(&self) -> &[f64] {
        &self.mid
    }

    /// The closed form's solutions for `target` (on one of `branches` if any are given),
    /// each in its copy nearest `reference`, ordered: within the limits first, then by
    /// distance.
    fn starts(
        &mut self,
        target: &Pose,
        reference: &[f64],
        branches: &[Branch],
    ) -> Vec<(bool, f64, Branch, [f64; 6])> {
        let Some(ik) = self.start.closed_form() else {
            return Vec::new();
        };
        ik.solve_branches_near(target, reference, &mut self.branches);
        let mut starts: Vec<(bool, f64, Branch, [f64; 6])> = self
            .branches
            .iter()
            .filter(|(b, _)| branches.is_empty() || branches.contains(b))
            .map(|(b, q)| {
                let (c, inside) = ik.nearest_copy(q, reference);
                (!inside, joint_distance(&c, reference), *b, c)
            })
            .collect();
        starts.sort_by(|a, b| a.0.cmp(&b.0).then(a.1.total_cmp(&b.1)));
        starts
    }

    /// The closed form's solution `q` of `target` as a solution, polished ([`Self::polished`]).
    fn exact(&mut self, target: &Pose, q: &[f64], branch: Option<Branch>) -> Solved {
        Solved {
            solution: self.polished(target, q),
            branch,
        }
    }

    /// The closed form's solution `q` of `target` with its errors; where they exceed the
    /// numerical solve's tolerances ([`IkOptions`]: 1e-9 mm, 1e-12 rad), the numerical solve
    /// from `q` instead when it converges without leaving more limits. Near a singularity the
    /// closed form keeps only about half the digits (a joint it takes from a square root): a
    /// helper measured 5e-5 mm with axes 2 and 3 tilted by 7e-8 rad, below the tilt at which
    /// the closed form is refused. Within [`super::ik_closed::WRIST_ALIGNED`] of a straight wrist, where the
    /// closed form puts q5 on the singularity, the solve converges only from the split of q4
    /// and q6 the pose has (a seed's); from another split the pose is about q5 times the
    /// wrist-to-tool distance away (4e-6 mm at 1.7e-8 rad and 200 mm) and no step lowers it.
    fn polished(&mut self, target: &Pose, q: &[f64]) -> IkSolution {
        let p = self.model.pose(q);
        let robot = self.model.robot();
        let closed = IkSolution {
            q: q.to_vec(),
            iterations: 0,
            position_error_mm: (target.translation.vector - p.translation.vector).norm(),
            rotation_error_rad: angle_between(&target.rotation, &p.rotation),
            outside_limits: robot.joints_outside_limits(q),
        };
        if closed.position_error_mm <= self.opts.tol_position_mm
            && closed.rotation_error_rad <= self.opts.tol_rotation_rad
        {
            return closed;
        }
        match self.refine(target, q) {
            // The same solution, closer: not a whole turn away (the solve wraps a joint that
            // ends a rounding beyond its limit) nor beyond a limit the closed form kept.
            Ok(sol)
                if sol
                    .q
                    .iter()
                    .zip(q)
                    .all(|(a, b)| (a - b).abs() < POLISH_STEP)
                    && (sol.outside_limits.iter()).all(|j| closed.outside_limits.contains(j)) =>
            {
                sol
            }
            _ => closed,
        }
    }

    fn refine(&mut self, target: &Pose, start: &[f64]) -> Result<IkSolution> {
        self.refine_within(target, start, self.opts.max_iterations)
    }

    /// [`Self::refine`] in at most `iterations` iterations.
    fn refine_within(
        &mut self,
        target: &Pose,
        start: &[f64],
        iterations: usize,
    ) -> Result<IkSolution> {
        let opts = IkOptions {
            max_iterations: iterations.min(self.opts.max_iterations),
            ..self.opts
        };
        solve_model(
            &mut self.model,
            &IkTarget::Pose(*target),
            start,
            &opts,
            &mut self.ws,
        )
    }

    /// A seed of the wrong length as a failure (before it reaches an index).
    fn check_seed(&self, seed: Option<&[f64]>) -> std::result::Result<(), IkFailure> {
        match seed {
            Some(s) if s.len() != self.mid.len() => Err(IkFailure::BadSeed(format!(
                "{} seed joints for a robot with {}",
                s.len(),
                self.mid.len()
            ))),
            _ => Ok(()),
        }
    }

    /// Why there is no start at all: no closed-form solution, and no seed.
    fn no_start(&self) -> IkFailure {
        match self.start {
            IkStart::Seed(_) => IkFailure::NoSeed,
            _ => IkFailure::Unreachable(
                "the closed form of the nominal model has no solution".into(),
            ),
        }
    }

    /// Every distinct converged solution within the limits, one numerical solve from the
    /// seed (when given) and from each closed-form start, and from each solution's reflection
    /// across a fold near it ([`across_fold`]); where every solution found leaves
    /// the limits, from each moved within them ([`LIMIT_INSET`]); where a nominal's closed
    /// form gave starts and none converged within the limits, where no branch of it reaches
    /// the pose, or where the solves found fewer distinct solutions than it has branches
    /// there, from [`SEARCH_STARTS`] starts spread over the turn around the reference too.
    /// The failure when none.
    fn refined(
        &mut self,
        target: &Pose,
        seed: Option<&[f64]>,
        reference: &[f64],
    ) -> std::result::Result<Vec<IkSolution>, IkFailure> {
        let mut starts: Vec<Vec<f64>> = seed.map(<[f64]>::to_vec).into_iter().collect();
        let closed = self.starts(target, reference, &[]);
        let present: Vec<Branch> = closed.iter().map(|(_, _, b, _)| *b).collect();
        let carried = self.carried(target, closed);
        starts.extend(carried);
        // A calibrated arm a little longer (or shorter) than the nominal reaches poses just
        // beyond the nominal's reach, on some branches or on all: those branches start at
        // their nearest to the pose, carried onto the model's solution where there is one.
        let beyond = self.beyond_starts(target, reference, &present);
        let none_yet = beyond.is_empty();
        starts.extend(beyond);
        let nominal = matches!(self.start, IkStart::Nominal(_));
        // Where no branch reaches the pose, the closed form's solutions of the same pose moved
        // a little toward (or away from) the base start numerical solves too: the pull that
        // gave them, if one did.
        let mut past_reach = false;
        let pulled = if present.is_empty() && nominal {
            let found = self.pulled_starts(target, reference);
            past_reach = found.is_none() && none_yet && seed.is_none();
            found.map(|(pull, joints)| {
                starts.extend(joints);
                pull
            })
        } else {
            None
        };
        if starts.is_empty() && !nominal {
            return Err(self.no_start());
        }
        let mut found = Found {
            sols: Vec::new(),
            nearest_outside: f64::INFINITY,
            failure: self.no_start(),
            outside: Vec::new(),
        };
        let all = self.opts.max_iterations;
        for q0 in &starts {
            self.solve_start(target, q0, reference, all, &mut found);
        }
        // Fewer distinct solutions than the nominal has branches at the pose: two branches'
        // starts led to one solution, as where a calibrated arm's solutions crowd next to a
        // singularity. Counted before the reflections' and the moved starts' solutions, which
        // need not be those the search would find (counted after, a UR10 with four times a
        // calibration's deviations lost 2 solutions of a pose next to its shoulder).
        let crowded = found.sols.len() + found.outside.len() < present.len();
        // Next to a fold (a straight elbow, the shoulder's cylinder) the pose's other solution
        // there lies across it, where the nominal's starts may not lead: each solution's
        // reflection across a fold within reach starts a solve.
        let mut solved: Vec<Vec<f64>> = found.sols.iter().map(|s| s.q.clone()).collect();
        solved.extend(found.outside.iter().cloned());
        for q in solved {
            if let Some(q0) = self.reflected(&q) {
                self.solve_start(target, &q0, reference, SEARCH_ITERATIONS, &mut found);
            }
        }
        // Every solution found leaves the limits: each moved within them starts a solve (next
        // to a singularity the arm's solution within the limits can lie a degree from one
        // outside them that every start led to).
        if found.sols.is_empty() && !found.outside.is_empty() {
            for q in std::mem::take(&mut found.outside) {
                let q0 = self.model.robot().moved_within_limits(&q, LIMIT_INSET);
                found.outside.push(q);
                self.solve_start(target, &q0, reference, all, &mut found);
            }
        }
        let searched = nominal && (crowded || present.is_empty() || found.sols.is_empty());
        if searched {
            let outside = found.nearest_outside;
            let failure = std::mem::replace(&mut found.failure, self.no_start());
            for k in 0..SEARCH_STARTS {
                let q0 = around(self.model.robot(), reference, k);
                self.solve_start(target, &q0, reference, SEARCH_ITERATIONS, &mut found);
            }
            // Where the search found a solution outside the limits nearer the reference than
            // any before, it names the failure; else the structured starts' failure stands
            // (not a search solve's that did not converge).
            if found.nearest_outside == outside {
                found.failure = failure;
            }
        }
        let search_note = if searched {
            format!(
                "; nor do solves from {SEARCH_STARTS} starts spread over the joints' turns \
                 around the {}",
                if seed.is_some() {
                    "seed"
                } else {
                    "middle of the ranges"
                }
            )
        } else {
            String::new()
        };
        match (found.failure, pulled) {
            _ if !found.sols.is_empty() => Ok(found.sols),
            _ if past_reach && found.nearest_outside.is_infinite() => {
                Err(IkFailure::Unreachable(format!(
                    "the closed form of the nominal model has no solution, for the pose nor for \
                     it moved by up to {:.0} % of its distance toward or away from the base{search_note}: \
                     no configuration of this model found reaches it",
                    PULLS[PULLS.len() - 1] * 100.0
                )))
            }
            (IkFailure::NotConverged(why), Some(moved)) => Err(IkFailure::Unreachable(format!(
                "the closed form of the nominal model has no solution (the pose is beyond \
                     its reach), and solves from the nearest poses it reaches (moved by {:.0} % \
                     of the distance toward or away from the base){} do not reach it on this \
                     model either: {why}{search_note}",
                moved * 100.0,
                if seed.is_some() {
                    " and from the seed"
                } else {
                    ""
                },
            ))),
            (IkFailure::NotConverged(why), None) => {
                Err(IkFailure::NotConverged(format!("{why}{search_note}")))
            }
            (IkFailure::Unreachable(why), None) => {
                Err(IkFailure::Unreachable(format!("{why}{search_note}")))
            }
            (failure, _) => Err(failure),
        }
    }

    /// One numerical solve of `target` from `q0` (at most `iterations` iterations), its
    /// solution in the whole-turn copy nearest `reference`, added to `found`: a new solution
    /// within the limits to its solutions, else (the nearest `reference` of those outside the
    /// limits, or a solve that did not converge where none has converged) as its failure.
    fn solve_start(
        &mut self,
        target: &Pose,
        q0: &[f64],
        reference: &[f64],
        iterations: usize,
        found: &mut Found,
    ) {
        let solved = self.refine_within(target, q0, iterations).map(|mut sol| {
            // The solve ends in whichever whole-turn copy its steps reach.
            let robot = self.model.robot();
            if let Some(q) = robot.turns_near(&sol.q, reference) {
                sol.outside_limits = robot.joints_outside_limits(&q);
                sol.q = q;
            }
            sol
        });
        match solved {
            Ok(sol) if sol.outside_limits.is_empty() => {
                if !found.sols.iter().any(|o| same_solution(&o.q, &sol.q)) {
                    found.sols.push(sol);
                }
            }
            Ok(sol) => {
                if !found.outside.iter().any(|o| same_solution(o, &sol.q)) {
                    found.outside.push(sol.q.clone());
                }
                let d = joint_distance(&sol.q, reference);
                if d < found.nearest_outside {
                    found.nearest_outside = d;
                    found.failure = IkFailure::OutsideLimits(sol.outside_limits);
                }
            }
            Err(e) if found.nearest_outside.is_infinite() => {
                found.failure = IkFailure::NotConverged(e.to_string())
            }
            Err(_) => {}
        }
    }

    /// Solution `q` reflected across a fold of the model within [`super::fold::FOLD_NEAR_RAD`]
    /// ([`across_fold`]), if any.
    fn reflected(&mut self, q: &[f64]) -> Option<Vec<f64>> {
        across_fold(&mut self.model, q, self.opts.length_scale_mm, &mut self.jac)
    }

    /// The starts of the closed-form solutions `found` ([`Self::starts`]) for `target`: each
    /// carried onto the model's solution on its branch where [`Self::tracked`] settles, and
    /// each as it is (next to a singularity the model can have solutions the nominal has not,
    /// a calibrated UR10 four near one nominal elbow pair, which a solve from there can find;
    /// every start of the code before the carrying still runs).
    fn carried(
        &mut self,
        target: &Pose,
        found: Vec<(bool, f64, Branch, [f64; 6])>,
    ) -> Vec<Vec<f64>> {
        let mut joints = Vec::with_capacity(2 * found.len());
        for (_, _, b, q) in found {
            if let Some(t) = self.tracked(target, b, &q) {
                joints.push(t.to_vec());
            }
            joints.push(q.to_vec());
        }
        joints
    }

    /// The nominal closed form's solution `q` (rad) of `target` on `branch` (or its nearest)
    /// carried onto the model's solution on that branch: the fixed point of
    /// q <- N_b^-1(target E(q)^-1), with N_b^-1 the closed form's solution on the branch (its
    /// nearest where the branch does not reach the pose: [`ClosedFormIk::solve_branch_nearest`])
    /// and E(q) = N(q)^-1 T(q) the model's tool pose T relative to the nominal's N. At the
    /// fixed point N(q) = target E(q)^-1, so T(q) = target. E is a calibration's few
    /// millimetres and milliradians and varies slowly with q, so the iteration contracts by
    /// about its relative size each step. A numerical solve from the nominal's solution
    /// instead can cross to another branch's solution or stall between two where they lie
    /// close together (an elbow near straight), and where the nominal's branch does not reach
    /// the pose (at the edge of the reach, which the calibrated arm's extends by
    /// millimetres) there is no solution of the nominal to start from. None for a model with
    /// its own closed form (nothing to carry), where the branch has no nearest either, or
    /// where the iteration does not settle within [`TRACK_ITERATIONS`]. The numerical solve
    /// from its result checks it.
    fn tracked(&mut self, target: &Pose, branch: Branch, q: &[f64; 6]) -> Option<[f64; 6]> {
        let IkStart::Nominal(ik) = &self.start else {
            return None;
        };
        let mut q = *q;
        let mut last = f64::INFINITY;
        let mut growing = 0;
        for _ in 0..TRACK_ITERATIONS {
            let relative = ik.pose(&q).inverse() * self.model.pose(&q);
            let next = ik.solve_branch_nearest(&(target * relative.inverse()), branch, &q)?;
            // The copy of each joint nearest the last, a straight wrist's split nearest its.
            let next = ik.wrist_split_nearest(&next, &q);
            let mut step = 0f64;
            for (now, next) in q.iter_mut().zip(next) {
                let d = wrap(next - *now);
                *now += d;
                step = step.max(d.abs());
            }
            if step <= TRACK_STEP {
                // A fixed point where the branch's nearest stood in for a solution misses the
                // pose by the gap: where that is a fraction of a millimetre (an elbow or
                // shoulder next to straight, where the model's two solutions can lie on one
                // side of the nominal's singularity) the numerical solve from it finds one,
                // where it is more the branch does not reach the pose on this model either.
                let reached = self.model.pose(&q);
                let off = (target.translation.vector - reached.translation.vector).norm();
                let turned = angle_between(&target.rotation, &reached.rotation);
                return (off <= TRACK_REACHED_MM && turned <= TRACK_REACHED_RAD).then_some(q);
            }
            // An iteration that does not contract (a branch that leaves toward another
            // solution, or none) is given up after a second step that does not shrink.
            growing = if step >= last { growing + 1 } else { 0 };
            if growing >= 2 {
                return None;
            }
            last = step;
        }
        None
    }

    /// The starts of the branches the nominal's closed form does not reach at `target` (not
    /// in `present`): each branch's nearest ([`ClosedFormIk::solve_branches_nearest`]) in the
    /// copy nearest `reference`, carried onto the model's solution of `target` on that branch
    /// ([`Self::tracked`]), where that settles.
    fn beyond_starts(
        &mut self,
        target: &Pose,
        reference: &[f64],
        present: &[Branch],
    ) -> Vec<Vec<f64>> {
        let IkStart::Nominal(ik) = &self.start else {
            return Vec::new();
        };
        if present.len() >= BRANCHES {
            return Vec::new();
        }
        ik.solve_branches_nearest(target, reference, &mut self.branches);
        let nearest: Vec<(Branch, [f64; 6])> = (self.branches.iter())
            .filter(|(b, _)| !present.contains(b))
            .map(|(b, q)| (*b, ik.nearest_copy(q, reference).0))
            .collect();
        (nearest.into_iter())
            .filter_map(|(b, q)| self.tracked(target, b, &q))
            .map(|q| q.to_vec())
            .collect()
    }

    /// The closed form's solutions (each in its copy nearest `reference`) of `target` moved
    /// toward the reach's anchor, or away from it, by the first fraction of [`PULLS`] of its
    /// distance at which there are any, with that fraction: starts for a model that reaches
    /// a little farther (or nearer) than the closed form's. Each starts as it is, and carried
    /// onto the model's solution of `target` on its branch where [`Self::tracked`] settles.
    /// None where no pull gives any.
    fn pulled_starts(&mut self, target: &Pose, reference: &[f64]) -> Option<(f64, Vec<Vec<f64>>)> {
        let anchor = self.reach.anchor;
        let v = target.translation.vector - anchor;
        for pull in PULLS {
            for sign in [-1.0, 1.0] {
                let mut moved = *target;
                moved.translation.vector = anchor + v * (1.0 + sign * pull);
                let found = self.starts(&moved, reference, &[]);
                if !found.is_empty() {
                    return Some((pull, self.carried(target, found)));
                }
            }
        }
        None
    }

    /// The solution within the limits nearest `seed` (or the middle of the ranges), by
    /// [`joint_distance`]: for an exact closed form the nearest of its solutions; else the
    /// nearest of the numerical solves from the seed and from every closed-form start.
    pub fn nearest(
        &mut self,
        target: &Pose,
        seed: Option<&[f64]>,
    ) -> std::result::Result<Solved, IkFailure> {
        self.check_seed(seed)?;
        self.check_reach(target)?;
        let reference = seed.map_or_else(|| self.mid.clone(), <[f64]>::to_vec);
        if let IkStart::Exact(_) = self.start {
            let starts = self.starts(target, &reference, &[]);
            return match starts.first() {
                Some((false, _, b, q)) => Ok(self.exact(target, q, Some(*b))),
                Some((true, _, _, q)) => Err(IkFailure::OutsideLimits(
                    self.model.robot().joints_outside_limits(q),
                )),
                None => Err(out_of_reach()),
            };
        }
        let sols = self.refined(target, seed, &reference)?;
        let best = sols
            .into_iter()
            .min_by(|a, b| {
                joint_distance(&a.q, &reference).total_cmp(&joint_distance(&b.q, &reference))
            })
            .expect("refined returns at least one solution");
        Ok(Solved {
            solution: best,
            branch: None,
        })
    }

    /// Every distinct solution within the limits, nearest `seed` (or the middle of the
    /// ranges) first, by [`joint_distance`]: for an exact closed form every whole-turn copy
    /// the limits allow (as [`Self::all`]), else the candidates of [`Self::nearest`].
    pub fn ranked(
        &mut self,
        target: &Pose,
        seed: Option<&[f64]>,
    ) -> std::result::Result<Vec<IkSolution>, IkFailure> {
        self.check_seed(seed)?;
        self.check_reach(target)?;
        let reference = seed.map_or_else(|| self.mid.clone(), <[f64]>::to_vec);
        let mut sols = match self.start {
            IkStart::Exact(_) => self.exact_copies(target, &reference)?,
            _ => self.refined(target, seed, &reference)?,
        };
        sols.sort_by(|a, b| {
            joint_distance(&a.q, &reference).total_cmp(&joint_distance(&b.q, &reference))
        });
        Ok(sols)
    }

    /// An exact closed form's every whole-turn copy within the limits of its solutions of
    /// `target` (a straight wrist split nearest `reference`), polished; the failure when none
    /// (the nearest start's joints outside the limits, or none at all).
    fn exact_copies(
        &mut self,
        target: &Pose,
        reference: &[f64],
    ) -> std::result::Result<Vec<IkSolution>, IkFailure> {
        let IkStart::Exact(ik) = &self.start else {
            return Err(self.no_start());
        };
        if !ik.solve_around(target, reference, &mut self.copies) {
            return Err(IkFailure::TooMany);
        }
        if self.copies.is_empty() {
            return Err(match self.starts(target, reference, &[]).first() {
                Some((_, _, _, q)) => {
                    IkFailure::OutsideLimits(self.model.robot().joints_outside_limits(q))
                }
                None => out_of_reach(),
            });
        }
        let copies = std::mem::take(&mut self.copies);
        let polished = (copies.iter()).map(|q| self.polished(target, q)).collect();
        self.copies = copies;
        Ok(polished)
    }

    /// One solve from the closed-form start nearest `seed` (or the middle of the ranges) on
    /// one of `branches` if any are given (the seed's: one, or both wrist flips at a straight
    /// wrist), within the limits if one is. The start's branch is the configuration kept
    /// (target compensation: the controller's), so no other start is tried; where the closed
    /// form has no solution the seed starts the solve, but only with `branches` (the seed's)
    /// to keep. The solution may leave the limits (see its `outside_limits`).
    pub fn from_nearest_start(
        &mut self,
        target: &Pose,
        seed: Option<&[f64]>,
        branches: &[Branch],
    ) -> std::result::Result<Solved, IkFailure> {
        self.check_seed(seed)?;
        self.check_reach(target)?;
        let reference = seed.map_or_else(|| self.mid.clone(), <[f64]>::to_vec);
        let (b, q0) = match self.starts(target, &reference, branches).first() {
            Some((_, _, b, q)) => (Some(*b), self.tracked(target, *b, q).unwrap_or(*q).to_vec()),
            None => match seed {
                Some(s) if !branches.is_empty() => (None, s.to_vec()),
                _ => return Err(self.no_start()),
            },
        };
        if let IkStart::Exact(_) = self.start
            && b.is_some()
        {
            return Ok(self.exact(target, &q0, b));
        }
        let solution = self
            .refine(target, &q0)
            .map_err(|e| IkFailure::NotConverged(e.to_string()))?;
        Ok(Solved {
            solution,
            branch: b,
        })
    }

    /// One numerical solve from `start` (rad, mm) as given: a seed's own configuration,
    /// where the closed-form start near it leads to another (near a singularity, where the
    /// model and the closed form's robot put a joint on either side of it). The solution may
    /// leave the limits (see its `outside_limits`).
    pub fn from_start(
        &mut self,
        target: &Pose,
        start: &[f64],
    ) -> std::result::Result<IkSolution, IkFailure> {
        self.check_seed(Some(start))?;
        self.check_reach(target)?;
        self.refine(target, start)
            .map_err(|e| IkFailure::NotConverged(e.to_string()))
    }

    /// Every distinct solution within the limits: for an exact closed form every whole-turn
    /// copy the limits allow (at most [`MAX_SOLUTIONS`]); else one numerical solve from the
    /// seed and from each closed-form start.
    pub fn all(
        &mut self,
        target: &Pose,
        seed: Option<&[f64]>,
    ) -> std::result::Result<Vec<Vec<f64>>, IkFailure> {
        self.check_seed(seed)?;
        self.check_reach(target)?;
        if let IkStart::Exact(_) = self.start {
            let reference = seed.map_or_else(|| self.mid.clone(), <[f64]>::to_vec);
            let copies = self.exact_copies(target, &reference)?;
            return Ok(copies.into_iter().map(|s| s.q).collect());
        }
        let reference = seed.map_or_else(|| self.mid.clone(), <[f64]>::to_vec);
        Ok(self
            .refined(target, seed, &reference)?
            .into_iter()
            .map(|s| s.q)
            .collect())
    }
}
