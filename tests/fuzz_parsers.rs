//! Issue 12, item 4: every parser and loader, in-process, on arbitrary bytes and on mutations
//! of the shipped files, gives `Ok` or an error that names its file, never a panic, and never
//! a non-finite number in what it returns.

mod common;
use common::mutate;
use proptest::prelude::*;
use robocal::data::{Profile, ReadOptions, Table, read_measurements};
use robocal::model::file::parse_robot;
use robocal::model::read_robot;
use robocal::neural::compensator::{Compensator, CompensatorOptions, Form, Network, Settings};
use robocal::neural::encoding::Encoding;
use robocal::neural::train::TrainOptions;
use robocal::sim::nongeometric::NonGeometric;
use robocal::sim::{Deviations, Region};
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn shipped(rel: &str) -> Vec<u8> {
    std::fs::read(root().join(rel)).unwrap()
}

fn edits() -> impl Strategy<Value = Vec<(usize, u8, u8)>> {
    prop::collection::vec((any::<usize>(), any::<u8>(), any::<u8>()), 1..6)
}

fn bytes() -> impl Strategy<Value = Vec<u8>> {
    prop::collection::vec(any::<u8>(), 0..300)
}

/// Whether a debug form holds a non-finite number: `NaN`, `inf` or `-inf` as a token outside
/// quoted strings (names and carried cells may say "inf").
fn has_non_finite(debug: &str) -> bool {
    let b = debug.as_bytes();
    let (mut i, mut quoted) = (0, false);
    while i < b.len() {
        match b[i] {
            b'\\' if quoted => i += 1,
            b'"' => quoted = !quoted,
            _ if !quoted => {
                let word = |w: &str| {
                    debug[i..].starts_with(w)
                        && (i == 0 || !b[i - 1].is_ascii_alphanumeric())
                        && b.get(i + w.len())
                            .is_none_or(|c| !c.is_ascii_alphanumeric())
                };
                if word("NaN") || word("inf") {
                    return true;
                }
            }
            _ => {}
        }
        i += 1;
    }
    false
}

/// Ok with only finite numbers in its debug form, or an error naming `file`.
fn located<T: std::fmt::Debug>(
    r: robocal::error::Result<T>,
    file: &str,
) -> Result<(), TestCaseError> {
    match r {
        Ok(v) => {
            let text = format!("{v:?}");
            prop_assert!(
                !has_non_finite(&text),
                "non-finite value accepted: {}",
                &text[..text.len().min(400)]
            );
        }
        Err(e) => {
            let msg = e.to_string();
            prop_assert!(msg.contains(file), "error without its file: {msg}");
        }
    }
    Ok(())
}

/// One folder per test process for the files the loaders read from a path.
fn scratch(name: &str, bytes: &[u8]) -> PathBuf {
    static DIR: OnceLock<tempfile::TempDir> = OnceLock::new();
    let dir = DIR.get_or_init(|| tempfile::Builder::new().prefix("fuzz").tempdir().unwrap());
    let p = dir
        .path()
        .join(format!("{:?}-{name}", std::thread::current().id()).replace(['(', ')'], ""));
    std::fs::write(&p, bytes).unwrap();
    p
}

fn fanuc() -> &'static robocal::model::Robot {
    static R: OnceLock<robocal::model::Robot> = OnceLock::new();
    R.get_or_init(|| read_robot(root().join("datasets/robots/fanuc_r2000ib_210f.toml")).unwrap())
}

fn ur10() -> &'static robocal::model::Robot {
    static R: OnceLock<robocal::model::Robot> = OnceLock::new();
    R.get_or_init(|| read_robot(root().join("datasets/robots/ur10.toml")).unwrap())
}

/// A small compensator file (fixed settings, a few epochs) to mutate.
fn compensator_text() -> &'static str {
    static T: OnceLock<String> = OnceLock::new();
    T.get_or_init(|| {
        let set =
            robocal::data::read_canonical(&root().join("datasets/case_d/training.csv"), fanuc())
                .unwrap();
        let settings = Settings {
            network: Network::Mix,
            form: Form::Pose,
            encoding: Encoding::Angles,
            hidden: 2,
            penalty: 1.0,
            members: 1,
            rbf_start: Some(0),
            refine: None,
            mlp_share: None,
        };
        let train = TrainOptions {
            momentum_epochs: 2,
            max_epochs: 2,
            ..Default::default()
        };
        let (c, _) = Compensator::train(
            fanuc(),
            &set,
            &CompensatorOptions::fixed(&settings, train),
            &|_, _| {},
        )
        .unwrap();
        c.to_file_text().unwrap()
    })
}

fn config() -> ProptestConfig {
    ProptestConfig {
        cases: 500,
        failure_persistence: None,
        ..ProptestConfig::default()
    }
}

fn text(b: &[u8]) -> String {
    String::from_utf8_lossy(b).into_owned()
}

proptest! {
    #![proptest_config(config())]

    #[test]
    fn robot_files(e in edits(), raw in bytes()) {
        for base in ["datasets/robots/fanuc_r2000ib_210f.toml", "datasets/robots/ur10_mdh_hayati.toml"] {
            let t = text(&mutate(&shipped(base), &e));
            located(parse_robot(&t, Path::new("robot.toml")), "robot.toml")?;
        }
        located(parse_robot(&text(&raw), Path::new("robot.toml")), "robot.toml")?;
    }

    #[test]
    fn measurement_files(e in edits(), raw in bytes()) {
        let canonical = mutate(&shipped("datasets/case_d/calibration.csv"), &e);
        for (bytes, profile) in [(canonical, Profile::default()), (raw.clone(), Profile::default())] {
            let p = scratch("data.csv", &bytes);
            for skip in [false, true] {
                let opts = ReadOptions { strict: false, skip_bad_rows: skip };
                located(read_measurements(&p, fanuc(), &profile, &opts).map(|r| r.0), "data.csv")?;
            }
        }
        let ipa = Profile::read(root().join("datasets/profiles/ipa_ur10.toml")).unwrap();
        let series = shipped("datasets/ipa-ur10/Series_B/measurements_joint_configurations.csv");
        // The header and a few rows: the mutations land where the parser looks.
        let head: Vec<u8> = series.split(|&b| b == b'\n').take(6).collect::<Vec<_>>().join(&b'\n');
        let p = scratch("series.csv", &mutate(&head, &e));
        located(read_measurements(&p, ur10(), &ipa, &ReadOptions::default()).map(|r| r.0), "series.csv")?;
        located(Table::parse(&raw, Path::new("t.csv"), b',', false), "t.csv")?;
        located(Table::parse(&raw, Path::new("t.csv"), b';', true), "t.csv")?;
    }

    #[test]
    fn profiles_deviations_regions_and_nongeometric_files(e in edits(), raw in bytes()) {
        let t = text(&mutate(&shipped("datasets/profiles/ipa_ur10.toml"), &e));
        located(Profile::parse(&t, Path::new("p.toml")), "p.toml")?;
        located(Profile::parse(&text(&raw), Path::new("p.toml")), "p.toml")?;
        let t = text(&mutate(&shipped("datasets/deviations/table_6_1.toml"), &e));
        located(Deviations::parse(&t, Path::new("dev.toml"), fanuc()), "dev.toml")?;
        located(Deviations::parse(&text(&raw), Path::new("dev.toml"), fanuc()), "dev.toml")?;
        for (name, base) in [
            ("region.toml", "datasets/regions/case_d_focused.toml"),
            ("ng.toml", "datasets/nongeometric/fanuc_compliance_gear.toml"),
        ] {
            for bytes in [mutate(&shipped(base), &e), raw.clone()] {
                let p = scratch(name, &bytes);
                if name == "region.toml" {
                    located(Region::read(&p, fanuc()), name)?;
                } else {
                    located(NonGeometric::read(&p, fanuc()), name)?;
                }
            }
        }
    }

    #[test]
    fn compensator_files(e in edits(), raw in bytes()) {
        let t = text(&mutate(compensator_text().as_bytes(), &e));
        located(Compensator::from_file_text(&t, Path::new("c.rcal")), "c.rcal")?;
        located(Compensator::from_file_text(&text(&raw), Path::new("c.rcal")), "c.rcal")?;
    }
}

#[test]
fn non_finite_tokens_are_found_outside_strings_only() {
    assert!(has_non_finite("A { x: NaN }"));
    assert!(has_non_finite("[1.0, -inf]"));
    assert!(!has_non_finite(
        "A { name: \"inf NaN \\\" inf\", info: 1.0 }"
    ));
}

/// The shipped compensator file text loads (the mutations above start from a valid file).
#[test]
fn the_unmutated_compensator_loads() {
    Compensator::from_file_text(compensator_text(), Path::new("c.rcal")).unwrap();
}
