//! Measurement and batch data in CSV files.

pub mod measurement;
pub mod pairs;
pub mod profile;
pub mod table;

pub use measurement::{
    JointInfo, Measurement, MeasurementSet, ReadOptions, ReadReport, read_canonical,
    read_measurements, write_measurements,
};
pub use profile::Profile;
pub use table::Table;

/// Names of the joint columns `q1..qN` (deg, or mm for prismatic joints).
pub fn joint_columns(n: usize) -> Vec<String> {
    (1..=n).map(|i| format!("q{i}")).collect()
}

/// Names of the pose columns: position (mm) and Z-Y-X Euler angles (deg, R = Rz Ry Rx).
pub const POSE_COLUMNS: [&str; 6] = ["x", "y", "z", "rz", "ry", "rx"];
