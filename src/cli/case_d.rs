//! `robocal case-d`: thesis Case D end to end (Table 6.6) and the same protocol on the shipped
//! non-geometric robot.

use super::compensator_args::CompensatorArgs;
use super::data_args::SigmaArgs;
use super::summary::write_report;
use anyhow::{Context, Result};
use clap::Args;
use robocal::plot::{ErrorRun, error_figures, training_figure};
use robocal::reports::studies::CaseDSet;
use robocal::reports::{CaseDReport, Report};
use robocal::studies::case_d::{
    Robotset, Row, SetData, Stage, copied_warnings, load_all, run_loaded,
};
use std::io::IsTerminal;
use std::path::{Path, PathBuf};

#[derive(Args)]
pub struct CaseDArgs {
    /// The repository's datasets folder.
    #[arg(long, default_value = "datasets")]
    datasets: PathBuf,
    #[command(flatten)]
    pub(super) build: CompensatorArgs,
    #[command(flatten)]
    sigma: SigmaArgs,
    /// JSON report of every row (statistics against truth and measurements, training).
    #[arg(long)]
    report: Option<PathBuf>,
    /// Folder for pictures (PNG and SVG, listed in figures.json for `robocal report`).
    #[arg(long)]
    plot: Option<PathBuf>,
}

fn print_set(s: &CaseDSet) {
    say!("\n{} - {} unseen test poses", s.title, s.test_rows);
    say!(
        "{:<27} | {:>17} | {:>27} | {:>27}",
        "model",
        "thesis Table 6.6",
        "vs truth",
        "vs measured"
    );
    say!(
        "{:<27} | {:>8} {:>8} | {:>8} {:>8} {:>9} | {:>8} {:>8} {:>9}",
        "",
        "mm",
        "deg",
        "mean mm",
        "coord mm",
        "mean deg",
        "mean mm",
        "coord mm",
        "mean deg"
    );
    for r in &s.rows {
        let thesis = match (r.thesis_mm, r.thesis_deg) {
            (Some(p), Some(o)) => format!("{p:>8.4} {o:>8.4}"),
            _ => format!("{:>17}", "-"),
        };
        say!(
            "{:<27} | {thesis} | {:>8.4} {:>8.4} {:>9.4} | {:>8.4} {:>8.4} {:>9.4}",
            r.label,
            r.truth.position_mean_mm(),
            r.truth.per_coordinate_mm(),
            r.truth.orientation_mean_deg(),
            r.measured.position_mean_mm(),
            r.measured.per_coordinate_mm(),
            r.measured.orientation_mean_deg()
        );
    }
    if let (Some(o), Some(f)) = (s.gain_after_offsets, s.gain_after_full) {
        let mut gains = vec![(o, "after offsets"), (f, "after full identification")];
        // A stage whose training kept no network: its gain is the refinement's, said so.
        let full = (s.rows.iter().find(|r| r.stage == Stage::FullNetwork))
            .and_then(|r| robocal::reports::studies::kept_no_network(r.training.as_ref()));
        match full {
            Some(true) => {
                gains[1].1 = "after full identification (no network: the model refined on the \
                              training poses)"
            }
            Some(false) => gains[1].1 = "after full identification (no network)",
            None => {}
        }
        gains.extend(
            s.gain_after_compliance
                .map(|c| (c, "after full + compliance")),
        );
        say!("{}", gain_words(&gains));
    }
}

/// Per set: the test errors of every stage, and the training curves of the network stages.
fn plot(dir: &Path, sets: &[(Robotset, SetData)], rows: &[Row]) -> Result<usize> {
    robocal::plot::forget_earlier(dir, "case_d")?;
    let mut figs = 0;
    for &(set, ref data) in sets {
        // Picture names: case_d_test, case_d_nongeometric_test, ...
        let (tag, name) = match set {
            Robotset::CaseD => ("case_d", "Case D"),
            Robotset::NonGeometric => ("case_d_nongeometric", "non-geometric robot"),
        };
        let mine: Vec<&Row> = rows.iter().filter(|r| r.set == set).collect();
        let runs: Vec<ErrorRun> = mine
            .iter()
            .map(|r| ErrorRun {
                label: r.stage.label(),
                errors: &r.truth_errors,
            })
            .collect();
        figs += error_figures(
            dir,
            &format!("{tag}_test"),
            &format!("{name} test truth"),
            &data.test_truth,
            &runs,
        )?
        .len();
        for r in &mine {
            if let Some(t) = r.training.as_ref().filter(|t| !t.networks.is_empty()) {
                let stage = match r.stage {
                    Stage::OffsetsNetwork => "offsets_network",
                    Stage::FullComplianceNetwork => "compliance_network",
                    _ => "full_network",
                };
                training_figure(
                    dir,
                    &format!("{tag}_{stage}"),
                    &format!("{name}, {}", r.stage.label()),
                    &t.networks[0], // not empty: filtered above
                )?;
                figs += 1;
            }
        }
    }
    Ok(figs)
}

pub fn run_case_d(a: CaseDArgs) -> Result<()> {
    use super::paths::{files_under, guard, opt, req};
    let read = files_under(&a.datasets);
    let inputs: Vec<_> = read.iter().map(|p| req("--datasets", p)).collect();
    guard(
        &inputs,
        &[
            opt("--report", a.report.as_ref()),
            opt("--plot", a.plot.as_ref()),
        ],
    )?;
    let opts = a
        .build
        .options(a.sigma.sigmas(), std::io::stderr().is_terminal())?;
    let context = || super::paths::datasets_context(&a.datasets, "Case D");
    let sets = load_all(&a.datasets).with_context(context)?;
    // Said before the training's minutes.
    for w in sets.iter().flat_map(|(_, data)| copied_warnings(data)) {
        eprintln!("warning: {w}");
    }
    let rows = run_loaded(&a.datasets, &sets, &opts).with_context(context)?;
    let report = CaseDReport::new(a.build.seed, &rows);
    // The rows as read (the protocol's 30 and 150 in the shipped files; a reviewer's
    // shortened files were still said to hold them).
    let poses = |kind: &str, count: &dyn Fn(&robocal::reports::studies::CaseDSet) -> usize| {
        let n: Vec<usize> = report.sets.iter().map(count).collect();
        if n.windows(2).all(|w| w[0] == w[1]) {
            format!("the {} {kind} poses", n.first().copied().unwrap_or(0))
        } else {
            let each: Vec<String> = (report.sets.iter().zip(&n))
                .map(|(s, k)| format!("{k} in {}", s.set.folder()))
                .collect();
            format!("the {kind} poses ({})", each.join(", "))
        }
    };
    say!(
        "Case D (thesis 6.4): identification on {}, then a compensator trained on {} (seed \
         {}; settings and the refinement of the identified parameters chosen by \
         cross-validation unless fixed by flags).",
        poses("calibration", &|s| s.calibration_rows),
        poses("training", &|s| s.training_rows),
        a.build.seed
    );
    for s in &report.sets {
        for r in &s.rows {
            if let Some(settings) = &r.settings {
                say!("  {}, {}: {settings}", s.set.folder(), r.label);
            }
            // What `train` would warn of (a network fixed by --members that the model alone
            // beats), said with the row it concerns.
            let selection = r.training.as_ref().and_then(|t| t.selection.as_ref());
            for w in selection.iter().flat_map(|sel| &sel.warnings) {
                eprintln!("warning: {}, {}: {w}", s.set.folder(), r.label);
            }
        }
    }
    say!(
        "Errors on the test poses: mean Euclidean position (mm), mean per coordinate |dx|,|dy|,|dz| \
         (mm, the thesis's measure), mean orientation angle (deg)."
    );
    for s in &report.sets {
        print_set(s);
    }
    if let Some(dir) = &a.plot {
        let figs = plot(dir, &sets, &rows)?;
        told_after!("\nplots: {figs} pictures in {}", dir.display());
    }
    if let Some(p) = &a.report {
        write_report(p, &Report::CaseD(report))?;
    }
    Ok(())
}

/// The compensator's gains (the model alone's mean position error over the compensated one's,
/// each with what it follows) in words; a gain below 1 is said as the rise it is.
fn gain_words(gains: &[(f64, &str)]) -> String {
    if gains.iter().all(|(g, _)| *g >= 1.0) {
        let words: Vec<String> = gains.iter().map(|(g, w)| format!("{g:.1}x {w}")).collect();
        return format!(
            "the compensator lowers the mean position error vs truth {}",
            words.join(", ")
        );
    }
    let words: Vec<String> = gains
        .iter()
        .map(|&(g, w)| match g {
            g if g >= 1.0 => format!("{g:.1}x lower {w}"),
            g => format!("{:.2}x higher {w}", 1.0 / g),
        })
        .collect();
    format!(
        "the compensator's mean position error vs truth against the model alone: {}",
        words.join(", ")
    )
}

#[cfg(test)]
mod tests {
    #[test]
    fn a_gain_below_one_is_said_as_a_rise() {
        assert_eq!(
            super::gain_words(&[(33.7, "after offsets"), (3.1, "after full identification")]),
            "the compensator lowers the mean position error vs truth 33.7x after offsets, 3.1x \
             after full identification"
        );
        assert_eq!(
            super::gain_words(&[(4.4, "after offsets"), (0.8, "after full identification")]),
            "the compensator's mean position error vs truth against the model alone: 4.4x \
             lower after offsets, 1.25x higher after full identification"
        );
    }
}
