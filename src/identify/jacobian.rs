//! The identification Jacobian (thesis eq. 4.19-4.21): how the tool pose moves with each
//! model parameter, analytic, from the frames of one forward-kinematics pass.
//!
//! Parameter k is an elementary motion of a frame of the chain (see `model::axes`): a rotation
//! about the world line through c_k along w_k, or a translation along w_k. Its column is
//! [w_k x (p - c_k); w_k] for a rotation and [w_k; 0] for a translation, p being the tool
//! origin: rows 0-2 in mm per mm or mm per rad, rows 3-5 the tool's angular velocity
//! (rad per unit), both in world coordinates.

use crate::kinematics::jacobian::axis_column;
use crate::kinematics::load::{Load, Twist, moment_sensitivity, world_gravity};
use crate::kinematics::{Frames, Pose};
use crate::model::Robot;
use crate::model::axes::{Anchor, ParamAxis};
use nalgebra::{Matrix6xX, Point3, Vector3};

/// Fills `out` (6 x cols.len()) with the columns of the parameters `cols` (indices into
/// [`Robot::parameters`]) at the configuration whose frames are in `frames`. Does not allocate
/// when `out` already has the right size.
///
/// For a compliant robot (q' = q + delta(q)), a geometric parameter's column is its rigid
/// column at the reached joints plus J' d delta / d p (it moves the masses and axes the
/// torques come from; [`Load::tool_change`]); a compliance c_j's column is J'_j tau_j, a
/// mass-free coefficient's J'_j times its deflection per unit ([`moment_sensitivity`]).
pub fn parameter_jacobian(
    robot: &Robot,
    frames: &Frames,
    cols: &[usize],
    out: &mut Matrix6xX<f64>,
) {
    if out.ncols() != cols.len() {
        *out = Matrix6xX::zeros(cols.len());
    }
    let chain = robot.chain();
    let n = robot.dof();
    let identity = Pose::identity();
    let p = frames.tool.translation.vector;
    let rows = chain.axes.len();
    // The rigid columns first, in the tightest loop: most robots have nothing else. (The
    // frame lookup of `screw`, written out: through `screw` this loop ran 1.7x slower.)
    for (k, &col) in cols.iter().enumerate() {
        let Some(axis) = chain.axes.get(col) else {
            continue;
        };
        let f: &Pose = match axis.anchor {
            Anchor::World => &identity,
            Anchor::Entry(0) => &chain.base,
            Anchor::Entry(i) => &frames.link[i - 1],
            Anchor::Joint(i) => &frames.joint[i],
            Anchor::ToolEntry => &frames.link[n - 1],
        };
        let w: Vector3<f64> = f.rotation * axis.u;
        let mut c = out.column_mut(k);
        if axis.rotation {
            let at = (f * Point3::from(axis.c)).coords;
            c.fixed_rows_mut::<3>(0).copy_from(&w.cross(&(p - at)));
            c.fixed_rows_mut::<3>(3).copy_from(&w);
        } else {
            c.fixed_rows_mut::<3>(0).copy_from(&w);
            c.fixed_rows_mut::<3>(3).fill(0.0);
        }
    }
    let load = &frames.load;
    if !load.compliant && cols.iter().all(|&c| c < rows) {
        return;
    }
    // Which compliance parameters the robot has, and gravity in the world: once per call.
    let joint_form = robot.masses().is_some_and(|m| m.has_mass());
    let g = world_gravity(robot);
    for (k, &col) in cols.iter().enumerate() {
        let mut c = out.column_mut(k);
        let Some(axis) = chain.axes.get(col) else {
            // The compliance parameters follow the row parameters: c1..cN (a robot with
            // masses) or k_jbi (joint j, bodies b = j..=N, parts i = 0..4).
            let (j, per_unit) = if joint_form {
                (col - rows, load.torque[col - rows])
            } else {
                mass_free_column(robot, frames, &g, col - rows)
            };
            // J'_j: kept in the load for a compliant robot, else at the (rigid) frames.
            let column = if load.compliant {
                load.columns[j]
            } else {
                axis_column(robot, frames, j)
            };
            c.copy_from(&(column * per_unit));
            continue;
        };
        if load.compliant
            && let Some(t) = twist(robot, load, axis, n)
        {
            c += load.tool_change(&t);
        }
    }
}

/// The joint the `k`-th mass-free coefficient k_jbi deflects (in the order of
/// [`Robot::parameters`]: joint j, bodies b = j..=N, parts i = 0..4) and its deflection per
/// unit of it ([`moment_sensitivity`]); `g` gravity in the world (m/s^2).
fn mass_free_column(robot: &Robot, frames: &Frames, g: &Vector3<f64>, k: usize) -> (usize, f64) {
    let load = &frames.load;
    let n = robot.dof();
    // A robot whose joints do not yet deflect: its frames are the commanded ones.
    let (joint, tool) = if load.compliant {
        (&load.joint[..], &load.tool)
    } else {
        (&frames.joint[..], &frames.tool)
    };
    let mut rest = k;
    for j in 0..n {
        let here = 4 * (n - j + 1);
        if rest < here {
            let (b, i) = (j + rest / 4, rest % 4);
            let revolute = robot.joints()[j].joint_type == crate::model::JointType::Revolute;
            return (j, moment_sensitivity(joint, tool, g, revolute, j, b, i));
        }
        rest -= here;
    }
    unreachable!("compliance parameter {k} beyond the robot's {n} joints")
}

/// A parameter's screw in the frames `joint`, `link` (world): its unit direction w and, for
/// a rotation, a point on its line (mm; zero for a translation).
#[inline]
fn screw(
    robot: &Robot,
    joint: &[Pose],
    link: &[Pose],
    axis: &ParamAxis,
) -> (Vector3<f64>, Vector3<f64>) {
    let chain = robot.chain();
    let identity = Pose::identity();
    let f: &Pose = match axis.anchor {
        Anchor::World => &identity,
        Anchor::Entry(0) => &chain.base,
        Anchor::Entry(i) => &link[i - 1],
        Anchor::Joint(i) => &joint[i],
        Anchor::ToolEntry => &link[robot.dof() - 1],
    };
    let w: Vector3<f64> = f.rotation * axis.u;
    // A translation has no line: skip the point (half the columns, a hot loop).
    let at = if axis.rotation {
        (f * Point3::from(axis.c)).coords
    } else {
        Vector3::zeros()
    };
    (w, at)
}

/// The motion a parameter gives the commanded configuration's frames, for the change of
/// its gravity torques; None for a base parameter, which moves gravity with the chain.
fn twist(robot: &Robot, load: &Load, axis: &ParamAxis, n: usize) -> Option<Twist> {
    let first = match axis.anchor {
        Anchor::World => return None,
        Anchor::Entry(i) => i,
        Anchor::Joint(i) => i + 1,
        Anchor::ToolEntry => n,
    };
    let (w, at) = screw(robot, &load.joint, &load.link, axis);
    Some(Twist::about_line(first, axis.rotation, w, at))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::rotation::rotation_vector;
    use crate::kinematics::{frames, tool_pose};
    use crate::model::file::parse_robot;
    use std::path::Path;

    /// Every parameter kind: MDH (a, alpha, d, theta), Hayati (beta), standard DH, 6-DOF base
    /// and tool, and an MDH base and tool row; with non-zero values everywhere so that no
    /// column is special.
    const MIXED: &str = r#"
[base]
convention = "transform"
x = 120.0
y = -40.0
z = 300.0
rz = 25.0
ry = -10.0
rx = 5.0
[[joint]]
convention = "mdh"
alpha = 3.0
a = 20.0
theta = 4.0
d = 400.0
limits = [-180, 180]
[[joint]]
convention = "mdh"
alpha = -88.0
a = 300.0
theta = -87.0
d = 12.0
limits = [-180, 180]
[[joint]]
convention = "hayati"
beta = 0.7
alpha = 1.5
a = 900.0
theta = 2.0
limits = [-180, 180]
[[joint]]
convention = "dh"
theta = 3.0
d = 850.0
a = 150.0
alpha = -91.0
limits = [-180, 180]
[[joint]]
convention = "dh"
theta = -1.0
d = 5.0
a = 7.0
alpha = 89.0
type = "prismatic"
limits = [-100, 100]
[[joint]]
convention = "mdh"
alpha = 92.0
a = 4.0
theta = -93.0
d = -210.0
limits = [-180, 180]
[tool]
convention = "transform"
x = 30.0
y = 15.0
z = 180.0
rz = 40.0
ry = 20.0
rx = -30.0
"#;

    fn check(robot: &Robot, seed: u64) {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let params = robot.parameters();
        let cols: Vec<usize> = (0..params.len()).collect();
        let mut ws = Frames::new(robot);
        let mut jac = Matrix6xX::zeros(cols.len());
        for _ in 0..20 {
            let q: Vec<f64> = (0..robot.dof())
                .map(|_| rng.random_range(-2.5..2.5))
                .collect();
            frames(robot, &q, &mut ws);
            parameter_jacobian(robot, &ws, &cols, &mut jac);
            for (k, id) in params.iter().enumerate() {
                let h = match id.field {
                    // 1e-3 mrad per kN m; 1 mrad per kN m times kg (or kg m).
                    crate::model::Field::C => 1e-9,
                    crate::model::Field::K { .. } => 1e-6,
                    f if f.is_angle() => 1e-6,
                    _ => 1e-4,
                };
                let v = robot.param(*id);
                let plus = tool_pose(&robot.with_param(*id, v + h).unwrap(), &q);
                let minus = tool_pose(&robot.with_param(*id, v - h).unwrap(), &q);
                let dp = (plus.translation.vector - minus.translation.vector) / (2.0 * h);
                let dr = rotation_vector(&(plus.rotation * minus.rotation.inverse())) / (2.0 * h);
                let col = jac.column(k);
                let (jp, jr) = (col.fixed_rows::<3>(0), col.fixed_rows::<3>(3));
                // Relative to the column's size (and to 1 for columns that vanish; a
                // compliance's column is mm per rad per N m, some 1e7 where it does not
                // vanish, and its differences carry 1e-4 of rounding, so its floor is 1e3).
                let unit = if id.field == crate::model::Field::C {
                    1e3
                } else {
                    1.0
                };
                let scale_p = dp.norm().max(unit);
                let scale_r = dr.norm().max(1e-3 * unit);
                assert!(
                    (jp - dp).norm() / scale_p < 1e-6,
                    "{}: {:?} vs {dp:?}",
                    id.name(),
                    jp.clone_owned()
                );
                assert!(
                    (jr - dr).norm() / scale_r < 1e-6,
                    "{}: {jr:?} vs {dr:?}",
                    id.name()
                );
            }
        }
    }

    #[test]
    fn analytic_jacobian_matches_central_differences_for_every_parameter_kind() {
        let robot = parse_robot(MIXED, Path::new("mixed.toml")).unwrap();
        check(&robot, 1);
        // MDH base and tool rows (the thesis's frames R and T).
        let fanuc = crate::model::test_fanuc();
        let bent = fanuc
            .with_params(&[
                (fanuc.find_param("base.a").unwrap(), 3.0),
                (fanuc.find_param("base.alpha").unwrap(), 0.01),
                (fanuc.find_param("tool.theta").unwrap(), 3.0),
                (fanuc.find_param("beta3").unwrap(), 0.002),
            ])
            .unwrap();
        check(&bent, 2);
        // Standard DH base and tool rows.
        let dh_ends = MIXED
            .replace("[base]\nconvention = \"transform\"\nx = 120.0\ny = -40.0\nz = 300.0\nrz = 25.0\nry = -10.0\nrx = 5.0", "[base]\nconvention = \"dh\"\ntheta = 10\nd = 50\na = 30\nalpha = 20")
            .replace("[tool]\nconvention = \"transform\"\nx = 30.0\ny = 15.0\nz = 180.0\nrz = 40.0\nry = 20.0\nrx = -30.0", "[tool]\nconvention = \"hayati\"\nbeta = 5\nalpha = 10\na = 40\ntheta = 15");
        let r = parse_robot(&dh_ends, Path::new("dh.toml")).unwrap();
        assert_eq!(r.base().convention(), crate::model::Convention::Dh);
        check(&r, 3);
    }

    /// `robot` with masses on every link and the payload, gravity tilted, and compliances
    /// large enough (deflections of mrad) that a missing term of the Jacobian shows.
    fn compliant(robot: &Robot) -> Robot {
        use crate::model::{BodyMass, Compliance, MassProperties};
        let n = robot.dof();
        let links = (0..n)
            .map(|k| BodyMass {
                mass_kg: 60.0 - 8.0 * k as f64,
                com_mm: Vector3::new(120.0 - 30.0 * k as f64, -40.0 + 15.0 * k as f64, 25.0),
            })
            .collect();
        let masses = MassProperties {
            links,
            payload: BodyMass {
                mass_kg: 80.0,
                com_mm: Vector3::new(10.0, 20.0, 150.0),
            },
            gravity: Vector3::new(0.6, -0.4, -9.78),
        };
        let c: Vec<f64> = (0..n).map(|j| 0.3 + 0.15 * j as f64).collect();
        robot
            .with_masses(Some(masses))
            .unwrap()
            .with_compliance(Some(Compliance::from_file_units(&c)))
            .unwrap()
    }

    #[test]
    fn compliant_jacobian_matches_central_differences_for_every_parameter_kind() {
        // Every row kind, a prismatic joint, and the compliances c1..cN themselves.
        let robot = compliant(&parse_robot(MIXED, Path::new("mixed.toml")).unwrap());
        assert!(robot.is_compliant());
        assert_eq!(
            robot
                .parameters()
                .iter()
                .filter(|p| p.field == crate::model::Field::C)
                .count(),
            6
        );
        check(&robot, 4);
        let fanuc = crate::model::test_fanuc();
        check(&compliant(&fanuc), 5);
    }

    /// `robot` without masses, with a mass-free coefficient for every body each joint
    /// carries (deflections of mrad).
    fn with_moments(robot: &Robot) -> Robot {
        use crate::model::Compliance;
        let n = robot.dof();
        let mut c = Compliance {
            moments: vec![0.0; n * (n + 1) * 4],
            ..Default::default()
        };
        for j in 0..n {
            for b in j..=n {
                for i in 0..4 {
                    let at = crate::model::compliance::moment_index(n, j, b, i);
                    // mrad per kN m times kg (i = 0) or kg m.
                    c.moments[at] = if i == 0 { 40.0 } else { 12.0 }
                        * (1.0 + 0.1 * (j + b + i) as f64)
                        * if (j + b + i) % 2 == 0 { 1.0 } else { -1.0 };
                }
            }
        }
        robot.with_compliance(Some(c)).unwrap()
    }

    /// [`crate::kinematics::jacobian::joint_jacobian`] against central differences of the
    /// tool pose in the commanded joints, on robots this module's fixtures build: a prismatic
    /// joint (mm per mm, no rotation) of a robot compliant with masses, and mass-free
    /// coefficients (the load's moment changes), which tests of the kinematics alone do
    /// not reach. It also asserts that the compliance changes the Jacobian by more than the
    /// tolerance, so a term left out shows.
    fn check_joint_jacobian(robot: &Robot, seed: u64) {
        use crate::kinematics::jacobian::joint_jacobian;
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let n = robot.dof();
        let (mut f, mut rigid_f) = (Frames::new(robot), Frames::new(robot));
        let (mut jac, mut rigid_jac) = (Matrix6xX::zeros(n), Matrix6xX::zeros(n));
        let (mut worst, mut correction) = (0.0f64, 0.0f64);
        for _ in 0..10 {
            let q: Vec<f64> = (robot.joints().iter())
                .map(|j| match j.joint_type {
                    crate::model::JointType::Prismatic => rng.random_range(-80.0..80.0),
                    crate::model::JointType::Revolute => rng.random_range(-2.5..2.5),
                })
                .collect();
            frames(robot, &q, &mut f);
            joint_jacobian(robot, &f, &mut jac);
            frames(&robot.rigid(), &q, &mut rigid_f);
            joint_jacobian(&robot.rigid(), &rigid_f, &mut rigid_jac);
            for i in 0..n {
                // The tool's metres carry 1e-13 mm of rounding: a step of 1e-6 left 4e-7 of
                // it in the quotient, 1e-4 leaves 3e-9 (the second differences are smaller).
                let h = 1e-4;
                let (mut qp, mut qm) = (q.clone(), q.clone());
                qp[i] += h;
                qm[i] -= h;
                let (p, m) = (tool_pose(robot, &qp), tool_pose(robot, &qm));
                let dp = (p.translation.vector - m.translation.vector) / (2.0 * h);
                let dr = rotation_vector(&(p.rotation * m.rotation.inverse())) / (2.0 * h);
                let col = jac.column(i);
                worst = worst.max((col.fixed_rows::<3>(0) - dp).norm() / dp.norm().max(1.0));
                worst = worst.max((col.fixed_rows::<3>(3) - dr).norm());
                correction = correction.max((col - rigid_jac.column(i)).norm());
            }
        }
        assert!(worst < 1e-7, "worst relative difference {worst}");
        assert!(
            correction > 1e-3,
            "largest compliant correction {correction}"
        );
    }

    #[test]
    fn joint_jacobian_with_a_prismatic_joint_and_mass_free_compliance_matches_differences() {
        let mixed = parse_robot(MIXED, Path::new("mixed.toml")).unwrap();
        check_joint_jacobian(&compliant(&mixed), 8);
        check_joint_jacobian(&with_moments(&mixed), 9);
        check_joint_jacobian(&with_moments(&crate::model::test_fanuc()), 10);
    }

    #[test]
    fn mass_free_compliance_jacobian_matches_central_differences() {
        let robot = with_moments(&parse_robot(MIXED, Path::new("mixed.toml")).unwrap());
        assert!(robot.is_compliant() && robot.masses().is_none());
        let k = robot
            .parameters()
            .iter()
            .filter(|p| matches!(p.field, crate::model::Field::K { .. }))
            .count();
        // 4 per body each joint carries: 4 (7 + 6 + ... + 2).
        assert_eq!(k, 4 * 27);
        check(&robot, 6);
        let fanuc = crate::model::test_fanuc();
        check(&with_moments(&fanuc), 7);
    }
}
