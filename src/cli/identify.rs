//! `robocal identify` and `robocal evaluate`.

use super::data_args::{DataArgs, SigmaArgs};
use super::train::load_compensator;
use crate::data::{JointInfo, MeasurementSet};
use crate::evaluate::{ErrorStats, RowError, row_errors, summarize};
use crate::identify::identifiability::DropReason;
use crate::identify::{Identified, Measure, Method, Options, RobustLoss, SolveOptions, identify};
use crate::kinematics::tool_pose;
use crate::model::{Robot, read_robot, write_robot};
use crate::neural::compensator::PredictWorkspace;
use crate::plot::{ErrorRun, error_figures};
use anyhow::Result;
use clap::Args;
use serde_json::{Value, json};
use std::path::{Path, PathBuf};

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

#[derive(Args)]
pub struct EvaluateArgs {
    /// Robot file to evaluate.
    #[arg(long)]
    robot: PathBuf,
    /// Measurements to evaluate against.
    #[arg(long)]
    data: PathBuf,
    /// A compensator (from `robocal train`) to evaluate beside the robot.
    #[arg(long)]
    compensator: Option<PathBuf>,
    #[command(flatten)]
    read: DataArgs,
    #[arg(long, value_enum)]
    measure: Option<Measure>,
    /// JSON report (`validation` holds the statistics, `compensated` those with the
    /// compensator).
    #[arg(long)]
    report: Option<PathBuf>,
    /// Folder for pictures (PNG and SVG, listed in figures.json for `robocal report`).
    #[arg(long)]
    plot: Option<PathBuf>,
}

fn fmt_stats(s: &ErrorStats) -> (String, String) {
    let p = s.position_mm.map_or("-".into(), |p| {
        format!(
            "{:>9.4} {:>9.4} {:>9.4} {:>9.4}",
            p.mean, p.rms, p.p95, p.max
        )
    });
    let r = s.orientation_deg.map_or("-".into(), |r| {
        format!("{:>8.4} {:>8.4} {:>8.4}", r.mean, r.rms, r.max)
    });
    (p, r)
}

/// Prints a before/after table of error statistics.
pub fn print_stats(rows: &[(&str, &str, &ErrorStats)]) {
    println!(
        "{:<12} {:<7} {:>39}   {:>26}",
        "set", "model", "position mm: mean rms p95 max", "orientation deg: mean rms max"
    );
    for (set, model, s) in rows {
        let (p, r) = fmt_stats(s);
        println!("{set:<12} {model:<7} {p:>39}   {r:>26}");
    }
}

pub(super) fn stats_json(s: &ErrorStats) -> Value {
    serde_json::to_value(s).unwrap_or(Value::Null)
}

pub(super) fn write_json(path: &Path, v: &Value) -> Result<()> {
    let mut b = serde_json::to_vec_pretty(v)?;
    b.push(b'\n');
    super::output::writing(crate::io::write_atomic(path, &b), path)
}

pub(super) fn read_set(args: &DataArgs, path: &Path, robot: &Robot) -> Result<MeasurementSet> {
    args.read(path, &JointInfo::of(robot))
}

/// The main data set and the optional validation set of a command.
pub(super) fn read_sets(
    args: &DataArgs,
    data: &Path,
    validate: Option<&Path>,
    robot: &Robot,
) -> Result<(MeasurementSet, Option<MeasurementSet>)> {
    let set = read_set(args, data, robot)?;
    let val = validate.map(|p| read_set(args, p, robot)).transpose()?;
    Ok((set, val))
}

/// The model and the data of a fit on measurements (`identify`, `train`), after refusing
/// outputs that name one of its inputs or each other ([`super::paths::guard`]).
pub(super) fn open_fit(
    robot: &Path,
    data: &Path,
    validate: Option<&PathBuf>,
    read: &DataArgs,
    out: &Path,
    report: Option<&PathBuf>,
) -> Result<(Robot, MeasurementSet, Option<MeasurementSet>)> {
    use super::paths::{guard, opt, req};
    guard(
        &[
            req("--robot", robot),
            req("--data", data),
            opt("--validate", validate),
            opt("--profile", read.profile.as_ref()),
        ],
        &[req("--out", out), opt("--report", report)],
    )?;
    let model = read_robot(robot)?;
    let (set, val) = read_sets(read, data, validate.map(|p| p.as_path()), &model)?;
    Ok((model, set, val))
}

pub fn run_identify(a: IdentifyArgs) -> Result<()> {
    let (nominal, cal, val) = open_fit(
        &a.robot,
        &a.data,
        a.validate.as_ref(),
        &a.read,
        &a.out,
        a.report.as_ref(),
    )?;
    let opts = Options {
        params: a.params.clone(),
        measure: a.measure,
        sigmas: a.sigma.sigmas(),
        solve: SolveOptions {
            method: a.method,
            max_iterations: a.max_iterations,
            ..Default::default()
        },
        robust: a.robust,
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
            "measure": m, "method": a.method, "params": a.params,
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
            "robust": a.robust, "robust_rounds": id.robust_rounds,
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

pub fn run_evaluate(a: EvaluateArgs) -> Result<()> {
    use super::paths::{guard, opt, req};
    guard(
        &[
            req("--robot", &a.robot),
            req("--data", &a.data),
            opt("--compensator", a.compensator.as_ref()),
            opt("--profile", a.read.profile.as_ref()),
        ],
        &[opt("--report", a.report.as_ref())],
    )?;
    let robot = read_robot(&a.robot)?;
    let (comp, note) = match &a.compensator {
        Some(p) => {
            let (c, note) = load_compensator(p, &a.robot, &robot)?;
            (Some(c), note)
        }
        None => (None, None),
    };
    let set = read_set(&a.read, &a.data, &robot)?;
    let m = a.measure.unwrap_or_else(|| Measure::default_for(&set));
    let model_rows = row_errors(&set, m, |q| tool_pose(&robot, q))?;
    let s = summarize(&model_rows);
    println!(
        "evaluate: {} on {} ({} rows, measure {})",
        a.robot.display(),
        a.data.display(),
        set.rows.len(),
        m.name()
    );
    let mut outside = Vec::new();
    let net_rows = match &comp {
        Some(c) => {
            let mut ws = PredictWorkspace::default();
            outside = set
                .rows
                .iter()
                .filter(|r| !c.domain_check(&r.q, &mut ws).inside())
                .map(|r| r.line)
                .collect();
            Some(row_errors(&set, m, |q| c.predict(q, &mut ws))?)
        }
        None => None,
    };
    let compensated = net_rows.as_deref().map(summarize);
    let mut table = vec![("data", "model", &s)];
    if let Some(c) = &compensated {
        table.push(("data", "+net", c));
    }
    print_stats(&table);
    for (what, st) in [
        ("model", Some(&s)),
        ("with the compensator", compensated.as_ref()),
    ] {
        if let Some(c) = st.and_then(|st| st.position_per_coordinate_mean_mm) {
            println!("mean per-coordinate position error |dx|,|dy|,|dz| ({what}): {c:.4} mm");
        }
    }
    if let Some(note) = note {
        println!("{note}");
    }
    super::train::warn_outside(&a.data, &outside, false);
    if let Some(dir) = &a.plot {
        let mut runs = vec![ErrorRun {
            label: "model",
            errors: &model_rows,
        }];
        if let Some(n) = &net_rows {
            runs.push(ErrorRun {
                label: "with compensator",
                errors: n,
            });
        }
        let figs = error_figures(dir, "evaluate", "evaluation data", &set, &runs)?;
        println!("plots: {} pictures in {}", figs.len(), dir.display());
    }
    if let Some(path) = &a.report {
        let mut v =
            json!({"robot": a.robot, "data": a.data, "measure": m, "validation": stats_json(&s)});
        if let (Some(p), Some(c)) = (&a.compensator, &compensated) {
            v["compensator"] = json!(p);
            v["compensated"] = stats_json(c);
            v["rows_outside_domain"] = json!(outside.len());
        }
        write_json(path, &v)?;
    }
    Ok(())
}
