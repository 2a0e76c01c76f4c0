//! Neural compensator speed: the default `robocal train` (cross-validated model selection,
//! then the chosen ensemble fitted) on Case D's 150 training poses and on a pool of 2000 real
//! UR10 poses (Series A), one phase-1 epoch (burn autodiff + SGD momentum), one evaluation of
//! the projected L-BFGS objective, and one compensated-pose prediction.

use criterion::{Criterion, criterion_group, criterion_main};
use robocal::data::measurement::split;
use robocal::data::{Profile, read_canonical, read_measurements};
use robocal::identify::{Options, identify};
use robocal::model::read_robot;
use robocal::neural::batch::Batch;
use robocal::neural::compensator::{Compensator, CompensatorOptions, Form, Settings};
use robocal::neural::encoding::Encoding;
use robocal::neural::net::train_momentum;
use robocal::neural::predict::PredictWorkspace;
use robocal::neural::targets::build;
use robocal::neural::train::initial_weights;
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
    let full = |p: &str| Options {
        params: p.into(),
        ..Default::default()
    };
    let model = identify(&nominal, &cal, &full("offsets")).unwrap().robot;
    let p = build(&model, &set, Form::Pose, Encoding::Gravity).unwrap();
    let outputs = p.output_norm.len();
    let start = initial_weights(p.samples.x[0].len(), 32, outputs, 1);
    let mut g = c.benchmark_group("neural");
    g.bench_function("phase1_epoch_150_samples", |b| {
        b.iter(|| train_momentum(&start, black_box(&p.samples), 0.1, 1, |_, _, _| true).unwrap())
    });
    let mut batch = Batch::new(&p.samples, &start);
    let mut grad = nalgebra::DVector::zeros(start.len());
    g.bench_function("projected_objective_150_samples", |b| {
        b.iter(|| {
            let mut w = start.clone();
            batch.objective_projected(&mut w, 0.1, &mut grad)
        })
    });
    let opts = CompensatorOptions::default();
    g.sample_size(10).measurement_time(Duration::from_secs(10));
    g.bench_function("train_default_150_poses", |b| {
        b.iter(|| Compensator::train(&model, black_box(&set), &opts, &|_, _| {}).unwrap())
    });
    let ur = read_robot(path("datasets/robots/ur10.toml")).unwrap();
    let profile = Profile::read(path("datasets/profiles/ipa_ur10.toml")).unwrap();
    let (a, _) = read_measurements(
        &path("datasets/ipa-ur10/Series_A/measurements_grid.csv"),
        &ur,
        &profile,
        &Default::default(),
    )
    .unwrap();
    let (pool, _) = split(&a, 2000.0 / a.rows.len() as f64, 21);
    let (id, _) = split(&pool, 0.25, 23);
    let ur_model = identify(&ur, &id, &full("full")).unwrap().robot;
    g.measurement_time(Duration::from_secs(60));
    g.bench_function("train_default_2000_poses", |b| {
        b.iter(|| Compensator::train(&ur_model, black_box(&pool), &opts, &|_, _| {}).unwrap())
    });
    g.finish();
    // A real ensemble (cross-validation may keep the model alone for some sets).
    let settings = Settings {
        network: robocal::neural::compensator::Network::Mlp,
        rbf_start: None,
        form: Form::Pose,
        encoding: Encoding::Gravity,
        hidden: 32,
        penalty: 1.0,
        members: 4,
        refine: None,
        mlp_share: None,
    };
    let (comp, _) = Compensator::fit(
        &model,
        &set,
        &settings,
        Default::default(),
        &Default::default(),
    )
    .unwrap();
    let mut ws = PredictWorkspace::default();
    let q = [0.05, 0.15, -0.05, 0.1, 0.7, 0.2];
    c.bench_function("compensated_pose_4_networks_gravity_inputs", |b| {
        b.iter(|| comp.predict(black_box(&q), &mut ws))
    });
    // The same MLPs mixed with an RBF network of one unit per training row (150).
    let mix = Settings {
        network: robocal::neural::compensator::Network::Mix,
        ..settings
    };
    let (comp, _) =
        Compensator::fit(&model, &set, &mix, Default::default(), &Default::default()).unwrap();
    assert!(comp.rbf.is_some());
    c.bench_function("compensated_pose_4_networks_and_rbf_150_units", |b| {
        b.iter(|| comp.predict(black_box(&q), &mut ws))
    });
}

criterion_group!(benches, neural);
criterion_main!(benches);
