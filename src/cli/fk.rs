//! `robocal fk`: forward kinematics of one joint vector or of a CSV batch.

use super::output::{OutputArgs, joints_arg, num};
use anyhow::{Context, Result};
use clap::Args;
use robocal::data::{JointTable, POSE_COLUMNS, TargetTable, joint_columns};
use robocal::kinematics::{pose_to_file, tool_pose};
use robocal::model::{Robot, read_robot};
use robocal::sim::Region;
use std::path::{Path, PathBuf};

#[derive(Args)]
#[command(group = clap::ArgGroup::new("input").required(true))]
pub struct FkArgs {
    /// Robot file (TOML; mm, deg).
    #[arg(long)]
    robot: PathBuf,
    /// One joint vector "j1,...,jN" (deg; mm for prismatic joints).
    #[arg(long, group = "input", allow_hyphen_values = true)]
    q: Option<String>,
    /// CSV with columns q1..qN (deg); other columns are carried through.
    #[arg(long, group = "input")]
    joints: Option<PathBuf>,
    #[command(flatten)]
    output: OutputArgs,
}

/// Warns (stderr) when a joint file read in degrees probably holds radians
/// ([`JointTable::looks_like_radians`]).
pub(super) fn warn_if_radians(path: &std::path::Path, robot: &Robot, t: &JointTable) {
    if t.looks_like_radians(robot) {
        warn_radians(path, "every joint angle", "the columns are read");
    }
}

/// Warns (stderr) where every bound of the revolute joints' ranges of region file `path`
/// lies within +-6.3 (a turn in radians), not all 0: read as degrees they hold every joint
/// within a few degrees, which radians typed into the file give (a reviewer's region of
/// +-0.1 to 1 drew 5 configurations within 1 deg, without a word). Not
/// [`JointTable::looks_like_radians`]'s rule, which asks some value to pass 1: a region of
/// wrist turns within +-1 rad is one.
pub(super) fn warn_if_radian_region(path: &std::path::Path, robot: &Robot, region: &Region) {
    let max = (region.0.iter().zip(robot.joints()))
        .filter(|(_, j)| j.joint_type == robocal::model::JointType::Revolute)
        .flat_map(|(r, _)| r.map(|v| v.to_degrees().abs()))
        .fold(0.0f64, f64::max);
    if max > 0.0 && max <= std::f64::consts::TAU {
        eprintln!(
            "warning: {}: every revolute joint's range lies within +-{:.2} deg, one turn in \
             radians: the ranges are read in degrees; if they hold radians, convert them to \
             degrees",
            path.display(),
            std::f64::consts::TAU
        );
    }
}

/// Warns that the seed columns of target file `path` probably hold radians (as
/// [`warn_if_radians`]): a seed read as degrees picks another branch, or none within the
/// limits, and the target fails or is solved in another configuration.
pub(super) fn warn_if_radian_seeds(path: &std::path::Path, robot: &Robot, t: &TargetTable) {
    if let Some(w) = radian_seeds_warning(path, robot, t) {
        eprintln!("warning: {w}");
    }
}

/// The warning of [`warn_if_radian_seeds`], where there is one.
pub(super) fn radian_seeds_warning(
    path: &std::path::Path,
    robot: &Robot,
    t: &TargetTable,
) -> Option<String> {
    (t.seeds_look_like_radians(robot))
        .then(|| radians_warning(path, "every seed joint angle", "the seed columns are read"))
}

/// The warning where the orientation columns of target file `path` probably hold radians
/// ([`TargetTable::orientations_look_like_radians`]): read as degrees, each target is turned
/// by up to 6.3 deg, not by up to 360, and is solved for that orientation without a word.
pub(super) fn radian_orientations_warning(
    path: &std::path::Path,
    t: &TargetTable,
) -> Option<String> {
    t.orientations_look_like_radians().then(|| {
        format!(
            "{}: every orientation value (rz, ry, rx) lies within +-6.3, one turn in radians: \
             the columns are read in degrees (R = Rz Ry Rx); if they hold radians, convert them",
            path.display()
        )
    })
}

fn warn_radians(path: &std::path::Path, what: &str, read: &str) {
    eprintln!("warning: {}", radians_warning(path, what, read));
}

fn radians_warning(path: &std::path::Path, what: &str, read: &str) -> String {
    format!(
        "{}: {what} lies within +-{:.2}, one turn in radians (or its joint's range in radians, \
         where that is wider): {read} in degrees; if they hold radians, convert them to degrees \
         (a profile's joint_unit = \"rad\" reads measurement files, not these)",
        path.display(),
        std::f64::consts::TAU
    )
}

/// Warns that the rows at file `lines` of `path` hold joints beyond the robot's limits.
pub fn warn_beyond_limits(path: &Path, lines: &[usize]) {
    if !lines.is_empty() {
        eprintln!(
            "warning: {}: {} row(s) have joints outside the robot's limits (lines {}); their \
             poses are written anyway",
            path.display(),
            lines.len(),
            robocal::data::measurement::list_lines(lines),
        );
    }
}

pub fn run(a: FkArgs) -> Result<()> {
    use super::paths::{guard, opt, req};
    guard(
        &[req("--robot", &a.robot), opt("--joints", a.joints.as_ref())],
        &[a.output.out_named()?],
    )?;
    let robot = read_robot(&a.robot)?;
    let n = robot.dof();
    let written: Vec<String> = POSE_COLUMNS.iter().map(|s| s.to_string()).collect();
    let written_count = written.len();
    let (headers, rows, joints, lines) = match (&a.q, &a.joints) {
        (Some(q), _) => {
            let q = joints_arg(&robot, q, "--q")?;
            let cells = q.iter().map(|v| num(*v, None)).collect();
            let mut headers = joint_columns(n);
            headers.extend(written);
            (headers, vec![cells], vec![q], vec![1])
        }
        (None, Some(path)) => {
            let t = JointTable::read(path, &robot)?;
            warn_if_radians(path, &robot, &t);
            (
                t.output_headers(&written)?,
                t.table.rows,
                t.joints,
                t.table.lines,
            )
        }
        (None, None) => unreachable!("clap requires one input"),
    };
    let mut out_rows = Vec::with_capacity(rows.len());
    let mut outside = Vec::new();
    let mut unchecked = super::unchecked::UncheckedRows::new(&robot);
    for ((cells, q), line) in rows.into_iter().zip(&joints).zip(lines) {
        let qi = robot.joints_to_internal(q);
        unchecked.add(&robot, &qi, line, true);
        if !robot.joints_outside_limits(&qi).is_empty() {
            outside.push(line);
        }
        let pose = tool_pose(&robot, &qi);
        let mut row = cells;
        row.extend(
            pose_to_file(&pose)
                .iter()
                .map(|v| num(*v, a.output.decimals)),
        );
        out_rows.push(row);
    }
    let source = a.joints.as_deref().unwrap_or(Path::new("--q"));
    warn_beyond_limits(source, &outside);
    unchecked.warn(source, &a.robot);
    a.output
        .emit(&headers, &out_rows, written_count)
        .with_context(|| "writing the FK output".to_string())
}
