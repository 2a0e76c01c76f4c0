//! Target compensation ("fake targets", thesis 2.7): the controller keeps its nominal model,
//! so to reach a desired pose T it is given the pose F = FK_nominal(q*) where q* are the
//! joints at which the calibrated (and optionally network-compensated) model reaches T. The
//! controller's own inverse kinematics of F, on the same configuration branch (without a
//! nominal closed form: its solution nearest the same seed joints), returns q*.

pub mod fake_target;
pub mod model;
pub mod nearest;

pub use fake_target::{Command, Failure, FakeTargetSolver};
pub use model::CalibratedModel;
