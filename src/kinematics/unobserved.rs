//! What of a tool pose depends on parameters the model's calibration did not observe
//! ([`Robot::unobserved`]): a position-only tracker never sees the tool's rotation, so a
//! model calibrated on it reaches a desired orientation only as well as the start model's
//! tool rotation is right; a model calibrated on distances keeps the start model's base.
//!
//! The test is a change of one unit (1 mm, 1 deg, or 1 mrad per kN m) of each unobserved
//! parameter: the pose depends on the parameter where that moves its position by more than
//! [`POSITION_TOL_MM`] or turns it by more than [`ROTATION_TOL_RAD`]. The dependence is
//! exactly zero where it is structural (the tool's rotation and the tool point's position),
//! so the tolerances only absorb rounding.

use super::tool_pose;
use crate::geometry::rotation::angle_between;
use crate::model::Robot;

/// Position change (mm) per unit change of a parameter above which a pose depends on it.
pub const POSITION_TOL_MM: f64 = 1e-6;
/// Rotation (rad) per unit change of a parameter above which a pose depends on it.
pub const ROTATION_TOL_RAD: f64 = 1e-9;

/// Which parts of a tool pose depend on unobserved parameters.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Unchecked {
    /// The position (mm) depends on one.
    pub position: bool,
    /// The orientation depends on one.
    pub orientation: bool,
}

/// The model with each unobserved parameter moved by one unit, built once and asked at
/// every configuration.
#[derive(Debug, Clone)]
pub struct UnobservedProbe {
    moved: Vec<Robot>,
}

impl UnobservedProbe {
    /// The probe of `robot`'s unobserved parameters (none: every answer is "checked").
    /// A unit change that leaves the model's bounds is taken the other way.
    pub fn new(robot: &Robot) -> UnobservedProbe {
        let moved = (robot.unobserved().iter())
            .filter_map(|&id| {
                let step = id.field.to_internal(1.0);
                let v = robot.param(id);
                (robot.with_param(id, v + step).ok())
                    .or_else(|| robot.with_param(id, v - step).ok())
            })
            .collect();
        UnobservedProbe { moved }
    }

    /// Whether any parameter is unobserved.
    pub fn is_empty(&self) -> bool {
        self.moved.is_empty()
    }

    /// What of the tool pose at joints `q` (rad or mm) depends on an unobserved parameter;
    /// `robot` is the model the probe was built from.
    pub fn at(&self, robot: &Robot, q: &[f64]) -> Unchecked {
        let mut out = Unchecked::default();
        if self.moved.is_empty() {
            return out;
        }
        let pose = tool_pose(robot, q);
        for m in &self.moved {
            let p = tool_pose(m, q);
            let dp = (p.translation.vector - pose.translation.vector).norm();
            out.position |= dp > POSITION_TOL_MM;
            out.orientation |= angle_between(&p.rotation, &pose.rotation) > ROTATION_TOL_RAD;
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::{Slot, test_fanuc};

    /// The FANUC with six-value base and tool, marking `names`.
    fn marked(names: &[&str]) -> Robot {
        let r = (test_fanuc().with_frame_as_transform(Slot::Base))
            .and_then(|r| r.with_frame_as_transform(Slot::Tool))
            .unwrap();
        let ids: Vec<_> = names.iter().map(|n| r.find_param(n).unwrap()).collect();
        r.with_unobserved(&ids).unwrap()
    }

    #[test]
    fn the_tools_rotation_moves_the_orientation_alone() {
        let r = marked(&["tool.rz", "tool.ry", "tool.rx"]);
        let probe = UnobservedProbe::new(&r);
        let q = [0.3, -0.2, 0.4, 1.0, 0.7, -0.5];
        let u = probe.at(&r, &q);
        assert!(u.orientation && !u.position, "{u:?}");
    }

    #[test]
    fn a_link_length_moves_the_position_and_a_base_shift_not_the_orientation() {
        let q = [0.3, -0.2, 0.4, 1.0, 0.7, -0.5];
        let r = marked(&["a2"]);
        let u = UnobservedProbe::new(&r).at(&r, &q);
        assert!(u.position && !u.orientation, "{u:?}");
        let r = marked(&["base.x", "base.y"]);
        let u = UnobservedProbe::new(&r).at(&r, &q);
        assert!(u.position && !u.orientation, "{u:?}");
        let r = marked(&["alpha3"]);
        let u = UnobservedProbe::new(&r).at(&r, &q);
        assert!(u.position && u.orientation, "{u:?}");
    }

    #[test]
    fn an_unmarked_model_is_checked_everywhere() {
        let r = test_fanuc();
        let probe = UnobservedProbe::new(&r);
        assert!(probe.is_empty());
        assert_eq!(probe.at(&r, &[0.1; 6]), Unchecked::default());
    }
}
