//! robocal: kinematic calibration of industrial robots.
//!
//! Units: files and the command line use mm and degrees; everything inside uses mm and
//! radians. Poses are [`geometry::Pose`] (a rotation matrix and a translation in mm).
//!
//! The modules run one way, each using only those below it: [`geometry`] -> [`model`] (a
//! [`Robot`] that never changes during a solve) -> [`kinematics`] (allocation-free free
//! functions over a robot and a reused workspace) -> [`data`] (measurements and tables) ->
//! [`identify`], [`sim`], [`evaluate`] -> [`neural`] (the compensator) -> [`compensation`]
//! (commands for an unmodified controller) -> `plot` (feature `plot`) -> [`studies`] (the
//! thesis's protocols) -> [`reports`] (typed reports; their HTML page with feature `report`).
//! Every file-reading entry point has an in-memory twin
//! (`Robot::from_toml`, `MeasurementSet::from_csv`, `Compensator::from_text`).
//!
//! Identify a robot's parameters from measurements and check the result:
//!
//! ```
//! use robocal::data::MeasurementSet;
//! use robocal::identify::{Options, identify};
//! use robocal::kinematics::{pose_to_file, tool_pose};
//! use robocal::model::read_robot;
//!
//! # fn main() -> robocal::Result<()> {
//! let nominal = read_robot("datasets/robots/fanuc_r2000ib_210f.toml")?;
//! // A "real" robot: joint 2 is 0.05 deg off its zero. Measure its tool at 12 poses.
//! let theta2 = nominal.find_param("theta2").unwrap();
//! let real = nominal.with_param(theta2, nominal.param(theta2) + 0.05f64.to_radians())?;
//! let mut csv = String::from("q1,q2,q3,q4,q5,q6,x,y,z,rz,ry,rx\n");
//! for k in 0..12 {
//!     let q = [10.0 * k as f64 - 60.0, 5.0 + k as f64, -10.0, 20.0, -40.0 + 3.0 * k as f64, 15.0];
//!     let p = pose_to_file(&tool_pose(&real, &real.joints_to_internal(&q)));
//!     let cells: Vec<String> = q.iter().chain(&p).map(|v| v.to_string()).collect();
//!     csv.push_str(&(cells.join(",") + "\n"));
//! }
//! let (set, _) = MeasurementSet::from_csv(&csv, &nominal)?;
//! let id = identify(&nominal, &set, &Options { params: "offsets".into(), ..Default::default() })?;
//! let offset = id.parameters.iter().find(|p| p.name == "theta2").unwrap();
//! assert!((offset.estimate - offset.nominal - 0.05).abs() < 1e-6); // deg
//! # Ok(())
//! # }
//! ```

#![warn(missing_docs)]

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
pub mod plan;
#[cfg(feature = "plot")]
pub mod plot;
pub mod reports;
pub mod sim;
pub mod stats;
pub mod studies;

pub use error::{Error, Result};
pub use geometry::Pose;
pub use model::Robot;
