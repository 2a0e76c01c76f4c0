//! `robocal reproduce`: the thesis's case studies (identification) on the shipped sets, with
//! the thesis's figures beside ours, and the same protocols over many seeds.

use anyhow::{Context, Result};
use clap::Args;
use robocal::evaluate::ErrorStats;
use robocal::model::read_robot;
use robocal::studies::reproduce::{
    Case, CaseRun, load_shipped, median_range, run_case, runs_over_seeds, thesis_figures,
};
use serde_json::json;
use std::path::PathBuf;

#[derive(Args)]
pub struct ReproduceArgs {
    /// The repository's datasets folder.
    #[arg(long, default_value = "datasets")]
    datasets: PathBuf,
    /// Seeds for the repeated protocols (1..=N; N from 1 to 1000).
    #[arg(long, default_value_t = 20, value_parser = clap::value_parser!(u64).range(1..=1000))]
    seeds: u64,
    /// JSON report of every figure.
    #[arg(long)]
    report: Option<PathBuf>,
}

fn pc(s: &ErrorStats) -> f64 {
    s.position_per_coordinate_mean_mm.unwrap_or(f64::NAN)
}
fn pos(s: &ErrorStats) -> f64 {
    s.position_mm.map_or(f64::NAN, |p| p.mean)
}
fn rms(s: &ErrorStats) -> f64 {
    s.position_mm.map_or(f64::NAN, |p| p.rms)
}
fn rot(s: &ErrorStats) -> f64 {
    s.orientation_deg.map_or(f64::NAN, |p| p.mean)
}

/// Rows of (figure, ours before vs measured, ours after vs measured, ours after vs truth).
fn figures(run: &CaseRun) -> Vec<(&'static str, f64, f64, f64)> {
    let (cb, ca, vb, va, vt) = (
        &run.calibration_before,
        &run.calibration_after,
        &run.validation_before,
        &run.validation_after,
        &run.validation_truth_after,
    );
    match run.case {
        Case::A => vec![
            (
                "calibration position, mean per coordinate mm",
                pc(cb),
                pc(ca),
                f64::NAN,
            ),
            (
                "validation position, mean per coordinate mm",
                pc(vb),
                pc(va),
                pc(vt),
            ),
            (
                "validation position, mean Euclidean mm",
                pos(vb),
                pos(va),
                pos(vt),
            ),
        ],
        Case::BSim => vec![
            (
                "calibration position, mean per coordinate mm",
                pc(cb),
                pc(ca),
                f64::NAN,
            ),
            (
                "calibration orientation, mean angle deg",
                rot(cb),
                rot(ca),
                f64::NAN,
            ),
            (
                "validation position, mean Euclidean mm",
                pos(vb),
                pos(va),
                pos(vt),
            ),
            (
                "validation orientation, mean angle deg",
                rot(vb),
                rot(va),
                rot(vt),
            ),
        ],
        Case::C => vec![(
            "validation RMS distance error mm",
            rms(vb),
            rms(va),
            rms(vt),
        )],
        Case::D => vec![
            (
                "test position, mean per coordinate mm",
                pc(vb),
                pc(va),
                pc(vt),
            ),
            (
                "test position, mean Euclidean mm",
                pos(vb),
                pos(va),
                pos(vt),
            ),
            (
                "test orientation, mean angle deg",
                rot(vb),
                rot(va),
                rot(vt),
            ),
        ],
    }
}

pub fn run(a: ReproduceArgs) -> Result<()> {
    use super::paths::{files_under, guard, opt, req};
    let read = files_under(&a.datasets);
    let inputs: Vec<_> = read.iter().map(|p| req("--datasets", p)).collect();
    guard(&inputs, &[opt("--report", a.report.as_ref())])?;
    let robot_path = a.datasets.join(robocal::studies::thesis::FANUC);
    let nominal = read_robot(&robot_path).with_context(|| {
        format!(
            "run from the repository root, or give --datasets ({})",
            robot_path.display()
        )
    })?;
    let mut report = serde_json::Map::new();
    println!(
        "Shipped data sets (one draw each); errors against the noisy measurements unless marked truth."
    );
    for case in Case::ALL {
        let data = load_shipped(&a.datasets, case, &nominal)?;
        let run = run_case(&nominal, case, &data)?;
        println!(
            "\ncase {} ({} calibration, {} validation rows); variance factor {:.3}",
            case.name(),
            data.calibration.rows.len(),
            data.validation.rows.len(),
            run.variance_factor
        );
        for (what, before, after) in thesis_figures(case) {
            println!("  thesis: {what:<34} {before:>9.4} -> {after:>8.4}");
        }
        println!(
            "  {:<46} {:>9} {:>9} {:>11}",
            "robocal", "before", "after", "after/truth"
        );
        let mut rows = Vec::new();
        for (what, b, af, t) in figures(&run) {
            let truth = if t.is_nan() {
                "-".to_string()
            } else {
                format!("{t:.4}")
            };
            println!("  {what:<46} {b:>9.4} {af:>9.4} {truth:>11}");
            rows.push(json!({"figure": what, "before": b, "after": af, "after_vs_truth": if t.is_nan() { serde_json::Value::Null } else { json!(t) }}));
        }
        report.insert(
            format!("case_{}", case.name()),
            json!({"figures": rows, "variance_factor": run.variance_factor}),
        );
    }
    println!(
        "\nThe same protocols over seeds 1..={} (simulated afresh): median [min, max]",
        a.seeds
    );
    let mut seeds = serde_json::Map::new();
    for case in [Case::A, Case::BSim, Case::C] {
        let runs = runs_over_seeds(&nominal, &a.datasets, case, a.seeds)?;
        let metrics: Vec<(&str, Vec<f64>)> = match case {
            Case::A => vec![(
                "validation mean per-coordinate error vs truth mm",
                runs.iter().map(|r| pc(&r.validation_truth_after)).collect(),
            )],
            Case::BSim => vec![
                (
                    "variance factor (1 = noise floor)",
                    runs.iter().map(|r| r.variance_factor).collect(),
                ),
                (
                    "validation mean position error vs truth mm",
                    runs.iter()
                        .map(|r| pos(&r.validation_truth_after))
                        .collect(),
                ),
                (
                    "validation mean position error vs measured mm",
                    runs.iter().map(|r| pos(&r.validation_after)).collect(),
                ),
                (
                    "noise floor: truth vs measured mm",
                    runs.iter()
                        .map(|r| pos(&r.validation_noise_floor))
                        .collect(),
                ),
            ],
            _ => vec![(
                "validation RMS distance error vs truth mm",
                runs.iter()
                    .map(|r| rms(&r.validation_truth_after))
                    .collect(),
            )],
        };
        for (what, v) in metrics {
            let (m, lo, hi) = median_range(&v);
            println!(
                "  case {:<6} {what:<50} {m:.4} [{lo:.4}, {hi:.4}]",
                case.name()
            );
            seeds.insert(
                format!("{} {what}", case.name()),
                json!({"median": m, "min": lo, "max": hi}),
            );
        }
    }
    report.insert("seeds".into(), serde_json::Value::Object(seeds));
    if let Some(p) = &a.report {
        let mut b = serde_json::to_vec_pretty(&serde_json::Value::Object(report))?;
        b.push(b'\n');
        robocal::io::write_atomic(p, &b)?;
    }
    Ok(())
}
