//! The compensator: training lowers the error on unseen data, save -> load gives identical
//! predictions, and damaged files are refused.

use robocal::data::{Profile, read_measurements};
use robocal::evaluate::{row_errors, summarize};
use robocal::identify::{Measure, Options, Sigmas, identify};
use robocal::model::read_robot;
use robocal::neural::compensator::{Compensator, Form, PredictWorkspace};
use robocal::neural::train::TrainOptions;
use std::path::{Path, PathBuf};

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

#[test]
fn case_d_offsets_model_with_network_save_and_load() {
    let nominal = read_robot(root().join("datasets/robots/fanuc_r2000ib_210f.toml")).unwrap();
    let rd = |p: &str| {
        read_measurements(
            &root().join(p),
            &nominal,
            &Profile::default(),
            &Default::default(),
        )
        .unwrap()
        .0
    };
    let cal = rd("datasets/case_d/calibration.csv");
    let train = rd("datasets/case_d/training.csv");
    let test = rd("datasets/case_d/test_truth.csv");
    let id = identify(
        &nominal,
        &cal,
        &Options {
            params: "offsets".into(),
            ..Default::default()
        },
    )
    .unwrap();
    let model = summarize(
        &row_errors(&test, Measure::Pose, |q| {
            robocal::kinematics::tool_pose(&id.robot, q)
        })
        .unwrap(),
    );
    let opts = TrainOptions {
        hidden: 10,
        ..Default::default()
    };
    for form in [Form::Pose, Form::Joint] {
        let (c, report) =
            Compensator::train(&id.robot, &train, form, Sigmas::default(), &opts).unwrap();
        assert!(report.lm_epochs > 0, "{form:?}: {report:?}");
        let mut ws = PredictWorkspace::default();
        let with = summarize(&row_errors(&test, Measure::Pose, |q| c.predict(q, &mut ws)).unwrap());
        let (a, b) = (
            model.position_mm.unwrap().mean,
            with.position_mm.unwrap().mean,
        );
        // Offsets leave about 1 mm in the focused region; the network removes most of it.
        assert!(b < 0.25 * a, "{form:?}: {a} -> {b}");

        let path =
            std::env::temp_dir().join(format!("robocal-comp-{}-{form:?}.rcal", std::process::id()));
        c.save(&path).unwrap();
        let back = Compensator::load(&path).unwrap();
        let mut ws2 = PredictWorkspace::default();
        for m in &test.rows {
            let (p, r) = (c.predict(&m.q, &mut ws), back.predict(&m.q, &mut ws2));
            assert_eq!(p, r, "identical predictions after save -> load");
        }
        // A flipped character is caught by the checksum; a wrong format by its tag.
        let text = std::fs::read_to_string(&path).unwrap();
        let i = text.find("\"hidden\": ").unwrap() + 10;
        let mut bad = text.clone().into_bytes();
        bad[i] = if bad[i] == b'9' { b'8' } else { b'9' };
        std::fs::write(&path, &bad).unwrap();
        let e = Compensator::load(&path).unwrap_err().to_string();
        assert!(e.contains("checksum"), "{e}");
        std::fs::write(&path, text.replace("robocal-compensator", "other")).unwrap();
        assert!(
            Compensator::load(Path::new(&path))
                .unwrap_err()
                .to_string()
                .contains("not a robocal compensator")
        );
    }
}
