//! Helpers shared by the command-line tests.
#![allow(dead_code)]

use std::path::PathBuf;
use std::process::{Command, Output};

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
