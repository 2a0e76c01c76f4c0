//! `robocal predict`, and loading a compensator for the commands that run one.

use super::output::{OutputArgs, num};
use anyhow::{Context, Result};
use clap::Args;
use robocal::data::JointTable;
use robocal::kinematics::pose_to_file;
use robocal::model::Robot;
use robocal::neural::compensator::Compensator;
use robocal::neural::predict::PredictWorkspace;
use std::path::{Path, PathBuf};

/// Loads a compensator to use beside `robot` (read from `robot_path`), with a note for the
/// user when it runs with a model other than that file's.
pub fn load_compensator(
    path: &Path,
    robot_path: &Path,
    robot: &Robot,
    warnings: &mut super::warnings::Warnings,
) -> Result<(Compensator, Option<String>)> {
    let mut c = Compensator::load_for(path, robot)?;
    let mut notes = Vec::new();
    // Joint limits are the cell's: the robot file given holds, not the file the compensator
    // was trained with (its embedded model's), so that a narrowed range is obeyed.
    let (limited, changed) = c.robot.with_limits_of(robot)?;
    if !changed.is_empty() {
        notes.push(format!(
            "note: the joint limits of {} hold, not those the compensator was trained with \
             (joint(s) {})",
            robot_path.display(),
            changed
                .iter()
                .map(usize::to_string)
                .collect::<Vec<_>>()
                .join(", ")
        ));
        c.robot = limited;
    }
    // The embedded model's base far from the robot file's: trained in another measurement
    // frame (another tracker set-up), whose poses are not the robot file's.
    if let Some((mm, deg)) = bases_apart(robot, &c.robot) {
        warnings.say(format!(
            "the compensator's model has its base {mm:.1} mm and {deg:.1} deg from {}'s: it was \
             trained in another frame (another measurement set-up), and its poses are in that \
             frame, not in the robot file's",
            robot_path.display()
        ));
    }
    // The tool and the payload are the cell's too (another gripper, another load). Where
    // the robot file is the compensator's own unrefined model with another tool or payload,
    // they hold; where the model differs otherwise (refined in training, another
    // identification), an edit cannot be told from the calibration, and the note says what
    // the compensator runs with instead.
    let (cell, tool, payload) = c.robot.with_tool_and_payload_of(robot)?;
    let differs = cell_differences(&c.robot, robot, tool, payload);
    if (tool || payload)
        && c.model_refined == Some(false)
        && robocal::model::robot_to_toml(&cell) == robocal::model::robot_to_toml(robot)
    {
        let pose_form = tool && c.form == robocal::neural::settings::Form::Pose && c.has_network();
        let what = match (tool, payload) {
            (true, true) => "tool and payload",
            (true, false) => "tool",
            _ => "payload",
        };
        // A warning, not a note: a tool of another calibration (the nominal file given
        // where the identified one belongs) looks the same as a new gripper, and its
        // commands would miss by the difference.
        let path = robot_path.display();
        warnings.say(format!(
            "the {what} of {path} hold{}, not the {what} the compensator was trained with \
             ({differs}){}: right for a new gripper or load, wrong where {path} is another \
             calibration of the same robot (its nominal file, say): then give the file the \
             compensator was trained with",
            if tool && payload { "" } else { "s" },
            if pose_form {
                "; its network corrects the pose of the tool it was trained with, and moves \
                 another tool's point a little otherwise (train it again with this file for \
                 the new tool's own correction)"
            } else {
                ""
            }
        ));
        c.robot = cell;
    } else if c.runs_another_model(robot) {
        notes.push(format!(
            "note: the compensator runs in series with its own model (embedded: the model it \
             was trained with, or that model refined in training), not with {}{}",
            robot_path.display(),
            if tool || payload {
                format!(
                    ", and with that model's tool and payload ({differs}): for another tool or \
                     payload, train it again with the robot file that has them"
                )
            } else {
                String::new()
            }
        ));
    }
    // Its figures are labelled as a network's (`+net`): say that none is there.
    if !c.has_network() {
        notes.push(
            "note: the compensator has no network (training kept its model alone): it \
             corrects by its embedded model only"
                .to_string(),
        );
    }
    Ok((c, (!notes.is_empty()).then(|| notes.join("\n"))))
}

/// How the tool and payload of `file` differ from the compensator's `own` model's (those
/// flagged): the tool's offset (mm) and rotation (deg), the payloads' masses (kg).
fn cell_differences(own: &Robot, file: &Robot, tool: bool, payload: bool) -> String {
    let mut parts = Vec::new();
    if tool {
        let d = own.tool().transform().inverse() * file.tool().transform();
        parts.push(format!(
            "tool {:.3} mm and {:.3} deg apart",
            d.translation.vector.norm(),
            d.rotation.angle().to_degrees()
        ));
    }
    if payload && let (Some(a), Some(b)) = (own.masses(), file.masses()) {
        let (a, b) = (&a.payload, &b.payload);
        parts.push(if a.mass_kg != b.mass_kg {
            format!("payload {} kg, trained with {} kg", b.mass_kg, a.mass_kg)
        } else {
            let c = |v: &nalgebra::Vector3<f64>| format!("[{}, {}, {}]", v.x, v.y, v.z);
            format!(
                "payload centre of mass {} mm, trained with {} mm",
                c(&b.com_mm),
                c(&a.com_mm)
            )
        });
    }
    parts.join("; ")
}

/// Base offset (mm) and rotation (deg) between two models of one robot beyond which their
/// bases lie in different frames (a base registered to a tracker's): far beyond a base's
/// calibration correction (millimetres, tenths of a degree).
const FRAME_APART_MM: f64 = 100.0;
const FRAME_APART_DEG: f64 = 5.0;

/// The offset (mm) and rotation (deg) of `b`'s base from `a`'s where they lie in different
/// frames (beyond [`FRAME_APART_MM`] or [`FRAME_APART_DEG`]), else None.
pub fn bases_apart(a: &Robot, b: &Robot) -> Option<(f64, f64)> {
    let d = a.base().transform().inverse() * b.base().transform();
    let (mm, deg) = (d.translation.vector.norm(), d.rotation.angle().to_degrees());
    (mm > FRAME_APART_MM || deg > FRAME_APART_DEG).then_some((mm, deg))
}

#[derive(Args)]
pub struct PredictArgs {
    /// Compensator file written by `robocal train`.
    #[arg(long)]
    compensator: PathBuf,
    /// CSV with columns q1..qN (deg); other columns are carried through.
    #[arg(long)]
    joints: PathBuf,
    #[command(flatten)]
    output: OutputArgs,
}

/// Compensated tool poses (x, y, z mm; rz, ry, rx deg) for a joint CSV.
pub fn run_predict(a: PredictArgs) -> Result<()> {
    use super::paths::{guard, req};
    guard(
        &[
            req("--compensator", &a.compensator),
            req("--joints", &a.joints),
        ],
        &[a.output.out_named()?],
    )?;
    let c = Compensator::load(&a.compensator)?;
    let t = JointTable::read(&a.joints, &c.robot)?;
    super::fk::warn_if_radians(&a.joints, &c.robot, &t);
    let mut written: Vec<String> = robocal::data::POSE_COLUMNS
        .iter()
        .map(|s| s.to_string())
        .collect();
    written.push(DOMAIN_COLUMN.into());
    let headers = t.output_headers(&written)?;
    let (rows, joints, lines) = (t.table.rows, t.joints, t.table.lines);
    let mut ws = PredictWorkspace::default();
    let mut out = Vec::with_capacity(rows.len());
    let mut outside = Vec::new();
    let mut beyond = Vec::new();
    let mut unchecked = super::unchecked::UncheckedRows::new(&c.robot);
    for ((cells, q), line) in rows.into_iter().zip(&joints).zip(lines) {
        let q = c.robot.joints_to_internal(q);
        unchecked.add(&c.robot, &q, line, true);
        if !c.robot.joints_outside_limits(&q).is_empty() {
            beyond.push(line);
        }
        let pose = c.predict(&q, &mut ws);
        let check = c.domain_check(&q, &mut ws);
        if !check.inside() {
            outside.push(line);
        }
        let mut row = cells;
        row.extend(
            pose_to_file(&pose)
                .iter()
                .map(|v| num(*v, a.output.decimals)),
        );
        row.push(check.describe());
        out.push(row);
    }
    super::fk::warn_beyond_limits(&a.joints, &beyond);
    warn_outside(&a.joints, &outside, true, c.has_network());
    unchecked.warn(&a.joints, &a.compensator);
    a.output
        .emit(&headers, &out, written.len())
        .with_context(|| "writing the predictions".to_string())
}

/// The output column that says where a row stands against the training domain.
pub const DOMAIN_COLUMN: &str = "domain";

/// Warns (stderr) about rows outside a compensator's training domain: [`outside_warning`].
pub fn warn_outside(path: &Path, lines: &[usize], column: bool, network: bool) {
    if let Some(w) = outside_warning(path, lines, column, network) {
        eprintln!("warning: {w}");
    }
}

/// The warning on rows outside a compensator's training domain, by line; `column`: the
/// output has the domain column; `network`: the compensator has one (else the model alone).
/// None where no row is outside.
pub fn outside_warning(
    path: &Path,
    lines: &[usize],
    column: bool,
    network: bool,
) -> Option<String> {
    (!lines.is_empty()).then(|| {
        let why = if network {
            "the network extrapolates there (its correction fades with the distance from the \
             training configurations, not for a joint beyond its training range alone)"
        } else {
            "a joint lies beyond the training rows' range, the only rows the compensator's \
             model (the model alone, refined in training) was fitted on"
        };
        format!(
            "{}: {} row(s) outside the compensator's training domain (lines {}): {why}{}",
            path.display(),
            lines.len(),
            robocal::data::measurement::list_lines(lines),
            if column {
                format!("; see the `{DOMAIN_COLUMN}` column")
            } else {
                String::new()
            }
        )
    })
}
