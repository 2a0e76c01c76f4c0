//! `robocal plan-study`: planned against random configurations on simulated robots over
//! seeds (the README's "Plan your measurements" table and picture).

use super::choices::Criterion;
use anyhow::{Context, Result};
use clap::Args;
use robocal::identify::Measure;
use robocal::plot::charts::{Curve, Curves};
use robocal::stats::median;
use robocal::studies::planning::{Case, Series, Setup, TABLE_HEADER, range, run};
use std::io::IsTerminal;
use std::path::PathBuf;

#[derive(Args)]
pub struct PlanStudyArgs {
    /// The repository's datasets folder.
    #[arg(long, default_value = "datasets")]
    datasets: PathBuf,
    /// Seeds (1 to 200): each a candidate pool, a validation cloud and a noise draw.
    #[arg(long, default_value_t = 20)]
    seeds: usize,
    /// Candidate configurations per seed (100 to 20000).
    #[arg(long, default_value_t = 2000)]
    pool: usize,
    /// What the plans maximise.
    #[arg(long, value_enum, default_value_t = Criterion::D)]
    criterion: Criterion,
    /// Folder for the pictures (error against the number measured, planned and random).
    #[arg(long)]
    plot: Option<PathBuf>,
}

const PLANNED: [usize; 5] = [15, 20, 30, 40, 60];
const RANDOM: [usize; 6] = [15, 20, 25, 30, 40, 60];

fn curve(label: &str, series: &[Series], predicted: bool) -> Curve {
    Curve {
        label: label.into(),
        points: series
            .iter()
            .map(|s| {
                let v = if predicted { &s.predicted } else { &s.realised };
                let (lo, hi) = range(v);
                (s.units as f64, median(v), lo, hi)
            })
            .collect(),
        dashed: predicted,
    }
}

pub fn run_study(a: PlanStudyArgs) -> Result<()> {
    // The picture folder checked before the study's minutes, not after.
    super::paths::guard(&[], &[super::paths::opt("--plot", a.plot.as_ref())])?;
    if !(1..=200).contains(&a.seeds) {
        usage!("--seeds {}: give 1 to 200", a.seeds);
    }
    if !(100..=20_000).contains(&a.pool) {
        usage!("--pool {}: give 100 to 20000", a.pool);
    }
    let d = &a.datasets;
    let cases = (|| -> robocal::error::Result<_> {
        Ok([
            (Case::table_6_1(d)?, "pose", Measure::Pose),
            (Case::table_6_1(d)?, "position", Measure::Position),
            (Case::nongeometric(d)?, "pose", Measure::Pose),
        ])
    })()
    .with_context(|| super::paths::datasets_context(d, "the planning study"))?;
    let bar = super::compensator_args::progress_bar(std::io::stderr().is_terminal());
    bar.set_length((a.seeds * cases.len()) as u64);
    let mut outcomes = Vec::new();
    for (case, _, measure) in &cases {
        let setup = Setup {
            seeds: a.seeds,
            pool: a.pool,
            cloud: 300,
            planned: PLANNED.to_vec(),
            random: RANDOM.to_vec(),
            measure: *measure,
            criterion: a.criterion.into(),
        };
        outcomes.push(run(case, &setup, &mut |_| bar.inc(1))?);
    }
    bar.finish_and_clear();
    say!(
        "mean position error against the truth over 300 validation configurations, {} seeds, identification of `full` (mm)",
        a.seeds
    );
    say!("{TABLE_HEADER}");
    for ((case, name, _), o) in cases.iter().zip(&outcomes) {
        if let Some(row) = o.table_row(&case.name, name) {
            say!("{row}");
        }
    }
    say!("\nmedian error (mm) against the number of configurations measured:");
    for ((case, name, _), o) in cases.iter().zip(&outcomes) {
        let line = |s: &[Series]| {
            s.iter()
                .map(|s| format!("{}: {:.4}", s.units, median(&s.realised)))
                .collect::<Vec<_>>()
                .join(", ")
        };
        say!("{} {name}: planned {}", case.name, line(&o.planned));
        say!("{} {name}: random  {}", case.name, line(&o.random));
    }
    if let Some(dir) = &a.plot {
        robocal::plot::forget_earlier(dir, "plan")?;
        for ((case, name, _), o) in cases.iter().zip(&outcomes) {
            let chart = Curves {
                title: format!(
                    "{} ({name} measured): planned and random configurations",
                    case.name
                ),
                x_label: "configurations measured".into(),
                y_label: "mean position error vs truth (mm)".into(),
                curves: vec![
                    curve("planned (median, range over seeds)", &o.planned, false),
                    curve("planned, predicted before measuring", &o.planned, true),
                    curve("random (median, range over seeds)", &o.random, false),
                    curve("random, predicted", &o.random, true),
                ],
            };
            let file = format!(
                "plan_{}_{name}",
                case.name
                    .to_lowercase()
                    .replace([' ', '.'], "_")
                    .replace("__", "_")
            );
            robocal::plot::save(
                dir,
                &file,
                &chart.title,
                &format!(
                    "Median mean position error against the truth after identifying `full`, over {} seeds; whiskers: range. Dashed: predicted before measuring.",
                    a.seeds
                ),
                &chart,
            )?;
        }
    }
    Ok(())
}
