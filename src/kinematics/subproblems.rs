//! Paden-Kahan subproblems (Murray, Li and Sastry, "A Mathematical Introduction to Robotic
//! Manipulation", 1994, sec. 3.2), and the geometry the closed forms share (closest points of
//! two lines, Rodrigues' rotation, angle wrapping, the tolerance of their structure checks).
//! Vectors are taken relative to a point on the axis (or on both axes); axis directions are
//! unit vectors; angles in rad, lengths in mm.

use nalgebra::{Matrix3, Rotation3, Vector3};
use std::f64::consts::PI;

type V3 = Vector3<f64>;

/// Relative tolerance under which a cosine slightly outside [-1, 1] is taken as a tangent
/// solution rather than as no solution.
const TANGENT_TOL: f64 = 1e-10;

/// What a subproblem gives where the point lies out of its rotation's reach (its cosine
/// beyond [-1, 1] by more than the rounding of a tangent).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Beyond {
    /// No solution: the closed form's answer.
    Nothing,
    /// The nearest the rotation comes: the cosine taken as +-1, both roots the tangent
    /// angle (a stretched or folded elbow, a tangent shoulder). Starts for a model that
    /// reaches a little farther than the closed form's robot
    /// ([`super::ik::IkSolver`]'s tracking of a branch).
    Nearest,
}

fn project(w: &V3, v: &V3) -> V3 {
    v - w * w.dot(v)
}

/// Subproblem 1: the angle theta with Rot(w, theta) u = v, judged on the parts of u and v
/// perpendicular to w. Returns 0 when either part vanishes (the angle is then free).
pub fn rotate_onto(w: &V3, u: &V3, v: &V3) -> f64 {
    let up = project(w, u);
    let vp = project(w, v);
    w.dot(&up.cross(&vp)).atan2(up.dot(&vp))
}

/// Subproblem 3: the angles theta with |Rot(w, theta) u - v| = delta; none, or two (equal
/// when tangent).
/// Beyond the reach as `beyond` says.
pub fn rotate_to_distance(w: &V3, u: &V3, v: &V3, delta: f64, beyond: Beyond) -> Option<[f64; 2]> {
    let up = project(w, u);
    let vp = project(w, v);
    let along = w.dot(&(u - v));
    let delta2 = delta * delta - along * along;
    let (nu, nv) = (up.norm(), vp.norm());
    if nu == 0.0 || nv == 0.0 {
        return None;
    }
    let theta0 = w.dot(&up.cross(&vp)).atan2(up.dot(&vp));
    let cos = (nu * nu + nv * nv - delta2) / (2.0 * nu * nv);
    let cos = clamp_tangent(cos, beyond)?;
    let phi = cos.acos();
    Some([theta0 - phi, theta0 + phi])
}

/// Subproblem 2: the angle pairs (t1, t2) with Rot(w1, t1) Rot(w2, t2) p = q for two
/// intersecting, non-parallel axes; none, or two (equal when tangent). Beyond the reach as
/// `beyond` says (the nearest: the pair that brings p to the point of the two axes' plane
/// nearest q).
pub fn rotate_two_axes(w1: &V3, w2: &V3, p: &V3, q: &V3, beyond: Beyond) -> Option<[[f64; 2]; 2]> {
    let c12 = w1.dot(w2);
    let cross = w1.cross(w2);
    let s2 = cross.norm_squared();
    if s2 < 1e-24 {
        return None;
    }
    let denom = c12 * c12 - 1.0;
    let alpha = (c12 * w2.dot(p) - w1.dot(q)) / denom;
    let beta = (c12 * w1.dot(q) - w2.dot(p)) / denom;
    let rest = p.norm_squared() - alpha * alpha - beta * beta - 2.0 * alpha * beta * c12;
    let gamma2 = rest / s2;
    let scale = p.norm_squared().max(f64::MIN_POSITIVE);
    if gamma2 < -TANGENT_TOL * scale && beyond == Beyond::Nothing {
        return None;
    }
    let gamma = gamma2.max(0.0).sqrt();
    let mut out = [[0.0; 2]; 2];
    for (k, g) in [gamma, -gamma].into_iter().enumerate() {
        let z = w1 * alpha + w2 * beta + cross * g;
        let t2 = rotate_onto(w2, p, &z);
        let t1 = rotate_onto(w1, &z, q);
        out[k] = [t1, t2];
    }
    Some(out)
}

fn clamp_tangent(cos: f64, beyond: Beyond) -> Option<f64> {
    if cos.abs() <= 1.0 {
        Some(cos)
    } else if cos.abs() <= 1.0 + TANGENT_TOL || (beyond == Beyond::Nearest && !cos.is_nan()) {
        Some(cos.signum())
    } else {
        None
    }
}

/// Solutions q of `a cos q + b sin q = c`: none, or two (equal when tangent); where |c|
/// exceeds the left side's amplitude, as `beyond` says (the nearest: the q of its maximum or
/// minimum). `None` also when a = b = 0 (then any q or none solves it).
pub fn cos_sin_equation(a: f64, b: f64, c: f64, beyond: Beyond) -> Option<[f64; 2]> {
    let r = a.hypot(b);
    if r == 0.0 {
        return None;
    }
    let phi = b.atan2(a);
    let cos = clamp_tangent(c / r, beyond)?;
    let d = cos.acos();
    Some([phi - d, phi + d])
}

/// The joint-1 angles (rad; two, equal when tangent) at which the arm's plane holds a point:
/// `x` (mm, where the target puts it) turned back about axis 1 (direction `w1`, through `p1`)
/// has the component along `n` (the arm's parallel axes) that `x0` (mm, the point at q = 0)
/// has, (Rot(w1, q1) n) . (x - p1) = n . (x0 - p1). None when no angle does; [0, 0] where
/// every angle does (the point on axis 1 with nothing to fix q1). Where no angle does, as
/// `beyond` says.
pub fn shoulder_angles(
    w1: &V3,
    n: &V3,
    p1: &V3,
    x: &V3,
    x0: &V3,
    beyond: Beyond,
) -> Option<[f64; 2]> {
    let v = x - p1;
    let (w1n, w1v) = (w1.dot(n), w1.dot(&v));
    let a = n.dot(&v) - w1n * w1v;
    let b = w1.cross(n).dot(&v);
    let c = n.dot(&(x0 - p1)) - w1n * w1v;
    match cos_sin_equation(a, b, c, beyond) {
        Some(s) => Some(s),
        None if a.hypot(b) < 1e-9 && c.abs() < 1e-9 => Some([0.0, 0.0]),
        None => None,
    }
}

/// Whether root `root` (0 or 1) of step `step` (0 shoulder, 1 elbow, 2 wrist) leads to the
/// solution a closed form is asked for: `only` its roots [shoulder, elbow, wrist], None for
/// every solution.
pub fn root_wanted(only: Option<[u8; 3]>, step: usize, root: usize) -> bool {
    only.is_none_or(|o| usize::from(o[step]) == root)
}

/// Tolerance (mm) for axes meeting in a point, and (unit-vector norm) for parallel axes.
pub const STRUCTURE_TOL: f64 = 1e-7;

/// Closest points of two lines (point, unit direction); None when parallel.
pub fn closest_points(p1: &V3, d1: &V3, p2: &V3, d2: &V3) -> Option<(V3, V3)> {
    let r = p1 - p2;
    let b = d1.dot(d2);
    let denom = 1.0 - b * b;
    if denom < 1e-12 {
        return None;
    }
    let (d, e) = (d1.dot(&r), d2.dot(&r));
    let s = (b * e - d) / denom;
    let t = (e - b * d) / denom;
    Some((p1 + d1 * s, p2 + d2 * t))
}

/// Rotation by `angle` (rad) about the unit axis `w` (Rodrigues' formula).
pub fn rot(w: &V3, angle: f64) -> Rotation3<f64> {
    let (s, c) = libm::sincos(angle);
    let k = w.cross_matrix();
    Rotation3::from_matrix_unchecked(
        Matrix3::identity() * c + w * w.transpose() * (1.0 - c) + k * s,
    )
}

/// Wraps an angle to [-pi, pi). The solver's angles come from atan2 plus or minus acos, so
/// a few steps of 2 pi suffice; this avoids `rem_euclid` (an fmod) on 48 values per pose.
pub fn wrap(mut a: f64) -> f64 {
    while a >= PI {
        a -= 2.0 * PI;
    }
    while a < -PI {
        a += 2.0 * PI;
    }
    a
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Rotation3, Unit};

    fn rot(w: &V3, t: f64) -> Rotation3<f64> {
        Rotation3::from_axis_angle(&Unit::new_normalize(*w), t)
    }

    #[test]
    fn subproblem_one_recovers_the_angle() {
        let w = V3::new(1.0, 2.0, -0.5).normalize();
        let u = V3::new(0.3, -1.0, 2.0);
        for &t in &[0.0, 0.7, -2.5, 3.1] {
            let v = rot(&w, t) * u;
            assert!((rotate_onto(&w, &u, &v) - t).abs() < 1e-12);
        }
    }

    #[test]
    fn subproblem_three_gives_the_distance() {
        let w = V3::z();
        let u = V3::new(2.0, 0.0, 1.0);
        let v = V3::new(-1.0, 3.0, -2.0);
        let truth = 0.9;
        let delta = (rot(&w, truth) * u - v).norm();
        let sols = rotate_to_distance(&w, &u, &v, delta, Beyond::Nothing).unwrap();
        for t in sols {
            assert!(((rot(&w, t) * u - v).norm() - delta).abs() < 1e-12);
        }
        assert!(sols.iter().any(|t| (t - truth).abs() < 1e-12));
        assert!(rotate_to_distance(&w, &u, &v, 100.0, Beyond::Nothing).is_none());
        // Beyond the reach, the nearest: the angle of the largest (or smallest) distance,
        // both roots, found by sampling the circle.
        for far in [100.0, 0.0] {
            let [a, b] = rotate_to_distance(&w, &u, &v, far, Beyond::Nearest).unwrap();
            assert!(wrap(a - b).abs() < 1e-12, "{a} {b}");
            let d = |t: f64| ((rot(&w, t) * u - v).norm() - far).abs();
            let best = (0..100_000)
                .map(|k| d(k as f64 * 2.0 * PI / 100_000.0))
                .fold(f64::INFINITY, f64::min);
            assert!(d(a) <= best + 1e-9, "{far}: {} against {best}", d(a));
        }
    }

    #[test]
    fn subproblem_two_reaches_the_point() {
        let w1 = V3::z();
        let w2 = V3::new(1.0, 0.0, 0.3).normalize();
        let p = V3::new(0.2, 1.0, -0.4);
        let (t1, t2) = (1.1, -0.6);
        let q = rot(&w1, t1) * rot(&w2, t2) * p;
        let sols = rotate_two_axes(&w1, &w2, &p, &q, Beyond::Nothing).unwrap();
        for [a, b] in sols {
            assert!((rot(&w1, a) * rot(&w2, b) * p - q).norm() < 1e-12);
        }
        assert!(
            sols.iter()
                .any(|[a, b]| (a - t1).abs() < 1e-12 && (b - t2).abs() < 1e-12)
        );
    }

    #[test]
    fn cos_sin_equation_solutions_satisfy_it() {
        let (a, b, c) = (2.0, -1.0, 0.5);
        for q in cos_sin_equation(a, b, c, Beyond::Nothing).unwrap() {
            assert!((a * q.cos() + b * q.sin() - c).abs() < 1e-14);
        }
        assert!(cos_sin_equation(1.0, 1.0, 2.0, Beyond::Nothing).is_none());
        // Beyond: the maximum (pi / 4) or the minimum (-3 pi / 4) of cos q + sin q.
        let [q, r] = cos_sin_equation(1.0, 1.0, 2.0, Beyond::Nearest).unwrap();
        assert!((q - PI / 4.0).abs() < 1e-15 && q == r);
        let [q, _] = cos_sin_equation(1.0, 1.0, -2.0, Beyond::Nearest).unwrap();
        assert!((wrap(q) + 0.75 * PI).abs() < 1e-15);
        assert!(cos_sin_equation(0.0, 0.0, 1.0, Beyond::Nearest).is_none());
    }
}
