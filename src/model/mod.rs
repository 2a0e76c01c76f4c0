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

/// A three-joint arm whose middle joint is prismatic (revolute, prismatic, revolute; mm and
/// deg as in a robot file), for the unit tests of what tells the joint types apart.
#[cfg(test)]
pub(crate) fn test_rpr_arm() -> Robot {
    Robot::from_toml(
        r#"
[[joint]]
convention = "dh"
d = 100.0
alpha = 90.0
limits = [-360, 360]
[[joint]]
convention = "dh"
alpha = -90.0
type = "prismatic"
limits = [-1000, 1000]
[[joint]]
convention = "dh"
a = 300.0
limits = [-360, 360]
"#,
    )
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
