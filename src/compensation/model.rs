//! The calibrated forward model that target compensation inverts: the identified model
//! (rigid or compliant), or a compensator (its embedded model and network in series).

use crate::kinematics::{Frames, Pose, ToolModel, frames, joint_jacobian};
use crate::model::Robot;
use crate::neural::compensator::Compensator;
use crate::neural::predict::PredictWorkspace;
use nalgebra::Matrix6xX;

/// What the robot really does at joints q, as far as calibration knows.
pub enum CalibratedModel<'a> {
    /// The identified kinematic model (compliant when its file has compliances).
    Identified {
        /// The identified robot model.
        robot: &'a Robot,
        /// Forward-kinematics workspace sized for `robot`.
        frames: Frames,
    },
    /// A compensator in series with its model.
    Compensated {
        /// The compensator: its embedded robot model and network.
        compensator: &'a Compensator,
        /// Scratch space for the compensator's predictions.
        ws: Box<PredictWorkspace>,
        /// Forward-kinematics workspace sized for the compensator's robot.
        frames: Frames,
    },
}

impl<'a> CalibratedModel<'a> {
    /// The kinematic model of `robot`, with a fresh workspace.
    pub fn identified(robot: &'a Robot) -> Self {
        CalibratedModel::Identified {
            robot,
            frames: Frames::new(robot),
        }
    }

    /// The model of `compensator` (its kinematic model plus network), with fresh workspaces.
    pub fn compensated(compensator: &'a Compensator) -> Self {
        CalibratedModel::Compensated {
            compensator,
            ws: Box::default(),
            frames: Frames::new(&compensator.robot),
        }
    }
}

impl ToolModel for CalibratedModel<'_> {
    fn robot(&self) -> &Robot {
        match self {
            CalibratedModel::Identified { robot, .. } => robot,
            CalibratedModel::Compensated { compensator, .. } => &compensator.robot,
        }
    }

    fn pose(&mut self, q: &[f64]) -> Pose {
        match self {
            CalibratedModel::Identified { robot, frames: f } => {
                frames(robot, q, f);
                f.tool
            }
            CalibratedModel::Compensated {
                compensator, ws, ..
            } => compensator.predict(q, ws),
        }
    }

    fn jacobian(&mut self, q: &[f64], jac: &mut Matrix6xX<f64>) {
        match self {
            CalibratedModel::Identified { robot, frames: f } => {
                frames(robot, q, f);
                joint_jacobian(robot, f, jac);
            }
            CalibratedModel::Compensated {
                compensator,
                ws,
                frames: f,
            } => compensator.jacobian(q, ws, f, jac),
        }
    }
}
