//! The command line: batch FK and IK, carried-through columns, and errors with exit codes.

mod common;
use common::{FANUC, robocal, stderr, stdout, tmp};

use std::path::Path;

#[test]
fn fk_single_configuration() {
    let o = robocal(&[
        "fk",
        "--robot",
        FANUC,
        "--q",
        "0,0,0,0,0,0",
        "--decimals",
        "3",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(
        stdout(&o),
        "q1,q2,q3,q4,q5,q6,x,y,z,rz,ry,rx\n0,0,0,0,0,0,2032.000,-182.000,1970.000,90.000,0.000,90.000\n"
    );
}

#[test]
fn fk_batch_carries_columns_and_ik_batch_round_trips() {
    let fk_out = tmp("fk.csv");
    let o = robocal(&[
        "fk",
        "--robot",
        FANUC,
        "--joints",
        "datasets/joints/fanuc_demo.csv",
        "--out",
        fk_out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = std::fs::read_to_string(&fk_out).unwrap();
    let mut lines = text.lines();
    assert_eq!(lines.next().unwrap(), "id,q1,q2,q3,q4,q5,q6,x,y,z,rz,ry,rx");
    assert!(lines.next().unwrap().starts_with("home,0,0,0,0,0,0,2032,"));
    assert_eq!(text.lines().count(), 6);

    // The FK output fed to IK: its q columns become per-row seeds; the nearest solution is
    // the generating configuration.
    let ik_out = tmp("ik.csv");
    let o = robocal(&[
        "ik",
        "--robot",
        FANUC,
        "--poses",
        fk_out.to_str().unwrap(),
        "--out",
        ik_out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let t = robocal::data::Table::read(&ik_out).unwrap();
    assert_eq!(t.headers[0], "id");
    assert_eq!(t.headers[1], "seed_q1");
    let sol: Vec<usize> = (1..=6)
        .map(|i| t.require(&format!("q{i}")).unwrap())
        .collect();
    let seed: Vec<usize> = (1..=6)
        .map(|i| t.require(&format!("seed_q{i}")).unwrap())
        .collect();
    assert_eq!(t.rows.len(), 5);
    for r in 0..t.rows.len() {
        let a = t.numbers(r, &sol).unwrap();
        let b = t.numbers(r, &seed).unwrap();
        for (x, y) in a.iter().zip(&b) {
            assert!((x - y).abs() < 1e-6, "row {r}: {a:?} vs {b:?}");
        }
    }
    // The IK output fed to IK again: its solutions are the seeds now, and its own seeds are
    // carried as input_seed_q1.. (they were refused as a column written twice).
    let o = robocal(&["ik", "--robot", FANUC, "--poses", ik_out.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let again = stdout(&o);
    let header: Vec<&str> = again.lines().next().unwrap().split(',').collect();
    assert_eq!(&header[..3], ["id", "input_seed_q1", "input_seed_q2"]);
    let at = |name: &str| header.iter().position(|h| *h == name).unwrap();
    assert!(
        at("input_seed_q6") < at("seed_q1") && at("seed_q1") < at("q1"),
        "{header:?}"
    );
    let rows: Vec<Vec<&str>> = again
        .lines()
        .skip(1)
        .map(|l| l.split(',').collect())
        .collect();
    assert_eq!(rows.len(), t.rows.len());
    for (r, row) in rows.iter().enumerate() {
        for i in 1..=6 {
            let seed: f64 = row[at(&format!("seed_q{i}"))].parse().unwrap();
            let was: f64 = t.rows[r][sol[i - 1]].parse().unwrap();
            assert_eq!(seed, was, "row {r}: q{i} read as the seed");
        }
    }
}

#[test]
fn ik_all_solutions_as_json() {
    let o = robocal(&[
        "ik",
        "--robot",
        FANUC,
        "--pose",
        "1842,0,1652,0,90,0",
        "--all",
        "--json",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_str(&stdout(&o)).unwrap();
    let rows = v.as_array().unwrap();
    assert!(rows.len() >= 2, "{v}");
    assert!(
        rows.iter()
            .all(|r| r["status"] == "ok" && r["q1"].is_number())
    );
}

/// Joints of four turns each way give the UR10 more than 10,000 solutions of a pose: `--all`
/// fails as too many, and says so without calling the pose unsolvable ("no solution for the
/// pose: too-many", before); one solution is still found.
#[test]
fn ik_all_with_too_many_solutions_says_so() {
    let ur10 = std::fs::read_to_string(common::root().join("datasets/robots/ur10.toml")).unwrap();
    let wide = tmp("ur10_wide.toml");
    std::fs::write(
        &wide,
        ur10.replace("limits = [-360.0, 360.0]", "limits = [-1440.0, 1440.0]"),
    )
    .unwrap();
    let pose = ["--pose", "-402.7,-520.9,1162.1,-120,15,-95"];
    let args = |all: bool| {
        let mut v = vec!["ik", "--robot", wide.to_str().unwrap()];
        v.extend(pose);
        v.extend(all.then_some("--all"));
        v
    };
    let o = robocal(&args(true));
    assert_eq!(o.status.code(), Some(1));
    let err = stderr(&o);
    assert!(
        err.contains("the pose is not solved: too-many: more than 10000 solutions")
            && !err.contains("no solution"),
        "{err}"
    );
    let o = robocal(&args(false));
    assert!(o.status.success(), "{}", stderr(&o));
}

#[test]
fn ik_of_a_ur_arm_is_closed_form_and_without_one_numerical() {
    // The UR10 has a closed form (the UR class): without a seed, its solution nearest the
    // middle of the ranges; with one, the configuration the pose came from, exactly.
    let ur = "datasets/robots/ur10.toml";
    let o = robocal(&["fk", "--robot", ur, "--q", "10,-80,70,-60,-80,20"]);
    let line = stdout(&o).lines().nth(1).unwrap().to_string();
    let pose: Vec<&str> = line.split(',').skip(6).collect();
    let pose = pose.join(",");
    let o = robocal(&["ik", "--robot", ur, "--pose", &pose, "--decimals", "9"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(!stderr(&o).contains("note:"), "{}", stderr(&o));
    // The elbow's other solution (q2 + q3 + q4 kept), nearer the middle (0) than the pose's.
    assert!(
        stdout(&o).contains(
            ",1,10.000000000,-12.689233103,-70.000000000,12.689233103,-80.000000000,20.000000000,ok"
        ),
        "{}",
        stdout(&o)
    );
    let o = robocal(&[
        "ik",
        "--robot",
        ur,
        "--pose",
        &pose,
        "--seed",
        "12,-78,72,-61,-79,18",
        "--decimals",
        "9",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stdout(&o).contains(
            ",1,10.000000000,-80.000000000,70.000000000,-60.000000000,-80.000000000,20.000000000,ok"
        ),
        "{}",
        stdout(&o)
    );
    // Axis 3 tilted by 0.1 deg: no closed form, so numerical solves from the seed, or
    // without one from starts spread around the middle of the ranges.
    let text = std::fs::read_to_string(ur).unwrap();
    let at = text.find("# elbow").unwrap();
    let tilted = format!(
        "{}{}",
        &text[..at],
        text[at..].replacen("alpha = 0.0", "alpha = 0.1", 1)
    );
    let tilted_path = tmp("ur10_tilted.toml");
    std::fs::write(&tilted_path, tilted).unwrap();
    let tilted = tilted_path.to_str().unwrap();
    let o = robocal(&["fk", "--robot", tilted, "--q", "10,-80,70,-60,-80,20"]);
    let line = stdout(&o).lines().nth(1).unwrap().to_string();
    let pose: Vec<&str> = line.split(',').skip(6).collect();
    let pose = pose.join(",");
    let o = robocal(&["ik", "--robot", tilted, "--pose", &pose, "--decimals", "3"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("no spherical wrist, nor is it of the UR class")
            && stderr(&o).contains("without one, from starts spread around the middle"),
        "{}",
        stderr(&o)
    );
    // The elbow's other solution, as on the untilted arm (it was "no-seed" before).
    assert!(
        stdout(&o).contains(",1,10.007,-12.664,-70.053,12.723,-80.106,19.958,ok"),
        "{}",
        stdout(&o)
    );
    let o = robocal(&[
        "ik",
        "--robot",
        tilted,
        "--pose",
        &pose,
        "--seed",
        "12,-78,72,-61,-79,18",
        "--decimals",
        "6",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stdout(&o).contains(",1,10.000000,-80.000000,70.000000,-60.000000,-80.000000,20.000000,ok"),
        "{}",
        stdout(&o)
    );
}

#[test]
fn unreachable_pose_is_an_error_for_one_pose_and_marked_in_a_batch() {
    let o = robocal(&["ik", "--robot", FANUC, "--pose", "9000,0,0,0,0,0"]);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("unreachable"), "{}", stderr(&o));
    let input = tmp("far.csv");
    std::fs::write(&input, "id,x,y,z,rz,ry,rx\nfar,9000,0,0,0,0,0\n").unwrap();
    let o = robocal(&["ik", "--robot", FANUC, "--poses", input.to_str().unwrap()]);
    // As `compensate`: the file is written, and the exit code says a pose has no solution.
    assert_eq!(o.status.code(), Some(3), "{}", stderr(&o));
    assert!(
        stdout(&o).contains("far,9000,0,0,0,0,0,,,,,,,,unreachable"),
        "{}",
        stdout(&o)
    );
    let line = format!("{}:2: ", input.display());
    assert!(stderr(&o).contains(&line), "{}", stderr(&o));
}

fn expect_failure(args: &[&str], needles: &[&str]) {
    let o = robocal(args);
    assert_eq!(o.status.code(), Some(1), "{args:?}: {}", stderr(&o));
    let e = stderr(&o);
    for n in needles {
        assert!(e.contains(n), "{args:?}: `{n}` not in: {e}");
    }
}

#[test]
fn bad_inputs_name_file_line_and_field() {
    let bad_robot = tmp("bad.toml");
    let text = std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join(FANUC)).unwrap();
    std::fs::write(&bad_robot, text.replacen("a = 312.0", "a = \"312\"", 1)).unwrap();
    let bad = bad_robot.to_str().unwrap();
    expect_failure(
        &["fk", "--robot", bad, "--q", "0,0,0,0,0,0"],
        &["bad.toml:", "a", "number"],
    );

    let csv = tmp("bad.csv");
    std::fs::write(
        &csv,
        "id,q1,q2,q3,q4,q5,q6\nok,0,0,0,0,0,0\nbroken,0,0,abc,0,0,0\n",
    )
    .unwrap();
    expect_failure(
        &["fk", "--robot", FANUC, "--joints", csv.to_str().unwrap()],
        &["bad.csv:3", "q3", "abc"],
    );

    let short = tmp("short.csv");
    std::fs::write(&short, "q1,q2,q3,q4,q5,q6\n0,0,0,0,0\n").unwrap();
    expect_failure(
        &["fk", "--robot", FANUC, "--joints", short.to_str().unwrap()],
        &["short.csv:2", "cells"],
    );

    let missing = tmp("missing.csv");
    std::fs::write(&missing, "q1,q2,q3,q4,q5\n0,0,0,0,0\n").unwrap();
    expect_failure(
        &[
            "fk",
            "--robot",
            FANUC,
            "--joints",
            missing.to_str().unwrap(),
        ],
        &["missing.csv", "q6", "missing column"],
    );

    // A flag's value of the wrong length: a usage error.
    let o = robocal(&["fk", "--robot", FANUC, "--q", "0,0,0"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("--q: 3 values given, 6 expected"));
    expect_failure(
        &["fk", "--robot", "nope.toml", "--q", "0,0,0,0,0,0"],
        &["nope.toml"],
    );

    // A failed run leaves no output file behind.
    let out = tmp("never.csv");
    let _ = robocal(&[
        "fk",
        "--robot",
        FANUC,
        "--joints",
        csv.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(!out.exists());
}
