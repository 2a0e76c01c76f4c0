//! Kinematics speed: FK of one configuration, closed-form IK (all solutions) of one pose
//! (FANUC; the UR10's 8 before copies), numerical IK of one pose on a calibrated-like model
//! (no closed form).

use criterion::{Criterion, criterion_group, criterion_main};
use robocal::kinematics::{
    ClosedFormIk, IkOptions, IkTarget, IkWorkspace, solve_numeric, tool_pose,
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
