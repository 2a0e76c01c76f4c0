//! A compensator: a kinematic model and an ensemble of MLPs in series (thesis 3.2, Fig. 3.6).
//!
//! Two forms (see [`super::targets`] for what each is trained on):
//! - joint: the networks give joint corrections dq(q) (mrad, or um for prismatic joints) added
//!   before the model's FK; compliance and gear errors live in the joints;
//! - pose (the thesis's): the networks give what the model misses at the tool, [dp (mm);
//!   dr (mrad, rotation vector)] in the robot's base frame, composed as p = p_model + R_b dp,
//!   R = exp(R_b dr) R_model (position-only data: dp only).
//!
//! Training a compensator ([`Compensator::train`]) fixes what the options fix and chooses the
//! rest by cross-validation ([`super::tuning`]); with refinement the model's parameters are
//! first re-estimated on the training rows through the exact model ([`super::refine`]).
//! Prediction is in [`super::predict`], the file in [`super::file`], the training domain in
//! [`super::domain`].

use super::domain::{Domain, DomainCheck};
use super::encoding::Encoding;
pub use super::predict::PredictWorkspace;
use super::rbf::Rbf;
use super::refine::{RefinedParam, refine};
use super::targets::build;
use super::train::{TrainOptions, TrainReport, train};
use super::tuning::{FIT_WORK, Selection, budget_epochs, select_settings};
use super::weights::{Affine, Weights};
use crate::data::MeasurementSet;
use crate::error::Result;
use crate::identify::Sigmas;
use crate::model::Robot;

/// Where the network's output acts.
#[derive(
    Debug, Clone, Copy, PartialEq, Eq, Hash, clap::ValueEnum, serde::Serialize, serde::Deserialize,
)]
#[serde(rename_all = "lowercase")]
pub enum Form {
    /// Pose residual at the tool (robot base frame).
    Pose,
    /// Joint corrections before FK.
    Joint,
}

impl Form {
    pub const ALL: [Form; 2] = [Form::Joint, Form::Pose];

    pub fn name(self) -> &'static str {
        match self {
            Form::Pose => "pose",
            Form::Joint => "joint",
        }
    }
}

/// What kind of network a compensator carries.
#[derive(
    Debug,
    Clone,
    Copy,
    Default,
    PartialEq,
    Eq,
    Hash,
    clap::ValueEnum,
    serde::Serialize,
    serde::Deserialize,
)]
#[serde(rename_all = "lowercase")]
pub enum Network {
    /// The thesis's multilayer perceptron: one logistic hidden layer, trained by momentum
    /// then L-BFGS (an ensemble of them where it helps).
    #[default]
    Mlp,
    /// A radial-basis-function network with one unit per training row, widths and weights of
    /// a Gaussian process's posterior mean ([`super::rbf`]); pose form only.
    Rbf,
    /// The MLPs' mean and an RBF network with equal say (pose form only): the MLPs follow the
    /// smooth trend, the RBF network the sharp local structure (repeated configurations), and
    /// their errors are far from fully correlated.
    Mix,
}

impl Network {
    pub fn name(self) -> &'static str {
        match self {
            Network::Mlp => "mlp",
            Network::Rbf => "rbf",
            Network::Mix => "mix",
        }
    }
}

/// A trained compensator.
#[derive(Debug, Clone)]
pub struct Compensator {
    pub form: Form,
    pub encoding: Encoding,
    /// The model the networks run in series with (refined in training when asked).
    pub robot: Robot,
    /// The ensemble's MLPs; the prediction uses their mean output, averaged with `rbf`'s
    /// where both are present (none of either: no correction).
    pub members: Vec<Weights>,
    /// An RBF network, alone or with the MLPs.
    pub rbf: Option<Rbf>,
    pub input_norm: Affine,
    pub output_norm: Affine,
    pub domain: Domain,
}

/// One complete choice of how to build a compensator.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Settings {
    pub network: Network,
    pub form: Form,
    pub encoding: Encoding,
    pub hidden: usize,
    /// L2 weight penalty lambda (see [`super::samples`]).
    pub penalty: f64,
    /// MLPs in the ensemble (for `Rbf`: 1 with the RBF network); 0 and no RBF network: the
    /// (refined) model alone, chosen where cross-validation finds that no network lowers the
    /// held-out error.
    pub members: usize,
    /// The RBF network's hyperparameter search start ([`super::rbf::STARTS`]); None: every
    /// start, the highest likelihood kept.
    pub rbf_start: Option<usize>,
    /// Model parameters re-estimated on the training rows first (a selection as for
    /// `identify`), or None.
    pub refine: Option<String>,
}

impl Settings {
    /// A one-line description: `joint/sincos/16 penalty 0.1 x5, refine full`.
    pub fn describe(&self) -> String {
        let refine = self
            .refine
            .as_ref()
            .map_or(String::new(), |r| format!(", refine {r}"));
        if !self.has_network() {
            return format!("model alone (no network){refine}");
        }
        let rbf = match self.rbf_start {
            Some(k) => format!("rbf start {}", k + 1),
            None => "rbf".into(),
        };
        match self.network {
            Network::Rbf => format!(
                "{}/{}/{rbf}{refine}",
                self.form.name(),
                self.encoding.name()
            ),
            Network::Mlp | Network::Mix => format!(
                "{}/{}/{} penalty {} x{}{}{refine}",
                self.form.name(),
                self.encoding.name(),
                self.hidden,
                self.penalty,
                self.members,
                if self.network == Network::Mix {
                    format!(" + {rbf}")
                } else {
                    String::new()
                }
            ),
        }
    }

    /// The network and its RBF search start, counted from 1 as in [`Settings::describe`]:
    /// `mlp`, `rbf 2`, `mix 1`.
    pub fn network_label(&self) -> String {
        match (self.network, self.rbf_start) {
            (Network::Mlp, _) => "mlp".into(),
            (n, Some(k)) => format!("{} {}", n.name(), k + 1),
            (n, None) => n.name().into(),
        }
    }

    /// Whether these settings carry a network at all.
    pub fn has_network(&self) -> bool {
        self.members > 0 || self.network == Network::Mix
    }

    /// Whether these settings carry an RBF network.
    pub fn has_rbf(&self) -> bool {
        match self.network {
            Network::Mlp => false,
            Network::Rbf => self.members > 0,
            Network::Mix => true,
        }
    }
}

/// Whether to re-estimate model parameters with the network.
#[derive(Debug, Clone, PartialEq)]
pub enum Refine {
    /// Cross-validation decides between no refinement and the full identifiable set.
    Auto,
    /// Never.
    Off,
    /// These parameters (a selection as for `identify`); kept only where cross-validation
    /// shows that refinement lowers the held-out error.
    Params(String),
}

/// How to build a compensator: each choice left None is made by cross-validation.
#[derive(Debug, Clone)]
pub struct CompensatorOptions {
    /// The network kind; None: cross-validation decides (an RBF network is tried on sets of
    /// at most [`super::tuning::RBF_MAX_ROWS`] rows).
    pub network: Option<Network>,
    /// The RBF network's search start ([`super::rbf::STARTS`]); None: cross-validation
    /// decides where it runs, else the highest likelihood.
    pub rbf_start: Option<usize>,
    pub form: Option<Form>,
    pub encoding: Option<Encoding>,
    pub hidden: Option<usize>,
    pub penalty: Option<f64>,
    pub members: Option<usize>,
    pub refine: Refine,
    /// Tracker sigmas for rows that carry none (refinement).
    pub sigmas: Sigmas,
    /// Cross-validation folds; None: 5, or 4 from 1500 distinct configurations.
    pub folds: Option<usize>,
    /// The training procedure of every network; its `hidden` and `penalty` are overridden by
    /// the settings.
    pub train: TrainOptions,
    /// Robust sigmas of the cross-validated error beyond which a training row is listed as
    /// an outlier ([`super::tuning::OUTLIER_K`]; infinite lists none). Applies where
    /// cross-validation runs.
    pub outlier_k: f64,
    /// Leave the listed outliers out of the final fit.
    pub drop_outliers: bool,
    /// Phase-2 epoch limits from the row count ([`super::tuning::CV_WORK`] for candidates,
    /// [`super::tuning::FIT_WORK`] for the final fit) instead of `train.max_epochs`.
    pub budget: bool,
}

impl Default for CompensatorOptions {
    fn default() -> Self {
        CompensatorOptions {
            network: None,
            rbf_start: None,
            form: None,
            encoding: None,
            hidden: None,
            penalty: None,
            members: None,
            refine: Refine::Auto,
            sigmas: Sigmas::default(),
            folds: None,
            train: TrainOptions::default(),
            outlier_k: super::tuning::OUTLIER_K,
            drop_outliers: false,
            budget: true,
        }
    }
}

impl CompensatorOptions {
    /// Options with every choice fixed.
    pub fn fixed(settings: &Settings, train: TrainOptions) -> Self {
        CompensatorOptions {
            network: Some(settings.network),
            rbf_start: settings.rbf_start,
            form: Some(settings.form),
            encoding: Some(settings.encoding),
            hidden: Some(settings.hidden),
            penalty: Some(settings.penalty),
            members: Some(settings.members),
            refine: settings.refine.clone().map_or(Refine::Off, Refine::Params),
            train,
            budget: false,
            ..Default::default()
        }
    }
}

/// What training did.
#[derive(Debug, Clone, serde::Serialize)]
pub struct CompensatorReport {
    pub settings: Settings,
    /// The cross-validation that chose the settings, when anything was left to choose.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub selection: Option<Selection>,
    /// The training of each ensemble member.
    pub networks: Vec<TrainReport>,
    pub refined: Vec<RefinedParam>,
    /// What the user should know (refinement kept or dropped, ill-conditioning).
    pub notes: Vec<String>,
    /// Wall-clock seconds of the cross-validation and of the final fit.
    pub selection_seconds: f64,
    pub fit_seconds: f64,
}

/// Runs `f(k)` for k in 0..n on up to `available_parallelism` threads; results in order.
pub(crate) fn parallel_map<T: Send>(n: usize, f: impl Fn(usize) -> T + Sync) -> Vec<T> {
    use std::sync::Mutex;
    use std::sync::atomic::{AtomicUsize, Ordering};
    let threads = std::thread::available_parallelism()
        .map_or(1, |t| t.get())
        .min(n.max(1));
    if threads <= 1 {
        return (0..n).map(f).collect();
    }
    let next = AtomicUsize::new(0);
    let out: Mutex<Vec<Option<T>>> = Mutex::new((0..n).map(|_| None).collect());
    std::thread::scope(|s| {
        for _ in 0..threads {
            s.spawn(|| {
                loop {
                    let k = next.fetch_add(1, Ordering::Relaxed);
                    if k >= n {
                        break;
                    }
                    let v = f(k);
                    if let Ok(mut o) = out.lock() {
                        o[k] = Some(v);
                    }
                }
            });
        }
    });
    out.into_inner()
        .unwrap_or_default()
        .into_iter()
        .flatten()
        .collect()
}

impl Compensator {
    pub fn inputs(&self) -> usize {
        self.input_norm.len()
    }

    /// Hidden units of each MLP (0 without MLPs).
    pub fn hidden(&self) -> usize {
        self.members.first().map_or(0, |w| w.hidden())
    }

    pub fn outputs(&self) -> usize {
        self.output_norm.len()
    }

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
        let (c, networks) =
            Compensator::fit_with(&robot, set, settings, train_opts, true, true, 0)?;
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
            },
        ))
    }

    /// [`Compensator::fit`] on a model already refined (`settings.refine` is not applied);
    /// `parallel` trains the members on several threads; without `with_domain` the domain is
    /// left empty (cross-validation fits never check it). Member m (counting from
    /// `first_member`) trains from seed `train_opts.seed + 7919 m`, so members already trained
    /// for the same settings can be reused and completed.
    pub(crate) fn fit_with(
        robot: &Robot,
        set: &MeasurementSet,
        settings: &Settings,
        train_opts: &TrainOptions,
        parallel: bool,
        with_domain: bool,
        first_member: usize,
    ) -> Result<(Compensator, Vec<TrainReport>)> {
        let problem = build(robot, set, settings.form, settings.encoding)?;
        let outputs = problem.output_norm.len();
        let mut members = Vec::new();
        let mut reports = Vec::new();
        let rbf = if settings.has_rbf() {
            Some(match &train_opts.rbf_hyper {
                Some(h) => Rbf::with_hyper(&problem.samples, h)?,
                None => Rbf::fit(&problem.samples, settings.rbf_start, train_opts.seed)?.0,
            })
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
                    progress: train_opts.progress && settings.members == 1,
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
        Ok((
            Compensator {
                form: settings.form,
                encoding: settings.encoding,
                robot: robot.clone(),
                members,
                rbf,
                input_norm: problem.input_norm,
                output_norm: problem.output_norm,
                domain,
            },
            reports,
        ))
    }

    /// Trains a compensator for `robot` on the measured rows of `set`: the choices `opts`
    /// leaves open are made by cross-validation on `set` (`progress` is told (done, total)
    /// trainings), then the chosen settings are fitted on every row.
    pub fn train(
        robot: &Robot,
        set: &MeasurementSet,
        opts: &CompensatorOptions,
        progress: &(dyn Fn(usize, usize) + Sync),
    ) -> Result<(Compensator, CompensatorReport)> {
        let started = std::time::Instant::now();
        let (settings, selection) = select_settings(robot, set, opts, progress)?;
        let selection_seconds = started.elapsed().as_secs_f64();
        let train = TrainOptions {
            max_epochs: if opts.budget {
                budget_epochs(FIT_WORK, set.rows.len(), 50, 60)
            } else {
                opts.train.max_epochs
            },
            // The search cross-validation made on these rows for this model (the same result).
            rbf_hyper: selection
                .as_ref()
                .and_then(|s| s.rbf_hyper.clone())
                .filter(|_| settings.refine.is_none()),
            ..opts.train.clone()
        };
        // Rows cross-validation listed as outliers stay out of the final fit when asked.
        let kept;
        let fit_set = match &selection {
            Some(s) if opts.drop_outliers && !s.outliers.is_empty() => {
                let out: std::collections::HashSet<usize> =
                    s.outliers.iter().map(|o| o.row).collect();
                kept = super::tuning::subset(set, |i| !out.contains(&i));
                &kept
            }
            _ => set,
        };
        let (c, mut report) = Compensator::fit(robot, fit_set, &settings, opts.sigmas, &train)?;
        if let Some(s) = &selection {
            report.notes.extend(s.notes.iter().cloned());
        }
        report.selection = selection;
        report.selection_seconds = selection_seconds;
        Ok((c, report))
    }

    /// Where `q` (rad, mm) stands against the training domain.
    pub fn domain_check(&self, q: &[f64], ws: &mut PredictWorkspace) -> DomainCheck {
        let x = ws.normalised_inputs(self, q);
        self.domain.check(q, x)
    }
}
