//! Gravity torques at the joints, and their derivatives: the load that bends compliant joints
//! (the thesis's literature review: Khalil and Besnard identify geometric and compliance
//! parameters together).
//!
//! Point masses m_k (kg) at p_k (mm, world), each carried by the joints before it; gravity g
//! (m/s^2) in the base (world) frame. The generalised gravity force at joint j, axis z_j
//! through o_j (both world), sums over the masses that joint j carries:
//! - revolute: tau_j = sum_k z_j . ((p_k - o_j) x m_k g) = sum_k m_k g . (z_j x (p_k - o_j))
//!   (N m; lengths in m);
//! - prismatic: f_j = sum_k m_k g . z_j (N).
//!
//! The compliant model sums the same torques from suffix sums, with their derivatives, in
//! [`super::load`]; this direct sum is the simulator's and the tests' reference.

use super::Pose;
use crate::model::{JointType, Robot};
use nalgebra::Vector3;

/// A point mass and the frame it rides on.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PointMass {
    /// Its mass (kg).
    pub mass_kg: f64,
    /// Where it is (mm, world).
    pub position_mm: Vector3<f64>,
    /// The frame it rides on: joint frame k (0-based, link k's mass), or N for the tool frame
    /// (the payload). Joints 0..=min(frame, N - 1) carry it.
    pub frame: usize,
}

/// Joint j's axis direction (unit) and a point on it (mm), world, from its joint frame.
#[inline]
pub(crate) fn axis(joint: &[Pose], j: usize) -> (Vector3<f64>, Vector3<f64>) {
    let f = &joint[j];
    (f.rotation.matrix().column(2).into(), f.translation.vector)
}

/// The point masses of `robot`'s mass properties in the joint frames `joint` and tool frame
/// `tool` (world) into `out` (none when the robot has no masses): each link's centre of mass
/// carried by its joint frame, the payload's by the tool frame. Allocates only when `out` must
/// grow.
pub fn mass_points(robot: &Robot, joint: &[Pose], tool: &Pose, out: &mut Vec<PointMass>) {
    out.clear();
    let Some(m) = robot.masses() else {
        return;
    };
    let n = robot.dof();
    for (k, b) in m.links.iter().enumerate() {
        out.push(PointMass {
            mass_kg: b.mass_kg,
            position_mm: joint[k].transform_point(&b.com_mm.into()).coords,
            frame: k,
        });
    }
    out.push(PointMass {
        mass_kg: m.payload.mass_kg,
        position_mm: tool.transform_point(&m.payload.com_mm.into()).coords,
        frame: n,
    });
}

/// The gravity force of every joint into `out` (N m for revolute joints, N for prismatic
/// ones) from `points`, the joint axes those of the joint frames `joint` (world), gravity `g`
/// (m/s^2, world). Does not allocate.
pub fn gravity_torques(
    robot: &Robot,
    joint: &[Pose],
    g: &Vector3<f64>,
    points: &[PointMass],
    out: &mut [f64],
) {
    for (j, (tau, jt)) in out.iter_mut().zip(robot.joints()).enumerate() {
        let (z, o) = axis(joint, j);
        *tau = points
            .iter()
            .filter(|p| p.frame >= j)
            .map(|p| match jt.joint_type {
                JointType::Revolute => z.dot(&((p.position_mm - o) * 1e-3).cross(&(g * p.mass_kg))),
                JointType::Prismatic => (g * p.mass_kg).dot(&z),
            })
            .sum();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kinematics::{Frames, frames};
    use crate::model::read_robot;

    #[test]
    fn torque_of_a_hand_computed_arm() {
        // The UR10 at q = 0 with one 10 kg mass 1 m out along the world x axis from joint 2's
        // axis point: gravity -z gives |tau_2| = 10 * 9.81 * 1 N m.
        let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("datasets/robots");
        let robot = read_robot(root.join("ur10.toml")).unwrap();
        let mut f = Frames::new(&robot);
        frames(&robot, &[0.0; 6], &mut f);
        let (z, o) = axis(&f.joint, 1);
        // A point 1 m from the axis, perpendicular to it and to gravity.
        let arm = z.cross(&Vector3::z()).normalize() * 1000.0;
        let p = PointMass {
            mass_kg: 10.0,
            position_mm: o + arm,
            frame: 5,
        };
        let mut tau = vec![0.0; 6];
        gravity_torques(
            &robot,
            &f.joint,
            &Vector3::new(0.0, 0.0, -9.81),
            &[p],
            &mut tau,
        );
        assert!((tau[1].abs() - 98.1).abs() < 1e-9, "{tau:?}");
        // Joint 1's axis is vertical: gravity exerts no torque about it.
        assert!(tau[0].abs() < 1e-9, "{tau:?}");
    }
}
