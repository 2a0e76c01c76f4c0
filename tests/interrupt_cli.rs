//! A command interrupted by Ctrl-C (SIGINT) or SIGTERM leaves nothing behind: no temporary
//! file of an output it had not yet put in place, no folder it made; it exits 130.
#![cfg(unix)]

mod common;
use common::{FANUC, root, tmp};

const UR10: &str = "datasets/robots/ur10.toml";
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// Runs `robocal args`, sends `signal` (`INT`, `TERM`) as soon as `ready` holds, and returns
/// its exit code and standard error. Panics where `ready` never holds or the command ended
/// before the signal (the test would then prove nothing).
fn interrupted(args: &[&str], signal: &str, ready: impl Fn() -> bool) -> (Option<i32>, String) {
    let mut child = Command::new(env!("CARGO_BIN_EXE_robocal"))
        .args(args)
        .current_dir(root())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let start = Instant::now();
    while !ready() {
        assert!(
            child.try_wait().unwrap().is_none(),
            "{args:?} ended before it could be interrupted"
        );
        assert!(
            start.elapsed() < Duration::from_secs(60),
            "{args:?} never got ready"
        );
        std::thread::sleep(Duration::from_millis(5));
    }
    assert!(
        child.try_wait().unwrap().is_none(),
        "{args:?} ended too soon"
    );
    let pid = child.id().to_string();
    let kill = Command::new("kill").args(["-s", signal, &pid]).status();
    assert!(kill.unwrap().success());
    let out = child.wait_with_output().unwrap();
    (
        out.status.code(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// The names in folder `dir`.
fn names(dir: &Path) -> Vec<String> {
    let mut n: Vec<String> = (std::fs::read_dir(dir).unwrap())
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    n.sort();
    n
}

#[test]
fn an_interrupted_simulation_leaves_no_temporary_file() {
    let dir = tmp("interrupted_simulation");
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("kept.txt"), "an earlier file").unwrap();
    let out = dir.join("million.csv");
    let (code, err) = interrupted(
        &[
            "simulate",
            "--robot",
            UR10,
            "--count",
            "1000000",
            "--seed",
            "1",
            "--out",
            out.to_str().unwrap(),
        ],
        "INT",
        // The rows stream into a temporary file beside the output from the start.
        || names(&dir).iter().any(|n| n.starts_with(".tmp")),
    );
    assert_eq!(code, Some(130), "{err}");
    assert!(err.contains("interrupted"), "{err}");
    assert!(!err.contains("panicked"), "{err}");
    assert_eq!(names(&dir), ["kept.txt"]);
}

#[test]
fn a_terminated_training_removes_the_plot_folder_it_made() {
    let dir = tmp("terminated_training");
    std::fs::create_dir_all(&dir).unwrap();
    let plots = dir.join("plots/deeper");
    let (code, err) = interrupted(
        &[
            "train",
            "--robot",
            FANUC,
            "--data",
            "datasets/nongeometric_robot/training.csv",
            "--out",
            dir.join("net.rcal").to_str().unwrap(),
            "--plot",
            plots.to_str().unwrap(),
        ],
        "TERM",
        // The `--plot` folder is made before the training starts.
        || plots.is_dir(),
    );
    assert_eq!(code, Some(130), "{err}");
    assert!(!err.contains("panicked"), "{err}");
    assert!(names(&dir).is_empty(), "left {:?}", names(&dir));
}
