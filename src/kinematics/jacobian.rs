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
/// [z_i; 0]. A compliant robot reaches q' = q + delta(q), so its Jacobian is J' (I + D),
/// J' at the reached joints and D = d delta / d q, D_ji the change of joint j's deflection
/// under joint i's motion (J' D's column i is [`super::load::Load::tool_change`] of that
/// motion).
pub fn joint_jacobian(robot: &Robot, frames: &Frames, jac: &mut Matrix6xX<f64>) {
    let n = robot.dof();
    if jac.ncols() != n {
        jac.resize_horizontally_mut(n, 0.0);
    }
    let p = frames.tool.translation.vector;
    for (i, joint) in robot.joints().iter().enumerate() {
        let f = &frames.joint[i];
        let z: Vector3<f64> = f.rotation.matrix().column(2).into();
        let mut col = jac.column_mut(i);
        match joint.joint_type {
            JointType::Revolute => {
                col.fixed_rows_mut::<3>(0)
                    .copy_from(&z.cross(&(p - f.translation.vector)));
                col.fixed_rows_mut::<3>(3).copy_from(&z);
            }
            JointType::Prismatic => {
                col.fixed_rows_mut::<3>(0).copy_from(&z);
                col.fixed_rows_mut::<3>(3).fill(0.0);
            }
        }
    }
    if frames.load.compliant {
        let load = &frames.load;
        for i in 0..n {
            let mut col = jac.column_mut(i);
            col += load.tool_change(&load.joint_twist(i));
        }
    }
}

/// The tool's motion per unit of joint i's reached value q'_i, from `frames`
/// ([`super::load::axis_column`]).
#[inline]
pub(crate) fn axis_column(robot: &Robot, frames: &Frames, i: usize) -> Vector6<f64> {
    let revolute = robot.joints()[i].joint_type == JointType::Revolute;
    super::load::axis_column(&frames.joint, &frames.tool, revolute, i)
}
