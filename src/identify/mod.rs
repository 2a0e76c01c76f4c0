//! Parametric identification (thesis ch. 4): which parameters the data can identify, and
//! their estimates by Levenberg-Marquardt, Gauss-Newton or Nelder-Mead.

pub mod candidates;
pub mod chained;
pub mod identifiability;
pub mod jacobian;
pub mod nelder_mead;
pub mod outliers;
pub mod plausibility;
pub mod problem;
pub mod register;
pub mod run;
pub mod select;
pub mod solve;
pub mod unmodelled;

pub use candidates::candidates;
pub use jacobian::parameter_jacobian;
pub use problem::{Measure, Sigmas};
pub use run::{Effort, Identified, Options, RobustLoss, identify};
pub use solve::{Method, SolveOptions, StopReason};
pub use unmodelled::Unmodelled;
