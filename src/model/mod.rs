//! Robot models: rows, joints, named parameters and robot files.

pub(crate) mod axes;
pub mod file;
pub mod robot;
pub mod row;

pub use file::{read_robot, robot_to_toml, write_robot};
pub use robot::{Joint, JointType, ParamId, Robot, Slot};
pub use row::{Convention, Field, Row};
