//! Target compensation speed: one fake target (nominal closed-form seed, numerical IK of the
//! calibrated model, limit and branch checks) on the non-geometric robot's test poses, for the
//! identified rigid model and for a compensator (joint form, gravity inputs, 32 hidden units,
//! 4 networks, full refined).

use criterion::{Criterion, criterion_group, criterion_main};
use robocal::compensation::{CalibratedModel, FakeTargetSolver};
use robocal::data::Target;
use robocal::data::read_canonical;
use robocal::identify::{Options, identify};
use robocal::kinematics::Pose;
use robocal::model::read_robot;
use robocal::neural::compensator::{Compensator, Form, Settings};
use robocal::neural::encoding::Encoding;
use std::hint::black_box;
use std::path::Path;

fn path(p: &str) -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(p)
}

fn compensation(c: &mut Criterion) {
    let nominal = read_robot(path("datasets/robots/fanuc_r2000ib_210f.toml")).unwrap();
    let rd = |p: &str| read_canonical(&path(p), &nominal).unwrap();
    let cal = rd("datasets/nongeometric_robot/calibration.csv");
    let training = rd("datasets/nongeometric_robot/training.csv");
    let test = rd("datasets/nongeometric_robot/test_truth.csv");
    let robot = identify(&nominal, &cal, &Options::default()).unwrap().robot;
    let settings = Settings {
        network: robocal::neural::compensator::Network::Mlp,
        rbf_start: None,
        form: Form::Joint,
        encoding: Encoding::Gravity,
        hidden: 32,
        penalty: 1.0,
        members: 4,
        refine: Some("full".into()),
        mlp_share: None,
    };
    let (comp, ..) = Compensator::fit(
        &robot,
        &training,
        &settings,
        Default::default(),
        &Default::default(),
    )
    .unwrap();
    let targets: Vec<(Pose, Vec<f64>)> = test
        .rows
        .iter()
        .take(50)
        .map(|m| {
            (
                Pose::from_parts(m.position.unwrap().into(), m.rotation.unwrap()),
                m.q.clone(),
            )
        })
        .collect();
    let mut g = c.benchmark_group("compensation");
    for (name, model) in [
        ("fake_target_rigid", CalibratedModel::identified(&robot)),
        (
            "fake_target_compensated",
            CalibratedModel::compensated(&comp),
        ),
    ] {
        let mut solver = FakeTargetSolver::new(&nominal, model).unwrap();
        let mut k = 0;
        g.bench_function(name, |b| {
            b.iter(|| {
                let (t, q) = &targets[k % targets.len()];
                k += 1;
                // A few targets near singularities fail; timing them is fair too.
                let _ = black_box(solver.solve(&Target::Pose(*t), Some(q)));
            })
        });
    }
    g.finish();
}

criterion_group!(benches, compensation);
criterion_main!(benches);
