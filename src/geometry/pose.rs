//! Rigid poses: a rotation matrix and a translation (mm), and their file form.

use super::rotation::{rotation_to_zyx, zyx_to_rotation};
use nalgebra::Translation3;

/// A rigid transform: rotation matrix and translation (mm).
pub type Pose = nalgebra::IsometryMatrix3<f64>;

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
