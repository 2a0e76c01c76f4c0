//! `robocal import`: a foreign export to canonical CSV through an import profile.

use super::data_args::{DataArgs, joints_of};
use anyhow::{Result, bail};
use clap::Args;
use robocal::data::measurement::write_measurements;
use robocal::data::{Table, joint_columns};
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
    let n = match (&a.robot, &profile.columns.joints) {
        (Some(_), _) => 0,
        (None, Some(j)) => j.len(),
        (None, None) => {
            // Count q1, q2, ... in the header.
            let t = Table::read_with(&a.input, profile.delimiter, profile.decimal_comma)?;
            let n = (1..)
                .take_while(|i| t.column(&format!("q{i}")).is_some())
                .count();
            if n == 0 {
                bail!(
                    "{}: no joint columns q1, q2, ... (give a profile that names them)",
                    a.input.display()
                );
            }
            n
        }
    };
    if a.robot.is_none() {
        eprintln!(
            "note: no --robot: joints are taken as revolute and their limits are not checked"
        );
    }
    let joints = joints_of(a.robot.as_ref(), n)?;
    let set = a.data.read(&a.input, &joints)?;
    super::output::writing(write_measurements(&set, &joints, &a.out), &a.out)?;
    let what = match (set.has_position(), set.has_rotation()) {
        (true, true) => "poses",
        (true, false) => "positions",
        (false, true) => "orientations",
        (false, false) => "distances",
    };
    eprintln!(
        "imported {} {what} ({} joints: {}) into {}",
        set.rows.len(),
        joints.len(),
        joint_columns(joints.len()).join(","),
        a.out.display()
    );
    Ok(())
}
