//! `robocal ik`: inverse kinematics of one pose or of a CSV batch.
//!
//! The strategy is the library's (`kinematics::ik`): the closed form when the robot has one;
//! else the nominal model's closed form (`--nominal`) refined numerically on the robot; else
//! numerical IK from a seed (`--seed`, or the row's own q1..qN columns), and from starts
//! spread around it, or without one around the middle of the ranges.

use super::output::{OutputArgs, joints_arg, num, pose_arg};
use anyhow::{Context, Result, bail};
use clap::Args;
use robocal::data::{POSE_COLUMNS, Target, TargetTable, joint_columns};
use robocal::kinematics::{IkFailure, IkOptions, IkSolver, IkStart, RobotModel, pose_from_file};
use robocal::model::read_robot;
use std::io::IsTerminal;
use std::path::{Path, PathBuf};

#[derive(Args)]
#[command(group = clap::ArgGroup::new("input").required(true))]
pub struct IkArgs {
    /// Robot file (TOML; mm, deg).
    #[arg(long)]
    robot: PathBuf,
    /// One pose "x,y,z,rz,ry,rx" (mm, deg; R = Rz Ry Rx).
    #[arg(long, group = "input", allow_hyphen_values = true)]
    pose: Option<String>,
    /// CSV with columns x,y,z,rz,ry,rx; other columns are carried through. Columns q1..qN,
    /// when present, seed the numerical solve of their row and are renamed seed_q1..seed_qN.
    #[arg(long, group = "input")]
    poses: Option<PathBuf>,
    /// Write every solution (default: the one nearest the seed, or the middle of the ranges).
    #[arg(long)]
    all: bool,
    /// Seed joints "j1,...,jN" (deg) for the numerical solve, and for choosing one solution.
    #[arg(long, allow_hyphen_values = true)]
    seed: Option<String>,
    /// Nominal robot whose closed form seeds the numerical solve (for calibrated models).
    #[arg(long)]
    nominal: Option<PathBuf>,
    #[command(flatten)]
    output: OutputArgs,
}

/// The library's message, with the flags that would help.
/// A failure as the status column and the warning give it: its code first (as
/// `compensate`'s statuses), then what to do.
fn explain(f: &IkFailure) -> String {
    let text = match f {
        IkFailure::TooMany => format!("{f}: leave out --all for the one nearest the seed"),
        IkFailure::BadSeed(m) => format!("{m} (--seed or the q1..qN columns)"),
        other => other.to_string(),
    };
    let code = f.code();
    match text.strip_prefix(code).and_then(|t| t.strip_prefix(": ")) {
        Some(_) => text,
        None => format!("{code}: {text}"),
    }
}

/// Runs `ik`; true when some poses of `--poses` have no solution (the file marks them, and
/// the command exits with [`super::EXIT_SOME_TARGETS_FAILED`]).
pub fn run(a: IkArgs) -> Result<bool> {
    use super::paths::{guard, opt, req};
    guard(
        &[
            req("--robot", &a.robot),
            opt("--poses", a.poses.as_ref()),
            opt("--nominal", a.nominal.as_ref()),
        ],
        &[a.output.out_named()?],
    )?;
    let robot = read_robot(&a.robot)?;
    let n = robot.dof();
    let global_seed = match &a.seed {
        Some(s) => Some(robot.joints_to_internal(&joints_arg(&robot, s, "--seed")?)),
        None => None,
    };
    let nominal = match &a.nominal {
        Some(p) => Some(read_robot(p)?),
        None => None,
    };
    let start = IkStart::choose(&robot, nominal.as_ref()).with_context(|| {
        a.nominal
            .as_ref()
            .map_or_else(String::new, |p| p.display().to_string())
    })?;
    if let IkStart::Seed(why) = &start {
        eprintln!(
            "note: {why}; solving numerically from the seed (without one, from starts spread \
             around the middle of the ranges; --nominal gives a closed form's starts){}",
            if a.all {
                ": --all lists the solutions these solves find, which can miss some"
            } else {
                ""
            }
        );
    }

    let mut written = vec!["solution".to_string()];
    written.extend(joint_columns(n));
    written.push("status".into());
    let written_count = written.len();
    // Inputs: headers, cells, targets, per-row seed (internal units), file lines.
    let (headers, rows, targets, row_seeds, lines) = match (&a.pose, &a.poses) {
        (Some(p), _) => {
            let v = pose_arg(p, "--pose")?;
            let mut headers: Vec<String> = POSE_COLUMNS.iter().map(|s| s.to_string()).collect();
            headers.extend(written);
            let cells = v.iter().map(|x| num(*x, None)).collect();
            let target = pose_from_file([v[0], v[1], v[2], v[3], v[4], v[5]]);
            (headers, vec![cells], vec![target], vec![None], vec![0])
        }
        (None, Some(path)) => {
            let t = TargetTable::read(path, &robot, false)?;
            super::fk::warn_if_radian_seeds(path, &robot, &t);
            if let Some(w) = super::fk::radian_orientations_warning(path, &t) {
                eprintln!("warning: {w}");
            }
            let headers = t.output_headers(&written)?;
            let targets = t
                .targets
                .iter()
                .map(|x| match x {
                    Target::Pose(p) => *p,
                    Target::Position(_) => unreachable!("orientation columns are required"),
                })
                .collect();
            (headers, t.table.rows, targets, t.seeds, t.table.lines)
        }
        (None, None) => unreachable!("clap requires one input"),
    };

    let mut solver = IkSolver::new(RobotModel::new(&robot), start, IkOptions::default());
    let mut out_rows = Vec::new();
    let mut failed = Vec::new();
    let mut unchecked = super::unchecked::UncheckedRows::new(&robot);
    // A model without a closed form solved from spread starts takes about 1 ms a pose: as
    // compensate, a bar from 1000 rows.
    let bar = if std::io::stderr().is_terminal() && rows.len() >= 1000 {
        indicatif::ProgressBar::new(rows.len() as u64)
    } else {
        indicatif::ProgressBar::hidden()
    };
    for (k, (cells, target)) in rows.iter().zip(&targets).enumerate() {
        bar.inc(1);
        let seed = row_seeds[k].as_deref().or(global_seed.as_deref());
        let solved = if a.all {
            solver.all(target, seed)
        } else {
            solver.nearest(target, seed).map(|s| vec![s.solution.q])
        };
        match solved.map_err(|f| explain(&f)) {
            Ok(sols) => {
                if let Some(q) = sols.first() {
                    unchecked.add(&robot, q, lines[k].max(1), true);
                }
                for (s, q) in sols.iter().enumerate() {
                    let mut row = cells.clone();
                    row.push((s + 1).to_string());
                    let q = robot.joints_to_file(q);
                    row.extend(q.iter().map(|x| num(*x, a.output.decimals)));
                    row.push("ok".into());
                    out_rows.push(row);
                }
            }
            Err(why) => {
                let mut row = cells.clone();
                row.push(String::new());
                row.extend(std::iter::repeat_n(String::new(), n));
                row.push(why.clone());
                out_rows.push(row);
                failed.push((lines[k], why));
            }
        }
    }
    bar.finish_and_clear();
    if a.pose.is_some() {
        if let Some((_, why)) = failed.first() {
            // Not "no solution": too many (--all on limits of many turns) is a failure too.
            bail!("the pose is not solved: {why}");
        }
    } else if !failed.is_empty() {
        eprintln!(
            "warning: {} of {} poses are not solved (marked in the status column):",
            failed.len(),
            rows.len()
        );
        let file = a.poses.as_deref().unwrap_or(Path::new("--pose"));
        for (line, why) in &failed {
            eprintln!("  {}:{line}: {why}", file.display());
        }
    }
    let source = a.poses.as_deref().unwrap_or(Path::new("--pose"));
    unchecked.warn(source, &a.robot);
    a.output.emit(&headers, &out_rows, written_count)?;
    Ok(!failed.is_empty())
}
