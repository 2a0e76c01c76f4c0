//! Issue 12: options that crashed the binary or ran away are refused with a usage error that
//! names the bound, never a panic.

mod common;
use common::{robocal, stderr};

const UR10: &str = "datasets/robots/ur10.toml";

/// The command fails cleanly: nonzero exit, no panic, and the message says `expect`.
fn refused(args: &[&str], expect: &str) {
    let o = robocal(args);
    let err = stderr(&o);
    assert!(!o.status.success(), "{args:?} succeeded");
    assert!(!err.contains("panicked"), "{args:?} panicked: {err}");
    assert!(err.contains(expect), "{args:?}: {err}");
}

#[test]
fn decimals_beyond_an_f64s_digits_are_refused() {
    for cmd in ["fk", "ik", "predict", "compensate"] {
        refused(&[cmd, "--decimals", "65536"], "give 0 to 17 decimals");
    }
    let o = robocal(&[
        "fk",
        "--robot",
        UR10,
        "--q",
        "0,0,0,0,0,0",
        "--decimals",
        "17",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
}

#[test]
fn sizes_are_bounded() {
    refused(
        &[
            "simulate",
            "--robot",
            UR10,
            "--count",
            "18446744073709551615",
            "--seed",
            "1",
            "--out",
            "never.csv",
        ],
        "give 1 to 1000000 configurations",
    );
    refused(
        &[
            "simulate",
            "--robot",
            UR10,
            "--count",
            "0",
            "--seed",
            "1",
            "--out",
            "never.csv",
        ],
        "give 1 to 1000000 configurations",
    );
    assert!(!std::path::Path::new("never.csv").exists());
    refused(&["reproduce", "--seeds", "0"], "0 is not in 1..=1000");
}

#[test]
fn sigmas_are_finite_positive_and_bounded() {
    for v in ["0", "nan", "-1", "inf", "1e308"] {
        let flag = format!("--sigma-pos={v}");
        for cmd in ["train", "identify"] {
            refused(
                &[cmd, "--robot", UR10, "--data", "none.csv", &flag],
                "give a sigma above 0 up to 1000",
            );
        }
        if v != "0" {
            refused(
                &[
                    "simulate", "--robot", UR10, "--count", "3", "--seed", "1", "--out", "x.csv",
                    &flag,
                ],
                "give a noise sigma from 0 up to 1000",
            );
        }
    }
    refused(
        &[
            "identify",
            "--robot",
            UR10,
            "--data",
            "none.csv",
            "--max-iterations",
            "0",
        ],
        "give 1 to 100000 iterations",
    );
}
