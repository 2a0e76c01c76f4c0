//! Measurement data: UR10 import checked by hand, canonical round trips, the virtual robot's
//! noise and non-geometric errors.
// The UR10 files hold rounded angles such as -3.14159 and -1.5708: the tests compare against
// those literal values, not against pi.
#![allow(clippy::approx_constant)]

use nalgebra::{Matrix3, Vector3};
use robocal::data::measurement::{measurements_to_csv, parse_measurements};
use robocal::data::pairs::{Pair, distance, pairs};
use robocal::data::{JointInfo, Profile, ReadOptions, Table, read_measurements};
use robocal::geometry::rotation::{rotation_vector, zyx_to_rotation};
use robocal::kinematics::{Frames, tool_pose};
use robocal::model::{Robot, read_robot};
use robocal::sim::nongeometric::{Backlash, Compliance, Gear, gravity_torques};
use robocal::sim::{Configurations, Deviations, NonGeometric, Observe, Region, Simulation};
use std::path::{Path, PathBuf};

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn robot(name: &str) -> Robot {
    read_robot(root().join("datasets/robots").join(name)).unwrap()
}

/// Rx(a) Ry(b) Rz(c) written out, angles in degrees.
fn xyz_intrinsic(a: f64, b: f64, c: f64) -> Matrix3<f64> {
    let (sa, ca) = a.to_radians().sin_cos();
    let (sb, cb) = b.to_radians().sin_cos();
    let (sc, cc) = c.to_radians().sin_cos();
    let rx = Matrix3::new(1.0, 0.0, 0.0, 0.0, ca, -sa, 0.0, sa, ca);
    let ry = Matrix3::new(cb, 0.0, sb, 0.0, 1.0, 0.0, -sb, 0.0, cb);
    let rz = Matrix3::new(cc, -sc, 0.0, sc, cc, 0.0, 0.0, 0.0, 1.0);
    rx * ry * rz
}

#[test]
fn ur10_import_gives_hand_checked_rows() {
    let ur = robot("ur10.toml");
    let profile = Profile::read(root().join("datasets/profiles/ipa_ur10.toml")).unwrap();
    let opts = ReadOptions::default();
    let b = root().join("datasets/ipa-ur10/Series_B/measurements_joint_configurations.csv");
    let (set, report) = read_measurements(&b, &ur, &profile, &opts).unwrap();
    assert_eq!(set.rows.len(), 1495);
    assert!(
        report.skipped.is_empty() && report.warnings.is_empty(),
        "{report:?}"
    );
    // Row 1 (file line 2): joints -3,14159;-1,5708;0;-1,5708;0;0 rad.
    let m = &set.rows[0];
    assert_eq!(m.line, 2);
    let q_expect = [-3.14159, -1.5708, 0.0, -1.5708, 0.0, 0.0];
    for (a, b) in m.q.iter().zip(q_expect) {
        assert_eq!(*a, b);
    }
    // Position 383,76294;-3240,8734;201,93157 mm.
    assert_eq!(
        m.position.unwrap(),
        Vector3::new(383.76294, -3240.8734, 201.93157)
    );
    // Angles rx -90,179302, ry -20,118749, rz -90,169308 deg as R = Rx Ry Rz.
    let r = xyz_intrinsic(-90.179302, -20.118749, -90.169308);
    assert!((m.rotation.unwrap().matrix() - r).abs().max() < 1e-14);
    // Sigmas: 0,031674 0,013252 0,0037622 mm; 0,0011832 0,0013871 0,0041345 deg, those of
    // the Euler angles (the profile's sigma_angles = "angles"): about the tracker's axes,
    // sqrt(diag(E diag(s^2) E^T)) with E = [x, Rx(rx) y, Rx(rx) Ry(ry) z], here from numpy.
    assert_eq!(
        m.sigma_position.unwrap(),
        Vector3::new(0.031674, 0.013252, 0.0037622)
    );
    let sr = m.sigma_rotation.unwrap().map(f64::to_degrees);
    let about_axes = Vector3::new(0.001849978420, 0.003882203444, 0.001387146411);
    assert!((sr - about_axes).norm() < 1e-11, "{sr:?}");
    // Carried columns, with decimal commas made points.
    let col = |name: &str| set.extra_columns.iter().position(|c| c == name).unwrap();
    assert_eq!(m.extra[col("Timestamp")], "2.02011E+13");
    assert_eq!(m.extra[col("Goal x")], "0.000121973");
    assert_eq!(m.extra[col("measurement_temperature")], "21.86750031");

    // Series A row 1: no sigmas (a warning says so); joints -1,5708;-1,5708;0;-1,5708;0;0.
    let a = root().join("datasets/ipa-ur10/Series_A/measurements_grid.csv");
    let (set, report) = read_measurements(&a, &ur, &profile, &opts).unwrap();
    assert_eq!(set.rows.len(), 11911);
    assert!(
        report.warnings.iter().any(|w| w.contains("sigma")),
        "{report:?}"
    );
    let m = &set.rows[0];
    assert_eq!(m.q[0], -1.5708);
    assert_eq!(
        m.position.unwrap(),
        Vector3::new(2361.9831, -1368.5474, 119.39713)
    );
    let r = xyz_intrinsic(-90.409151, -59.885105, -90.887438);
    assert!((m.rotation.unwrap().matrix() - r).abs().max() < 1e-14);
    assert!(m.sigma_position.is_none());

    // The canonical form states the same orientation as Z-Y-X degrees.
    let text = String::from_utf8(measurements_to_csv(&set, &JointInfo::of(&ur)).unwrap()).unwrap();
    let t = Table::parse(text.as_bytes(), Path::new("c.csv"), b',', false).unwrap();
    let ang: Vec<f64> = ["rz", "ry", "rx"]
        .iter()
        .map(|c| t.number(0, t.require(c).unwrap()).unwrap())
        .collect();
    let back = zyx_to_rotation(
        ang[0].to_radians(),
        ang[1].to_radians(),
        ang[2].to_radians(),
    );
    assert!((back.matrix() - r).abs().max() < 1e-13);
    assert_eq!(
        t.number(0, t.require("q1").unwrap()).unwrap(),
        (-1.5708f64).to_degrees()
    );
}

fn fanuc_sim(
    count: usize,
    seed: u64,
    sp: f64,
    sr: f64,
    observe: Observe,
    ng: &NonGeometric,
) -> robocal::sim::SimOutput {
    let r = robot("fanuc_r2000ib_210f.toml");
    let region = Region::limits(&r);
    Simulation {
        truth: &r,
        nongeometric: ng,
        configurations: Configurations::Drawn {
            region: &region,
            count,
        },
        seed,
        sigma_position_mm: sp,
        sigma_rotation_rad: sr,
        observe,
    }
    .run(PathBuf::from("sim.csv"))
    .unwrap()
}

#[test]
fn canonical_write_read_round_trip() {
    let r = robot("fanuc_r2000ib_210f.toml");
    let out = fanuc_sim(50, 9, 0.05, 2e-4, Observe::Pose, &NonGeometric::default());
    let mut set = out.measured;
    set.extra_columns = vec!["note".into()];
    for (k, m) in set.rows.iter_mut().enumerate() {
        m.extra = vec![format!("row {k}")];
        m.set = Some(if k % 2 == 0 {
            "cal".into()
        } else {
            "val".into()
        });
    }
    let joints = JointInfo::of(&r);
    let bytes = measurements_to_csv(&set, &joints).unwrap();
    let t = Table::parse(&bytes, Path::new("rt.csv"), b',', false).unwrap();
    let (back, report) =
        parse_measurements(&t, &joints, &Profile::default(), &ReadOptions::default()).unwrap();
    assert!(report.warnings.is_empty());
    assert_eq!(back.rows.len(), set.rows.len());
    assert_eq!(back.extra_columns, set.extra_columns);
    for (a, b) in set.rows.iter().zip(&back.rows) {
        assert_eq!(a.id, b.id);
        assert_eq!(a.set, b.set);
        assert_eq!(a.extra, b.extra);
        assert_eq!(a.position, b.position, "positions are written exactly");
        for (x, y) in a.q.iter().zip(&b.q) {
            assert!((x - y).abs() < 1e-15);
        }
        let dr = rotation_vector(&(a.rotation.unwrap() * b.rotation.unwrap().inverse())).norm();
        assert!(dr < 1e-14);
        assert!((a.sigma_position.unwrap() - b.sigma_position.unwrap()).norm() < 1e-15);
        assert!((a.sigma_rotation.unwrap() - b.sigma_rotation.unwrap()).norm() < 1e-18);
    }
}

#[test]
fn zero_everything_reproduces_fk_exactly() {
    let r = robot("fanuc_r2000ib_210f.toml");
    let out = fanuc_sim(100, 5, 0.0, 0.0, Observe::Pose, &NonGeometric::default());
    for (m, t) in out.measured.rows.iter().zip(&out.truth.rows) {
        let fk = tool_pose(&r, &m.q);
        assert_eq!(m.position.unwrap(), fk.translation.vector);
        assert_eq!(m.rotation.unwrap(), fk.rotation);
        assert_eq!(t.position, m.position);
        assert!(m.sigma_position.is_none());
    }
}

#[test]
fn noise_statistics_match_the_requested_sigma() {
    let (sp, sr) = (0.033, 0.174e-3);
    let out = fanuc_sim(10_000, 11, sp, sr, Observe::Pose, &NonGeometric::default());
    let mut pos = Vec::new();
    let mut rot = Vec::new();
    for (m, t) in out.measured.rows.iter().zip(&out.truth.rows) {
        let dp = m.position.unwrap() - t.position.unwrap();
        let dr = rotation_vector(&(m.rotation.unwrap() * t.rotation.unwrap().inverse()));
        pos.extend(dp.iter().copied());
        rot.extend(dr.iter().copied());
    }
    for (v, s) in [(pos, sp), (rot, sr)] {
        let n = v.len() as f64;
        let mean = v.iter().sum::<f64>() / n;
        let std = (v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
        // 30,000 draws: the sample std is within 1.2% (3 standard errors) of sigma, the mean
        // within 4 standard errors of zero.
        assert!((std / s - 1.0).abs() < 0.012, "std {std} vs {s}");
        assert!(mean.abs() < 4.0 * s / n.sqrt(), "mean {mean}");
    }
}

#[test]
fn simulation_is_reproducible_and_noise_does_not_move_configurations() {
    let r = robot("fanuc_r2000ib_210f.toml");
    let j = JointInfo::of(&r);
    let a = fanuc_sim(20, 3, 0.033, 1e-4, Observe::Pose, &NonGeometric::default());
    let b = fanuc_sim(20, 3, 0.033, 1e-4, Observe::Pose, &NonGeometric::default());
    assert_eq!(
        measurements_to_csv(&a.measured, &j).unwrap(),
        measurements_to_csv(&b.measured, &j).unwrap()
    );
    let c = fanuc_sim(20, 3, 0.5, 1e-3, Observe::Pose, &NonGeometric::default());
    for (x, y) in a.measured.rows.iter().zip(&c.measured.rows) {
        assert_eq!(x.q, y.q);
    }
    let d = fanuc_sim(20, 4, 0.033, 1e-4, Observe::Pose, &NonGeometric::default());
    assert_ne!(a.measured.rows[0].q, d.measured.rows[0].q);
}

/// Given configurations are measured as drawn ones are: a drawn run's own configurations given
/// back give its rows exactly (same noise stream); a configuration with the wrong number of
/// joints or a value not finite is refused.
#[test]
fn given_configurations_give_the_drawn_rows() {
    let r = robot("fanuc_r2000ib_210f.toml");
    let ng = NonGeometric::default();
    let drawn = fanuc_sim(15, 8, 0.033, 1e-4, Observe::Pose, &ng);
    let qs: Vec<Vec<f64>> = drawn.measured.rows.iter().map(|m| m.q.clone()).collect();
    let given = |qs: &[Vec<f64>]| {
        Simulation {
            truth: &r,
            nongeometric: &ng,
            configurations: Configurations::Given(qs),
            seed: 8,
            sigma_position_mm: 0.033,
            sigma_rotation_rad: 1e-4,
            observe: Observe::Pose,
        }
        .run(PathBuf::from("given.csv"))
    };
    let out = given(&qs).unwrap();
    let j = JointInfo::of(&r);
    assert_eq!(
        measurements_to_csv(&out.measured, &j).unwrap(),
        measurements_to_csv(&drawn.measured, &j).unwrap()
    );
    let mut short = qs.clone();
    short[3].pop();
    assert!(
        given(&short)
            .unwrap_err()
            .to_string()
            .contains("configuration 4: 5 joint values")
    );
    let mut nan = qs;
    nan[6][2] = f64::NAN;
    assert!(
        given(&nan)
            .unwrap_err()
            .to_string()
            .contains("configuration 7")
    );
}

/// Non-geometric errors and a region built in code meet the checks a file's reader makes: a
/// gear of joint 0 or 7, a backlash of 3 joints, a NaN amplitude and a NaN region are errors,
/// not an index out of bounds or NaN rows.
#[test]
fn simulation_checks_what_code_builds() {
    let r = robot("fanuc_r2000ib_210f.toml");
    let run = |ng: &NonGeometric, region: &Region| {
        Simulation {
            truth: &r,
            nongeometric: ng,
            configurations: Configurations::Drawn { region, count: 5 },
            seed: 1,
            sigma_position_mm: 0.0,
            sigma_rotation_rad: 0.0,
            observe: Observe::Pose,
        }
        .run(PathBuf::from("sim.csv"))
    };
    let limits = Region::limits(&r);
    let gear = |joint: usize, amplitude: f64| NonGeometric {
        gear: vec![Gear {
            joint,
            amplitude1_mrad: amplitude,
            phase1_deg: 0.0,
            amplitude2_mrad: 0.0,
            phase2_deg: 0.0,
        }],
        ..NonGeometric::default()
    };
    for (ng, said) in [
        (gear(0, 0.1), "gear"),
        (gear(7, 0.1), "gear"),
        (gear(2, f64::NAN), "gear"),
        (
            NonGeometric {
                backlash: Some(Backlash { mrad: vec![0.1; 3] }),
                ..NonGeometric::default()
            },
            "backlash",
        ),
    ] {
        let e = run(&ng, &limits).unwrap_err().to_string();
        assert!(
            e.contains("non-geometric errors") && e.contains(said),
            "{e}"
        );
    }
    assert!(run(&gear(2, 0.1), &limits).is_ok());
    let nan = Region(vec![[f64::NAN, f64::NAN]; 6]);
    let e = run(&NonGeometric::default(), &nan).unwrap_err().to_string();
    assert!(e.contains("region: joint 1"), "{e}");
}

/// Displacement of the tool point (mm) that one non-geometric term causes at `q`.
fn displacement(r: &Robot, ng: &NonGeometric, q: &[f64], previous: &[f64]) -> (Vec<f64>, f64) {
    let mut ws = Frames::new(r);
    let mut dq = vec![0.0; 6];
    ng.deflection(r, q, previous, &mut ws, &mut dq);
    let moved: Vec<f64> = q.iter().zip(&dq).map(|(a, b)| a + b).collect();
    let d = (tool_pose(r, &moved).translation.vector - tool_pose(r, q).translation.vector).norm();
    (dq, d)
}

#[test]
fn each_nongeometric_term_moves_the_pose_as_expected() {
    let r = robot("fanuc_r2000ib_210f.toml");
    let q0 = [0.0; 6];
    // Compliance of joint 2 only, payload only, at q = 0. The tool point is 1720 mm in front
    // of axis 2 (x) and 1300 mm above it; gravity -z; axis 2 is +y. Torque about +y of a
    // downward force at +x: r x F = (1.720 m)(m g) about +y.
    let c = Compliance {
        payload_kg: 100.0,
        link_masses_kg: vec![0.0; 6],
        mrad_per_knm: vec![0.0, 0.1, 0.0, 0.0, 0.0, 0.0],
        gravity: [0.0, 0.0, -9.81],
    };
    let mut ws = Frames::new(&r);
    let tau = gravity_torques(&r, &c, &q0, &mut ws);
    assert!((tau[1] - 1.720 * 100.0 * 9.81).abs() < 1e-9, "{tau:?}");
    // Axis 1 is vertical: gravity has no torque about it.
    assert!(tau[0].abs() < 1e-9);
    let ng = NonGeometric {
        compliance: Some(c),
        ..Default::default()
    };
    let (dq, d) = displacement(&r, &ng, &q0, &q0);
    let expect_dq = 0.1e-3 * (1.720 * 100.0 * 9.81) * 1e-3;
    assert!((dq[1] - expect_dq).abs() < 1e-15);
    // The tool swings about axis 2 on a lever of hypot(1720, 1300) mm.
    let lever = 1720f64.hypot(1300.0);
    assert!((d / (expect_dq * lever) - 1.0).abs() < 1e-3, "{d}");

    // Gear error of joint 6: amplitude 0.05 mrad once per revolution, phase 90 deg, so
    // dq = 0.05 mrad at q6 = 0; plus 0.02 mrad twice per revolution with phase 0 (0 at q = 0).
    // The tool point is 182 mm off axis 6.
    let ng = NonGeometric {
        gear: vec![Gear {
            joint: 6,
            amplitude1_mrad: 0.05,
            phase1_deg: 90.0,
            amplitude2_mrad: 0.02,
            phase2_deg: 0.0,
        }],
        ..Default::default()
    };
    let (dq, d) = displacement(&r, &ng, &q0, &q0);
    assert!((dq[5] - 0.05e-3).abs() < 1e-15);
    assert!((d / (0.05e-3 * 182.0) - 1.0).abs() < 1e-3, "{d}");
    // At q6 = 45 deg the second harmonic is at its peak: 0.05 sin(135 deg) + 0.02 sin(90 deg).
    let q = [0.0, 0.0, 0.0, 0.0, 0.0, 45f64.to_radians()];
    let (dq, _) = displacement(&r, &ng, &q, &q);
    assert!((dq[5] - 1e-3 * (0.05 * 135f64.to_radians().sin() + 0.02)).abs() < 1e-15);

    // Backlash of joint 1 (0.2 mrad play): approaching from either side differs by the play.
    let ng = NonGeometric {
        backlash: Some(Backlash {
            mrad: vec![0.2, 0.0, 0.0, 0.0, 0.0, 0.0],
        }),
        ..Default::default()
    };
    let q = [0.5, 0.0, 0.0, 0.0, 0.0, 0.0];
    let (up, _) = displacement(&r, &ng, &q, &[0.0; 6]);
    let (down, _) = displacement(&r, &ng, &q, &[1.0, 0.0, 0.0, 0.0, 0.0, 0.0]);
    assert!((up[0] - down[0] - 0.2e-3).abs() < 1e-15);
    // The tool point is hypot(2032, 182) mm from axis 1.
    let mut a = q;
    a[0] += up[0];
    let mut b = q;
    b[0] += down[0];
    let d = (tool_pose(&r, &a).translation.vector - tool_pose(&r, &b).translation.vector).norm();
    assert!((d / (0.2e-3 * 2032f64.hypot(182.0)) - 1.0).abs() < 1e-3);
}

#[test]
fn deviations_file_applies_and_rejects_unknown_names() {
    let r = robot("fanuc_r2000ib_210f.toml");
    let dev = Deviations::read(root().join("datasets/deviations/table_6_1.toml"), &r).unwrap();
    assert_eq!(dev.0.len(), 30);
    let truth = dev.apply(&r).unwrap();
    let id = r.find_param("theta2").unwrap();
    assert!((truth.param(id) - r.param(id) - (-3.64e-3)).abs() < 1e-15);
    let id = r.find_param("base.d").unwrap();
    assert!((truth.param(id) - (-0.02)).abs() < 1e-15);
    let e = Deviations::parse("a1 = 1.0\nd3 = 2.0\n", Path::new("dev.toml"), &r)
        .unwrap_err()
        .to_string();
    assert!(e.contains("dev.toml:2") && e.contains("d3"), "{e}");
    let e = Deviations::parse("a1 = \"x\"\n", Path::new("dev.toml"), &r)
        .unwrap_err()
        .to_string();
    assert!(e.contains("dev.toml:1"), "{e}");
}

#[test]
fn relative_pairs_consecutive_and_labelled() {
    let r = robot("fanuc_r2000ib_210f.toml");
    let j = JointInfo::of(&r);
    let parse = |text: &str| {
        let t = Table::parse(text.as_bytes(), Path::new("rel.csv"), b',', false).unwrap();
        parse_measurements(&t, &j, &Profile::default(), &ReadOptions::default())
            .unwrap()
            .0
    };
    let set = parse(
        "q1,q2,q3,q4,q5,q6,x,y,z\n0,0,0,0,0,0,0,0,0\n1,0,0,0,0,0,3,4,0\n2,0,0,0,0,0,3,4,12\n",
    );
    let p = pairs(&set).unwrap();
    assert_eq!(p, vec![Pair { a: 0, b: 1 }, Pair { a: 1, b: 2 }]);
    assert_eq!(distance(&set, p[0]), Some(5.0));
    assert_eq!(distance(&set, p[1]), Some(12.0));
    let set = parse(
        "pair,q1,q2,q3,q4,q5,q6,distance\nA,0,0,0,0,0,0,\nB,1,0,0,0,0,0,\nA,2,0,0,0,0,0,150.5\nB,3,0,0,0,0,0,99\n",
    );
    let p = pairs(&set).unwrap();
    assert_eq!(p, vec![Pair { a: 0, b: 2 }, Pair { a: 1, b: 3 }]);
    assert_eq!(distance(&set, p[0]), Some(150.5));
    let set = parse(
        "pair,q1,q2,q3,q4,q5,q6,distance\nA,0,0,0,0,0,0,\nA,1,0,0,0,0,0,1\nA,2,0,0,0,0,0,2\n",
    );
    let e = pairs(&set).unwrap_err().to_string();
    assert!(e.contains("rel.csv:2") && e.contains("3 rows"), "{e}");
}

/// Rodrigues' formula written out: the rotation by `angle` (rad) about the unit `axis`.
fn rodrigues(axis: Vector3<f64>, angle: f64) -> Matrix3<f64> {
    let (s, c) = angle.sin_cos();
    let k = Matrix3::new(
        0.0, -axis.z, axis.y, axis.z, 0.0, -axis.x, -axis.y, axis.x, 0.0,
    );
    Matrix3::identity() + k * s + k * k * (1.0 - c)
}

/// A rotation vector (UR's tool pose) and a quaternion (scalar first, ABB's and many trackers'
/// exports) read as the rotation Rodrigues' formula gives; a quaternion off unit norm, a
/// partial group, `euler` beside them and an unknown form are errors naming file, line and
/// field.
#[test]
fn rotation_vectors_and_quaternions_are_read_as_their_rotations() {
    let fanuc = robot("fanuc_r2000ib_210f.toml");
    let axis = Vector3::new(1.0, -2.0, 2.0) / 3.0;
    let angle = 2.5_f64; // rad, beyond 90 deg
    let expect = rodrigues(axis, angle);
    let (h, w) = ((angle / 2.0).sin(), (angle / 2.0).cos());
    let r = axis * angle;
    let dir = std::env::temp_dir().join(format!("robocal_orient_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let read = |profile: &str, csv: &str| {
        let p = dir.join("p.toml");
        std::fs::write(&p, profile).unwrap();
        let d = dir.join("d.csv");
        std::fs::write(&d, csv).unwrap();
        Profile::read(&p)
            .and_then(|pr| read_measurements(&d, &fanuc, &pr, &ReadOptions::default()))
            .map(|(set, _)| set)
            .map_err(|e| e.to_string())
    };
    let joints = "q1,q2,q3,q4,q5,q6";
    let zeros = "0,0,0,0,0,0";
    // The rotation vector in degrees (angle_unit), and in radians as UR reports it.
    for (unit, scale) in [("deg", angle.to_degrees() / angle), ("rad", 1.0)] {
        let csv = format!(
            "{joints},x,y,z,rx,ry,rz\n{zeros},1,2,3,{},{},{}\n",
            r.x * scale,
            r.y * scale,
            r.z * scale
        );
        let set = read(
            &format!("orientation = \"rotation_vector\"\nangle_unit = \"{unit}\"\n"),
            &csv,
        )
        .unwrap();
        let got = set.rows[0].rotation.unwrap();
        assert!(
            (got.matrix() - expect).abs().max() < 1e-14,
            "{unit}: {got:?}"
        );
    }
    // The quaternion, its columns named by the profile (one of them `rx`: unused here), with
    // the sign of every component flipped (the same rotation) and rounded to 6 decimals.
    let profile = "orientation = \"quaternion\"\n[columns]\nqw = \"Q0\"\nqx = \"rx\"\n";
    for sign in [1.0, -1.0] {
        let [a, b, c, d] = [w, axis.x * h, axis.y * h, axis.z * h].map(|v| sign * v);
        let csv =
            format!("{joints},x,y,z,Q0,rx,qy,qz\n{zeros},1,2,3,{a:.6},{b:.6},{c:.6},{d:.6}\n");
        let got = read(profile, &csv).unwrap().rows[0].rotation.unwrap();
        assert!((got.matrix() - expect).abs().max() < 1e-5, "{got:?}");
    }
    let csv = format!(
        "{joints},x,y,z,Q0,rx,qy,qz\n{zeros},1,2,3,{w},{},{},{}\n",
        axis.x * h,
        axis.y * h,
        axis.z * h
    );
    let got = read(profile, &csv).unwrap().rows[0].rotation.unwrap();
    assert!((got.matrix() - expect).abs().max() < 1e-14, "{got:?}");

    // Errors, each naming the file, the line and the field.
    let bad_norm = format!("{joints},x,y,z,qw,qx,qy,qz\n{zeros},1,2,3,0.9,0,0,0\n");
    let e = read("orientation = \"quaternion\"\n", &bad_norm).unwrap_err();
    assert!(
        e.contains("d.csv:2: field `qw`") && e.contains("norm 0.9"),
        "{e}"
    );
    let partial = format!("{joints},x,y,z,qw,qx,qy\n{zeros},1,2,3,1,0,0\n");
    let e = read("orientation = \"quaternion\"\n", &partial).unwrap_err();
    assert!(
        e.contains("d.csv:1: field `qz`") && e.contains("group of four"),
        "{e}"
    );
    let e = read("orientation = \"quaternion\"\neuler = \"zyx\"\n", &partial).unwrap_err();
    assert!(e.contains("p.toml:2: field `euler`"), "{e}");
    let e = read("orientation = \"matrix\"\n", &partial).unwrap_err();
    assert!(
        e.contains("p.toml:1: field `orientation`") && e.contains("rotation_vector"),
        "{e}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// A profile that names a column the defaults already read (`x = "q1"` beside the default
/// joint columns) is refused, naming the column and both fields: read, the column gave its
/// number to both and the real `x` was carried as an extra column.
#[test]
fn one_column_is_not_read_as_two_fields() {
    let fanuc = robot("fanuc_r2000ib_210f.toml");
    let dir = std::env::temp_dir().join(format!("robocal_twice_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let csv = dir.join("d.csv");
    std::fs::write(&csv, "q1,q2,q3,q4,q5,q6,x,y,z\n10,0,0,0,0,0,1500,2,3\n").unwrap();
    let read = |profile: &str| {
        let p = dir.join("p.toml");
        std::fs::write(&p, profile).unwrap();
        Profile::read(&p)
            .and_then(|pr| read_measurements(&csv, &fanuc, &pr, &ReadOptions::default()))
            .map(|(set, _)| set)
            .map_err(|e| e.to_string())
    };
    for (profile, field) in [
        ("[columns]\nx = \"q1\"\n", "position"),
        ("[columns]\nid = \"q3\"\n", "id"),
    ] {
        let e = read(profile).unwrap_err();
        assert!(
            e.contains("p.toml") && e.contains("`q") && e.contains("joints") && e.contains(field),
            "{e}"
        );
    }
    // Its own columns are read as before.
    let set = read("[columns]\nx = \"x\"\n").unwrap();
    assert_eq!(set.rows[0].position.unwrap().x, 1500.0);
}

/// With `sigma_angles = "angles"` the file's own sigmas are checked before they are carried
/// to the axes (a negative one was accepted, squared away), and at the gimbal lock the carried
/// sigmas keep a floor of a tenth of the smallest (an axis there got about 1e-8 rad, or an
/// error blaming a cell whose value was fine).
#[test]
fn euler_angle_sigmas_are_checked_as_given_and_floored_at_the_lock() {
    let ur = robot("ur10.toml");
    let profile = Profile::parse(
        "euler = \"xyz_intrinsic\"\nsigma_angles = \"angles\"\n",
        Path::new("p.toml"),
    )
    .unwrap();
    let read = |rx: f64, ry: f64, srx: f64| {
        let text = format!(
            "q1,q2,q3,q4,q5,q6,x,y,z,rx,ry,rz,srx,sry,srz\n\
             0,-90,0,-90,0,0,100,200,300,{rx},{ry},10,{srx},0.002,0.004\n"
        );
        let t = Table::parse(text.as_bytes(), Path::new("s.csv"), b',', false).unwrap();
        parse_measurements(&t, &JointInfo::of(&ur), &profile, &ReadOptions::default())
    };
    // Without the angles there is nothing to carry the sigmas through.
    let t = Table::parse(
        b"q1,q2,q3,q4,q5,q6,x,y,z,srx,sry,srz\n0,-90,0,-90,0,0,100,200,300,0.001,0.002,0.004\n",
        Path::new("s.csv"),
        b',',
        false,
    )
    .unwrap();
    let e = parse_measurements(&t, &JointInfo::of(&ur), &profile, &ReadOptions::default())
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("s.csv:1") && e.contains("no angle columns"),
        "{e}"
    );
    let e = read(-90.0, -20.0, -0.001).unwrap_err().to_string();
    assert!(
        e.contains("s.csv:2") && e.contains("srx") && e.contains("must be positive"),
        "{e}"
    );
    // At the lock (ry = 90 deg) rx and rz turn about one axis: the third axis is floored.
    let (set, _) = read(0.0, 90.0, 0.001).unwrap();
    let s = set.rows[0].sigma_rotation.unwrap().map(f64::to_degrees);
    assert!(s.min() >= 0.1 * 0.001 - 1e-15, "{s:?}");
    // Away from it, sqrt(diag(E diag(s^2) E^T)), E = [x, Rx y, Rx Ry z] (here rx = 0).
    let (set, _) = read(0.0, -20.0, 0.001).unwrap();
    let s = set.rows[0].sigma_rotation.unwrap().map(f64::to_degrees);
    let (sb, cb) = (-20.0f64).to_radians().sin_cos();
    let want = Vector3::new(
        (0.001f64.powi(2) + (sb * 0.004).powi(2)).sqrt(),
        0.002,
        (cb * 0.004).abs(),
    );
    assert!((s - want).norm() < 1e-12, "{s:?} against {want:?}");
}
