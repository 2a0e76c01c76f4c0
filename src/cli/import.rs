//! `robocal import`: a foreign export to canonical CSV through an import profile.

use super::data_args::{DataArgs, counted_joints};
use anyhow::Result;
use clap::Args;
use robocal::data::measurement::Layout;
use robocal::data::measurement::write_measurements;
use robocal::data::{JointInfo, joint_columns};
use std::path::PathBuf;

#[derive(Args)]
pub struct ImportArgs {
    /// The file to import.
    input: PathBuf,
    #[command(flatten)]
    data: DataArgs,
    /// Robot file: checks the joint limits and knows prismatic joints. Without it, joints are
    /// taken as revolute and limits are not checked.
    #[arg(long)]
    robot: Option<PathBuf>,
    /// Canonical CSV to write (atomically).
    #[arg(long)]
    out: PathBuf,
}

pub fn run(a: ImportArgs) -> Result<()> {
    use super::paths::{guard, opt, req};
    guard(
        &[
            req("input", &a.input),
            opt("--profile", a.data.profile.as_ref()),
            opt("--robot", a.robot.as_ref()),
        ],
        &[req("--out", &a.out)],
    )?;
    let profile = a.data.profile()?;
    let n = counted_joints(&a.input, a.robot.as_ref(), &profile)?;
    if a.robot.is_none() {
        eprintln!(
            "note: no --robot: joints are taken as revolute and their limits are not checked"
        );
    }
    // The robot, read once: its joints for the read, its positions for the scale check.
    let robot = a
        .robot
        .as_ref()
        .map(robocal::model::read_robot)
        .transpose()?;
    let joints = robot
        .as_ref()
        .map_or_else(|| JointInfo::revolute(n), JointInfo::of);
    let set = a.data.read(&a.input, &joints)?;
    super::data_args::warn_lone_pairs(&a.input, &set);
    // Positions in metres or inches: `identify` and `train` refuse them, and the canonical
    // file written here would carry the mistake on (a reviewer's metres were written as mm
    // without a word).
    if let Some(robot) = &robot
        && let Err(e) = robocal::identify::register::check_position_scale(robot, &set)
    {
        eprintln!("warning: {e} (written as read: `identify` and `train` refuse such rows)");
    }
    super::output::writing(write_measurements(&set, &joints, &a.out), &a.out)?;
    if let Some(note) = super::output::renamed_note(&Layout::of(&set), joints.len()) {
        eprintln!("{note}");
    }
    let what = match (set.has_position(), set.has_rotation()) {
        (true, true) => "poses",
        (true, false) => "positions",
        (false, true) => "orientations",
        (false, false) => "distances",
    };
    let what = if set.rows.len() == 1 {
        what.trim_end_matches('s')
    } else {
        what
    };
    told_after_on_stderr!(
        "imported {} {what} ({} joint{}: {}) into {}",
        set.rows.len(),
        joints.len(),
        if joints.len() == 1 { "" } else { "s" },
        joint_columns(joints.len()).join(","),
        a.out.display()
    );
    Ok(())
}
