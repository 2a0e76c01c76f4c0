//! The solution a controller that solves near the joints it is given runs for a commanded
//! pose, where robocal knows no closed form of its model (a UR-class model has one, and is
//! solved exactly instead): the solution nearest those joints (as URScript's
//! `get_inverse_kin(pose, qnear)`).
//!
//! One numerical solve from the seed finds a solution, not the nearest: from a seed far from
//! every solution it can run past a nearer configuration to another (an elbow or a wrist
//! flipped). The solutions are searched here from the seed, from the solution in hand and from
//! [`SPREAD`] starts spread over the turn around the seed (a fixed low-discrepancy set,
//! `kinematics::spread::around`); each revolute joint's whole turns are
//! then taken nearest the seed within the limits ([`Robot::turns_near`]), as a controller
//! choosing near the seed takes them. A search, not a closed form: a solution no start reaches is not seen, so the
//! search runs only where the seed leaves room for one (a command far from its seed).

use super::model::CalibratedModel;
use crate::kinematics::spread::around;
use crate::kinematics::{IkSolver, Pose};
use crate::model::{Robot, joint_distance};

/// Starts spread over the turn around the seed, besides the seed and the solution in hand.
pub const SPREAD: usize = 64;

/// Joints (rad, mm) closer than this are one solution.
const SAME: f64 = 1e-6;

/// The solution of `pose` (mm, in the frame of `solver`'s model, `robot`) nearest `seed`
/// (rad, mm) that the search finds, its turns nearest the seed within the limits; `known` (a
/// solution in hand) starts a solve too. None where no start converges within the limits.
pub fn nearest_solution(
    solver: &mut IkSolver<CalibratedModel<'_>>,
    robot: &Robot,
    pose: &Pose,
    seed: &[f64],
    known: &[f64],
) -> Option<Vec<f64>> {
    let starts = [seed.to_vec(), known.to_vec()]
        .into_iter()
        .chain((0..SPREAD).map(|k| around(robot, seed, k)));
    let mut best: Option<(f64, Vec<f64>)> = None;
    for start in starts {
        let Ok(sol) = solver.from_start(pose, &start) else {
            continue;
        };
        let Some(q) = robot.turns_near(&sol.q, seed) else {
            continue;
        };
        let d = joint_distance(&q, seed);
        if best.as_ref().is_none_or(|(b, _)| d < *b - SAME) {
            best = Some((d, q));
        }
    }
    best.map(|(_, q)| q)
}
