//! `robocal train` and `robocal predict`: the neural compensator.

use super::compensator_args::{CompensatorArgs, progress_bar};
use super::data_args::{DataArgs, SigmaArgs};
use super::identify::{print_stats, stats_json, write_json};
use super::output::{OutputArgs, num};
use crate::evaluate::{row_errors, summarize};
use crate::identify::Measure;
use crate::kinematics::{pose_to_file, tool_pose};
use crate::model::{Robot, robot_to_toml};
use crate::neural::compensator::{Compensator, Network, PredictWorkspace};
use crate::neural::train::Phase2;
use crate::neural::tuning::RACE_FOLDS;
use crate::neural::tuning::{Score, Selection};
use crate::plot::{ErrorRun, error_figures, training_figure};
use anyhow::{Context, Result, bail};
use clap::Args;
use serde_json::json;
use std::io::IsTerminal;
use std::path::{Path, PathBuf};

#[derive(Args)]
pub struct TrainArgs {
    /// The model the network runs in series with (nominal or identified robot file).
    #[arg(long)]
    robot: PathBuf,
    /// Training measurements (full pose or position).
    #[arg(long)]
    data: PathBuf,
    /// Measurements to report the compensator on (e.g. a simulated set's truth file).
    #[arg(long)]
    validate: Option<PathBuf>,
    #[command(flatten)]
    read: DataArgs,
    #[command(flatten)]
    build: CompensatorArgs,
    /// Tracker sigmas for rows without their own (refinement).
    #[command(flatten)]
    sigma: SigmaArgs,
    /// Compensator file to write (JSON).
    #[arg(long)]
    out: PathBuf,
    /// JSON report: cross-validation, training curves, refined parameters, statistics.
    #[arg(long)]
    report: Option<PathBuf>,
    /// Folder for pictures (PNG and SVG, listed in figures.json for `robocal report`).
    #[arg(long)]
    plot: Option<PathBuf>,
}

/// Prints the cross-validation table.
fn print_selection(sel: &Selection) {
    println!(
        "cross-validation ({} folds of whole configurations; RMS over every held-out row):",
        sel.folds
    );
    println!(
        "  {:>5} {:<7} {:<5} {:<6} {:>6} {:>7} {:>7} {:<10} {:>11} {:>15}",
        "stage",
        "network",
        "form",
        "inputs",
        "hidden",
        "penalty",
        "members",
        "refine",
        "position mm",
        "orientation deg"
    );
    let rot = |s: &Score| {
        s.orientation_rms_deg
            .map_or("-".into(), |r| format!("{r:.4}"))
    };
    println!(
        "  {:>5} {:<52} {:>11.4} {:>15}",
        "-",
        "model alone",
        sel.model.position_rms_mm,
        rot(&sel.model)
    );
    for (i, c) in sel.candidates.iter().enumerate() {
        let s = &c.settings;
        let score = match (&c.score, &c.pruned) {
            (Some(x), _) => format!("{:>11.4} {:>15}", x.position_rms_mm, rot(x)),
            (None, Some(x)) => format!(
                "{:>11.4} {:>15}  dropped after {} folds",
                x.position_rms_mm,
                rot(x),
                RACE_FOLDS
            ),
            (None, None) => "failed".to_string(),
        };
        let network = s.network_label();
        let mlp = s.network != Network::Rbf;
        let dash = |show: bool, v: String| if show { v } else { "-".into() };
        println!(
            "{} {:>5} {:<7} {:<5} {:<6} {:>6} {:>7} {:>7} {:<10} {score}",
            if i == sel.chosen { "*" } else { " " },
            c.stage,
            network,
            s.form.name(),
            s.encoding.name(),
            dash(mlp, s.hidden.to_string()),
            dash(mlp, s.penalty.to_string()),
            dash(mlp, s.members.to_string()),
            s.refine.as_deref().unwrap_or("-"),
        );
        if let Some(e) = &c.error {
            println!("        {e}");
        }
    }
}

pub fn run_train(a: TrainArgs) -> Result<()> {
    let (robot, set, val) = super::identify::open_fit(
        &a.robot,
        &a.data,
        a.validate.as_ref(),
        &a.read,
        &a.out,
        a.report.as_ref(),
    )?;
    let terminal = std::io::stderr().is_terminal();
    let opts = a.build.options(a.sigma.sigmas(), terminal)?;
    let bar = progress_bar(terminal);
    let started = std::time::Instant::now();
    let (c, report) = Compensator::train(&robot, &set, &opts, &|done, total| {
        bar.set_length(total as u64);
        bar.set_position(done as u64);
    })
    .with_context(|| format!("training on {}", a.data.display()))?;
    let seconds = started.elapsed().as_secs_f64();
    bar.finish_and_clear();
    println!(
        "train: {} rows of {}, model {}",
        set.rows.len(),
        a.data.display(),
        a.robot.display()
    );
    if let Some(sel) = &report.selection {
        print_selection(sel);
    }
    println!("settings: {}", report.settings.describe());
    for n in &report.notes {
        println!("note: {n}");
    }
    if !report.refined.is_empty() {
        println!(
            "refined on the training rows (exact identification, {} parameters):",
            report.refined.len()
        );
        for p in &report.refined {
            println!(
                "  {:<12} {:<4} {:>14.6} -> {:>14.6}  (std {:.6})",
                p.name, p.unit, p.before, p.after, p.std
            );
        }
    }
    let n = &report.networks;
    let timing = format!(
        "{seconds:.1} s ({:.1} s cross-validation, {:.1} s final fit)",
        report.selection_seconds, report.fit_seconds
    );
    if let Some(r) = &c.rbf {
        let widths: Vec<String> = r.widths.iter().map(|w| format!("{w:.3}")).collect();
        println!(
            "rbf network: {} units ({} inputs), widths {} (standardised inputs), noise variance \
             {:.4} of signal {:.4}{}",
            r.units(),
            c.encoding.name(),
            widths.join(" "),
            r.noise_variance,
            r.signal_variance,
            if n.is_empty() {
                format!("; {timing}")
            } else {
                "; averaged with the MLPs' mean".into()
            }
        );
    }
    if n.is_empty() {
        if c.rbf.is_none() {
            println!("networks: none, the compensator is the model alone; {timing}");
        }
    } else {
        let stops: std::collections::BTreeSet<&str> = n.iter().map(|r| r.stop.describe()).collect();
        let most = n.iter().map(|r| r.lm_epochs).max().unwrap_or(0);
        let phase2 = match n[0].phase2 {
            Phase2::Lbfgs => format!("L-BFGS ({most} iterations)"),
            _ => format!("LM ({most} epochs)"),
        };
        println!(
            "networks: {} x {}-{}-{} ({} inputs); phase 1 {} epochs, phase 2 {phase2} per \
             network; stopped: {}; {timing}",
            n.len(),
            c.inputs(),
            c.hidden(),
            c.outputs(),
            c.encoding.name(),
            n.iter().map(|r| r.momentum_epochs).max().unwrap_or(0),
            stops.into_iter().collect::<Vec<_>>().join(", "),
        );
    }
    let mut figs = 0;
    if let Some(dir) = &a.plot
        && let Some(first) = report.networks.first()
    {
        training_figure(dir, "train", "compensator", first)?;
        figs += 1;
    }
    let mut ws = PredictWorkspace::default();
    let mut rows = vec![];
    let mut stat_rows = vec![];
    for (name, s) in [("training", Some(&set)), ("validation", val.as_ref())] {
        let Some(s) = s else { continue };
        let m = Measure::default_for(s);
        let before_rows = row_errors(s, m, |q| tool_pose(&robot, q))?;
        let after_rows = row_errors(s, m, |q| c.predict(q, &mut ws))?;
        let outside = s
            .rows
            .iter()
            .filter(|r| !c.domain_check(&r.q, &mut ws).inside())
            .count();
        if let Some(dir) = &a.plot {
            let runs = [
                ErrorRun {
                    label: "model",
                    errors: &before_rows,
                },
                ErrorRun {
                    label: "with compensator",
                    errors: &after_rows,
                },
            ];
            figs += error_figures(
                dir,
                &format!("train_{name}"),
                &format!("{name} data"),
                s,
                &runs,
            )?
            .len();
        }
        let (before, after) = (summarize(&before_rows), summarize(&after_rows));
        stat_rows.push((name, before, after, outside));
        rows.push(json!({
            "set": name, "model": stats_json(&before), "compensated": stats_json(&after),
            "rows_outside_domain": outside,
        }));
    }
    let table: Vec<(&str, &str, &crate::evaluate::ErrorStats)> = stat_rows
        .iter()
        .flat_map(|(n, b, a, _)| [(*n, "model", b), (*n, "+net", a)])
        .collect();
    print_stats(&table);
    for (name, _, _, outside) in &stat_rows {
        if *outside > 0 && *name != "training" {
            eprintln!(
                "warning: {outside} {name} row(s) lie outside the compensator's training domain"
            );
        }
    }
    super::output::writing(c.save(&a.out), &a.out)?;
    println!("wrote {}", a.out.display());
    if let Some(dir) = &a.plot {
        println!("plots: {figs} pictures in {}", dir.display());
    }
    if let Some(p) = &a.report {
        write_json(
            p,
            &json!({
                "robot": a.robot, "data": a.data, "compensator": a.out,
                "seconds": seconds,
                "training": report, "statistics": rows,
            }),
        )?;
    }
    Ok(())
}

/// Loads a compensator to use beside `robot` (read from `robot_path`): its joints must be
/// the robot's. With it, a note for the user when it runs with a model other than that file's.
pub(super) fn load_compensator(
    path: &Path,
    robot_path: &Path,
    robot: &Robot,
) -> Result<(Compensator, Option<String>)> {
    let c = Compensator::load(path)?;
    if !c.robot.same_joints(robot) {
        bail!(
            "{}: the compensator was trained for a robot with other joints than {}",
            path.display(),
            robot_path.display()
        );
    }
    let note = (robot_to_toml(&c.robot) != robot_to_toml(robot)).then(|| {
        format!(
            "note: the compensator runs in series with its own model (embedded; refined in \
             training), not with {}",
            robot_path.display()
        )
    });
    Ok((c, note))
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
    use super::paths::{guard, opt, req};
    guard(
        &[
            req("--compensator", &a.compensator),
            req("--joints", &a.joints),
        ],
        &[opt("--out", a.output.out.as_ref())],
    )?;
    let c = Compensator::load(&a.compensator)?;
    let (mut headers, rows, joints, lines) = super::fk::joint_table(&a.joints, c.robot.dof())?;
    super::fk::warn_if_radians(&a.joints, &c.robot, &joints);
    if headers.iter().any(|h| h == DOMAIN_COLUMN) {
        bail!(
            "{}: the input already has a column `{DOMAIN_COLUMN}`, which would be written; \
             rename or drop it",
            a.joints.display()
        );
    }
    headers.extend(crate::data::POSE_COLUMNS.iter().map(|s| s.to_string()));
    headers.push(DOMAIN_COLUMN.into());
    let mut ws = PredictWorkspace::default();
    let mut out = Vec::with_capacity(rows.len());
    let mut outside = Vec::new();
    for ((cells, q), line) in rows.into_iter().zip(&joints).zip(lines) {
        let q = c.robot.joints_to_internal(q);
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
    warn_outside(&a.joints, &outside, true);
    a.output
        .emit(&headers, &out)
        .with_context(|| "writing the predictions".to_string())
}

/// The output column that says where a row stands against the training domain.
pub(super) const DOMAIN_COLUMN: &str = "domain";

/// Warns (stderr) about rows outside a compensator's training domain, by line; `column`: the
/// output has the domain column.
pub(super) fn warn_outside(path: &Path, lines: &[usize], column: bool) {
    if !lines.is_empty() {
        eprintln!(
            "warning: {}: {} row(s) outside the compensator's training domain (lines {}): \
             the network extrapolates there, its correction fades{}",
            path.display(),
            lines.len(),
            crate::data::measurement::list_lines(lines),
            if column {
                format!("; see the `{DOMAIN_COLUMN}` column")
            } else {
                String::new()
            }
        );
    }
}
