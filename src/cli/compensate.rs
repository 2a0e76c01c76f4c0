//! `robocal compensate`: fake targets for an unmodified controller (see `compensation`).

use super::output::{OutputArgs, joints_arg, num};
use super::predict::load_compensator;
use anyhow::{Context, Result, bail};
use clap::Args;
use nalgebra::{IsometryMatrix3, Point3};
use robocal::compensation::{CalibratedModel, Command, Failure, FakeTargetSolver};
use robocal::data::{POSE_COLUMNS, Target, TargetTable, joint_columns};
use robocal::kinematics::{Reach, pose_from_file, pose_to_file};
use robocal::model::{Robot, read_robot};
use robocal::reports::compensate::{FrameChange, TargetFailure, WrittenMiss};
use robocal::reports::{CompensateReport, Report};
use std::io::IsTerminal;
use std::path::PathBuf;

#[derive(Args)]
pub struct CompensateArgs {
    /// The controller's nominal robot (TOML; mm, deg). A UR-class arm (axes 2, 3 and 4
    /// parallel), whose controller runs the solution nearest the joints it is given, or one
    /// without a closed form: every target needs seed joints and has no branch.
    #[arg(long)]
    nominal: PathBuf,
    /// The calibrated robot (from `robocal identify`).
    #[arg(long)]
    robot: PathBuf,
    /// A compensator (from `robocal train`): its model and network are inverted instead.
    #[arg(long)]
    compensator: Option<PathBuf>,
    /// Desired tool poses: CSV with x,y,z (mm) and rz,ry,rx (deg, R = Rz Ry Rx), or x,y,z
    /// only (the orientation is then the calibrated robot's at the seed joints). Optional
    /// q1..qN (deg) seed each row (branch and turns; for a controller solving near the seed,
    /// a UR-class nominal or one without a closed form, the joints it solves near, required;
    /// all empty: no seed) and are renamed seed_q1..seed_qN; other columns are carried
    /// through.
    #[arg(long)]
    targets: PathBuf,
    /// Seed joints "j1,...,jN" (deg) for rows without their own (no q1..qN columns, or all
    /// of a row's q cells empty).
    #[arg(long, allow_hyphen_values = true)]
    seed: Option<String>,
    #[command(flatten)]
    output: OutputArgs,
    /// JSON report (typed: `kind` compensate; counts, shifts, failures, domain).
    #[arg(long)]
    report: Option<PathBuf>,
}

/// Runs `compensate`; `Some(message)` when some targets have no command (the others are
/// written, and the caller exits with [`super::EXIT_SOME_TARGETS_FAILED`]).
pub fn run(a: CompensateArgs) -> Result<Option<String>> {
    use super::paths::{guard, opt, req};
    guard(
        &[
            req("--nominal", &a.nominal),
            req("--robot", &a.robot),
            opt("--compensator", a.compensator.as_ref()),
            req("--targets", &a.targets),
        ],
        &[a.output.out_named()?, opt("--report", a.report.as_ref())],
    )?;
    let nominal = read_robot(&a.nominal)?;
    let robot = read_robot(&a.robot)?;
    let n = nominal.dof();
    if !nominal.same_joints(&robot) {
        bail!(
            "{} and {} have different joints",
            a.nominal.display(),
            a.robot.display()
        );
    }
    let mut warnings = super::warnings::Warnings::default();
    let (comp, note) = match &a.compensator {
        Some(p) => {
            let (c, note) = load_compensator(p, &a.robot, &robot, &mut warnings)?;
            if let Some(note) = &note {
                eprintln!("{note}");
            }
            (Some(c), note)
        }
        None => (None, None),
    };
    let model = match &comp {
        Some(c) => CalibratedModel::compensated(c),
        None => CalibratedModel::identified(&robot),
    };
    let mut solver = FakeTargetSolver::new(&nominal, model)?;
    if let Some(why) = solver.solves_near_seed() {
        eprintln!(
            "note: {}: {why}: each target is solved nearest its seed joints, and the nominal \
             model's solution of its command nearest the seed, which a controller given the \
             seed runs, must be those joints (empty branch column)",
            a.nominal.display()
        );
    }
    let global_seed = match &a.seed {
        Some(s) => Some(nominal.joints_to_internal(&joints_arg(&nominal, s, "--seed")?)),
        None => None,
    };

    let tt = TargetTable::read(&a.targets, &nominal, true)?;
    warnings.say_some(super::fk::radian_seeds_warning(&a.targets, &robot, &tt));
    warnings.say_some(super::fk::radian_orientations_warning(&a.targets, &tt));
    // The limits every solution is held to: the calibrated model's.
    let calibrated = comp.as_ref().map_or(&robot, |c| &c.robot);
    let tool_gap = robocal::kinematics::tool_gap(&nominal, calibrated, TOOL_GAP_MM);
    if let Some(gap) = tool_gap {
        // The file whose tool the calibrated model holds: the robot file's where the
        // compensator took it (a new gripper), else the compensator's own (a reviewer's: the
        // compensator was named for a tool 50 mm longer that only the robot file had).
        let whose = match &a.compensator {
            Some(p) if calibrated.tool() != robot.tool() => p,
            _ => &a.robot,
        };
        eprintln!(
            "note: the distances between the tool positions at the same joints differ by up to \
             {gap:.1} mm between {} and {}, beyond a calibration's millimetres (the flanges' \
             agree within {TOOL_GAP_MM} mm): the files hold different tools (a measurement tool, or a TCP updated in \
             one file only); the commands are poses of the nominal's tool, which the \
             controller must run as its TCP",
            a.nominal.display(),
            whose.display()
        );
    }
    let picks = "still pick the branch and the turns (and, for a position-only target, the \
                 orientation), and every solution is held to the limits";
    if let Some(s) = &global_seed
        && tt.seeds.iter().any(Option::is_none)
    {
        let beyond = calibrated.joints_outside_limits(s);
        if !beyond.is_empty() {
            warnings.say(format!(
                "--seed leaves the calibrated model's limits of joint(s) {}: its joints {picks}",
                join_joints(&beyond)
            ));
        }
    }
    let seeds_beyond: Vec<usize> = (tt.seeds.iter().zip(&tt.table.lines))
        .filter(|(s, _)| {
            s.as_ref()
                .is_some_and(|s| !calibrated.joints_outside_limits(s).is_empty())
        })
        .map(|(_, &line)| line)
        .collect();
    if !seeds_beyond.is_empty() {
        warnings.say(format!(
            "{}: {} row(s) have seed joints outside the calibrated model's limits (lines {}): \
             they {picks}",
            a.targets.display(),
            seeds_beyond.len(),
            robocal::data::measurement::list_lines(&seeds_beyond)
        ));
    }
    let with_orientation = tt.with_orientation;
    let d = a.output.decimals;
    let written = written_columns(n, with_orientation, comp.is_some(), d.is_some());
    let headers = tt.output_headers(&written)?;
    let t = &tt.table;

    let bar = if std::io::stderr().is_terminal() && t.rows.len() >= 1000 {
        indicatif::ProgressBar::new(t.rows.len() as u64)
    } else {
        indicatif::ProgressBar::hidden()
    };
    let mut out_rows = Vec::with_capacity(t.rows.len());
    let mut failed = Vec::new();
    let mut shifts = Vec::new();
    // The targets carried into the nominal model's world frame (B_n B_c^-1 T): the shift
    // without the change of frame, where the calibrated base was registered elsewhere.
    let to_nominal = nominal.base().transform() * calibrated.base().transform().inverse();
    let mut moved = Vec::new();
    let mut outside = Vec::new();
    let mut dws = robocal::neural::predict::PredictWorkspace::default();
    let mut unchecked = super::unchecked::UncheckedRows::new(calibrated);
    // With --decimals: the miss (mm, deg) of each command as written, and its line; the
    // lines of the commands whose miss could not be found.
    let mut as_written: Vec<(f64, f64, usize)> = Vec::new();
    let mut not_checked: Vec<usize> = Vec::new();
    // Targets without seed joints solved on another branch than the middle's: (line, the
    // middle's branch, the command's).
    let mut other_branch: Vec<(usize, String, String)> = Vec::new();
    let mut frame_mix = FrameMix::new(&nominal, calibrated);
    for r in 0..t.rows.len() {
        bar.inc(1);
        let desired = tt.targets[r];
        let seed = tt.seeds[r].as_deref().or(global_seed.as_deref());
        let mut row = t.rows[r].clone();
        match solver.solve(&desired, seed) {
            Ok(c) => {
                if let (Some(middle), Some(b)) = (c.instead_of, c.branch) {
                    other_branch.push((t.lines[r], middle.to_string(), b.to_string()));
                }
                row.extend(command_cells(&c, &nominal, with_orientation, d));
                unchecked.add(calibrated, &c.q, t.lines[r], with_orientation);
                if let Some(cm) = &comp {
                    let check = cm.domain_check(&c.q, &mut dws);
                    if !check.inside() {
                        outside.push(t.lines[r]);
                    }
                    row.push(check.describe());
                }
                if d.is_some() {
                    // The command's cells as written, read back: the pose the controller gets.
                    let cells = pose_to_file(&c.fake).map(|v| num(v, d).parse().unwrap_or(v));
                    match solver.miss_as_written(&c, &pose_from_file(cells)) {
                        Some((mm, rad)) => {
                            row.push(num(mm, Some(9)));
                            row.push(num(rad.to_degrees(), Some(9)));
                            as_written.push((mm, rad.to_degrees(), t.lines[r]));
                        }
                        None => {
                            row.extend([String::new(), String::new()]);
                            not_checked.push(t.lines[r]);
                        }
                    }
                }
                shifts.push((c.fake.translation.vector - c.desired.translation.vector).norm());
                let carried = to_nominal * c.desired;
                moved.push((c.fake.translation.vector - carried.translation.vector).norm());
            }
            Err(why) => {
                let blanks = (if with_orientation { 0 } else { 3 }) + 1 + n + 6 + 2;
                row.extend(std::iter::repeat_n(String::new(), blanks));
                row.push(why.to_string());
                if comp.is_some() {
                    row.push(String::new());
                }
                if d.is_some() {
                    row.extend([String::new(), String::new()]);
                }
                frame_mix.check(&desired, &why, t.lines[r]);
                failed.push((t.lines[r], why));
            }
        }
        out_rows.push(row);
    }
    bar.finish_and_clear();
    a.output
        .emit(&headers, &out_rows, written.len())
        .context("writing the commands")?;
    let network = comp.as_ref().is_some_and(|c| c.has_network());
    warnings.say_some(super::predict::outside_warning(
        &a.targets, &outside, true, network,
    ));
    let robot_path = a.compensator.as_ref().unwrap_or(&a.robot);
    warnings.say_some(unchecked.warning(&a.targets, robot_path));
    warnings.say_some(frame_mix.warning(&a.targets));
    let total = t.rows.len();
    let (mean, max) = mean_and_max(&shifts).unzip();
    let report = CompensateReport {
        nominal: a.nominal.display().to_string(),
        robot: a.robot.display().to_string(),
        compensator: a.compensator.as_ref().map(|p| p.display().to_string()),
        targets: a.targets.display().to_string(),
        output: a.output.out.as_ref().map(|p| p.display().to_string()),
        total,
        solved: shifts.len(),
        shift_mean_mm: mean,
        shift_max_mm: max,
        failures: failed
            .iter()
            .map(|(line, why)| TargetFailure {
                line: *line,
                status: why.code().into(),
                message: why.to_string(),
            })
            .collect(),
        lines_outside_domain: outside,
        note,
        frame_change: frame_change(&nominal, calibrated, &moved),
        tool_gap_mm: tool_gap,
        written_miss: d.and_then(|decimals| written_miss(decimals, &as_written, not_checked)),
        unchecked: unchecked.report(),
        other_branch_lines: other_branch.iter().map(|o| o.0).collect(),
        warnings: warnings.into_vec(),
    };
    if !other_branch.is_empty() {
        let shown: Vec<String> = (other_branch.iter().take(5))
            .map(|(line, middle, b)| format!("line {line}: {b} instead of {middle}"))
            .collect();
        eprintln!(
            "note: {} target(s) without seed joints are solved on another branch than the one \
             nearest the middle of the joint ranges, where the calibrated solution left the \
             limits, did not converge or changed branch ({}{}): a move between consecutive \
             targets may change configuration; seed joints choose the branch",
            other_branch.len(),
            shown.join(", "),
            if other_branch.len() > 5 { ", ..." } else { "" }
        );
    }
    match (report.shift_mean_mm, report.shift_max_mm) {
        (Some(mean), Some(max)) => eprintln!(
            "compensate: {} of {total} targets solved; the commands move the tool positions by \
             {mean:.3} mm on average (max {max:.3} mm) from the desired ones{}",
            report.solved,
            report
                .frame_change
                .as_ref()
                .map_or(String::new(), across_frames)
        ),
        _ => eprintln!("compensate: 0 of {total} targets solved"),
    }
    if let Some(w) = &report.written_miss {
        eprintln!(
            "compensate: as written ({} decimals), the commands reach the targets within \
             {} mm (line {}) and {} deg; the residual columns are the unrounded commands', \
             the written_miss columns each row's{}",
            w.decimals,
            short(w.max_mm),
            w.max_line,
            short(w.max_deg),
            if w.unchecked.is_empty() {
                String::new()
            } else {
                format!(
                    "; not checked, where the nominal's solve of the rounded command did not \
                     converge (empty cells): {} command(s), lines {}",
                    w.unchecked.len(),
                    robocal::data::measurement::list_lines(&w.unchecked)
                )
            }
        );
    }
    if let Some(p) = &a.report {
        super::summary::write_report(p, &Report::Compensate(report))?;
    }
    Ok((!failed.is_empty()).then(|| failure_message(&a.targets, &failed, total)))
}

/// Where the calibrated model's base frame lies far from the nominal's (a base registered to
/// a tracker's frame: [`super::predict::bases_apart`]), the targets are
/// in the calibrated model's world frame and the commands in the nominal model's, so the
/// shift mixes that change of frame with the correction: the change, and the shift of the
/// targets carried into the nominal frame (`moved`, mm); else (or with no target solved)
/// None.
fn frame_change(nominal: &Robot, calibrated: &Robot, moved: &[f64]) -> Option<FrameChange> {
    let (mm, deg) = super::predict::bases_apart(nominal, calibrated)?;
    let (mean, max) = mean_and_max(moved)?;
    Some(FrameChange {
        base_offset_mm: mm,
        base_rotation_deg: deg,
        carried_shift_mean_mm: mean,
        carried_shift_max_mm: max,
    })
}

/// Targets out of the calibrated model's reach that it would reach read in the nominal
/// model's frame, where the two bases lie apart ([`super::predict::bases_apart`]): targets
/// given in the robot's own base frame to a model whose base `identify` registered to the
/// measuring instrument's frame.
struct FrameMix {
    /// The bases' distance (mm) and angle (deg), the calibrated model's reach and the map
    /// from the nominal's frame to its world frame (B_c B_n^-1); None where the bases agree.
    apart: Option<(f64, f64, Reach, IsometryMatrix3<f64>)>,
    /// The lines of such targets.
    lines: Vec<usize>,
    /// Targets out of reach, these and the others.
    unreachable: usize,
}

impl FrameMix {
    fn new(nominal: &Robot, calibrated: &Robot) -> FrameMix {
        let apart = super::predict::bases_apart(nominal, calibrated).map(|(mm, deg)| {
            let into = calibrated.base().transform() * nominal.base().transform().inverse();
            (mm, deg, Reach::of(calibrated), into)
        });
        FrameMix {
            apart,
            lines: Vec::new(),
            unreachable: 0,
        }
    }

    /// Counts a target that `failed` out of reach, and keeps its `line` where, carried from
    /// the nominal's frame into the calibrated model's world frame, it lies within reach.
    fn check(&mut self, target: &Target, failed: &Failure, line: usize) {
        if !matches!(failed, Failure::Unreachable(_)) {
            return;
        }
        self.unreachable += 1;
        let Some((_, _, reach, into)) = &self.apart else {
            return;
        };
        let p = Point3::from(match target {
            Target::Pose(t) => t.translation.vector,
            Target::Position(p) => *p,
        });
        if !reach.holds(&p.coords) && reach.holds(&(into * p).coords) {
            self.lines.push(line);
        }
    }

    /// The warning on `targets` where some of its targets out of reach are such targets.
    fn warning(&self, targets: &std::path::Path) -> Option<String> {
        let unreachable = self.unreachable;
        let (mm, deg, ..) = self.apart?;
        (!self.lines.is_empty()).then(|| {
            format!(
                "{}: {} of the {unreachable} target(s) out of the calibrated model's reach (lines \
                 {}) would be within it read in the nominal model's frame: the calibrated \
                 model's base lies {mm:.1} mm and {deg:.1} deg from the nominal's (`identify` \
                 registers it to the measuring instrument's frame), and targets are read in the \
                 calibrated model's world frame; targets given in the robot's own base frame \
                 must first be carried into it (T_world = B_calibrated B_nominal^-1 T, the \
                 [base] rows of the two files)",
                targets.display(),
                self.lines.len(),
                robocal::data::measurement::list_lines(&self.lines)
            )
        })
    }
}

/// The summary's words on a change of frame ([`frame_change`]).
fn across_frames(f: &FrameChange) -> String {
    format!(
        ", across frames: the calibrated model's base lies {:.1} mm and {:.1} deg from the \
         nominal's (targets in the calibrated model's world frame, commands in the nominal \
         model's); carried into the nominal frame, the targets move by {:.3} mm on average \
         (max {:.3} mm)",
        f.base_offset_mm, f.base_rotation_deg, f.carried_shift_mean_mm, f.carried_shift_max_mm
    )
}

/// The largest misses (mm, deg) of the commands as written, rounded to `decimals`, from each
/// row's (mm, deg, line), and the lines of those `unchecked`; None where no command was
/// checked.
fn written_miss(
    decimals: usize,
    rows: &[(f64, f64, usize)],
    unchecked: Vec<usize>,
) -> Option<WrittenMiss> {
    let worst = rows.iter().max_by(|a, b| a.0.total_cmp(&b.0))?;
    Some(WrittenMiss {
        decimals,
        max_mm: worst.0,
        max_line: worst.2,
        max_deg: rows.iter().map(|r| r.1).fold(0.0, f64::max),
        unchecked,
    })
}

/// A small figure (mm, deg) to 4 decimals, or to 2 significant digits below 1e-3.
fn short(v: f64) -> String {
    if v >= 1e-3 || v == 0.0 {
        format!("{v:.4}")
    } else {
        format!("{v:.1e}")
    }
}

/// The mean and the largest of the shifts `v` (mm); None for none.
fn mean_and_max(v: &[f64]) -> Option<(f64, f64)> {
    (!v.is_empty()).then(|| {
        (
            v.iter().sum::<f64>() / v.len() as f64,
            v.iter().copied().fold(0.0, f64::max),
        )
    })
}

/// Difference of the tool's distances (mm, [`robocal::kinematics::tool_gap`]) beyond which
/// the nominal's and the calibrated model's tools are said to differ: a calibration moves
/// them by millimetres, a forgotten TCP or a measurement tool by tens or hundreds (a
/// reviewer's nominal tool 300 mm longer than the calibrated one went without a word).
const TOOL_GAP_MM: f64 = 20.0;

/// The columns compensate writes after the target file's: for position targets the
/// orientation used, the branch, the joints, the command, the residuals and the status, with
/// a compensator the domain, and with `--decimals` the miss of the command as written.
fn written_columns(n: usize, with_orientation: bool, domain: bool, rounded: bool) -> Vec<String> {
    let mut written: Vec<String> = Vec::new();
    if !with_orientation {
        written.extend(POSE_COLUMNS[3..].iter().map(|s| s.to_string()));
    }
    written.push("branch".into());
    written.extend(joint_columns(n));
    written.extend(POSE_COLUMNS.iter().map(|c| format!("cmd_{c}")));
    written.extend(["residual_mm".into(), "residual_deg".into(), "status".into()]);
    if domain {
        written.push(super::predict::DOMAIN_COLUMN.into());
    }
    if rounded {
        written.extend(WRITTEN_MISS.map(String::from));
    }
    written
}

/// With `--decimals`, the columns of the calibrated robot's miss of the target when the
/// controller is given the command as written, rounded ([`FakeTargetSolver::miss_as_written`]).
const WRITTEN_MISS: [&str; 2] = ["written_miss_mm", "written_miss_deg"];

/// The cells of a solved target, in [`written_columns`]' order (without the domain).
fn command_cells(
    c: &Command,
    nominal: &Robot,
    with_orientation: bool,
    d: Option<usize>,
) -> Vec<String> {
    let mut row = Vec::new();
    let want = pose_to_file(&c.desired);
    if !with_orientation {
        row.extend(want[3..].iter().map(|v| num(*v, d)));
    }
    row.push(c.branch.map_or_else(String::new, |b| b.to_string()));
    row.extend(nominal.joints_to_file(&c.q).iter().map(|v| num(*v, d)));
    row.extend(pose_to_file(&c.fake).iter().map(|v| num(*v, d)));
    row.push(num(c.position_residual_mm, Some(9)));
    row.push(num(c.rotation_residual_rad.to_degrees(), Some(9)));
    row.push("ok".into());
    row
}

/// The message of a run where some targets have no command: the first 20 by line.
fn failure_message(targets: &std::path::Path, failed: &[(usize, Failure)], total: usize) -> String {
    let mut msg = format!(
        "{} of {total} targets have no command (marked in the status column, the rest were \
         written):",
        failed.len()
    );
    for (line, why) in failed.iter().take(20) {
        // Where this command's seed joints come from.
        let hint = match why {
            Failure::NoSeed | Failure::NoSeedToSolveNear => " (give q1..qN columns or --seed)",
            _ => "",
        };
        msg.push_str(&format!("\n  {}:{line}: {why}{hint}", targets.display()));
    }
    if failed.len() > 20 {
        msg.push_str(&format!("\n  ... and {} more", failed.len() - 20));
    }
    msg
}

/// 1-based joint numbers of 0-based `joints`, comma-separated.
fn join_joints(joints: &[usize]) -> String {
    (joints.iter().map(|j| (j + 1).to_string()))
        .collect::<Vec<_>>()
        .join(", ")
}
