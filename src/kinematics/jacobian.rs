//! The geometric joint Jacobian of the tool frame.

use super::fk::Frames;
use crate::model::{JointType, Robot};
use nalgebra::{Matrix6xX, Vector3};

/// Fills `jac` (6 x N) with the geometric Jacobian at the configuration whose frames are in
/// `frames`: rows 0-2 the tool origin's velocity (mm per rad, or mm per mm), rows 3-5 the
/// tool's angular velocity (rad per rad), both in world coordinates.
///
/// Revolute joint i with axis z_i through o_i: [z_i x (p - o_i); z_i]; prismatic: [z_i; 0].
pub fn joint_jacobian(robot: &Robot, frames: &Frames, jac: &mut Matrix6xX<f64>) {
    let n = robot.dof();
    if jac.ncols() != n {
        jac.resize_horizontally_mut(n, 0.0);
    }
    let p = frames.tool.translation.vector;
    for (i, joint) in robot.joints().iter().enumerate() {
        let f = &frames.joint[i];
        let z: Vector3<f64> = f.rotation.matrix().column(2).into();
        let (lin, ang) = match joint.joint_type {
            JointType::Revolute => (z.cross(&(p - f.translation.vector)), z),
            JointType::Prismatic => (z, Vector3::zeros()),
        };
        let mut col = jac.column_mut(i);
        col.fixed_rows_mut::<3>(0).copy_from(&lin);
        col.fixed_rows_mut::<3>(3).copy_from(&ang);
    }
}
