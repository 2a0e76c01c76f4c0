//! Fitting a compensator of fixed settings: refinement (exact re-identification) first, then
//! the RBF network and the MLPs of the ensemble on the training rows.

use super::compensator::Compensator;
use super::domain::Domain;
use super::parallel::parallel_map;
use super::rbf::{LeftOut, Rbf, search_from, search_start_without, unit_rows};
use super::refine::{RefinedParam, refine};
use super::repeats::Repeats;
use super::selection::Selection;
use super::settings::{MIX_SHARE, Network, Settings, check_share};
use super::shrink::Shrink;
use super::targets::build;
use super::train::{RbfHyper, TrainOptions, TrainReport, train};
use super::weights::Weights;
use crate::data::MeasurementSet;
use crate::data::shared_readings::SharedReading;
use crate::error::Result;
use crate::identify::Sigmas;
use crate::model::Robot;

/// What training did.
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
pub struct CompensatorReport {
    /// The settings the compensator was fitted with.
    pub settings: Settings,
    /// The cross-validation that chose the settings, when anything was left to choose.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub selection: Option<Selection>,
    /// The training of each ensemble member.
    pub networks: Vec<TrainReport>,
    /// The model parameters refinement re-estimated (empty without refinement).
    pub refined: Vec<RefinedParam>,
    /// What the user should know (refinement kept or dropped, ill-conditioning).
    pub notes: Vec<String>,
    /// Wall-clock seconds of the cross-validation and of the final fit.
    pub selection_seconds: f64,
    /// Wall-clock seconds of the final fit (s).
    pub fit_seconds: f64,
    /// How far the residuals of repeated configurations under the compensator's model (refined,
    /// when refinement ran) disagree: the data's floor; None without repeats.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub repeats: Option<Repeats>,
    /// Training rows that carry another configuration's reading under the model as given
    /// ([`crate::data::shared_readings`]), indexed in the rows given to
    /// [`Compensator::train`]: left out of cross-validation and the fit unless outliers are
    /// kept. Empty when there are none (then left out of the file, and in reports written
    /// before it).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub shared_readings: Vec<SharedReading>,
    /// Rows of the final fit, where the RBF network's units sit on a choice of them (more rows
    /// than [`TrainOptions::rbf_units`], see [`crate::neural::rbf::unit_rows`]); None: a unit
    /// on every row, or no RBF network (then left out of the file).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rbf_centred_on: Option<usize>,
    /// What the user must know before using the compensator that no cross-validation said
    /// (rows too few to train a network: the model alone). Empty when there is none.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub warnings: Vec<String>,
}

impl Compensator {
    /// Builds a compensator for `model` on the measured rows of `set` with fixed `settings`:
    /// refinement (exact re-identification) first, then the members, each with its own seed
    /// (and so its own initial weights and held-out part), trained in parallel.
    pub fn fit(
        model: &Robot,
        set: &MeasurementSet,
        settings: &Settings,
        sigmas: Sigmas,
        train_opts: &TrainOptions,
    ) -> Result<(Compensator, CompensatorReport)> {
        let (robot, refined, notes) = match &settings.refine {
            Some(spec) => refine(model, set, spec, sigmas)?,
            None => (model.clone(), Vec::new(), Vec::new()),
        };
        let started = std::time::Instant::now();
        let (mut c, networks) =
            fit_with(&robot, set, settings, train_opts, true, true, Vec::new())?;
        c.model_refined = Some(settings.refine.is_some());
        let rbf_centred_on = c
            .rbf
            .as_ref()
            .filter(|r| r.units() < set.rows.len())
            .map(|_| set.rows.len());
        Ok((
            c,
            CompensatorReport {
                settings: settings.clone(),
                selection: None,
                networks,
                refined,
                notes,
                selection_seconds: 0.0,
                fit_seconds: started.elapsed().as_secs_f64(),
                repeats: Repeats::of(&robot, set),
                shared_readings: Vec::new(),
                rbf_centred_on,
                warnings: Vec::new(),
            },
        ))
    }
}

/// [`Compensator::fit`] on a model already refined (`settings.refine` is not applied);
/// `parallel` trains the members on several threads; without `with_domain` the domain is
/// left empty (cross-validation fits never check it). The members `reused` (already
/// trained for the same settings and rows) come first; member m after them trains from seed
/// `train_opts.seed + 7919 m`, m counting them, so an ensemble can be completed.
pub(crate) fn fit_with(
    robot: &Robot,
    set: &MeasurementSet,
    settings: &Settings,
    train_opts: &TrainOptions,
    parallel: bool,
    with_domain: bool,
    reused: Vec<Weights>,
) -> Result<(Compensator, Vec<TrainReport>)> {
    if let (Network::Mix, Some(share)) = (settings.network, settings.mlp_share) {
        check_share(share)?;
    }
    let problem = build(robot, set, settings.form, settings.encoding)?;
    let outputs = problem.output_norm.len();
    let first_member = reused.len();
    let mut members = reused;
    let mut reports = Vec::new();
    let rbf = if settings.has_rbf() {
        let (x, draw, left) = (
            &problem.samples,
            train_opts.rbf_draw(),
            LeftOut {
                rows: &train_opts.rbf_left_out,
                groups: &train_opts.rbf_whole_groups,
            },
        );
        let hyper = match &train_opts.rbf_hyper {
            RbfHyper::Given(h) => h.clone(),
            // Begun at hyperparameters found on a superset of the rows searched, it cannot
            // fail on the data: its start's kernel matrices are principal submatrices of
            // positive definite ones, and it only takes steps that lower a finite objective.
            RbfHyper::From(from) => search_from(x, from, draw, left)?.hyper,
            RbfHyper::Search => search_start_without(x, settings.rbf_start, draw, left)?.hyper,
        };
        // On a large set the units sit on a choice of its rows (the whole set's, where rows
        // were left out); the others train the MLPs.
        let centred = unit_rows(x, draw.seed, train_opts.rbf_units, left)?.map(|r| x.pick(&r));
        Some(Rbf::with_hyper_on(
            centred.as_ref().unwrap_or(x),
            &hyper,
            draw.covariance,
            parallel,
        )?)
    } else {
        None
    };
    if settings.network != Network::Rbf {
        let one = |m: usize| {
            let m = m + first_member;
            let opts = TrainOptions {
                hidden: settings.hidden,
                penalty: settings.penalty,
                seed: train_opts.seed.wrapping_add(m as u64 * 7919),
                progress: train_opts
                    .progress
                    .clone()
                    .filter(|_| settings.members == 1),
                ..train_opts.clone()
            };
            train(&problem.samples, outputs, &opts)
        };
        let count = settings.members.saturating_sub(first_member);
        let trained = if parallel {
            parallel_map(count, one)
        } else {
            (0..count).map(one).collect()
        };
        for t in trained {
            let (w, r) = t?;
            members.push(w);
            reports.push(r);
        }
    }
    let qs: Vec<&[f64]> = if with_domain {
        set.rows.iter().map(|m| m.q.as_slice()).collect()
    } else {
        Vec::new()
    };
    let domain = Domain::fit(robot, settings.encoding, &problem.input_norm, &qs);
    let shrink = Shrink::fit(&members, &problem.samples.x);
    Ok((
        Compensator {
            form: settings.form,
            encoding: settings.encoding,
            robot: robot.clone(),
            members,
            rbf,
            mlp_share: settings.mlp_share.unwrap_or(MIX_SHARE),
            shrink,
            input_norm: problem.input_norm,
            output_norm: problem.output_norm,
            domain,
            model_refined: Some(false),
        },
        reports,
    ))
}
