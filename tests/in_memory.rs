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

/// A set built in code with rows the robot cannot be evaluated at (joints of another count,
/// a joint or reading not finite, a sigma not positive) is an error naming the row in
/// `identify`, `evaluate_model` and compensator training (they panicked in forward
/// kinematics, or said "the data identify none of the selected parameters"); an empty set is
/// said to be empty. IK refuses a seed or target not finite (a NaN seed gave Ok(NaN joints)).
#[test]
fn rows_built_in_code_are_checked_not_panicked_on() {
    use robocal::evaluate::evaluate_model;
    use robocal::identify::{Measure, Options, identify};
    use robocal::kinematics::{IkFailure, IkOptions, IkSolver, IkStart, RobotModel};
    let robot = Robot::from_toml(&shipped("datasets/robots/fanuc_r2000ib_210f.toml")).unwrap();
    let good = |k: usize| {
        let q: Vec<f64> = (0..6).map(|j| 0.1 * ((k * 7 + j) as f64).sin()).collect();
        let mut m = Measurement::new(q.clone());
        let pose = tool_pose(&robot, &q);
        m.position = Some(pose.translation.vector);
        m.rotation = Some(pose.rotation);
        m.line = k + 2;
        m
    };
    let rows: Vec<Measurement> = (0..20).map(good).collect();
    type Spoil = fn(&mut Measurement);
    let spoils: [(Spoil, &str); 5] = [
        (
            |m| m.q.truncate(5),
            "line 5: 5 joint values for a robot with 6 joints",
        ),
        (|m| m.q.push(0.0), "line 5: 7 joint values"),
        (|m| m.q[2] = f64::NAN, "line 5: a joint value is not finite"),
        (
            |m| m.position = m.position.map(|p| p * f64::NAN),
            "line 5: its position is not finite",
        ),
        (
            |m| m.sigma_position = Some(nalgebra::Vector3::new(0.03, 0.0, 0.03)),
            "line 5: a sigma is not finite and positive",
        ),
    ];
    for (spoil, said) in spoils {
        let mut bad = rows.clone();
        spoil(&mut bad[3]);
        let set = MeasurementSet::from_rows(bad);
        let e = identify(&robot, &set, &Options::default())
            .unwrap_err()
            .to_string();
        assert!(e.contains(said), "identify: {e}");
        let e = evaluate_model(&robot, &set, Measure::Position)
            .unwrap_err()
            .to_string();
        assert!(e.contains(said), "evaluate: {e}");
        let e = Compensator::train(&robot, &set, &CompensatorOptions::default(), &|_, _| {})
            .unwrap_err()
            .to_string();
        assert!(e.contains(said), "train: {e}");
    }
    let e = identify(
        &robot,
        &MeasurementSet::from_rows(Vec::new()),
        &Options::default(),
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("no rows to identify from"), "{e}");
    // IK: a NaN seed or target is refused.
    let start = IkStart::choose(&robot, None).unwrap();
    let mut ik = IkSolver::new(RobotModel::new(&robot), start, IkOptions::default());
    let target = tool_pose(&robot, &[0.1, 0.2, -0.1, 0.3, -0.4, 0.5]);
    let nan = [f64::NAN; 6];
    assert!(matches!(
        ik.nearest(&target, Some(&nan)),
        Err(IkFailure::BadSeed(_))
    ));
    let mut lost = target;
    lost.translation.vector.x = f64::NAN;
    assert!(ik.nearest(&lost, None).is_err());
    assert!(ik.nearest(&target, None).is_ok());
}
