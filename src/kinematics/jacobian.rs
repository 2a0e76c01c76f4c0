//! The geometric joint Jacobian of the tool frame.

use super::fk::Frames;
use crate::model::{JointType, Robot};
use nalgebra::{Matrix6xX, Vector3, Vector6};

/// Fills `jac` (6 x N) with the Jacobian of the tool pose with respect to the commanded
/// joints at the configuration whose frames are in `frames`: rows 0-2 the tool origin's
/// velocity (mm per rad, or mm per mm), rows 3-5 the tool's angular velocity (rad per rad),
/// both in world coordinates.
///
/// Revolute joint i with axis z_i through o_i: J'_i = [z_i x (p - o_i); z_i]; prismatic:
/// [z_i; 0]. A compliant robot reaches q' = q + c tau(q), so its Jacobian is J' (I + D),
/// J' at the reached joints and D = C d tau / d q ([`super::load::Load`]).
pub fn joint_jacobian(robot: &Robot, frames: &Frames, jac: &mut Matrix6xX<f64>) {
    let n = robot.dof();
    if jac.ncols() != n {
        jac.resize_horizontally_mut(n, 0.0);
    }
    for i in 0..n {
        let c = axis_column(robot, frames, i);
        jac.column_mut(i).copy_from(&c);
    }
    if frames.load.compliant {
        let d = &frames.load.deflection_jacobian;
        for j in 0..n {
            // J'_j is column j before the correction: recompute it rather than keep a copy.
            let cj = axis_column(robot, frames, j);
            for i in 0..n {
                let dji = d[(j, i)];
                if dji != 0.0 {
                    let mut col = jac.column_mut(i);
                    col += cj * dji;
                }
            }
        }
    }
}

/// The tool's motion per unit of joint i's reached value q'_i: [z_i x (p - o_i); z_i], or
/// [z_i; 0] for a prismatic joint (world).
pub(crate) fn axis_column(robot: &Robot, frames: &Frames, i: usize) -> Vector6<f64> {
    let p = frames.tool.translation.vector;
    let f = &frames.joint[i];
    let z: Vector3<f64> = f.rotation.matrix().column(2).into();
    let (lin, ang) = match robot.joints()[i].joint_type {
        JointType::Revolute => (z.cross(&(p - f.translation.vector)), z),
        JointType::Prismatic => (z, Vector3::zeros()),
    };
    Vector6::new(lin.x, lin.y, lin.z, ang.x, ang.y, ang.z)
}
