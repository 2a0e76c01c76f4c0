//! Target compensation (issue 6, item 1) on simulated robots: the TRUE robot, commanded to the
//! joints found for each desired pose, reaches it within the accuracy the calibrated (and
//! compensated) model reached on test data; the fake target is what the nominal controller
//! turns back into those joints; impossible targets are failures, never commands.

mod common;

use robocal::compensation::{CalibratedModel, Failure, FakeTargetSolver};
use robocal::data::Target;
use robocal::data::{MeasurementSet, read_canonical};
use robocal::geometry::rotation::rotation_vector;
use robocal::identify::{Measure, Options, identify};
use robocal::kinematics::{ClosedFormIk, Frames, IkOptions, IkSolver, IkStart, Pose, tool_pose};
use robocal::model::{Robot, read_robot};
use robocal::neural::compensator::{Compensator, CompensatorOptions};
use robocal::neural::predict::PredictWorkspace;
use robocal::sim::{actual_pose, nongeometric::NonGeometric};
use std::path::{Path, PathBuf};

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

struct Sim {
    nominal: Robot,
    truth: Robot,
    ng: NonGeometric,
    calibration: MeasurementSet,
    training: MeasurementSet,
    test_truth: MeasurementSet,
}

fn load(set: &str, ng: Option<&str>) -> Sim {
    let d = root().join("datasets");
    let nominal = read_robot(d.join("robots/fanuc_r2000ib_210f.toml")).unwrap();
    let truth = read_robot(d.join(set).join("true_robot.toml")).unwrap();
    let ng = match ng {
        Some(p) => NonGeometric::read(d.join(p), &truth).unwrap(),
        None => NonGeometric::default(),
    };
    let rd = |f: &str| read_canonical(&d.join(set).join(f), &nominal).unwrap();
    Sim {
        calibration: rd("calibration.csv"),
        training: rd("training.csv"),
        test_truth: rd("test_truth.csv"),
        nominal,
        truth,
        ng,
    }
}

fn truth_pose(m: &robocal::data::Measurement) -> Pose {
    Pose::from_parts(m.position.unwrap().into(), m.rotation.unwrap())
}

/// Mean position (mm) and orientation (rad) errors of `f` against the test truth.
fn model_errors(s: &Sim, f: &mut dyn FnMut(&[f64]) -> Pose) -> (f64, f64) {
    let (mut p, mut r) = (0.0, 0.0);
    for m in &s.test_truth.rows {
        let (want, got) = (truth_pose(m), f(&m.q));
        p += (want.translation.vector - got.translation.vector).norm();
        r += rotation_vector(&(want.rotation * got.rotation.inverse())).norm();
    }
    let n = s.test_truth.rows.len() as f64;
    (p / n, r / n)
}

/// Solves every test-truth pose as a desired target (seeded with the test joints, or by the
/// nominal closed form alone) and returns the TRUE robot's mean position and orientation
/// errors at the commanded joints, after checking each command.
/// `model_pose` evaluates the same calibrated model independently of the solver.
fn true_errors(
    s: &Sim,
    model: CalibratedModel,
    model_pose: &mut dyn FnMut(&[f64]) -> Pose,
    seeded: bool,
    position_only: bool,
) -> (f64, f64) {
    let mut solver = FakeTargetSolver::new(&s.nominal, model).unwrap();
    let closed = ClosedFormIk::new(&s.nominal).unwrap();
    let mut ws = Frames::new(&s.truth);
    let (mut p, mut r, mut n, mut skipped, mut at_limits) = (0.0, 0.0, 0, 0, 0);
    let mut moves = Vec::new();
    let mut sols = Vec::new();
    for m in &s.test_truth.rows {
        let want = truth_pose(m);
        let desired = if position_only {
            Target::Position(want.translation.vector)
        } else {
            Target::Pose(want)
        };
        let seed = seeded.then_some(m.q.as_slice());
        let cmd = match solver.solve(&desired, seed) {
            Ok(c) => c,
            // A test pose within about a degree of a limit may need the joint beyond it.
            Err(Failure::OutsideLimits(js))
                if js.iter().all(|&j| {
                    let [lo, hi] = s.nominal.joints()[j].limits_internal();
                    (m.q[j] - lo).min(hi - m.q[j]) < 0.02
                }) =>
            {
                skipped += 1;
                at_limits += 1;
                continue;
            }
            // Within about two degrees of the wrist singularity q5 = 0, calibration may move
            // q5 across it: the wrist flips branch, and that is reported.
            Err(Failure::BranchChanged(_)) if m.q[4].abs() < 0.035 => {
                skipped += 1;
                continue;
            }
            Err(e) => panic!("row {:?}: {e}", m.id),
        };
        // The calibrated model, evaluated on its own, reaches the target at q*.
        let at = model_pose(&cmd.q);
        let (dp, dr) = (
            (at.translation.vector - want.translation.vector).norm(),
            rotation_vector(&(at.rotation * cmd.desired.rotation.inverse())).norm(),
        );
        assert!(
            dp < 1e-6 && (position_only || dr < 1e-9),
            "row {:?}: {dp} mm {dr} rad",
            m.id
        );
        // The controller: nominal closed form of the fake target on the seed's branch.
        closed.solve_branches(&cmd.fake, &mut sols);
        let (_, back) = sols.iter().find(|(b, _)| Some(*b) == cmd.branch).unwrap();
        for (a, b) in back.iter().zip(&cmd.q) {
            let d = (a - b).rem_euclid(2.0 * std::f64::consts::PI);
            assert!(
                d.min(2.0 * std::f64::consts::PI - d) < 1e-8,
                "{back:?} vs {:?}",
                cmd.q
            );
        }
        if seeded {
            // Same configuration as the seed: typically the joints move by calibration-sized
            // amounts (near singularities some swing further, still on the branch).
            moves.push(
                cmd.q
                    .iter()
                    .zip(&m.q)
                    .map(|(a, b)| (a - b).abs())
                    .fold(0.0, f64::max),
            );
        }
        let got = actual_pose(&s.truth, &s.ng, &cmd.q, &cmd.q, &mut ws);
        p += (cmd.desired.translation.vector - got.translation.vector).norm();
        r += rotation_vector(&(cmd.desired.rotation * got.rotation.inverse())).norm();
        n += 1;
    }
    println!(
        "{n} targets solved, {at_limits} outside the limits, {} across the wrist singularity",
        skipped - at_limits
    );
    assert!(skipped * 50 <= n, "{skipped} targets skipped");
    moves.sort_by(f64::total_cmp);
    if let Some(median) = moves.get(moves.len() / 2) {
        assert!(*median < 0.01, "median joint move {median} rad");
    }
    (p / n as f64, r / n as f64)
}

fn identified(s: &Sim) -> Robot {
    identify(
        &s.nominal,
        &s.calibration,
        &Options {
            params: "full".into(),
            measure: Some(Measure::Pose),
            ..Default::default()
        },
    )
    .unwrap()
    .robot
}

#[test]
fn true_robot_reaches_compensated_targets_within_the_model_accuracy() {
    let s = load(
        "nongeometric_robot",
        Some("nongeometric/fanuc_compliance_gear.toml"),
    );
    let robot = identified(&s);
    let opts = CompensatorOptions::default();
    let (comp, _) = Compensator::train(&robot, &s.training, &opts, &|_, _| {}).unwrap();
    let mut pw = PredictWorkspace::default();
    let (model_p, model_r) = model_errors(&s, &mut |q| comp.predict(q, &mut pw));
    let (rigid_p, rigid_r) = model_errors(&s, &mut |q| tool_pose(&robot, q));
    // Without compensation: the desired poses given straight to the nominal controller.
    let mut pw = PredictWorkspace::default();
    let mut comp_pose = |q: &[f64]| comp.predict(q, &mut pw);
    let mut nominal_pose = |q: &[f64]| tool_pose(&s.nominal, q);
    let mut rigid_pose = |q: &[f64]| tool_pose(&robot, q);
    let (nominal_p, _) = true_errors(
        &s,
        CalibratedModel::identified(&s.nominal),
        &mut nominal_pose,
        true,
        false,
    );
    let (got_p, got_r) = true_errors(
        &s,
        CalibratedModel::compensated(&comp),
        &mut comp_pose,
        true,
        false,
    );
    let (rigid_got_p, rigid_got_r) = true_errors(
        &s,
        CalibratedModel::identified(&robot),
        &mut rigid_pose,
        true,
        false,
    );
    println!(
        "nominal {nominal_p:.4} mm; rigid model {rigid_p:.4} -> true {rigid_got_p:.4} mm; \
         compensated model {model_p:.4} -> true {got_p:.4} mm, {model_r:.2e} -> {got_r:.2e} rad"
    );
    for (got, model, what) in [
        (got_p, model_p, "compensated position"),
        (got_r, model_r, "compensated orientation"),
        (rigid_got_p, rigid_p, "rigid position"),
        (rigid_got_r, rigid_r, "rigid orientation"),
    ] {
        assert!(
            got <= 1.1 * model,
            "{what}: true robot {got} vs model {model}"
        );
    }
    assert!(got_p * 20.0 < nominal_p, "{got_p} vs nominal {nominal_p}");
    assert!(got_p < rigid_got_p, "{got_p} vs rigid {rigid_got_p}");

    // Position-only targets keep the seed's orientation and reach the position as well.
    let (pos_p, _) = true_errors(
        &s,
        CalibratedModel::compensated(&comp),
        &mut comp_pose,
        true,
        true,
    );
    println!("position-only targets: true robot {pos_p:.4} mm");
    assert!(
        pos_p <= 1.1 * model_p,
        "position-only: {pos_p} vs model {model_p}"
    );
}

#[test]
fn geometric_deviations_are_compensated_to_the_noise_floor_without_seeds() {
    // Case D's robot has geometric deviations only: the full identification leaves ~0.03 mm.
    let s = load("case_d", None);
    let robot = identified(&s);
    let (model_p, _) = model_errors(&s, &mut |q| tool_pose(&robot, q));
    let (got_p, _) = true_errors(
        &s,
        CalibratedModel::identified(&robot),
        &mut |q| tool_pose(&robot, q),
        false,
        false,
    );
    println!(
        "Case D: identified model {model_p:.4} mm on the test truth; true robot at the commands {got_p:.4} mm"
    );
    assert!(
        got_p <= 1.1 * model_p && got_p < 0.05,
        "{got_p} vs model {model_p}"
    );
}

#[test]
fn a_ur_target_past_the_nominal_reach_is_unreachable_with_a_seed() {
    // A UR10 (the nominal its own calibration, a controller solving near the seed): targets
    // along x from the reach of the arm to its reach bound. The nominal's closed form has no
    // solution past 1300 mm here, and the solve from the seed stalls: unreachable, as `ik`
    // says it (from 1500 mm on, where no pulled pose gave a start either, they were
    // "not-converged"; a reviewer's).
    let ur10 = read_robot(root().join("datasets/robots/ur10.toml")).unwrap();
    let mut solver = FakeTargetSolver::new(&ur10, CalibratedModel::identified(&ur10)).unwrap();
    let seed: Vec<f64> = [0.0, -90.0, 90.0, -90.0, -90.0, 0.0_f64]
        .iter()
        .map(|d| d.to_radians())
        .collect();
    let at = |x: f64| Target::Pose(Pose::translation(x, 0.0, 127.3));
    assert!(solver.solve(&at(1300.0), Some(&seed)).is_ok());
    for x in [1400.0, 1450.0, 1500.0, 1543.0, 1600.0, 1690.0] {
        match solver.solve(&at(x), Some(&seed)) {
            Err(Failure::Unreachable(_)) => {}
            other => panic!("x {x} mm: {other:?}"),
        }
    }
}

#[test]
fn impossible_targets_are_failures_not_commands() {
    let s = load("case_d", None);
    let robot = identified(&s);
    let mut solver =
        FakeTargetSolver::new(&s.nominal, CalibratedModel::identified(&robot)).unwrap();
    let far = Pose::translation(1.0e5, 0.0, 0.0);
    assert!(matches!(
        solver.solve(&Target::Pose(far), None),
        Err(Failure::Unreachable(_))
    ));
    // A far target with a seed: refused before any solve, beyond the arm's reach bound
    // (it was a solve that did not converge).
    let seed = s.test_truth.rows[0].q.clone();
    match solver.solve(&Target::Pose(far), Some(&seed)) {
        Err(Failure::Unreachable(m)) => assert!(m.contains("the arm reaches at most"), "{m}"),
        other => panic!("{other:?}"),
    }
    // Just beyond the bound (within its margin): the calibrated model's IK from the seed
    // cannot reach it either, and the nominal closed form has no solution: unreachable, as
    // `ik` says (it was "not converged").
    let reach = robocal::kinematics::Reach::of(&robot);
    let near = Pose::translation(0.0, 0.0, 0.0);
    let mut just = near;
    just.translation.vector = reach.anchor + nalgebra::Vector3::x() * (1.05 * reach.bound_mm);
    match solver.solve(&Target::Pose(just), Some(&seed)) {
        Err(Failure::Unreachable(m)) => assert!(
            m.contains("its closed form has no solution") && m.contains("position error"),
            "{m}"
        ),
        other => panic!("{other:?}"),
    }
    let p = truth_pose(&s.test_truth.rows[0]).translation.vector;
    assert_eq!(
        solver.solve(&Target::Position(p), None).unwrap_err(),
        Failure::NoSeed
    );
    // A pose the calibrated model reaches only with joint 2 beyond its upper limit; the
    // seed is inside the limits on the same branch.
    let mut beyond = seed.clone();
    beyond[1] = s.nominal.joints()[1].limits_internal()[1] + 0.02;
    let mut inside = beyond.clone();
    inside[1] -= 0.04;
    let target = tool_pose(&robot, &beyond);
    assert_eq!(
        solver
            .solve(&Target::Pose(target), Some(&inside))
            .unwrap_err(),
        Failure::OutsideLimits(vec![1])
    );
    // The same pose moved back inside is solved.
    let target = tool_pose(&robot, &inside);
    assert!(solver.solve(&Target::Pose(target), Some(&inside)).is_ok());
}

/// `settings` fitted as they are, each network for 20 epochs: a quick compensator whose
/// network matters, for tests of how it is used.
fn quick_fixed(settings: &robocal::neural::compensator::Settings) -> CompensatorOptions {
    CompensatorOptions::fixed(
        settings,
        robocal::neural::train::TrainOptions {
            max_epochs: 20,
            ..Default::default()
        },
    )
}

#[test]
fn compensated_jacobian_matches_central_differences() {
    use robocal::kinematics::ToolModel;
    use robocal::neural::compensator::Form;
    let s = load(
        "nongeometric_robot",
        Some("nongeometric/fanuc_compliance_gear.toml"),
    );
    let mut positions = s.training.clone();
    for m in &mut positions.rows {
        m.rotation = None;
        m.sigma_rotation = None;
    }
    use robocal::neural::compensator::Network;
    use robocal::neural::compensator::Settings;
    use robocal::neural::encoding::Encoding;
    for (form, encoding, members, training, network) in [
        (Form::Joint, Encoding::Gravity, 1, &s.training, Network::Mlp),
        (Form::Joint, Encoding::SinCos, 2, &s.training, Network::Mlp),
        (Form::Pose, Encoding::Gravity, 2, &s.training, Network::Mlp),
        (Form::Pose, Encoding::Angles, 1, &positions, Network::Mlp),
        (Form::Pose, Encoding::Gravity, 2, &s.training, Network::Mix),
        (Form::Pose, Encoding::SinCos, 1, &positions, Network::Rbf),
    ] {
        let settings = Settings {
            network,
            rbf_start: None,
            form,
            encoding,
            hidden: 8,
            penalty: 0.1,
            members,
            refine: None,
            mlp_share: None,
        };
        let opts = quick_fixed(&settings);
        let (comp, _) = Compensator::train(&s.nominal, training, &opts, &|_, _| {}).unwrap();
        let mut model = CalibratedModel::compensated(&comp);
        let mut rigid = robocal::kinematics::Frames::new(&comp.robot);
        let mut jac_rigid = nalgebra::Matrix6xX::zeros(6);
        let mut jac = nalgebra::Matrix6xX::zeros(6);
        for m in s.test_truth.rows.iter().take(5) {
            model.jacobian(&m.q, &mut jac);
            // The network's part must be far above the tolerance below.
            robocal::kinematics::frames(&comp.robot, &m.q, &mut rigid);
            robocal::kinematics::joint_jacobian(&comp.robot, &rigid, &mut jac_rigid);
            let diff = (&jac - &jac_rigid).abs().max();
            assert!(
                diff > 1e-2,
                "{form:?}: the network changes the Jacobian by {diff}"
            );
            for c in 0..6 {
                let h = 1e-6;
                let (mut qp, mut qm) = (m.q.clone(), m.q.clone());
                qp[c] += h;
                qm[c] -= h;
                let (fp, fm) = (model.pose(&qp), model.pose(&qm));
                let dp = (fp.translation.vector - fm.translation.vector) / (2.0 * h);
                let dw = rotation_vector(&(fp.rotation * fm.rotation.inverse())) / (2.0 * h);
                for r in 0..3 {
                    // mm per rad (reach ~3000 mm) and rad per rad.
                    let (ep, er) = ((dp[r] - jac[(r, c)]).abs(), (dw[r] - jac[(3 + r, c)]).abs());
                    assert!(
                        ep < 1e-4 && er < 1e-7,
                        "{form:?} {encoding:?} {network:?} joint {c} row {r}: {ep} {er}"
                    );
                }
            }
        }
        // With two MLPs the shrinkage must act, or its derivative would go unchecked.
        if members == 2 && network == Network::Mlp {
            let mut unshrunk = comp.clone();
            unshrunk.shrink = None;
            let (mut w1, mut w2) = (PredictWorkspace::default(), PredictWorkspace::default());
            let acts = s.test_truth.rows.iter().take(5).any(|m| {
                let (a, b) = (
                    comp.correction(&m.q, &mut w1).to_vec(),
                    unshrunk.correction(&m.q, &mut w2).to_vec(),
                );
                a.iter()
                    .zip(&b)
                    .any(|(x, y)| (x - y).abs() > 1e-3 * y.abs().max(1e-3))
            });
            assert!(acts, "{form:?} {encoding:?}: the shrinkage does not act");
        }
        // The network must matter here, or the check above would only test the rigid model.
        let mut pw = PredictWorkspace::default();
        let q = &s.test_truth.rows[0].q;
        let moved = (comp.predict(q, &mut pw).translation.vector
            - tool_pose(&comp.robot, q).translation.vector)
            .norm();
        assert!(moved > 1e-3, "{form:?}: network output {moved} mm");
    }
}

/// The nominal UR10, its model identified (`full`) on Series B's README split, and the
/// split's validation rows.
fn series_b_identified() -> (Robot, Robot, MeasurementSet) {
    let nominal = common::ur10::robot();
    let (id, _, val) = common::ur10::series_b_split(&nominal);
    let options = Options {
        params: "full".into(),
        ..Default::default()
    };
    let robot = identify(&nominal, &id, &options).unwrap().robot;
    (nominal, robot, val)
}

/// A controller that runs the solution nearest the joints it is given (the UR10, of the UR
/// class) on its real tracker data: the model identified on Series B's README split; each
/// validation row's
/// measured pose a target, seeded with its measured joints moved by 2 deg. The solved joints
/// are the measured configuration to within what the model misses there (not another of
/// the arm's solutions), the calibrated model reaches the target at them, the command is
/// the nominal pose there, and no branch is claimed.
#[test]
fn ur10_targets_are_solved_nearest_their_seeds() {
    let (nominal, robot, val) = series_b_identified();
    let mut solver = FakeTargetSolver::new(&nominal, CalibratedModel::identified(&robot)).unwrap();
    assert!(
        solver
            .solves_near_seed()
            .is_some_and(|w| w.contains("UR-class"))
    );
    // The controller's view, solved here on its own (not by the closed form the solver
    // uses): the nominal model from the seed.
    let mut controller = IkSolver::new(
        CalibratedModel::identified(&nominal),
        IkStart::Seed("test".into()),
        IkOptions::default(),
    );
    let mut worst: f64 = 0.0;
    for m in val.rows.iter().take(100) {
        let target = truth_pose(m);
        let seed: Vec<f64> = m.q.iter().map(|q| q + 2f64.to_radians()).collect();
        let cmd = solver
            .solve(&Target::Pose(target), Some(&seed))
            .unwrap_or_else(|e| panic!("line {}: {e}", m.line));
        assert_eq!(cmd.branch, None);
        let reached = tool_pose(&robot, &cmd.q);
        let dp = (reached.translation.vector - target.translation.vector).norm();
        let dr = rotation_vector(&(reached.rotation * target.rotation.inverse())).norm();
        assert!(dp < 1e-5 && dr < 1e-8, "line {}: {dp} mm, {dr} rad", m.line);
        let fake = tool_pose(&nominal, &cmd.q);
        assert!((fake.translation.vector - cmd.fake.translation.vector).norm() < 1e-9);
        assert!(rotation_vector(&(fake.rotation * cmd.fake.rotation.inverse())).norm() < 1e-12);
        let back = controller
            .nearest(&cmd.fake, Some(&seed))
            .unwrap()
            .solution
            .q;
        for (a, b) in back.iter().zip(&cmd.q) {
            assert!(
                (a - b).abs() < 1e-6,
                "line {}: the controller's {a} against {b}",
                m.line
            );
        }
        for (a, b) in cmd.q.iter().zip(&m.q) {
            worst = worst.max((a - b).abs());
        }
    }
    // The model misses Series B's poses by 0.46 mm RMS, 2 mm at most: joint changes of a few
    // mrad at most; another solution of the arm lies tenths of a radian away or more.
    eprintln!(
        "solved joints at most {:.3} mrad from the measured ones",
        worst * 1e3
    );
    assert!(
        worst < 0.01,
        "solved joints {worst} rad from the measured ones"
    );
    // Without a seed nothing starts the solve; a position target takes the seed's
    // orientation.
    let m = &val.rows[0];
    let p = truth_pose(m).translation.vector;
    assert_eq!(
        solver
            .solve(&Target::Pose(truth_pose(m)), None)
            .unwrap_err(),
        Failure::NoSeedToSolveNear
    );
    let cmd = solver.solve(&Target::Position(p), Some(&m.q)).unwrap();
    let reached = tool_pose(&robot, &cmd.q);
    assert!((reached.translation.vector - p).norm() < 1e-5);
    let at_seed = tool_pose(&robot, &m.q).rotation;
    assert!(rotation_vector(&(reached.rotation * at_seed.inverse())).norm() < 1e-8);
    // A controller whose joint 1 may not reach the solution: outside its limits, no command.
    let q1 = cmd.q[0].to_degrees();
    let text = std::fs::read_to_string(common::root().join("datasets/robots/ur10.toml"))
        .unwrap()
        .replacen(
            "limits = [-360.0, 360.0]",
            &format!("limits = [{}, {}]", q1 + 1.0, q1 + 10.0),
            1,
        );
    let narrow = Robot::from_toml(&text).unwrap();
    let mut solver = FakeTargetSolver::new(&narrow, CalibratedModel::identified(&robot)).unwrap();
    assert_eq!(
        solver
            .solve(&Target::Pose(truth_pose(m)), Some(&m.q))
            .unwrap_err(),
        Failure::OutsideLimits(vec![0])
    );
}

/// A UR-class controller runs the solution nearest the joints it is given, whose solutions the
/// nominal closed form lists exactly: from seeds up to 90 deg off every joint, a command's joints
/// are the nominal's solution of the command nearest the seed (each of the closed form's
/// solutions moved by whole turns nearest the seed within the limits, here), with the model
/// identified on Series B's README split (its base in the tracker's frame, metres away).
/// The joints a UR-class controller runs for `fake` given `seed` (rad): the nominal closed
/// form's solution nearest the seed, each joint's whole turn within the limits nearest the
/// seed's.
fn controller_choice(
    closed: &ClosedFormIk,
    nominal: &Robot,
    fake: &Pose,
    seed: &[f64],
) -> [f64; 6] {
    let limits: Vec<[f64; 2]> = (nominal.joints().iter())
        .map(|j| j.limits_internal())
        .collect();
    let tau = std::f64::consts::TAU;
    let mut sols = Vec::new();
    closed.solve_unlimited(fake, &mut sols);
    (sols.iter())
        .filter_map(|s| {
            let mut c = [0.0; 6];
            for j in 0..6 {
                let [lo, hi] = limits[j];
                c[j] = (-3..=3)
                    .map(|k| s[j] + k as f64 * tau)
                    .filter(|v| (lo..=hi).contains(v))
                    .min_by(|a, b| (a - seed[j]).abs().total_cmp(&(b - seed[j]).abs()))?;
            }
            let d: f64 = c.iter().zip(seed).map(|(a, b)| (a - b).powi(2)).sum();
            Some((d, c))
        })
        .min_by(|a, b| a.0.total_cmp(&b.0))
        .unwrap()
        .1
}

#[test]
fn far_seeded_ur10_commands_are_the_nominal_solution_nearest_the_seed() {
    use rand::{Rng, SeedableRng};
    let (nominal, robot, _) = series_b_identified();
    let mut solver = FakeTargetSolver::new(&nominal, CalibratedModel::identified(&robot)).unwrap();
    let closed = ClosedFormIk::new(&nominal).unwrap();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(40);
    let mut solved = 0;
    for row in 0..300 {
        let q: Vec<f64> = (0..6).map(|_| rng.random_range(-3.0..3.0)).collect();
        let seed: Vec<f64> = q
            .iter()
            .map(|v| v + rng.random_range(-90f64..90.0).to_radians())
            .collect();
        let Ok(cmd) = solver.solve(&Target::Pose(tool_pose(&robot, &q)), Some(&seed)) else {
            continue;
        };
        solved += 1;
        let nearest = controller_choice(&closed, &nominal, &cmd.fake, &seed);
        for (a, b) in nearest.iter().zip(&cmd.q) {
            assert!(
                (a - b).abs() < 1e-6,
                "row {row}: the command's joints {:?}, the nominal's nearest the seed {nearest:?}",
                cmd.q
            );
        }
    }
    // Taught at the wrist singularity (q5 = 0, q6 free), seeded with the taught joints: the
    // command keeps them (before, 11 of 20 such rows failed and 6 moved 38-113 deg).
    for _ in 0..20 {
        let mut q: Vec<f64> = (0..6).map(|_| rng.random_range(-3.0..3.0)).collect();
        q[4] = 0.0;
        let Ok(cmd) = solver.solve(&Target::Pose(tool_pose(&robot, &q)), Some(&q)) else {
            panic!("{q:?} at the wrist singularity has no command");
        };
        for (a, b) in cmd.q.iter().zip(&q) {
            assert!(
                (a - b).abs() < 1e-6,
                "{q:?}: the command's joints {:?}",
                cmd.q
            );
        }
    }
    // Every one is solved (the solve from the seed alone, with the nominal's solutions
    // searched, left 18 unsolved); a few may fail by name near the elbow's or the shoulder's
    // singularity.
    eprintln!("{solved} of 300 far-seeded targets solved");
    assert!(solved >= 295, "{solved} of 300 solved");
}

/// Another robot's model given as the calibrated one is refused: the distances between the
/// flange positions at the same joints (which neither the measurement frame nor the tool
/// changes) differ by far more than a calibration moves them; the FANUC's own calibrations
/// pass, by millimetres, and so does the UR10 written in another convention.
#[test]
fn a_calibrated_model_of_another_robot_is_refused() {
    use robocal::kinematics::{GEOMETRY_GAP, arm_distance_gap};
    let s = load("nongeometric_robot", None);
    let calibrated = identified(&s);
    let (gap, scale) = arm_distance_gap(&s.nominal, &calibrated);
    assert!(gap < 10.0 && scale > 2000.0, "{gap} mm of {scale}");
    let (gap, _) = arm_distance_gap(&s.nominal, &s.truth);
    assert!(gap < 10.0, "{gap}");
    assert!(FakeTargetSolver::new(&s.nominal, CalibratedModel::identified(&calibrated)).is_ok());
    let robots = root().join("datasets/robots");
    let ur10 = read_robot(robots.join("ur10.toml")).unwrap();
    let hayati = read_robot(robots.join("ur10_mdh_hayati.toml")).unwrap();
    let (gap, scale) = arm_distance_gap(&ur10, &hayati);
    assert!(gap < 1e-6 && scale > 1000.0, "{gap} mm of {scale}");
    assert!(FakeTargetSolver::new(&ur10, CalibratedModel::identified(&hayati)).is_ok());
    // The FANUC with joint 6's offset moved from its row into the tool: the same poses, the
    // flange 235 mm elsewhere (its distances 402 mm off, over 10 % of the arm), the tool's
    // distances the same.
    let text = std::fs::read_to_string(robots.join("fanuc_r2000ib_210f.toml")).unwrap();
    let tool_at = text.find("[tool]").unwrap();
    let moved = format!(
        "{}[tool]\nconvention = \"transform\"\nx = 182.0\ny = 0.0\nz = -440.0\nrz = 0.0\n\
         ry = 180.0\nrx = 0.0\n",
        text[..tool_at].replacen("d = -235.0", "d = 0.0", 1)
    );
    let moved = robocal::model::file::parse_robot(&moved, Path::new("moved.toml")).unwrap();
    let q = [0.3, 0.2, -0.1, 0.5, 0.7, -0.4];
    let (a, b) = (tool_pose(&s.nominal, &q), tool_pose(&moved, &q));
    assert!((a.translation.vector - b.translation.vector).norm() < 1e-9);
    assert!(robocal::kinematics::another_arm(&s.nominal, &moved).is_none());
    assert!(FakeTargetSolver::new(&s.nominal, CalibratedModel::identified(&moved)).is_ok());
    let (gap, scale) = arm_distance_gap(&ur10, &calibrated);
    assert!(gap > GEOMETRY_GAP * scale, "{gap} mm of {scale}");
    let e = FakeTargetSolver::new(&ur10, CalibratedModel::identified(&calibrated))
        .err()
        .expect("refused")
        .to_string();
    assert!(e.contains("not a calibration of the nominal"), "{e}");
}

/// A calibrated base registered to a tracker's frame (metres and degrees from the nominal's,
/// as `identify` with registration writes it): the nominal closed form starts the solves in
/// that frame, so targets are solved without seeds. Every target was "unreachable: out of the
/// nominal model's reach" before (the closed form solved them in the nominal's frame).
#[test]
fn targets_in_a_registered_frame_are_solved_without_seeds() {
    let s = load("case_d", None);
    let identified = identified(&s);
    let p = |name: &str| identified.find_param(name).unwrap();
    let far = identified
        .with_params(&[
            (p("base.x"), identified.param(p("base.x")) + 3000.0),
            (p("base.y"), identified.param(p("base.y")) - 1200.0),
            (
                p("base.rz"),
                identified.param(p("base.rz")) + 30f64.to_radians(),
            ),
            (
                p("base.rx"),
                identified.param(p("base.rx")) + 2f64.to_radians(),
            ),
        ])
        .unwrap();
    let mut solver = FakeTargetSolver::new(&s.nominal, CalibratedModel::identified(&far)).unwrap();
    for m in s.test_truth.rows.iter().take(25) {
        let target = tool_pose(&far, &m.q);
        let c = solver.solve(&Target::Pose(target), None).unwrap();
        let reached = tool_pose(&far, &c.q);
        assert!(
            (reached.translation.vector - target.translation.vector).norm() < 1e-5,
            "line {}",
            m.line
        );
        let fake = tool_pose(&s.nominal, &c.q);
        assert!((fake.translation.vector - c.fake.translation.vector).norm() < 1e-9);
    }
    // `ik --robot far --nominal nominal`: the same starts.
    let start = IkStart::choose(&far, Some(&s.nominal)).unwrap();
    assert!(matches!(start, IkStart::Nominal(_)));
    let mut ik = IkSolver::new(
        CalibratedModel::identified(&far),
        start,
        IkOptions::default(),
    );
    for m in s.test_truth.rows.iter().take(25) {
        let target = tool_pose(&far, &m.q);
        let solved = ik.nearest(&target, None).unwrap();
        let reached = tool_pose(&far, &solved.solution.q);
        assert!((reached.translation.vector - target.translation.vector).norm() < 1e-5);
    }
}

/// Near the wrist singularity a calibrated joint-5 offset puts the seed's q5 on one side of
/// 0 and the nominal's view of the same pose on the other: the closed-form start on the
/// seed's branch is then the other wrist configuration, half a turn of q4 away. The seed
/// itself, an exact solution, starts the solve instead (it was "branch-changed").
#[test]
fn a_seed_next_to_the_wrist_singularity_is_its_own_command() {
    let s = load("case_d", None);
    let theta5 = s.nominal.find_param("theta5").unwrap();
    let calibrated = s
        .nominal
        .with_param(theta5, s.nominal.param(theta5) + 0.05f64.to_radians())
        .unwrap();
    let mut solver =
        FakeTargetSolver::new(&s.nominal, CalibratedModel::identified(&calibrated)).unwrap();
    for q5 in [-0.03, -0.01, -0.001, 0.02] {
        let seed: Vec<f64> = [10.0, 20.0, -10.0, 15.0, q5, 5.0]
            .iter()
            .map(|d: &f64| d.to_radians())
            .collect();
        let target = tool_pose(&calibrated, &seed);
        let c = solver
            .solve(&Target::Pose(target), Some(&seed))
            .unwrap_or_else(|f| panic!("q5 = {q5} deg: {f}"));
        let apart = robocal::kinematics::joint_distance(&c.q, &seed);
        assert!(apart < 1e-6, "q5 = {q5} deg: {apart} rad from the seed");
    }
    // At the singularity itself the branch is ambiguous, and that is the failure.
    let seed: Vec<f64> = [10.0f64, 20.0, -10.0, 15.0, 0.0, 5.0]
        .iter()
        .map(|d| d.to_radians())
        .collect();
    let target = tool_pose(&calibrated, &seed);
    assert!(solver.solve(&Target::Pose(target), Some(&seed)).is_err());
}

/// A straight wrist (q5 = 0), the calibrated model the nominal itself: every target comes
/// back at its seed joints, on the seed's branch. The closed form splits q4 + q6 as its
/// arithmetic falls there; the command must not (half of such targets were refused as a
/// branch change, the others moved the wrist by up to 240 deg).
#[test]
fn a_straight_wrist_is_commanded_at_its_seed() {
    let nominal = read_robot(root().join("datasets/robots/fanuc_r2000ib_210f.toml")).unwrap();
    // The nominal itself, and a calibration of joint 6's zero: both reach the same pose
    // whatever the split of q4 + q6 (a joint-5 offset does not: see the test above).
    let theta6 = nominal.find_param("theta6").unwrap();
    let turned =
        (nominal.with_param(theta6, nominal.param(theta6) + 0.05f64.to_radians())).unwrap();
    for calibrated in [&nominal, &turned] {
        straight_wrist_targets_at_their_seeds(&nominal, calibrated);
    }
}

/// [`a_straight_wrist_is_commanded_at_its_seed`] for one calibration of `nominal`.
fn straight_wrist_targets_at_their_seeds(nominal: &Robot, calibrated: &Robot) {
    let mut solver =
        FakeTargetSolver::new(nominal, CalibratedModel::identified(calibrated)).unwrap();
    let mut rng = <rand_chacha::ChaCha8Rng as rand::SeedableRng>::seed_from_u64(61);
    for _ in 0..60 {
        let mut q: Vec<f64> = (nominal.joints().iter())
            .map(|j| {
                let [lo, hi] = j.limits_internal();
                rand::Rng::random_range(&mut rng, 0.8 * lo..=0.8 * hi)
            })
            .collect();
        q[4] = 0.0;
        let target = tool_pose(calibrated, &q);
        let cmd = solver
            .solve(&Target::Pose(target), Some(&q))
            .unwrap_or_else(|e| panic!("{q:?}: {e}"));
        let gap = cmd
            .q
            .iter()
            .zip(&q)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        assert!(gap < 1e-6, "{gap} rad: {:?} for {q:?}", cmd.q);
        assert!(cmd.branch.is_some());
    }
}

/// Targets next to a calibrated UR10's fold whose command nearest the seed is not one the
/// controller runs get the next nearest that is (a reviewer's cases). There the calibrated
/// solution nearest the seed lies between the calibrated elbow's (or shoulder's) fold and the
/// nominal's: the controller, given the seed, runs the nominal's mirror of it, from which the
/// calibrated solve slides back, and the target read `controller-differs` although the
/// solution across the fold is a command the controller reproduces (as it was before the
/// solves from the reflections across a fold found the nearer one).
#[test]
fn a_target_whose_nearest_command_the_controller_would_not_run_takes_the_next() {
    use common::ur10::{ur10_calibrated, ur10_four_times};
    use robocal::kinematics::pose_from_file;
    let nominal = common::ur10::robot();
    // (robot, seed joints deg, target x, y, z mm, rz, ry, rx deg)
    let cases: [(Robot, [f64; 6], [f64; 6]); 3] = [
        (
            ur10_four_times(),
            [
                150.358562711,
                6.579103416,
                -0.147033264,
                68.272598314,
                -119.623899588,
                -72.700989973,
            ],
            [
                993.9181391808427,
                -412.4284549126782,
                57.41593371898839,
                168.94272237555333,
                24.001812646166286,
                -25.298257268875126,
            ],
        ),
        (
            ur10_four_times(),
            [
                74.556175750,
                -66.311756342,
                -0.396388873,
                88.639423992,
                -19.600954110,
                -129.080395284,
            ],
            [
                166.365987814474,
                -456.024690267061,
                1128.86707367263,
                -66.88801058033994,
                72.88617395288769,
                -70.97675181412934,
            ],
        ),
        (
            ur10_calibrated(),
            [
                47.956703494,
                95.152470753,
                -19.957050567,
                40.302305049,
                29.940060902,
                102.931934859,
            ],
            [
                201.06256445219984,
                -142.31141706605175,
                -1027.9909876244726,
                -137.81817109829768,
                36.81955585131267,
                -124.21147354494225,
            ],
        ),
    ];
    let closed = ClosedFormIk::new(&nominal).unwrap();
    for (robot, seed_deg, pose) in cases {
        let seed: Vec<f64> = seed_deg.iter().map(|d| d.to_radians()).collect();
        let target = pose_from_file(pose);
        let mut solver =
            FakeTargetSolver::new(&nominal, CalibratedModel::identified(&robot)).unwrap();
        let cmd = solver
            .solve(&Target::Pose(target), Some(&seed))
            .unwrap_or_else(|e| panic!("{seed_deg:?}: {e}"));
        // The calibrated robot reaches the target at the command's joints ...
        let reached = tool_pose(&robot, &cmd.q);
        assert!((reached.translation.vector - target.translation.vector).norm() < 1e-6);
        // ... and they are the nominal's solution of the command nearest the seed, which the
        // controller runs.
        let nearest = controller_choice(&closed, &nominal, &cmd.fake, &seed);
        for (a, b) in nearest.iter().zip(&cmd.q) {
            assert!(
                (a - b).abs() < 1e-6,
                "{seed_deg:?}: {nearest:?} {:?}",
                cmd.q
            );
        }
    }
    // Only the same configuration across a fold is taken: where the next solution the
    // controller would run is another configuration (here a shoulder flip 287 deg from the
    // seed, a reviewer's case, seeded 2.6 deg from the target's nearest solution), the row
    // stays a failure that asks for seed joints nearer the taught configuration.
    let robot = ur10_calibrated();
    let mut solver = FakeTargetSolver::new(&nominal, CalibratedModel::identified(&robot)).unwrap();
    let seed: Vec<f64> = [
        -14.595563312,
        9.742260180,
        0.930633017,
        128.323769558,
        82.570085157,
        15.039351833,
    ]
    .iter()
    .map(|d: &f64| d.to_radians())
    .collect();
    let target = pose_from_file([
        -1032.0585903520664,
        90.33496148556011,
        -68.40876484736911,
        -122.04515763814665,
        6.723936852933697,
        -131.8827692338515,
    ]);
    match solver.solve(&Target::Pose(target), Some(&seed)) {
        Err(Failure::ControllerDiffers(why)) => assert!(why.contains("nearer the taught"), "{why}"),
        other => panic!("{other:?}"),
    }
}

/// A robot on a linear track (a prismatic joint, then a six-axis arm): seven joints for six
/// pose coordinates, so every pose has a continuum of solutions, through which the nominal's
/// solve from the seed and the calibrated model's drift apart by nanometres. Its targets
/// were `controller-differs` for those nanometres (14 of 40 in a reviewer's run); now the
/// controller's joints hold where the calibrated model reaches the target there.
#[test]
fn a_redundant_robot_on_a_track_gets_its_commands() {
    use rand::{Rng, SeedableRng};
    let text = "name = \"arm on a track\"\n\
        [base]\nconvention = \"transform\"\nx = 200.0\ny = 100.0\nz = 300.0\nrz = 0.0\nry = 0.0\nrx = 0.0\n\
        [[joint]]\nconvention = \"dh\"\ntype = \"prismatic\"\ntheta = 90.0\nd = 0.0\na = 0.0\nalpha = -90.0\nlimits = [0.0, 3000.0]\n\
        [[joint]]\nconvention = \"dh\"\ntheta = 0.0\nd = 750.0\na = 350.0\nalpha = -90.0\nlimits = [-185.0, 185.0]\n\
        [[joint]]\nconvention = \"dh\"\ntheta = -90.0\nd = 0.0\na = 1250.0\nalpha = 0.0\nlimits = [-45.0, 85.0]\n\
        [[joint]]\nconvention = \"dh\"\ntheta = 0.0\nd = 0.0\na = -54.0\nalpha = -90.0\nlimits = [-120.0, 65.0]\n\
        [[joint]]\nconvention = \"dh\"\ntheta = 0.0\nd = 1500.0\na = 0.0\nalpha = 90.0\nlimits = [-350.0, 350.0]\n\
        [[joint]]\nconvention = \"dh\"\ntheta = 0.0\nd = 0.0\na = 0.0\nalpha = -90.0\nlimits = [-125.0, 125.0]\n\
        [[joint]]\nconvention = \"dh\"\ntheta = 0.0\nd = 303.0\na = 0.0\nalpha = 0.0\nlimits = [-350.0, 350.0]\n\
        [tool]\nconvention = \"transform\"\nx = 40.0\ny = -15.0\nz = 250.0\nrz = 0.0\nry = 20.0\nrx = 0.0\n";
    let nominal = robocal::model::file::parse_robot(text, Path::new("track.toml")).unwrap();
    let moved: Vec<_> = [
        ("a2", 0.8),
        ("alpha3", 1e-3),
        ("theta4", -2e-3),
        ("d5", 0.6),
        ("theta6", 1.5e-3),
        ("tool.x", -0.4),
    ]
    .iter()
    .map(|&(name, by)| {
        let id = nominal.find_param(name).unwrap();
        (id, nominal.param(id) + by)
    })
    .collect();
    let calibrated = nominal.with_params(&moved).unwrap();
    let mut solver =
        FakeTargetSolver::new(&nominal, CalibratedModel::identified(&calibrated)).unwrap();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(21);
    let mut frames = Frames::new(&calibrated);
    for k in 0..40 {
        let q: Vec<f64> = nominal
            .joints()
            .iter()
            .map(|j| {
                let [lo, hi] = j.limits_internal();
                let (lo, hi) = match j.joint_type {
                    robocal::model::JointType::Prismatic => (lo, hi),
                    robocal::model::JointType::Revolute => (lo.max(-2.5), hi.min(2.5)),
                };
                let m = 0.1 * (hi - lo);
                rng.random_range(lo + m..hi - m)
            })
            .collect();
        let target = tool_pose(&calibrated, &q);
        let seed: Vec<f64> = q
            .iter()
            .enumerate()
            .map(|(j, v)| v + if j == 0 { 2.0 } else { 0.01 })
            .collect();
        let c = solver
            .solve(&Target::Pose(target), Some(&seed))
            .unwrap_or_else(|f| panic!("target {k}: {f}"));
        robocal::kinematics::frames(&calibrated, &c.q, &mut frames);
        let dp = (frames.tool.translation.vector - target.translation.vector).norm();
        let dr =
            robocal::geometry::rotation::angle_between(&frames.tool.rotation, &target.rotation);
        assert!(dp < 1e-4 && dr < 1e-7, "target {k}: {dp} mm {dr} rad");
        let f = tool_pose(&nominal, &c.q);
        assert!((f.translation.vector - c.fake.translation.vector).norm() < 1e-9);
    }
}

/// A compensator whose inputs are the joint angles themselves (`--encoding angles`) tells q
/// and q + 2 pi apart. A solve converging at q4 = -180.2 deg, outside the FANUC's limits, was
/// moved a turn into them (179.8 deg) and written with the residual of -180.2, where the
/// compensator misses the target by 0.02 mm (a reviewer's run). Every command must now be
/// one at which the compensator reaches its target.
#[test]
fn a_compensator_with_angle_inputs_is_reached_at_its_commands() {
    use robocal::kinematics::ToolModel;
    use robocal::neural::compensator::{Form, Network, Settings};
    use robocal::neural::encoding::Encoding;
    let s = load(
        "nongeometric_robot",
        Some("nongeometric/fanuc_compliance_gear.toml"),
    );
    let settings = Settings {
        network: Network::Mlp,
        rbf_start: None,
        form: Form::Joint,
        encoding: Encoding::Angles,
        hidden: 8,
        penalty: 0.1,
        members: 1,
        refine: None,
        mlp_share: None,
    };
    let opts = quick_fixed(&settings);
    let calibrated = identified(&s);
    let (comp, _) = Compensator::train(&calibrated, &s.training, &opts, &|_, _| {}).unwrap();
    let mut model = CalibratedModel::compensated(&comp);
    let mut solver =
        FakeTargetSolver::new(&s.nominal, CalibratedModel::compensated(&comp)).unwrap();
    let (mut solved, mut moved) = (0, 0);
    for q4 in [
        179.0, 179.5, 179.8, 179.9, 179.95, 179.99, 179.999, -179.9, -179.99,
    ] {
        let q: Vec<f64> = [20.0, 10.0, -5.0, q4, -40.0, 0.0]
            .iter()
            .map(|d: &f64| d.to_radians())
            .collect();
        let target = model.pose(&q);
        // The rigid model alone at q is not the target: the network must matter here.
        let rigid = tool_pose(&comp.robot, &q);
        moved += usize::from((rigid.translation.vector - target.translation.vector).norm() > 1e-3);
        let Ok(c) = solver.solve(&Target::Pose(target), Some(&q)) else {
            continue;
        };
        solved += 1;
        let at = model.pose(&c.q);
        let dp = (at.translation.vector - target.translation.vector).norm();
        assert!(
            dp < 1e-5,
            "q4 = {q4} deg: the compensator misses by {dp} mm at {:?}",
            c.q
        );
    }
    assert_eq!(moved, 9);
    assert!(solved >= 7, "{solved} of 9 solved");
}

/// A nominal model with joint compliances (as `identify --params full,compliance` writes
/// them) is its own calibration: every target's command is the target, on the seed's
/// configuration. Its own closed form (the deflected arm's) returned no branch for any
/// configuration, and every target of the FANUC was branch-changed; the UR10's
/// controller-differs where the deflection was large.
#[test]
fn a_compliant_nominal_model_is_its_own_calibration() {
    for (file, compliance) in [
        (
            "datasets/nongeometric_robot/nominal_masses.toml",
            [0.0, 0.0566, 0.0766, 0.262, 0.527, 0.0],
        ),
        (
            "datasets/robots/ur10_published_masses.toml",
            [0.0, 20.0, 20.0, 20.0, 0.0, 0.0],
        ),
    ] {
        let nominal = read_robot(root().join(file))
            .unwrap()
            .with_compliance(Some(robocal::model::Compliance::from_file_units(
                &compliance,
            )))
            .unwrap();
        assert!(nominal.is_compliant(), "{file}");
        let mut solver =
            FakeTargetSolver::new(&nominal, CalibratedModel::identified(&nominal)).unwrap();
        let deg = |v: [f64; 6]| v.map(f64::to_radians);
        for q in [
            deg([10.0, 20.0, -10.0, 15.0, -50.0, 5.0]),
            deg([-30.0, -40.0, 40.0, -80.0, 70.0, 10.0]),
            deg([40.0, 10.0, 20.0, 30.0, -90.0, 30.0]),
        ] {
            let desired = tool_pose(&nominal, &q);
            let c = solver
                .solve(&Target::Pose(desired), Some(&q))
                .unwrap_or_else(|e| panic!("{file} {q:?}: {e:?}"));
            let moved = (c.fake.translation.vector - desired.translation.vector).norm();
            assert!(moved < 1e-6, "{file}: the command moved {moved} mm");
            let apart = (c.q.iter().zip(&q)).fold(0.0_f64, |m, (a, b)| m.max((a - b).abs()));
            assert!(apart < 1e-6, "{file}: {:?} against {q:?}", c.q);
        }
    }
}
