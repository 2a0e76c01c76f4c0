//! `robocal plan` from the command line: planned files, their prediction read back through
//! `--evaluate`, constraints, pairs, and bad input.

mod common;
use common::{FANUC, json, robocal, stderr, stdout, tmp};

#[test]
fn a_plan_is_written_within_its_constraints_and_evaluate_predicts_it_the_same() {
    let out = tmp("plan.csv");
    let report = tmp("plan.json");
    let common = [
        "--robot",
        FANUC,
        "--seed",
        "4",
        "--margin-deg",
        "5",
        "--floor-mm",
        "300",
        "--pool",
        "800",
    ];
    let mut args = vec!["plan", "--count", "12"];
    args.extend(common);
    args.extend([
        "--out",
        out.to_str().unwrap(),
        "--report",
        report.to_str().unwrap(),
    ]);
    let o = robocal(&args);
    assert!(o.status.success(), "{}", stderr(&o));
    // The prediction's cloud is drawn within the floor too, and says so.
    assert!(
        stdout(&o).contains("validation configurations (drawn within --floor-mm too"),
        "{}",
        stdout(&o)
    );
    let text = std::fs::read_to_string(&out).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines[0], "id,q1,q2,q3,q4,q5,q6");
    assert_eq!(lines.len(), 13);
    let r = json(&report);
    assert_eq!(r["units"], 12);
    // What the plan was drawn from and held to, to run it again.
    let inputs = &r["inputs"];
    assert_eq!(
        (
            &inputs["seed"],
            &inputs["pool"],
            &inputs["count"],
            &inputs["margin_deg"]
        ),
        (
            &serde_json::json!(4),
            &serde_json::json!(800),
            &serde_json::json!(12),
            &serde_json::json!(5.0)
        ),
        "{inputs}"
    );
    assert_eq!(
        (
            &inputs["floor_mm"],
            &inputs["validation"],
            &inputs["forbid_mm"],
            &inputs["evaluate"]
        ),
        (
            &serde_json::json!(300.0),
            &serde_json::json!(300),
            &serde_json::Value::Null,
            &serde_json::Value::Null
        ),
        "{inputs}"
    );
    let robot = robocal::model::read_robot(common::root().join(FANUC)).unwrap();
    let rows = r["rows"].as_array().unwrap();
    assert_eq!(rows.len(), 12);
    for row in rows {
        let q: Vec<f64> = row
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_f64().unwrap())
            .collect();
        for (v, j) in q.iter().zip(robot.joints()) {
            assert!(
                *v >= j.limits[0] + 5.0 - 1e-9 && *v <= j.limits[1] - 5.0 + 1e-9,
                "{q:?}"
            );
        }
        let p = robocal::kinematics::tool_pose(&robot, &robot.joints_to_internal(&q));
        assert!(p.translation.vector.z >= 300.0);
    }
    let planned = r["prediction"]["position_mm"]["mean"].as_f64().unwrap();
    let random = r["random_prediction"]["position_mm"]["mean"]
        .as_f64()
        .unwrap();
    assert!(planned < random, "{planned} vs {random}");
    assert!(r["value"].as_f64().unwrap() >= r["greedy_value"].as_f64().unwrap());
    // Tagged as every report, `robocal report` reads it (it refused it before: no `kind`).
    assert_eq!(r["kind"], "plan");
    let run = tmp("plan_run");
    std::fs::create_dir_all(&run).unwrap();
    std::fs::copy(&report, run.join("plan.json")).unwrap();
    let html = tmp("plan_run.html");
    let o = robocal(&[
        "report",
        run.to_str().unwrap(),
        "--out",
        html.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let page = std::fs::read_to_string(&html).unwrap();
    assert!(
        page.contains("plan") && page.contains("not_identifiable"),
        "report page"
    );
    // The same prediction for the written file: same cloud (seed and constraints), same
    // units, through the file.
    let back = tmp("plan_eval.json");
    let mut args = vec!["plan", "--evaluate", out.to_str().unwrap()];
    args.extend(common);
    args.extend(["--report", back.to_str().unwrap()]);
    let o = robocal(&args);
    assert!(o.status.success(), "{}", stderr(&o));
    let e = json(&back)["prediction"]["position_mm"]["mean"]
        .as_f64()
        .unwrap();
    assert!((e - planned).abs() < 1e-6 * planned, "{e} vs {planned}");
    assert!(
        stdout(&o).contains("predicted error of 12 units"),
        "{}",
        stdout(&o)
    );
    // Seeded: the same command writes the same file.
    let again = tmp("plan2.csv");
    let mut args = vec!["plan", "--count", "12"];
    args.extend(common);
    args.extend(["--out", again.to_str().unwrap()]);
    assert!(robocal(&args).status.success());
    assert_eq!(std::fs::read(&again).unwrap(), text.as_bytes());
}

#[test]
fn distance_plans_pairs_and_a_target_finds_the_fewest_units() {
    let out = tmp("pairs.csv");
    let o = robocal(&[
        "plan",
        "--robot",
        FANUC,
        "--measure",
        "distance",
        "--count",
        "40",
        "--pool",
        "400",
        "--params",
        "offsets",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = std::fs::read_to_string(&out).unwrap();
    assert!(text.starts_with("id,pair,q1,"), "{text}");
    assert_eq!(text.lines().count(), 81);
    let t = tmp("target.json");
    let o = robocal(&[
        "plan",
        "--robot",
        FANUC,
        "--target-mm",
        "0.03",
        "--pool",
        "600",
        "--out",
        tmp("target.csv").to_str().unwrap(),
        "--report",
        t.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let r = json(&t);
    let n = r["units"].as_u64().unwrap() as usize;
    assert!(r["prediction"]["position_mm"]["mean"].as_f64().unwrap() <= 0.03);
    // One unit fewer misses the target.
    let fewer = tmp("fewer.json");
    let o = robocal(&[
        "plan",
        "--robot",
        FANUC,
        "--count",
        &(n - 1).to_string(),
        "--pool",
        "600",
        "--out",
        tmp("fewer.csv").to_str().unwrap(),
        "--report",
        fewer.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        json(&fewer)["prediction"]["position_mm"]["mean"]
            .as_f64()
            .unwrap()
            > 0.03
    );
}

#[test]
fn bad_plans_are_refused_with_the_reason() {
    let out = tmp("bad.csv");
    let o_ = out.to_str().unwrap();
    for (args, want) in [
        (vec!["--count", "3"], "equations"),
        (vec!["--count", "20", "--forbid", "1,2,3,4,5"], "--forbid"),
        (
            vec!["--count", "20", "--forbid", "5,0,0,1,1,1"],
            "minimum corner",
        ),
        (
            vec!["--count", "20", "--floor-mm", "100000"],
            "refuse nearly every",
        ),
        (vec!["--count", "20", "--margin-deg", "120"], "--margin-deg"),
        (
            vec!["--target-mm", "0.000001"],
            "the whole pool (300 units) predicts",
        ),
        (
            vec!["--count", "20", "--evaluate", "datasets/robots/ur10.toml"],
            "cannot be used",
        ),
        (
            vec![
                "--evaluate",
                "datasets/case_d/calibration.csv",
                "--params",
                "nonsense",
            ],
            "nonsense",
        ),
    ] {
        let mut a = vec!["plan", "--robot", FANUC, "--pool", "300", "--out", o_];
        a.extend(args.iter().copied());
        let o = robocal(&a);
        assert!(!o.status.success(), "{args:?}");
        assert!(stderr(&o).contains(want), "{args:?}: {}", stderr(&o));
        assert!(!out.exists(), "{args:?} left a file");
    }
    // More units than the pool holds: a flag's value at odds with another (exit code 2).
    let o = robocal(&[
        "plan", "--robot", FANUC, "--pool", "300", "--count", "301", "--out", o_,
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("--count 301: the candidates hold 300 units"),
        "{}",
        stderr(&o)
    );
    assert!(!out.exists());
    // A list to evaluate with a row beyond the limits: named, not dropped.
    let beyond = tmp("beyond.csv");
    std::fs::write(
        &beyond,
        "q1,q2,q3,q4,q5,q6\n0,0,0,0,-30,0\n400,0,0,0,-30,0\n",
    )
    .unwrap();
    let o = robocal(&[
        "plan",
        "--robot",
        FANUC,
        "--evaluate",
        beyond.to_str().unwrap(),
    ]);
    assert!(!o.status.success());
    assert!(
        stderr(&o)
            .contains("beyond.csv:3: field `q1`: joint 1 at 400.0000 deg, beyond [-150, 150]"),
        "{}",
        stderr(&o)
    );
    // A candidates file that is not one: its name and the missing column.
    let o = robocal(&[
        "plan",
        "--robot",
        FANUC,
        "--count",
        "10",
        "--candidates",
        "datasets/robots/ur10.toml",
        "--out",
        o_,
    ]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("ur10.toml"), "{}", stderr(&o));
}

/// A list that identifies fewer parameters than configurations spread over the region do is
/// evaluated with a warning naming what it leaves out (its prediction leaves their errors
/// out); a list that identifies them all is evaluated without one.
#[test]
fn a_list_that_identifies_less_than_a_spread_is_said_to_be_optimistic() {
    let same = tmp("plan_same30.csv");
    let mut text = String::from("q1,q2,q3,q4,q5,q6\n");
    for _ in 0..30 {
        text.push_str("10,20,30,40,50,60\n");
    }
    std::fs::write(&same, text).unwrap();
    let o = robocal(&[
        "plan",
        "--robot",
        FANUC,
        "--evaluate",
        same.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let err = stderr(&o);
    assert!(
        err.contains("the list identifies 6 of the 30 parameters") && err.contains("optimistic"),
        "{err}"
    );
    assert!(err.contains("a3") && !err.contains("theta1"), "{err}");
    let spread = tmp("plan_spread.csv");
    let o = robocal(&[
        "plan",
        "--robot",
        FANUC,
        "--count",
        "40",
        "--seed",
        "3",
        "--out",
        spread.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let o = robocal(&[
        "plan",
        "--robot",
        FANUC,
        "--evaluate",
        spread.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(!stderr(&o).contains("optimistic"), "{}", stderr(&o));
}

/// Candidates that hold a joint still identify less than configurations spread over the
/// region: the plan's prediction over the region's validation cloud leaves those parameters'
/// errors out, and says so (a review measured 0.037 mm predicted against 6.09 mm realised).
#[test]
fn candidates_that_identify_less_than_a_spread_are_said_to_be_optimistic() {
    let held = tmp("plan_q4_held.csv");
    let mut text = String::from("q1,q2,q3,q4,q5,q6\n");
    // A deterministic spread of every joint but q4, held at 10 deg.
    for k in 0..200 {
        let t = k as f64;
        text.push_str(&format!(
            "{},{},{},10,{},{}\n",
            -120.0 + (t * 37.0) % 240.0,
            -40.0 + (t * 13.0) % 80.0,
            -50.0 + (t * 29.0) % 100.0,
            -90.0 + (t * 53.0) % 180.0,
            -170.0 + (t * 71.0) % 340.0
        ));
    }
    std::fs::write(&held, text).unwrap();
    let o = robocal(&[
        "plan",
        "--robot",
        FANUC,
        "--candidates",
        held.to_str().unwrap(),
        "--count",
        "30",
        "--out",
        tmp("plan_q4_held_out.csv").to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let err = stderr(&o);
    assert!(
        err.contains("the candidates identify 26 of the 30 parameters")
            && err.contains("d4")
            && err.contains("optimistic")
            && err.contains(
                "a plan from them leaves them at their nominal values too (give \
                 candidates that move every joint)"
            ),
        "{err}"
    );
    // Its advice is one the command line takes (a --region beside --candidates is refused).
    assert!(!err.contains("--region"), "{err}");
}

/// A plan on a DH or MDH model with parallel axes says, as `identify` does, that the model
/// cannot express their tilt and that the prediction takes them as exactly parallel (a
/// reviewer's UR10 planned in DH predicted 0.0308 mm where axes 3 and 4 tilted by a
/// milliradian gave 0.4383); the UR10 with Hayati rows and the FANUC get no such note.
#[test]
fn a_plan_on_parallel_axes_without_a_hayati_row_says_so() {
    for (robot, noted) in [
        ("ur10.toml", true),
        ("ur10_mdh_hayati.toml", false),
        ("fanuc_r2000ib_210f.toml", false),
    ] {
        let o = robocal(&[
            "plan",
            "--robot",
            &format!("datasets/robots/{robot}"),
            "--count",
            "12",
            "--pool",
            "500",
            "--out",
            tmp(&format!("plan_parallel_{robot}.csv")).to_str().unwrap(),
        ]);
        assert!(o.status.success(), "{}", stderr(&o));
        let all = stdout(&o) + &stderr(&o);
        let note = "note: parallel axes: joints 2, 3 and 4: an MDH or DH description cannot \
                    express the small tilt out of parallel a real arm has, and the prediction \
                    takes those axes as exactly parallel";
        assert_eq!(all.contains(note), noted, "{robot}: {all}");
    }
}

/// A position plan predicts no orientation (the tool's rotation keeps its nominal value), an
/// orientation plan no position, neither on the screen nor in the report; a pose plan both.
#[test]
fn a_plan_predicts_only_what_its_measure_sees() {
    let out = tmp("plan_measure_sees.csv");
    let report = tmp("plan_measure_sees.json");
    for (measure, position, orientation) in [
        ("position", true, false),
        ("orientation", false, true),
        ("pose", true, true),
    ] {
        let o = robocal(&[
            "plan",
            "--robot",
            FANUC,
            "--count",
            "20",
            "--measure",
            measure,
            "--out",
            out.to_str().unwrap(),
            "--report",
            report.to_str().unwrap(),
        ]);
        assert!(o.status.success(), "{}", stderr(&o));
        let said = stdout(&o);
        let line = said
            .lines()
            .find(|l| l.starts_with("predicted error of 20 units"))
            .unwrap_or_else(|| panic!("{said}"));
        assert_eq!(line.contains(" mm,"), position, "{line}");
        assert_eq!(line.contains(" deg,"), orientation, "{line}");
        assert_eq!(line.contains("position not predicted"), !position, "{line}");
        assert_eq!(
            line.contains("orientation not predicted"),
            !orientation,
            "{line}"
        );
        let r = json(&report);
        let p = &r["prediction"];
        assert_eq!(p.get("position_mm").is_some(), position, "{p}");
        assert_eq!(p.get("orientation_deg").is_some(), orientation, "{p}");
    }
}

/// A selection short of `full` predicts the noise floor of its own parameters: the others are
/// taken as exact. A reviewer's `--params offsets` on the FANUC with Table 6.1's deviations
/// predicted 0.015 mm and gave 5.7 mm after identification, without a word, and ranked
/// better than `full` (0.040 mm). The warning names what `full` adds; `full` gets none.
#[test]
fn a_selection_short_of_full_is_said_to_take_the_others_as_exact() {
    let out = tmp("plan_partial.csv");
    let plan = |params: &str| {
        let o = robocal(&[
            "plan",
            "--robot",
            FANUC,
            "--count",
            "20",
            "--params",
            params,
            "--out",
            out.to_str().unwrap(),
        ]);
        assert!(o.status.success(), "{}", stderr(&o));
        stderr(&o)
    };
    let said = plan("offsets");
    assert!(
        said.contains(
            "warning: --params offsets leaves out 26 of the 30 parameters `full` identifies \
             (base.x, base.y, base.z, base.rz, base.ry, base.rx, tool.x, tool.y, tool.z, \
             tool.rz, tool.ry, tool.rx, alpha2, a2, d2, beta3, alpha3, a3, alpha4, a4, d4, \
             alpha5, a5, d5, alpha6, a6): the plan takes them as exact"
        ),
        "{said}"
    );
    let said = plan("joints");
    assert!(said.contains("leaves out 12 of the 30"), "{said}");
    for params in ["full", "full,compliance"] {
        let said = plan(params);
        assert!(!said.contains("leaves out"), "{params}: {said}");
    }
}

/// Positions of a point on the UR10's flange (the shipped file's tool) cannot identify a5 and
/// alpha5, which positions of a point off it can (`identify` found 25 parameters on the
/// measured Series A, whose reflector sits off the flange, where the plan said 23): `plan`
/// says so, and with the tool point moved off the flange in the file it plans for 25.
#[test]
fn a_position_plan_at_the_flange_says_what_an_offset_point_identifies() {
    let ur10 = common::root().join("datasets/robots/ur10.toml");
    let text = std::fs::read_to_string(&ur10).unwrap();
    let (head, tool) = text.split_at(text.find("[tool]").unwrap());
    let moved = tmp("ur10_off_tool.toml");
    std::fs::write(
        &moved,
        format!(
            "{head}{}",
            tool.replacen("x = 0.0", "x = 50.0", 1)
                .replacen("z = 0.0", "z = 100.0", 1)
        ),
    )
    .unwrap();
    let out = tmp("ur10_position_plan.csv");
    let plan = |robot: &std::path::Path, measure: &str| {
        let o = robocal(&[
            "plan",
            "--robot",
            robot.to_str().unwrap(),
            "--measure",
            measure,
            "--count",
            "40",
            "--pool",
            "600",
            "--seed",
            "1",
            "--out",
            out.to_str().unwrap(),
        ]);
        assert!(o.status.success(), "{}", stderr(&o));
        (stdout(&o), stderr(&o))
    };
    let (said, warned) = plan(&ur10, "position");
    assert!(said.contains("23 identifiable parameters"), "{said}");
    assert!(
        warned.contains("identify 2 parameter(s) more than the tool point's (a5, alpha5)"),
        "{warned}"
    );
    let (said, warned) = plan(&moved, "position");
    assert!(said.contains("25 identifiable parameters"), "{said}");
    assert!(
        !warned.contains("parameter(s) more than the tool point's"),
        "{warned}"
    );
    // Pairs of positions (relative) lose the same two at the flange.
    let (_, warned) = plan(&ur10, "relative");
    assert!(
        warned.contains("identify 2 parameter(s) more than the tool point's (a5, alpha5)"),
        "{warned}"
    );
}

/// A margin that leaves a joint no room is an error naming it (the FANUC's joint 2, limits
/// -50 to 70 deg, at 60 deg); one that leaves it under a tenth of its range is warned of.
#[test]
fn a_margin_that_leaves_a_joint_no_room_is_refused_and_a_narrow_one_warned_of() {
    let out = tmp("margin_plan.csv");
    let plan = |margin: &str| {
        robocal(&[
            "plan",
            "--robot",
            FANUC,
            "--count",
            "30",
            "--pool",
            "600",
            "--seed",
            "1",
            "--margin-deg",
            margin,
            "--out",
            out.to_str().unwrap(),
        ])
    };
    let o = plan("60");
    assert!(!o.status.success());
    assert!(
        stderr(&o).contains("joint 2: the margin (60.0 deg) leaves no room"),
        "{}",
        stderr(&o)
    );
    let o = plan("59.99");
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("leaves joint 2 0.020 deg of its 120.0 deg range (under a tenth)"),
        "{}",
        stderr(&o)
    );
    let o = plan("30");
    assert!(o.status.success() && !stderr(&o).contains("under a tenth"));
}

#[test]
fn a_region_that_holds_a_joint_at_one_value_is_warned_of() {
    let region = tmp("flat_region.toml");
    let ranges =
        |q3: &str| format!("ranges = [[-10, 10], [0, 20], {q3}, [-20, 20], [30, 60], [-30, 30]]\n");
    let plan = |name: &str| {
        let out = tmp(name);
        robocal(&[
            "plan",
            "--robot",
            FANUC,
            "--region",
            region.to_str().unwrap(),
            "--count",
            "30",
            "--out",
            out.to_str().unwrap(),
        ])
    };
    std::fs::write(&region, ranges("[5, 5]")).unwrap();
    let o = plan("flat_plan.csv");
    assert!(o.status.success(), "{}", stderr(&o));
    let err = stderr(&o);
    assert!(
        err.contains("the region holds joint 3 within 5.0000 to 5.0000 deg"),
        "{err}"
    );
    // A range of its own: nothing said.
    std::fs::write(&region, ranges("[5, 25]")).unwrap();
    let o = plan("wide_plan.csv");
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(!stderr(&o).contains("the region holds"), "{}", stderr(&o));
}

/// `plan --evaluate` without `--measure` predicts for what the file measures, as `identify`
/// reads it: Case A's file holds positions alone, so position (before 2026-12-02 pose, 13 %
/// more optimistic than the identification realises, with an orientation figure for data
/// that has none); `--measure pose` still plans for pose.
#[test]
fn evaluate_predicts_for_what_the_file_measures() {
    let file = "datasets/case_a/calibration.csv";
    let run = |extra: &[&str]| {
        let args = [&["plan", "--robot", FANUC, "--evaluate", file][..], extra].concat();
        let o = robocal(&args);
        assert!(o.status.success(), "{}", stderr(&o));
        stderr(&o) + &stdout(&o)
    };
    let text = run(&[]);
    assert!(
        text.contains(&format!(
            "note: {file}: measure position, as `identify` reads the file (of the measured \
             columns it holds the positions alone)"
        )) && text.contains("measure position, 27 identifiable parameters")
            && text.contains("orientation not predicted"),
        "{text}"
    );
    // A position measure has no orientation: --sigma-rot is said to be unused.
    let text = run(&["--sigma-rot", "1000"]);
    assert!(
        text.contains("note: --sigma-rot is not used: a position measure has no orientation"),
        "{text}"
    );
    let text = run(&["--measure", "pose"]);
    assert!(
        !text.contains("as `identify` reads the file") && text.contains("measure pose, 30"),
        "{text}"
    );
    // A ball-bar's file (joints, pairs, distances): distance, as `identify` reads it.
    let mut bar = String::from("q1,q2,q3,q4,q5,q6,pair,distance\n");
    for k in 0..40 {
        let v = f64::from(k);
        bar += &format!(
            "{},{},{},{},{},{},{},500\n",
            -60.0 + 3.0 * v,
            -30.0 + (v * 7.0) % 50.0,
            -20.0 + (v * 11.0) % 40.0,
            -90.0 + (v * 13.0) % 180.0,
            -60.0 + (v * 17.0) % 120.0,
            -90.0 + (v * 19.0) % 180.0,
            k / 2 + 1
        );
    }
    let path = tmp("plan_ballbar.csv");
    std::fs::write(&path, bar).unwrap();
    let o = robocal(&[
        "plan",
        "--robot",
        FANUC,
        "--evaluate",
        path.to_str().unwrap(),
    ]);
    let text = stderr(&o) + &stdout(&o);
    assert!(
        text.contains(
            "measure distance, as `identify` reads the file (of the measured columns \
                       it holds the distances alone)"
        ),
        "{text}"
    );
}

/// Rows `plan --out` takes from a given file (`--evaluate`, `--candidates`) are written as read
/// there, not carried through radians and back (which moved the last digit of some: a
/// reviewer's 32 of 480 cells).
#[test]
fn rows_from_a_given_file_are_written_as_read() {
    let drawn = tmp("plan_drawn.csv");
    let again = tmp("plan_again.csv");
    let picked = tmp("plan_picked.csv");
    let plan = |extra: &[&str]| {
        let o = robocal(&[&["plan", "--robot", FANUC][..], extra].concat());
        assert!(o.status.success(), "{}", stderr(&o));
    };
    let (d, g, p) = (
        drawn.to_str().unwrap(),
        again.to_str().unwrap(),
        picked.to_str().unwrap(),
    );
    plan(&["--count", "40", "--out", d]);
    plan(&["--evaluate", d, "--out", g]);
    plan(&["--candidates", d, "--count", "10", "--out", p]);
    let rows = |path: &std::path::Path| -> Vec<Vec<String>> {
        let mut r = csv::Reader::from_path(path).unwrap();
        r.records()
            .map(|x| x.unwrap().iter().map(String::from).collect())
            .collect()
    };
    let joints = |row: &[String], from: usize| -> Vec<f64> {
        row[from..from + 6]
            .iter()
            .map(|c| c.parse().unwrap())
            .collect()
    };
    let source = rows(&drawn);
    // id, q1..q6 in the drawn plan; id, source_line, q1..q6 in the two read from it.
    for path in [&again, &picked] {
        for row in rows(path) {
            let line: usize = row[1].parse().unwrap();
            assert_eq!(
                joints(&row, 2),
                joints(&source[line - 2], 1),
                "{path:?} line {line}"
            );
        }
    }
}

/// `plan --report` holds the warnings `plan` printed, in order: what the terminal said is what
/// the file holds (the report had none of them).
#[test]
fn the_report_holds_the_printed_warnings() {
    let (out, report) = (tmp("plan_warned.csv"), tmp("plan_warned.json"));
    let o = robocal(&[
        "plan",
        "--robot",
        "datasets/robots/ur10.toml",
        "--count",
        "20",
        "--measure",
        "position",
        "--params",
        "offsets",
        "--out",
        out.to_str().unwrap(),
        "--report",
        report.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let printed: Vec<String> = (stderr(&o).lines())
        .filter_map(|l| l.strip_prefix("warning: "))
        .map(String::from)
        .collect();
    assert!(printed.len() >= 2, "{}", stderr(&o));
    let kept: Vec<String> = (json(&report)["warnings"].as_array().unwrap().iter())
        .map(|w| w.as_str().unwrap().to_string())
        .collect();
    assert_eq!(kept, printed);
}
