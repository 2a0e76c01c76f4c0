//! `robocal evaluate`: the accuracy of a model (and a compensator) on measurements.

use super::data_args::DataArgs;
use super::predict::{load_compensator, outside_warning};
use super::summary::{
    clean_accuracy, print_repeats, print_shared, print_stats, print_worst, shared_under,
    write_report,
};
use anyhow::Result;
use clap::Args;
use robocal::data::shared_readings::rows_checked;
use robocal::evaluate::{misplaced_model_warning, row_errors, summarize, worst_rows};
use robocal::identify::Measure;
use robocal::kinematics::tool_pose;
use robocal::model::read_robot;
use robocal::neural::predict::PredictWorkspace;
use robocal::neural::repeats::Repeats;
use robocal::plot::{ErrorRun, error_figures};
use robocal::reports::{Accuracy, EvaluateReport, Report};
use std::path::PathBuf;

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
    /// Other measurements of the same robot (the training file of a compensator, say) to
    /// check this file's readings against: a row here that carries the reading of a row there,
    /// logged with other joints, is listed and left out of `data clean` as one that carries the
    /// reading of a row of this file is (read with the same options as `--data`; measures pose
    /// and position; rows with a position and an orientation).
    #[arg(long, value_name = "FILE")]
    check_against: Option<PathBuf>,
    #[command(flatten)]
    read: DataArgs,
    #[arg(long, value_enum)]
    measure: Option<super::choices::Measure>,
    /// JSON report (typed: `kind` evaluate, the `accuracy` rows of the model and of the
    /// compensator).
    #[arg(long)]
    report: Option<PathBuf>,
    /// Folder for pictures (PNG and SVG, listed in figures.json for `robocal report`).
    #[arg(long)]
    plot: Option<PathBuf>,
}

/// The label of the accuracy rows without the rows that carry another configuration's
/// reading.
const CLEAN: &str = "data clean";

pub fn run_evaluate(a: EvaluateArgs) -> Result<()> {
    use super::paths::{guard, opt, req};
    guard(
        &[
            req("--robot", &a.robot),
            req("--data", &a.data),
            opt("--compensator", a.compensator.as_ref()),
            opt("--check-against", a.check_against.as_ref()),
            opt("--profile", a.read.profile.as_ref()),
        ],
        &[
            opt("--report", a.report.as_ref()),
            opt("--plot", a.plot.as_ref()),
        ],
    )?;
    let robot = read_robot(&a.robot)?;
    let mut warnings = super::warnings::Warnings::default();
    let (comp, note) = match &a.compensator {
        Some(p) => {
            let (c, note) = load_compensator(p, &a.robot, &robot, &mut warnings)?;
            (Some(c), note)
        }
        None => (None, None),
    };
    let joints = robocal::data::JointInfo::of(&robot);
    let (set, read) = a.read.read_noted(&a.data, &joints)?;
    warnings.printed_too(read);
    let m = a
        .measure
        .map(Measure::from)
        .unwrap_or_else(|| Measure::default_for(&set));
    // What `identify` asks of the rows for this measure (an orientation in every row, pairs,
    // ...): a measure the file cannot give is refused, not reported as empty columns.
    robocal::identify::problem::Observations::new(&set, m, Default::default())?;
    if matches!(m, Measure::Relative | Measure::Distance) {
        warnings.say_some(robocal::data::pairs::broken_pairs_warning(&set));
    }
    // Positions in metres or inches, refused as `identify` refuses them.
    if matches!(m, Measure::Pose | Measure::Position) {
        robocal::identify::register::check_position_scale(&robot, &set)?;
    }
    if a.check_against.is_some() && !matches!(m, Measure::Pose | Measure::Position) {
        usage!(
            "--check-against compares the readings of single rows (measure pose or position), \
             not measure {}",
            m.name()
        );
    }
    let reference = match &a.check_against {
        Some(p) => {
            let (r, read) = a.read.read_noted(p, &joints)?;
            warnings.printed_too(read);
            // The file checked against is most often the training file (the README's).
            let held = (
                "data",
                "where that file trained the model or the compensator, ",
            );
            warnings.say_some(super::data_args::shared_rows_warning(
                &a.data, &set, p, &r, held,
            ));
            Some(r)
        }
        None => None,
    };
    let model_rows = row_errors(&set, m, |q| tool_pose(&robot, q))?;
    // A model calibrated without orientations (or positions) keeps its start values of the
    // parameters they did not observe: its errors there say nothing of its accuracy (a
    // reviewer's position-identified UR10 on pose rows: 90 deg mean orientation error, no
    // word).
    if matches!(m, Measure::Pose | Measure::Position | Measure::Orientation) {
        let mut unchecked = super::unchecked::UncheckedRows::new(&robot);
        let position = matches!(m, Measure::Pose | Measure::Position);
        let orientation = matches!(m, Measure::Pose | Measure::Orientation);
        for r in &set.rows {
            unchecked.add_measured(&robot, &r.q, r.line, position, orientation);
        }
        warnings.say_some(unchecked.warning(&a.data, &a.robot));
    }
    let s = summarize(&model_rows);
    say!(
        "evaluate: {} on {} ({} rows, measure {})",
        a.robot.display(),
        a.data.display(),
        set.rows.len(),
        m.name()
    );
    let mut inside = Vec::new();
    let net_rows = match &comp {
        Some(c) => {
            let mut ws = PredictWorkspace::default();
            inside = set
                .rows
                .iter()
                .map(|r| c.domain_check(&r.q, &mut ws).inside())
                .collect();
            Some(row_errors(&set, m, |q| c.predict(q, &mut ws))?)
        }
        None => None,
    };
    let outside: Vec<usize> = set
        .rows
        .iter()
        .zip(&inside)
        .filter(|(_, inside)| !**inside)
        .map(|(r, _)| r.line)
        .collect();
    let compensated = net_rows.as_deref().map(summarize);
    let mut accuracy = vec![Accuracy::new("data", "model", s)];
    let label = comp
        .as_ref()
        .map_or("+net", super::summary::compensated_label);
    if let Some(c) = compensated {
        accuracy.push(Accuracy {
            rows_outside_domain: Some(outside.len()),
            ..Accuracy::new("data", label, c)
        });
    }
    // Readings logged with other joints, judged under the robot file's model.
    let shared = shared_under(&robot, &set, m, reference.as_ref());
    accuracy.extend(clean_accuracy(
        CLEAN,
        &shared,
        &model_rows,
        net_rows.as_deref().map(|n| (n, &inside[..], label)),
    ));
    let mut report = EvaluateReport {
        robot: a.robot.display().to_string(),
        compensator: a.compensator.as_ref().map(|p| p.display().to_string()),
        data: a.data.display().to_string(),
        rows: set.rows.len(),
        measure: m,
        accuracy,
        lines_outside_domain: outside.clone(),
        note,
        repeats: Repeats::of(&robot, &set),
        shared_readings: shared,
        check_against: a.check_against.as_ref().map(|p| p.display().to_string()),
        worst_rows: worst_rows(&model_rows, net_rows.as_deref())?,
        warnings: Vec::new(),
    };
    super::summary::warn_copies(&set, &mut warnings);
    if let Some(r) = &report.repeats {
        print_repeats(r, &robot, &set, &mut warnings);
    }
    if let (Some(path), Some(r)) = (&a.check_against, &reference) {
        // Said whatever it found: a check that could not run is not a clean result.
        let (mine, theirs) = (rows_checked(&robot, &set), rows_checked(&robot, r));
        say!(
            "checked against {}: {mine} row(s) with a position and an orientation, against \
             themselves and {theirs} of its rows; {} carry another configuration's reading",
            path.display(),
            report.shared_readings.len()
        );
        if mine == 0 || theirs == 0 {
            warnings.say(format!(
                "--check-against {}: {} no row with both a position and an orientation, so no \
                 reading was compared with its rows",
                path.display(),
                if mine == 0 { "the data have" } else { "it has" }
            ));
        }
    }
    if !report.shared_readings.is_empty() {
        print_shared(
            "data",
            &report.shared_readings,
            &format!("'{CLEAN}' leaves them out"),
        );
    }
    print_stats(&report.accuracy, m);
    // Measures of single rows only: a pair's displacement or length does not see the frame.
    // With a compensator, said where the model it runs (refined or not) misses too.
    let single_rows = matches!(m, Measure::Pose | Measure::Position);
    // Where the compensator's own model is off the rows (misplaced, or in a moved frame),
    // their errors make the figures, not the network; where it misses some rows only, those
    // are left out of the comparison with the model alone.
    let mut embedded_off = false;
    let mut far = Vec::new();
    if single_rows {
        let file_name = a.robot.display().to_string();
        let file = misplaced_model_warning(&file_name, &robot, &set);
        // With a compensator, the model it runs (refined or not) is the one that counts.
        let embedded = comp
            .as_ref()
            .zip(a.compensator.as_ref())
            .and_then(|(c, path)| {
                let name = format!("the model embedded in {}", path.display());
                misplaced_model_warning(&name, &c.robot, &set)
            });
        embedded_off = embedded.as_ref().is_some_and(|(_, e)| e.is_the_model());
        far = super::summary::far_lines(embedded.as_ref().map(|e| &e.1));
        let said = match (&comp, file, embedded) {
            (None, file, _) => file.map(|f| f.0),
            (Some(_), _, None) => None,
            // Both off the rows: the robot file is the one to look at.
            (Some(_), Some((w, f)), Some((_, e))) if f.is_the_model() && e.is_the_model() => {
                Some(w)
            }
            // The robot file fits the rows, the compensator's own model does not: trained in
            // another frame (another tracker set-up) or with another tool. A reviewer's
            // compensator trained on Series B, evaluated on Series A rows: 3.5 m off, and only
            // the note that it runs its own model.
            (Some(_), _, Some((w, e))) if e.is_the_model() => Some(format!(
                "{w} (The compensator runs in series with its own model, not with {}: train it \
                 on rows in this frame.)",
                a.robot.display()
            )),
            // Rows the model the compensator runs misses: named as it misses them (the robot
            // file, another model, may miss others).
            (Some(_), _, Some((w, _))) => Some(w),
        };
        if let Some(w) = said {
            warnings.say(w);
        }
    }
    for row in report.accuracy.iter().filter(|r| r.data == "data") {
        let what = if row.model == "model" {
            "model"
        } else {
            "with the compensator"
        };
        if let Some(c) = row.stats.position_per_coordinate_mean_mm {
            say!("mean per-coordinate position error |dx|,|dy|,|dz| ({what}): {c:.4} mm");
        }
    }
    if let Some(w) = &report.worst_rows {
        print_worst("data", "the model", m, w);
    }
    let suspects: Vec<usize> = report.shared_readings.iter().map(|r| r.line).collect();
    if let Some(w) = (net_rows.as_deref())
        .filter(|_| !embedded_off)
        .and_then(|n| {
            let rows = (&model_rows[..], n);
            super::summary::worse_than_model_without(&a.data, rows, m, &suspects, &far)
        })
    {
        warnings.say(w);
    }
    if let Some(note) = &report.note {
        say!("{note}");
    }
    // With --check-against, the check's own warning says where it could not compare.
    if a.check_against.is_none()
        && let Some(n) = super::summary::unchecked_readings_note(&robot, &set, m)
    {
        say!("note: {n}");
    }
    warnings.say_some(outside_warning(
        &a.data,
        &outside,
        false,
        comp.as_ref().is_some_and(|c| c.has_network()),
    ));
    report.warnings = warnings.into_vec();
    if let Some(dir) = &a.plot {
        robocal::plot::forget_earlier(dir, "evaluate")?;
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
        told_after!("plots: {} pictures in {}", figs.len(), dir.display());
    }
    if let Some(path) = &a.report {
        write_report(path, &Report::Evaluate(report))?;
    }
    Ok(())
}
