//! Helpers shared by the integration tests: running the binary, temporary files, the UR10
//! series.
#![allow(dead_code)]

pub mod ur10;

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// The FANUC R-2000iB/210F's nominal file, relative to the repository root.
pub const FANUC: &str = "datasets/robots/fanuc_r2000ib_210f.toml";

/// `train` with every choice fixed and two epochs: a compensator in milliseconds.
pub const CHEAP_TRAIN: &[&str] = &[
    "--network",
    "mlp",
    "--form",
    "pose",
    "--encoding",
    "angles",
    "--hidden",
    "2",
    "--penalty",
    "1",
    "--members",
    "1",
    "--refine",
    "none",
    "--max-epochs",
    "2",
    "--momentum-epochs",
    "2",
];

/// The repository root (where `datasets/` is).
pub fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// A JSON file, parsed.
pub fn json(path: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

/// Runs the `robocal` binary from the repository root.
pub fn robocal(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_robocal"))
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("run robocal")
}

pub fn stdout(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

pub fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// A path in a temporary folder of this test binary's process.
pub fn tmp(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("robocal-tests-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

/// `robocal train` of the FANUC on `data` into `out`, with `extra` flags.
pub fn train_fanuc(data: &str, out: &str, extra: &[&str]) -> Output {
    let mut args = vec!["train", "--robot", FANUC, "--data", data, "--out", out];
    args.extend_from_slice(extra);
    robocal(&args)
}

/// The shipped non-geometric robot's protocol on a virtual robot: 30 calibration, 150
/// training and 300 test poses (drawn with `seeds` in that order; noise 0.033 mm and 0.174
/// mrad; the sensor reports `measure`) written with their truths as `{name}_cal.csv`,
/// `{name}_cal_truth.csv`, `{name}_train.csv`, ... in the test folder, then `identify --params
/// full` on the calibration set into `{name}_full.toml`. Panics with robocal's stderr on a
/// failure. Returns the path of `{name}_{tail}` for a tail such as `test_truth.csv`.
pub fn simulate_and_identify(
    name: &str,
    robot: &str,
    deviations: &str,
    nongeometric: &str,
    seeds: [u64; 3],
    measure: &str,
) -> impl Fn(&str) -> String + use<> {
    let name = name.to_string();
    let file = move |tail: &str| tmp(&format!("{name}_{tail}")).to_str().unwrap().to_string();
    for ((count, set), seed) in [("30", "cal"), ("150", "train"), ("300", "test")]
        .into_iter()
        .zip(seeds)
    {
        let o = robocal(&[
            "simulate",
            "--robot",
            robot,
            "--deviations",
            deviations,
            "--nongeometric",
            nongeometric,
            "--count",
            count,
            "--seed",
            &seed.to_string(),
            "--sigma-pos",
            "0.033",
            "--sigma-rot",
            "0.174",
            "--measure",
            measure,
            "--out",
            &file(&format!("{set}.csv")),
            "--truth-out",
            &file(&format!("{set}_truth.csv")),
        ]);
        assert!(o.status.success(), "{}", stderr(&o));
    }
    let o = robocal(&[
        "identify",
        "--robot",
        robot,
        "--data",
        &file("cal.csv"),
        "--params",
        "full",
        "--out",
        &file("full.toml"),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    file
}

/// `robocal identify` of the FANUC on Case D's calibration set into `out`, with `extra` flags;
/// panics with robocal's stderr on failure. Returns stdout.
pub fn identify_case_d(out: &std::path::Path, extra: &[&str]) -> String {
    let mut args = vec![
        "identify",
        "--robot",
        "datasets/robots/fanuc_r2000ib_210f.toml",
        "--data",
        "datasets/case_d/calibration.csv",
        "--out",
        out.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    let o = robocal(&args);
    assert!(o.status.success(), "{}", stderr(&o));
    stdout(&o)
}

/// Text that breaks parsers: non-finite and huge numbers, separators, quotes, brackets, a BOM.
const TOKENS: &[&str] = &[
    "nan",
    "inf",
    "-inf",
    "1e308",
    "1e300",
    "-1e300",
    "-0",
    "",
    ",",
    ";",
    "\"",
    "\n",
    "=",
    "[",
    "]",
    "{",
    "}",
    "99999999999",
    "0x10",
    "1e-320",
    "\u{feff}",
    "\r\n",
    "#",
    "'",
    "[[",
    "\u{0}",
    "é",
    "\\",
    "true",
    "1,5",
];

/// `base` after `edits` (position, operation, value): replace, delete or insert a byte,
/// splice a token, duplicate the line, or cut the rest.
pub fn mutate(base: &[u8], edits: &[(usize, u8, u8)]) -> Vec<u8> {
    let mut v = base.to_vec();
    for &(pos, op, val) in edits {
        if v.is_empty() {
            v.push(val);
            continue;
        }
        let i = pos % v.len();
        match op % 6 {
            0 => v[i] = val,
            1 => {
                v.remove(i);
            }
            2 => v.insert(i, val),
            3 => {
                let t = TOKENS[val as usize % TOKENS.len()].as_bytes();
                v.splice(i..i, t.iter().copied());
            }
            4 => {
                let start = v[..i]
                    .iter()
                    .rposition(|&b| b == b'\n')
                    .map_or(0, |p| p + 1);
                let end = v[i..]
                    .iter()
                    .position(|&b| b == b'\n')
                    .map_or(v.len(), |p| i + p + 1);
                let line: Vec<u8> = v[start..end].to_vec();
                v.splice(end..end, line);
            }
            _ => v.truncate(i),
        }
    }
    v
}

/// The statistics of a typed report's accuracy row (`data`, `model`); `+net` finds the
/// compensator's row whatever its label (`+net`, or `refined` / `no-net` where training kept
/// no network).
pub fn accuracy<'a>(r: &'a serde_json::Value, data: &str, model: &str) -> &'a serde_json::Value {
    let labels: &[&str] = if model == "+net" {
        &["+net", "refined", "no-net"]
    } else {
        &[model]
    };
    &r["accuracy"]
        .as_array()
        .expect("an accuracy table")
        .iter()
        .find(|a| a["data"] == data && labels.iter().any(|l| a["model"] == *l))
        .unwrap_or_else(|| panic!("no accuracy row {data} / {model}"))["stats"]
}

/// The shipped non-geometric robot's nominal with its masses and a start of compliances
/// (mrad/kNm) `[0, 0.06, 0.09, 0.35, 0.45, 0.2]` the rows cannot all tell apart, written as
/// `name` in the test folder.
#[allow(dead_code)]
pub fn compliant_start(name: &str) -> PathBuf {
    let masses =
        std::fs::read_to_string("datasets/nongeometric_robot/nominal_masses.toml").unwrap();
    let start = tmp(name);
    std::fs::write(
        &start,
        masses.replacen(
            "[mass]",
            "[compliance]\njoints = [0, 0.06, 0.09, 0.35, 0.45, 0.2]\n\n[mass]",
            1,
        ),
    )
    .unwrap();
    start
}

/// Copies the shipped data sets the studies read (`reproduce`, `case-d`: robots, deviations,
/// regions, the cases and the non-geometric robot; not the tracker series) into `to`, a
/// `datasets` folder a test may edit.
pub fn copy_studies_datasets(to: &Path) {
    for dir in [
        "robots",
        "deviations",
        "regions",
        "case_a",
        "case_b_sim",
        "case_c",
        "case_d",
        "nongeometric_robot",
    ] {
        std::fs::create_dir_all(to.join(dir)).unwrap();
        for f in std::fs::read_dir(root().join("datasets").join(dir)).unwrap() {
            let f = f.unwrap().path();
            if f.is_file() {
                std::fs::copy(&f, to.join(dir).join(f.file_name().unwrap())).unwrap();
            }
        }
    }
}
