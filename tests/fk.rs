//! Forward kinematics against hand-computed poses and an independent product of 4x4 matrices.

use nalgebra::{Matrix4, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use robocal::kinematics::{Frames, frames, pose_to_file, tool_pose};
use robocal::model::{Convention, Field, Robot, read_robot};

fn fanuc() -> Robot {
    read_robot(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/datasets/robots/fanuc_r2000ib_210f.toml"
    ))
    .unwrap()
}

fn ur10() -> Robot {
    read_robot(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/datasets/robots/ur10.toml"
    ))
    .unwrap()
}

fn deg(v: &[f64]) -> Vec<f64> {
    v.iter().map(|x| x.to_radians()).collect()
}

fn assert_close(a: Vector3<f64>, b: Vector3<f64>, tol: f64) {
    assert!((a - b).norm() < tol, "{a:?} vs {b:?}");
}

/// Table 3.1 by hand at q = 0: frame 1 at z = 670; axis 2 at (312, 0, 670) along +y; the upper
/// arm (a3 = 1075) points up to z = 1745; the forearm offset a4 = 225 up to z = 1970 and
/// d4 = -1280 along z4 = -x to x = 1592; d6 = -235 to x = 1827; the tool's a = 182 along
/// x6 = -y and d = 205 along -z6 = +x. Tool axes: x = +y, y = +z, z = +x.
#[test]
fn fanuc_at_zero_by_hand() {
    let t = tool_pose(&fanuc(), &[0.0; 6]);
    assert_close(
        t.translation.vector,
        Vector3::new(2032.0, -182.0, 1970.0),
        1e-9,
    );
    let r = t.rotation.matrix();
    assert_close(r.column(0).into(), Vector3::y(), 1e-12);
    assert_close(r.column(1).into(), Vector3::z(), 1e-12);
    assert_close(r.column(2).into(), Vector3::x(), 1e-12);
    let p = pose_to_file(&t);
    assert!((p[3] - 90.0).abs() < 1e-9 && p[4].abs() < 1e-9 && (p[5] - 90.0).abs() < 1e-9);
}

/// Single-joint motions about axes whose place is known from the zero pose.
#[test]
fn fanuc_single_joint_motions_by_hand() {
    let robot = fanuc();
    // q1 = 90: the tool point turns about the vertical axis: (x, y) -> (-y, x).
    let t = tool_pose(&robot, &deg(&[90.0, 0.0, 0.0, 0.0, 0.0, 0.0]));
    assert_close(
        t.translation.vector,
        Vector3::new(182.0, 2032.0, 1970.0),
        1e-9,
    );
    // q2 = 90: axis 2 is +y through (312, 0, 670); the tool point (1720, 1300) from it in the
    // x-z plane turns to (1300, -1720).
    let t = tool_pose(&robot, &deg(&[0.0, 90.0, 0.0, 0.0, 0.0, 0.0]));
    assert_close(
        t.translation.vector,
        Vector3::new(1612.0, -182.0, -1050.0),
        1e-9,
    );
    // q3 = 30: axis 3 is -y through (312, 0, 1745); the tool point is (1720, 225) from it.
    // A rotation by 30 deg about -y: (x, z) -> (x cos + z sin(-30) ..).
    let (s, c) = (-30f64).to_radians().sin_cos();
    let (dx, dz) = (1720.0, 225.0);
    let expect = Vector3::new(312.0 + dx * c + dz * s, -182.0, 1745.0 - dx * s + dz * c);
    let t = tool_pose(&robot, &deg(&[0.0, 0.0, 30.0, 0.0, 0.0, 0.0]));
    assert_close(t.translation.vector, expect, 1e-9);
    // q6 = 90: axis 6 is -x through (1827, 0, 1970); the tool point (205, -182, 0) from it
    // turns to (205, 0, 182).
    let t = tool_pose(&robot, &deg(&[0.0, 0.0, 0.0, 0.0, 0.0, 90.0]));
    assert_close(
        t.translation.vector,
        Vector3::new(2032.0, 0.0, 2152.0),
        1e-9,
    );
    // q4 = 90: axis 4 is -x through (1592, 0, 1970); same turn for (440, -182, 0).
    let t = tool_pose(&robot, &deg(&[0.0, 0.0, 0.0, 90.0, 0.0, 0.0]));
    assert_close(
        t.translation.vector,
        Vector3::new(2032.0, 0.0, 2152.0),
        1e-9,
    );
}

/// UR10 in its upright pose (q2 = q4 = -90 deg): x = 0, y = -(d4 + d6), z = d1 - a2 - a3 + d5.
#[test]
fn ur10_upright_by_hand() {
    let t = tool_pose(&ur10(), &deg(&[0.0, -90.0, 0.0, -90.0, 0.0, 0.0]));
    assert_close(
        t.translation.vector,
        Vector3::new(0.0, -(163.941 + 92.2), 127.3 + 612.0 + 572.3 + 115.7),
        1e-9,
    );
}

fn rx(a: f64) -> Matrix4<f64> {
    let (s, c) = a.sin_cos();
    Matrix4::new(
        1.0, 0.0, 0.0, 0.0, 0.0, c, -s, 0.0, 0.0, s, c, 0.0, 0.0, 0.0, 0.0, 1.0,
    )
}
fn ry(a: f64) -> Matrix4<f64> {
    let (s, c) = a.sin_cos();
    Matrix4::new(
        c, 0.0, s, 0.0, 0.0, 1.0, 0.0, 0.0, -s, 0.0, c, 0.0, 0.0, 0.0, 0.0, 1.0,
    )
}
fn rz(a: f64) -> Matrix4<f64> {
    let (s, c) = a.sin_cos();
    Matrix4::new(
        c, -s, 0.0, 0.0, s, c, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0,
    )
}
fn tr(x: f64, y: f64, z: f64) -> Matrix4<f64> {
    Matrix4::new(
        1.0, 0.0, 0.0, x, 0.0, 1.0, 0.0, y, 0.0, 0.0, 1.0, z, 0.0, 0.0, 0.0, 1.0,
    )
}

/// Plain 4x4 product of the conventions' formulas, written here independently of the crate.
fn row_matrix(row: &robocal::model::Row, q: f64) -> Matrix4<f64> {
    let g = |f| row.file_value(f).unwrap_or(0.0);
    let r = |f| g(f).to_radians();
    match row.convention() {
        Convention::Mdh => {
            rx(r(Field::Alpha))
                * tr(g(Field::A), 0.0, 0.0)
                * rz(r(Field::Theta) + q)
                * tr(0.0, 0.0, g(Field::D))
        }
        Convention::Hayati => {
            ry(r(Field::Beta))
                * rx(r(Field::Alpha))
                * tr(g(Field::A), 0.0, 0.0)
                * rz(r(Field::Theta) + q)
        }
        Convention::Dh => {
            rz(r(Field::Theta) + q)
                * tr(0.0, 0.0, g(Field::D))
                * tr(g(Field::A), 0.0, 0.0)
                * rx(r(Field::Alpha))
        }
        Convention::Transform => {
            tr(g(Field::X), g(Field::Y), g(Field::Z))
                * rz(r(Field::Rz))
                * ry(r(Field::Ry))
                * rx(r(Field::Rx))
        }
    }
}

fn plain_fk(robot: &Robot, q: &[f64]) -> Matrix4<f64> {
    let mut m = row_matrix(robot.base(), 0.0);
    for (j, qi) in robot.joints().iter().zip(q) {
        m *= row_matrix(&j.row, *qi);
    }
    m * row_matrix(robot.tool(), 0.0)
}

#[test]
fn fk_equals_plain_matrix_product_for_every_convention() {
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    // A perturbed FANUC (non-zero Hayati beta, 6-DOF tool) and the standard-DH UR10.
    let f = fanuc();
    let f = f
        .with_params(&[
            (f.find_param("beta3").unwrap(), 0.003),
            (f.find_param("base.theta").unwrap(), 0.01),
            (f.find_param("tool.d").unwrap(), 7.0),
        ])
        .unwrap();
    let mut u = ur10();
    u = u
        .with_params(&[
            (u.find_param("tool.z").unwrap(), 100.0),
            (u.find_param("tool.rx").unwrap(), 0.2),
            (u.find_param("base.ry").unwrap(), -0.4),
            (u.find_param("base.x").unwrap(), 2000.0),
        ])
        .unwrap();
    for robot in [f, u] {
        let mut ws = Frames::new(&robot);
        for _ in 0..200 {
            let q: Vec<f64> = (0..6).map(|_| rng.random_range(-3.0..3.0)).collect();
            let ours = tool_pose(&robot, &q).to_homogeneous();
            let plain = plain_fk(&robot, &q);
            assert!((ours - plain).abs().max() < 1e-9, "{}", robot.name());
            // The frames variant ends at the same tool pose, and its last link frame times the
            // tool row is the tool.
            frames(&robot, &q, &mut ws);
            assert!((ws.tool.to_homogeneous() - plain).abs().max() < 1e-9);
            let via_link = ws.link[5].to_homogeneous() * row_matrix(robot.tool(), 0.0);
            assert!((via_link - plain).abs().max() < 1e-9);
        }
    }
}

#[test]
fn prismatic_joint_moves_along_its_axis() {
    let text = "[[joint]]\nconvention = \"mdh\"\ntype = \"prismatic\"\nd = 10\nlimits = [0, 500]\n\n[[joint]]\nconvention = \"dh\"\nalpha = 90\nlimits = [-180, 180]\n";
    let robot = robocal::model::file::parse_robot(text, std::path::Path::new("p.toml")).unwrap();
    let t = tool_pose(&robot, &[100.0, 0.3]);
    assert_close(t.translation.vector, Vector3::new(0.0, 0.0, 110.0), 1e-12);
}

/// The shipped MDH + Hayati form of the UR10 is the same robot as the vendor's DH table.
#[test]
fn ur10_mdh_hayati_equals_vendor_dh() {
    let dh = ur10();
    let mdh = read_robot(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/datasets/robots/ur10_mdh_hayati.toml"
    ))
    .unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(12);
    for _ in 0..1000 {
        let q: Vec<f64> = (0..6).map(|_| rng.random_range(-6.0..6.0)).collect();
        let (a, b) = (
            tool_pose(&dh, &q).to_homogeneous(),
            tool_pose(&mdh, &q).to_homogeneous(),
        );
        assert!((a - b).abs().max() < 1e-9);
    }
}
