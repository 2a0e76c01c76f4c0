//! Kinematics speed: FK of one configuration, closed-form IK (all solutions) of one pose
//! (FANUC; the UR10's 8 before copies), numerical IK of one pose on a calibrated-like model
//! (no closed form), and every solution of a calibrated UR10's pose next to a straight elbow
//! (the `ik --all` strategy: starts carried from the nominal's closed form, then solved).

use criterion::{Criterion, criterion_group, criterion_main};
use robocal::kinematics::{
    ClosedFormIk, IkOptions, IkSolver, IkStart, IkTarget, IkWorkspace, RobotModel, solve_numeric,
    tool_pose,
};
use robocal::model::read_robot;
use std::hint::black_box;

fn benches(c: &mut Criterion) {
    let robot = read_robot(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/datasets/robots/fanuc_r2000ib_210f.toml"
    ))
    .unwrap();
    let q = [0.3, 0.2, -0.4, 1.0, 0.8, -0.6];
    let target = tool_pose(&robot, &q);

    c.bench_function("fk_one_configuration", |b| {
        b.iter(|| tool_pose(black_box(&robot), black_box(&q)))
    });

    let ik = ClosedFormIk::new(&robot).unwrap();
    let mut sols = Vec::with_capacity(64);
    c.bench_function("ik_closed_form_all_solutions", |b| {
        b.iter(|| {
            ik.solve(black_box(&target), &mut sols);
            sols.len()
        })
    });

    // The UR class: the UR10's 8 solutions of one pose, before copies (its +-360 deg limits
    // give each 64).
    let ur = read_robot(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/datasets/robots/ur10.toml"
    ))
    .unwrap();
    let ur_ik = ClosedFormIk::new(&ur).unwrap();
    let ur_target = tool_pose(&ur, &[0.3, -1.2, 1.1, -1.4, -1.0, 0.5]);
    let mut ur_sols = Vec::with_capacity(8);
    c.bench_function("ik_closed_form_ur10_eight_solutions", |b| {
        b.iter(|| {
            ur_ik.solve_branches(black_box(&ur_target), &mut ur_sols);
            ur_sols.len()
        })
    });

    // A calibrated UR10 (links millimetres longer, axes a tenth of a degree off parallel):
    // every solution of a pose with the elbow 3 deg from straight.
    let param = |name: &str| ur.find_param(name).unwrap();
    let calibrated = ur
        .with_params(&[
            (param("a2"), -614.97),
            (param("a3"), -573.41),
            (param("alpha2"), 0.1135_f64.to_radians()),
            (param("theta3"), 0.1658_f64.to_radians()),
            (param("alpha4"), 90.0973_f64.to_radians()),
        ])
        .unwrap();
    let start = IkStart::choose(&calibrated, Some(&ur)).unwrap();
    let mut solver = IkSolver::new(RobotModel::new(&calibrated), start, IkOptions::default());
    let near_straight = tool_pose(&calibrated, &[0.3, -1.2, 0.05, -1.4, -1.0, 0.5]);
    // 4 solutions: the other wrist flips do not reach the pose (numerical solves from 2000
    // random starts find the same 4). `all` lists each with every whole-turn copy the limits
    // allow: 2^6 within the UR10's +-360 deg.
    let every = solver.all(&near_straight, None).unwrap();
    let mut distinct: Vec<Vec<f64>> = Vec::new();
    for q in &every {
        let wrapped: Vec<f64> = q
            .iter()
            .map(|v| (v + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU))
            .collect();
        let same = |d: &Vec<f64>| {
            d.iter().zip(&wrapped).all(|(a, b)| {
                let e = (a - b).abs();
                e.min(std::f64::consts::TAU - e) < 1e-9
            })
        };
        if !distinct.iter().any(same) {
            distinct.push(wrapped);
        }
    }
    assert_eq!((distinct.len(), every.len()), (4, 4 * 64));
    c.bench_function("ik_calibrated_ur10_all_solutions", |b| {
        b.iter(|| solver.all(black_box(&near_straight), None).unwrap().len())
    });

    // A bent model (Hayati beta3 = 1 mrad, a link 1 mm longer) has no closed form: refine the
    // nominal closed-form solution numerically, as for a calibrated robot.
    let bent = robot
        .with_params(&[
            (robot.find_param("beta3").unwrap(), 1e-3),
            (robot.find_param("a2").unwrap(), 313.0),
        ])
        .unwrap();
    let bent_target = tool_pose(&bent, &q);
    ik.solve_unlimited(&bent_target, &mut sols);
    let seed = sols
        .iter()
        .min_by(|a, b| {
            let d = |s: &[f64; 6]| s.iter().zip(&q).map(|(x, y)| (x - y).abs()).sum::<f64>();
            d(a).total_cmp(&d(b))
        })
        .copied()
        .unwrap();
    let mut ws = IkWorkspace::new(&bent);
    let opts = IkOptions::default();
    c.bench_function("ik_numeric_one_pose", |b| {
        b.iter(|| {
            solve_numeric(
                &bent,
                &IkTarget::Pose(bent_target),
                black_box(&seed),
                &opts,
                &mut ws,
            )
            .unwrap()
            .iterations
        })
    });
}

criterion_group! {
    name = kinematics;
    config = Criterion::default()
        .warm_up_time(std::time::Duration::from_millis(500))
        .measurement_time(std::time::Duration::from_secs(2));
    targets = benches
}
criterion_main!(kinematics);
