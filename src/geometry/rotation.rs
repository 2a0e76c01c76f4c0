//! Rotations: elementary rotations, Euler-angle conventions and rotation vectors.
//!
//! All angles here are in radians. Conversions to angles never return NaN: at gimbal lock the
//! free combination of the first and third angle is resolved by setting the third angle to 0.

use nalgebra::{Matrix3, Rotation3, UnitQuaternion, Vector3};

/// Rotation about x by `a` rad.
pub fn rot_x(a: f64) -> Rotation3<f64> {
    let (s, c) = a.sin_cos();
    Rotation3::from_matrix_unchecked(Matrix3::new(1.0, 0.0, 0.0, 0.0, c, -s, 0.0, s, c))
}

/// Rotation about y by `a` rad.
pub fn rot_y(a: f64) -> Rotation3<f64> {
    let (s, c) = a.sin_cos();
    Rotation3::from_matrix_unchecked(Matrix3::new(c, 0.0, s, 0.0, 1.0, 0.0, -s, 0.0, c))
}

/// Rotation about z by `a` rad.
pub fn rot_z(a: f64) -> Rotation3<f64> {
    let (s, c) = a.sin_cos();
    Rotation3::from_matrix_unchecked(Matrix3::new(c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0))
}

/// How three angles describe an orientation.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum EulerConvention {
    /// The thesis's Z-Y-X convention (eq. 3.5): angles `(rz, ry, rx)`, R = Rz(rz) Ry(ry) Rx(rx).
    Zyx,
    /// Intrinsic X-Y-Z, as Leica T-Mac exports: angles `(rx, ry, rz)`, R = Rx(rx) Ry(ry) Rz(rz).
    XyzIntrinsic,
    /// Extrinsic x-y-z (roll, pitch, yaw about fixed axes, as ROS): angles `(rx, ry, rz)`,
    /// R = Rz(rz) Ry(ry) Rx(rx).
    XyzExtrinsic,
}

impl EulerConvention {
    /// The rotation for three angles (rad) given in this convention's order.
    pub fn to_rotation(self, angles: [f64; 3]) -> Rotation3<f64> {
        match self {
            EulerConvention::Zyx => zyx_to_rotation(angles[0], angles[1], angles[2]),
            EulerConvention::XyzIntrinsic => rot_x(angles[0]) * rot_y(angles[1]) * rot_z(angles[2]),
            EulerConvention::XyzExtrinsic => zyx_to_rotation(angles[2], angles[1], angles[0]),
        }
    }

    /// Values given per axis (x, y, z: the angles about them, or those angles' standard
    /// deviations, as files hold them) in this convention's order: z, y, x for `Zyx`, else
    /// x, y, z.
    pub fn ordered(self, about: Vector3<f64>) -> [f64; 3] {
        match self {
            EulerConvention::Zyx => [about.z, about.y, about.x],
            EulerConvention::XyzIntrinsic | EulerConvention::XyzExtrinsic => {
                [about.x, about.y, about.z]
            }
        }
    }

    /// The angular-velocity Jacobian E of this convention at `angles` (rad, this
    /// convention's order): omega = E d(angles), omega the small rotation (rad) about the
    /// frame's fixed x, y, z axes, as in R(angles + d) R(angles)^T = exp(\[omega\]x) to first
    /// order. Column k belongs to angle k: for R = R1(a1) R2(a2) R3(a3) about axes e1, e2, e3,
    /// the columns are e1, R1 e2 and R1 R2 e3.
    pub fn angular_jacobian(self, angles: [f64; 3]) -> Matrix3<f64> {
        let (x, y, z) = (Vector3::x(), Vector3::y(), Vector3::z());
        let [a1, a2, a3] = angles;
        match self {
            EulerConvention::Zyx => {
                let (r1, r2) = (rot_z(a1), rot_y(a2));
                Matrix3::from_columns(&[z, r1 * y, r1 * r2 * x])
            }
            EulerConvention::XyzIntrinsic => {
                let (r1, r2) = (rot_x(a1), rot_y(a2));
                Matrix3::from_columns(&[x, r1 * y, r1 * r2 * z])
            }
            // R = Rz(a3) Ry(a2) Rx(a1): the third angle's factor comes first.
            EulerConvention::XyzExtrinsic => {
                let (r1, r2) = (rot_z(a3), rot_y(a2));
                Matrix3::from_columns(&[r1 * r2 * x, r1 * y, z])
            }
        }
    }

    /// The three angles (rad) of `r` in this convention's order.
    pub fn from_rotation(self, r: &Rotation3<f64>) -> [f64; 3] {
        match self {
            EulerConvention::Zyx => rotation_to_zyx(r),
            EulerConvention::XyzIntrinsic => {
                // (Rx(a) Ry(b) Rz(c))^T = Rz(-c) Ry(-b) Rx(-a): read the transpose as Z-Y-X.
                let [z, y, x] = rotation_to_zyx(&r.inverse());
                [-x, -y, -z]
            }
            EulerConvention::XyzExtrinsic => {
                let [z, y, x] = rotation_to_zyx(r);
                [x, y, z]
            }
        }
    }
}

/// R = Rz(rz) Ry(ry) Rx(rx), thesis eq. 3.6; angles in rad.
pub fn zyx_to_rotation(rz: f64, ry: f64, rx: f64) -> Rotation3<f64> {
    let (sr, cr) = rz.sin_cos();
    let (ss, cs) = ry.sin_cos();
    let (su, cu) = rx.sin_cos();
    Rotation3::from_matrix_unchecked(Matrix3::new(
        cr * cs,
        cr * ss * su - sr * cu,
        cr * ss * cu + sr * su,
        sr * cs,
        sr * ss * su + cr * cu,
        sr * ss * cu - cr * su,
        -ss,
        cs * su,
        cs * cu,
    ))
}

/// Z-Y-X angles `[rz, ry, rx]` (rad) of `r`, thesis eq. 3.8, with ry in [-pi/2, pi/2].
///
/// At gimbal lock (cos ry = 0) only rz - rx (ry = +90 deg) or rz + rx (ry = -90 deg) is
/// defined; rx is then set to 0.
pub fn rotation_to_zyx(r: &Rotation3<f64>) -> [f64; 3] {
    let m = r.matrix();
    let cs = m[(0, 0)].hypot(m[(1, 0)]);
    let ry = (-m[(2, 0)]).atan2(cs);
    if cs > 1e-12 {
        [m[(1, 0)].atan2(m[(0, 0)]), ry, m[(2, 1)].atan2(m[(2, 2)])]
    } else {
        // With rx = 0: m01 = -sin rz, m11 = cos rz.
        [(-m[(0, 1)]).atan2(m[(1, 1)]), ry, 0.0]
    }
}

/// Rotation vector (axis times angle, rad; angle in [0, pi]) of `r`.
///
/// Goes through the unit quaternion and `2 atan2(|v|, w)`, which stays accurate for tiny angles
/// (where `acos` of the trace loses half the digits) and near pi.
pub fn rotation_vector(r: &Rotation3<f64>) -> Vector3<f64> {
    let q = UnitQuaternion::from_rotation_matrix(r);
    let (w, v) = if q.w < 0.0 {
        (-q.w, -q.imag())
    } else {
        (q.w, q.imag())
    };
    let s = v.norm();
    if s == 0.0 {
        return Vector3::zeros();
    }
    v * (2.0 * s.atan2(w) / s)
}

/// Rotation for a rotation vector (rad).
pub fn from_rotation_vector(v: &Vector3<f64>) -> Rotation3<f64> {
    Rotation3::from_scaled_axis(*v)
}

/// Angle (rad, in [0, pi]) of the rotation that takes `b` to `a`: |rotation_vector(a b^T)|.
pub fn angle_between(a: &Rotation3<f64>, b: &Rotation3<f64>) -> f64 {
    rotation_vector(&(a * b.inverse())).norm()
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::{FRAC_PI_2, PI};

    fn close(a: &Rotation3<f64>, b: &Rotation3<f64>, tol: f64) -> bool {
        (a.matrix() - b.matrix()).abs().max() < tol
    }

    /// The angular Jacobian of each convention against central differences of
    /// rotation_vector(R(angles + h e_k) R(angles)^T) / h.
    #[test]
    fn angular_jacobians_match_finite_differences() {
        let h = 1e-6;
        for conv in [
            EulerConvention::Zyx,
            EulerConvention::XyzIntrinsic,
            EulerConvention::XyzExtrinsic,
        ] {
            for angles in [[0.3, -1.1, 2.0], [-1.57, 0.2, -0.4], [3.0, 1.4, -2.9]] {
                let e = conv.angular_jacobian(angles);
                let r = conv.to_rotation(angles);
                for k in 0..3 {
                    let (mut plus, mut minus) = (angles, angles);
                    plus[k] += h;
                    minus[k] -= h;
                    let w = (rotation_vector(&(conv.to_rotation(plus) * r.inverse()))
                        - rotation_vector(&(conv.to_rotation(minus) * r.inverse())))
                        / (2.0 * h);
                    let gap = (w - e.column(k)).abs().max();
                    assert!(gap < 1e-8, "{conv:?} {angles:?} column {k}: {gap:e}");
                }
            }
        }
    }

    #[test]
    fn elementary_rotations_by_hand() {
        // Rz(90 deg) takes x to y.
        let v = rot_z(FRAC_PI_2) * Vector3::x();
        assert!((v - Vector3::y()).norm() < 1e-15);
        // Rx(90 deg) takes y to z; Ry(90 deg) takes z to x.
        assert!((rot_x(FRAC_PI_2) * Vector3::y() - Vector3::z()).norm() < 1e-15);
        assert!((rot_y(FRAC_PI_2) * Vector3::z() - Vector3::x()).norm() < 1e-15);
    }

    #[test]
    fn zyx_matches_product_and_round_trips() {
        let angles = [0.3, -0.7, 2.1];
        let r = zyx_to_rotation(angles[0], angles[1], angles[2]);
        assert!(close(&r, &(rot_z(0.3) * rot_y(-0.7) * rot_x(2.1)), 1e-15));
        let back = rotation_to_zyx(&r);
        for k in 0..3 {
            assert!((back[k] - angles[k]).abs() < 1e-13, "{back:?}");
        }
    }

    #[test]
    fn every_convention_round_trips_away_from_and_near_gimbal_lock() {
        let middles = [
            0.4,
            -1.2,
            FRAC_PI_2,
            -FRAC_PI_2,
            FRAC_PI_2 - 1e-9,
            -FRAC_PI_2 + 1e-7,
            FRAC_PI_2 + 1e-10,
        ];
        for conv in [
            EulerConvention::Zyx,
            EulerConvention::XyzIntrinsic,
            EulerConvention::XyzExtrinsic,
        ] {
            for &mid in &middles {
                for &(first, last) in &[(0.2, -2.9), (-3.0, 1.0), (0.0, 0.0), (PI, -PI)] {
                    let r = conv.to_rotation([first, mid, last]);
                    let ang = conv.from_rotation(&r);
                    assert!(ang.iter().all(|a| a.is_finite()), "{conv:?} {ang:?}");
                    let r2 = conv.to_rotation(ang);
                    assert!(close(&r, &r2, 1e-12), "{conv:?} mid {mid}: {ang:?}");
                    if (mid.abs() - FRAC_PI_2).abs() > 1e-3 {
                        for k in 0..3 {
                            let want = [first, mid, last][k];
                            let d = (ang[k] - want + PI).rem_euclid(2.0 * PI) - PI;
                            assert!(d.abs() < 1e-12, "{conv:?} {ang:?} vs {want}");
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn exact_gimbal_lock_gives_finite_angles() {
        let r = zyx_to_rotation(0.5, FRAC_PI_2, 0.2);
        let a = rotation_to_zyx(&r);
        assert_eq!(a[2], 0.0);
        assert!((a[1] - FRAC_PI_2).abs() < 1e-8);
        // Only rz - rx is defined at ry = +90 deg.
        assert!((a[0] - 0.3).abs() < 1e-8, "{a:?}");
    }

    #[test]
    fn conventions_differ_as_documented() {
        // Intrinsic XYZ is Rx Ry Rz; extrinsic xyz is Rz Ry Rx.
        let a = [0.1, 0.2, 0.3];
        let intr = EulerConvention::XyzIntrinsic.to_rotation(a);
        let extr = EulerConvention::XyzExtrinsic.to_rotation(a);
        assert!(close(&intr, &(rot_x(0.1) * rot_y(0.2) * rot_z(0.3)), 1e-15));
        assert!(close(&extr, &(rot_z(0.3) * rot_y(0.2) * rot_x(0.1)), 1e-15));
    }

    #[test]
    fn rotation_vectors_round_trip_small_and_large() {
        for &angle in &[0.0, 1e-12, 1e-6, 0.5, 3.0, PI - 1e-9] {
            let axis = Vector3::new(0.3, -0.5, 0.8).normalize();
            let v = axis * angle;
            let r = from_rotation_vector(&v);
            let back = rotation_vector(&r);
            assert!(
                (back - v).norm() <= 1e-15 + 1e-12 * angle,
                "{angle}: {back:?}"
            );
        }
        // A tiny rotation keeps full relative precision (acos of the trace would give 0).
        let tiny = Vector3::new(1e-10, -2e-10, 3e-10);
        let back = rotation_vector(&from_rotation_vector(&tiny));
        assert!((back - tiny).norm() < 1e-24);
    }
}
