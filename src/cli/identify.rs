//! `robocal identify`.

use super::choices::{Measure, Method, RobustLoss};
use super::data_args::{DataArgs, FitInputs, SigmaArgs, open_fit};
use super::summary::{print_stats, write_report};
use anyhow::Result;
use clap::Args;
use robocal::data::MeasurementSet;
use robocal::evaluate::{ErrorStats, RowError, row_errors, summarize, worst_rows};
use robocal::identify::register::check_position_scale;
use robocal::identify::{Measure as Measured, Options, SolveOptions, identify};
use robocal::kinematics::tool_pose;
use robocal::model::write_robot;
use robocal::plot::{ErrorRun, error_figures};
use robocal::reports::identify::IdentifyFiles;
use robocal::reports::{Accuracy, IdentifyReport, Report};
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
    /// Parameters: offsets | full | base | tool | joints | compliance | names, comma-separated
    /// (`compliance`: the joint compliances c1..cN where the robot file gives masses,
    /// else the mass-free coefficients k<joint>.<part><link>, e.g. k2.mx3).
    #[arg(long, default_value = "full")]
    params: String,
    /// How to compare measurements (default: what the data hold: pose with positions and
    /// orientations, position or orientation with one of them, distance with neither).
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
    /// Rows beyond this many robust sigmas are reported as outliers (1 to 1e6, or inf for
    /// none).
    #[arg(long, allow_negative_numbers = true, default_value_t = 3.0, value_parser = super::bounds::outlier_k)]
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
    let FitInputs {
        robot: nominal,
        data: cal,
        validation: val,
        mut read_warnings,
    } = open_fit(
        &a.robot,
        &a.data,
        a.validate.as_ref(),
        &a.read,
        &a.out,
        a.report.as_ref(),
        a.plot.as_ref(),
    )?;
    // A selection that names no parameter of this robot is a flag's value refused.
    if let Err(e) = robocal::identify::candidates(&nominal, &a.params) {
        usage!("--params `{}`: {e}", a.params);
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
    // The validation rows in metres or inches, refused (before the solve) as the calibration
    // rows are.
    let measure = opts.measure.unwrap_or_else(|| Measured::default_for(&cal));
    if matches!(measure, Measured::Relative | Measured::Distance) {
        for set in std::iter::once(&cal).chain(&val) {
            if let Some(w) = robocal::data::pairs::broken_pairs_warning(set) {
                eprintln!("warning: {w}");
                read_warnings.push(w);
            }
        }
    }
    if let (Some(v), Measured::Pose | Measured::Position) = (&val, measure) {
        check_position_scale(&nominal, v)?;
    }
    // A solve's failure names no file (the input errors name theirs).
    let id = identify(&nominal, &cal, &opts).map_err(|e| match e {
        robocal::error::Error::NotConverged(_) => {
            anyhow::Error::new(e).context(format!("identifying from {}", a.data.display()))
        }
        e => e.into(),
    })?;
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
    let mut accuracy = vec![
        Accuracy::new("calibration", "before", cal_before),
        Accuracy::new("calibration", "after", cal_after),
    ];
    let mut worse = None;
    if let Some((b, af)) = val_stats {
        worse = worse_on_validation(&b, &af).or_else(|| worse_than_calibration(&cal_after, &af));
        accuracy.push(Accuracy::new("validation", "before", b));
        accuracy.push(Accuracy::new("validation", "after", af));
    }
    let mut report = IdentifyReport::new(
        &id,
        &opts,
        IdentifyFiles {
            robot: a.robot.display().to_string(),
            data: a.data.display().to_string(),
            validation: a.validate.as_ref().map(|p| p.display().to_string()),
            output: a.out.display().to_string(),
        },
        cal.rows.len(),
        accuracy,
    );
    // Readings logged with other joints, judged under the identified model.
    report.shared_readings = super::summary::shared_under(&id.robot, &cal, m, None);
    if let Some((_, after)) = &val_rows {
        report.validation_worst_rows = worst_rows(after, None)?;
    }
    report.warnings.extend(worse);
    report.notes.extend(a.sigma.unused(&cal));
    report
        .notes
        .extend(super::summary::unchecked_readings_note(&id.robot, &cal, m));
    print_identified(&report);
    print_stats(&report.accuracy, report.measure);
    if let Some(w) = &report.validation_worst_rows {
        super::summary::print_worst("validation", "the identified model", m, w);
    }
    for n in &report.notes {
        say!("note: {n}");
    }
    for w in &report.warnings {
        eprintln!("warning: {w}");
    }
    // Printed when the files were read; in the report with the rest.
    report.warnings.splice(0..0, read_warnings);
    told_after!("wrote {}", a.out.display());
    if let Some(dir) = &a.plot {
        robocal::plot::forget_earlier(dir, "identify")?;
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
        told_after!("plots: {figs} pictures in {}", dir.display());
    }
    if let Some(path) = &a.report {
        write_report(path, &Report::Identify(report))?;
    }
    Ok(())
}

/// How much worse (RMS, above which) the identified model may be than the nominal on the
/// validation rows before it is flagged, and by at least 0.05 mm (0.005 deg): noise and the
/// fit's own spread (about sqrt(1 + n/m)) move a near-perfect nominal's figure a little.
const WORSE_ON_VALIDATION: f64 = 1.1;

/// The warning for an identified model that misses the validation rows by more than
/// [`WORSE_ON_VALIDATION`] times the nominal's RMS (position, else orientation).
fn worse_on_validation(before: &ErrorStats, after: &ErrorStats) -> Option<String> {
    let (b, a, unit, what) = match (before.position_mm, after.position_mm) {
        (Some(b), Some(a)) => (b.rms, a.rms, "mm", "position"),
        _ => {
            let (b, a) = (before.orientation_deg?, after.orientation_deg?);
            (b.rms, a.rms, "deg", "orientation")
        }
    };
    let floor = if unit == "mm" { 0.05 } else { 0.005 };
    (a > WORSE_ON_VALIDATION * b && a - b > floor).then(|| {
        format!(
            "the identified model misses the validation rows by more than the nominal one \
             ({what} RMS {b:.4} -> {a:.4} {unit}): it does not generalise beyond its \
             calibration rows; check those rows (outliers, joints beyond the limits) and the \
             selected parameters"
        )
    })
}

/// How many times its calibration rows' RMS the identified model may miss the validation
/// rows by before it is flagged, and by at least 0.5 mm (0.05 deg) more: a model fitted to
/// rows that cannot tell its parameters apart (30 neighbouring poses for `full`) fits them
/// and misses the rest by centimetres. Needed beside [`WORSE_ON_VALIDATION`], whose nominal
/// misses by metres where the rows are in a tracker's frame.
const WORSE_THAN_CALIBRATION: f64 = 5.0;

/// The warning for an identified model that misses the validation rows by more than
/// [`WORSE_THAN_CALIBRATION`] times its calibration RMS (position, else orientation).
fn worse_than_calibration(cal: &ErrorStats, val: &ErrorStats) -> Option<String> {
    let (c, v, unit, what, floor) = match (cal.position_mm, val.position_mm) {
        (Some(c), Some(v)) => (c.rms, v.rms, "mm", "position", 0.5),
        _ => {
            let (c, v) = (cal.orientation_deg?, val.orientation_deg?);
            (c.rms, v.rms, "deg", "orientation", 0.05)
        }
    };
    (v > WORSE_THAN_CALIBRATION * c && v - c > floor).then(|| {
        format!(
            "the identified model misses the validation rows by {v:.4} {unit} {what} RMS, \
             {:.0} times its calibration rows' {c:.4}: it does not generalise beyond them; \
             they are too few or too close together to tell the selected parameters apart \
             (see the nearly aliased pairs and the condition number), or they differ from \
             the validation rows (another tool, frame or load): spread the calibration \
             rows over the workspace, or select fewer parameters",
            v / c.max(f64::MIN_POSITIVE)
        )
    })
}

fn print_identified(r: &IdentifyReport) {
    say!(
        "identify: {} rows of {}, measure {}, method {:?}, parameters `{}`",
        r.rows,
        r.data,
        r.measure.name(),
        r.method,
        r.params
    );
    if let Some(rms) = r.registration_rms_mm {
        say!(
            "registration of the base{}: RMS {rms:.4} mm",
            if r.registration_tool { " and tool" } else { "" },
        );
    }
    say!(
        "identifiability: {} candidates, rank {} (SVD) / {} (pivoted QR), condition number {:.4e} \
         (column-scaled); identifiable set: {} parameters, condition number {:.4e}",
        r.candidates,
        r.rank,
        r.rank_pivoted_qr,
        r.condition_number_all_candidates,
        r.identifiable,
        r.condition_number
    );
    for d in &r.dropped {
        let why = if d.reason == "no effect" {
            "no effect on these measurements".to_string()
        } else if let Some(t) = d.estimate_over_std {
            match d.held_at {
                Some(v) if v != 0.0 => format!(
                    "not significant (estimate {t:+.2} std from its start), held at its start \
                     value {v} {}",
                    d.unit
                ),
                _ => format!("not significant (estimate {t:+.2} std), held at zero"),
            }
        } else {
            format!(
                "regroups with {}",
                d.regroups_with
                    .iter()
                    .map(|g| {
                        // A unit only where it is not one per one (mm per mm).
                        let same = g.unit.split_once(" per ").is_some_and(|(a, b)| a == b);
                        if same {
                            format!("{:+.4} {}", g.coefficient, g.name)
                        } else {
                            format!("{:+.4} {} ({})", g.coefficient, g.name, g.unit)
                        }
                    })
                    .collect::<Vec<_>>()
                    .join(" ")
            )
        };
        say!("  left out {:<12} {why}", d.name);
    }
    say!(
        "solution: {}; variance factor s^2 = {:.4}",
        solve_work(r),
        r.variance_factor
    );
    if let Some(note) = r.unmodelled.note("the rows") {
        say!("weights: {note}");
    }
    let w = super::summary::unit_width(r.parameters.iter().map(|p| p.unit.as_str()));
    say!(
        "{:<12} {:<w$} {:>14} {:>14} {:>12}",
        "parameter",
        "unit",
        "nominal",
        "estimate",
        "std"
    );
    for p in &r.parameters {
        say!(
            "{:<12} {:<w$} {:>14.6} {:>14.6} {:>12.6}",
            p.name,
            p.unit,
            p.nominal,
            p.estimate,
            p.std
        );
    }
    if !r.correlations.is_empty() {
        let list: Vec<String> = r
            .correlations
            .iter()
            .map(|c| format!("{}/{} {:+.3}", c.a, c.b, c.correlation))
            .collect();
        say!("correlated (|r| > 0.9): {}", list.join(", "));
    }
    if r.outliers.is_empty() {
        say!("outliers (> {} robust sigmas): none", r.outlier_k);
    } else {
        let lines: Vec<String> = r
            .outliers
            .iter()
            .map(|o| format!("line {} ({:.1})", o.line, o.robust_sigmas))
            .collect();
        say!(
            "outliers (> {} robust sigmas): {}",
            r.outlier_k,
            lines.join(", ")
        );
    }
    if !r.shared_readings.is_empty() {
        super::summary::print_shared(
            "calibration",
            &r.shared_readings,
            "kept in the fit, as outliers are",
        );
    }
}

/// How the solution was reached, in words: the last solve's iterations and stop, and where
/// there were more solves (robust reweighting rounds, solves again with the unmodelled error
/// in the sigmas or without an insignificant parameter), how many and their iterations.
fn solve_work(r: &IdentifyReport) -> String {
    let plural = |n: usize| if n == 1 { "" } else { "s" };
    let last = format!(
        "{} iteration{}, {}",
        r.iterations,
        plural(r.iterations),
        r.stop
    );
    if r.solves <= 1 {
        return last;
    }
    let rounds = match r.robust_rounds {
        0 => String::new(),
        1 => ", 1 of them a robust reweighting round".into(),
        k => format!(", {k} of them robust reweighting rounds"),
    };
    format!(
        "{} solves{rounds}, {} iterations in all; the last: {last}",
        r.solves, r.total_iterations
    )
}
