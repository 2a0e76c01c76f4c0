//! Geometry every other module builds on: rigid poses and rotations (mm, rad inside; mm and
//! degrees in files).

pub mod pose;
pub mod rotation;

pub use pose::{Pose, pose_from_file, pose_to_file};
