//! A command interrupted by Ctrl-C (SIGINT) or SIGTERM leaves nothing behind: no temporary
//! file of an output it had not yet put in place, no folder it made; it ends killed by the
//! signal, as a shell loop needs to stop. A signal ignored at start-up (`nohup`) stays ignored.
#![cfg(unix)]

mod common;
use common::{FANUC, root, tmp};

const UR10: &str = "datasets/robots/ur10.toml";
use std::os::unix::process::{CommandExt, ExitStatusExt};
use std::path::Path;
use std::process::{Command, ExitStatus, Stdio};
use std::time::{Duration, Instant};

/// Runs `robocal args` (under `wrapper`, a command such as `nohup`, where given), sends
/// `signal` (`INT`, `TERM`, `HUP`) as soon as `ready` holds, and returns how it ended and its
/// standard error. Panics where `ready` never holds or the command ended before the signal
/// (the test would then prove nothing).
fn interrupted(
    wrapper: Option<&str>,
    args: &[&str],
    signal: &str,
    ready: impl Fn() -> bool,
) -> (ExitStatus, String) {
    let exe = env!("CARGO_BIN_EXE_robocal");
    let mut command = match wrapper {
        Some(w) => {
            let mut c = Command::new(w);
            c.arg(exe);
            c
        }
        None => Command::new(exe),
    };
    // The signals as a terminal's foreground job has them: a background job of a script
    // (CI's) starts with SIGINT ignored, which robocal rightly leaves ignored.
    // SAFETY: signal() is async-signal-safe, as a pre_exec hook must be.
    unsafe {
        command.pre_exec(|| {
            for sig in [libc::SIGINT, libc::SIGTERM, libc::SIGHUP] {
                libc::signal(sig, libc::SIG_DFL);
            }
            Ok(())
        });
    }
    let mut child = command
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
        out.status,
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// The simulation of a million rows into `out`.
fn simulation(out: &Path) -> Vec<String> {
    let args = [
        "simulate", "--robot", UR10, "--count", "1000000", "--seed", "1", "--out",
    ];
    (args.iter().map(|a| a.to_string()))
        .chain([out.to_str().unwrap().to_string()])
        .collect()
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
    let args = simulation(&dir.join("million.csv"));
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    let (status, err) = interrupted(
        None,
        &args,
        "INT",
        // The rows stream into a temporary file beside the output from the start.
        || names(&dir).iter().any(|n| n.starts_with(".tmp")),
    );
    assert_eq!(status.signal(), Some(2), "{status:?}: {err}");
    assert!(!err.contains("panicked"), "{err}");
    assert_eq!(names(&dir), ["kept.txt"]);
}

#[test]
fn a_hang_up_ignored_at_start_up_stays_ignored() {
    // `nohup` ignores SIGHUP for the command it runs: logging out must not end it.
    let dir = tmp("nohup_simulation");
    std::fs::create_dir_all(&dir).unwrap();
    let out = dir.join("million.csv");
    let args = simulation(&out);
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    let (status, err) = interrupted(Some("nohup"), &args, "HUP", || {
        names(&dir).iter().any(|n| n.starts_with(".tmp"))
    });
    assert!(status.success(), "{status:?}: {err}");
    assert_eq!(names(&dir), ["million.csv"]);
    let text = std::fs::read_to_string(&out).unwrap();
    assert_eq!(text.lines().count(), 1_000_001);
}

#[test]
fn a_terminated_training_removes_the_plot_folder_it_made() {
    let dir = tmp("terminated_training");
    std::fs::create_dir_all(&dir).unwrap();
    let plots = dir.join("plots/deeper");
    let (status, err) = interrupted(
        None,
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
    assert_eq!(status.signal(), Some(15), "{status:?}: {err}");
    assert!(!err.contains("panicked"), "{err}");
    assert!(names(&dir).is_empty(), "left {:?}", names(&dir));
}
