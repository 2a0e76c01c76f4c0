//! Closed-form inverse kinematics of the UR class (Universal Robots' arms and their like):
//! axes 2, 3 and 4 parallel (direction n), axis 1 not parallel to them, axis 5 meeting axis
//! 4 (at A) and axis 6 (at B), not parallel to n, and axis 6 not parallel to axis 5. Up to 8
//! solutions: 2 for q1 x 2 for q5 (the wrist) x 2 elbows.
//!
//! On the product-of-exponentials form T(q) = e1(q1) ... e6(q6) M (axes read at q = 0; G =
//! T M^-1 = e1 ... e6), a rotation about an axis parallel to n keeps every point's and every
//! direction's component along n, which decouples the joints:
//! 1. B lies on axes 5 and 6, so B(q) = G B0 = e1 e2 e3 e4 B0 and n . e1^-1 G B0 = n . B0:
//!    `a cos q1 + b sin q1 = c`;
//! 2. axis 6 points R_G w6 = R1 R234 R5 w6, so n . R5(q5) w6 = n . R1^T R_G w6: q5 from the
//!    same equation (its two roots are the wrist's flip);
//! 3. R6^T R5^T n = R_G^T R1 n: q6 by subproblem 1. Where axis 6 lies along n (the wrist
//!    singularity, sin q5 = 0, within [`WRIST_ALONG_N`]) q6 is free: turning it moves A on a
//!    circle about axis 6 and q2..q4 take the rest, where the elbow reaches A. The q6 given
//!    as the hint (a seed's, or the middle of its range) is taken where it does, else the
//!    nearest that does on a 1 deg grid from it; q5 is put on the singularity, and the two
//!    wrist flips are one solution (branch `wrist` 0);
//! 4. A lies on axes 4 and 5, so e1^-1 G e6^-1 e5^-1 A0 = e2 e3 A0: subproblem 3 (the
//!    distance from axis 2) gives q3, subproblem 1 q2;
//! 5. R4 = (R1 R2 R3)^T R_G (R5 R6)^T: q4 by subproblem 1.

use super::Pose;
use super::subproblems::{
    Beyond, STRUCTURE_TOL, closest_points, cos_sin_equation, root_wanted, rot, rotate_onto,
    rotate_to_distance, shoulder_angles, wrap,
};
use nalgebra::Vector3;

type V3 = Vector3<f64>;

/// Sine of the angle between axis 6 and axes 2-4 below which the wrist counts as singular
/// (q6 free): q5 there comes from an arccosine near its end, good to about the square root of
/// the rounding (1e-8 rad), so the bound lies above that.
pub const WRIST_ALONG_N: f64 = 1e-7;

/// Step (rad) of the search for a q6 at which the elbow reaches the wrist, at the singularity.
const Q6_STEP: f64 = std::f64::consts::PI / 180.0;

/// A and B (mm, at q = 0) where the axes (directions `w`, points `p` at q = 0) have the UR
/// class's structure; else why not.
pub(super) fn structure(w: &[V3; 6], p: &[V3; 6]) -> Result<(V3, V3), String> {
    let n = &w[1];
    if w[3].cross(n).norm() > STRUCTURE_TOL {
        return Err("axis 4 is not parallel to axes 2 and 3".into());
    }
    if w[4].cross(n).norm() < 1e-6 {
        return Err("axis 5 is parallel to axes 2, 3 and 4".into());
    }
    if w[5].cross(&w[4]).norm() < 1e-6 {
        return Err("axes 5 and 6 are parallel".into());
    }
    let meet = |i: usize, j: usize| -> Result<V3, String> {
        let (a, b) = closest_points(&p[i], &w[i], &p[j], &w[j])
            .ok_or_else(|| format!("axes {} and {} are parallel", i + 1, j + 1))?;
        if (a - b).norm() > STRUCTURE_TOL {
            return Err(format!(
                "axes {} and {} do not intersect (they pass {:.3e} mm apart)",
                i + 1,
                j + 1,
                (a - b).norm()
            ));
        }
        Ok((a + b) * 0.5)
    };
    Ok((meet(3, 4)?, meet(4, 5)?))
}

/// Every solution of G = T M^-1 (the target times the inverse of the tool pose at q = 0),
/// wrapped to [-pi, pi), with its roots [q1's, q3's (elbow), q5's (wrist)], 0 or 1 each, for
/// the axes `w`, `p` and the points `[a0, b0]` (where axis 5 meets axes 4 and 6) at q = 0
/// (mm). None when the pose is out of reach; with `beyond` [`Beyond::Nearest`], every root
/// each step has, where it has none its nearest (two equal roots, both emitted). With `only`,
/// the solution of those roots alone (the others are not computed). At the wrist
/// singularity, q6 is `q6_hint` (rad) where the elbow reaches, else the nearest q6 that does
/// (module doc, step 3).
pub(super) fn each_solution(
    w: &[V3; 6],
    p: &[V3; 6],
    [a0, b0]: [&V3; 2],
    g: &Pose,
    q6_hint: f64,
    (beyond, only): (Beyond, Option<[u8; 3]>),
    mut emit: impl FnMut([u8; 3], [f64; 6]),
) {
    let [w1, n, w3, w4, w5, w6] = w;
    let [p1, p2, p3, ..] = p;
    let rg = g.rotation;
    let b = rg * b0 + g.translation.vector;

    let Some(q1s) = shoulder_angles(w1, n, p1, &b, b0, beyond) else {
        return;
    };
    let q1s: &[f64] = &q1s;
    let distinct = |r: &[f64]| {
        if beyond == Beyond::Nothing && (r[0] - r[1]).abs() < 1e-14 {
            1
        } else {
            2
        }
    };
    // Axis 6's part along axis 5, which q5 does not turn.
    let w6_along = w5 * w5.dot(w6);
    for (b1, &q1) in q1s[..distinct(q1s)].iter().enumerate() {
        if !root_wanted(only, 0, b1) {
            continue;
        }
        let r1 = rot(w1, q1);
        // q5: n . Rot(w5, q5) w6 = n . R1^T R_G w6.
        let d = n.dot(&(r1.inverse() * (rg * w6)));
        let a5 = n.dot(&(w6 - w6_along));
        let b5 = n.dot(&w5.cross(w6));
        let c5 = d - n.dot(&w6_along);
        // m = R_G^T R1 n = R6^T R5^T n: across axis 6 it is the sine of the angle between
        // axis 6 and n, so q6 is free where it vanishes (the wrist singularity). There the
        // two roots of q5 meet at the top (or bottom) of a cos q5 + b sin q5, whose angle is
        // exact where the arccosine of the roots keeps half the digits: q5 is put on it.
        let m = rg.inverse() * (r1 * n);
        let singular = (m - w6 * w6.dot(&m)).norm() < WRIST_ALONG_N;
        let q5s = if singular {
            let top = b5.atan2(a5);
            let q5 = if c5 >= 0.0 {
                top
            } else {
                top + std::f64::consts::PI
            };
            [q5, q5]
        } else {
            let Some(q5s) = cos_sin_equation(a5, b5, c5, beyond) else {
                continue;
            };
            q5s
        };
        let roots = if singular { 1 } else { distinct(&q5s) };
        for (bw, &q5) in q5s[..roots].iter().enumerate() {
            if !root_wanted(only, 2, bw) {
                continue;
            }
            let r5 = rot(w5, q5);
            // A = G e6^-1 e5^-1 A0 (B0 lies on axes 5 and 6), then e1^-1 A = e2 e3 A0: for
            // q6, its rotation, A's point and the elbow's roots.
            let elbow_for = |q6: f64| {
                let r6 = rot(w6, q6);
                let back = r6.inverse() * (r5.inverse() * (a0 - b0)) + b0;
                let ap = r1.inverse() * (rg * back + g.translation.vector - p1) + p1;
                rotate_to_distance(w3, &(a0 - p3), &(p2 - p3), (ap - p2).norm(), beyond)
                    .map(|q3s| (q6, r6, ap, q3s))
            };
            // q6: Rot(w6, q6) m = R5^T n; at the singularity the hint, then 1, 2, ... steps
            // either side of it.
            let found = if singular {
                elbow_for(q6_hint).or_else(|| {
                    (1..=180).find_map(|k| {
                        let step = k as f64 * Q6_STEP;
                        elbow_for(q6_hint + step).or_else(|| elbow_for(q6_hint - step))
                    })
                })
            } else {
                elbow_for(rotate_onto(w6, &m, &(r5.inverse() * n)))
            };
            let Some((q6, r6, ap, q3s)) = found else {
                continue;
            };
            for (b3, &q3) in q3s[..distinct(&q3s)].iter().enumerate() {
                if !root_wanted(only, 1, b3) {
                    continue;
                }
                let r3 = rot(w3, q3);
                let elbow = r3 * (a0 - p3) + p3;
                let q2 = rotate_onto(n, &(elbow - p2), &(ap - p2));
                let r4 = (r1 * rot(n, q2) * r3).inverse() * rg * (r5 * r6).inverse();
                // Any direction off axis 4 fixes q4; axis 5's part across it is one.
                let x = w5 - w4 * w4.dot(w5);
                let q4 = rotate_onto(w4, &x, &(r4 * x));
                emit(
                    [b1 as u8, b3 as u8, bw as u8],
                    [q1, q2, q3, q4, q5, q6].map(wrap),
                );
            }
        }
    }
}
