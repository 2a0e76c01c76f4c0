//! `robocal train` and `robocal predict`: the neural compensator.

use super::compensator_args::{CompensatorArgs, compliance_conflict, progress_bar};
use super::data_args::{DataArgs, SigmaArgs};
use super::summary::{clean_accuracy, print_shared, print_stats, shared_under, write_report};
use anyhow::{Context, Result};
use clap::Args;
use robocal::data::measurement::subset;
use robocal::evaluate::{misplaced_model_warning, row_errors, summarize, worst_rows};
use robocal::identify::Measure;
use robocal::kinematics::tool_pose;
use robocal::neural::compensator::{Compensator, Network, Refine};
use robocal::neural::predict::PredictWorkspace;
use robocal::neural::repeats::{configuration_groups, group_count};
use robocal::neural::train::Phase2;
use robocal::neural::tuning::RACE_FOLDS;
use robocal::neural::tuning::{Score, Selection, names_compliance};
use robocal::plot::{ErrorRun, error_figures, training_figure};
use robocal::reports::{Accuracy, Report, TrainReport};
use std::io::IsTerminal;
use std::path::PathBuf;

#[derive(Args)]
pub struct TrainArgs {
    /// The model the network runs in series with (nominal or identified robot file).
    #[arg(long)]
    robot: PathBuf,
    /// Training measurements (full pose or position).
    #[arg(long)]
    data: PathBuf,
    /// Measurements to report the compensator on (e.g. a simulated set's truth file); their
    /// readings are checked against themselves and the training rows' for readings logged with
    /// other joints (`validation clean` leaves those rows out).
    #[arg(long)]
    validate: Option<PathBuf>,
    #[command(flatten)]
    read: DataArgs,
    #[command(flatten)]
    pub(super) build: CompensatorArgs,
    /// Tracker sigmas for rows without their own (refinement).
    #[command(flatten)]
    sigma: SigmaArgs,
    /// Compensator file to write (JSON).
    #[arg(long)]
    out: PathBuf,
    /// JSON report: cross-validation, training curves, refined parameters, statistics.
    #[arg(long)]
    report: Option<PathBuf>,
    /// Folder for pictures (PNG and SVG, listed in figures.json for `robocal report`).
    #[arg(long)]
    plot: Option<PathBuf>,
}

/// Prints the cross-validation table.
fn print_selection(sel: &Selection) {
    say!(
        "cross-validation ({} folds of whole configurations; RMS over every held-out row):",
        sel.folds
    );
    // The refine column fits its longest entry (`full,compliance`).
    let w = sel
        .candidates
        .iter()
        .filter_map(|c| c.settings.refine.as_ref().map(|r| r.len()))
        .fold(10, usize::max);
    say!(
        "  {:>5} {:<7} {:<5} {:<7} {:>6} {:>7} {:>7} {:>5} {:<w$} {:>11} {:>15}",
        "stage",
        "network",
        "form",
        "inputs",
        "hidden",
        "penalty",
        "members",
        "share",
        "refine",
        "position mm",
        "orientation deg"
    );
    let rot = |s: &Score| {
        s.orientation_rms_deg
            .map_or("-".into(), |r| format!("{r:.4}"))
    };
    say!(
        "  {:>5} {:<m$} {:>11.4} {:>15}",
        "-",
        "model alone",
        sel.model.position_rms_mm,
        rot(&sel.model),
        m = 59 + w - 10
    );
    for (i, c) in sel.candidates.iter().enumerate() {
        let s = &c.settings;
        let score = match (&c.score, &c.pruned) {
            (Some(x), _) => format!("{:>11.4} {:>15}", x.position_rms_mm, rot(x)),
            (None, Some(x)) if c.proxy => format!(
                "{:>11.4} {:>15}  proxy on {} folds (refinement for the blend)",
                x.position_rms_mm,
                rot(x),
                RACE_FOLDS
            ),
            (None, Some(x)) => format!(
                "{:>11.4} {:>15}  dropped after {} folds",
                x.position_rms_mm,
                rot(x),
                RACE_FOLDS
            ),
            (None, None) => "failed".to_string(),
        };
        let network = s.network_label();
        // The model alone (no members) trains no MLP: its size and penalty are the best
        // MLPs' it was held against, not its own.
        let mlp = s.has_mlp();
        let dash = |show: bool, v: String| if show { v } else { "-".into() };
        // The MLPs' share of a blend (chosen by cross-validation unless fixed).
        let share = match (s.network, s.mlp_share) {
            (Network::Mix, Some(x)) => x.to_string(),
            _ => "-".into(),
        };
        say!(
            "{} {:>5} {:<7} {:<5} {:<7} {:>6} {:>7} {:>7} {:>5} {:<w$} {score}",
            if i == sel.chosen { "*" } else { " " },
            c.stage,
            network,
            dash(s.has_network(), s.form.name().into()),
            dash(s.has_network(), s.encoding.name().into()),
            dash(mlp, s.hidden.to_string()),
            dash(mlp, s.penalty.to_string()),
            dash(s.network != Network::Rbf, s.members.to_string()),
            share,
            s.refine.as_deref().unwrap_or("-"),
        );
        if let Some(e) = &c.error {
            say!("        {e}");
        }
    }
    // Said where the figures are read: the RBF rows' hyperparameters saw the rows each fold
    // holds out (one search for every fold, for speed), which the MLP rows' fits never do.
    if sel.candidates.iter().any(|c| c.settings.has_rbf()) {
        say!(
            "  (rbf and mix rows: their RBF hyperparameters were searched once on all training \
             rows, each fold's held-out rows among them, which can flatter them; a chosen one \
             is tested again on rows no search saw, in the notes)"
        );
    }
}

/// Which of `rows` training rows (of `configurations` arm configurations) the RBF search saw,
/// in blocks of `sizes`: "all rows", "N of the rows" (with "one per configuration" where some
/// configuration has several), and the blocks when there are more than one; with the
/// `outliers` the final fit left out, said to be left out of those.
fn searched_rows(rows: usize, configurations: usize, sizes: &[usize], outliers: usize) -> String {
    let searched: usize = sizes.iter().sum();
    let which = if searched >= rows {
        "all rows".to_string()
    } else if configurations < rows {
        format!("{searched} of the rows, one per arm configuration")
    } else {
        format!("{searched} of the rows")
    };
    let blocks = if sizes.len() < 2 {
        String::new()
    } else {
        let each: Vec<String> = sizes.iter().map(usize::to_string).collect();
        format!(
            ", in {} blocks of {} (their likelihoods added)",
            sizes.len(),
            each.join(" + ")
        )
    };
    let left = match outliers {
        0 => String::new(),
        n => format!(", less the outliers among them ({n} left out of the final fit)"),
    };
    format!("{which}{blocks}{left}")
}

/// Prints the refined parameters, the RBF network and the MLPs of a finished training on
/// the training rows `searched` (those cross-validation saw), the RBF search's drawn from
/// them by `draw` (one per configuration), of which the final fit left `outliers` out.
fn print_fit(
    c: &Compensator,
    report: &robocal::neural::fit::CompensatorReport,
    seconds: f64,
    (searched, draw, outliers): (
        &robocal::data::MeasurementSet,
        robocal::neural::rbf::Draw,
        usize,
    ),
) {
    let rows = searched.rows.len();
    let groups = configuration_groups(&c.robot, searched);
    let configurations = group_count(&groups);
    if !report.refined.is_empty() {
        say!(
            "refined on the training rows (exact identification, {} parameters):",
            report.refined.len()
        );
        let w = super::summary::unit_width(report.refined.iter().map(|p| p.unit.as_str()));
        for p in &report.refined {
            say!(
                "  {:<12} {:<w$} {:>14.6} -> {:>14.6}  (std {:.6})",
                p.name,
                p.unit,
                p.before,
                p.after,
                p.std
            );
        }
    }
    let n = &report.networks;
    let timing = format!(
        "{seconds:.1} s ({:.1} s cross-validation, {:.1} s final fit)",
        report.selection_seconds, report.fit_seconds
    );
    if let Some(r) = &c.rbf {
        say!(
            "rbf network: {} units ({} inputs){}, one Gaussian process per output ({} \
             covariance), its hyperparameters searched on {}{}",
            r.units(),
            c.encoding.name(),
            // At most `--rbf-units`: on a larger set, centred on a choice of the rows.
            match report.rbf_centred_on {
                Some(fitted) if configurations < rows => format!(
                    " centred on a seeded choice of the final fit's {fitted} rows, one per \
                     arm configuration first (at most --rbf-units)"
                ),
                Some(fitted) => format!(
                    " centred on a seeded choice of the final fit's {fitted} rows (at most \
                     --rbf-units)"
                ),
                None => String::new(),
            },
            r.kernels.first().map_or("-", |k| k.covariance.name()),
            // The draw is of the rows cross-validation saw: the training rows but those left
            // out for carrying another configuration's reading, outliers included.
            searched_rows(
                rows,
                configurations,
                &draw.block_sizes_of(&groups),
                outliers
            ),
            if n.is_empty() {
                format!("; {timing}")
            } else {
                format!(
                    "; blended with the MLPs' mean (their share {})",
                    c.mlp_share
                )
            }
        );
        // Pose-form outputs: position (mm) then rotation (mrad), robot base frame.
        const NAMES: [&str; 6] = ["dx", "dy", "dz", "rx", "ry", "rz"];
        for (k, outs) in r.kernel_outputs() {
            let name = match outs.len() {
                1 => NAMES.get(outs.start).copied().unwrap_or("?").to_string(),
                _ => format!("outputs {}-{}", outs.start + 1, outs.end),
            };
            let widths: Vec<String> = k.widths.iter().map(|w| format!("{w:.3}")).collect();
            say!(
                "  {name}: noise variance {:.4} of signal {:.4}, widths {} (standardised inputs)",
                k.noise_variance,
                k.signal_variance,
                widths.join(" ")
            );
        }
    }
    if n.is_empty() {
        if c.rbf.is_none() {
            say!("networks: none, the compensator is the model alone; {timing}");
        }
    } else {
        let stops: std::collections::BTreeSet<&str> = n.iter().map(|r| r.stop.describe()).collect();
        let fewest = n.iter().map(|r| r.lm_epochs).min().unwrap_or(0);
        let most = n.iter().map(|r| r.lm_epochs).max().unwrap_or(0);
        let steps = if fewest == most {
            format!("{most}")
        } else {
            format!("{fewest}-{most}")
        };
        let phase2 = match n[0].phase2 {
            Phase2::Lbfgs => format!("L-BFGS ({steps} iterations)"),
            _ => format!("LM ({steps} epochs)"),
        };
        say!(
            "networks: {} x {}-{}-{} ({} inputs); phase 1 {} epochs, phase 2 {phase2} per \
             network; stopped: {}; {timing}",
            n.len(),
            c.inputs(),
            c.hidden(),
            c.outputs(),
            c.encoding.name(),
            n.iter().map(|r| r.momentum_epochs).max().unwrap_or(0),
            stops.into_iter().collect::<Vec<_>>().join(", "),
        );
    }
}

pub fn run_train(a: TrainArgs) -> Result<()> {
    let super::data_args::FitInputs {
        robot,
        data: set,
        validation: val,
        read_warnings,
    } = super::data_args::open_fit(
        &a.robot,
        &a.data,
        a.validate.as_ref(),
        &a.read,
        &a.out,
        a.report.as_ref(),
        a.plot.as_ref(),
    )?;
    // Rows in metres or inches, refused before the training (which refuses its own rows so
    // too) and before the model's misfit below, which a wrong unit would explain.
    for s in std::iter::once(&set).chain(&val) {
        robocal::identify::register::check_position_scale(&robot, s)?;
    }
    let mut warnings = super::warnings::Warnings::printed(read_warnings);
    // A model far off its rows is said before the training, not after it.
    if let Some((w, found)) = misplaced_model_warning(&a.robot.display().to_string(), &robot, &set)
    {
        warnings.say(if found.is_the_model() {
            format!(
                "{w} The compensator is trained and written as asked: its refinement may take up \
                 a frame or a tool, never another robot"
            )
        } else {
            // A reviewer's rows, 40 % of them moved 500 mm: no row stood out from the others'
            // spread, a refinement followed them to 228 mm of mean error, and nothing was said.
            format!(
                "{w}. The compensator is trained on them as asked, unless cross-validation lists \
                 them as outliers (many such rows widen the spread it judges by): a refinement \
                 and a network bend toward them"
            )
        });
    }
    // And far off the validation rows, as `evaluate` on them would say (a reviewer's rows
    // moved 500 mm, or another robot's, 4 m off, passed with their figures alone).
    if let Some(v) = &val
        && let Some((w, found)) = misplaced_model_warning(&a.robot.display().to_string(), &robot, v)
    {
        warnings.say(if found.is_the_model() {
            format!("{w} Its validation figures are no check of the compensator on this robot")
        } else {
            format!("{w}. They weigh on its validation figures")
        });
    }
    let terminal = std::io::stderr().is_terminal();
    let opts = a.build.options(a.sigma.sigmas(), terminal)?;
    // A selection that names no parameter of this robot is a flag's value refused.
    if let Refine::Params(spec) = &opts.refine
        && let Err(e) = names_compliance(&robot, spec)
    {
        usage!("--refine `{spec}`: {e}");
    }
    if let (Refine::Params(spec), Some(false)) = (&opts.refine, opts.compliance)
        && names_compliance(&robot, spec).unwrap_or(false)
    {
        return Err(compliance_conflict(spec));
    }
    let bar = progress_bar(terminal);
    let started = std::time::Instant::now();
    let (c, report) = Compensator::train(&robot, &set, &opts, &|done, total| {
        bar.set_length(total as u64);
        bar.set_position(done as u64);
    })
    .with_context(|| format!("training on {}", a.data.display()))?;
    let seconds = started.elapsed().as_secs_f64();
    bar.finish_and_clear();
    say!(
        "train: {} rows of {}, model {}",
        set.rows.len(),
        a.data.display(),
        a.robot.display()
    );
    super::summary::warn_copies(&set, &mut warnings);
    if let Some(r) = &report.repeats {
        super::summary::print_repeats(r, &robot, &set, &mut warnings);
    }
    if let Some(sel) = &report.selection {
        print_selection(sel);
    }
    say!("settings: {}", report.settings.describe());
    let unchecked: Vec<String> = std::iter::once(&set)
        .chain(&val)
        .filter_map(|s| super::summary::unchecked_readings_note(&robot, s, Measure::default_for(s)))
        .collect();
    for n in (report.notes.iter())
        .chain(&a.sigma.unused(&set))
        .chain(&unchecked)
    {
        say!("note: {n}");
    }
    for w in (report.warnings.iter()).chain(report.selection.iter().flat_map(|s| &s.warnings)) {
        warnings.say(w.clone());
    }
    // The rows cross-validation saw: the training rows but those left out for carrying
    // another configuration's reading, and the outliers of a first choice made again without
    // them.
    let trained;
    let first: &[robocal::neural::selection::Outlier] = report
        .selection
        .as_ref()
        .map_or(&[], |s| s.first_outliers.as_slice());
    print_fit(
        &c,
        &report,
        seconds,
        (
            if opts.drop_outliers {
                trained = subset(&set, |i| {
                    report.shared_readings.iter().all(|r| r.row != i)
                        && first.iter().all(|o| o.row != i)
                });
                &trained
            } else {
                &set
            },
            opts.train.rbf_draw(),
            report
                .selection
                .as_ref()
                .filter(|s| s.outliers_left_out)
                .map_or(0, |s| s.outliers.len()),
        ),
    );
    let mut figs = 0;
    if let Some(dir) = &a.plot {
        robocal::plot::forget_earlier(dir, "train")?;
    }
    if let Some(dir) = &a.plot
        && let Some(first) = report.networks.first()
    {
        training_figure(dir, "train", "compensator", first)?;
        figs += 1;
    }
    let mut ws = PredictWorkspace::default();
    let mut accuracy = Vec::new();
    let mut clean = Vec::new();
    let mut val_worst = None;
    // Where the compensator does worse than the model alone on the validation rows.
    let mut val_worse = None;
    // The validation rows outside the compensator's training domain, by line.
    let mut val_outside: Vec<usize> = Vec::new();
    // The training rows' readings logged with other joints were judged in training, under the
    // robot file's model, among themselves; the validation rows' are judged here against
    // their own and the training rows, as `evaluate --check-against` the training file judges
    // them (a validation row can carry a training row's reading).
    let val_shared = val
        .as_ref()
        .map(|v| shared_under(&robot, v, Measure::default_for(v), Some(&set)))
        .unwrap_or_default();
    let training_fate = if opts.drop_outliers {
        "left out of cross-validation and the fit; 'training clean' leaves them out of the figures"
    } else {
        "kept in cross-validation and the fit, as asked; 'training clean' leaves them out of the \
         figures"
    };
    for (name, s, shared, fate) in [
        (
            "training",
            Some(&set),
            &report.shared_readings,
            training_fate,
        ),
        (
            "validation",
            val.as_ref(),
            &val_shared,
            "'validation clean' leaves them out",
        ),
    ] {
        let Some(s) = s else { continue };
        let m = Measure::default_for(s);
        if !shared.is_empty() {
            print_shared(name, shared, fate);
        }
        let before_rows = row_errors(s, m, |q| tool_pose(&robot, q))?;
        let after_rows = row_errors(s, m, |q| c.predict(q, &mut ws))?;
        let inside: Vec<bool> = s
            .rows
            .iter()
            .map(|r| c.domain_check(&r.q, &mut ws).inside())
            .collect();
        let outside = inside.iter().filter(|i| !**i).count();
        clean.extend(clean_accuracy(
            &format!("{name} clean"),
            shared,
            &before_rows,
            Some((&after_rows, &inside, super::summary::compensated_label(&c))),
        ));
        if let Some(dir) = &a.plot {
            let runs = [
                ErrorRun {
                    label: "model",
                    errors: &before_rows,
                },
                ErrorRun {
                    label: "with compensator",
                    errors: &after_rows,
                },
            ];
            figs += error_figures(
                dir,
                &format!("train_{name}"),
                &format!("{name} data"),
                s,
                &runs,
            )?
            .len();
        }
        if name == "validation" {
            let suspects: Vec<usize> = shared.iter().map(|r| r.line).collect();
            val_worse = (a.validate.as_ref()).and_then(|p| {
                let rows = (&before_rows[..], &after_rows[..]);
                // As `evaluate`: measures of single rows only (a pair's rows are its lines).
                let misfit = matches!(m, Measure::Pose | Measure::Position)
                    .then(|| robocal::evaluate::misfit(&c.robot, s))
                    .flatten();
                let far = super::summary::far_lines(misfit.as_ref());
                super::summary::worse_than_model_without(p, rows, m, &suspects, &far)
            });
            val_worst = worst_rows(&before_rows, Some(&after_rows))?;
            val_outside = (s.rows.iter().zip(&inside))
                .filter(|(_, inside)| !**inside)
                .map(|(r, _)| r.line)
                .collect();
        }
        let (before, after) = (summarize(&before_rows), summarize(&after_rows));
        // Fitted to these rows, a compensator that misses them by more than its model has
        // not learned (no epochs, a step limit hit at once): written as asked, but said.
        let (b, f) = (before.position_rms_mm(), after.position_rms_mm());
        if name == "training" && f > b {
            warnings.say(format!(
                "the compensator misses its own training rows by more than the model alone \
                 ({f:.4} against {b:.4} mm RMS): its networks did not learn them (too few epochs \
                 or iterations?); the file is written as asked, but the model alone is more \
                 accurate"
            ));
        }
        accuracy.push(Accuracy::new(name, "model", before));
        accuracy.push(Accuracy {
            rows_outside_domain: Some(outside),
            ..Accuracy::new(name, super::summary::compensated_label(&c), after)
        });
    }
    accuracy.extend(clean);
    let mut report = TrainReport::new(
        &c,
        report,
        a.robot.display().to_string(),
        a.data.display().to_string(),
        set.rows.len(),
        a.validate.as_ref().map(|p| p.display().to_string()),
        a.out.display().to_string(),
        seconds,
        accuracy,
    );
    report.validation_shared_readings = val_shared;
    report.validation_worst_rows = val_worst;
    print_stats(&report.accuracy, robocal::identify::Measure::Pose);
    if let (Some(w), Some(v)) = (&report.validation_worst_rows, &val) {
        super::summary::print_worst("validation", "the model", Measure::default_for(v), w);
    }
    if let Some(path) = &a.validate {
        warnings.say_some(super::predict::outside_warning(
            path,
            &val_outside,
            false,
            c.has_network(),
        ));
    }
    warnings.say_some(val_worse);
    report.validation_lines_outside_domain = val_outside;
    report.warnings = warnings.into_vec();
    super::output::writing(c.save(&a.out), &a.out)?;
    told_after!("wrote {}", a.out.display());
    if let Some(dir) = &a.plot {
        told_after!("plots: {figs} pictures in {}", dir.display());
    }
    if let Some(p) = &a.report {
        write_report(p, &Report::Train(report))?;
    }
    Ok(())
}
