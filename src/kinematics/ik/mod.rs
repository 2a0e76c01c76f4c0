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
//! 3. The caller's seed joints start a numerical solve too (where no closed form gives a
//!    start, [`IkStart::Seed`], the first; a pose out of the nominal's reach on every branch
//!    has its solutions of the pose pulled a little toward the base as starts too).
//! 4. Each solution found within [`super::fold::FOLD_NEAR_RAD`] of a fold of the model (a
//!    straight elbow, the shoulder's cylinder) starts a solve from its reflection across the
//!    fold ([`across_fold`](super::fold::across_fold)): the pose's other solution there, which the nominal's starts
//!    of a calibrated arm, whose fold lies off the nominal's, may not lead to.
//! 5. Where every solution the solves found leaves the limits, each moved within them
//!    ([`Robot::moved_within_limits`]) starts a solve too.
//! 6. Where a nominal's closed form gave the starts and no solve from them converged within
//!    the limits, where no branch of the nominal reaches the pose (its starts are then only
//!    the pulled and nearest ones), or where they found fewer distinct solutions than the
//!    nominal has branches at the pose, starts spread over the joints' turns around the
//!    reference ([`super::spread::around`]) are tried too: next to a singularity a
//!    calibrated arm can have solutions no branch's start leads to. Where no closed form
//!    gives a start, more of them (64) are tried before steps 4 and 5: around the middle of
//!    the ranges, the only starts without a seed; around the seed, where its solve found no
//!    solution within the limits.
//!
//! The reference is the seed when one is given, else the middle of the joint ranges.
//! [`IkSolver::nearest`] (`robocal ik`) refines the seed and every start and returns the
//! converged solution within the limits nearest the reference; [`IkSolver::all`] every
//! distinct one; [`IkSolver::from_nearest_start`] (target compensation) solves once from the
//! nearest start on a given branch, the configuration the controller keeps.

mod failure;
mod search;
mod track;

use super::ik_closed::{Branch, ClosedFormIk};
use super::ik_numeric::{IkOptions, IkSolution, IkTarget, IkWorkspace, ToolModel, solve_model};
use super::{Pose, Reach};
use crate::error::{Error, Result};
use crate::geometry::rotation::angle_between;
use crate::model::Robot;
pub use crate::model::joint_distance;
pub use failure::IkFailure;
use failure::out_of_reach;
use nalgebra::Matrix6xX;

/// Where the solves start.
#[derive(Debug, Clone)]
pub enum IkStart {
    /// The model's own closed form: exact solutions, no numerical solve.
    Exact(ClosedFormIk),
    /// A rigid model's closed form starts numerical solves of the model: the nominal's
    /// (placed at the model's base and tool), or for a compliant robot its own without the
    /// compliances.
    Nominal(ClosedFormIk),
    /// No closed form: the caller's seed starts the numerical solve, and starts spread around
    /// it (or the middle of the ranges) where it finds no solution; the text says why the
    /// model has no closed form.
    Seed(String),
}

impl IkStart {
    /// The model's own closed form when it has one; for a compliant robot, the closed form
    /// of its rigid self as the start of numerical solves; else `nominal`'s (an error when
    /// that has none or other joints); else the seed.
    ///
    /// A `nominal` that is not an arm of the robot's (other joints, or geometry beyond what
    /// a calibration moves: [`super::same_arm::another_arm`]) is refused whether or not it is
    /// needed: its starts would lead the solves to another arm's solutions.
    pub fn choose(robot: &Robot, nominal: Option<&Robot>) -> Result<IkStart> {
        if let Some(nom) = nominal {
            if !nom.same_joints(robot) {
                return Err(Error::Invalid(format!(
                    "the nominal model's joints differ from the robot's in number or type ({} and {} joints)",
                    nom.dof(),
                    robot.dof()
                )));
            }
            if let Some(gap) = super::same_arm::another_arm(nom, robot) {
                return Err(Error::Invalid(format!(
                    "the robot is not a calibration of the nominal model: {gap}: give this \
                     robot's nominal model"
                )));
            }
        }
        let own = if robot.is_compliant() {
            ClosedFormIk::new(&robot.rigid()).map(IkStart::Nominal)
        } else {
            ClosedFormIk::new(robot).map(IkStart::Exact)
        };
        match own {
            Ok(start) => Ok(start),
            Err(why) => match nominal {
                Some(nom) => {
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
    /// Scratch of [`across_fold`](crate::kinematics::fold::across_fold) (6 x N).
    jac: Matrix6xX<f64>,
}

/// Largest joint change (rad, mm) a polish of a closed-form solution may make: the closed
/// form near a singularity is off by the square root of the rounding (1e-8), never by this.
const POLISH_STEP: f64 = 1e-3;

pub use super::reach::REACH_MARGIN;

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
        let finite = (target.translation.vector.iter())
            .chain(target.rotation.matrix().iter())
            .all(|v| v.is_finite());
        if !finite {
            return Err(IkFailure::Unreachable(
                "the target pose is not finite".into(),
            ));
        }
        if !self.reach.holds(&target.translation.vector) {
            let d = self.reach.distance_mm(&target.translation.vector);
            let bound = self.reach.bound_mm;
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
            // A seed not finite picks no branch (every distance NaN) and starts no solve.
            Some(s) if s.iter().any(|v| !v.is_finite()) => {
                Err(IkFailure::BadSeed("a seed joint is not finite".into()))
            }
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
    /// the limits allow (as [`Self::all`]), else the candidates of [`Self::nearest`], each
    /// in its copy nearest the reference (where [`Self::all`] lists every copy).
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

    /// The branches of the closed form's solutions of `target`, in the order
    /// [`Self::from_nearest_start`] takes them without a seed: those whose solution lies
    /// within the limits first, each group nearest the middle of the ranges first. Empty
    /// without a closed form.
    pub fn start_branches(&mut self, target: &Pose) -> Vec<Branch> {
        let mid = self.mid.clone();
        self.starts(target, &mid, &[])
            .into_iter()
            .map(|s| s.2)
            .collect()
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

    /// Every distinct solution within the limits, with every whole-turn copy the limits allow
    /// (at most [`MAX_SOLUTIONS`](super::ik_closed::MAX_SOLUTIONS), else
    /// [`IkFailure::TooMany`]): an exact closed form's, or those of one numerical solve from
    /// the seed and from each closed-form start, each solution first and then its other
    /// copies, a copy kept where the model reaches the target there as at the solution (a
    /// model whose pose repeats when a revolute joint turns by 2 pi, as every kinematic model).
    pub fn all(
        &mut self,
        target: &Pose,
        seed: Option<&[f64]>,
    ) -> std::result::Result<Vec<Vec<f64>>, IkFailure> {
        self.check_seed(seed)?;
        self.check_reach(target)?;
        let reference = seed.map_or_else(|| self.mid.clone(), <[f64]>::to_vec);
        if let IkStart::Exact(_) = self.start {
            let copies = self.exact_copies(target, &reference)?;
            return Ok(copies.into_iter().map(|s| s.q).collect());
        }
        let misses = |model: &mut M, q: &[f64]| {
            let at = model.pose(q);
            let mm = (at.translation.vector - target.translation.vector).norm();
            (mm, angle_between(&at.rotation, &target.rotation))
        };
        let mut out = Vec::new();
        for s in self.refined(target, seed, &reference)? {
            let (mm, rad) = misses(&mut self.model, &s.q);
            let copies = turn_copies(self.model.robot(), &s.q);
            out.push(s.q);
            for copy in copies {
                let (c_mm, c_rad) = misses(&mut self.model, &copy);
                // Rounding moves a copy's pose by ~1e-12 mm; a model that does not repeat
                // over a turn (a network on the raw angles) misses by far more.
                if c_mm <= mm + COPY_SLACK_MM && c_rad <= rad + COPY_SLACK_RAD {
                    out.push(copy);
                }
            }
            if out.len() > super::ik_closed::MAX_SOLUTIONS {
                return Err(IkFailure::TooMany);
            }
        }
        Ok(out)
    }
}

/// How much farther (mm) a whole-turn copy of a solution may miss the target than the
/// solution and still be listed ([`IkSolver::all`]).
const COPY_SLACK_MM: f64 = 1e-9;
/// The same for the orientation (rad).
const COPY_SLACK_RAD: f64 = 1e-12;

/// The other whole-turn copies of `q` (rad, mm) within `robot`'s limits ([`Joint::turns`]):
/// its revolute joints moved by multiples of 2 pi, prismatic joints as they are; none where
/// `q` itself leaves a limit. At most a little past
/// [`MAX_SOLUTIONS`](super::ik_closed::MAX_SOLUTIONS), which the caller checks.
///
/// [`Joint::turns`]: crate::model::Joint::turns
fn turn_copies(robot: &Robot, q: &[f64]) -> Vec<Vec<f64>> {
    let Some(turns) = (robot.joints().iter().zip(q))
        .map(|(j, &v)| j.turns(v))
        .collect::<Option<Vec<(i64, i64)>>>()
    else {
        return Vec::new();
    };
    let tau = std::f64::consts::TAU;
    let mut out = Vec::new();
    let mut k: Vec<i64> = turns.iter().map(|t| t.0).collect();
    loop {
        if k.iter().any(|&x| x != 0) {
            out.push(
                (q.iter().zip(&k))
                    .map(|(v, &x)| v + x as f64 * tau)
                    .collect(),
            );
            if out.len() > super::ik_closed::MAX_SOLUTIONS {
                return out;
            }
        }
        // Odometer over the turn counts: the first that can still count up does, those
        // before it start again.
        let Some(j) = (0..k.len()).find(|&j| k[j] < turns[j].1) else {
            return out;
        };
        k[j] += 1;
        for (i, t) in turns.iter().enumerate().take(j) {
            k[i] = t.0;
        }
    }
}
