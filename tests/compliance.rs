//! Joint compliance in the model (issue 14): q' = q + c tau(q). The model against the
//! simulator's compliance, its forward kinematics with and without a workspace, its joint
//! Jacobian against central differences, inverse kinematics round trips, and robot files.

use nalgebra::Matrix6xX;
use robocal::geometry::rotation::rotation_vector;
use robocal::kinematics::{
    Frames, IkOptions, IkSolver, IkStart, RobotModel, frames, joint_jacobian, tool_pose,
};
use robocal::model::file::parse_robot;
use robocal::model::{Compliance, Robot, read_robot, robot_to_toml};
use robocal::sim::NonGeometric;
use std::path::Path;

fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

fn fanuc() -> Robot {
    read_robot(root().join("datasets/robots/fanuc_r2000ib_210f.toml")).unwrap()
}

/// The shipped non-geometric robot's compliance alone (no gear errors).
fn compliance_only(robot: &Robot) -> NonGeometric {
    let ng = NonGeometric::read(
        root().join("datasets/nongeometric/fanuc_compliance_gear.toml"),
        robot,
    )
    .unwrap();
    NonGeometric {
        compliance: ng.compliance,
        ..Default::default()
    }
}

/// `robot` with the shipped non-geometric robot's masses and compliances, as the model's own.
fn compliant(robot: &Robot) -> Robot {
    compliance_only(robot)
        .compliance
        .unwrap()
        .on_robot(robot)
        .unwrap()
}

/// Configurations spread over 80% of the FANUC's joint ranges (rad).
fn configurations(count: usize) -> Vec<Vec<f64>> {
    let robot = fanuc();
    (0..count)
        .map(|s| {
            (0..6)
                .map(|j| {
                    let [lo, hi] = robot.joints()[j].limits_internal();
                    let t = ((s * 7 + j * 5) % 13) as f64 / 12.0;
                    0.5 * (lo + hi) + 0.8 * (t - 0.5) * (hi - lo)
                })
                .collect()
        })
        .collect()
}

#[test]
fn the_model_reaches_the_simulators_pose() {
    let truth = fanuc();
    let ng = compliance_only(&truth);
    let model = ng.compliance.as_ref().unwrap().on_robot(&truth).unwrap();
    assert!(model.is_compliant());
    let mut ws = Frames::new(&truth);
    let mut largest: f64 = 0.0;
    for q in configurations(30) {
        let want = robocal::sim::actual_pose(&truth, &ng, &q, &q, &mut ws);
        let got = tool_pose(&model, &q);
        let rigid = tool_pose(&truth, &q);
        largest = largest.max((want.translation.vector - rigid.translation.vector).norm());
        let dp = (got.translation.vector - want.translation.vector).norm();
        let dr = rotation_vector(&(got.rotation * want.rotation.inverse())).norm();
        assert!(dp < 1e-9 && dr < 1e-12, "{dp} mm, {dr} rad at {q:?}");
    }
    // The compliance moves the tool by tenths of a mm: the check above is not vacuous.
    assert!(largest > 0.2, "largest deflection {largest} mm");
}

#[test]
fn frames_and_tool_pose_agree_to_the_bit() {
    let truth = fanuc();
    let model = compliant(&truth);
    let mut f = Frames::new(&model);
    for q in configurations(20) {
        frames(&model, &q, &mut f);
        assert!(f.load.compliant);
        assert_eq!(f.tool, tool_pose(&model, &q));
        // The load's commanded frames are the rigid robot's.
        assert_eq!(f.load.tool, tool_pose(&model.rigid(), &q));
    }
}

#[test]
fn joint_jacobian_of_a_compliant_robot_matches_central_differences() {
    let truth = fanuc();
    let model = compliant(&truth);
    let mut f = Frames::new(&model);
    let mut jac = Matrix6xX::zeros(6);
    let mut rigid_jac = Matrix6xX::zeros(6);
    let mut rigid_f = Frames::new(&model);
    let mut worst: f64 = 0.0;
    let mut correction: f64 = 0.0;
    for q in configurations(10) {
        frames(&model, &q, &mut f);
        joint_jacobian(&model, &f, &mut jac);
        frames(&model.rigid(), &q, &mut rigid_f);
        joint_jacobian(&model.rigid(), &rigid_f, &mut rigid_jac);
        for i in 0..6 {
            let h = 1e-6;
            let (mut qp, mut qm) = (q.clone(), q.clone());
            qp[i] += h;
            qm[i] -= h;
            let (p, m) = (tool_pose(&model, &qp), tool_pose(&model, &qm));
            let dp = (p.translation.vector - m.translation.vector) / (2.0 * h);
            let dr = rotation_vector(&(p.rotation * m.rotation.inverse())) / (2.0 * h);
            let col = jac.column(i);
            let scale = dp.norm().max(1.0);
            worst = worst.max((col.fixed_rows::<3>(0) - dp).norm() / scale);
            worst = worst.max((col.fixed_rows::<3>(3) - dr).norm());
            correction = correction
                .max((col.fixed_rows::<3>(0) - rigid_jac.column(i).fixed_rows::<3>(0)).norm());
        }
    }
    assert!(worst < 1e-7, "worst relative difference {worst}");
    // The compliant Jacobian differs from the rigid one by more than the tolerance.
    assert!(correction > 1e-3, "largest correction {correction} mm/rad");
}

#[test]
fn inverse_kinematics_of_a_compliant_robot_round_trips() {
    let truth = fanuc();
    let model = compliant(&truth);
    let start = IkStart::choose(&model, None).unwrap();
    assert!(
        matches!(start, IkStart::Nominal(_)),
        "the rigid closed form starts a numerical solve"
    );
    let mut solver = IkSolver::new(RobotModel::new(&model), start, IkOptions::default());
    for q in configurations(15) {
        let target = tool_pose(&model, &q);
        let solved = solver
            .nearest(&target, Some(&q))
            .unwrap_or_else(|e| panic!("{q:?}: {e}"));
        let back = tool_pose(&model, &solved.solution.q);
        let dp = (back.translation.vector - target.translation.vector).norm();
        assert!(dp < 1e-6, "{dp} mm");
        let dq: f64 = solved
            .solution
            .q
            .iter()
            .zip(&q)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        assert!(dq < 1e-7, "joints {dq} rad from the commanded ones");
    }
}

#[test]
fn robot_files_keep_compliances_and_refuse_bad_ones() {
    let truth = fanuc();
    let model = compliant(&truth);
    let text = robot_to_toml(&model);
    assert!(text.contains("[compliance]"), "{text}");
    let back = parse_robot(&text, Path::new("back.toml")).unwrap();
    assert_eq!(back, model);
    assert_eq!(back.compliance(), model.compliance());
    let c = model.find_param("c3").unwrap();
    assert!((model.param(c) - 0.08e-6).abs() < 1e-20);

    let plain =
        std::fs::read_to_string(root().join("datasets/robots/fanuc_r2000ib_210f.toml")).unwrap();
    let mass = "[mass]\nlink_kg = [1, 2, 3, 4, 5, 6]\nlink_com_mm = [[0, 0, 0], [0, 0, 0], \
                [0, 0, 0], [0, 0, 0], [0, 0, 0], [0, 0, 0]]\n";
    for (tables, want, line_of) in [
        (
            "[compliance]\njoints = [0, 0.05, 0.08, 0, 0, 0]\n".to_string(),
            "joint compliances need mass properties",
            "[compliance]",
        ),
        // A table of gravity alone (which the mass-free moments take) holds no mass for the
        // compliances to deflect: they did nothing, without a word.
        (
            "[mass]\ngravity = [0, 0, -9.81]\n[compliance]\njoints = [0, 0.05, 0.08, 0, 0, 0]\n"
                .to_string(),
            "joint compliances need mass properties",
            "joints =",
        ),
        (
            format!("{mass}[compliance]\njoints = [0, 0.05]\n"),
            "2 compliances for a robot with 6 joints",
            "joints =",
        ),
        (
            format!("{mass}[compliance]\njoints = [0, 0.05, 2e3, 0, 0, 0]\n"),
            "joint 3: compliance 2000 mrad per kN m",
            "joints =",
        ),
    ] {
        let text = format!("{plain}\n{tables}");
        let line = text.lines().position(|l| l.starts_with(line_of)).unwrap() + 1;
        let e = parse_robot(&text, Path::new("r.toml"))
            .unwrap_err()
            .to_string();
        assert!(e.contains(want), "{e}");
        assert!(
            e.starts_with(&format!("r.toml:{line}:")),
            "{e} (want line {line})"
        );
    }
    // Joint compliances are parameters of a robot with masses only; without, the
    // mass-free coefficients are.
    assert!(truth.find_param("c2").is_none());
    assert!(truth.find_param("k2.mx3").is_some());
    assert!(model.find_param("k2.mx3").is_none());
    // Every parameter is found by its name, and names that only look like one are not.
    let params = truth.parameters();
    for p in &params {
        assert_eq!(truth.find_param(&p.name()), Some(*p), "{}", p.name());
    }
    for bad in [
        "k2.mx03", "k0.m1", "k2.mq3", "k7.m1", "k2.m7", "k2.m0", "k3.m2", "k2.mx", "k2.x3",
        "k2.mp", "k+2.m3", "k2.m+3",
    ] {
        assert!(truth.find_param(bad).is_none(), "{bad}");
    }
    let chosen = robocal::identify::select::select(&truth, "compliance").unwrap();
    assert_eq!(params[chosen[0]].name(), "k1.m1");
    assert_eq!(params[*chosen.last().unwrap()].name(), "k6.mzP");
}

mod recovery {
    use super::*;
    use robocal::data::MeasurementSet;
    use robocal::identify::{Options, identify};
    use robocal::sim::{Configurations, Deviations, Observe, Region, Simulation};
    use std::path::PathBuf;

    fn simulate(
        truth: &Robot,
        ng: &NonGeometric,
        count: usize,
        seed: u64,
    ) -> (MeasurementSet, MeasurementSet) {
        let region = Region::limits(truth);
        let out = Simulation {
            truth,
            nongeometric: ng,
            configurations: Configurations::Drawn {
                region: &region,
                count,
            },
            seed,
            sigma_position_mm: 0.033,
            sigma_rotation_rad: 0.174e-3,
            observe: Observe::Pose,
        }
        .run(PathBuf::from("sim"))
        .unwrap();
        (out.measured, out.truth)
    }

    fn mean_error(robot: &Robot, truth: &MeasurementSet) -> f64 {
        truth
            .rows
            .iter()
            .map(|r| (tool_pose(robot, &r.q).translation.vector - r.position.unwrap()).norm())
            .sum::<f64>()
            / truth.rows.len() as f64
    }

    #[test]
    fn compliances_are_recovered_over_seeds() {
        let nominal = fanuc();
        let truth = Deviations::read(root().join("datasets/deviations/table_6_1.toml"), &nominal)
            .unwrap()
            .apply(&nominal)
            .unwrap();
        let ng = NonGeometric::read(
            root().join("datasets/nongeometric/fanuc_compliance_gear.toml"),
            &truth,
        )
        .unwrap();
        let gears = NonGeometric {
            compliance: None,
            ..ng.clone()
        };
        let sim = ng.compliance.clone().unwrap();
        let with_masses = sim
            .on_robot(&nominal)
            .unwrap()
            .with_compliance(None)
            .unwrap();
        let (_, test) = simulate(&truth, &ng, 300, 9999);
        let (_, test_gears) = simulate(&truth, &gears, 300, 9999);
        let compliance_only = NonGeometric {
            compliance: ng.compliance.clone(),
            ..Default::default()
        };
        let opts = Options {
            params: "full,compliance".into(),
            ..Options::default()
        };
        let z_of = |id: &robocal::identify::Identified| -> Vec<(usize, f64)> {
            id.parameters
                .iter()
                .filter(|p| p.name.starts_with('c'))
                .map(|p| {
                    let j: usize = p.name[1..].parse().unwrap();
                    (j, (p.estimate - sim.mrad_per_knm[j - 1]) / p.std)
                })
                .collect()
        };
        let (mut full_e, mut comp_e, mut floor_e) = (Vec::new(), Vec::new(), Vec::new());
        let mut free_e = Vec::new();
        let (mut z_gears, mut z_only) = (Vec::new(), Vec::new());
        for seed in 0..20u64 {
            let (cal, _) = simulate(&truth, &ng, 30, 1000 + seed);
            let (cal_floor, _) = simulate(&truth, &gears, 30, 1000 + seed);
            let (cal_c, _) = simulate(&truth, &compliance_only, 30, 1000 + seed);
            let full = identify(&nominal, &cal, &Options::default()).unwrap();
            let floor = identify(&nominal, &cal_floor, &Options::default()).unwrap();
            let comp = identify(&with_masses, &cal, &opts).unwrap();
            let only = identify(&with_masses, &cal_c, &opts).unwrap();
            let free = identify(&nominal, &cal, &opts).unwrap();
            free_e.push(mean_error(&free.robot, &test));
            // c1 has no effect (joint 1 is vertical); c2..c5 are identified; c6 (zero in
            // truth) may be dropped as not significant.
            let kept: Vec<usize> = z_of(&only).iter().map(|(j, _)| *j).collect();
            assert!((2..=5).all(|j| kept.contains(&j)), "{kept:?}");
            full_e.push(mean_error(&full.robot, &test));
            comp_e.push(mean_error(&comp.robot, &test));
            floor_e.push(mean_error(&floor.robot, &test_gears));
            z_gears.extend(z_of(&comp));
            z_only.extend(z_of(&only));
        }
        let median = |v: &mut Vec<f64>| {
            v.sort_by(f64::total_cmp);
            0.5 * (v[9] + v[10])
        };
        let worst = |z: &[(usize, f64)], j: usize| {
            z.iter()
                .filter(|(k, _)| *k == j)
                .map(|(_, z)| z.abs())
                .fold(0.0, f64::max)
        };
        let (full_m, comp_m, floor_m) = (
            median(&mut full_e),
            median(&mut comp_e),
            median(&mut floor_e),
        );
        let free_range = (
            free_e.iter().copied().fold(f64::INFINITY, f64::min),
            free_e.iter().copied().fold(0.0, f64::max),
        );
        let free_m = median(&mut free_e);
        println!(
            "test mean error vs truth over 20 seeds (median mm): full {full_m:.4}, \
             full+compliance {comp_m:.4} (masses known), {free_m:.4} (without masses, range \
             {:.4}-{:.4}), floor (geometry fit without compliance) {floor_m:.4}",
            free_range.0, free_range.1
        );
        for j in 2..=6 {
            println!(
                "c{j}: largest |estimate - true| / std: compliance alone {:.2}, with gear errors {:.2}",
                worst(&z_only, j),
                worst(&z_gears, j)
            );
        }
        // Compliance alone: the model is complete, so every estimate is within 3 reported
        // standard deviations of the truth.
        let beyond: Vec<_> = z_only.iter().filter(|(_, z)| z.abs() > 3.0).collect();
        assert!(beyond.is_empty(), "beyond 3 sigma: {beyond:?}");
        // With gear errors too: at the floor the geometry reaches without the compliance,
        // and far below the geometry alone.
        assert!(comp_m <= 1.1 * floor_m, "{comp_m} vs floor {floor_m}");
        assert!(comp_m <= 0.3 * full_m, "{comp_m} vs full {full_m}");
    }
}

#[test]
fn the_shipped_nominal_with_masses_is_the_simulators() {
    let nominal = fanuc();
    let ng = compliance_only(&nominal);
    let want = ng
        .compliance
        .unwrap()
        .on_robot(&nominal)
        .unwrap()
        .with_compliance(None)
        .unwrap();
    let shipped =
        read_robot(root().join("datasets/nongeometric_robot/nominal_masses.toml")).unwrap();
    assert_eq!(shipped, want);
    let c = Compliance::from_file_units(&[0.0; 6]);
    assert!(!shipped.with_compliance(Some(c)).unwrap().is_compliant());
}

/// Without masses: the mass-free coefficients identified from the shipped non-geometric
/// robot's calibration set, their file round trip, and forward kinematics with and without a
/// workspace.
#[test]
fn mass_free_compliance_is_identified_written_and_read_back() {
    use robocal::data::read_canonical;
    use robocal::identify::{Options, identify};
    let nominal = fanuc();
    let dir = root().join("datasets/nongeometric_robot");
    let cal = read_canonical(&dir.join("calibration.csv"), &nominal).unwrap();
    let test = read_canonical(&dir.join("test_truth.csv"), &nominal).unwrap();
    let opts = Options {
        params: "full,compliance".into(),
        ..Options::default()
    };
    let id = identify(&nominal, &cal, &opts).unwrap();
    let full = identify(&nominal, &cal, &Options::default()).unwrap();
    let robot = &id.robot;
    assert!(robot.is_compliant() && robot.masses().is_none());
    // The rows give no payload: the coefficients hold for the one carried, and a note says so.
    assert!(
        id.notes
            .iter()
            .any(|n| n.starts_with("mass-free compliance: the coefficients carry the payload")),
        "{:?}",
        id.notes
    );
    assert!(!full.notes.iter().any(|n| n.starts_with("mass-free")));
    // Joint 1 is vertical: none of its coefficients has an effect.
    assert!(id.parameters.iter().all(|p| !p.name.starts_with("k1.")));
    assert!(id.parameters.iter().any(|p| p.name.starts_with("k2.")));
    let text = robot_to_toml(robot);
    assert!(text.contains("moments = ["), "{text}");
    let back = parse_robot(&text, Path::new("back.toml")).unwrap();
    assert_eq!(&back, robot);
    let mut f = Frames::new(robot);
    let mean = |r: &Robot| {
        test.rows
            .iter()
            .map(|row| (tool_pose(r, &row.q).translation.vector - row.position.unwrap()).norm())
            .sum::<f64>()
            / test.rows.len() as f64
    };
    for row in &test.rows {
        frames(&back, &row.q, &mut f);
        assert_eq!(f.tool, tool_pose(&back, &row.q));
    }
    let (e_full, e_free) = (mean(&full.robot), mean(&back));
    println!(
        "validation mean vs truth: full {e_full:.4} mm, full + mass-free compliance {e_free:.4} mm"
    );
    assert!(e_free < 0.5 * e_full, "{e_free} vs {e_full}");

    // A [mass] table may give gravity alone (a wall mount without known masses): the
    // mass-free coefficients then act along that gravity.
    let plain =
        std::fs::read_to_string(root().join("datasets/robots/fanuc_r2000ib_210f.toml")).unwrap();
    let wall = parse_robot(
        &format!("{plain}\n[mass]\ngravity = [9.81, 0.0, 0.0]\n"),
        Path::new("wall.toml"),
    )
    .unwrap();
    assert!(!wall.masses().unwrap().has_mass());
    assert!(wall.find_param("k1.mx2").is_some() && wall.find_param("c1").is_none());
    let bad = format!("{plain}\n[compliance]\nmoments = [[[1, 2, 3, 4]]]\n");
    let line = bad.lines().position(|l| l.starts_with("moments")).unwrap() + 1;
    let e = parse_robot(&bad, Path::new("r.toml"))
        .unwrap_err()
        .to_string();
    assert!(
        e.starts_with(&format!("r.toml:{line}:")) && e.contains("moments need 6 lists"),
        "{e}"
    );
}

/// Target compensation on a compliant model: the joints commanded reach the desired pose
/// through the deflected chain, and the joints it reaches from the command are those the
/// rigid nominal needs for the desired pose.
#[test]
fn compensation_inverts_the_compliant_model() {
    use robocal::compensation::{CalibratedModel, FakeTargetSolver};
    use robocal::data::targets::Target;
    let nominal = fanuc();
    let model = compliant(&nominal);
    let mut solver = FakeTargetSolver::new(&nominal, CalibratedModel::identified(&model)).unwrap();
    let mut ws = Frames::new(&model);
    let (mut moved, mut checked): (f64, usize) = (0.0, 0);
    for q in configurations(12) {
        // A pose the rigid nominal reaches at q: the compliant robot needs other joints.
        let desired = tool_pose(&nominal, &q);
        let c = solver
            .solve(&Target::Pose(desired), Some(&q))
            .unwrap_or_else(|e| panic!("{q:?}: {e:?}"));
        let reached = tool_pose(&model, &c.q);
        assert!((reached.translation.vector - desired.translation.vector).norm() < 1e-6);
        assert!(rotation_vector(&(reached.rotation * desired.rotation.inverse())).norm() < 1e-9);
        // The model is the nominal geometry plus deflections: the joints it reaches from the
        // command are the rigid nominal's joints for the desired pose, q (away from the wrist
        // singularity q5 = 0, where only q4 + q6 is defined).
        frames(&model, &c.q, &mut ws);
        moved = moved.max((c.fake.translation.vector - desired.translation.vector).norm());
        if q[4].sin().abs() < 1e-3 {
            continue;
        }
        checked += 1;
        let off = ws
            .load
            .reached
            .iter()
            .zip(&q)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        assert!(off < 1e-7, "reached joints {off} rad from q at {q:?}");
        assert!(c.q.iter().zip(&q).any(|(a, b)| (a - b).abs() > 1e-5));
    }
    assert!(
        checked >= 10,
        "{checked} configurations away from the wrist singularity"
    );
    // The compliance is worth compensating: the fake targets move by tenths of a mm.
    assert!(moved > 0.2, "{moved} mm");
}
