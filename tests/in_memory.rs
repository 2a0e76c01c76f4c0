//! The library used without files: robots, measurements, tables and compensators from text
//! or bytes given in code, with errors that say where (`<in memory>`, line, column).

use robocal::data::{JointTable, Measurement, MeasurementSet, Table, read_canonical};
use robocal::error::IN_MEMORY;
use robocal::kinematics::tool_pose;
use robocal::neural::compensator::{Compensator, CompensatorOptions, Form, Network, Refine};
use robocal::neural::predict::PredictWorkspace;
use robocal::{Pose, Robot};
use std::path::Path;

fn shipped(p: &str) -> String {
    std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join(p)).unwrap()
}

#[test]
fn robot_from_text_is_the_file_robot() {
    let text = shipped("datasets/robots/ur10.toml");
    let a = Robot::from_toml(&text).unwrap();
    let b = robocal::model::read_robot(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("datasets/robots/ur10.toml"),
    )
    .unwrap();
    let q = [0.1, -0.7, 1.2, -0.4, 0.9, 0.3];
    assert_eq!(tool_pose(&a, &q), tool_pose(&b, &q));
    let err = Robot::from_toml(&text.replacen("[[joint]]", "[[joint]]\nbogus = 1", 1))
        .unwrap_err()
        .to_string();
    assert!(err.starts_with(IN_MEMORY), "{err}");
}

#[test]
fn measurements_from_text_and_from_rows() {
    let robot = Robot::from_toml(&shipped("datasets/robots/ur10.toml")).unwrap();
    let text = "q1,q2,q3,q4,q5,q6,x,y,z\n0,-90,90,0,90,0,1,2,3\n10,-80,80,0,90,0,4,5,6\n";
    let (set, report) = MeasurementSet::from_csv(text, &robot).unwrap();
    assert_eq!(set.rows.len(), 2);
    assert_eq!(set.rows[1].line, 3);
    assert!((set.rows[1].q[0] - 10f64.to_radians()).abs() < 1e-15);
    assert!(report.warnings.is_empty(), "{:?}", report.warnings);
    let bad = text.replace("4,5,6", "4,five,6");
    let err = MeasurementSet::from_csv(&bad, &robot)
        .unwrap_err()
        .to_string();
    assert!(
        err.starts_with("<in memory>:3: field `y`"),
        "the error names the row and column: {err}"
    );
    // A set built in code evaluates like a read one.
    let rows = set
        .rows
        .iter()
        .map(|m| Measurement {
            position: m.position,
            ..Measurement::new(m.q.clone())
        })
        .collect();
    let built = MeasurementSet::from_rows(rows);
    assert_eq!(built.source, Path::new(IN_MEMORY));
    let e = |s: &MeasurementSet| {
        robocal::evaluate::evaluate_model(&robot, s, robocal::identify::Measure::Position)
            .unwrap()
            .position_mm
            .unwrap()
            .mean
    };
    assert_eq!(e(&built), e(&set));
}

#[test]
fn tables_from_text() {
    let robot = Robot::from_toml(&shipped("datasets/robots/ur10.toml")).unwrap();
    let t = Table::from_text("name,q1,q2,q3,q4,q5,q6\na,0,-90,90,0,90,0\n").unwrap();
    let j = JointTable::from_table(t, &robot).unwrap();
    assert_eq!(j.joints, vec![vec![0.0, -90.0, 90.0, 0.0, 90.0, 0.0]]);
    let err = Table::from_text("q1\n").unwrap_err().to_string();
    assert!(
        err.contains(IN_MEMORY) && err.contains("no data rows"),
        "{err}"
    );
}

#[test]
fn compensator_round_trips_through_text_and_bytes() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let robot =
        robocal::model::read_robot(root.join("datasets/robots/fanuc_r2000ib_210f.toml")).unwrap();
    let training = read_canonical(&root.join("datasets/case_d/training.csv"), &robot).unwrap();
    let opts = CompensatorOptions {
        network: Some(Network::Mlp),
        form: Some(Form::Pose),
        hidden: Some(8),
        penalty: Some(1.0),
        members: Some(1),
        refine: Refine::Off,
        ..Default::default()
    };
    let (c, _) = Compensator::train(&robot, &training, &opts, &|_, _| {}).unwrap();
    let text = c.to_file_text().unwrap();
    let from_text = Compensator::from_text(&text).unwrap();
    let from_bytes = Compensator::from_bytes(text.as_bytes()).unwrap();
    // A byte-order mark before the JSON (a Windows editor's save) is no part of it, as for
    // every other input file.
    let with_bom = Compensator::from_text(&format!("\u{feff}{text}")).unwrap();
    let mut ws = PredictWorkspace::default();
    for m in training.rows.iter().take(10) {
        let p: Pose = c.predict(&m.q, &mut ws);
        assert_eq!(from_text.predict(&m.q, &mut ws), p);
        assert_eq!(from_bytes.predict(&m.q, &mut ws), p);
        assert_eq!(with_bom.predict(&m.q, &mut ws), p);
    }
    let err = Compensator::from_bytes(&[0xff, 0xfe])
        .unwrap_err()
        .to_string();
    assert!(err.starts_with(IN_MEMORY) && err.contains("UTF-8"), "{err}");
    let err = Compensator::from_text(&text.replacen("\"hidden\"", "\"hidd\"", 1))
        .unwrap_err()
        .to_string();
    assert!(err.starts_with(IN_MEMORY), "{err}");
}
