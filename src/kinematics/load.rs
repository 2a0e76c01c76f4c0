//! The gravity load of one configuration, and how it changes: what bends a compliant robot's
//! joints ([`crate::model::compliance`]: q' = q + c tau(q)).
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
use crate::model::{JointType, Robot};
use nalgebra::{DMatrix, Vector3};

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

/// Gravity load at the commanded joints; a workspace inside [`super::Frames`].
#[derive(Debug, Clone)]
pub struct Load {
    /// Whether the robot has mass properties (otherwise the rest is unused).
    pub active: bool,
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
    pub points: Vec<PointMass>,
    /// Gravity torque of each joint (N m; N for a prismatic joint).
    pub torque: Vec<f64>,
    /// Deflection of each joint, c_j tau_j (rad; mm for a prismatic joint).
    pub deflection: Vec<f64>,
    /// The joints the robot reaches, q + deflection (rad or mm).
    pub reached: Vec<f64>,
    /// D = C d tau / d q (n x n, rad per rad and the like): d q' / d q = I + D. Filled only
    /// for a compliant robot.
    pub deflection_jacobian: DMatrix<f64>,
    /// M_j (kg) for j = 0..=N.
    suffix_mass: Vec<f64>,
    /// S_j (kg mm, world) for j = 0..=N.
    suffix_moment: Vec<Vector3<f64>>,
    revolute: Vec<bool>,
}

impl Load {
    /// A workspace sized for `robot`.
    pub fn new(robot: &Robot) -> Self {
        let n = robot.dof();
        Load {
            active: false,
            compliant: false,
            joint: vec![Pose::identity(); n],
            link: vec![Pose::identity(); n],
            tool: Pose::identity(),
            gravity: Vector3::zeros(),
            points: Vec::with_capacity(n + 1),
            torque: vec![0.0; n],
            deflection: vec![0.0; n],
            reached: vec![0.0; n],
            deflection_jacobian: DMatrix::zeros(n, n),
            suffix_mass: vec![0.0; n + 1],
            suffix_moment: vec![Vector3::zeros(); n + 1],
            revolute: robot
                .joints()
                .iter()
                .map(|j| j.joint_type == JointType::Revolute)
                .collect(),
        }
    }

    /// From the commanded frames already in `joint`, `link` and `tool`: points, torques,
    /// deflections and the joints reached `q + deflection`; with `jacobian`, also
    /// [`Load::deflection_jacobian`]. The robot must have masses.
    pub(crate) fn compute(&mut self, robot: &Robot, q: &[f64], jacobian: bool) {
        let Some(m) = robot.masses() else {
            self.active = false;
            return;
        };
        self.active = true;
        self.compliant = robot.is_compliant();
        self.gravity = robot.chain().base.rotation * m.gravity;
        mass_points(robot, &self.joint, &self.tool, &mut self.points);
        let n = self.joint.len();
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
        for (j, &qj) in q.iter().enumerate().take(n) {
            let (z, o) = super::gravity::axis(&self.joint, j);
            self.torque[j] = torque(
                self.revolute[j],
                &z,
                &o,
                self.suffix_mass[j],
                &self.suffix_moment[j],
                &self.gravity,
            );
            let c = robot.compliance().map_or(0.0, |c| c.joint(j));
            self.deflection[j] = c * self.torque[j];
            self.reached[j] = qj + self.deflection[j];
        }
        if jacobian && self.compliant {
            for i in 0..n {
                let t = self.joint_twist(i);
                for j in 0..n {
                    let c = robot.compliance().map_or(0.0, |c| c.joint(j));
                    self.deflection_jacobian[(j, i)] = c * self.torque_change(j, &t);
                }
            }
        }
    }

    /// The motion of joint i's variable (per rad or per mm), at the commanded joints.
    pub fn joint_twist(&self, i: usize) -> Twist {
        let (z, o) = super::gravity::axis(&self.joint, i);
        if self.revolute[i] {
            Twist {
                first: i,
                v: -z.cross(&o),
                w: z,
            }
        } else {
            Twist {
                first: i,
                v: z,
                w: Vector3::zeros(),
            }
        }
    }

    /// d tau_j for the motion `t` (N m or N per unit of what moves), at the commanded joints.
    pub fn torque_change(&self, j: usize, t: &Twist) -> f64 {
        let (z, o) = super::gravity::axis(&self.joint, j);
        let g = &self.gravity;
        match (self.revolute[j], j >= t.first) {
            (true, true) => {
                let r = self.suffix_moment[j] - o * self.suffix_mass[j];
                g.dot(&t.w.cross(&z.cross(&r))) * 1e-3
            }
            (true, false) => {
                let f = t.first;
                let dm = t.v * self.suffix_mass[f] + t.w.cross(&self.suffix_moment[f]);
                g.dot(&z.cross(&dm)) * 1e-3
            }
            (false, true) => self.suffix_mass[j] * g.dot(&t.w.cross(&z)),
            (false, false) => 0.0,
        }
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
