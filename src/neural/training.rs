//! Training a compensator: what the options leave open is chosen by cross-validation
//! ([`super::tuning`]), then the chosen settings are fitted on every row ([`super::fit`]; an
//! RBF network's units on at most [`super::train::TrainOptions::rbf_units`] of them).

use super::compensator::Compensator;
use super::fit::CompensatorReport;
use super::repeats::configuration_groups;
use super::settings::CompensatorOptions;
use super::train::{RbfHyper, TrainOptions};
use super::tuning::{FIT_WORK, budget_epochs, outlier_note, select_settings};
use crate::data::MeasurementSet;
use crate::data::measurement::{row_name, subset};
use crate::data::shared_readings::{SharedReading, shared_readings, suspect_rows};
use crate::error::Result;
use crate::identify::register::check_position_scale;
use crate::model::Robot;

/// The share of the training rows beyond the outlier cut above which a note says the
/// held-out errors are heavy-tailed.
pub const OUTLIER_SHARE: f64 = 0.05;

/// How many times cross-validation's RMS the final compensator may miss its own training rows
/// by before a warning says the rows left out fell outside its domain.
pub const FADED_MISS: f64 = 2.0;

/// Position RMS (mm) of compensator `c` on the rows of `set` with a position.
fn position_rms(c: &Compensator, set: &MeasurementSet) -> Result<f64> {
    let mut ws = Default::default();
    let rows = crate::evaluate::row_errors(set, crate::identify::Measure::Position, |q| {
        c.predict(q, &mut ws)
    })?;
    Ok(crate::evaluate::summarize(&rows)
        .position_mm
        .map_or(0.0, |p| p.rms))
}

impl Compensator {
    /// Trains a compensator for `robot` on the measured rows of `set`: the choices `opts`
    /// leaves open are made by cross-validation on `set` (`progress` is told (done, total)
    /// trainings), then the chosen settings are fitted on every row. Unless
    /// `opts.drop_outliers` is false, rows that carry another configuration's reading
    /// ([`crate::data::shared_readings`], under `robot`) take part in neither, and the rows
    /// cross-validation lists as outliers are left out of the final fit; the report names
    /// both by their index in `set`. Positions whose spread differs from the model's by a
    /// unit's factor (metres, inches) are refused ([`check_position_scale`]).
    pub fn train(
        robot: &Robot,
        set: &MeasurementSet,
        opts: &CompensatorOptions,
        progress: &(dyn Fn(usize, usize) + Sync),
    ) -> Result<(Compensator, CompensatorReport)> {
        let started = std::time::Instant::now();
        // Positions in metres or inches, refused as `identify` and `evaluate` refuse them: a
        // network would learn the factor, and its file would write metres as mm.
        check_position_scale(robot, set)?;
        // A row that carries another configuration's reading is no measurement of its own
        // joints: it scores no candidate and trains no network (unless outliers are kept).
        let shared = shared_readings(robot, set);
        let suspects = suspect_rows(&shared);
        let drop_shared = opts.drop_outliers && !suspects.is_empty();
        let trains = |i: &usize| !drop_shared || suspects.binary_search(i).is_err();
        // The index in `set` of each row that trains.
        let index: Vec<usize> = (0..set.rows.len()).filter(trains).collect();
        let read;
        let set = if drop_shared {
            read = subset(set, |i| trains(&i));
            &read
        } else {
            set
        };
        let (settings, mut selection, untested) = select_settings(robot, set, opts, progress)?;
        let selection_seconds = started.elapsed().as_secs_f64();
        // Rows cross-validation listed as outliers stay out of the final fit when asked.
        let left_out: Vec<usize> = match &selection {
            Some(s) if opts.drop_outliers => s.outliers.iter().map(|o| o.row).collect(),
            _ => Vec::new(),
        };
        let kept;
        let fit_set = if left_out.is_empty() {
            set
        } else {
            let out: std::collections::HashSet<usize> = left_out.iter().copied().collect();
            kept = subset(set, |i| !out.contains(&i));
            &kept
        };
        // The RBF hyperparameters cross-validation judged, searched on these rows for the
        // model as given. Where rows are left out, the final fit searches again from them on
        // the rows their search drew but those: a mis-measured row pulls the likelihood
        // toward more noise or narrower widths. Over 28 Series B runs (seven splits, training
        // seeds 1-4) that lowered the held-out RMS in 21 of the 22 runs without refinement
        // (by up to 9.4 %; +0.4 % in the other) and the mean of all 28 by 1.6 %, for 0.2 s
        // of the 7 s on Series A's pool of 2000 (a warm search on at most 500 rows). A refined
        // model's residual is searched again from the start, on the same rows: the model as
        // given's hyperparameters on it were worse in 6 runs of 6, by 4-25 %
        // (cross-validation judges a refinement with them, see `Cv::hyper`).
        let judged = selection
            .as_ref()
            .and_then(|s| s.rbf_hyper.clone())
            .filter(|_| settings.refine.is_none());
        let rbf_hyper = match judged {
            None => RbfHyper::Search,
            Some(h) if left_out.is_empty() => RbfHyper::Given(h),
            Some(h) => RbfHyper::From(h),
        };
        let train = TrainOptions {
            max_epochs: if opts.budget {
                budget_epochs(FIT_WORK, set.rows.len(), 50, 60)
            } else {
                opts.train.max_epochs
            },
            rbf_hyper,
            // Cross-validation's search drew one row per configuration of `set` (its samples'
            // groups are these): the final fit's search draws the same rows, but those left out.
            rbf_whole_groups: if left_out.is_empty() {
                Vec::new()
            } else {
                configuration_groups(robot, set)
            },
            rbf_left_out: left_out,
            ..opts.train.clone()
        };
        let (c, mut report) = Compensator::fit(robot, fit_set, &settings, opts.sigmas, &train)?;
        // Rows left out may lie outside the training domain, where the correction fades: on
        // them the compensator is the model. Where that leaves it missing its own training
        // rows by more than twice cross-validation's RMS, the user is told (a reviewer's 150
        // Series B rows under the nominal UR10, 3.7 m off the tracker's frame: 29 rows left
        // out, 898 mm RMS on the training rows against a cross-validated 5.19 mm).
        if !train.rbf_left_out.is_empty()
            && let Some(s) = &mut selection
            && let Some(cv) = (s.candidates[s.chosen].score.as_ref()).map(|x| x.position_rms_mm)
        {
            let rms = position_rms(&c, set)?;
            if rms > FADED_MISS * cv {
                s.warnings.push(format!(
                    "the compensator misses its training rows by {rms:.4} mm RMS, more than \
                     {FADED_MISS} times the cross-validated {cv:.4} mm: the {} row(s) left out \
                     of the final fit lie outside its training domain, where its correction \
                     fades to the model's (--keep-outliers keeps them in the fit)",
                    train.rbf_left_out.len()
                ));
            }
        }
        if !shared.is_empty() {
            report.notes.push(shared_note(&shared, drop_shared));
        }
        report.notes.extend(untested);
        if let Some(s) = &mut selection {
            // Outliers were found among the rows that trained; name them in the rows given.
            for o in &mut s.outliers {
                o.row = index[o.row];
            }
            s.outliers_left_out = !train.rbf_left_out.is_empty();
            if !s.outliers.is_empty() {
                s.notes
                    .push(outlier_note(&s.outliers, s.outlier_k, s.outliers_left_out));
            }
            // Mis-measured rows are rare; many rows far out are a heavy tail of the held-out
            // error (one gross row bends its neighbours' predictions too, so a few more rows
            // than the bad ones are flagged; the note does not change the fit).
            let share = s.outliers.len() as f64 / set.rows.len() as f64;
            if share > OUTLIER_SHARE {
                s.notes.push(format!(
                    "the rows beyond {} robust sigmas are {:.1} % of the training rows, more \
                     than mis-measured rows usually are: the held-out errors are heavy-tailed \
                     (a model far from its data, a network unsuited to it, or a gross error \
                     that bends its neighbours' predictions); check the rows, the model and the \
                     settings",
                    s.outlier_k,
                    100.0 * share
                ));
            }
            report.notes.extend(s.notes.iter().cloned());
        }
        // One configuration measured again and again gives the network one input: it can
        // learn a constant only, whatever it is told.
        if report
            .repeats
            .as_ref()
            .is_some_and(|r| r.configurations == 1 && r.rows == fit_set.rows.len())
        {
            report.notes.push(format!(
                "the {} training rows are one configuration: the network can learn only a \
                 constant correction; measure configurations spread over the workspace",
                fit_set.rows.len()
            ));
        }
        report.selection = selection;
        report.selection_seconds = selection_seconds;
        report.shared_readings = shared;
        Ok((c, report))
    }
}

/// The note on training rows that carry another configuration's reading.
fn shared_note(shared: &[SharedReading], dropped: bool) -> String {
    let list: Vec<String> = shared
        .iter()
        .map(|s| {
            format!(
                "{} that of {}",
                row_name(s.line, s.row),
                row_name(s.other_line, s.other_row)
            )
        })
        .collect();
    format!(
        "{} training row(s) carry the reading of another configuration ({}): {}",
        shared.len(),
        list.join(", "),
        if dropped {
            "left out of cross-validation and the fit"
        } else {
            "kept as asked"
        }
    )
}
