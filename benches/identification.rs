//! Identification speed: the analytic Jacobian (one and 1,000 configurations, every
//! parameter), LM identification of Case D's 30 poses (`full` and `offsets`), of the
//! non-geometric robot's 30 poses and of the real UR10 Series A (11,911 poses), geometry alone
//! and with the joint compliances (known masses, and mass-free); the check for readings
//! logged with other joints on Series A.

use criterion::{Criterion, criterion_group, criterion_main};
use nalgebra::Matrix6xX;
use robocal::data::shared_readings::shared_readings;
use robocal::data::{Profile, read_measurements};
use robocal::identify::{Options, identify, parameter_jacobian};
use robocal::kinematics::{Frames, frames};
use robocal::model::read_robot;
use std::hint::black_box;
use std::path::Path;

fn path(p: &str) -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(p)
}

fn jacobian(c: &mut Criterion) {
    let robot = read_robot(path("datasets/robots/fanuc_r2000ib_210f.toml")).unwrap();
    // Every geometric parameter (32; the mass-free compliance coefficients are not in it).
    let cols = robocal::identify::select::select(&robot, "full").unwrap();
    assert_eq!(cols.len(), 32);
    let mut ws = Frames::new(&robot);
    let mut jac = Matrix6xX::zeros(cols.len());
    let q = [0.3, 0.2, -0.4, 1.0, 0.8, -0.6];
    c.bench_function("jacobian_full_one_configuration", |b| {
        b.iter(|| {
            frames(&robot, black_box(&q), &mut ws);
            parameter_jacobian(&robot, &ws, &cols, &mut jac);
            jac[(0, 0)]
        })
    });
    let configs: Vec<[f64; 6]> = (0..1000)
        .map(|k| {
            let t = k as f64 * 0.001;
            [t, 0.2 - t * 0.3, -0.4 + t * 0.5, 1.0 - t, 0.8, -0.6 + t]
        })
        .collect();
    c.bench_function("jacobian_full_1000_configurations", |b| {
        b.iter(|| {
            let mut s = 0.0;
            for q in &configs {
                frames(&robot, q, &mut ws);
                parameter_jacobian(&robot, &ws, &cols, &mut jac);
                s += jac[(0, 0)];
            }
            s
        })
    });
    // The non-geometric robot's nominal with its masses and the simulator's compliances
    // (c2..c5 non-zero): FK through the deflected chain and every geometric column with its
    // compliance term, plus the columns of c1..c6 (38 in all).
    let masses = read_robot(path("datasets/nongeometric_robot/nominal_masses.toml")).unwrap();
    let compliant = masses
        .with_compliance(Some(robocal::model::Compliance::from_file_units(&[
            0.0, 0.05, 0.08, 0.3, 0.5, 0.0,
        ])))
        .unwrap();
    let cols = robocal::identify::select::select(&compliant, "full,compliance").unwrap();
    assert_eq!(cols.len(), 38);
    let mut ws = Frames::new(&compliant);
    let mut jac = Matrix6xX::zeros(cols.len());
    c.bench_function("jacobian_full_compliance_one_configuration", |b| {
        b.iter(|| {
            frames(&compliant, black_box(&q), &mut ws);
            parameter_jacobian(&compliant, &ws, &cols, &mut jac);
            jac[(0, 0)]
        })
    });
}

fn case_d(c: &mut Criterion) {
    let robot = read_robot(path("datasets/robots/fanuc_r2000ib_210f.toml")).unwrap();
    let (set, _) = read_measurements(
        &path("datasets/case_d/calibration.csv"),
        &robot,
        &Profile::default(),
        &Default::default(),
    )
    .unwrap();
    for params in ["full", "offsets"] {
        let opts = Options {
            params: params.into(),
            ..Default::default()
        };
        c.bench_function(&format!("identify_case_d_30_poses_{params}"), |b| {
            b.iter(|| {
                identify(&robot, black_box(&set), &opts)
                    .unwrap()
                    .solution
                    .iterations
            })
        });
    }
}

/// The non-geometric robot's 30 calibration poses: `full`, and `full,compliance` with the
/// simulator's masses and without masses.
fn compliance_30(c: &mut Criterion) {
    let nominal = read_robot(path("datasets/robots/fanuc_r2000ib_210f.toml")).unwrap();
    let masses = read_robot(path("datasets/nongeometric_robot/nominal_masses.toml")).unwrap();
    let (set, _) = read_measurements(
        &path("datasets/nongeometric_robot/calibration.csv"),
        &nominal,
        &Profile::default(),
        &Default::default(),
    )
    .unwrap();
    for (name, robot, params) in [
        ("full", &nominal, "full"),
        ("full_compliance_masses", &masses, "full,compliance"),
        ("full_compliance_mass_free", &nominal, "full,compliance"),
    ] {
        let opts = Options {
            params: params.into(),
            ..Default::default()
        };
        c.bench_function(&format!("identify_nongeometric_30_poses_{name}"), |b| {
            b.iter(|| {
                identify(robot, black_box(&set), &opts)
                    .unwrap()
                    .solution
                    .iterations
            })
        });
    }
}

fn ur10_series_a(c: &mut Criterion) {
    let robot = read_robot(path("datasets/robots/ur10.toml")).unwrap();
    let profile = Profile::read(path("datasets/profiles/ipa_ur10.toml")).unwrap();
    let (set, _) = read_measurements(
        &path("datasets/ipa-ur10/Series_A/measurements_grid.csv"),
        &robot,
        &profile,
        &Default::default(),
    )
    .unwrap();
    let published = read_robot(path("datasets/robots/ur10_published_masses.toml")).unwrap();
    // The check for readings logged with other joints, which `identify` runs after the fit,
    // under the model identified on the whole series.
    let full = identify(
        &robot,
        &set,
        &Options {
            params: "full".into(),
            ..Default::default()
        },
    )
    .unwrap()
    .robot;
    c.bench_function("shared_readings_ur10_series_a_11911_poses", |b| {
        b.iter(|| shared_readings(&full, black_box(&set)).len())
    });
    let mut g = c.benchmark_group("slow");
    g.sample_size(10);
    for (name, robot, params) in [
        ("full", &robot, "full"),
        ("full_compliance_masses", &published, "full,compliance"),
        ("full_compliance_mass_free", &robot, "full,compliance"),
    ] {
        let opts = Options {
            params: params.into(),
            ..Default::default()
        };
        g.bench_function(format!("identify_ur10_series_a_11911_poses_{name}"), |b| {
            b.iter(|| {
                identify(robot, black_box(&set), &opts)
                    .unwrap()
                    .solution
                    .iterations
            })
        });
    }
    g.finish();
}

criterion_group! {
    name = identification;
    config = Criterion::default()
        .warm_up_time(std::time::Duration::from_millis(500))
        .measurement_time(std::time::Duration::from_secs(3));
    targets = jacobian, case_d, compliance_30, ur10_series_a
}
criterion_main!(identification);
