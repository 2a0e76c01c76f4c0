//! `robocal reproduce`: the thesis's case studies (identification) on the shipped sets, with
//! the thesis's figures beside ours, and the same protocols over many seeds.

use anyhow::{Context, Result};
use clap::Args;
use robocal::model::read_robot;
use robocal::reports::{Report, ReproduceCase, ReproduceReport, SeedFigure};
use robocal::studies::reproduce::{Case, load_shipped, run_case, runs_over_seeds};
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

pub fn run(a: ReproduceArgs) -> Result<()> {
    use super::paths::{files_under, guard, opt, req};
    let read = files_under(&a.datasets);
    let inputs: Vec<_> = read.iter().map(|p| req("--datasets", p)).collect();
    guard(&inputs, &[opt("--report", a.report.as_ref())])?;
    let robot_path = a.datasets.join(robocal::studies::thesis::FANUC);
    let nominal = read_robot(&robot_path)
        .with_context(|| super::paths::datasets_context(&a.datasets, "the shipped robot"))?;
    say!(
        "Shipped data sets (one draw each); errors against the noisy measurements unless marked truth."
    );
    let mut cases = Vec::new();
    for case in Case::ALL {
        let data = load_shipped(&a.datasets, case, &nominal)?;
        // Rows pasted twice count one reading twice, as identify warns.
        for set in [&data.calibration, &data.validation] {
            if let Some(w) = robocal::identify::plausibility::copied_warning(set) {
                eprintln!("warning: {w}");
            }
        }
        let run = run_case(&nominal, case, &data)?;
        let c = ReproduceCase::new(&data, &run);
        say!(
            "\ncase {} ({} calibration, {} validation rows); variance factor {:.3}",
            c.case,
            c.calibration_rows,
            c.validation_rows,
            c.variance_factor
        );
        for t in &c.thesis {
            say!(
                "  thesis: {:<34} {:>9.4} -> {:>8.4}",
                t.figure,
                t.before,
                t.after
            );
        }
        say!(
            "  {:<46} {:>9} {:>9} {:>11}",
            "robocal",
            "before",
            "after",
            "after/truth"
        );
        for f in &c.figures {
            let truth = f
                .after_vs_truth
                .map_or_else(|| "-".to_string(), |t| format!("{t:.4}"));
            say!(
                "  {:<46} {:>9.4} {:>9.4} {truth:>11}",
                f.figure,
                f.before,
                f.after
            );
        }
        cases.push(c);
    }
    say!(
        "\nThe same protocols over seeds 1..={} (simulated afresh): median [min, max]",
        a.seeds
    );
    let mut over_seeds = Vec::new();
    for case in [Case::A, Case::BSim, Case::C] {
        let runs = runs_over_seeds(&nominal, &a.datasets, case, a.seeds)?;
        for f in SeedFigure::of(case, &runs) {
            say!(
                "  case {:<6} {:<50} {:.4} [{:.4}, {:.4}]",
                f.case,
                f.figure,
                f.median,
                f.min,
                f.max
            );
            over_seeds.push(f);
        }
    }
    if let Some(p) = &a.report {
        let report = ReproduceReport {
            cases,
            seeds: a.seeds,
            over_seeds,
        };
        super::summary::write_report(p, &Report::Reproduce(report))?;
    }
    Ok(())
}
