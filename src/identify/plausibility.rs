//! A check of an identified model against the sizes a calibration can leave: a robot's
//! nominal model misses by millimetres and an identified one by hundredths to tenths, so a
//! model that still misses its own calibration rows by centimetres or degrees does not
//! describe them. The fit is the least-squares answer to a question the data do not pose:
//! measurements in a frame the model does not know (the base not selected), in another
//! unit, joints paired with another reading, or a few rows far off. Said, not refused: the
//! model is written and the user decides.

use super::Measure;
use super::problem::{Observations, residuals};
use crate::data::MeasurementSet;
use crate::data::measurement::{copied_rows, row_name};
use crate::model::{ParamId, Robot};

/// Position RMS (mm, per row or pair) on the calibration rows beyond which an identified
/// model is flagged: ten times what a nominal model of an industrial robot misses by.
pub const IMPLAUSIBLE_POSITION_MM: f64 = 10.0;

/// Orientation RMS (rad, per row) beyond which an identified model is flagged: 1 deg, about
/// a hundred times what a tracker's orientation sigma is and ten times a nominal model's miss.
pub const IMPLAUSIBLE_ROTATION_RAD: f64 = std::f64::consts::PI / 180.0;

/// RMS over the observations of the position part (mm, the norm of the position components;
/// the displacement error of a pair, the length error of a distance) and of the orientation
/// part (rad) of `robot`'s residuals on `obs`; None for a part the measure lacks. For single
/// rows these are the RMS figures of `evaluate` (which identify cannot call: it sits above).
pub fn misfit(robot: &Robot, obs: &Observations) -> [Option<f64>; 2] {
    let (pos, rot) = match obs.measure {
        Measure::Pose => (0..3, 3..6),
        Measure::Orientation => (0..0, 0..3),
        Measure::Position | Measure::Relative => (0..3, 0..0),
        Measure::Distance => (0..1, 0..0),
    };
    let square = |r: &[f64]| r.iter().map(|v| v * v).sum::<f64>();
    let rs = residuals(robot, obs);
    let rms = |part: std::ops::Range<usize>| {
        let sum: f64 = rs.iter().map(|r| square(&r[part.clone()])).sum();
        (!part.is_empty()).then(|| (sum / rs.len().max(1) as f64).sqrt())
    };
    [rms(pos), rms(rot)]
}

/// Standard deviations of s^2 above 1 (sqrt(2 / dof): s^2 is a chi-square over its degrees
/// of freedom where the rows' sigmas are their noise) beyond which the model is said to leave
/// out errors ([`variance_factor_warning`]).
pub const VARIANCE_FACTOR_SIGMAS: f64 = 3.0;

/// The warning for a variance factor `s2` (with `dof` degrees of freedom, residual components
/// less parameters) above 1 by more than [`VARIANCE_FACTOR_SIGMAS`] of its standard
/// deviations: the model misses the rows by more than their noise, and its standard
/// deviations, scaled by s, take that miss for noise. The caller leaves it out where an
/// unmodelled error was added to the sigmas, whose note says the same. With `compliance`
/// (joint compliances among the parameters) it does not suggest them. On the FANUC with the
/// shipped gravity compliance and gear errors (50 rows, s^2 = 22) a helper found 6 of 30
/// estimates more than 3 reported standard deviations from the truth over 200 seeds, with
/// no word said.
pub fn variance_factor_warning(s2: f64, dof: usize, compliance: bool) -> Option<String> {
    if dof == 0 || !s2.is_finite() {
        return None;
    }
    let bound = 1.0 + VARIANCE_FACTOR_SIGMAS * (2.0 / dof as f64).sqrt();
    (s2 > bound).then(|| {
        format!(
            "the variance factor s^2 = {s2:.2} lies above {bound:.2} (1 + \
             {VARIANCE_FACTOR_SIGMAS} sqrt(2 / {dof}), where the rows' sigmas are their \
             noise): the model misses the rows by {:.1} times their sigmas, from errors it \
             leaves out (joint compliance under gravity, gear errors), rows far off, or sigmas \
             set too small. The standard deviations are scaled by s, but an error of the model \
             is not noise: the estimates can be off by more than they say ({}`train` learns \
             what the model leaves)",
            s2.sqrt(),
            if compliance {
                ""
            } else {
                "`--params full,compliance` where gravity bends the joints; "
            }
        )
    })
}

/// Spread (max - min over the rows; deg for a revolute joint, mm for a prismatic one) under
/// which a joint counts as held at one value: its motion cannot tell apart the parameters
/// that move with it (those after it in the chain and its own offset), whose regroupings
/// then hold at that value only.
pub const HELD_JOINT_SPREAD: f64 = 1.0;

/// The warning for rows in which some joints hold one value (spread under
/// [`HELD_JOINT_SPREAD`] deg or mm) while parameters of their rows or of the joint rows
/// after them are solved for (`ids`): those the joints' motion would tell apart come out as
/// combinations that hold at that value only (a FANUC with q5 held at 25 deg fits its rows
/// to the noise and misses other q5 by 2.1 mm RMS), or, where the rest of the rows cannot
/// hold them, wander far (a KUKA with q4 held: lengths moved by 62 mm, 24 mm RMS on other
/// rows). None where every joint moves, or where only the base and tool are solved for (the
/// joints' own model turns the tool with them).
pub fn held_joints_warning(robot: &Robot, set: &MeasurementSet, ids: &[ParamId]) -> Option<String> {
    if set.rows.len() < 2 {
        return None;
    }
    let moved = |j: usize| {
        ids.iter()
            .any(|p| matches!(p.slot, crate::model::Slot::Joint(k) if k >= j))
    };
    let held: Vec<String> = (robot.joints().iter().enumerate())
        .filter(|(j, _)| moved(*j))
        .filter_map(|(j, joint)| {
            let values = set.rows.iter().filter_map(|r| r.q.get(j).copied());
            let (lo, hi) = values.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
                (lo.min(v), hi.max(v))
            });
            let unit = joint.joint_type.file_unit();
            let [lo, hi] = [lo, hi].map(|v| joint.joint_type.to_file(v));
            (hi - lo < HELD_JOINT_SPREAD)
                .then(|| format!("q{} within {lo:.4} to {hi:.4} {unit}", j + 1))
        })
        .collect();
    (!held.is_empty()).then(|| {
        format!(
            "{}: {} joint(s) hold one value in these rows ({}; under {HELD_JOINT_SPREAD} deg \
             or mm of spread): the parameters their motion would tell apart are identified \
             as combinations that hold at that value only (see the left-out parameters and \
             the standard deviations), and the model may miss by far more elsewhere; measure \
             over each joint's range, or use the model at those values only",
            set.source.display(),
            held.len(),
            held.join(", ")
        )
    })
}

/// Distance (deg) from ry = +-90 deg within which a 6-DOF row's Z-Y-X angles are near their
/// gimbal lock: there rz and rx turn about axes less than this apart, so only rz - rx
/// (rz + rx at -90 deg) is well determined, and a rotation of the frame by a fraction of a
/// milliradian moves the two by tens of degrees.
pub const GIMBAL_LOCK_DEG: f64 = 2.0;

/// Notes on the identified 6-DOF base and tool rows of `robot` whose rotation was solved for
/// (`ids`) and whose ry lies within [`GIMBAL_LOCK_DEG`] of +-90 deg: their rz and rx, and
/// those angles' standard deviations, describe the frame through a nearly singular map (a
/// wall- or ceiling-mounted base, a tool along the flange's x), so the file's rz and rx may
/// lie far from the start's with the frame itself close to it.
///
/// `rebased`: the frames whose rotation the solve took as turns about their own axes
/// (`Robot::with_frames_rebased`): the note says so, and that their
/// standard deviations are those turns'.
pub fn gimbal_notes(robot: &Robot, ids: &[ParamId], rebased: &[crate::model::Slot]) -> Vec<String> {
    use crate::model::{Convention, Field, Slot};
    [
        (Slot::Base, "base", robot.base()),
        (Slot::Tool, "tool", robot.tool()),
    ]
    .into_iter()
    .filter(|(slot, _, row)| {
        row.convention() == Convention::Transform
            && ids
                .iter()
                .any(|p| p.slot == *slot && matches!(p.field, Field::Rz | Field::Rx))
    })
    .filter_map(|(slot, name, row)| {
        let ry = row.file_value(Field::Ry)?;
        let turns = if rebased.contains(&slot) {
            format!(
                " (the solve took {name}'s rotation as turns about its start frame's own z, y \
                 and x axes, which the lock does not touch: the frame is identified in full, \
                 and the standard deviations of {name}.rz, .ry and .rx are those turns')"
            )
        } else {
            String::new()
        };
        let off = 90.0 - ry.abs();
        if off.abs() >= GIMBAL_LOCK_DEG {
            // Rebased within a few degrees more of the lock: only the turns are told of.
            return rebased.contains(&slot).then(|| {
                format!(
                    "{name}: ry = {ry:.4} deg lies {:.4} deg from {}90 deg, near the gimbal \
                     lock of Z-Y-X angles{turns}",
                    off.abs(),
                    if ry > 0.0 { "+" } else { "-" }
                )
            });
        }
        Some({
            let (sum, sign) = if ry > 0.0 {
                ("rz - rx", "+")
            } else {
                ("rz + rx", "-")
            };
            format!(
                "{name}: ry = {ry:.4} deg lies {:.4} deg from {sign}90 deg, the gimbal lock \
                     of Z-Y-X angles: there {name}.rz and {name}.rx turn the frame about nearly \
                     the same axis, so only {sum} is well determined, and a rotation of the \
                     frame by a fraction of a milliradian moves the two by tens of degrees; \
                     compare frames (poses), not these angles, with another calibration's{turns}",
                off.abs()
            )
        })
    })
    .collect()
}

/// The warning for an identified model that is not a calibration of its start `start` (its
/// distances between flange or tool positions at the same joints differ by more than a
/// tenth of the arm, [`crate::kinematics::another_arm`]): where it fits its data (`identify`
/// asks only then, [`warning`] being silent), the robot file describes another robot than
/// the data's, whose fit moved lengths by hundreds of millimetres, or rows that cannot tell
/// the parameters apart let the fit move them by as much. `compensate` refuses such a model.
pub fn another_arm_warning(start: &Robot, identified: &Robot) -> Option<String> {
    crate::kinematics::another_arm(start, identified).map(|gap| {
        format!(
            "the identified model fits its data but is not a calibration of the start model: \
             {gap}: the robot file describes another robot than the data's, or the rows \
             cannot tell the parameters apart (too few or too close together: see the nearly \
             aliased pairs and the condition number) and the fit moved them along what they \
             do not see (`compensate` refuses such a model)"
        )
    })
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
    // A distance between two poses of the tool is the same in every frame: the frame is no
    // cause there.
    let frame = if registered || matches!(obs.measure, Measure::Distance) {
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

/// The warning for rows of `set` that repeat an earlier row to the last digit
/// ([`copied_rows`]): they count one reading twice.
pub fn copied_warning(set: &MeasurementSet) -> Option<String> {
    let copied = copied_rows(set);
    if copied.is_empty() {
        return None;
    }
    let name = |i: usize| row_name(set.rows[i].line, i);
    let shown: Vec<String> = (copied.iter().take(5))
        .map(|&(i, j)| format!("{} repeats {}", name(i), name(j)))
        .collect();
    Some(format!(
        "{}: {} row(s) repeat an earlier row to the last digit, joints and reading ({}{}): a \
         repeated measurement reads differently in its last digits; copied rows count one \
         reading twice and make the standard deviations look smaller than they are (by \
         sqrt(2) for a set doubled). Remove them if they were copied",
        set.source.display(),
        copied.len(),
        shown.join(", "),
        if copied.len() > 5 { ", ..." } else { "" }
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::{Slot, test_fanuc};

    fn with(robot: &Robot, name: &str, value: f64) -> Robot {
        let id = robot.find_param(name).unwrap();
        robot.with_param(id, value).unwrap()
    }

    #[test]
    fn a_frame_near_its_gimbal_lock_is_noted() {
        let robot = test_fanuc().with_frame_as_transform(Slot::Base).unwrap();
        let ids = |r: &Robot| vec![r.find_param("base.rz").unwrap()];
        let wall = with(&robot, "base.ry", 89.94f64.to_radians());
        let notes = gimbal_notes(&wall, &ids(&wall), &[]);
        assert_eq!(notes.len(), 1, "{notes:?}");
        assert!(notes[0].starts_with("base: ry = 89.9400 deg lies 0.0600 deg from +90"));
        assert!(notes[0].contains("only rz - rx"), "{}", notes[0]);
        let ceiling = with(&robot, "base.ry", (-91.5f64).to_radians());
        let notes = gimbal_notes(&ceiling, &ids(&ceiling), &[]);
        assert!(
            notes.len() == 1 && notes[0].contains("only rz + rx"),
            "{notes:?}"
        );
        // 2.5 deg away, or the angles not solved for: nothing to say.
        let tilted = with(&robot, "base.ry", 87.5f64.to_radians());
        assert!(gimbal_notes(&tilted, &ids(&tilted), &[]).is_empty());
        assert!(gimbal_notes(&wall, &[wall.find_param("base.x").unwrap()], &[]).is_empty());
    }

    #[test]
    fn a_model_of_another_arm_is_warned_of() {
        let robot = test_fanuc();
        let a3 = robot.param(robot.find_param("a3").unwrap());
        let calibrated = with(&with(&robot, "a3", a3 + 2.0), "d4", -1281.0);
        assert_eq!(another_arm_warning(&robot, &calibrated), None);
        let other = with(&robot, "a3", a3 + 500.0);
        let w = another_arm_warning(&robot, &other).expect("a warning");
        assert!(w.contains("not a calibration of the start model"), "{w}");
    }
}
