//! Configurations spread over the joints' ranges by a fixed low-discrepancy sequence: the
//! configurations `same_arm` compares two models at, and the starts of the searches that
//! look for solutions where no closed form gives one (`IkSolver`'s last resort, and
//! `compensation::nearest`'s search for a controller's nearest solution).

use crate::model::{JointType, Robot};
use std::f64::consts::TAU;

/// Joint `j` of configuration `k` (of robots with `n` joints) in a fixed low-discrepancy
/// spread: the fraction ((k n + j) phi + 0.25) mod 1 of its range, phi the golden ratio's
/// fractional part.
pub fn spread(k: usize, n: usize, j: usize) -> f64 {
    ((k * n + j) as f64 * 0.618_033_988_749_895 + 0.25).fract()
}

/// Start `k` of a search around `centre` (rad, mm): each revolute joint at its fraction
/// ([`spread`]) of the turn centred on `centre`'s (one turn holds every configuration; the
/// caller takes whole turns within the limits), a prismatic joint at its fraction of its
/// range.
pub fn around(robot: &Robot, centre: &[f64], k: usize) -> Vec<f64> {
    let n = robot.dof();
    (robot.joints().iter().enumerate())
        .map(|(j, joint)| {
            let t = spread(k, n, j);
            if joint.joint_type == JointType::Prismatic {
                let [lo, hi] = joint.limits_internal();
                lo + (hi - lo) * t
            } else {
                centre[j] + TAU * (t - 0.5)
            }
        })
        .collect()
}
