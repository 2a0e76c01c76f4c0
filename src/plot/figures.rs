//! The pictures the commands draw, from their results.

use super::charts::{ErrorSeries, Histograms, Scatter, Series, TrainingCurve};
use super::{Figure, save};
use crate::data::MeasurementSet;
use crate::error::Result;
use crate::evaluate::RowError;
use crate::neural::train::{Phase2, TrainReport};
use std::path::Path;

/// The errors of several predictors on one set, each named (e.g. "nominal", "identified").
pub struct ErrorRun<'a> {
    /// The predictor's name, used in legends and panel titles.
    pub label: &'a str,
    /// Its error on every row (or pair) of the set, in row order.
    pub errors: &'a [RowError],
}

/// One series per run of the values `get` finds, each at its row's line in the data file; rows
/// without a (finite) value are left out, not shifted.
fn series(runs: &[ErrorRun], get: impl Fn(&RowError) -> Option<f64>) -> Vec<Series> {
    runs.iter()
        .map(|r| {
            let (rows, values) = r
                .errors
                .iter()
                .filter_map(|e| get(e).filter(|v| v.is_finite()).map(|v| (e.line, v)))
                .unzip();
            Series {
                label: r.label.to_string(),
                rows,
                values,
            }
        })
        .filter(|s| !s.values.is_empty())
        .collect()
}

/// Per-measurement position and orientation errors of every run, their histograms, and the
/// set's measured tool positions coloured by the last run's position error. Files are named
/// `{prefix}_position`, `{prefix}_orientation`, `{prefix}_histogram`, `{prefix}_scatter`;
/// `what` names the data in titles (e.g. "calibration data").
pub fn error_figures(
    dir: &Path,
    prefix: &str,
    what: &str,
    set: &MeasurementSet,
    runs: &[ErrorRun],
) -> Result<Vec<Figure>> {
    let mut figs = Vec::new();
    let names = runs.iter().map(|r| r.label).collect::<Vec<_>>().join(", ");
    // Relative and distance data give one error per pair of rows, the error of the
    // displacement's length (they were titled position errors per measurement).
    let pairs = runs
        .first()
        .is_some_and(|r| r.errors.len() != set.rows.len());
    let (kind, per, x_label) = if pairs {
        (
            "Length error",
            "pair",
            "line of the pair's second row in the data file",
        )
    } else {
        ("Position error", "measurement", "line in the data file")
    };
    let lower = kind.to_lowercase();
    let pos = series(runs, |e| e.position_mm);
    if !pos.is_empty() {
        figs.push(save(
            dir,
            &format!("{prefix}_position"),
            &format!("{kind} per {per}, {what}"),
            &format!(
                "{} (mm) of every {per} of {what} ({}): {names}.",
                if pairs {
                    "Error of the displacement's length"
                } else {
                    "Euclidean position error"
                },
                set.source.display()
            ),
            &ErrorSeries {
                title: format!("{kind} per {per}, {what}"),
                y_label: format!("{lower} (mm)"),
                x_label: x_label.into(),
                unit: "mm".into(),
                series: pos.clone(),
            },
        )?);
        figs.push(save(
            dir,
            &format!("{prefix}_histogram"),
            &format!("{kind} histograms, {what}"),
            &format!("How the {lower}s (mm) of {what} are distributed: {names}."),
            &Histograms {
                title: format!("{kind} histograms, {what}"),
                x_label: format!("{lower} (mm)"),
                unit: "mm".into(),
                series: pos,
            },
        )?);
    }
    // Orientation errors come of single rows only: their x is the line, as `x_label` says.
    let rot = series(runs, |e| e.orientation_deg);
    if !rot.is_empty() {
        figs.push(save(
            dir,
            &format!("{prefix}_orientation"),
            &format!("Orientation error per measurement, {what}"),
            &format!(
                "Angle (deg) between the measured and predicted tool orientations, {what}: \
                 {names}."
            ),
            &ErrorSeries {
                title: format!("Orientation error per measurement, {what}"),
                y_label: "orientation error (deg)".into(),
                x_label: x_label.into(),
                unit: "deg".into(),
                series: rot,
            },
        )?);
    }
    // The scatter needs one error per measured position.
    if let Some(last) = runs.last()
        && last.errors.len() == set.rows.len()
    {
        let (points, errors): (Vec<[f64; 3]>, Vec<f64>) = set
            .rows
            .iter()
            .zip(last.errors)
            .filter_map(|(m, e)| {
                let p = m.position?;
                let v = e.position_mm.filter(|v| v.is_finite())?;
                Some(([p.x, p.y, p.z], v))
            })
            .unzip();
        if !points.is_empty() {
            figs.push(save(
                dir,
                &format!("{prefix}_scatter"),
                &format!("Tool positions by position error, {what}"),
                &format!(
                    "Measured tool positions (mm) of {what} from above and from the side, \
                     coloured by the position error (mm) of {}.",
                    last.label
                ),
                &Scatter {
                    title: format!("Tool positions by position error, {what}"),
                    points,
                    errors,
                    label: format!("position error (mm), {}", last.label),
                },
            )?);
        }
    }
    Ok(figs)
}

/// What phase 2's steps are called: epochs of Levenberg-Marquardt, iterations of L-BFGS.
fn phase2_steps(phase2: Phase2) -> &'static str {
    match phase2 {
        Phase2::Lbfgs => "L-BFGS iterations",
        _ => "Levenberg-Marquardt epochs",
    }
}

/// The training curve of a compensator's first network: `{prefix}_training`.
pub fn training_figure(
    dir: &Path,
    prefix: &str,
    what: &str,
    report: &TrainReport,
) -> Result<Figure> {
    save(
        dir,
        &format!("{prefix}_training"),
        &format!("Training curve, {what}"),
        &format!(
            "Mean squared error of the normalised network outputs by epoch, {what} (its first \
             network): {} SGD momentum epochs, then {} {}; stopped: {}. {}",
            report.momentum_epochs,
            report.lm_epochs,
            phase2_steps(report.phase2),
            report.stop.describe(),
            if report.validation_mse.is_some() {
                "Beside the training rows', the held-out part's."
            } else {
                "Beside it, the penalised objective (MSE plus the L2 penalty) the best weights \
                 are chosen by: no rows were held out (--validation-fraction 0)."
            }
        ),
        &TrainingCurve {
            title: format!("Training curve, {what}"),
            curve: report.curve.clone(),
            held_out: report.validation_mse.is_some(),
            momentum_epochs: report.momentum_epochs,
            phase2: report.phase2,
        },
    )
}
