//! Measurement and batch data in CSV files.

pub mod configuration;
pub mod joints;
pub mod measurement;
pub mod pairs;
pub mod profile;
pub mod shared_readings;
pub mod table;
pub mod targets;

pub use joints::JointTable;
pub use measurement::{
    JointInfo, Measurement, MeasurementSet, ReadOptions, ReadReport, read_canonical,
    read_measurements, write_measurements,
};
pub use profile::Profile;
pub use table::Table;
pub use targets::{Target, TargetTable};

use crate::error::{Error, Location, Result};

/// The header of an output that carries table `t`'s columns (`carried`, renamed or not) and
/// adds `written`: a carried column whose name is written is kept as `input_<name>`; a name
/// that would still appear twice is refused (the CSV would be ambiguous and JSON would keep
/// only one of them).
pub fn output_headers(t: &Table, carried: Vec<String>, written: &[String]) -> Result<Vec<String>> {
    let mut headers: Vec<String> = carried
        .into_iter()
        .map(|h| {
            if written.contains(&h) {
                format!("input_{h}")
            } else {
                h
            }
        })
        .collect();
    headers.extend(written.iter().cloned());
    for (i, h) in headers.iter().enumerate() {
        if headers[..i].contains(h) {
            return Err(Error::input(
                Location::at(&t.path, 1, h.clone()),
                "this column would appear twice in the output (the input's own, renamed or \
                 not, and one the command writes); rename or drop it",
            ));
        }
    }
    Ok(headers)
}

/// Names of the joint columns `q1..qN` (deg, or mm for prismatic joints).
pub fn joint_columns(n: usize) -> Vec<String> {
    (1..=n).map(|i| format!("q{i}")).collect()
}

/// Refuses a table with a joint column beyond the robot's `n` (`q{n+1}`): its rows are
/// another robot's, and dropping that joint would be silent.
pub fn no_extra_joint(t: &table::Table, n: usize) -> crate::error::Result<()> {
    let next = format!("q{}", n + 1);
    match t.column(&next) {
        Some(_) => Err(crate::error::Error::input(
            crate::error::Location::at(&t.path, 1, next),
            format!(
                "a joint column beyond the robot's {n} joints: is this file for another robot?"
            ),
        )),
        None => Ok(()),
    }
}

/// Names of the pose columns: position (mm) and Z-Y-X Euler angles (deg, R = Rz Ry Rx).
pub const POSE_COLUMNS: [&str; 6] = ["x", "y", "z", "rz", "ry", "rx"];
