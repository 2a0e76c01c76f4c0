//! Robot models: rows, joints, named parameters and robot files.

pub(crate) mod axes;
pub(crate) mod chain;
pub mod compliance;
pub mod file;
pub(crate) mod joint;
pub mod mass;
pub mod robot;
pub mod row;

pub use compliance::Compliance;
pub use file::{read_robot, robot_to_toml, write_robot};
pub use mass::{BodyMass, MassProperties};
pub use robot::{
    Joint, JointType, LIMIT_TOL, MAX_ANGLE_DEG, MAX_JOINT_DEG, MAX_LENGTH_MM, ParamId, Robot, Slot,
    joint_distance,
};
pub use row::{Convention, Field, Row};

/// The shipped FANUC R-2000iB/210F's nominal model, for the unit tests.
#[cfg(test)]
pub(crate) fn test_fanuc() -> Robot {
    read_robot(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/datasets/robots/fanuc_r2000ib_210f.toml"
    ))
    .unwrap()
}

/// The shipped UR10's nominal model, for the unit tests.
#[cfg(test)]
pub(crate) fn test_ur10() -> Robot {
    read_robot(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/datasets/robots/ur10.toml"
    ))
    .unwrap()
}
