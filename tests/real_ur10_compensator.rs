//! The compensator on real laser-tracker data (UR10 Series B, shipped) against the plain MLP
//! baseline of issue 11, on a fixed seeded split: 1000 poses form the training pool, 500 of
//! them identify the model (`full`), the other 495 validate.
//!
//! The baseline (test code only, not the product): inputs the six joint angles
//! (standardised); target the 6-D residual of the identified model (mm, mrad) in the robot's
//! base frame (standardised); one logistic hidden layer of 16 or 32 units; L2 weight penalty
//! alpha in {1e-3, 1e-1} (scikit-learn's convention); L-BFGS; size and penalty chosen on an
//! inner 80/20 split; correction p += R_b dp, R = exp(R_b dr) R.

mod common;

use common::ur10::{SERIES_A, SERIES_B, series, series_b_split};
use robocal::data::MeasurementSet;
use robocal::data::measurement::split;
use robocal::evaluate::{ErrorStats, row_errors, summarize};
use robocal::identify::{Measure, Options, identify};
use robocal::model::Robot;
use robocal::neural::compensator::{Compensator, CompensatorOptions, Form};
use robocal::neural::domain::Domain;
use robocal::neural::encoding::Encoding;
use robocal::neural::lbfgs::{Next, minimize};
use robocal::neural::predict::PredictWorkspace;
use robocal::neural::repeats::SAME_CONFIGURATION;
use robocal::neural::samples::objective;
use robocal::neural::targets::build;
use robocal::neural::train::initial_weights;
use std::time::Instant;

fn identified(robot: &Robot, id: &MeasurementSet) -> Robot {
    identify(
        robot,
        id,
        &Options {
            params: "full".into(),
            ..Default::default()
        },
    )
    .unwrap()
    .robot
}

/// The rows of a training pool that identify its model: the pool itself up to 500 rows, else
/// 500 of them drawn by `seed`.
fn identification_rows(pool: &MeasurementSet, seed: u64) -> MeasurementSet {
    if pool.rows.len() <= 500 {
        pool.clone()
    } else {
        split(pool, 500.0 / pool.rows.len() as f64, seed).0
    }
}

/// `series_pools`' Series B split `seed` of the whole series `set`: a pool of `pool_n` rows
/// (drawn by seed 100 + `seed`), the rest to validate, and the model identified (`full`) on
/// [`identification_rows`] of the pool (seed 200 + `seed`).
fn series_b_pool(
    ur: &Robot,
    set: &MeasurementSet,
    pool_n: f64,
    seed: u64,
) -> (MeasurementSet, MeasurementSet, Robot) {
    let (pool, val) = split(set, pool_n / set.rows.len() as f64, 100 + seed);
    let model = identified(ur, &identification_rows(&pool, 200 + seed));
    (pool, val, model)
}

/// The baseline network for fixed size and scikit-learn penalty alpha, fitted on `set`.
fn baseline_fit(model: &Robot, set: &MeasurementSet, hidden: usize, alpha: f64) -> Compensator {
    let p = build(model, set, Form::Pose, Encoding::Angles).unwrap();
    let s = &p.samples;
    // Targets standardised per output, as a StandardScaler would.
    let mut s = s.clone();
    let outputs = s.rows();
    let mut out_norm = p.output_norm.clone();
    for o in 0..outputs {
        let n = s.len() as f64;
        let var = s.b.iter().map(|b| b[o] * b[o]).sum::<f64>() / n;
        let sd = var.sqrt().max(1e-12);
        s.b.iter_mut().for_each(|b| b[o] /= sd);
        out_norm.scale[o] *= sd;
    }
    // scikit-learn: loss = sum r^2 / (2 n o) + alpha |W|^2 / (2 n): lambda = alpha o here.
    let lambda = alpha * outputs as f64;
    let w0 = initial_weights(s.x[0].len(), hidden, outputs, 7);
    let shape = w0.clone();
    let mut g = nalgebra::DVector::zeros(w0.len());
    let (v, _, _) = minimize(
        w0.to_vector(),
        10,
        1000,
        1e-9,
        |v, grad| {
            let f = objective(&s, &shape.from_vector(v), lambda, &mut g);
            grad.copy_from(&g);
            f
        },
        |_, _, _| Next::Continue,
    );
    // No training domain: the baseline has no fade.
    let domain = Domain::fit(model, Encoding::Angles, &p.input_norm, &[]);
    Compensator {
        form: Form::Pose,
        encoding: Encoding::Angles,
        robot: model.clone(),
        members: vec![shape.from_vector(&v)],
        rbf: None,
        mlp_share: 0.5,
        shrink: None,
        input_norm: p.input_norm,
        output_norm: out_norm,
        domain,
        model_refined: Some(false),
    }
}

fn position_rms(c: &Compensator, set: &MeasurementSet) -> f64 {
    let mut ws = PredictWorkspace::default();
    let e = row_errors(set, Measure::Pose, |q| c.predict(q, &mut ws)).unwrap();
    summarize(&e).position_mm.unwrap().rms
}

/// The baseline: size and penalty chosen on an inner 80/20 split, then refitted on all rows.
fn baseline(model: &Robot, pool: &MeasurementSet) -> Compensator {
    let (inner_train, inner_val) = split(pool, 0.8, 5);
    let mut best = (f64::INFINITY, 16, 1e-3);
    for hidden in [16, 32] {
        for alpha in [1e-3, 1e-1] {
            let c = baseline_fit(model, &inner_train, hidden, alpha);
            let rms = position_rms(&c, &inner_val);
            if rms < best.0 {
                best = (rms, hidden, alpha);
            }
        }
    }
    baseline_fit(model, pool, best.1, best.2)
}

fn stats(c: &Compensator, set: &MeasurementSet) -> ErrorStats {
    let mut ws = PredictWorkspace::default();
    summarize(&row_errors(set, Measure::Pose, |q| c.predict(q, &mut ws)).unwrap())
}

fn line(name: &str, s: &ErrorStats, seconds: f64) -> String {
    let p = s.position_mm.unwrap();
    let r = s.orientation_deg.unwrap();
    format!(
        "| {name} | {:.4} | {:.4} | {:.4} | {:.4} | {:.4} | {seconds:.1} |",
        p.mean, p.rms, p.p95, p.max, r.mean
    )
}

/// Where the tracker stands is not a property of the robot (issue 11: with a tracker 3.7 m
/// away, the linearised refinement of then moved a base rotation against a constant joint
/// correction by degrees, 16 mm held out). Series B's readings moved into a frame 10.4 m away
/// and turned by (170, 55, -120) deg give the same identified model (base aside: the
/// registration takes the frame), and the same compensator with its refinement forced
/// (`full`, refined exactly on the training rows): the joints' refined parameters agree to
/// 1e-3 (mm, deg), the held-out RMS to 1 %, and the refined compensator stays far below the
/// model. The tracker's per-axis sigmas are left out of both sets: turned into another frame
/// they would no longer be per axis.
#[test]
#[cfg_attr(
    debug_assertions,
    ignore = "trains RBF networks and MLPs: release builds only"
)]
fn moving_the_tracker_ten_metres_away_changes_nothing() {
    use nalgebra::{Rotation3, Vector3};
    use robocal::model::Slot;
    use robocal::neural::compensator::Network;
    use robocal::neural::settings::Settings;
    let ur = common::ur10::robot();
    let mut set = series(&ur, SERIES_B);
    for row in &mut set.rows {
        row.sigma_position = None;
        row.sigma_rotation = None;
    }
    let d = std::f64::consts::PI / 180.0;
    let turn = Rotation3::from_euler_angles(170.0 * d, 55.0 * d, -120.0 * d);
    let shift = Vector3::new(-8000.0, 6000.0, -3000.0);
    let mut far = set.clone();
    for row in &mut far.rows {
        row.position = row.position.map(|p| turn * p + shift);
        row.rotation = row.rotation.map(|r| turn * r);
    }
    let settings = Settings {
        network: Network::Mix,
        form: Form::Pose,
        encoding: Encoding::Gravity,
        hidden: 16,
        penalty: 3.0,
        members: 2,
        rbf_start: Some(0),
        refine: Some("full".into()),
        mlp_share: Some(0.1),
    };
    let mut runs = Vec::new();
    for s in [&set, &far] {
        let (pool, rest) = split(s, 400.0 / s.rows.len() as f64, 100);
        let val = split(&rest, 300.0 / rest.rows.len() as f64, 5).0;
        let model = identified(&ur, &split(&pool, 0.5, 200).0);
        let (c, _) = Compensator::fit(
            &model,
            &pool,
            &settings,
            Default::default(),
            &Default::default(),
        )
        .unwrap();
        let model_rms = position_rms(
            &Compensator {
                members: Vec::new(),
                rbf: None,
                ..c.clone()
            },
            &val,
        );
        runs.push((model, c.clone(), model_rms, position_rms(&c, &val)));
    }
    let ((m0, c0, model0, rms0), (m1, c1, model1, rms1)) = (&runs[0], &runs[1]);
    eprintln!("as measured: refined model {model0:.5}, with the networks {rms0:.5} mm");
    eprintln!("10.4 m away: refined model {model1:.5}, with the networks {rms1:.5} mm");
    for (a, b) in [(m0, m1), (&c0.robot, &c1.robot)] {
        for id in a
            .parameters()
            .into_iter()
            .filter(|id| id.slot != Slot::Base)
        {
            let (x, y) = (id.field.to_file(a.param(id)), id.field.to_file(b.param(id)));
            assert!((x - y).abs() < 1e-3, "{}: {x} vs {y}", id.name());
        }
    }
    let base = |r: &Robot| r.base().transform();
    let moved = nalgebra::IsometryMatrix3::from_parts(shift.into(), turn) * base(&c0.robot);
    let gap = moved.inverse() * base(&c1.robot);
    assert!(
        gap.translation.vector.norm() < 0.01 && gap.rotation.angle() < 1e-5,
        "{gap:?}"
    );
    assert!(
        (model0 - model1).abs() < 1e-4 * model0,
        "{model0} vs {model1}"
    );
    assert!((rms0 - rms1).abs() < 0.01 * rms0, "{rms0} vs {rms1}");
    assert!(*rms1 < 0.7 * model1, "{rms1} vs the model's {model1}");
}

/// A refinement that cross-validation of a few rows ranks first is kept only where it wins
/// by a margin and significantly row by row (`REFINEMENT_MARGIN`, `REFINEMENT_Z`): on 30 rows
/// of the README split's pool (28 parameters of `full`), its cross-validated lead (3.6 %, z
/// -0.4 with the tests' data) is no evidence, and the refined model raised the error on the
/// 495 held-out rows from 0.4557 to 0.8379 mm RMS. The compensator is the model as given.
/// A refinement forced on a model far off the rows (the nominal file, metres from the
/// tracker's frame: `train` warns of it) registers their frame first, as `identify` does.
/// Without, `full,compliance` on Series B ran its compliances to 30 mm of validation error
/// (a reviewer's run: the compensator 53.7 mm RMS, where the default gave 0.45 mm).
#[test]
fn a_forced_refinement_registers_a_model_far_off_the_rows() {
    use robocal::neural::compensator::{Form, Network, Settings};
    use robocal::neural::encoding::Encoding;
    let ur = common::ur10::robot();
    let (id, _, val) = series_b_split(&ur);
    let settings = Settings {
        network: Network::Mlp,
        rbf_start: None,
        form: Form::Joint,
        encoding: Encoding::Gravity,
        hidden: 16,
        penalty: 1.0,
        members: 0,
        refine: Some("full,compliance".into()),
        mlp_share: None,
    };
    let opts = CompensatorOptions::fixed(&settings, Default::default());
    let (c, report) = Compensator::train(&ur, &id, &opts, &|_, _| {}).unwrap();
    let rms = position_rms(&c, &val);
    assert!(rms < 0.6, "{rms} mm: {:?}", report.notes);
    assert!(
        report.notes.iter().any(|n| n.contains("registered first")),
        "{:?}",
        report.notes
    );
}

/// Rows cross-validation lists as outliers and the final fit leaves out may lie outside the
/// training domain, where the correction fades to the model's. A reviewer's 150 Series B rows
/// under the nominal UR10, 3.7 m off the tracker's frame, with an RBF network on the angles:
/// 29 rows (19 %) were left out, and the compensator missed its own training rows by 898 mm
/// RMS against a cross-validated 5.19 mm, exit 0 and no warning. Now a warning says so, and
/// a note that so many rows far out are a heavy tail.
#[test]
fn a_compensator_that_misses_its_training_rows_is_warned_of() {
    use robocal::neural::compensator::{Network, Refine};
    let ur = common::ur10::robot();
    let (rows, _) = split(&series(&ur, SERIES_B), 0.1, 3);
    let opts = |keep: bool| CompensatorOptions {
        network: Some(Network::Rbf),
        form: Some(Form::Pose),
        encoding: Some(Encoding::Angles),
        refine: Refine::Off,
        drop_outliers: !keep,
        ..Default::default()
    };
    let (c, report) = Compensator::train(&ur, &rows, &opts(false), &|_, _| {}).unwrap();
    let s = report.selection.as_ref().unwrap();
    let cv = s.candidates[s.chosen]
        .score
        .as_ref()
        .unwrap()
        .position_rms_mm;
    let rms = position_rms(&c, &rows);
    assert!(
        s.outliers_left_out && s.listed_outliers().len() > 15,
        "{:?}",
        s.listed_outliers().len()
    );
    assert!(
        rms > 2.0 * cv,
        "{rms} mm on the training rows, {cv} cross-validated"
    );
    let warned = |s: &robocal::neural::selection::Selection| {
        s.warnings
            .iter()
            .any(|w| w.contains("row(s) left out of the final fit by"))
    };
    assert!(warned(s), "{:?}", s.warnings);
    assert!(
        report.notes.iter().any(|n| n.contains("heavy-tailed")),
        "{:?}",
        report.notes
    );
    println!(
        "{} rows listed ({} of a first choice), {rms:.2} mm RMS on the training rows, {cv:.2} \
         cross-validated; {:?}",
        s.listed_outliers().len(),
        s.first_outliers.len(),
        s.warnings
    );
    // Kept, they train the network (and no choice is made again without them).
    let (c, report) = Compensator::train(&ur, &rows, &opts(true), &|_, _| {}).unwrap();
    let s = report.selection.as_ref().unwrap();
    assert!(!s.outliers_left_out && s.first_outliers.is_empty() && !s.outliers.is_empty());
    assert!(position_rms(&c, &rows) < cv);
}

#[test]
#[cfg_attr(
    debug_assertions,
    ignore = "trains dozens of networks: release builds only"
)]
fn a_refinement_on_a_few_rows_must_win_significantly() {
    use robocal::neural::tuning::{REFINEMENT_MARGIN, REFINEMENT_Z};
    let ur = common::ur10::robot();
    let (id, pool, val) = series_b_split(&ur);
    let model = identified(&ur, &id);
    // The first 30 of the pool's rows that did not identify the model, in the file's order.
    let few = MeasurementSet {
        rows: (pool.rows.iter())
            .filter(|r| id.rows.iter().all(|i| i.line != r.line))
            .take(30)
            .cloned()
            .collect(),
        ..pool.clone()
    };
    let (c, report) =
        Compensator::train(&model, &few, &CompensatorOptions::default(), &|_, _| {}).unwrap();
    let sel = report.selection.as_ref().unwrap();
    assert_eq!(report.settings.refine, None, "{:?}", sel.notes);
    let test = sel
        .refinement_tests
        .iter()
        .find(|t| !sel.candidates[t.network].settings.has_network())
        .expect("the refined model alone was ranked first and tested");
    assert!(!test.kept && test.ratio < 1.0, "{test:?}");
    assert!(
        test.ratio * (1.0 + REFINEMENT_MARGIN) > 1.0 || test.z > -REFINEMENT_Z,
        "{test:?}"
    );
    // Its figures are the candidates' (`full` names no compliance: no margin of its own),
    // row by row over every training row.
    let rms = |i: usize| sel.candidates[i].score.as_ref().unwrap().position_rms_mm;
    assert!(
        (test.ratio - rms(test.network) / rms(test.alone)).abs() < 1e-12,
        "{test:?}"
    );
    assert!(
        test.z.is_finite() && test.rows == few.rows.len(),
        "{test:?}"
    );
    assert!(
        sel.notes
            .iter()
            .any(|n| n.contains("the refinement is not kept")),
        "{:?}",
        sel.notes
    );
    let model_rms = {
        let e = row_errors(&val, Measure::Pose, |q| {
            robocal::kinematics::tool_pose(&model, q)
        });
        summarize(&e.unwrap()).position_mm.unwrap().rms
    };
    let rms = position_rms(&c, &val);
    assert!(
        rms <= 1.02 * model_rms,
        "{rms} against the model's {model_rms}"
    );
    // The model alone, not refined, has no network to extrapolate and fitted nothing on the
    // rows: no row is outside its domain (before, 20 of the 495 were flagged, their
    // correction said to fade).
    let mut ws = PredictWorkspace::default();
    assert!(c.members.is_empty() && c.rbf.is_none());
    assert!(
        val.rows
            .iter()
            .all(|r| c.domain_check(&r.q, &mut ws).inside())
    );
}

/// A network the flags fix that cross-validates far above the model alone is warned of,
/// whatever its paired z: a reviewer's 64-unit pose-form network without a penalty on 50
/// Series A rows cross-validated at 55 times the model's RMS with z 1.4 (a few rows of huge
/// errors), got a note only, and missed held-out rows by up to 65 mm. Here: 50 Series A rows.
#[test]
#[cfg_attr(
    debug_assertions,
    ignore = "trains a few networks: release builds only"
)]
fn a_fixed_network_far_worse_than_the_model_is_warned_of() {
    use robocal::neural::compensator::{Network, Refine};
    use robocal::neural::tuning::{FIXED_NETWORK_WORSE, NETWORK_Z};
    let ur = common::ur10::robot();
    let (id, rest) = split(&series(&ur, SERIES_A), 0.33, 1);
    let model = identified(&ur, &id);
    let few = MeasurementSet {
        rows: rest.rows[..50].to_vec(),
        ..rest.clone()
    };
    let opts = CompensatorOptions {
        network: Some(Network::Mlp),
        form: Some(Form::Pose),
        encoding: Some(Encoding::Angles),
        hidden: Some(64),
        penalty: Some(0.0),
        members: Some(1),
        refine: Refine::Off,
        ..Default::default()
    };
    let (_, report) = Compensator::train(&model, &few, &opts, &|_, _| {}).unwrap();
    let sel = report.selection.as_ref().unwrap();
    let t = sel
        .fixed_network_test
        .as_ref()
        .expect("the fixed network is tested");
    let rms = |i: usize| sel.candidates[i].score.as_ref().unwrap().position_rms_mm;
    let ratio = rms(t.network) / rms(t.alone);
    assert!(ratio >= FIXED_NETWORK_WORSE, "{ratio} {t:?}");
    let warned = sel
        .warnings
        .iter()
        .any(|w| w.contains("the model alone is more accurate on rows it did not see"));
    assert!(warned, "{:?} {:?}", sel.warnings, sel.notes);
    // The case the paired z alone let through (z 1.1 here, the RMS 9.1 times the model's).
    assert!(t.z < NETWORK_Z, "{t:?}");
    assert!(
        !sel.notes
            .iter()
            .any(|n| n.contains("kept as --members fixes it")),
        "{:?}",
        sel.notes
    );
}

/// One row 5 mm off among 100 Series A rows made 54 % of the model alone's cross-validated
/// squared error, and `train` kept the model alone (0.4283 mm RMS on 1000 new rows). The row
/// is listed, the settings are chosen again without it, the compensator is the one the rows
/// without it train, and it beats the first choice on the new rows (0.3075 mm).
#[test]
#[cfg_attr(
    debug_assertions,
    ignore = "trains dozens of networks: release builds only"
)]
fn an_outlier_that_weighs_in_the_choice_is_left_out_of_it() {
    let ur = common::ur10::robot();
    let (id, rest) = split(&series(&ur, SERIES_A), 0.05, 3);
    let model = identified(&ur, &id);
    let (few, val) = split(&rest, 100.0 / rest.rows.len() as f64, 4);
    let bad = 10;
    let mut moved = few.clone();
    moved.rows[bad].position.as_mut().unwrap().x += 5.0;
    let opts = CompensatorOptions::default();
    let (c, report) = Compensator::train(&model, &moved, &opts, &|_, _| {}).unwrap();
    let s = report.selection.as_ref().unwrap();
    let first: Vec<usize> = s.first_outliers.iter().map(|o| o.row).collect();
    assert_eq!(first, vec![bad], "{:?}", s.notes);
    assert!(
        report
            .notes
            .iter()
            .any(|n| n.contains("chosen again without them")),
        "{:?}",
        report.notes
    );
    let without = robocal::neural::tuning::subset(&moved, |i| i != bad);
    let (other, again) = Compensator::train(&model, &without, &opts, &|_, _| {}).unwrap();
    assert_eq!(report.settings, again.settings);
    let val = MeasurementSet {
        rows: val.rows[..1000].to_vec(),
        ..val
    };
    let (rms, rms_without) = (position_rms(&c, &val), position_rms(&other, &val));
    assert!((rms - rms_without).abs() < 1e-9, "{rms} {rms_without}");
    // Kept in the choice, as before, on the same rows.
    let first_choice = CompensatorOptions {
        reselect: false,
        ..Default::default()
    };
    let (kept, report) = Compensator::train(&model, &moved, &first_choice, &|_, _| {}).unwrap();
    let s = report.selection.as_ref().unwrap();
    assert!(s.first_outliers.is_empty() && s.outliers.iter().any(|o| o.row == bad));
    let first_rms = position_rms(&kept, &val);
    assert!(rms < first_rms, "{rms} {first_rms}");
    println!(
        "held-out RMS: chosen again {rms:.4} mm, first choice {first_rms:.4} mm ({}), model \
         {:.4} mm",
        report.settings.describe(),
        summarize(
            &row_errors(&val, Measure::Position, |q| {
                robocal::kinematics::tool_pose(&model, q)
            })
            .unwrap()
        )
        .position_mm
        .unwrap()
        .rms
    );
}

/// Release builds only: the default compensator beats the baseline by at least 10 % RMS on
/// the Series B split, and its max error stays within 10 % of the model's on the validation
/// rows whose measurement agrees with a repeat of theirs in the pool (or has none); on a row
/// whose every repeat lies more than 1 mm away (one of them carries another configuration's
/// reading: lines 856 and 857 here, see `series_b_shared_readings_are_its_four_logging_slips`),
/// it stays within that distance of the measurement. Configurations turned 1 or 3 deg off
/// the training rows (any joint) stay inside its training domain.
#[test]
#[cfg_attr(
    debug_assertions,
    ignore = "trains dozens of networks: release builds only"
)]
fn default_beats_the_plain_baseline_on_series_b() {
    let ur = common::ur10::robot();
    let (id, pool, val) = series_b_split(&ur);
    let model = identified(&ur, &id);
    let base = baseline(&model, &pool);
    let (c, report) =
        Compensator::train(&model, &pool, &CompensatorOptions::default(), &|_, _| {}).unwrap();
    // The RBF network of the final fit: searched again without the rows cross-validation
    // listed, from the hyperparameters it judged, on the rows its search drew but those (the
    // pool has more rows than one search sees, so another draw would be other rows).
    {
        use robocal::neural::compensator::Form;
        use robocal::neural::rbf::{Draw, LeftOut, Rbf, search_from};
        let sel = report.selection.as_ref().unwrap();
        assert!(report.settings.has_rbf() && report.settings.refine.is_none());
        // The network is far ahead of the model alone, row by row too (z about -21).
        let test = sel.network_test.as_ref().unwrap();
        assert!(test.kept && test.ratio < 0.7, "{test:?}");
        assert!(
            test.z < -3.0 * robocal::neural::tuning::NETWORK_Z,
            "{test:?}"
        );
        assert_eq!(test.network, sel.chosen);
        assert!(pool.rows.len() > robocal::neural::rbf::HYPER_ROWS);
        // Its hyperparameters were searched on 500 of the pool's configurations, the rows
        // the folds hold out among them; on the held-out rows of the others (401, more than
        // a fold holds out) it is as far ahead (46.8 % below, z -13.7).
        let u = test.unseen.as_ref().expect("tested on rows no search saw");
        assert_eq!(u.by, robocal::neural::tuning::Unseen::Rows, "{test:?}");
        let trained = pool.rows.len() - 2;
        assert!(
            u.rows * sel.folds >= trained && u.rows + robocal::neural::rbf::HYPER_ROWS <= trained,
            "{test:?}"
        );
        assert!(
            u.ratio < 0.7 && u.z < -2.0 * robocal::neural::tuning::NETWORK_Z,
            "{test:?}"
        );
        // The pool's rows that carry another configuration's reading (lines 534 and 1065)
        // trained nothing; the outliers are named in the pool's rows, and were found (and
        // left out of the search) among the rest.
        let shared: Vec<usize> = report.shared_readings.iter().map(|s| s.row).collect();
        let lines: Vec<usize> = report.shared_readings.iter().map(|s| s.line).collect();
        assert_eq!(lines, vec![534, 1065]);
        let trained = robocal::neural::tuning::subset(&pool, |i| !shared.contains(&i));
        let outliers: Vec<usize> = sel.outliers.iter().map(|o| o.row).collect();
        // The two weigh too little in the choice to make it again (see
        // `an_outlier_that_weighs_in_the_choice_is_left_out_of_it`).
        assert!(sel.first_outliers.is_empty(), "{:?}", sel.first_outliers);
        // The cut is for gross errors: it lists two rows here, at most 0.5 % of the pool (5
        // rows), not the tail of the network's error (a cut of 4 listed 6).
        assert!(
            !outliers.is_empty() && outliers.len() <= pool.rows.len() / 200,
            "{:?}",
            sel.outliers
        );
        let index: Vec<usize> = (0..pool.rows.len())
            .filter(|i| !shared.contains(i))
            .collect();
        let left: Vec<usize> = outliers
            .iter()
            .map(|o| index.iter().position(|i| i == o).unwrap())
            .collect();
        let kept = robocal::neural::tuning::subset(&trained, |i| !left.contains(&i));
        let samples = robocal::neural::targets::build(&c.robot, &kept, Form::Pose, c.encoding)
            .unwrap()
            .samples;
        let judged = sel.rbf_hyper.as_ref().unwrap();
        let draw = Draw::seeded(CompensatorOptions::default().train.seed);
        // Cross-validation's search drew one row per configuration of the rows that trained.
        let groups = robocal::neural::repeats::configuration_groups(&c.robot, &trained);
        let whole = LeftOut {
            rows: &left,
            groups: &groups,
        };
        let again = search_from(&samples, judged, draw, whole).unwrap().hyper;
        let kernels = |h| {
            Rbf::with_hyper(&samples, h, draw.covariance)
                .unwrap()
                .kernels
        };
        assert_eq!(c.rbf.as_ref().unwrap().kernels, kernels(&again));
        let other_draw = search_from(&samples, judged, draw, LeftOut::NONE)
            .unwrap()
            .hyper;
        assert_ne!(again, other_draw);
    }
    let plain = summarize(
        &row_errors(&val, Measure::Pose, |q| {
            robocal::kinematics::tool_pose(&model, q)
        })
        .unwrap(),
    );
    let (b, d) = (stats(&base, &val), stats(&c, &val));
    eprintln!("{}", line("model", &plain, 0.0));
    eprintln!("{}", line("baseline", &b, 0.0));
    eprintln!("{}", line("default", &d, 0.0));
    let (brms, drms) = (b.position_mm.unwrap().rms, d.position_mm.unwrap().rms);
    assert!(drms <= 0.9 * brms, "default {drms} vs baseline {brms}");
    // The max, judged where the measurements agree with themselves. A validation row whose
    // configuration the pool measured again more than 1 mm away (30 times the data's pure
    // error, 0.034 mm) is a mis-measured row of the two (lines 856 and 857 carry other
    // configurations' readings): there the compensator can only be as right as the repeat it
    // learned, and it must be that.
    let glitch: Vec<Option<f64>> = val
        .rows
        .iter()
        .map(|m| {
            pool.rows
                .iter()
                .filter(|p| {
                    p.q.iter()
                        .zip(&m.q)
                        .all(|(a, b)| (a - b).abs() <= SAME_CONFIGURATION)
                })
                .map(|p| (p.position.unwrap() - m.position.unwrap()).norm())
                .reduce(f64::min)
                .filter(|&gap| gap > 1.0)
        })
        .collect();
    // The same rows by the product's own check, the validation rows against themselves and
    // the pool (as `train --validate` and `evaluate --check-against` judge them): line 856
    // carries the reading of line 855's configuration, here line 847's (a repeat of 855, in
    // the validation rows), line 857 that of line 864 (in the pool). On the other rows the max
    // is the compensator's, and within 10 % of the model's.
    let shared = robocal::data::shared_readings::shared_readings_with(&model, &val, &pool);
    let named: Vec<(usize, usize, bool)> = shared
        .iter()
        .map(|s| (s.line, s.other_line, s.other_source.is_some()))
        .collect();
    assert_eq!(named, vec![(856, 847, false), (857, 864, true)]);
    let mut ws = PredictWorkspace::default();
    let (mut model_max, mut comp_max): (f64, f64) = (0.0, 0.0);
    let (mut model_clean, mut comp_clean): (f64, f64) = (0.0, 0.0);
    for (i, (m, g)) in val.rows.iter().zip(&glitch).enumerate() {
        let at = m.position.unwrap();
        let model_err = (at
            - robocal::kinematics::tool_pose(&model, &m.q)
                .translation
                .vector)
            .norm();
        let comp_err = (at - c.predict(&m.q, &mut ws).translation.vector).norm();
        if shared.iter().all(|s| s.row != i) {
            model_clean = model_clean.max(model_err);
            comp_clean = comp_clean.max(comp_err);
        }
        match g {
            None => {
                model_max = model_max.max(model_err);
                comp_max = comp_max.max(comp_err);
            }
            Some(gap) => assert!(
                comp_err <= gap + 0.1,
                "line {}: {comp_err} mm, its repeat {gap} mm away",
                m.line
            ),
        }
    }
    println!("rows agreeing with their repeat: max {comp_max:.4} mm (model {model_max:.4})");
    println!("rows without a shared reading: max {comp_clean:.4} mm (model {model_clean:.4})");
    assert!(
        comp_clean <= 1.1 * model_clean,
        "max {comp_clean} vs model {model_clean}"
    );
    // A sanity bound: Series B has three glitched pairs in all.
    assert!(
        glitch.iter().filter(|g| g.is_some()).count() <= 3,
        "{glitch:?}"
    );
    assert!(
        comp_max <= 1.1 * model_max,
        "max {comp_max} vs model {model_max} (all rows: {} vs {})",
        d.position_mm.unwrap().max,
        plain.position_mm.unwrap().max
    );
    // Off the training rows' manifold: Series B keeps the flange's x axis level within 0.04
    // deg, so a turn of q6 (or of q2, q3, q4) leaves it. A training configuration turned by 1
    // or 3 deg in any joint stays inside the domain, its correction whole or nearly (before
    // the inputs' scale floor, 1 deg of q6 was 20.8 units from the nearest configuration
    // against a radius of 2.2, and the correction faded to nothing 0.4 deg away).
    let mut ws = PredictWorkspace::default();
    let mut turned = 0;
    for m in pool.rows.iter().step_by(50) {
        for j in 0..6 {
            for deg in [1.0_f64, -3.0] {
                let mut q = m.q.clone();
                q[j] += deg.to_radians();
                let [lo, hi] = ur.joints()[j].limits;
                if q[j] < lo || q[j] > hi {
                    continue;
                }
                let check = c.domain_check(&q, &mut ws);
                assert!(
                    check.weight > 0.5,
                    "line {} q{} {deg:+} deg: {}",
                    m.line,
                    j + 1,
                    check.describe()
                );
                turned += 1;
            }
        }
    }
    assert!(turned > 200, "{turned}");
    // Nor does the correction change within a fraction of a degree off that manifold: a
    // quarter degree of q6 moves the orientation correction by little (its median over these
    // configurations is 0.74 mrad). Without the RBF widths held at the inputs' resolution
    // the median change was 0.49 mrad: the orientation outputs' widths on the flange's
    // gravity components had narrowed to the 0.04 deg the data vary by.
    let mut changes = Vec::new();
    for m in pool.rows.iter().step_by(10) {
        let at = c.predict(&m.q, &mut ws);
        let mut q = m.q.clone();
        q[5] += 0.25_f64.to_radians();
        let turned_pose = c.predict(&q, &mut ws);
        let (plain_at, plain_turned) = (
            robocal::kinematics::tool_pose(&c.robot, &m.q),
            robocal::kinematics::tool_pose(&c.robot, &q),
        );
        // Each correction as a rotation (mrad), compensated pose against the model's.
        let correction = |comp: &robocal::kinematics::Pose, plain: &robocal::kinematics::Pose| {
            (comp.rotation * plain.rotation.inverse()).scaled_axis() * 1e3
        };
        let moved = correction(&turned_pose, &plain_turned) - correction(&at, &plain_at);
        changes.push(moved.norm());
    }
    changes.sort_by(f64::total_cmp);
    let median = changes[changes.len() / 2];
    assert!(
        median < 0.1,
        "orientation correction moved {median} mrad (median)"
    );
}

/// Release builds only: the default outlier cut lists gross errors of real data. Five rows of
/// a Series B pool of 1000 (`series_pools`' seed 0), drawn by seed among those that neither
/// carry another configuration's reading nor lend theirs (such rows are left out before
/// cross-validation), are moved 2 mm in random directions: readings wrong by 2 mm that no
/// other check finds. `train` lists every one and names it in the note of the rows left out of
/// the final fit. (A cut of 8 lists three of the five: 2 mm lies near 8 robust sigmas of the
/// cross-validated position error on this pool, whose sigma is 0.23 mm.)
#[test]
#[cfg_attr(
    debug_assertions,
    ignore = "trains dozens of networks: release builds only"
)]
fn the_default_cut_lists_rows_two_millimetres_off() {
    use rand::{Rng, SeedableRng};
    let ur = common::ur10::robot();
    let (pool, _, model) = series_b_pool(&ur, &series(&ur, SERIES_B), 1000.0, 0);
    let shared = robocal::data::shared_readings::shared_readings(&model, &pool);
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
    let mut moved = pool.clone();
    let mut lines = Vec::new();
    while lines.len() < 5 {
        let i = rng.random_range(0..moved.rows.len());
        let line = moved.rows[i].line;
        if lines.contains(&line) || shared.iter().any(|s| s.row == i || s.other_row == i) {
            continue;
        }
        let d = nalgebra::Vector3::from_fn(|_, _| rng.sample::<f64, _>(rand_distr::StandardNormal));
        *moved.rows[i].position.as_mut().unwrap() += d * (2.0 / d.norm());
        lines.push(line);
    }
    let (_, report) =
        Compensator::train(&model, &moved, &CompensatorOptions::default(), &|_, _| {}).unwrap();
    let listed: Vec<(usize, f64)> = report
        .selection
        .as_ref()
        .unwrap()
        .listed_outliers()
        .iter()
        .map(|o| (o.line, o.robust_sigmas))
        .collect();
    assert!(
        lines.iter().all(|l| listed.iter().any(|o| o.0 == *l)),
        "moved {lines:?}, listed (line, robust sigmas) {listed:?}"
    );
    let note = report
        .notes
        .iter()
        .find(|n| n.contains("robust sigmas of the cross-validated error"))
        .expect("a note on the rows left out");
    let named: Vec<&str> = note
        .split_once("error (")
        .and_then(|(_, rest)| rest.split_once(')'))
        .unwrap()
        .0
        .split(", ")
        .collect();
    assert!(note.contains("left out of the final fit"), "{note}");
    assert!(
        lines
            .iter()
            .all(|l| named.contains(&format!("line {l}").as_str())),
        "{note}"
    );
}

/// The README table (run by hand: `cargo test --release --test real_ur10_compensator --
/// --ignored --nocapture`).
#[test]
#[ignore = "prints the README table; a minute"]
fn readme_table_series_b() {
    use robocal::neural::compensator::{Refine, Settings};
    use robocal::neural::train::TrainOptions;
    let ur = common::ur10::robot();
    let (id, pool, val) = series_b_split(&ur);
    let model = identified(&ur, &id);
    let plain = summarize(
        &row_errors(&val, Measure::Pose, |q| {
            robocal::kinematics::tool_pose(&model, q)
        })
        .unwrap(),
    );
    println!("| model | mean | RMS | p95 | max | orientation mean deg | training s | settings |");
    println!("|---|---|---|---|---|---|---|---|");
    println!(
        "{} - |",
        line("identified model (`full`, 500 poses)", &plain, 0.0)
    );
    let t = Instant::now();
    let base = baseline(&model, &pool);
    println!(
        "{} see the test |",
        line(
            "plain MLP baseline (test code)",
            &stats(&base, &val),
            t.elapsed().as_secs_f64()
        )
    );
    let thesis = Settings {
        network: robocal::neural::compensator::Network::Mlp,
        rbf_start: None,
        form: Form::Joint,
        encoding: Encoding::SinCos,
        hidden: 20,
        penalty: 0.0,
        members: 1,
        refine: None,
        mlp_share: None,
    };
    let d = CompensatorOptions::default;
    let runs: Vec<(&str, CompensatorOptions)> = vec![
        ("`train` default (cross-validated)", d()),
        (
            "`--form pose`",
            CompensatorOptions {
                form: Some(Form::Pose),
                ..d()
            },
        ),
        (
            "`--form joint`",
            CompensatorOptions {
                form: Some(Form::Joint),
                ..d()
            },
        ),
        (
            "`--network mlp` (MLPs only)",
            CompensatorOptions {
                network: Some(robocal::neural::compensator::Network::Mlp),
                ..d()
            },
        ),
        (
            "`--network rbf`",
            CompensatorOptions {
                network: Some(robocal::neural::compensator::Network::Rbf),
                ..d()
            },
        ),
        (
            "`--network mix`",
            CompensatorOptions {
                network: Some(robocal::neural::compensator::Network::Mix),
                ..d()
            },
        ),
        (
            "`--refine full`",
            CompensatorOptions {
                refine: Refine::Params("full".into()),
                ..d()
            },
        ),
        (
            "`--refine full --compliance off`",
            CompensatorOptions {
                refine: Refine::Params("full".into()),
                compliance: Some(false),
                ..d()
            },
        ),
        (
            "`--refine none`",
            CompensatorOptions {
                refine: Refine::Off,
                ..d()
            },
        ),
        (
            "fixed as before: joint, sin/cos, 20 hidden, no penalty, 15 % early stopping",
            CompensatorOptions::fixed(
                &thesis,
                TrainOptions {
                    validation_fraction: 0.15,
                    momentum_epochs: 200,
                    max_epochs: 200,
                    ..Default::default()
                },
            ),
        ),
    ];
    for (name, opts) in runs {
        let t = Instant::now();
        let (c, rep) = Compensator::train(&model, &pool, &opts, &|_, _| {}).unwrap();
        println!(
            "{} {} |",
            line(name, &stats(&c, &val), t.elapsed().as_secs_f64()),
            rep.settings.describe()
        );
    }
}

/// Series A (grid): a pool of 2000 poses (500 of them identify), 2000 others validate.
#[test]
#[ignore = "experiment: Series A, pool of 2000"]
fn series_a_pool_2000() {
    let ur = common::ur10::robot();
    let set = series(&ur, "Series_A/measurements_grid.csv");
    let (pool, rest) = split(&set, 2000.0 / set.rows.len() as f64, 21);
    let (val, _) = split(&rest, 2000.0 / rest.rows.len() as f64, 22);
    let (id, _) = split(&pool, 0.25, 23);
    let model = identified(&ur, &id);
    let plain = summarize(
        &row_errors(&val, Measure::Pose, |q| {
            robocal::kinematics::tool_pose(&model, q)
        })
        .unwrap(),
    );
    println!("{}", line("model", &plain, 0.0));
    let t = Instant::now();
    let base = baseline(&model, &pool);
    println!(
        "{}",
        line("baseline", &stats(&base, &val), t.elapsed().as_secs_f64())
    );
    let t = Instant::now();
    let (c, rep) =
        Compensator::train(&model, &pool, &CompensatorOptions::default(), &|_, _| {}).unwrap();
    println!(
        "{} {}",
        line("default", &stats(&c, &val), t.elapsed().as_secs_f64()),
        rep.settings.describe()
    );
    let mut ws = PredictWorkspace::default();
    let mut rows: Vec<(f64, f64, String, f64)> = val
        .rows
        .iter()
        .map(|m| {
            let e = (m.position.unwrap() - c.predict(&m.q, &mut ws).translation.vector).norm();
            let em = (m.position.unwrap()
                - robocal::kinematics::tool_pose(&model, &m.q)
                    .translation
                    .vector)
                .norm();
            let corr = c
                .correction(&m.q, &mut ws)
                .iter()
                .take(3)
                .map(|v| v * v)
                .sum::<f64>()
                .sqrt();
            let d = c.domain_check(&m.q, &mut ws);
            // Spread: RMS distance of the members' position corrections from their mean.
            let mut outs = Vec::new();
            for w in &c.members {
                let mut one = c.clone();
                one.members = vec![w.clone()];
                outs.push(one.correction(&m.q, &mut ws)[..3].to_vec());
            }
            let mean: Vec<f64> = (0..3)
                .map(|k| outs.iter().map(|o| o[k]).sum::<f64>() / outs.len() as f64)
                .collect();
            let spread = (outs
                .iter()
                .map(|o| (0..3).map(|k| (o[k] - mean[k]).powi(2)).sum::<f64>())
                .sum::<f64>()
                / outs.len() as f64)
                .sqrt();
            (
                e,
                em,
                format!(
                    "{} line {} nearest {:.2}/{:.2} spread {spread:.3}",
                    d.describe(),
                    m.line,
                    d.nearest,
                    d.radius
                ),
                corr,
            )
        })
        .collect();
    rows.sort_by(|a, b| b.0.total_cmp(&a.0));
    for r in rows
        .iter()
        .take(6)
        .chain(rows.iter().skip(500).step_by(300).take(5))
    {
        println!("comp {:.3} model {:.3} |corr| {:.3} {}", r.0, r.1, r.3, r.2);
    }
    let outside = rows.iter().filter(|r| !r.2.starts_with("inside")).count();
    println!(
        "{outside} of {} validation rows outside the domain",
        rows.len()
    );
    let shared = robocal::data::shared_readings::shared_readings_with(&model, &val, &pool);
    println!(
        "{} validation rows carry another configuration's reading",
        shared.len()
    );
    assert!(shared.is_empty(), "{shared:?}");
}

/// Series B (or Series A with SERIES=A) with other pool sizes and seeds (POOL, SEEDS env;
/// OUTLIER_K, KEEP for the outlier options): identification on the pool itself when POOL <=
/// 500, else on 500 of it; validation on the rest of Series B, on 2000 of the rest of Series A.
#[test]
#[ignore = "experiment"]
fn series_pools() {
    let ur = common::ur10::robot();
    let a = std::env::var("SERIES").is_ok_and(|s| s == "A");
    let mut set = series(&ur, if a { SERIES_A } else { SERIES_B });
    // NOISE=s adds seeded Gaussian noise of s mm per coordinate to every measured position
    // (a tracker farther away, or a worse one), before the split.
    if let Ok(sigma) = std::env::var("NOISE") {
        use rand::SeedableRng;
        use rand_distr::{Distribution, Normal};
        let normal = Normal::new(0.0, sigma.parse::<f64>().unwrap()).unwrap();
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(77);
        for row in &mut set.rows {
            if let Some(p) = row.position.as_mut() {
                for k in 0..3 {
                    p[k] += normal.sample(&mut rng);
                }
            }
        }
    }
    let pool_n: f64 = std::env::var("POOL")
        .map(|v| v.parse().unwrap())
        .unwrap_or(500.0);
    let seeds: u64 = std::env::var("SEEDS")
        .map(|v| v.parse().unwrap())
        .unwrap_or(3);
    for seed in 0..seeds {
        let (pool, val, model) = if a {
            let (pool, rest) = split(&set, pool_n / set.rows.len() as f64, 300 + seed);
            let (val, _) = split(&rest, 2000.0 / rest.rows.len() as f64, 400 + seed);
            let model = identified(&ur, &identification_rows(&pool, 500 + seed));
            (pool, val, model)
        } else {
            series_b_pool(&ur, &set, pool_n, seed)
        };
        let plain = summarize(
            &row_errors(&val, Measure::Pose, |q| {
                robocal::kinematics::tool_pose(&model, q)
            })
            .unwrap(),
        );
        let base = stats(&baseline(&model, &pool), &val);
        let t = Instant::now();
        let opts = CompensatorOptions {
            outlier_k: std::env::var("OUTLIER_K")
                .map(|v| v.parse().unwrap())
                .unwrap_or(robocal::neural::tuning::OUTLIER_K),
            drop_outliers: std::env::var("KEEP").is_err(),
            ..Default::default()
        };
        let (c, rep) = Compensator::train(&model, &pool, &opts, &|_, _| {}).unwrap();
        let d = stats(&c, &val);
        let (m, b, dd) = (
            plain.position_mm.unwrap(),
            base.position_mm.unwrap(),
            d.position_mm.unwrap(),
        );
        println!(
            "seed {seed}: model {:.4}/{:.3} baseline {:.4}/{:.3} default {:.4}/{:.3} ({:+.1}% vs baseline, max {:.2}x the model's) {:.1} s {}",
            m.rms,
            m.max,
            b.rms,
            b.max,
            dd.rms,
            dd.max,
            100.0 * (dd.rms / b.rms - 1.0),
            dd.max / m.max,
            t.elapsed().as_secs_f64(),
            rep.settings.describe()
        );
        if let Some(sel) = &rep.selection {
            println!(
                "  outliers listed: {} ({} of a first choice made again without them)",
                sel.listed_outliers().len(),
                sel.first_outliers.len()
            );
            if let Some(t) = &sel.rbf_network_test {
                println!("  failed on rows no search saw: {t:?}");
            }
            if let Some(t) = &sel.network_test {
                println!("  network test: {t:?}");
                // The network stage 5 did not keep, fitted as it would have been.
                if !t.kept {
                    let mut s = sel.candidates[t.network].settings.clone();
                    if s.members == robocal::neural::tuning::ENSEMBLE_PROBE
                        && s.network != robocal::neural::compensator::Network::Mix
                    {
                        s.members = robocal::neural::tuning::ENSEMBLE;
                    }
                    let fixed = CompensatorOptions::fixed(&s, opts.train.clone());
                    let (n, _) = Compensator::train(&model, &pool, &fixed, &|_, _| {}).unwrap();
                    let e = stats(&n, &val).position_mm.unwrap();
                    println!(
                        "  the network left out ({}): {:.4}/{:.3}",
                        s.describe(),
                        e.rms,
                        e.max
                    );
                }
            }
        }
        let mut ws = PredictWorkspace::default();
        let comp_rows = row_errors(&val, Measure::Position, |q| c.predict(q, &mut ws)).unwrap();
        // Validation rows, largest compensated position error first.
        let mut idx: Vec<usize> = (0..comp_rows.len()).collect();
        idx.sort_by(|&a, &b| {
            comp_rows[b]
                .position_mm
                .unwrap()
                .total_cmp(&comp_rows[a].position_mm.unwrap())
        });
        println!("  worst validation row: line {}", comp_rows[idx[0]].line);
        if std::env::var("WORST").is_ok() {
            let model_rows = row_errors(&val, Measure::Position, |q| {
                robocal::kinematics::tool_pose(&model, q)
            })
            .unwrap();
            for &i in idx.iter().take(8) {
                let d = c.domain_check(&val.rows[i].q, &mut ws);
                println!(
                    "    line {} model {:.3} comp {:.3} nearest {:.3} radius {:.3} weight {:.2} joints out {:?}",
                    comp_rows[i].line,
                    model_rows[i].position_mm.unwrap(),
                    comp_rows[i].position_mm.unwrap(),
                    d.nearest,
                    d.radius,
                    d.weight,
                    d.joints_outside
                );
            }
        }
        // The max without the validation rows that carry another configuration's reading (of
        // a validation row or a pool row), as `train --validate` judges them.
        let shared = robocal::data::shared_readings::shared_readings_with(&model, &val, &pool);
        if !shared.is_empty() {
            let clean =
                robocal::data::measurement::subset(&val, |i| shared.iter().all(|s| s.row != i));
            let (m, d) = (
                summarize(
                    &row_errors(&clean, Measure::Pose, |q| {
                        robocal::kinematics::tool_pose(&model, q)
                    })
                    .unwrap(),
                )
                .position_mm
                .unwrap(),
                stats(&c, &clean).position_mm.unwrap(),
            );
            let lines: Vec<usize> = shared.iter().map(|s| s.line).collect();
            println!(
                "  without lines {lines:?} (shared readings): model {:.4}/{:.3} default {:.4}/{:.3} (max {:.2}x the model's)",
                m.rms,
                m.max,
                d.rms,
                d.max,
                d.max / m.max
            );
        }
        if std::env::var("TABLE").is_ok() {
            let sel = rep.selection.as_ref().unwrap();
            println!("  model alone cv {:.4}", sel.model.position_rms_mm);
            for cand in &sel.candidates {
                println!(
                    "  {} {:?}",
                    cand.settings.describe(),
                    cand.score.as_ref().map(|s| s.position_rms_mm)
                );
            }
        }
    }
}

/// The readings of Series B that two configurations share: under the model identified on the
/// whole series, the four rows whose reading is another row's (lines 534 and 1065 repeat
/// lines 533 and 1064 number for number; 856 reads 855's pose, 857 the pose 864 measured
/// later). Series A, a grid turned about the probe point in 10 deg steps, has none under
/// `full` identified on all of it: many of its rows of different configurations read one
/// position to 0.1 mm, at other orientations.
#[test]
fn series_b_shared_readings_are_its_four_logging_slips() {
    use robocal::data::shared_readings::{SEPARATION_MM, shared_readings};
    let ur = common::ur10::robot();
    let b = series(&ur, SERIES_B);
    let model = identified(&ur, &b);
    let found = shared_readings(&model, &b);
    let pairs: Vec<(usize, usize)> = found.iter().map(|s| (s.line, s.other_line)).collect();
    // 856 reads 855's pose and also 847's (855's configuration measured earlier, 0.015 mm
    // from it: the closer reading); 534 reads 533's and 525's (0.0145 mm), 533's closer.
    assert_eq!(
        pairs,
        vec![(534, 533), (856, 847), (857, 864), (1065, 1064)],
        "{found:#?}"
    );
    for s in &found {
        assert!(s.reading_mm < 0.03 && s.reading_deg < 0.01, "{s:?}");
        assert!(
            s.model_mm >= SEPARATION_MM && s.residual_mm > s.other_residual_mm,
            "{s:?}"
        );
    }
    let a = series(&ur, SERIES_A);
    let model_a = identified(&ur, &a);
    assert!(shared_readings(&model_a, &a).is_empty());
}
