//! The default compensator on simulated robots it was not designed on (issue 11, item 7: on a
//! simulated non-geometric robot the default must be >= 2.5x better than full geometric
//! alone). Each robot is drawn by a seed: geometric deviations of every parameter (random
//! sign, 0.2-3 mm or mrad), the joints' gravity compliance (payload, link masses and the
//! compliances drawn), and periodic gear errors of every joint; FANUC R-2000iB/210F and UR10
//! structures, pose and position-only measurements. The flow is a user's: `simulate`
//! (calibration, training and test sets), `identify --params full` on the calibration set,
//! `train` with no options on the training set, its validation against the test set's truth.
//! A second test takes a SCARA and a seven-joint arm, written here, through the same flow.
//!
//! About 12 s in a release build; the table: `cargo test --release --test simulated_robots --
//! --nocapture`.

mod common;

use common::{FANUC, accuracy, json, robocal, simulate_and_identify, stderr, stdout, tmp};
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use robocal::model::read_robot;
use std::fmt::Write as _;

const UR10: &str = "datasets/robots/ur10.toml";

/// One drawn robot: its structure, what the sensor measures, and its two files' text.
struct Drawn {
    structure: &'static str,
    measure: &'static str,
    deviations: String,
    nongeometric: String,
}

/// Draws a robot of `structure`'s deviations and non-geometric errors from `seed`.
fn draw(structure: &'static str, measure: &'static str, seed: u64) -> Drawn {
    let mut rng = StdRng::seed_from_u64(seed);
    let robot = read_robot(common::root().join(structure)).unwrap();
    let mut deviations = String::new();
    for id in robot.parameters() {
        let name = id.name();
        // Geometry only: the compliances are drawn below, in the simulator's own terms.
        if name.starts_with('c') || name.starts_with('k') {
            continue;
        }
        let size: f64 = rng.random_range(0.2..3.0);
        let sign = if rng.random_bool(0.5) { 1.0 } else { -1.0 };
        writeln!(deviations, "\"{name}\" = {:.3}", sign * size).unwrap();
    }
    // Masses (kg) and compliances (mrad per kN m) of the structure's size: a 210 kg-payload
    // FANUC's gears are stiff, a UR10's harmonic drives far less so.
    let (payload, masses, arm, wrist): (f64, [f64; 6], (f64, f64), (f64, f64)) =
        if structure == FANUC {
            (
                rng.random_range(20.0..210.0),
                [400.0, 220.0, 180.0, 30.0, 20.0, 5.0],
                (0.02, 0.1),
                (0.0, 0.5),
            )
        } else {
            (
                rng.random_range(0.0..10.0),
                [7.1, 12.7, 4.3, 1.2, 1.2, 0.25],
                (0.5, 3.0),
                (0.0, 5.0),
            )
        };
    let scale: f64 = rng.random_range(0.5..1.5);
    let masses = masses.map(|m| m * scale);
    let c = [
        0.0,
        rng.random_range(arm.0..arm.1),
        rng.random_range(arm.0..arm.1),
        rng.random_range(wrist.0..wrist.1),
        rng.random_range(wrist.0..wrist.1),
        0.0,
    ];
    let mut nongeometric = format!(
        "[compliance]\npayload_kg = {payload:.1}\nlink_masses_kg = {masses:?}\n\
         mrad_per_knm = {c:?}\ngravity = [0.0, 0.0, -9.81]\n"
    );
    for joint in 1..=6 {
        writeln!(
            nongeometric,
            "\n[[gear]]\njoint = {joint}\namplitude1_mrad = {:.3}\nphase1_deg = {:.1}\n\
             amplitude2_mrad = {:.3}\nphase2_deg = {:.1}",
            rng.random_range(0.01..0.1),
            rng.random_range(-180.0..180.0),
            rng.random_range(0.0..0.04),
            rng.random_range(-180.0..180.0),
        )
        .unwrap();
    }
    Drawn {
        structure,
        measure,
        deviations,
        nongeometric,
    }
}

/// `train` with no options on the files `file` names (the identified `full.toml`, the
/// training set), validated against the test set's truth: its output and JSON report.
fn train_default(file: &impl Fn(&str) -> String) -> (std::process::Output, serde_json::Value) {
    let report = file("train.json");
    let o = robocal(&[
        "train",
        "--robot",
        &file("full.toml"),
        "--data",
        &file("train.csv"),
        "--validate",
        &file("test_truth.csv"),
        "--out",
        &file("default.rcal"),
        "--report",
        &report,
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let r = json(std::path::Path::new(&report));
    (o, r)
}

/// Mean position error against the truth (mm) of the identified model and of the default
/// compensator on the test set, and the settings `train` chose.
fn run(index: usize, d: &Drawn, seed: u64) -> (f64, f64, String) {
    let file = |n: &str| {
        tmp(&format!("sim{index}_{n}"))
            .to_str()
            .unwrap()
            .to_string()
    };
    std::fs::write(file("deviations.toml"), &d.deviations).unwrap();
    std::fs::write(file("nongeometric.toml"), &d.nongeometric).unwrap();
    let file = simulate_and_identify(
        &format!("sim{index}"),
        d.structure,
        &file("deviations.toml"),
        &file("nongeometric.toml"),
        [1, 2, 3].map(|offset| seed * 10 + offset),
        d.measure,
    );
    let (o, r) = train_default(&file);
    // Where a kept network's cross-validated orientation error is above the model alone's
    // (the choice is made on position), the note says so; only there.
    let sel = &r["training"]["selection"];
    let test = &sel["network_test"];
    if test["kept"] == true {
        let rot = |i: &serde_json::Value| {
            sel["candidates"][i.as_u64().unwrap() as usize]["score"]["orientation_rms_deg"].as_f64()
        };
        let worse =
            matches!((rot(&test["network"]), rot(&test["alone"])), (Some(n), Some(a)) if n > a);
        assert_eq!(
            stdout(&o).contains(
                "the network is kept (chosen on position; its cross-validated orientation error is"
            ),
            worse,
            "{}",
            stdout(&o)
        );
    }
    let mean = |what| {
        accuracy(&r, "validation", what)["position_mm"]["mean"]
            .as_f64()
            .unwrap()
    };
    let chosen = stdout(&o)
        .lines()
        .find(|l| l.starts_with("settings: "))
        .map_or(String::new(), |l| l["settings: ".len()..].to_string());
    (mean("model"), mean("+net"), chosen)
}

#[test]
fn default_beats_full_geometry_on_drawn_robots() {
    let robots = [
        (FANUC, "pose"),
        (FANUC, "pose"),
        (FANUC, "pose"),
        (FANUC, "position"),
        (FANUC, "pose"),
        (FANUC, "pose"),
        (UR10, "pose"),
        (UR10, "pose"),
        (UR10, "pose"),
        (UR10, "position"),
    ];
    let mut table = String::from(
        "| robot | structure | measured | full mm | default mm | ratio | chosen |\n|---|---|---|---|---|---|---|\n",
    );
    let mut ratios = Vec::new();
    for (i, &(structure, measure)) in robots.iter().enumerate() {
        let seed = 7100 + i as u64;
        let d = draw(structure, measure, seed);
        let (model, net, chosen) = run(i, &d, seed);
        let name = if structure == FANUC { "FANUC" } else { "UR10" };
        writeln!(
            table,
            "| {i} | {name} | {measure} | {model:.4} | {net:.4} | {:.2} | {chosen} |",
            model / net
        )
        .unwrap();
        ratios.push(model / net);
    }
    println!("{table}");
    // The target, on every robot: on the UR10 draws full geometry leaves only
    // 0.07-0.17 mm against the noise of 0.033 mm per coordinate, and robot 6 reached 1.92x
    // while refinement was tried on the leading network family alone (the RBF network,
    // refined to no gain, where the MLPs refined with the compliances reach 2.75x).
    for (i, r) in ratios.iter().enumerate() {
        let floor = 2.5;
        assert!(
            *r >= floor,
            "robot {i}: default only {r:.2}x below full geometry (at least {floor}x)\n{table}"
        );
    }
}

/// A SCARA (two vertical revolute axes, a prismatic joint, a revolute wrist: four joints)
/// and a seven-joint arm, each written here in standard DH, through the same user's flow.
/// The SCARA's errors are geometric only, which `full` identifies completely: the network
/// has nothing to learn, and the default must not make the compensated pose worse than the
/// model against the truth (a blend of MLPs and the RBF network that won cross-validation
/// by 0.4 % had raised the max by 44 % here), and a network's file must be written (the gravity directions in the
/// links that turn about the identified, barely tilted vertical axes vary by 4e-10: their
/// standardisation once made a scale no file can hold). The arm's joints 2 and 4 carry gear
/// errors, which the default must take a third of (it took 55 % in a trial with 400 rows).
#[test]
fn a_scara_and_a_seven_joint_arm_go_through_the_default() {
    let frame = |x: &str| format!("convention = \"transform\"\n{x}rz = 0.0\nry = 0.0\nrx = 0.0\n");
    let joint = |kind: &str, d: f64, a: f64, alpha: f64, lim: (f64, f64)| {
        format!(
            "\n[[joint]]\nconvention = \"dh\"\ntype = \"{kind}\"\nd = {d:?}\na = {a:?}\n\
             alpha = {alpha:?}\nlimits = [{:?}, {:?}]\n",
            lim.0, lim.1
        )
    };
    let scara = [
        joint("revolute", 400.0, 325.0, 0.0, (-140.0, 140.0)),
        joint("revolute", 0.0, 275.0, 180.0, (-145.0, 145.0)),
        joint("prismatic", 0.0, 0.0, 0.0, (0.0, 200.0)),
        joint("revolute", 50.0, 0.0, 0.0, (-360.0, 360.0)),
    ]
    .concat();
    let arm = [
        joint("revolute", 340.0, 0.0, -90.0, (-170.0, 170.0)),
        joint("revolute", 0.0, 0.0, 90.0, (-120.0, 120.0)),
        joint("revolute", 400.0, 0.0, 90.0, (-170.0, 170.0)),
        joint("revolute", 0.0, 0.0, -90.0, (-120.0, 120.0)),
        joint("revolute", 400.0, 0.0, -90.0, (-170.0, 170.0)),
        joint("revolute", 0.0, 0.0, 90.0, (-120.0, 120.0)),
        joint("revolute", 126.0, 0.0, 0.0, (-175.0, 175.0)),
    ]
    .concat();
    let arm = format!(
        "name = \"arm7\"\n[base]\n{}{arm}\n[tool]\n{}",
        frame("x = 0.0\ny = 0.0\nz = 0.0\n"),
        frame("x = 0.0\ny = 0.0\nz = 100.0\n")
    );
    let gear = |j: usize, a: f64, p: f64| {
        format!(
            "\n[[gear]]\njoint = {j}\namplitude1_mrad = {a:?}\nphase1_deg = {p:?}\n\
             amplitude2_mrad = 0.0\nphase2_deg = 0.0\n"
        )
    };
    let cases = [
        (
            "scara",
            format!("name = \"scara\"\n{scara}"),
            "\"a1\" = 0.8\n\"a2\" = -0.5\n\"theta2\" = 0.1\n\"d3\" = 0.4\n\"alpha1\" = 0.03\n\
             \"theta4\" = 0.2\n",
            String::new(),
        ),
        (
            "arm7",
            arm,
            "\"a1\" = 0.8\n\"d3\" = -0.6\n\"alpha2\" = 0.05\n\"theta4\" = 0.08\n\"a5\" = 0.5\n\
             \"alpha6\" = -0.04\n\"theta7\" = 0.1\n\"base.x\" = 1.2\n\"tool.z\" = -0.7\n",
            gear(2, 0.15, 30.0) + &gear(4, 0.12, 100.0),
        ),
    ];
    for (name, robot, deviations, nongeometric) in cases {
        let path = |tail: &str| {
            let p = tmp(&format!("shape_{name}_{tail}"));
            p.to_str().unwrap().to_string()
        };
        std::fs::write(path("robot.toml"), robot).unwrap();
        std::fs::write(path("deviations.toml"), deviations).unwrap();
        std::fs::write(path("nongeometric.toml"), nongeometric).unwrap();
        let file = simulate_and_identify(
            &format!("shape_{name}"),
            &path("robot.toml"),
            &path("deviations.toml"),
            &path("nongeometric.toml"),
            [81, 82, 83],
            "pose",
        );
        let (o, r) = train_default(&file);
        let position = |what: &str, stat: &str| {
            accuracy(&r, "validation", what)["position_mm"][stat]
                .as_f64()
                .unwrap()
        };
        let (model, net) = (position("model", "rms"), position("+net", "rms"));
        let (model_max, net_max) = (position("model", "max"), position("+net", "max"));
        eprintln!(
            "{name}: full {model:.4} (max {model_max:.4}) -> default {net:.4} (max {net_max:.4}) \
             mm RMS against the truth"
        );
        if name == "scara" {
            assert!(
                net <= model && net_max <= 1.1 * model_max,
                "{name}\n{}",
                stdout(&o)
            );
            // The model alone, by the margin: the network is less than 2 % ahead (0.4 %).
            let test = &r["training"]["selection"]["network_test"];
            let ratio = test["ratio"].as_f64().unwrap();
            let margin = 1.0 + robocal::neural::tuning::NETWORK_MARGIN;
            assert!(ratio * margin > 1.0 && test["kept"] == false, "{test}");
            assert!(
                stdout(&o).contains("not 2 % or more below: the compensator is the model alone"),
                "{}",
                stdout(&o)
            );
            // A model whose first two twists are off by 0.002 deg each (3.5e-5 rad): the
            // gravity direction's z in the links beyond joint 2 varies with q2 by the product
            // of the two, below 1e-9 as a standard deviation; a network on it (the model kept
            // as given) is written.
            let tilted = std::fs::read_to_string(path("robot.toml"))
                .unwrap()
                .replacen(
                    "alpha = 0.0\nlimits = [-140.0",
                    "alpha = 0.002\nlimits = [-140.0",
                    1,
                )
                .replacen("alpha = 180.0\n", "alpha = 180.002\n", 1);
            assert_eq!(tilted.matches("alpha = 0.002\n").count(), 1, "{tilted}");
            assert_eq!(tilted.matches("alpha = 180.002\n").count(), 1, "{tilted}");
            std::fs::write(path("tilted.toml"), tilted).unwrap();
            let o = robocal(&[
                "train",
                "--robot",
                &path("tilted.toml"),
                "--data",
                &file("train.csv"),
                "--refine",
                "none",
                "--network",
                "rbf",
                "--encoding",
                "gravity",
                "--members",
                "1",
                "--out",
                &path("tilted.rcal"),
            ]);
            assert!(o.status.success(), "{}", stderr(&o));
            assert!(stdout(&o).contains("rbf network: "), "{}", stdout(&o));
            assert!(std::path::Path::new(&path("tilted.rcal")).exists());
        } else {
            assert!(net <= model / 1.5, "{name}\n{}", stdout(&o));
        }
    }
}

/// A robot whose errors are geometric only, identified with `full` on the rows it trains on:
/// what is left is the tracker's noise, and no network can learn it. The RBF network's
/// hyperparameters, searched once on every training row, had seen the rows each fold holds
/// out; on those figures it was 3.4 % below the model alone (paired z -3.4) and was kept, and
/// raised the error of 86 of 150 new rows. Stage 5 judges a network with an RBF network
/// again with each fold's hyperparameters searched on its training rows alone: there it is
/// above the model alone, as it is on the new rows (the same network fixed by flags), and
/// the compensator is the model alone.
#[test]
fn a_network_that_learns_only_noise_is_judged_on_rows_no_search_saw() {
    let file = |tail: &str| tmp(&format!("noise_{tail}")).to_str().unwrap().to_string();
    let run = |args: &[&str]| {
        let o = robocal(args);
        assert!(o.status.success(), "{args:?}\n{}", stderr(&o));
        o
    };
    run(&[
        "simulate",
        "--robot",
        FANUC,
        "--deviations",
        "datasets/deviations/table_6_1.toml",
        "--count",
        "300",
        "--seed",
        "3",
        "--sigma-pos",
        "0.02",
        "--sigma-rot",
        "0.05",
        "--out",
        &file("all.csv"),
    ]);
    run(&[
        "split",
        &file("all.csv"),
        "--fraction",
        "0.5",
        "--seed",
        "2",
        "--out-a",
        &file("train.csv"),
        "--out-b",
        &file("new.csv"),
    ]);
    run(&[
        "identify",
        "--robot",
        FANUC,
        "--data",
        &file("train.csv"),
        "--params",
        "full",
        "--out",
        &file("full.toml"),
    ]);
    let train = |extra: &[&str], name: &str| {
        let (out, report) = (file(&format!("{name}.rcal")), file(&format!("{name}.json")));
        let (robot, data, new) = (file("full.toml"), file("train.csv"), file("new.csv"));
        let mut args = vec![
            "train",
            "--robot",
            &robot,
            "--data",
            &data,
            "--validate",
            &new,
            "--out",
            &out,
            "--report",
            &report,
        ];
        args.extend_from_slice(extra);
        let o = run(&args);
        (o, json(std::path::Path::new(&report)))
    };
    let (o, r) = train(&[], "default");
    let sel = &r["training"]["selection"];
    let (margin, z_needed) = (
        1.0 + robocal::neural::tuning::NETWORK_MARGIN,
        robocal::neural::tuning::NETWORK_Z,
    );
    // On the candidates' figures the network with the RBF network passes the test ...
    let rbf = &sel["rbf_network_test"];
    let number = |v: &serde_json::Value| v.as_f64().unwrap();
    assert!(
        number(&rbf["ratio"]) * margin <= 1.0 && number(&rbf["z"]) <= -z_needed,
        "{rbf}"
    );
    let chosen = &sel["candidates"][rbf["network"].as_u64().unwrap() as usize]["settings"];
    assert_ne!(chosen["network"], "mlp", "{chosen}");
    // Fixed below with `--refine none`.
    assert!(chosen["refine"].is_null(), "{chosen}");
    // ... and fails it where each fold's hyperparameters never saw its held-out rows.
    let unseen = &rbf["unseen"];
    assert_eq!(unseen["by"], "folds", "{rbf}");
    assert_eq!(unseen["rows"], 150, "{rbf}");
    assert_eq!(unseen["configurations"], 150, "{rbf}");
    assert!(number(&unseen["ratio"]) > 1.0, "{rbf}");
    assert!(number(&unseen["ratio"]) > number(&rbf["ratio"]), "{rbf}");
    assert_eq!(rbf["kept"], false);
    // The best MLP held against the model alone instead fails too: the model alone.
    let test = &sel["network_test"];
    assert!(test["kept"] == false && test["unseen"].is_null(), "{test}");
    let mlp = &sel["candidates"][test["network"].as_u64().unwrap() as usize]["settings"];
    assert_eq!(mlp["network"], "mlp", "{mlp}");
    assert_eq!(sel["chosen"], test["alone"]);
    let text = stdout(&o);
    assert!(
        text.contains(
            "searched on each fold's training rows alone (no search seeing the rows it is \
             judged on)"
        ) && text.contains("the best network without an RBF network's cross-validated error"),
        "{text}"
    );
    let position = |r: &serde_json::Value, model: &str| {
        number(&accuracy(r, "validation", model)["position_mm"]["rms"])
    };
    assert_eq!(position(&r, "+net"), position(&r, "model"));
    // The network the candidates' figures chose, fixed by flags: on the new rows it is worse
    // than the model alone, as the test on unseen rows said (0.0364 against 0.0351 mm RMS).
    let s = |k: &str| chosen[k].as_str().unwrap().to_string();
    let (network, encoding) = (s("network"), s("encoding"));
    let mut fixed = vec![
        "--network",
        &network,
        "--encoding",
        &encoding,
        "--refine",
        "none",
    ];
    // Members given: stage 5 does not run (the network is what was asked for).
    let (hidden, penalty, members, share);
    if network == "rbf" {
        fixed.extend(["--members", "1"]);
    } else {
        hidden = chosen["hidden"].to_string();
        penalty = chosen["penalty"].to_string();
        members = chosen["members"].to_string();
        share = chosen["mlp_share"].to_string();
        fixed.extend([
            "--hidden",
            &hidden,
            "--penalty",
            &penalty,
            "--members",
            &members,
            "--mlp-share",
            &share,
        ]);
    }
    let (_, fixed) = train(&fixed, "fixed");
    assert!(
        position(&fixed, "+net") > position(&fixed, "model"),
        "{} vs {}",
        position(&fixed, "+net"),
        position(&fixed, "model")
    );
}
