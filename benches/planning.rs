//! Measurement planning speed: 30 units from a pool of 5,000 candidates on the FANUC
//! (`full`, pose and position measures, D-optimal; I-optimal for pose): the choice alone,
//! and the whole `plan` as the CLI runs it (candidate pool and validation
//! cloud drawn, Jacobian blocks and rank analysis, choice, the plan's and the random units'
//! predictions).

use criterion::{Criterion as Bench, criterion_group, criterion_main};
use robocal::identify::identifiability::RANK_TOL;
use robocal::identify::problem::{Measure, Sigmas};
use robocal::model::read_robot;
use robocal::plan::{Constraints, Criterion, Design, choose, pool, predict};
use robocal::sim::Region;
use std::hint::black_box;

fn planning(c: &mut Bench) {
    let robot = read_robot(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/datasets/robots/fanuc_r2000ib_210f.toml"
    ))
    .unwrap();
    let region = Region::limits(&robot);
    let free = Constraints::default();
    let cloud = pool::draw(&robot, &region, &free, 300, 1, 2)
        .unwrap()
        .into_configurations();
    for (name, measure, criterion) in [
        ("pose_d", Measure::Pose, Criterion::D),
        ("position_d", Measure::Position, Criterion::D),
        ("pose_i", Measure::Pose, Criterion::I),
    ] {
        let candidates = pool::draw(&robot, &region, &free, 5000, 1, 1).unwrap();
        let design = Design::new(
            &robot,
            "full",
            measure,
            Sigmas::default(),
            &candidates,
            cloud.clone(),
            RANK_TOL,
        )
        .unwrap();
        c.bench_function(&format!("plan_30_of_5000_{name}_choice"), |b| {
            b.iter(|| {
                choose(black_box(&design), 30, criterion, &[])
                    .unwrap()
                    .value
            })
        });
    }
    c.bench_function("plan_30_of_5000_pose_d_whole", |b| {
        b.iter(|| {
            let candidates = pool::draw(&robot, &region, &free, 5000, 1, 1).unwrap();
            let cloud = pool::draw(&robot, &region, &free, 300, 1, 2)
                .unwrap()
                .into_configurations();
            let design = Design::new(
                &robot,
                "full",
                Measure::Pose,
                Sigmas::default(),
                &candidates,
                cloud,
                RANK_TOL,
            )
            .unwrap();
            let chosen = choose(&design, 30, Criterion::D, &[]).unwrap();
            let random: Vec<usize> = (0..30).collect();
            let planned = predict(&design, &chosen.units, 0)
                .unwrap()
                .position_mm
                .unwrap()
                .mean;
            planned
                + predict(&design, &random, 0)
                    .unwrap()
                    .position_mm
                    .unwrap()
                    .mean
        })
    });
}

criterion_group! {
    name = benches;
    config = Bench::default()
        .sample_size(10)
        .warm_up_time(std::time::Duration::from_millis(500))
        .measurement_time(std::time::Duration::from_secs(3));
    targets = planning
}
criterion_main!(benches);
