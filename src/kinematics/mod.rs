//! Forward and inverse kinematics.
//!
//! Joint vectors are in internal units: rad for revolute joints, mm for prismatic ones.

pub mod fk;
pub mod ik_closed;
pub mod ik_numeric;
pub mod jacobian;
pub mod subproblems;

/// A rigid transform: rotation matrix and translation (mm).
pub type Pose = nalgebra::IsometryMatrix3<f64>;

pub use fk::{Frames, frames, tool_pose};
pub use ik_closed::{Branch, SphericalWristIk};
pub use ik_numeric::{
    IkBuffers, IkOptions, IkSolution, IkTarget, IkWorkspace, RigidModel, ToolModel, solve_model,
    solve_numeric,
};
pub use jacobian::joint_jacobian;

use crate::rotation::{rotation_to_zyx, zyx_to_rotation};
use nalgebra::Translation3;

/// A pose as written in files: `[x, y, z]` in mm and Z-Y-X angles `[rz, ry, rx]` in degrees
/// (R = Rz Ry Rx, thesis eq. 3.5).
pub fn pose_to_file(p: &Pose) -> [f64; 6] {
    let t = p.translation.vector;
    let [rz, ry, rx] = rotation_to_zyx(&p.rotation);
    [
        t.x,
        t.y,
        t.z,
        rz.to_degrees(),
        ry.to_degrees(),
        rx.to_degrees(),
    ]
}

/// The inverse of [`pose_to_file`]: mm and Z-Y-X degrees to a pose.
pub fn pose_from_file(v: [f64; 6]) -> Pose {
    Pose::from_parts(
        Translation3::new(v[0], v[1], v[2]),
        zyx_to_rotation(v[3].to_radians(), v[4].to_radians(), v[5].to_radians()),
    )
}
