//! How far the tool can get from the robot: a bound that tells a target out of reach from
//! one a numerical solve failed to reach.

use super::{Frames, frames};
use crate::model::Robot;
use nalgebra::Vector3;

/// How far beyond the model's [`Reach`] a target must lie to be refused before any solve: a
/// compensator's correction (millimetres) moves the tool beyond its robot's bound by far less.
pub const REACH_MARGIN: f64 = 1.1;

/// The arm's reach from its anchor: no configuration puts the tool's origin farther from
/// `anchor` than `bound_mm`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Reach {
    /// The origin of the frame joint 1 moves in (the base row and joint 1's fixed part), in
    /// the world frame (mm).
    pub anchor: Vector3<f64>,
    /// An upper bound on the distance from `anchor` to the tool's origin (mm).
    pub bound_mm: f64,
}

impl Reach {
    /// The reach of `robot` (its compliances included): the sum of the distances from the
    /// anchor to joint 1's frame origin, between consecutive joint frames' origins, and from
    /// the last to the tool's. A revolute joint turns its frame about the frame's own z axis
    /// through its origin, so no distance depends on it (a compliance deflects a joint the
    /// same way); a prismatic joint slides along that axis, and its distance, the norm of an
    /// affine function of the joint, is largest at a limit: each distance is taken at the
    /// larger of the two ends of the joint ranges. The triangle inequality makes the sum a
    /// bound; for a serial arm it is the arm stretched out, its reach when every link lines
    /// up.
    pub fn of(robot: &Robot) -> Reach {
        let anchor = robot.chain().head.translation.vector;
        let n = robot.dof();
        let mut f = Frames::new(robot);
        let mut longest = vec![0.0_f64; n + 1];
        for end in [0, 1] {
            let q: Vec<f64> = (robot.joints().iter())
                .map(|j| j.limits_internal()[end])
                .collect();
            frames(robot, &q, &mut f);
            let mut from = anchor;
            for (i, joint) in f.joint.iter().enumerate() {
                longest[i] = longest[i].max((joint.translation.vector - from).norm());
                from = joint.translation.vector;
            }
            longest[n] = longest[n].max((f.tool.translation.vector - from).norm());
        }
        Reach {
            anchor,
            bound_mm: longest.iter().sum(),
        }
    }

    /// How far `point` (world, mm) lies from the anchor (mm).
    pub fn distance_mm(&self, point: &Vector3<f64>) -> f64 {
        (point - self.anchor).norm()
    }

    /// Whether `point` (world, mm) lies within [`REACH_MARGIN`] times the bound: a target
    /// beyond is refused before any solve.
    pub fn holds(&self, point: &Vector3<f64>) -> bool {
        self.distance_mm(point) <= REACH_MARGIN * self.bound_mm
    }
}
