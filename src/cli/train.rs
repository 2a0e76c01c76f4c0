//! `robocal train` and `robocal predict`: the neural compensator.

use super::data_args::{DataArgs, SigmaArgs};
use super::identify::{print_stats, read_sets, stats_json, write_json};
use super::output::{OutputArgs, num};
use crate::evaluate::{row_errors, summarize};
use crate::identify::Measure;
use crate::kinematics::{pose_to_file, tool_pose};
use crate::model::{Robot, read_robot, robot_to_toml};
use crate::neural::compensator::{Compensator, CompensatorOptions, Form, PredictWorkspace};
use crate::neural::train::TrainOptions;
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
    /// Where the network acts: joint corrections before FK, or a pose residual after it.
    #[arg(long, value_enum, default_value_t = Form::Joint)]
    form: Form,
    /// Hidden sigmoid units.
    #[arg(long, default_value_t = 20)]
    hidden: usize,
    /// Model parameters re-estimated together with the network (offsets | full | names, as
    /// for identify); the compensator then embeds the refined model.
    #[arg(long)]
    refine: Option<String>,
    /// Seed of the initial weights and of the held-out validation part.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Phase-1 (gradient descent with momentum) epochs.
    #[arg(long, default_value_t = 200)]
    momentum_epochs: usize,
    /// Phase-2 (Levenberg-Marquardt) epoch limit.
    #[arg(long, default_value_t = 200)]
    max_epochs: usize,
    /// Performance goal: mean squared normalised residual.
    #[arg(long, default_value_t = 0.0)]
    goal: f64,
    /// Validation failures in a row before stopping.
    #[arg(long, default_value_t = 6)]
    max_fail: usize,
    /// Part of the training rows held out for early stopping.
    #[arg(long, default_value_t = 0.15)]
    validation_fraction: f64,
    /// Tracker sigmas for rows without their own (joint form weighting, refinement).
    #[command(flatten)]
    sigma: SigmaArgs,
    /// Compensator file to write (JSON).
    #[arg(long)]
    out: PathBuf,
    /// JSON report: training curve, stop reason, refined parameters, statistics.
    #[arg(long)]
    report: Option<PathBuf>,
    /// Folder for pictures (PNG and SVG, listed in figures.json for `robocal report`).
    #[arg(long)]
    plot: Option<PathBuf>,
}

pub fn run_train(a: TrainArgs) -> Result<()> {
    let robot = read_robot(&a.robot)?;
    let (set, val) = read_sets(&a.read, &a.data, a.validate.as_deref(), &robot)?;
    let opts = CompensatorOptions {
        form: a.form,
        sigmas: a.sigma.sigmas(),
        refine: a.refine.clone(),
        train: TrainOptions {
            hidden: a.hidden,
            seed: a.seed,
            momentum_epochs: a.momentum_epochs,
            max_epochs: a.max_epochs,
            goal: a.goal,
            max_fail: a.max_fail,
            validation_fraction: a.validation_fraction,
            progress: std::io::stderr().is_terminal(),
            ..Default::default()
        },
    };
    let (c, report) = Compensator::train(&robot, &set, &opts)
        .with_context(|| format!("training on {}", a.data.display()))?;
    c.save(&a.out)
        .with_context(|| format!("writing {}", a.out.display()))?;
    let n = &report.network;
    println!(
        "train: {} form, {}-{}-{} network on {} rows of {}; {} momentum + {} LM epochs; stopped: {}",
        match a.form {
            Form::Joint => "joint",
            Form::Pose => "pose",
        },
        c.weights.inputs(),
        c.weights.hidden(),
        c.weights.outputs(),
        set.rows.len(),
        a.data.display(),
        n.momentum_epochs,
        n.lm_epochs,
        n.stop.describe()
    );
    println!(
        "performance (mean squared normalised residual): training {:.4e}, held-out {:.4e}",
        n.train_mse, n.validation_mse
    );
    if !report.refined.is_empty() {
        println!("refined with the network:");
        for p in &report.refined {
            println!(
                "  {:<12} {:<4} {:>14.6} -> {:>14.6}",
                p.name, p.unit, p.before, p.after
            );
        }
    }
    let mut figs = 0;
    if let Some(dir) = &a.plot {
        training_figure(dir, "train", "compensator", &report.network)?;
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
        stat_rows.push((name, before, after));
        rows.push(
            json!({"set": name, "model": stats_json(&before), "compensated": stats_json(&after)}),
        );
    }
    let table: Vec<(&str, &str, &crate::evaluate::ErrorStats)> = stat_rows
        .iter()
        .flat_map(|(n, b, a)| [(*n, "model", b), (*n, "+net", a)])
        .collect();
    print_stats(&table);
    println!("wrote {}", a.out.display());
    if let Some(dir) = &a.plot {
        println!("plots: {figs} pictures in {}", dir.display());
    }
    if let Some(p) = &a.report {
        write_json(
            p,
            &json!({
                "robot": a.robot, "data": a.data, "compensator": a.out,
                "form": a.form, "hidden": a.hidden, "seed": a.seed,
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
    let c = Compensator::load(&a.compensator)?;
    let (mut headers, rows, joints) = super::fk::joint_table(&a.joints, c.robot.dof())?;
    headers.extend(crate::data::POSE_COLUMNS.iter().map(|s| s.to_string()));
    let mut ws = PredictWorkspace::default();
    let mut out = Vec::with_capacity(rows.len());
    for (cells, q) in rows.into_iter().zip(&joints) {
        let pose = c.predict(&c.robot.joints_to_internal(q), &mut ws);
        let mut row = cells;
        row.extend(
            pose_to_file(&pose)
                .iter()
                .map(|v| num(*v, a.output.decimals)),
        );
        out.push(row);
    }
    a.output
        .emit(&headers, &out)
        .with_context(|| "writing the predictions".to_string())
}
