//! Forward and inverse kinematics.
//!
//! Joint vectors are in internal units: rad for revolute joints, mm for prismatic ones.

pub mod fk;
pub mod fold;
pub mod gravity;
pub mod ik;
pub mod ik_closed;
pub mod ik_numeric;
pub mod ik_parallel;
pub mod jacobian;
pub mod load;
pub mod reach;
pub mod same_arm;
pub mod spread;
pub mod subproblems;
pub mod unobserved;

pub use fk::{Frames, frames, tool_pose};
pub use ik::{IkFailure, IkSolver, IkStart, Solved, joint_distance};
pub use ik_closed::{Branch, ClosedFormIk};
pub use ik_numeric::{
    IkOptions, IkSolution, IkTarget, IkWorkspace, RobotModel, ToolModel, solve_model, solve_numeric,
};
pub use jacobian::joint_jacobian;
pub use reach::Reach;
pub use same_arm::{GEOMETRY_GAP, another_arm, arm_distance_gap, tool_gap};
pub use unobserved::{Unchecked, UnobservedProbe};

pub use crate::geometry::{Pose, pose_from_file, pose_to_file};
