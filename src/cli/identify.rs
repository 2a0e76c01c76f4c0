//! `robocal identify`.

use super::choices::{Measure, Method, RobustLoss};
use super::data_args::{DataArgs, SigmaArgs, open_fit};
use super::summary::{print_stats, stats_json, write_json};
use anyhow::Result;
use clap::Args;
use robocal::data::MeasurementSet;
use robocal::evaluate::{RowError, row_errors, summarize};
use robocal::identify::identifiability::DropReason;
use robocal::identify::{Identified, Options, SolveOptions, identify};
use robocal::kinematics::tool_pose;
use robocal::model::write_robot;
use robocal::plot::{ErrorRun, error_figures};
use serde_json::{Value, json};
use std::path::PathBuf;

#[derive(Args)]
pub struct IdentifyArgs {
    /// Starting (nominal) robot file.
    #[arg(long)]
    robot: PathBuf,
    /// Calibration measurements.
    #[arg(long)]
    data: PathBuf,
    /// Validation measurements (e.g. another set, or a simulated set's truth file).
    #[arg(long)]
    validate: Option<PathBuf>,
    #[command(flatten)]
    read: DataArgs,
    /// Parameters: offsets | full | base | tool | joints | names, comma-separated.
    #[arg(long, default_value = "full")]
    params: String,
    /// How to compare measurements (default: pose if the data has orientations, else position).
    #[arg(long, value_enum)]
    measure: Option<Measure>,
    #[arg(long, value_enum, default_value_t = Method::Lm)]
    method: Method,
    #[command(flatten)]
    sigma: SigmaArgs,
    /// Robust loss by iteratively reweighted least squares.
    #[arg(long, value_enum)]
    robust: Option<RobustLoss>,
    /// Do not register a 6-DOF base (and tool) to the measured positions before solving.
    #[arg(long)]
    no_register: bool,
    /// Iteration limit (1 to 100000).
    #[arg(long, default_value_t = 200, value_parser = super::bounds::iterations)]
    max_iterations: usize,
    /// Rows beyond this many robust sigmas are reported as outliers.
    #[arg(long, default_value_t = 3.0)]
    outlier_k: f64,
    /// Calibrated robot file to write.
    #[arg(long)]
    out: PathBuf,
    /// JSON report.
    #[arg(long)]
    report: Option<PathBuf>,
    /// Folder for pictures (PNG and SVG, listed in figures.json for `robocal report`).
    #[arg(long)]
    plot: Option<PathBuf>,
}

pub fn run_identify(a: IdentifyArgs) -> Result<()> {
    let (nominal, cal, val) = open_fit(
        &a.robot,
        &a.data,
        a.validate.as_ref(),
        &a.read,
        &a.out,
        a.report.as_ref(),
        a.plot.as_ref(),
    )?;
    if a.outlier_k.is_nan() || a.outlier_k < 1.0 {
        anyhow::bail!(
            "--outlier-k {}: give a cut of at least 1 robust sigma (inf reports none)",
            a.outlier_k
        );
    }
    let opts = Options {
        params: a.params.clone(),
        measure: a.measure.map(Into::into),
        sigmas: a.sigma.sigmas(),
        solve: SolveOptions {
            method: a.method.into(),
            max_iterations: a.max_iterations,
            ..Default::default()
        },
        robust: a.robust.map(Into::into),
        register: !a.no_register,
        outlier_k: a.outlier_k,
        ..Default::default()
    };
    let id = identify(&nominal, &cal, &opts)?;
    super::output::writing(write_robot(&id.robot, &a.out), &a.out)?;
    let m = id.measure;
    // Row errors before and after, per set: for the statistics and the pictures.
    let errors = |set: &MeasurementSet| -> Result<(Vec<RowError>, Vec<RowError>)> {
        Ok((
            row_errors(set, m, |q| tool_pose(&nominal, q))?,
            row_errors(set, m, |q| tool_pose(&id.robot, q))?,
        ))
    };
    let cal_rows = errors(&cal)?;
    let val_rows = val.as_ref().map(errors).transpose()?;
    let (cal_before, cal_after) = (summarize(&cal_rows.0), summarize(&cal_rows.1));
    let val_stats = val_rows
        .as_ref()
        .map(|(b, af)| (summarize(b), summarize(af)));
    print_identified(&a, &cal, &id);
    let mut rows = vec![
        ("calibration", "before", &cal_before),
        ("calibration", "after", &cal_after),
    ];
    if let Some((b, af)) = &val_stats {
        rows.push(("validation", "before", b));
        rows.push(("validation", "after", af));
    }
    print_stats(&rows);
    for n in &id.notes {
        println!("note: {n}");
    }
    for w in &id.warnings {
        eprintln!("warning: {w}");
    }
    println!("wrote {}", a.out.display());
    if let Some(dir) = &a.plot {
        let mut figs = 0;
        let sets = [
            ("calibration", Some((&cal, &cal_rows))),
            ("validation", val.as_ref().zip(val_rows.as_ref())),
        ];
        for (name, set) in sets {
            let Some((set, (before, after))) = set else {
                continue;
            };
            let runs = [
                ErrorRun {
                    label: "nominal",
                    errors: before,
                },
                ErrorRun {
                    label: "identified",
                    errors: after,
                },
            ];
            figs += error_figures(
                dir,
                &format!("identify_{name}"),
                &format!("{name} data"),
                set,
                &runs,
            )?
            .len();
        }
        println!("plots: {figs} pictures in {}", dir.display());
    }
    if let Some(path) = &a.report {
        let params = id.robot.parameters();
        let dropped: Vec<Value> = id
            .identifiability
            .dropped
            .iter()
            .map(|d| match &d.reason {
                DropReason::NoEffect => json!({"name": params[d.param].name(), "reason": "no effect"}),
                DropReason::Regroups(g) => json!({
                    "name": params[d.param].name(),
                    "reason": "regroups",
                    "regroups_with": g.iter().map(|(p, c)| json!({"name": params[*p].name(), "coefficient": c})).collect::<Vec<_>>(),
                }),
            })
            .collect();
        let ident = &id.identifiability;
        let v = json!({
            "robot": a.robot, "data": a.data, "validation_data": a.validate,
            "measure": m, "method": robocal::identify::Method::from(a.method), "params": a.params,
            "calibration": stats_json(&cal_after),
            "calibration_before": stats_json(&cal_before),
            "validation": val_stats.as_ref().map(|(_, af)| stats_json(af)),
            "validation_before": val_stats.as_ref().map(|(b, _)| stats_json(b)),
            "parameters": id.parameters,
            "dropped": dropped,
            "condition_number": finite_or_null(ident.selected_condition_number),
            "condition_number_all_candidates": finite_or_null(ident.condition_number),
            "rank": ident.rank,
            "rank_pivoted_qr": ident.rank_pivoted_qr,
            "singular_values": ident.singular_values,
            "iterations": id.solution.iterations,
            "stop_reason": id.solution.stop,
            "variance_factor": finite_or_null(id.variance_factor),
            "correlations": id.correlations.iter().map(|(x, y, r)| json!({"a": x, "b": y, "correlation": r})).collect::<Vec<_>>(),
            "outliers": id.outliers,
            "robust": a.robust.map(robocal::identify::RobustLoss::from), "robust_rounds": id.robust_rounds,
            "registration_rms_mm": id.registration.as_ref().map(|r| r.rms_mm),
            "notes": id.notes,
            "warnings": id.warnings,
        });
        write_json(path, &v)?;
    }
    Ok(())
}

fn finite_or_null(v: f64) -> Value {
    if v.is_finite() { json!(v) } else { Value::Null }
}

fn print_identified(a: &IdentifyArgs, cal: &MeasurementSet, id: &Identified) {
    let params = id.robot.parameters();
    let ident = &id.identifiability;
    println!(
        "identify: {} rows of {}, measure {}, method {:?}, parameters `{}`",
        cal.rows.len(),
        a.data.display(),
        id.measure.name(),
        a.method,
        a.params
    );
    if let Some(r) = &id.registration {
        println!(
            "registration of the base{}: RMS {:.4} mm",
            if r.tool.is_some() { " and tool" } else { "" },
            r.rms_mm
        );
    }
    println!(
        "identifiability: {} candidates, rank {} (SVD) / {} (pivoted QR), condition number {:.4e} \
         (column-scaled); identifiable set: {} parameters, condition number {:.4e}",
        ident.candidates.len(),
        ident.rank,
        ident.rank_pivoted_qr,
        ident.condition_number,
        ident.selected.len(),
        ident.selected_condition_number
    );
    for d in &ident.dropped {
        let why = match &d.reason {
            DropReason::NoEffect => "no effect on these measurements".to_string(),
            DropReason::Regroups(g) => format!(
                "regroups with {}",
                g.iter()
                    .map(|(p, c)| format!("{:+.4} {}", c, params[*p].name()))
                    .collect::<Vec<_>>()
                    .join(" ")
            ),
        };
        println!("  left out {:<12} {why}", params[d.param].name());
    }
    println!(
        "solution: {} iterations, {}; variance factor s^2 = {:.4}",
        id.solution.iterations,
        id.solution.stop.describe(),
        id.variance_factor
    );
    println!(
        "{:<12} {:<4} {:>14} {:>14} {:>12}",
        "parameter", "unit", "nominal", "estimate", "std"
    );
    for p in &id.parameters {
        println!(
            "{:<12} {:<4} {:>14.6} {:>14.6} {:>12.6}",
            p.name, p.unit, p.nominal, p.estimate, p.std
        );
    }
    if !id.correlations.is_empty() {
        let list: Vec<String> = id
            .correlations
            .iter()
            .map(|(x, y, r)| format!("{x}/{y} {r:+.3}"))
            .collect();
        println!("correlated (|r| > 0.9): {}", list.join(", "));
    }
    if id.outliers.is_empty() {
        println!("outliers (> {} robust sigmas): none", a.outlier_k);
    } else {
        let lines: Vec<String> = id
            .outliers
            .iter()
            .map(|o| format!("line {} ({:.1})", o.line, o.robust_sigmas))
            .collect();
        println!(
            "outliers (> {} robust sigmas): {}",
            a.outlier_k,
            lines.join(", ")
        );
    }
}
