//! The shipped UR10 series (real laser-tracker data), imported through their profile, and
//! the README's fixed split of Series B.

use super::root;
use robocal::data::measurement::split;
use robocal::data::{MeasurementSet, Profile, read_measurements};
use robocal::model::file::parse_robot;
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

/// The UR10's nominal DH rows (theta deg, d mm, a mm, alpha deg).
pub const UR10_NOMINAL_ROWS: [[f64; 4]; 6] = [
    [0.0, 127.3, 0.0, 90.0],
    [0.0, 0.0, -612.0, 0.0],
    [0.0, 0.0, -572.3, 0.0],
    [0.0, 163.941, 0.0, 90.0],
    [0.0, 115.7, 0.0, -90.0],
    [0.0, 92.2, 0.0, 0.0],
];

/// A calibrated UR10: its nominal's DH table off by what an identification on tracker data
/// finds (millimetres, a tenth of a degree), so no closed form of its own: its rows (as
/// [`UR10_NOMINAL_ROWS`]), base and tool (x, y, z mm, rz, ry, rx deg).
pub const UR10_CALIBRATED_ROWS: [[f64; 4]; 6] = [
    [0.0, 127.3, -2.8399, 89.9784],
    [-0.0045, 0.5440, -614.9671, 0.1135],
    [0.1658, 0.0, -573.4083, 0.0698],
    [-0.0691, 163.941, -1.3230, 90.0973],
    [0.1673, 118.6177, 2.2950, -89.8583],
    [0.0, 92.2, 0.0, 0.0],
];
pub const UR10_CALIBRATED_BASE: [f64; 6] = [2.2255, -1.2867, 3.1296, 0.2193, 0.0740, 0.1429];
pub const UR10_CALIBRATED_TOOL: [f64; 6] = [1.7597, 0.6367, 0.1911, 0.1723, -0.1047, -0.2924];

/// A UR10 robot file (DH rows, joints within +-360 deg) of `rows`, `base` and `tool` (as
/// [`UR10_CALIBRATED_ROWS`]); every number written in its shortest exact form.
pub fn ur10_file(name: &str, rows: &[[f64; 4]; 6], base: &[f64; 6], tool: &[f64; 6]) -> String {
    let frame = |name: &str, v: &[f64; 6]| {
        let keys = ["x", "y", "z", "rz", "ry", "rx"];
        let lines: Vec<String> = (keys.iter().zip(v))
            .map(|(k, x)| format!("{k} = {x}"))
            .collect();
        format!(
            "[{name}]\nconvention = \"transform\"\n{}\n",
            lines.join("\n")
        )
    };
    let mut file = format!("name = \"{name}\"\n{}", frame("base", base));
    for [theta, d, a, alpha] in rows {
        file += &format!(
            "[[joint]]\nconvention = \"dh\"\ntheta = {theta}\nd = {d}\na = {a}\nalpha = {alpha}\n\
             limits = [-360.0, 360.0]\n"
        );
    }
    file + &frame("tool", tool)
}

/// [`UR10_CALIBRATED_ROWS`] with its base and tool as a robot.
pub fn ur10_calibrated() -> Robot {
    let file = ur10_file(
        "UR10, calibrated",
        &UR10_CALIBRATED_ROWS,
        &UR10_CALIBRATED_BASE,
        &UR10_CALIBRATED_TOOL,
    );
    parse_robot(&file, Path::new("ur10_cal.toml")).unwrap()
}

/// The robot file of a UR10 with four times the deviations of [`UR10_CALIBRATED_ROWS`] (and
/// its base and tool) from the nominal.
pub fn ur10_four_times_file() -> String {
    let mut rows = UR10_NOMINAL_ROWS;
    for (row, c) in rows.iter_mut().zip(&UR10_CALIBRATED_ROWS) {
        for (n, c) in row.iter_mut().zip(c) {
            *n += 4.0 * (c - *n);
        }
    }
    let times_four = |v: &[f64; 6]| v.map(|x| 4.0 * x);
    ur10_file(
        "UR10 x4",
        &rows,
        &times_four(&UR10_CALIBRATED_BASE),
        &times_four(&UR10_CALIBRATED_TOOL),
    )
}

/// [`ur10_four_times_file`]'s robot.
pub fn ur10_four_times() -> Robot {
    parse_robot(&ur10_four_times_file(), Path::new("ur10_x4.toml")).unwrap()
}
