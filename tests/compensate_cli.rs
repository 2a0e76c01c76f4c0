//! `robocal compensate` from the command line: commands that the nominal model turns back into
//! the solved joints, position-only targets, marked failures and bad input.

mod common;
use common::{FANUC, identify_case_d, robocal, stderr, stdout, tmp};

fn identified() -> std::path::PathBuf {
    let model = tmp("cd_full.toml");
    if !model.exists() {
        identify_case_d(&model, &[]);
    }
    model
}

fn csv(text: &str) -> Vec<Vec<String>> {
    csv::ReaderBuilder::new()
        .has_headers(false)
        .from_reader(text.as_bytes())
        .records()
        .map(|r| r.unwrap().iter().map(str::to_string).collect())
        .collect()
}

fn col(rows: &[Vec<String>], name: &str) -> usize {
    rows[0].iter().position(|h| h == name).unwrap()
}

fn compensate(
    model: &std::path::Path,
    targets: &std::path::Path,
    extra: &[&str],
) -> std::process::Output {
    let mut args = vec![
        "compensate",
        "--nominal",
        FANUC,
        "--robot",
        model.to_str().unwrap(),
        "--targets",
        targets.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    robocal(&args)
}

#[test]
fn commands_are_what_the_nominal_model_reaches_at_the_solved_joints() {
    let model = identified();
    // Desired poses: the true robot's poses of five test configurations, with their joints
    // as seeds.
    let truth = std::fs::read_to_string("datasets/case_d/test_truth.csv").unwrap();
    let targets = tmp("targets.csv");
    std::fs::write(
        &targets,
        truth.lines().take(6).collect::<Vec<_>>().join("\n"),
    )
    .unwrap();
    let out = tmp("commands.csv");
    let o = compensate(&model, &targets, &["--out", out.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("5 of 5 targets solved"),
        "{}",
        stderr(&o)
    );
    let rows = csv(&std::fs::read_to_string(&out).unwrap());
    assert_eq!(rows.len(), 6);
    for h in [
        "seed_q1",
        "branch",
        "q1",
        "q6",
        "cmd_x",
        "cmd_rx",
        "residual_mm",
        "status",
    ] {
        col(&rows, h);
    }
    // The controller's view: the nominal closed form of each cmd_ pose, seeded with q1..q6,
    // gives q1..q6 back.
    let cmds = tmp("cmd_poses.csv");
    let mut text = String::from("x,y,z,rz,ry,rx,q1,q2,q3,q4,q5,q6\n");
    for r in rows.iter().skip(1) {
        let mut cells: Vec<String> = ["x", "y", "z", "rz", "ry", "rx"]
            .iter()
            .map(|c| r[col(&rows, &format!("cmd_{c}"))].clone())
            .collect();
        cells.extend((1..=6).map(|i| r[col(&rows, &format!("q{i}"))].clone()));
        text.push_str(&(cells.join(",") + "\n"));
        assert!(r[col(&rows, "branch")].starts_with('s'), "branch is text");
    }
    std::fs::write(&cmds, text).unwrap();
    let o = robocal(&["ik", "--robot", FANUC, "--poses", cmds.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let back = csv(&stdout(&o));
    for (r, b) in rows.iter().zip(&back).skip(1) {
        for i in 1..=6 {
            let q: f64 = r[col(&rows, &format!("q{i}"))].parse().unwrap();
            let k: f64 = b[col(&back, &format!("q{i}"))].parse().unwrap();
            assert!(
                (q - k).abs() < 1e-6,
                "q{i}: command {q} deg, controller {k} deg"
            );
        }
    }
    // robocal fk of the nominal robot at q1..q6 gives the cmd_ columns.
    let joints = tmp("joints.csv");
    let qs: Vec<String> = rows
        .iter()
        .map(|r| {
            (1..=6)
                .map(|i| r[col(&rows, &format!("q{i}"))].clone())
                .collect::<Vec<_>>()
                .join(",")
        })
        .collect();
    std::fs::write(&joints, qs.join("\n")).unwrap();
    let o = robocal(&["fk", "--robot", FANUC, "--joints", joints.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let fk = csv(&stdout(&o));
    for (r, f) in rows.iter().zip(&fk).skip(1) {
        assert_eq!(r[col(&rows, "status")], "ok");
        for c in ["x", "y", "z", "rz", "ry", "rx"] {
            let a: f64 = r[col(&rows, &format!("cmd_{c}"))].parse().unwrap();
            let b: f64 = f[col(&fk, c)].parse().unwrap();
            assert!((a - b).abs() < 1e-9, "{c}: {a} vs {b}");
        }
        // The commands differ from the desired poses by the calibration (mm).
        let d: f64 = (0..3)
            .map(|k| {
                let c = ["x", "y", "z"][k];
                let a: f64 = r[col(&rows, &format!("cmd_{c}"))].parse().unwrap();
                let b: f64 = r[col(&rows, c)].parse().unwrap();
                (a - b).powi(2)
            })
            .sum::<f64>()
            .sqrt();
        assert!(d > 1.0 && d < 50.0, "{d}");
    }
}

#[test]
fn position_targets_keep_the_seed_orientation_and_failures_are_marked() {
    let model = identified();
    let targets = tmp("positions.csv");
    // Row 2: position-only without a seed cannot be solved (its orientation is undefined) ...
    std::fs::write(&targets, "name,x,y,z\na,1400,100,1800\nb,1e5,0,0\n").unwrap();
    let out = tmp("position_commands.csv");
    let o = compensate(
        &model,
        &targets,
        &["--out", out.to_str().unwrap(), "--seed", "5,10,0,10,45,0"],
    );
    let err = stderr(&o);
    // Exit 3: some targets failed, the file holds every row.
    assert_eq!(o.status.code(), Some(3), "{err}");
    assert!(
        err.contains("warning: 1 of 2 targets have no command"),
        "{err}"
    );
    assert!(
        err.contains("positions.csv:3: unreachable: the target is 99999 mm from the robot's base"),
        "{err}"
    );
    let rows = csv(&std::fs::read_to_string(&out).unwrap());
    assert_eq!(rows[0][..7], ["name", "x", "y", "z", "rz", "ry", "rx"]);
    assert_eq!(rows[1][col(&rows, "status")], "ok");
    assert!(rows[2][col(&rows, "status")].starts_with("unreachable"));
    assert_eq!(rows[2][col(&rows, "q1")], "", "a failed row has no joints");
    assert_eq!(
        rows[2][col(&rows, "cmd_x")],
        "",
        "a failed row has no command"
    );
    // The orientation written for row 1 is the calibrated robot's at the seed.
    let seed_pose = robocal(&[
        "fk",
        "--robot",
        model.to_str().unwrap(),
        "--q",
        "5,10,0,10,45,0",
    ]);
    let fk = csv(&stdout(&seed_pose));
    for c in ["rz", "ry", "rx"] {
        let a: f64 = rows[1][col(&rows, c)].parse().unwrap();
        let b: f64 = fk[1][col(&fk, c)].parse().unwrap();
        assert!((a - b).abs() < 1e-9, "{c}: {a} vs {b}");
    }
    // Without any seed, position-only targets are refused row by row.
    let o = compensate(&model, &targets, &[]);
    assert_eq!(o.status.code(), Some(3));
    assert!(
        stderr(&o).contains("positions.csv:2: no-seed"),
        "{}",
        stderr(&o)
    );
}

#[test]
fn bad_input_names_file_line_and_column() {
    let model = identified();
    let bad = tmp("bad_targets.csv");
    for (text, want) in [
        ("x,z\n1,2\n", "bad_targets.csv:1: field `y`"),
        ("x,y,z,rz\n1,2,3,4\n", "field `ry`"),
        ("x,y,z\n1,abc,3\n", "bad_targets.csv:2: field `y`"),
        ("x,y,z,q1,q2\n1,2,3,4,5\n", "field `q3`"),
    ] {
        std::fs::write(&bad, text).unwrap();
        let out = tmp("never.csv");
        let o = compensate(&model, &bad, &["--out", out.to_str().unwrap()]);
        assert_eq!(o.status.code(), Some(1), "{text}");
        assert!(stderr(&o).contains(want), "{text}: {}", stderr(&o));
        assert!(!out.exists(), "{text}: no output on bad input");
    }
    // Output columns in the input (a previous output fed back in) are kept under
    // `input_<name>`, as in every command that carries columns; a name that would still
    // appear twice is refused.
    let out = tmp("carried.csv");
    std::fs::write(&bad, "x,y,z,rz,ry,rx,status\n2000,0,1500,90,0,90,taught\n").unwrap();
    let o = compensate(&model, &bad, &["--out", out.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let written = std::fs::read_to_string(&out).unwrap();
    let header = written.lines().next().unwrap();
    assert!(
        header.contains("input_status") && written.contains("taught"),
        "{written}"
    );
    std::fs::write(
        &bad,
        "x,y,z,rz,ry,rx,status,input_status\n2000,0,1500,90,0,90,a,b\n",
    )
    .unwrap();
    let o = compensate(&model, &bad, &[]);
    assert_eq!(o.status.code(), Some(1));
    assert!(
        stderr(&o).contains("field `input_status`: this column would appear twice"),
        "{}",
        stderr(&o)
    );
}

#[test]
fn a_nominal_model_without_closed_form_solves_from_the_seeds() {
    // A nominal robot without a closed form needs a seed for every target: the row is
    // marked, the run exits with the code of failed targets (3).
    let good = tmp("ur10_targets.csv");
    std::fs::write(&good, "x,y,z,rz,ry,rx\n2000,0,1500,90,0,90\n").unwrap();
    let out = tmp("ur10_commands.csv");
    let ur10_path = "datasets/robots/ur10.toml";
    let ur10_nominal = |robot: &str, targets: &std::path::Path, out: &std::path::Path| {
        let (targets, out) = (targets.to_str().unwrap(), out.to_str().unwrap());
        robocal(&[
            "compensate",
            "--nominal",
            ur10_path,
            "--robot",
            robot,
            "--targets",
            targets,
            "--out",
            out,
            "--decimals",
            "9",
        ])
    };
    let o = ur10_nominal(ur10_path, &good, &out);
    assert_eq!(o.status.code(), Some(3), "{}", stderr(&o));
    let err = stderr(&o);
    assert!(
        err.contains("no closed-form inverse kinematics")
            && err.contains(":2: no-seed: the nominal model has no closed form")
            && err.contains("(give q1..qN columns or --seed)"),
        "{err}"
    );
    assert!(std::fs::read_to_string(&out).unwrap().contains("no-seed"));
    // Seeded, the target is solved: the UR10 as both models, so the command is the target
    // itself and the joints the configuration it was made at (the seed 3 deg away), with an
    // empty branch.
    let ur10 = robocal::model::read_robot(ur10_path).unwrap();
    let q = [30.0f64, -70.0, 80.0, -100.0, -60.0, 20.0];
    let pose = robocal::kinematics::pose_to_file(&robocal::kinematics::tool_pose(
        &ur10,
        &q.map(f64::to_radians),
    ));
    let cells: Vec<String> = pose
        .iter()
        .chain(&q.map(|v| v + 3.0))
        .map(|v| format!("{v:.12}"))
        .collect();
    std::fs::write(
        &good,
        format!("x,y,z,rz,ry,rx,q1,q2,q3,q4,q5,q6\n{}\n", cells.join(",")),
    )
    .unwrap();
    let o = ur10_nominal(ur10_path, &good, &out);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(!stderr(&o).contains("across frames"), "{}", stderr(&o));
    let rows = csv(&std::fs::read_to_string(&out).unwrap());
    let cell = |name: &str| rows[1][col(&rows, name)].clone();
    assert_eq!(
        (cell("branch").as_str(), cell("status").as_str()),
        ("", "ok")
    );
    for (j, want) in q.iter().enumerate() {
        let got: f64 = cell(&format!("q{}", j + 1)).parse().unwrap();
        assert!(
            (got - want).abs() < 1e-6,
            "q{}: {got} against {want}",
            j + 1
        );
    }
    for (c, want) in ["cmd_x", "cmd_y", "cmd_z"].iter().zip(&pose) {
        let got: f64 = cell(c).parse().unwrap();
        assert!((got - want).abs() < 1e-6, "{c}: {got} against {want}");
    }
    // A calibrated base registered 3 m away (a tracker's frame): the summary separates the
    // change of frame from the correction, here none (the same arm).
    let text = std::fs::read_to_string(ur10_path).unwrap();
    let moved_text = text.replacen("x = 0.0", "x = 3000.0", 1);
    assert_ne!(moved_text, text);
    let moved = tmp("ur10_moved_base.toml");
    std::fs::write(&moved, &moved_text).unwrap();
    let pose = robocal::kinematics::pose_to_file(&robocal::kinematics::tool_pose(
        &robocal::model::Robot::from_toml(&moved_text).unwrap(),
        &q.map(f64::to_radians),
    ));
    let cells: Vec<String> = pose.iter().chain(&q).map(|v| format!("{v:.12}")).collect();
    std::fs::write(
        &good,
        format!("x,y,z,rz,ry,rx,q1,q2,q3,q4,q5,q6\n{}\n", cells.join(",")),
    )
    .unwrap();
    let o = ur10_nominal(moved.to_str().unwrap(), &good, &out);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let err = stderr(&o);
    assert!(
        err.contains("by 3000.000 mm on average")
            && err
                .contains("across frames: the calibrated model's base lies 3000.0 mm and 0.0 deg")
            && err.contains("the targets move by 0.000 mm on average (max 0.000 mm)"),
        "{err}"
    );
}
