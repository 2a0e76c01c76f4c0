//! Issue 12, item 4: a seeded mutation test through the binary. Every command that reads a
//! file runs on mutated copies of its inputs (bytes replaced, deleted or inserted, hostile
//! tokens such as `nan` or `1e308` spliced in, lines duplicated, files cut): it must exit 0,
//! 1 (an error) or 3 (`compensate` with failed targets), never panic, and whatever it writes
//! holds no non-finite number.

mod common;
use common::{CHEAP_TRAIN, mutate, robocal, stderr};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::path::{Path, PathBuf};

/// Cases in the test suite (each one run of the binary; CASES in the environment for more).
const CASES: usize = 300;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// The first `lines` lines of a shipped file.
fn head(rel: &str, lines: usize) -> Vec<u8> {
    let text = std::fs::read_to_string(root().join(rel)).unwrap();
    let mut out: String = text.lines().take(lines).collect::<Vec<_>>().join("\n");
    out.push('\n');
    out.into_bytes()
}

/// A written output holds a non-finite number (a CSV cell, a JSON or TOML value; JSON null
/// is how serde writes NaN, except for a compensator without an RBF network).
fn non_finite(text: &str) -> bool {
    // The compensator file's optional parts are null when absent.
    let text = text
        .replace("\"rbf\": null", "")
        .replace("\"shrink\": null", "");
    text.split([',', '\n', ' ', ':', '='])
        .map(|t| t.trim().trim_matches('"'))
        .any(|t| {
            let t = t.to_ascii_lowercase();
            t == "nan" || t == "inf" || t == "-inf" || t == "infinity" || t == "null"
        })
}

struct Input {
    /// Placeholder in the argument list.
    key: &'static str,
    name: &'static str,
    bytes: Vec<u8>,
}

#[test]
fn mutated_inputs_never_crash_a_command() {
    let dir = tempfile::Builder::new().prefix("mutate").tempdir().unwrap();
    let d = dir.path();
    let p = |n: &str| d.join(n).to_str().unwrap().to_string();
    let fanuc = "datasets/robots/fanuc_r2000ib_210f.toml";
    // A small compensator to mutate and to use.
    let base = p("base.rcal");
    let mut args = vec![
        "train",
        "--robot",
        fanuc,
        "--data",
        "datasets/case_d/training.csv",
    ];
    args.extend_from_slice(CHEAP_TRAIN);
    args.extend(["--out", &base]);
    let o = robocal(&args);
    assert!(o.status.success(), "{}", stderr(&o));
    let inputs = vec![
        Input {
            key: "ROBOT",
            name: "robot.toml",
            bytes: std::fs::read(root().join(fanuc)).unwrap(),
        },
        Input {
            key: "JOINTS",
            name: "joints.csv",
            bytes: head("datasets/joints/fanuc_demo.csv", 8),
        },
        Input {
            key: "DATA",
            name: "data.csv",
            bytes: head("datasets/case_d/calibration.csv", 31),
        },
        Input {
            key: "REF",
            name: "reference.csv",
            bytes: head("datasets/case_d/training.csv", 31),
        },
        Input {
            key: "SERIES",
            name: "series.csv",
            bytes: head(
                "datasets/ipa-ur10/Series_B/measurements_joint_configurations.csv",
                8,
            ),
        },
        Input {
            key: "PROFILE",
            name: "profile.toml",
            bytes: head("datasets/profiles/ipa_ur10.toml", 40),
        },
        Input {
            key: "DEV",
            name: "dev.toml",
            bytes: head("datasets/deviations/table_6_1.toml", 100),
        },
        Input {
            key: "NG",
            name: "ng.toml",
            bytes: head("datasets/nongeometric/fanuc_compliance_gear.toml", 200),
        },
        Input {
            key: "REGION",
            name: "region.toml",
            bytes: head("datasets/regions/case_d_focused.toml", 20),
        },
        Input {
            key: "TARGETS",
            name: "targets.csv",
            bytes: head("datasets/targets/fanuc_cell.csv", 5),
        },
        Input {
            key: "COMP",
            name: "comp.rcal",
            bytes: std::fs::read(p("base.rcal")).unwrap(),
        },
        Input {
            key: "POSES",
            name: "poses.csv",
            bytes: b"x,y,z,rz,ry,rx\n1842,0,1652,0,90,0\n2000,100,1500,10,80,5\n".to_vec(),
        },
    ];
    // Every command that reads a file; OUT is its output.
    let commands: Vec<Vec<&str>> = vec![
        vec![
            "fk", "--robot", "ROBOT", "--joints", "JOINTS", "--out", "OUT",
        ],
        vec!["ik", "--robot", "ROBOT", "--poses", "POSES", "--out", "OUT"],
        vec!["import", "SERIES", "--profile", "PROFILE", "--out", "OUT"],
        vec![
            "simulate",
            "--robot",
            "ROBOT",
            "--deviations",
            "DEV",
            "--nongeometric",
            "NG",
            "--region",
            "REGION",
            "--count",
            "3",
            "--seed",
            "1",
            "--out",
            "OUT",
        ],
        vec![
            "split", "DATA", "--seed", "1", "--out-a", "OUT", "--out-b", "OUT2",
        ],
        vec![
            "identify", "--robot", "ROBOT", "--data", "DATA", "--params", "offsets", "--out", "OUT",
        ],
        vec![
            "evaluate",
            "--robot",
            "ROBOT",
            "--data",
            "DATA",
            "--compensator",
            "COMP",
            "--check-against",
            "REF",
            "--report",
            "OUT",
        ],
        [
            &["train", "--robot", "ROBOT", "--data", "DATA"][..],
            CHEAP_TRAIN,
            &["--out", "OUT"],
        ]
        .concat(),
        vec![
            "predict",
            "--compensator",
            "COMP",
            "--joints",
            "JOINTS",
            "--out",
            "OUT",
        ],
        vec![
            "compensate",
            "--nominal",
            "ROBOT",
            "--robot",
            "ROBOT",
            "--targets",
            "TARGETS",
            "--compensator",
            "COMP",
            "--out",
            "OUT",
        ],
    ];
    let mut rng = ChaCha8Rng::seed_from_u64(12);
    let mut codes = [0usize; 4];
    let cases = std::env::var("CASES").map_or(CASES, |v| v.parse().unwrap());
    for case in 0..cases {
        let cmd = &commands[case % commands.len()];
        let used: Vec<&Input> = inputs.iter().filter(|i| cmd.contains(&i.key)).collect();
        let victim = rng.random_range(0..used.len());
        let edits: Vec<(usize, u8, u8)> = (0..rng.random_range(1..5))
            .map(|_| (rng.random::<u64>() as usize, rng.random(), rng.random()))
            .collect();
        let out = p(&format!("out{case}"));
        let out2 = p(&format!("out{case}b"));
        let _ = std::fs::remove_file(&out);
        let mut paths = Vec::new();
        for (k, i) in used.iter().enumerate() {
            let bytes = if k == victim {
                mutate(&i.bytes, &edits)
            } else {
                i.bytes.clone()
            };
            let path = p(&format!("{case}-{}", i.name));
            std::fs::write(&path, bytes).unwrap();
            paths.push((i.key, path));
        }
        let args: Vec<String> = cmd
            .iter()
            .map(|a| match *a {
                "OUT" => out.clone(),
                "OUT2" => out2.clone(),
                k => paths
                    .iter()
                    .find(|(key, _)| *key == k)
                    .map_or(k.to_string(), |(_, p)| p.clone()),
            })
            .collect();
        let a: Vec<&str> = args.iter().map(String::as_str).collect();
        let o = robocal(&a);
        let err = stderr(&o);
        let what = format!(
            "case {case}: {} with {} mutated by {edits:?}",
            cmd[0], used[victim].name
        );
        assert!(!err.contains("panicked"), "{what}: {err}");
        assert!(
            matches!(o.status.code(), Some(0 | 1 | 3)),
            "{what}: exit {:?}: {err}",
            o.status.code()
        );
        if o.status.code() == Some(1) {
            assert!(
                !Path::new(&out).exists(),
                "{what}: an output after a failure"
            );
        } else if let Ok(text) = std::fs::read_to_string(&out) {
            // A typed report writes an absent value ("none") as null; its numbers must still
            // be finite.
            let typed = robocal::reports::Report::from_json(&text, Path::new(&out)).is_ok();
            let checked = if typed {
                text.replace(": null", ": none")
            } else {
                text.clone()
            };
            assert!(!non_finite(&checked), "{what}: non-finite output: {text}");
        }
        codes[o.status.code().unwrap_or(0).clamp(0, 3) as usize] += 1;
    }
    eprintln!("exit codes 0/1/3: {}/{}/{}", codes[0], codes[1], codes[3]);
    // The mutations must leave some runs succeeding and make some fail, or they test nothing.
    assert!(codes[0] > cases / 10 && codes[1] > cases / 10, "{codes:?}");
}
