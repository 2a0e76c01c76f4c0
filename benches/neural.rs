//! Neural compensator speed on Case D's 150 training poses (joint form, 20 hidden units,
//! offsets refined with the network, the defaults of `robocal train` and `case-d`): one
//! phase-1 epoch (burn autodiff + SGD momentum), one Levenberg-Marquardt iteration, a whole
//! training to its stopping rule, and one compensated-pose prediction.

use criterion::{Criterion, criterion_group, criterion_main};
use robocal::data::read_canonical;
use robocal::identify::{Options, identify};
use robocal::model::read_robot;
use robocal::neural::compensator::{Compensator, CompensatorOptions, PredictWorkspace, prepare};
use robocal::neural::net::train_momentum;
use robocal::neural::train::{TrainOptions, initial_weights, train};
use std::hint::black_box;
use std::path::Path;
use std::time::Duration;

fn path(p: &str) -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(p)
}

fn neural(c: &mut Criterion) {
    let nominal = read_robot(path("datasets/robots/fanuc_r2000ib_210f.toml")).unwrap();
    let rd = |p: &str| read_canonical(&path(p), &nominal).unwrap();
    let cal = rd("datasets/case_d/calibration.csv");
    let set = rd("datasets/case_d/training.csv");
    let model = identify(
        &nominal,
        &cal,
        &Options {
            params: "offsets".into(),
            ..Default::default()
        },
    )
    .unwrap()
    .robot;
    let opts = CompensatorOptions {
        refine: Some("offsets".into()),
        ..Default::default()
    };
    let p = prepare(&model, &set, &opts).unwrap();
    let outputs = p.output_norm.min.len();
    let start = initial_weights(p.samples.x[0].len(), 20, outputs, 1);
    let mut g = c.benchmark_group("neural");
    g.bench_function("phase1_epoch_150_samples", |b| {
        b.iter(|| train_momentum(&start, black_box(&p.samples), 1, |_, _, _| true).unwrap())
    });
    let one_lm = TrainOptions {
        momentum_epochs: 0,
        max_epochs: 1,
        validation_fraction: 0.0,
        ..Default::default()
    };
    g.bench_function("lm_iteration_150_samples", |b| {
        b.iter(|| train(black_box(&p.samples), outputs, &one_lm).unwrap())
    });
    g.sample_size(10).measurement_time(Duration::from_secs(10));
    g.bench_function("whole_training_150_samples", |b| {
        b.iter(|| Compensator::train(&model, black_box(&set), &opts).unwrap())
    });
    g.finish();
    let (comp, _) = Compensator::train(&model, &set, &opts).unwrap();
    let mut ws = PredictWorkspace::default();
    let q = [0.05, 0.15, -0.05, 0.1, 0.7, 0.2];
    c.bench_function("compensated_pose", |b| {
        b.iter(|| comp.predict(black_box(&q), &mut ws))
    });
}

criterion_group!(benches, neural);
criterion_main!(benches);
