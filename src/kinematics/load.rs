//! The gravity load of one configuration, and how it changes: what bends a compliant robot's
//! joints ([`crate::model::compliance`]: q' = q + delta(q), delta_j = c_j tau_j or its mass-free form).
//!
//! The torques are computed from suffix sums: with M_j the mass (kg) and S_j the first moment
//! (kg mm, world) of the point masses that joint j carries (those on frames j..N, frame N the
//! tool's), and z_j, o_j joint j's axis and a point on it (world),
//! - revolute: tau_j = g . (z_j x (S_j - M_j o_j)) 1e-3 (N m);
//! - prismatic: f_j = M_j g . z_j (N).
//!
//! A small rigid motion of the frames from index `first` on (velocity v + w x x at a world
//! point x; a parameter or a joint variable, per unit of it) changes them by
//! - revolute j >= first (axis and masses move together): g . (w x (z_j x r_j)) 1e-3,
//!   r_j = S_j - M_j o_j (the Jacobi identity);
//! - revolute j < first (only the masses from `first` on move):
//!   g . (z_j x (M_first v + w x S_first)) 1e-3;
//! - prismatic j >= first: M_j g . (w x z_j); prismatic j < first: 0.
//!
//! A motion of the whole chain with gravity (a base parameter: gravity is fixed in the frame
//! after the base row) changes nothing.

use super::Pose;
use super::gravity::{PointMass, mass_points};
use crate::model::chain::Motion;
use crate::model::{Compliance, JointType, Robot};
use nalgebra::{Matrix6x3, Vector3, Vector6};

/// A small rigid motion of the chain from frame `first` on: the velocity of every point x
/// of those frames is v + w x x (world), per unit of whatever moves them.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Twist {
    /// The first frame that moves: joint frame `first` (0-based), or N for the tool frame
    /// alone. Every later frame moves too.
    pub first: usize,
    /// Velocity of the world origin (mm per unit).
    pub v: Vector3<f64>,
    /// Angular velocity (rad per unit).
    pub w: Vector3<f64>,
}

impl Twist {
    /// The unit motion of the frames from `first` on: a rotation about the world line along
    /// `w` through `at` (mm), or with `rotation` false a translation along `w`.
    pub fn about_line(first: usize, rotation: bool, w: Vector3<f64>, at: Vector3<f64>) -> Twist {
        if rotation {
            Twist {
                first,
                v: -w.cross(&at),
                w,
            }
        } else {
            Twist {
                first,
                v: w,
                w: Vector3::zeros(),
            }
        }
    }
}

/// Gravity load at the commanded joints, the joints it makes the robot reach and, for a
/// compliant robot, what the Jacobians need at the reached joints (`columns`, the maps of
/// [`Load::tool_change`]); a workspace inside [`super::Frames`].
#[derive(Debug, Clone)]
pub struct Load {
    /// Whether the robot's joints deflect (non-zero compliances): then the frames of
    /// [`super::Frames`] are those of the deflected joints and these below the commanded
    /// ones'.
    pub compliant: bool,
    /// Joint frames at the commanded joints (world).
    pub joint: Vec<Pose>,
    /// Link frames at the commanded joints (world).
    pub link: Vec<Pose>,
    /// Tool frame at the commanded joints (world).
    pub tool: Pose,
    /// Gravity (m/s^2, world): the robot's, turned by the base row.
    pub gravity: Vector3<f64>,
    /// The point masses at the commanded joints.
    points: Vec<PointMass>,
    /// Each joint's axis direction z_j and a point o_j on it (mm), at the commanded joints.
    axes: Vec<(Vector3<f64>, Vector3<f64>)>,
    /// J'_j: the tool's motion per unit of each reached joint value (world; rows 0-2 mm,
    /// 3-5 rad), at the reached joints. Filled for a compliant robot.
    pub columns: Vec<nalgebra::Vector6<f64>>,
    /// Gravity torque of each joint (N m; N for a prismatic joint).
    pub torque: Vec<f64>,
    /// The joints the robot reaches, q + delta(q) (rad or mm): delta_j = c_j tau_j plus the
    /// mass-free coefficients' deflection.
    pub reached: Vec<f64>,
    /// delta(q) (rad or mm), per joint.
    pub deflection: Vec<f64>,
    /// Each joint's motion at the commanded joints (sine, cosine, offset), from which the
    /// deflected walk turns on.
    pub(crate) motion: Vec<Motion>,
    /// Whether the robot has mass-free compliance coefficients ([`crate::model::compliance`]).
    moments: bool,
    /// c_j (internal units) of each joint, 0 without.
    c: Vec<f64>,
    /// Per joint j and body frame f >= j (at j (N + 1) + f), the sums over bodies b >= f of
    /// k_jb0 (rad per N m times kg), k_jb0 o_b (times kg mm, world) and R_b (k_jb1, k_jb2,
    /// k_jb3) (times kg m, world).
    km: Vec<f64>,
    ks: Vec<Vector3<f64>>,
    kh: Vec<Vector3<f64>>,
    /// Per joint, c_j d tau_j / d w for motions that carry its axis (first <= j), so that
    /// the change is one dot product: c_j ((z_j x r_j) x g) 1e-3 (revolute, r_j = S_j -
    /// M_j o_j) or c_j M_j (z_j x g) (prismatic); zero when c_j is.
    carried: Vec<Vector3<f64>>,
    /// Per joint, c_j d tau_j / d m for motions beyond it (first > j), m = M_f v + w x S_f
    /// the moved masses' change of first moment: c_j (g x z_j) 1e-3 (revolute), zero
    /// (prismatic).
    beyond: Vec<Vector3<f64>>,
    /// M_j (kg) for j = 0..=N.
    suffix_mass: Vec<f64>,
    /// S_j (kg mm, world) for j = 0..=N.
    suffix_moment: Vec<Vector3<f64>>,
    revolute: Vec<bool>,
    /// Per first moved frame f = 0..=N, the tool's motion through the changed deflections
    /// per unit of a motion's w (sum over j >= f of J'_j carried_j^T) and of its moved first
    /// moment (sum over j < f of J'_j beyond_j^T): a motion's whole effect in two 6 x 3
    /// products ([`Load::tool_change`]). Filled by [`Load::fill_maps`] for a compliant robot.
    carried_map: Vec<Matrix6x3<f64>>,
    beyond_map: Vec<Matrix6x3<f64>>,
}

impl Load {
    /// A workspace sized for `robot`.
    pub fn new(robot: &Robot) -> Self {
        let n = robot.dof();
        Load {
            compliant: false,
            joint: vec![Pose::identity(); n],
            link: vec![Pose::identity(); n],
            tool: Pose::identity(),
            gravity: Vector3::zeros(),
            points: Vec::with_capacity(n + 1),
            axes: vec![(Vector3::zeros(), Vector3::zeros()); n],
            columns: vec![nalgebra::Vector6::zeros(); n],
            torque: vec![0.0; n],
            reached: vec![0.0; n],
            deflection: vec![0.0; n],
            motion: vec![Motion::default(); n],
            moments: false,
            c: vec![0.0; n],
            km: vec![0.0; n * (n + 1)],
            ks: vec![Vector3::zeros(); n * (n + 1)],
            kh: vec![Vector3::zeros(); n * (n + 1)],
            carried: vec![Vector3::zeros(); n],
            beyond: vec![Vector3::zeros(); n],
            suffix_mass: vec![0.0; n + 1],
            suffix_moment: vec![Vector3::zeros(); n + 1],
            revolute: robot
                .joints()
                .iter()
                .map(|j| j.joint_type == JointType::Revolute)
                .collect(),
            carried_map: vec![Matrix6x3::zeros(); n + 1],
            beyond_map: vec![Matrix6x3::zeros(); n + 1],
        }
    }

    /// Fills the maps of [`Load::tool_change`] from `columns` (J'_j at the reached joints).
    pub(crate) fn fill_maps(&mut self) {
        let n = self.columns.len();
        self.carried_map[n] = Matrix6x3::zeros();
        for j in (0..n).rev() {
            self.carried_map[j] =
                self.carried_map[j + 1] + self.columns[j] * self.carried[j].transpose();
        }
        self.beyond_map[0] = Matrix6x3::zeros();
        for j in 0..n {
            self.beyond_map[j + 1] =
                self.beyond_map[j] + self.columns[j] * self.beyond[j].transpose();
        }
    }

    /// The tool's motion (world; rows 0-2 mm, 3-5 rad, per unit of what moves) through the
    /// deflections the motion `t` changes: sum over j of J'_j d delta_j, d delta_j = c_j d
    /// tau_j (the module's formulas: carried_j . w for j >= first, beyond_j . dm for j <
    /// first, dm the moved first moment) plus the change through the mass-free
    /// coefficients.
    pub fn tool_change(&self, t: &Twist) -> Vector6<f64> {
        let dm = self.moved_moment(t);
        let mut out = self.carried_map[t.first] * t.w + self.beyond_map[t.first] * dm;
        if self.moments {
            // The mass-free terms, joint by joint.
            for j in 0..self.columns.len() {
                let d = self.moment_change(j, t);
                if d != 0.0 {
                    out += self.columns[j] * d;
                }
            }
        }
        out
    }

    /// From the commanded frames already in `joint`, `link` and `tool`: points, torques,
    /// the joints reached q + delta(q), and the per-joint terms of the deflections' changes
    /// (`carried`, `beyond`, the mass-free suffix sums).
    pub(crate) fn compute(&mut self, robot: &Robot, q: &[f64]) {
        let n = self.joint.len();
        let active = robot.masses().is_some();
        self.compliant = robot.is_compliant();
        let comp = robot.compliance();
        self.moments = comp.is_some_and(|c| c.has_moments());
        self.gravity = world_gravity(robot);
        for j in 0..n {
            self.c[j] = comp.map_or(0.0, |c| c.joint(j));
            self.axes[j] = super::gravity::axis(&self.joint, j);
        }
        if active {
            mass_points(robot, &self.joint, &self.tool, &mut self.points);
            // Totals, then suffixes by removing the masses frame by frame (the order
            // `fk::tool_pose` uses, so that both give the same bits).
            let (mut mass, mut moment) = (0.0, Vector3::zeros());
            for p in &self.points {
                mass += p.mass_kg;
                moment += p.position_mm * p.mass_kg;
            }
            for (j, p) in self.points.iter().enumerate() {
                self.suffix_mass[j] = mass;
                self.suffix_moment[j] = moment;
                if j < n {
                    mass -= p.mass_kg;
                    moment -= p.position_mm * p.mass_kg;
                }
            }
        }
        if let (true, Some(c)) = (self.moments, comp) {
            for j in 0..n {
                let (mut m, mut sm, mut h) = (0.0, Vector3::zeros(), Vector3::zeros());
                for b in (j..=n).rev() {
                    let f = if b < n { &self.joint[b] } else { &self.tool };
                    accumulate_moments(c, n, j, b, f, &mut m, &mut sm, &mut h);
                    let at = j * (n + 1) + b;
                    self.km[at] = m;
                    self.ks[at] = sm;
                    self.kh[at] = h;
                }
            }
        }
        for (j, &qj) in q.iter().enumerate().take(n) {
            let (z, o) = self.axes[j];
            self.torque[j] = if active {
                torque(
                    self.revolute[j],
                    &z,
                    &o,
                    self.suffix_mass[j],
                    &self.suffix_moment[j],
                    &self.gravity,
                )
            } else {
                0.0
            };
            let mut deflection = self.c[j] * self.torque[j];
            if let (true, Some(c)) = (self.moments, comp) {
                // Summed forward, body by body, as `fk::tool_pose` does (same bits).
                let (mut m, mut sm, mut h) = (0.0, Vector3::zeros(), Vector3::zeros());
                for b in j..=n {
                    let f = if b < n { &self.joint[b] } else { &self.tool };
                    accumulate_moments(c, n, j, b, f, &mut m, &mut sm, &mut h);
                }
                deflection +=
                    moment_deflection(self.revolute[j], &z, &o, m, &sm, &h, &self.gravity);
            }
            self.reached[j] = qj + deflection;
            self.deflection[j] = deflection;
            let c = self.c[j];
            let g = self.gravity;
            (self.carried[j], self.beyond[j]) = match (active && c != 0.0, self.revolute[j]) {
                (false, _) => (Vector3::zeros(), Vector3::zeros()),
                (true, true) => {
                    let r = self.suffix_moment[j] - o * self.suffix_mass[j];
                    (z.cross(&r).cross(&g) * (1e-3 * c), g.cross(&z) * (1e-3 * c))
                }
                (true, false) => (z.cross(&g) * (self.suffix_mass[j] * c), Vector3::zeros()),
            };
        }
    }

    /// The change of the first moment (kg mm, world) of the masses the motion `t` moves
    /// without their joint's axis: M_f v + w x S_f, f = `t.first` (zero without masses).
    /// Shared by every joint before f.
    fn moved_moment(&self, t: &Twist) -> Vector3<f64> {
        t.v * self.suffix_mass[t.first] + t.w.cross(&self.suffix_moment[t.first])
    }

    /// The change of joint j's deflection through its mass-free coefficients under the
    /// motion `t` (rad or mm per unit of what moves).
    fn moment_change(&self, j: usize, t: &Twist) -> f64 {
        let n = self.joint.len();
        let (z, o) = self.axes[j];
        let g = &self.gravity;
        match (self.revolute[j], j >= t.first) {
            (true, true) => {
                let at = j * (n + 1) + j;
                let r = (self.ks[at] - o * self.km[at]) * 1e-3 + self.kh[at];
                g.dot(&t.w.cross(&z.cross(&r)))
            }
            (true, false) => {
                let at = j * (n + 1) + t.first;
                let dm =
                    (t.v * self.km[at] + t.w.cross(&self.ks[at])) * 1e-3 + t.w.cross(&self.kh[at]);
                g.dot(&z.cross(&dm))
            }
            (false, true) => self.km[j * (n + 1) + j] * g.dot(&t.w.cross(&z)),
            (false, false) => 0.0,
        }
    }

    /// The motion of joint i's variable (per rad or per mm), at the commanded joints.
    pub fn joint_twist(&self, i: usize) -> Twist {
        let (z, o) = self.axes[i];
        Twist::about_line(i, self.revolute[i], z, o)
    }
}

/// d delta_j / d k_jbi: the deflection of joint j (revolute or not) per unit of its
/// mass-free coefficient for body b (0..=N, N the payload) and part i (0: mass, 1-3: moment
/// x, y, z) at the commanded configuration with joint frames `joint` and tool frame `tool`
/// (world), gravity g (m/s^2, world): rad per (rad per N m) per kg, or per kg m.
pub fn moment_sensitivity(
    joint: &[Pose],
    tool: &Pose,
    g: &Vector3<f64>,
    revolute: bool,
    j: usize,
    b: usize,
    i: usize,
) -> f64 {
    let (z, o) = super::gravity::axis(joint, j);
    let f = if b < joint.len() { &joint[b] } else { tool };
    match (revolute, i) {
        (true, 0) => g.dot(&z.cross(&(f.translation.vector - o))) * 1e-3,
        (true, i) => {
            let e: Vector3<f64> = f.rotation.matrix().column(i - 1).into();
            g.dot(&z.cross(&e))
        }
        (false, 0) => g.dot(&z),
        (false, _) => 0.0,
    }
}

/// The tool's motion per unit of joint i's value with joint frames `joint` and tool frame
/// `tool` (world): [z_i x (p - o_i); z_i] (mm per rad, rad per rad), or [z_i; 0] for a
/// prismatic joint.
#[inline]
pub(crate) fn axis_column(
    joint: &[Pose],
    tool: &Pose,
    revolute: bool,
    i: usize,
) -> nalgebra::Vector6<f64> {
    let p = tool.translation.vector;
    let (z, o) = super::gravity::axis(joint, i);
    let (lin, ang) = if revolute {
        (z.cross(&(p - o)), z)
    } else {
        (z, Vector3::zeros())
    };
    nalgebra::Vector6::new(lin.x, lin.y, lin.z, ang.x, ang.y, ang.z)
}

/// Adds body b's mass-free terms of joint j, its frame `f` (world), to the sums k0, k0 o
/// and R k.
#[allow(clippy::too_many_arguments)]
#[inline]
pub(crate) fn accumulate_moments(
    c: &Compliance,
    n: usize,
    j: usize,
    b: usize,
    f: &Pose,
    m: &mut f64,
    s: &mut Vector3<f64>,
    h: &mut Vector3<f64>,
) {
    let k0 = c.moment(n, j, b, 0);
    let k = Vector3::new(
        c.moment(n, j, b, 1),
        c.moment(n, j, b, 2),
        c.moment(n, j, b, 3),
    );
    *m += k0;
    *s += f.translation.vector * k0;
    *h += f.rotation * k;
}

/// The robot's gravity in the world (m/s^2): its mass properties' (or -9.81 along z), given
/// in the frame after the base row and turned by it.
pub fn world_gravity(robot: &Robot) -> Vector3<f64> {
    robot.chain().base.rotation
        * robot
            .masses()
            .map_or(Vector3::new(0.0, 0.0, -9.81), |m| m.gravity)
}

/// The mass-free deflection of one joint (rad; mm if prismatic) with axis z through o
/// (world) from the sums of its coefficients over the bodies it carries: k0 (rad per N m
/// times kg), k0 o (times kg mm) and R k (times kg m), gravity g (m/s^2, world).
#[inline]
pub(crate) fn moment_deflection(
    revolute: bool,
    z: &Vector3<f64>,
    o: &Vector3<f64>,
    m: f64,
    s: &Vector3<f64>,
    h: &Vector3<f64>,
    g: &Vector3<f64>,
) -> f64 {
    if revolute {
        g.dot(&z.cross(&((s - o * m) * 1e-3 + h)))
    } else {
        m * g.dot(z)
    }
}

/// The gravity torque of one joint (N m; N if prismatic) with axis z through o (world) from
/// the mass (kg) and first moment (kg mm, world) it carries; gravity g (m/s^2, world).
#[inline]
pub(crate) fn torque(
    revolute: bool,
    z: &Vector3<f64>,
    o: &Vector3<f64>,
    mass: f64,
    moment: &Vector3<f64>,
    g: &Vector3<f64>,
) -> f64 {
    if revolute {
        g.dot(&z.cross(&(moment - o * mass))) * 1e-3
    } else {
        mass * g.dot(z)
    }
}
