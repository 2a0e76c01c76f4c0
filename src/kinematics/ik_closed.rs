//! Closed-form inverse kinematics for 6R robots of two classes, up to 8 solutions each:
//! - the thesis robot's (App. B): axes 2 and 3 parallel, axes 4, 5 and 6 meeting in one point
//!   (a spherical wrist); 2 solutions for joint 1 x 2 elbows x 2 wrists;
//! - the UR class (Universal Robots' arms): axes 2, 3 and 4 parallel, axis 5 meeting axes 4
//!   and 6 ([`super::ik_parallel`]); 2 for joint 1 x 2 for joint 5 (wrist) x 2 elbows.
//!
//! Thesis App. B solves the FANUC's equations symbolically; here the same decoupling is done
//! on the product-of-exponentials form T(q) = e1(q1) ... e6(q6) M, with the joint axes read
//! from the model at q = 0. Each step is a Paden-Kahan subproblem, so the solver works for
//! any convention (MDH, Hayati, DH) and any base and tool that give this structure. With a
//! spherical wrist:
//! 1. the wrist centre W = G W0 (G = T M^-1) depends on q1..q3 only;
//! 2. q1: the arm plane (normal to axes 2 and 3) must hold W, `a cos q1 + b sin q1 = c`;
//! 3. q3: subproblem 3, the distance from axis 2 to W fixes the elbow;
//! 4. q2: subproblem 1 swings the elbow onto W;
//! 5. q4, q5: subproblem 2 points axis 6 where the target needs it; q6: subproblem 1.

use super::Pose;
use super::fk::{Frames, frames};
use super::subproblems::{
    Beyond, STRUCTURE_TOL, closest_points, root_wanted, rot, rotate_onto, rotate_to_distance,
    rotate_two_axes, shoulder_angles, wrap,
};
use crate::error::{Error, Result};
use crate::model::{JointType, Robot};
use nalgebra::Vector3;
use std::f64::consts::PI;

type V3 = Vector3<f64>;

/// Sine of the angle between axis 4 and axis 6 (as q5 turns it) below which the wrist counts
/// as singular ([`ClosedFormIk::wrist_split_nearest`]). The closed form's q5 there is good
/// to about the square root of the rounding (subproblem 2 takes a square root: 1e-8 rad), so
/// the bound must lie above that; a solution within it is put on the singularity, which
/// turns the tool by about this angle over the sine between axes 5 and 6 (1e-7 rad for a
/// wrist whose axes 5 and 6 are perpendicular: 3e-5 mm at 300 mm from the wrist). A pose read
/// from a file of 4 decimals of a degree (1.7e-6 rad) lies outside it: its closed-form split
/// is then the arithmetic's (a numerical solve from the seed keeps the seed's).
pub const WRIST_ALIGNED: f64 = 1e-7;

/// Which of the closed form's up to 8 solutions: one of two roots for joint 1 (shoulder), for
/// joint 3 (elbow) and for joints 4-5 (wrist flip), in the solver's fixed order. A controller's
/// configuration flags name the same choice; a pose keeps its branch under small changes away
/// from singularities, which is what target compensation relies on.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Branch {
    /// Root of the joint-1 equation, 0 or 1.
    pub shoulder: u8,
    /// Root of the joint-3 (elbow) subproblem, 0 or 1.
    pub elbow: u8,
    /// Root of the joints 4-5 subproblem (wrist flip), 0 or 1; for the UR class, of joint
    /// 5's equation (the sign of q5).
    pub wrist: u8,
}

impl std::fmt::Display for Branch {
    /// `s<shoulder>e<elbow>w<wrist>`, each 0 or 1 (text, so that it stays text in JSON).
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "s{}e{}w{}", self.shoulder, self.elbow, self.wrist)
    }
}

/// A closed-form solver built once for a robot and reused for many poses.
#[derive(Debug, Clone)]
pub struct ClosedFormIk {
    /// Joint axis directions at q = 0 (world, unit).
    w: [V3; 6],
    /// A point on each joint axis at q = 0 (world, mm).
    p: [V3; 6],
    /// Which class the robot is of, with its points at q = 0.
    structure: Structure,
    /// Inverse of the tool pose at q = 0.
    m_inv: Pose,
    /// Joint limits (rad).
    limits: [[f64; 2]; 6],
    /// The q5 (rad) at which axis 6 lies on axis 4 (first) and on its opposite (second),
    /// where some q5 does: a spherical wrist's singularities
    /// ([`ClosedFormIk::straight_wrist`]; none for the UR class).
    straight: [Option<f64>; 2],
    /// |w5 x w6|: the radius of the cone axis 6 sweeps about axis 5, so that q5 off a
    /// singular value by e turns axis 6 off axis 4 by about e times this.
    cone: f64,
}

/// The two classes of robot the closed form solves.
#[derive(Debug, Clone, Copy)]
enum Structure {
    /// Axes 4, 5 and 6 meet in the wrist centre (mm, at q = 0).
    SphericalWrist { centre: V3 },
    /// Axes 2, 3 and 4 parallel; axis 5 meets axis 4 at `a` and axis 6 at `b` (mm, at
    /// q = 0).
    ParallelAxes { a: V3, b: V3 },
}

fn distance_to_line(x: &V3, p: &V3, d: &V3) -> f64 {
    let r = x - p;
    (r - d * d.dot(&r)).norm()
}

impl ClosedFormIk {
    /// Checks the robot's structure at q = 0 and prepares the solver.
    pub fn new(robot: &Robot) -> Result<Self> {
        if robot.dof() != 6 {
            return Err(Error::NoClosedForm(format!(
                "it has {} joints, not 6",
                robot.dof()
            )));
        }
        if robot
            .joints()
            .iter()
            .any(|j| j.joint_type != JointType::Revolute)
        {
            return Err(Error::NoClosedForm("not every joint is revolute".into()));
        }
        let mut f = Frames::new(robot);
        frames(robot, &[0.0; 6], &mut f);
        let mut w = [V3::zeros(); 6];
        let mut p = [V3::zeros(); 6];
        for i in 0..6 {
            w[i] = f.joint[i].rotation.matrix().column(2).into();
            p[i] = f.joint[i].translation.vector;
        }
        if w[1].cross(&w[2]).norm() > STRUCTURE_TOL {
            return Err(Error::NoClosedForm("axes 2 and 3 are not parallel".into()));
        }
        if w[0].cross(&w[1]).norm() < 1e-6 {
            return Err(Error::NoClosedForm("axes 1 and 2 are parallel".into()));
        }
        let structure = match spherical_wrist(&w, &p) {
            Ok(centre) => Structure::SphericalWrist { centre },
            Err(spherical) => match super::ik_parallel::structure(&w, &p) {
                Ok((a, b)) => Structure::ParallelAxes { a, b },
                Err(parallel) => {
                    return Err(Error::NoClosedForm(format!(
                        "{spherical}, nor is it of the UR class: {parallel}"
                    )));
                }
            },
        };
        let mut limits = [[0.0; 2]; 6];
        for (l, j) in limits.iter_mut().zip(robot.joints()) {
            *l = j.limits_internal();
        }
        // Axis 6 meets +-axis 4 as q5 turns where both make the same angle with axis 5.
        let straight = match structure {
            Structure::SphericalWrist { .. } => [1.0, -1.0].map(|s: f64| {
                let target = w[3] * s;
                ((w[4].dot(&w[5]) - w[4].dot(&target)).abs() < STRUCTURE_TOL)
                    .then(|| wrap(rotate_onto(&w[4], &w[5], &target)))
            }),
            Structure::ParallelAxes { .. } => [None, None],
        };
        Ok(ClosedFormIk {
            w,
            p,
            structure,
            m_inv: f.tool.inverse(),
            limits,
            straight,
            cone: w[4].cross(&w[5]).norm(),
        })
    }

    /// Whether the robot is of the UR class (axes 2, 3 and 4 parallel) rather than one with
    /// a spherical wrist.
    pub fn is_ur_class(&self) -> bool {
        matches!(self.structure, Structure::ParallelAxes { .. })
    }

    /// This solver for the arm moved in the world by `left` and carrying `right` beyond its
    /// tool: the closed form of the robot whose tool pose is left T(q) right (mm), T(q) this
    /// solver's. A pose carried along keeps its joint values and branches: the solver reads
    /// only the axes' geometry relative to the target.
    pub fn moved(&self, left: &Pose, right: &Pose) -> ClosedFormIk {
        let point = |p: &V3| left.transform_point(&(*p).into()).coords;
        ClosedFormIk {
            w: self.w.map(|w| left.rotation * w),
            p: self.p.map(|p| point(&p)),
            structure: match self.structure {
                Structure::SphericalWrist { centre } => Structure::SphericalWrist {
                    centre: point(&centre),
                },
                Structure::ParallelAxes { a, b } => Structure::ParallelAxes {
                    a: point(&a),
                    b: point(&b),
                },
            },
            m_inv: (left * self.m_inv.inverse() * right).inverse(),
            limits: self.limits,
            straight: self.straight,
            cone: self.cone,
        }
    }

    /// The closed form of `nominal` (this solver's robot) placed at `robot`'s base and tool
    /// ([`ClosedFormIk::moved`]): starts for the numerical solves of `robot`, a
    /// calibration of `nominal`, in `robot`'s world frame, which a base registered to a
    /// tracker puts metres from the nominal's.
    pub fn placed_as(&self, nominal: &Robot, robot: &Robot) -> ClosedFormIk {
        let left = robot.base().transform() * nominal.base().transform().inverse();
        let right = nominal.tool().transform().inverse() * robot.tool().transform();
        self.moved(&left, &right)
    }

    /// Every solution for `target` (tool pose, mm), wrapped to [-pi, pi), ignoring limits.
    /// Up to 8; none when the pose is out of reach. At a singularity (wrist centre on axis 1,
    /// or q5 such that axes 4 and 6 align) one representative of the continuum is returned
    /// (at a spherical wrist's, an arbitrary split of q4 + s q6: see
    /// [`ClosedFormIk::wrist_split_nearest`]; at a UR-class wrist's, where q6 is free, q6 the
    /// middle of its range's where the elbow reaches, else the nearest that does:
    /// [`ClosedFormIk::solve_unlimited_near`] takes a reference's instead).
    pub fn solve_unlimited(&self, target: &Pose, out: &mut Vec<[f64; 6]>) {
        out.clear();
        self.each_solution(target, None, Beyond::Nothing, None, |_, q| out.push(q));
    }

    /// [`ClosedFormIk::solve_unlimited`] at a UR-class wrist singularity with q6 that of
    /// `reference` (rad) where the elbow reaches ([`super::ik_parallel`]); the same elsewhere.
    pub fn solve_unlimited_near(&self, target: &Pose, reference: &[f64], out: &mut Vec<[f64; 6]>) {
        six_joints(reference);
        out.clear();
        self.each_solution(target, Some(reference), Beyond::Nothing, None, |_, q| {
            out.push(q)
        });
    }

    /// As [`ClosedFormIk::solve_unlimited`], each solution with its [`Branch`].
    pub fn solve_branches(&self, target: &Pose, out: &mut Vec<(Branch, [f64; 6])>) {
        out.clear();
        self.each_solution(target, None, Beyond::Nothing, None, |b, q| out.push((b, q)));
    }

    /// [`ClosedFormIk::solve_branches`] with a UR-class wrist singularity's q6 that of
    /// `reference` (rad) where the elbow reaches, as [`ClosedFormIk::solve_unlimited_near`].
    pub fn solve_branches_near(
        &self,
        target: &Pose,
        reference: &[f64],
        out: &mut Vec<(Branch, [f64; 6])>,
    ) {
        out.clear();
        self.each_solution(target, Some(reference), Beyond::Nothing, None, |b, q| {
            out.push((b, q))
        });
    }

    /// The solution of `target` on `branch` (wrapped to [-pi, pi), ignoring limits), at a
    /// singularity the representative [`ClosedFormIk::solve_branches_near`] gives for
    /// `reference` (rad); where the branch does not reach the pose, its nearest
    /// ([`Beyond::Nearest`]: each step without a root takes the tangent angle, a stretched
    /// elbow, a tangent shoulder or wrist, and both branches of it keep their labels). None
    /// only where a step has no nearest either (the point on axis 1, with nothing to fix q1).
    pub fn solve_branch_nearest(
        &self,
        target: &Pose,
        branch: Branch,
        reference: &[f64],
    ) -> Option<[f64; 6]> {
        let mut found = None;
        self.each_solution(
            target,
            Some(reference),
            Beyond::Nearest,
            Some(branch),
            |_, q| found = Some(q),
        );
        found
    }

    /// [`ClosedFormIk::solve_branches_near`], and where a branch does not reach the pose its
    /// nearest ([`ClosedFormIk::solve_branch_nearest`]): every branch the structure has (which
    /// of them reach the pose, [`ClosedFormIk::solve_branches_near`] says).
    pub fn solve_branches_nearest(
        &self,
        target: &Pose,
        reference: &[f64],
        out: &mut Vec<(Branch, [f64; 6])>,
    ) {
        out.clear();
        self.each_solution(target, Some(reference), Beyond::Nearest, None, |b, q| {
            out.push((b, q))
        });
    }

    /// The tool pose (mm) at joints `q` (rad) of the robot this solver was built for (moved
    /// as it was moved): the product of exponentials e1(q1) ... e6(q6) M the solver inverts,
    /// each e_i the turn by q_i about axis i (direction w_i through the point p_i). It equals
    /// the robot's forward kinematics to rounding.
    pub fn pose(&self, q: &[f64]) -> Pose {
        let mut g = Pose::identity();
        for ((w, p), &angle) in self.w.iter().zip(&self.p).zip(q) {
            let r = rot(w, angle);
            g *= Pose::from_parts((p - r * p).into(), r);
        }
        g * self.m_inv.inverse()
    }

    /// Every solution; at a UR-class wrist singularity q6 is `reference`'s where it can be,
    /// else the middle of joint 6's range's.
    fn each_solution(
        &self,
        target: &Pose,
        reference: Option<&[f64]>,
        beyond: Beyond,
        only: Option<Branch>,
        mut emit: impl FnMut(Branch, [f64; 6]),
    ) {
        let g = target * self.m_inv;
        let only = only.map(|b| [b.shoulder, b.elbow, b.wrist]);
        match self.structure {
            Structure::SphericalWrist { centre } => self.spherical(&g, &centre, beyond, only, emit),
            Structure::ParallelAxes { a, b } => {
                let branch = |[shoulder, elbow, wrist]: [u8; 3]| Branch {
                    shoulder,
                    elbow,
                    wrist,
                };
                let [lo, hi] = self.limits[5];
                let hint = reference.map_or(0.5 * (lo + hi), |r| r[5]);
                super::ik_parallel::each_solution(
                    &self.w,
                    &self.p,
                    [&a, &b],
                    &g,
                    hint,
                    (beyond, only),
                    |r, q| emit(branch(r), q),
                )
            }
        }
    }

    /// [`ClosedFormIk::each_solution`] of a spherical wrist of centre `w0` (mm, at q = 0) for
    /// G = T M^-1, beyond the reach as `beyond` says (with [`Beyond::Nearest`] equal roots
    /// are emitted as two branches), of the roots `only` alone where given.
    fn spherical(
        &self,
        g: &Pose,
        w0: &V3,
        beyond: Beyond,
        only: Option<[u8; 3]>,
        mut emit: impl FnMut(Branch, [f64; 6]),
    ) {
        let merge = beyond == Beyond::Nothing;
        let [w1, w2, w3, w4, w5, w6] = &self.w;
        let [p1, p2, p3, ..] = &self.p;
        let wc = g.rotation * w0 + g.translation.vector;

        let Some(q1s) = shoulder_angles(w1, w2, p1, &wc, w0, beyond) else {
            return;
        };
        let q1s: &[f64] = &q1s;
        let dedup1 = merge && (q1s[0] - q1s[1]).abs() < 1e-14;
        for (b1, &q1) in q1s[..if dedup1 { 1 } else { 2 }].iter().enumerate() {
            if !root_wanted(only, 0, b1) {
                continue;
            }
            let r1 = rot(w1, q1);
            let wp = r1.inverse() * (wc - p1) + p1;
            let delta = (wp - p2).norm();
            let Some(q3s) = rotate_to_distance(w3, &(w0 - p3), &(p2 - p3), delta, beyond) else {
                continue;
            };
            let dedup3 = merge && (q3s[0] - q3s[1]).abs() < 1e-14;
            for (b3, &q3) in q3s[..if dedup3 { 1 } else { 2 }].iter().enumerate() {
                if !root_wanted(only, 1, b3) {
                    continue;
                }
                let r3 = rot(w3, q3);
                let elbow = r3 * (w0 - p3) + p3;
                let q2 = rotate_onto(w2, &(elbow - p2), &(wp - p2));
                let r123 = r1 * rot(w2, q2) * r3;
                let rw = r123.inverse() * g.rotation;
                let Some(wrists) = rotate_two_axes(w4, w5, w6, &(rw * w6), beyond) else {
                    continue;
                };
                let dedupw = merge
                    && (wrists[0][0] - wrists[1][0]).abs() < 1e-14
                    && (wrists[0][1] - wrists[1][1]).abs() < 1e-14;
                for (bw, &[q4, q5]) in wrists[..if dedupw { 1 } else { 2 }].iter().enumerate() {
                    if !root_wanted(only, 2, bw) {
                        continue;
                    }
                    // Any vector off axis 6 fixes q6; axis 5 is perpendicular to it here.
                    let x = w5 - w6 * w6.dot(w5);
                    let y = (rot(w4, q4) * rot(w5, q5)).inverse() * (rw * x);
                    let q6 = rotate_onto(w6, &x, &y);
                    let branch = Branch {
                        shoulder: b1 as u8,
                        elbow: b3 as u8,
                        wrist: bw as u8,
                    };
                    emit(branch, [q1, q2, q3, q4, q5, q6].map(wrap));
                }
            }
        }
    }

    /// Every solution within the joint limits, including the copies shifted by multiples of
    /// 360 deg that the limits allow; solutions equal modulo 360 deg (within 1e-9 rad) are
    /// merged first, and a copy within 1e-6 rad of one already listed is dropped, so
    /// the copies are distinct. At most [`MAX_SOLUTIONS`] are listed: false when more exist
    /// (joint ranges of many turns; see [`ClosedFormIk::solve_nearest`]).
    /// At a wrist singularity, the split of q4 + s q6 nearest the middle of the ranges.
    pub fn solve(&self, target: &Pose, out: &mut Vec<[f64; 6]>) -> bool {
        let mid = self.limits.map(|[lo, hi]| 0.5 * (lo + hi));
        self.solve_around(target, &mid, out)
    }

    /// [`ClosedFormIk::solve`], a wrist singularity's split of q4 + s q6 the one nearest
    /// `reference` (rad).
    pub fn solve_around(&self, target: &Pose, reference: &[f64], out: &mut Vec<[f64; 6]>) -> bool {
        let mut raw = Vec::with_capacity(8);
        self.solve_unlimited_near(target, reference, &mut raw);
        for q in &mut raw {
            *q = self.wrist_split_within_limits(q, reference);
        }
        out.clear();
        let roots = distinct_mod_turn(&raw);
        let mut twin = Vec::new();
        for (i, q) in roots.iter().enumerate() {
            // A straight elbow's two roots, split by rounding: the copies of the second that
            // the first's already list go, the rest stay (where a limit lies at the straight
            // elbow, only one root's copies may be within it). Its copies count against
            // MAX_SOLUTIONS only once the duplicates are gone.
            if roots[..i]
                .iter()
                .any(|o| same_mod_turn(o, q, SAME_ROOT_RAD))
            {
                twin.clear();
                if !self.push_copies(q, &mut twin) {
                    return false;
                }
                for c in &twin {
                    let seen = (out.iter())
                        .any(|o| (o.iter().zip(c)).all(|(x, y)| (x - y).abs() < SAME_ROOT_RAD));
                    if !seen {
                        out.push(*c);
                    }
                }
                if out.len() > MAX_SOLUTIONS {
                    return false;
                }
            } else if !self.push_copies(q, out) {
                return false;
            }
        }
        true
    }

    /// The solution within the limits nearest `reference` (rad, Euclidean over the joints):
    /// each joint's copy is chosen on its own, so ranges of many turns cost nothing.
    pub fn solve_nearest(&self, target: &Pose, reference: &[f64]) -> Option<[f64; 6]> {
        let mut raw = Vec::with_capacity(8);
        self.solve_unlimited_near(target, reference, &mut raw);
        let mut best: Option<(f64, [f64; 6])> = None;
        for q in &raw {
            let (cand, inside) = self.nearest_copy(q, reference);
            if !inside {
                continue;
            }
            let dist = crate::model::joint_distance(&cand, reference);
            if best.is_none_or(|(d, _)| dist < d) {
                best = Some((dist, cand));
            }
        }
        best.map(|(_, q)| q)
    }

    /// At a wrist singularity of `q` (q5 turns axis 6 onto axis 4, or onto its opposite, to
    /// within [`WRIST_ALIGNED`]) the pose depends on q4 + s q6 alone, not on q4 and q6 each
    /// (s = +1 or -1 as the two axes then point the same way or opposite ways: R4 R5 R6 =
    /// Rot(w4, q4 + s q6) R5): `q` put on the singularity (q5 where the axes align exactly)
    /// with that sum split nearest `reference` (rad: q4 and q6 the reference's, each moved by
    /// half of what the sum lacks, over the sum's nearest whole turn), so that a reference on
    /// the continuum is returned as it is. Elsewhere `q` unchanged.
    pub fn wrist_split_nearest(&self, q: &[f64; 6], reference: &[f64]) -> [f64; 6] {
        six_joints(reference);
        match self.straight_wrist(q) {
            Some(s) => self.split_nearest(q, s, reference),
            None => *q,
        }
    }

    /// [`ClosedFormIk::wrist_split_nearest`] of a `q` at a straight wrist of sign `s`.
    fn split_nearest(&self, q: &[f64; 6], s: f64, reference: &[f64]) -> [f64; 6] {
        let d = wrap(q[3] + s * q[5] - (reference[3] + s * reference[5]));
        let singular = self.straight[usize::from(s < 0.0)].unwrap_or(q[4]);
        let mut out = *q;
        out[3] = reference[3] + 0.5 * d;
        out[4] = q[4] + wrap(singular - q[4]);
        out[5] = reference[5] + s * 0.5 * d;
        out
    }

    /// s of [`ClosedFormIk::wrist_split_nearest`] (+1 or -1) where `q` is at a wrist
    /// singularity (within [`WRIST_ALIGNED`]); None elsewhere.
    pub fn straight_wrist(&self, q: &[f64; 6]) -> Option<f64> {
        // No trigonometry: this runs for every closed-form solution.
        let near =
            |at: Option<f64>| at.is_some_and(|a| wrap(q[4] - a).abs() * self.cone <= WRIST_ALIGNED);
        if near(self.straight[0]) {
            Some(1.0)
        } else if near(self.straight[1]) {
            Some(-1.0)
        } else {
            None
        }
    }

    /// The copy of `q` (each joint shifted by whole turns) nearest `reference` (rad) joint by
    /// joint among the copies within the limits, and true; when some joint has no copy within
    /// its limits, the copy nearest `reference` and false. At a wrist singularity, q4 and q6
    /// split first as [`ClosedFormIk::wrist_split_within_limits`] does.
    pub fn nearest_copy(&self, q: &[f64; 6], reference: &[f64]) -> ([f64; 6], bool) {
        self.turn_copy(&self.wrist_split_within_limits(q, reference), reference)
    }

    /// [`ClosedFormIk::wrist_split_nearest`] within joint 4's and joint 6's ranges: of
    /// the splits q4 + s q6 = t + 2 pi n whose q4 and q6 both lie within them (each line of the
    /// continuum through the ranges' box, from the point nearest `reference` along the line
    /// to the box), the one nearest `reference` (rad); the unconstrained split where no line
    /// crosses the box. `q` unchanged away from a wrist singularity.
    pub fn wrist_split_within_limits(&self, q: &[f64; 6], reference: &[f64]) -> [f64; 6] {
        six_joints(reference);
        let Some(s) = self.straight_wrist(q) else {
            return *q;
        };
        let split = self.split_nearest(q, s, reference);
        let tau = 2.0 * PI;
        let ([lo4, hi4], [lo6, hi6]) = (self.limits[3], self.limits[5]);
        let (r4, r6) = (reference[3], reference[5]);
        let t = split[3] + s * split[5];
        // The lines a + s b = t + 2 pi n that cross the box; n = 0 is the line through the
        // reference's nearest split. Ranges of many turns hold many lines: those within 256
        // of it hold the nearest of any real robot.
        let (c_lo, c_hi) = (lo4 + (s * lo6).min(s * hi6), hi4 + (s * lo6).max(s * hi6));
        let n_lo = ((c_lo - t) / tau).ceil().max(-256.0);
        let n_hi = ((c_hi - t) / tau).floor().min(256.0);
        let mut best: Option<(f64, f64, f64)> = None;
        let mut n = n_lo;
        while n <= n_hi {
            let d = t + n * tau - (r4 + s * r6);
            let (a0, b0) = (r4 + 0.5 * d, r6 + s * 0.5 * d);
            // Along the line: a = a0 + l, b = b0 - s l, both within their ranges.
            let (l4, h4) = (lo4 - a0, hi4 - a0);
            let (l6, h6) = if s > 0.0 {
                (b0 - hi6, b0 - lo6)
            } else {
                (lo6 - b0, hi6 - b0)
            };
            let (lo, hi) = (l4.max(l6), h4.min(h6));
            if lo <= hi {
                let l = 0f64.clamp(lo, hi);
                let (a, b) = (a0 + l, b0 - s * l);
                let dist = (a - r4).powi(2) + (b - r6).powi(2);
                if best.is_none_or(|(d, ..)| dist < d) {
                    best = Some((dist, a, b));
                }
            }
            n += 1.0;
        }
        let mut out = split;
        if let Some((_, a, b)) = best {
            (out[3], out[5]) = (a, b);
        }
        out
    }

    /// [`ClosedFormIk::nearest_copy`] of `q` as it is (whole turns only).
    fn turn_copy(&self, q: &[f64; 6], reference: &[f64]) -> ([f64; 6], bool) {
        let tau = 2.0 * PI;
        let mut cand = *q;
        let mut inside = true;
        for j in 0..6 {
            let k = ((reference[j] - q[j]) / tau).round();
            let k = match self.turns(j, q[j]) {
                Some((kmin, kmax)) => k.clamp(kmin as f64, kmax as f64),
                None => {
                    inside = false;
                    k
                }
            };
            cand[j] = q[j] + k * tau;
        }
        (cand, inside)
    }

    /// The range of whole turns k for which joint `j` at `v + 2 pi k` (rad) lies within its
    /// limits (tolerance 1e-9 rad); None when no copy does.
    fn turns(&self, j: usize, v: f64) -> Option<(i64, i64)> {
        const TOL: f64 = 1e-9;
        let tau = 2.0 * PI;
        let [lo, hi] = self.limits[j];
        let kmin = ((lo - TOL - v) / tau).ceil() as i64;
        let kmax = ((hi + TOL - v) / tau).floor() as i64;
        (kmin <= kmax).then_some((kmin, kmax))
    }

    /// Pushes every 2 pi copy of `q` within the limits (tolerance 1e-9 rad); false, with
    /// nothing pushed, when `out` would pass [`MAX_SOLUTIONS`].
    fn push_copies(&self, q: &[f64; 6], out: &mut Vec<[f64; 6]>) -> bool {
        let tau = 2.0 * PI;
        let mut ranges = [(0i64, -1i64); 6];
        let mut count = 1usize;
        for j in 0..6 {
            let Some((kmin, kmax)) = self.turns(j, q[j]) else {
                return true;
            };
            ranges[j] = (kmin, kmax);
            count = count.saturating_mul((kmax - kmin + 1) as usize);
        }
        if out.len().saturating_add(count) > MAX_SOLUTIONS {
            return false;
        }
        let mut k = ranges.map(|r| r.0);
        loop {
            let mut cand = *q;
            for j in 0..6 {
                cand[j] += k[j] as f64 * tau;
            }
            out.push(cand);
            // Odometer over the copy indices.
            let mut j = 0;
            loop {
                if j == 6 {
                    return true;
                }
                if k[j] < ranges[j].1 {
                    k[j] += 1;
                    break;
                }
                k[j] = ranges[j].0;
                j += 1;
            }
        }
    }
}

/// The wrist centre (mm, at q = 0) where axes 4, 5 and 6 (directions `w`, points `p` at
/// q = 0) meet in one point; else why not.
fn spherical_wrist(w: &[V3; 6], p: &[V3; 6]) -> std::result::Result<V3, String> {
    let (a, b) = closest_points(&p[3], &w[3], &p[4], &w[4])
        .ok_or_else(|| "axes 4 and 5 are parallel".to_string())?;
    if (a - b).norm() > STRUCTURE_TOL {
        return Err(format!(
            "axes 4 and 5 do not intersect (they pass {:.3e} mm apart): no spherical wrist",
            (a - b).norm()
        ));
    }
    let w0 = (a + b) * 0.5;
    let off = distance_to_line(&w0, &p[5], &w[5]);
    if off > STRUCTURE_TOL {
        return Err(format!(
            "axis 6 misses the intersection of axes 4 and 5 by {off:.3e} mm: no spherical wrist"
        ));
    }
    if w[4].cross(&w[5]).norm() < 1e-6 {
        return Err("axes 5 and 6 are parallel".into());
    }
    Ok(w0)
}

/// Most solutions [`ClosedFormIk::solve`] lists for one pose.
pub const MAX_SOLUTIONS: usize = 10_000;

/// Two closed-form solutions within this of each other on every joint (rad) are one. At a
/// straight elbow the two elbow roots are one configuration, but the closed form takes the
/// elbow angle from an arccosine next to 1, so rounding leaves them about 5e-8 rad apart
/// (UR10, q3 = 0: 142 such pairs in 300 poses were listed twice); no encoder tells apart
/// configurations 1e-6 rad apart.
const SAME_ROOT_RAD: f64 = 1e-6;

/// Whether `a` and `b` (rad) are within `tol` of each other modulo 2 pi on every joint.
fn same_mod_turn(a: &[f64; 6], b: &[f64; 6], tol: f64) -> bool {
    let tau = 2.0 * PI;
    (a.iter().zip(b)).all(|(x, y)| ((x - y + PI).rem_euclid(tau) - PI).abs() < tol)
}

/// `raw` without solutions equal to an earlier one modulo 2 pi on every joint (1e-9 rad).
fn distinct_mod_turn(raw: &[[f64; 6]]) -> Vec<[f64; 6]> {
    let mut out: Vec<[f64; 6]> = Vec::with_capacity(raw.len());
    for q in raw {
        if !out.iter().any(|o| same_mod_turn(o, q, 1e-9)) {
            out.push(*q);
        }
    }
    out
}

/// Panics unless `reference` holds six joints (rad): every function of [`ClosedFormIk`]
/// taking a reference reads all six and checks them here, first or through the function it
/// starts with (some only at a wrist singularity, where a short one
/// would pass ordinary use and fail there), as [`crate::kinematics::tool_pose`] requires a
/// joint per joint.
fn six_joints(reference: &[f64]) {
    assert_eq!(
        reference.len(),
        6,
        "a closed-form reference holds the six joints (rad) of the arm"
    );
}
