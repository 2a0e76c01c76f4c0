//! A check of an identified model against the sizes a calibration can leave: a robot's
//! nominal model misses by millimetres and an identified one by hundredths to tenths, so a
//! model that still misses its own calibration rows by centimetres or degrees does not
//! describe them. The fit is the least-squares answer to a question the data do not pose:
//! measurements in a frame the model does not know (the base not selected), in another
//! unit, joints paired with another reading, or a few rows far off. Said, not refused: the
//! model is written and the user decides.

use super::Measure;
use super::problem::{IdentifyWorkspace, Observations, residual};
use crate::model::Robot;
use nalgebra::Matrix6xX;

/// Position RMS (mm, per row or pair) on the calibration rows beyond which an identified
/// model is flagged: ten times what a nominal model of an industrial robot misses by.
pub const IMPLAUSIBLE_POSITION_MM: f64 = 10.0;

/// Orientation RMS (rad, per row) beyond which an identified model is flagged: 1 deg, about
/// a hundred times what a tracker's orientation sigma is and ten times a nominal model's miss.
pub const IMPLAUSIBLE_ROTATION_RAD: f64 = std::f64::consts::PI / 180.0;

/// RMS over the observations of the position part (mm, the norm of the position components;
/// the displacement error of a pair, the length error of a distance) and of the orientation
/// part (rad) of `robot`'s residuals on `obs`; None for a part the measure lacks.
pub fn misfit(robot: &Robot, obs: &Observations) -> [Option<f64>; 2] {
    let (pos, rot) = match obs.measure {
        Measure::Pose => (0..3, 3..6),
        Measure::Orientation => (0..0, 0..3),
        Measure::Position | Measure::Relative => (0..3, 0..0),
        Measure::Distance => (0..1, 0..0),
    };
    let mut ws = IdentifyWorkspace::new(robot);
    let mut r = [0.0; 6];
    let mut jac = Matrix6xX::zeros(0);
    let mut sums = [0.0; 2];
    for o in &obs.items {
        residual(robot, obs, o, None, &mut ws, &mut r, &mut jac);
        sums[0] += r[pos.clone()].iter().map(|v| v * v).sum::<f64>();
        sums[1] += r[rot.clone()].iter().map(|v| v * v).sum::<f64>();
    }
    let n = obs.items.len().max(1) as f64;
    [
        (!pos.is_empty()).then(|| (sums[0] / n).sqrt()),
        (!rot.is_empty()).then(|| (sums[1] / n).sqrt()),
    ]
}

/// The warning for a model that misses its calibration rows `obs` by more than
/// [`IMPLAUSIBLE_POSITION_MM`] or [`IMPLAUSIBLE_ROTATION_RAD`] RMS; None within both.
/// `registered`: whether the measurement frame was registered; `tool_free`: whether every
/// tool parameter was solved for; `robust`: whether a robust loss weighted the rows.
pub fn warning(
    robot: &Robot,
    obs: &Observations,
    registered: bool,
    tool_free: bool,
    robust: bool,
) -> Option<String> {
    let [pos, rot] = misfit(robot, obs);
    let far: Vec<String> = [
        pos.filter(|p| *p > IMPLAUSIBLE_POSITION_MM)
            .map(|p| format!("{p:.4} mm RMS in position")),
        rot.filter(|r| *r > IMPLAUSIBLE_ROTATION_RAD)
            .map(|r| format!("{:.4} deg RMS in orientation", r.to_degrees())),
    ]
    .into_iter()
    .flatten()
    .collect();
    if far.is_empty() {
        return None;
    }
    let frame = if registered {
        ""
    } else {
        "in a frame the model does not know and was not registered (select every base \
         parameter, e.g. `offsets,base`, with registration on: the frame is then registered \
         first), "
    };
    let tool = if tool_free {
        ""
    } else {
        "; or the model lacks a tool (marker) offset (select the tool)"
    };
    let rows = if robust {
        "see the outliers"
    } else {
        "see the outliers; a robust loss, Huber or Cauchy, weights them down"
    };
    Some(format!(
        "the identified model still misses its calibration rows by {}, far beyond what a \
         calibration leaves (above {IMPLAUSIBLE_POSITION_MM} mm or 1 deg): it does not describe \
         the data. The measurements may be {frame}in another unit, or have joints paired with \
         another reading{tool}; or a few rows are far off ({rows}). Do not use this model as \
         it is",
        far.join(" and ")
    ))
}
