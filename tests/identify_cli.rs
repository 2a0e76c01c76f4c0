//! `robocal identify`, `evaluate`, `split` and `reproduce` from the command line.

mod common;
use common::{FANUC, accuracy, robocal, stderr, stdout, tmp};

fn text(o: &std::process::Output) -> (String, String) {
    (stdout(o), stderr(o))
}

#[test]
fn identify_writes_a_robot_and_a_report_that_evaluate_confirms() {
    let out = tmp("b.toml");
    let report = tmp("b.json");
    let o = robocal(&[
        "identify",
        "--robot",
        FANUC,
        "--data",
        "datasets/case_b_sim/calibration.csv",
        "--validate",
        "datasets/case_b_sim/validation_truth.csv",
        "--out",
        out.to_str().unwrap(),
        "--report",
        report.to_str().unwrap(),
    ]);
    let (stdout, stderr) = text(&o);
    assert!(o.status.success(), "{stderr}");
    assert!(
        stdout.contains("left out theta1") && stdout.contains("regroups with"),
        "{stdout}"
    );
    assert!(
        stdout.contains("note: the base row (mdh) is identified as the equivalent 6-DOF transform"),
        "{stdout}"
    );
    let r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap();
    assert_eq!(r["kind"], "identify");
    for key in ["calibration", "validation"] {
        for stat in ["mean", "rms", "max"] {
            let a = accuracy(&r, key, "after");
            assert!(
                a["position_mm"][stat].is_number(),
                "{key}.position_mm.{stat}"
            );
            assert!(
                a["orientation_deg"][stat].is_number(),
                "{key}.orientation_deg.{stat}"
            );
        }
    }
    assert!(
        r["parameters"]
            .as_array()
            .unwrap()
            .iter()
            .all(|p| p["name"].is_string() && p["std"].as_f64().unwrap() > 0.0)
    );
    assert_eq!(r["dropped"].as_array().unwrap().len(), 6);
    assert!(r["condition_number"].as_f64().unwrap() > 1.0);
    assert!(r["iterations"].as_u64().unwrap() > 0);
    assert_eq!(r["stop_reason"], "function");
    let val_mean = accuracy(&r, "validation", "after")["position_mm"]["mean"]
        .as_f64()
        .unwrap();
    assert!(val_mean < 0.1, "{val_mean}");

    // The written robot is a normal robot file: evaluate gives the same validation figure.
    let eval_report = tmp("e.json");
    let o = robocal(&[
        "evaluate",
        "--robot",
        out.to_str().unwrap(),
        "--data",
        "datasets/case_b_sim/validation_truth.csv",
        "--report",
        eval_report.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", text(&o).1);
    let e: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&eval_report).unwrap()).unwrap();
    let m = accuracy(&e, "data", "model")["position_mm"]["mean"]
        .as_f64()
        .unwrap();
    assert!((m - val_mean).abs() < 1e-9, "{m} vs {val_mean}");
}

#[test]
fn identify_on_real_ur10_through_the_profile_with_a_split() {
    let (a, b) = (tmp("ur_cal.csv"), tmp("ur_val.csv"));
    let o = robocal(&[
        "split",
        "datasets/ipa-ur10/Series_B/measurements_joint_configurations.csv",
        "--profile",
        "datasets/profiles/ipa_ur10.toml",
        "--robot",
        "datasets/robots/ur10.toml",
        "--seed",
        "1",
        "--out-a",
        a.to_str().unwrap(),
        "--out-b",
        b.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", text(&o).1);
    assert!(text(&o).1.contains("748 into"), "{}", text(&o).1);
    let report = tmp("ur.json");
    let o = robocal(&[
        "identify",
        "--robot",
        "datasets/robots/ur10.toml",
        "--data",
        a.to_str().unwrap(),
        "--validate",
        b.to_str().unwrap(),
        "--out",
        tmp("ur.toml").to_str().unwrap(),
        "--report",
        report.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", text(&o).1);
    let r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap();
    assert!(
        accuracy(&r, "validation", "after")["position_mm"]["rms"]
            .as_f64()
            .unwrap()
            <= 0.5
    );
    assert!(r["registration_rms_mm"].as_f64().unwrap() < 5.0);
    // The tracker's sigmas are far below what the model leaves: the unmodelled error added
    // to them is printed, and is the report's, in its units (mm, rad).
    let tau = &r["unmodelled"];
    let (p, rot) = (
        tau["position_mm"].as_f64().unwrap(),
        tau["rotation_rad"].as_f64().unwrap(),
    );
    assert!(
        (0.15..0.4).contains(&p) && (2e-4..2e-3).contains(&rot),
        "{tau}"
    );
    let out = text(&o).0;
    let line = format!(
        "an unmodelled error (position {p:.4} mm, orientation {:.4} mrad)",
        rot * 1e3
    );
    assert!(out.contains(&line), "{out}");
}

#[test]
fn identify_errors_exit_nonzero() {
    let o = robocal(&[
        "identify",
        "--robot",
        FANUC,
        "--data",
        "datasets/case_a/calibration.csv",
        "--measure",
        "pose",
        "--out",
        tmp("x.toml").to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(1));
    assert!(
        text(&o).1.contains("needs position and orientation"),
        "{}",
        text(&o).1
    );
    let o = robocal(&[
        "identify",
        "--robot",
        FANUC,
        "--data",
        "datasets/case_a/calibration.csv",
        "--params",
        "nope",
        "--out",
        tmp("y.toml").to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(1));
    assert!(!tmp("y.toml").exists());
}

#[test]
fn reproduce_prints_the_thesis_beside_ours() {
    let o = robocal(&["reproduce", "--seeds", "3"]);
    let (stdout, stderr) = text(&o);
    assert!(o.status.success(), "{stderr}");
    for needle in [
        "case A",
        "case B-sim",
        "case C",
        "case D",
        "thesis: validation position mm",
        "median",
    ] {
        assert!(stdout.contains(needle), "{needle} missing in {stdout}");
    }
}
