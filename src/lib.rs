//! robocal: kinematic calibration of industrial robots.
//!
//! Units: files and the command line use mm and degrees; everything inside uses mm and
//! radians. Poses are [`geometry::Pose`] (a rotation matrix and a translation in mm).

pub mod compensation;
pub mod data;
pub mod error;
pub mod evaluate;
pub mod geometry;
pub mod identify;
pub mod io;
pub mod kinematics;
pub mod model;
pub mod neural;
#[cfg(feature = "plot")]
pub mod plot;
#[cfg(feature = "report")]
pub mod report;
pub mod sim;
pub mod stats;
pub mod studies;

pub use error::{Error, Result};
pub use geometry::Pose;
pub use model::Robot;
