//! `robocal fk`: forward kinematics of one joint vector or of a CSV batch.

use super::output::{OutputArgs, joints_arg, num};
use anyhow::{Context, Result, bail};
use clap::Args;
use robocal::data::{POSE_COLUMNS, Table, joint_columns};
use robocal::kinematics::{pose_to_file, tool_pose};
use robocal::model::read_robot;
use std::path::PathBuf;

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

/// Headers, cells of each row, and joint values of each row (file units: deg, mm).
/// Headers, cells of each row, joints of each row (file units) and each row's file line.
pub(super) type JointTable = (Vec<String>, Vec<Vec<String>>, Vec<Vec<f64>>, Vec<usize>);

/// The joint table of a CSV with columns q1..qN; refuses a table that already has the pose
/// columns the command would write.
/// Warns (stderr) when every revolute joint angle of a file read in degrees lies within one
/// radian turn (|q| <= 2 pi) and some exceed 1: a file that holds radians (the joint_unit of
/// most controllers' logs) would otherwise give plausible but wrong poses.
pub(super) fn warn_if_radians(
    path: &std::path::Path,
    robot: &robocal::model::Robot,
    joints: &[Vec<f64>],
) {
    let revolute: Vec<usize> = (0..robot.dof())
        .filter(|&j| robot.joints()[j].joint_type == robocal::model::JointType::Revolute)
        .collect();
    let values = joints
        .iter()
        .flat_map(|q| revolute.iter().map(|&j| q[j].abs()));
    let (mut max, mut any) = (0.0f64, false);
    for v in values {
        max = max.max(v);
        any = true;
    }
    if any && max > 1.0 && max <= std::f64::consts::TAU {
        eprintln!(
            "warning: {}: every joint angle lies within +-{:.2}, one turn in radians: the \
             columns are read in degrees; if they hold radians, convert them (or import the \
             file with a profile whose joint_unit is \"rad\")",
            path.display(),
            std::f64::consts::TAU
        );
    }
}

pub(super) fn joint_table(path: &std::path::Path, n: usize) -> Result<JointTable> {
    let t = Table::read(path)?;
    let idx: Vec<usize> = joint_columns(n)
        .iter()
        .map(|c| t.require(c))
        .collect::<Result<_, _>>()?;
    for c in POSE_COLUMNS {
        if t.column(c).is_some() {
            bail!(
                "{}: the input already has a column `{c}`, which would be written; \
                 rename or drop it",
                path.display()
            );
        }
    }
    let joints = (0..t.rows.len())
        .map(|r| t.numbers(r, &idx))
        .collect::<Result<Vec<_>, _>>()?;
    Ok((t.headers, t.rows, joints, t.lines))
}

pub fn run(a: FkArgs) -> Result<()> {
    use super::paths::{guard, opt, req};
    guard(
        &[req("--robot", &a.robot), opt("--joints", a.joints.as_ref())],
        &[opt("--out", a.output.out.as_ref())],
    )?;
    let robot = read_robot(&a.robot)?;
    let n = robot.dof();
    let qcols = joint_columns(n);
    let (mut headers, rows, joints, _): JointTable = match (&a.q, &a.joints) {
        (Some(q), _) => {
            let q = joints_arg(&robot, q, "--q")?;
            let cells = q.iter().map(|v| num(*v, None)).collect();
            (qcols, vec![cells], vec![q], vec![0])
        }
        (None, Some(path)) => {
            let t = joint_table(path, n)?;
            warn_if_radians(path, &robot, &t.2);
            t
        }
        (None, None) => unreachable!("clap requires one input"),
    };
    headers.extend(POSE_COLUMNS.iter().map(|s| s.to_string()));
    let mut out_rows = Vec::with_capacity(rows.len());
    let mut outside = Vec::new();
    for (k, (cells, q)) in rows.into_iter().zip(&joints).enumerate() {
        let qi = robot.joints_to_internal(q);
        if !robot.joints_outside_limits(&qi).is_empty() {
            outside.push(k + 1);
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
    if !outside.is_empty() {
        eprintln!(
            "warning: {} row(s) have joints outside the robot's limits (data rows {:?}); their poses are written anyway",
            outside.len(),
            outside
        );
    }
    a.output
        .emit(&headers, &out_rows)
        .with_context(|| "writing the FK output".to_string())
}
