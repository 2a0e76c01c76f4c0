//! The shipped UR10 series (real laser-tracker data), imported through their profile, and
//! the README's fixed split of Series B.

use super::root;
use robocal::data::measurement::split;
use robocal::data::{MeasurementSet, Profile, read_measurements};
use robocal::model::{Robot, read_robot};
use std::path::Path;

/// Series B's file, under `datasets/ipa-ur10/`.
pub const SERIES_B: &str = "Series_B/measurements_joint_configurations.csv";
/// Series A's file, under `datasets/ipa-ur10/`.
pub const SERIES_A: &str = "Series_A/measurements_grid.csv";

/// The UR10's nominal model (`datasets/robots/ur10.toml`).
pub fn robot() -> Robot {
    read_robot(root().join("datasets/robots/ur10.toml")).unwrap()
}

/// A series of the shipped UR10 data set, imported through its profile.
pub fn series(robot: &Robot, file: &str) -> MeasurementSet {
    let profile = Profile::read(root().join("datasets/profiles/ipa_ur10.toml")).unwrap();
    let path = root().join("datasets/ipa-ur10").join(file);
    read_measurements(Path::new(&path), robot, &profile, &Default::default())
        .unwrap()
        .0
}

/// Series B, split as in the README: (identification 500, pool 1000, validation 495).
pub fn series_b_split(robot: &Robot) -> (MeasurementSet, MeasurementSet, MeasurementSet) {
    let set = series(robot, SERIES_B);
    let (pool, val) = split(&set, 1000.0 / 1495.0, 11);
    let (id, _) = split(&pool, 0.5, 12);
    (id, pool, val)
}
