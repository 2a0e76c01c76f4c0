//! Starts carried from a nominal's closed form onto the model's solutions (step 2 of
//! [`super`]): each branch's solution tracked to the model's, the branches the nominal does
//! not reach started from their nearest, and poses beyond its reach pulled toward it.

use super::{IkSolver, IkStart};
use crate::geometry::rotation::angle_between;
use crate::kinematics::Pose;
use crate::kinematics::ik_closed::Branch;
use crate::kinematics::ik_numeric::ToolModel;
use crate::kinematics::subproblems::wrap;

/// Fractions of a target's distance from the reach's anchor by which a pose the nominal
/// closed form cannot reach is moved toward (or away from) the anchor, in turn, to find
/// starts ([`IkSolver::pulled_starts`]). A calibration changes an arm's length by millimetres
/// in metres, about 1e-3, but a start moved that little lies at the nominal's stretched
/// elbow, a singularity from which the solve cannot bend it back (it stalled there, 18 mm off,
/// where a start moved by 1 % converges).
pub(super) const PULLS: [f64; 3] = [1e-2, 3e-2, 1e-1];

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

impl<M: ToolModel> IkSolver<M> {
    /// The starts of the closed-form solutions `found` ([`Self::starts`]) for `target`: each
    /// carried onto the model's solution on its branch where [`Self::tracked`] settles, and
    /// each as it is (next to a singularity the model can have solutions the nominal has not,
    /// a calibrated UR10 four near one nominal elbow pair, which a solve from there can find;
    /// every start of the code before the carrying still runs).
    pub(super) fn carried(
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
    /// its own closed form (nothing to carry), where the branch has no nearest either, where
    /// the iteration does not settle within [`TRACK_ITERATIONS`], or where it stops
    /// contracting away from the pose ([`Self::near_target`]). The numerical solve from its
    /// result checks it.
    ///
    /// [`ClosedFormIk::solve_branch_nearest`]:
    /// crate::kinematics::ClosedFormIk::solve_branch_nearest
    pub(super) fn tracked(
        &mut self,
        target: &Pose,
        branch: Branch,
        q: &[f64; 6],
    ) -> Option<[f64; 6]> {
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
                return self.near_target(target, &q).then_some(q);
            }
            // An iteration that does not contract (a branch that leaves toward another
            // solution, or none) is given up after a second step that does not shrink, but
            // where it wanders within reach of the pose (the nominal's stretched elbow, where
            // its nearest on the branch jumps by 1e-7 rad from step to step; a calibrated
            // UR10's pose at q3 = 0, the model's fold 0.03 deg away, lost its configuration
            // and its wrist flip in 24 of 100 poses) it is a start as a settled one.
            growing = if step >= last { growing + 1 } else { 0 };
            if growing >= 2 {
                return self.near_target(target, &q).then_some(q);
            }
            last = step;
        }
        None
    }

    /// Whether the model's tool at `q` (rad) is within [`TRACK_REACHED_MM`] and
    /// [`TRACK_REACHED_RAD`] of `target`: near enough for a numerical solve to start.
    fn near_target(&mut self, target: &Pose, q: &[f64; 6]) -> bool {
        let reached = self.model.pose(q);
        let off = (target.translation.vector - reached.translation.vector).norm();
        let turned = angle_between(&target.rotation, &reached.rotation);
        off <= TRACK_REACHED_MM && turned <= TRACK_REACHED_RAD
    }

    /// The starts of the branches the nominal's closed form does not reach at `target` (not
    /// in `present`): each branch's nearest ([`ClosedFormIk::solve_branches_nearest`]) in the
    /// copy nearest `reference`, carried onto the model's solution of `target` on that branch
    /// ([`Self::tracked`]), where that settles.
    ///
    /// [`ClosedFormIk::solve_branches_nearest`]:
    /// crate::kinematics::ClosedFormIk::solve_branches_nearest
    pub(super) fn beyond_starts(
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
    pub(super) fn pulled_starts(
        &mut self,
        target: &Pose,
        reference: &[f64],
    ) -> Option<(f64, Vec<Vec<f64>>)> {
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
}
