//! Gravity torques at the joints, and their derivatives: the load that bends compliant joints
//! (the thesis's literature review: Khalil and Besnard identify geometric and compliance
//! parameters together).
//!
//! Point masses m_k (kg) at p_k (mm, world), each carried by the joints before it; gravity g
//! (m/s^2) in the base (world) frame. The generalised gravity force at joint j, axis z_j
//! through o_j (both world), sums over the masses that joint j carries:
//! - revolute: tau_j = sum_k z_j . ((p_k - o_j) x m_k g) = sum_k m_k g . (z_j x (p_k - o_j))
//!   (N m; lengths in m);
//! - prismatic: f_j = sum_k m_k g . z_j (N).
//!
//! Derivatives (for the Jacobian of a compliant model): joint i moves the masses it carries,
//! dp_k/dq_i = z_i x (p_k - o_i) (revolute) or z_i (prismatic); when i comes before j it also
//! moves joint j's axis with them, a rigid motion that leaves a prismatic j's force and the
//! lever arms p_k - o_j unchanged but turns z_j x (p_k - o_j) about z_i.

use super::Pose;
use crate::model::{JointType, Robot};
use nalgebra::{DMatrix, Vector3};

/// A point mass and the frame it rides on.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PointMass {
    /// Its mass (kg).
    pub mass_kg: f64,
    /// Where it is (mm, world).
    pub position_mm: Vector3<f64>,
    /// The frame it rides on: joint frame k (0-based, link k's mass), or N for the tool frame
    /// (the payload). Joints 0..=min(frame, N - 1) carry it.
    pub frame: usize,
}

/// Joint j's axis direction (unit) and a point on it (mm), world, from its joint frame.
#[inline]
pub(crate) fn axis(joint: &[Pose], j: usize) -> (Vector3<f64>, Vector3<f64>) {
    let f = &joint[j];
    (f.rotation.matrix().column(2).into(), f.translation.vector)
}

/// The point masses of `robot`'s mass properties in the joint frames `joint` and tool frame
/// `tool` (world) into `out` (none when the robot has no masses): each link's centre of mass
/// carried by its joint frame, the payload's by the tool frame. Allocates only when `out` must
/// grow.
pub fn mass_points(robot: &Robot, joint: &[Pose], tool: &Pose, out: &mut Vec<PointMass>) {
    out.clear();
    let Some(m) = robot.masses() else {
        return;
    };
    let n = robot.dof();
    for (k, b) in m.links.iter().enumerate() {
        out.push(PointMass {
            mass_kg: b.mass_kg,
            position_mm: joint[k].transform_point(&b.com_mm.into()).coords,
            frame: k,
        });
    }
    out.push(PointMass {
        mass_kg: m.payload.mass_kg,
        position_mm: tool.transform_point(&m.payload.com_mm.into()).coords,
        frame: n,
    });
}

/// The gravity force of every joint into `out` (N m for revolute joints, N for prismatic
/// ones) from `points`, the joint axes those of the joint frames `joint` (world), gravity `g`
/// (m/s^2, world). Does not allocate.
pub fn gravity_torques(
    robot: &Robot,
    joint: &[Pose],
    g: &Vector3<f64>,
    points: &[PointMass],
    out: &mut [f64],
) {
    for (j, (tau, jt)) in out.iter_mut().zip(robot.joints()).enumerate() {
        let (z, o) = axis(joint, j);
        *tau = points
            .iter()
            .filter(|p| p.frame >= j)
            .map(|p| match jt.joint_type {
                JointType::Revolute => z.dot(&((p.position_mm - o) * 1e-3).cross(&(g * p.mass_kg))),
                JointType::Prismatic => (g * p.mass_kg).dot(&z),
            })
            .sum();
    }
}

/// d tau_j / d q_i of [`gravity_torques`] into `out` (n x n; N m per rad, N m per mm, N per
/// rad or N per mm as the joints are), at the configuration of the joint frames `joint`.
pub fn gravity_torque_jacobian(
    robot: &Robot,
    joint: &[Pose],
    g: &Vector3<f64>,
    points: &[PointMass],
    out: &mut DMatrix<f64>,
) {
    let joints = robot.joints();
    let n = joints.len();
    out.fill(0.0);
    for j in 0..n {
        let (zj, oj) = axis(joint, j);
        for i in 0..n {
            let (zi, oi) = axis(joint, i);
            let revolute_i = joints[i].joint_type == JointType::Revolute;
            let mut d = 0.0;
            for p in points.iter().filter(|p| p.frame >= j && p.frame >= i) {
                let f = g * p.mass_kg;
                let r = (p.position_mm - oj) * 1e-3;
                d += match (joints[j].joint_type, i < j, revolute_i) {
                    // Joint i turns joint j's axis and the mass together: the lever arm
                    // turns about z_i.
                    (JointType::Revolute, true, true) => f.dot(&zi.cross(&zj.cross(&r))),
                    // A translation before j moves axis and mass alike.
                    (JointType::Revolute, true, false) => 0.0,
                    (JointType::Revolute, false, true) => {
                        let dp = zi.cross(&((p.position_mm - oi) * 1e-3));
                        f.dot(&zj.cross(&dp))
                    }
                    (JointType::Revolute, false, false) => f.dot(&zj.cross(&(zi * 1e-3))),
                    (JointType::Prismatic, true, true) => f.dot(&zi.cross(&zj)),
                    (JointType::Prismatic, _, _) => 0.0,
                };
            }
            out[(j, i)] = d;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kinematics::{Frames, frames};
    use crate::model::read_robot;

    /// Masses midway along each link of `robot` at `q` and a payload at the tool.
    fn masses(robot: &Robot, f: &Frames) -> Vec<PointMass> {
        let n = robot.dof();
        let origin = |k: usize| {
            if k < n {
                f.joint[k].translation.vector
            } else {
                f.tool.translation.vector
            }
        };
        let mut v: Vec<PointMass> = (0..n)
            .map(|k| PointMass {
                mass_kg: 10.0 + 7.0 * k as f64,
                position_mm: (origin(k) + origin(k + 1)) * 0.5,
                frame: k,
            })
            .collect();
        v.push(PointMass {
            mass_kg: 50.0,
            position_mm: origin(n),
            frame: n,
        });
        v
    }

    #[test]
    fn torque_jacobian_matches_central_differences() {
        let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("datasets/robots");
        let g = Vector3::new(0.3, -0.2, -9.81);
        // A robot with prismatic joints too (a gantry-like R-P-R-P), beside the shipped 6R.
        let rprp = Robot::from_toml(
            "[[joint]]\nconvention = \"mdh\"\nalpha = 0.0\na = 0.0\ntheta = 0.0\nd = 300.0\n\
             limits = [-180.0, 180.0]\n\
             [[joint]]\nconvention = \"mdh\"\ntype = \"prismatic\"\nalpha = 90.0\na = 150.0\n\
             theta = 20.0\nd = 0.0\nlimits = [-500.0, 500.0]\n\
             [[joint]]\nconvention = \"mdh\"\nalpha = -60.0\na = 400.0\ntheta = 0.0\nd = 80.0\n\
             limits = [-180.0, 180.0]\n\
             [[joint]]\nconvention = \"mdh\"\ntype = \"prismatic\"\nalpha = 45.0\na = 120.0\n\
             theta = -30.0\nd = 0.0\nlimits = [-500.0, 500.0]\n\
             [tool]\nconvention = \"transform\"\nx = 100.0\ny = 20.0\nz = 50.0\n",
        )
        .unwrap();
        for (file, robot) in [
            (
                "fanuc_r2000ib_210f.toml",
                read_robot(root.join("fanuc_r2000ib_210f.toml")).unwrap(),
            ),
            ("ur10.toml", read_robot(root.join("ur10.toml")).unwrap()),
            ("rprp", rprp),
        ] {
            let n = robot.dof();
            // rad, or mm for the prismatic joints.
            let q: Vec<f64> = (0..n).map(|j| 0.3 + 0.2 * j as f64).collect();
            let mut f = Frames::new(&robot);
            frames(&robot, &q, &mut f);
            // The masses ride with their frames: (mass, frame, coordinates in it).
            let frame_of = |f: &Frames, k: usize| if k == n { f.tool } else { f.joint[k] };
            let local: Vec<(f64, usize, Vector3<f64>)> = masses(&robot, &f)
                .iter()
                .map(|p| {
                    let frame = frame_of(&f, p.frame);
                    let l = frame.inverse_transform_point(&p.position_mm.into()).coords;
                    (p.mass_kg, p.frame, l)
                })
                .collect();
            let at = |q: &[f64], f: &mut Frames| -> Vec<PointMass> {
                frames(&robot, q, f);
                local
                    .iter()
                    .map(|&(mass_kg, frame, l)| PointMass {
                        mass_kg,
                        position_mm: frame_of(f, frame).transform_point(&l.into()).coords,
                        frame,
                    })
                    .collect()
            };
            let mut jac = DMatrix::zeros(n, n);
            let pts = at(&q, &mut f);
            gravity_torque_jacobian(&robot, &f.joint, &g, &pts, &mut jac);
            let h = 1e-6;
            let mut worst: f64 = 0.0;
            for i in 0..n {
                let (mut qp, mut qm) = (q.clone(), q.clone());
                qp[i] += h;
                qm[i] -= h;
                let (mut tp, mut tm) = (vec![0.0; n], vec![0.0; n]);
                let pp = at(&qp, &mut f);
                gravity_torques(&robot, &f.joint, &g, &pp, &mut tp);
                let pm = at(&qm, &mut f);
                gravity_torques(&robot, &f.joint, &g, &pm, &mut tm);
                for j in 0..n {
                    let fd = (tp[j] - tm[j]) / (2.0 * h);
                    worst = worst.max((fd - jac[(j, i)]).abs() / (1.0 + fd.abs()));
                }
            }
            assert!(worst < 1e-6, "{file}: worst relative difference {worst}");
        }
    }

    #[test]
    fn torque_of_a_hand_computed_arm() {
        // The UR10 at q = 0 with one 10 kg mass 1 m out along the world x axis from joint 2's
        // axis point: gravity -z gives |tau_2| = 10 * 9.81 * 1 N m.
        let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("datasets/robots");
        let robot = read_robot(root.join("ur10.toml")).unwrap();
        let mut f = Frames::new(&robot);
        frames(&robot, &[0.0; 6], &mut f);
        let (z, o) = axis(&f.joint, 1);
        // A point 1 m from the axis, perpendicular to it and to gravity.
        let arm = z.cross(&Vector3::z()).normalize() * 1000.0;
        let p = PointMass {
            mass_kg: 10.0,
            position_mm: o + arm,
            frame: 5,
        };
        let mut tau = vec![0.0; 6];
        gravity_torques(
            &robot,
            &f.joint,
            &Vector3::new(0.0, 0.0, -9.81),
            &[p],
            &mut tau,
        );
        assert!((tau[1].abs() - 98.1).abs() < 1e-9, "{tau:?}");
        // Joint 1's axis is vertical: gravity exerts no torque about it.
        assert!(tau[0].abs() < 1e-9, "{tau:?}");
    }
}
