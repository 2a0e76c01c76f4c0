//! The cross-validation workspace: each fold's training and held-out rows, the refinement of
//! a fold's model, and the fits (networks, warm starts, RBF hyperparameters) that candidates
//! share.

use super::SHARES;
use super::rows::{share_sums, sums};
use super::shares::open_share;
use super::{CV_WORK, budget_epochs};
use crate::data::MeasurementSet;
use crate::error::{Error, Result};
use crate::model::Robot;
use crate::neural::compensator::Compensator;
use crate::neural::encoding::Encoding;
use crate::neural::parallel::parallel_map;
use crate::neural::rbf::{self, Hyper};
use crate::neural::refine::refine;
use crate::neural::selection::Sums;
use crate::neural::settings::{CompensatorOptions, Form, MIX_SHARE, Network, Settings};
use crate::neural::targets::build;
use crate::neural::train::{RbfHyper, TrainOptions};
use crate::neural::weights::Weights;
use std::collections::HashMap;
use std::sync::Mutex;

/// The cross-validation workspace: folds, each fold's training and held-out rows, and the
/// fits candidates share (the refined models of each fold are computed once per refinement
/// with [`Cv::model`] and held by the race).
pub(super) struct Cv<'a> {
    pub(super) robot: &'a Robot,
    pub(super) train: Vec<MeasurementSet>,
    pub(super) held: Vec<MeasurementSet>,
    /// Each fold's held-out rows: their indices in the training set, in `held`'s order.
    pub(super) held_index: Vec<Vec<usize>>,
    /// The configuration group of every training row
    /// ([`crate::neural::repeats::configuration_groups`]).
    pub(super) groups: Vec<usize>,
    pub(super) opts: &'a CompensatorOptions,
    /// The network of each (single-network settings, fold) fitted so far: an ensemble
    /// candidate of the same settings reuses it as its first member.
    /// With it, the phase-2 epochs behind it (a warm start's included).
    pub(super) nets: Mutex<HashMap<(String, usize), Worked>>,
    /// Single networks by (settings but the penalty, fold): the warm starts of candidates
    /// that differ from them by the penalty only.
    pub(super) warm: Mutex<HashMap<(String, usize), Vec<WarmStart>>>,
    /// Every MLP candidate's fold fit by (settings, fold): a mixed candidate adds an RBF
    /// network to it instead of training it again.
    pub(super) fitted: Mutex<HashMap<(String, usize), Compensator>>,
    /// All training rows: the RBF hyperparameters are searched on them once per (encoding,
    /// start); the folds fit only the weights.
    pub(super) set: &'a MeasurementSet,
    pub(super) hypers: Mutex<HashMap<(Encoding, Option<usize>), Searched>>,
    /// The RBF hyperparameters of (encoding, start, fold) searched on that fold's training
    /// rows alone, for the network test ([`Cv::unseen`]).
    pub(super) fold_hypers: Mutex<HashMap<FoldSearch, Searched>>,
    /// The RBF network alone of each (refinement, encoding, start, fold, hyperparameters'
    /// rows).
    pub(super) rbf_fits: Mutex<HashMap<RbfKey, Compensator>>,
}

/// A hyperparameter search's outcome, its error as text (cached and told by the candidates).
pub(super) type Searched = std::result::Result<Hyper, String>;

/// (encoding, search start (None: the best), fold) of a search on a fold's training rows.
pub(super) type FoldSearch = (Encoding, Option<usize>, usize);

/// (refinement, encoding, search start, fold, hyperparameters' rows) of a fold's RBF fit.
pub(super) type RbfKey = (Option<String>, Encoding, Option<usize>, usize, Hypers);

/// The rows a fold's RBF hyperparameters are searched on.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub(super) enum Hypers {
    /// All training rows, once ([`Cv::hyper`]): every candidate's. The search then sees the
    /// rows each fold holds out, which a fold's error does not tell for what it is: on the
    /// residuals of two simulated robots with geometric errors only (identified with `full`
    /// on the rows they train on: noise alone) it chose hyperparameters under which the
    /// network's held-out error fell 3.4 and 4.7 % below the model's, where on new rows it
    /// rose 3.7 and 8.7 % above.
    AllRows,
    /// The fold's training rows alone ([`Cv::hyper_without`]): the network test's.
    FoldRows,
}

/// A network and the phase-2 epochs behind it.
pub(super) type Worked = (Weights, usize);

/// A fitted single network: (evaluation round, penalty, weights, phase-2 epochs behind it).
pub(super) type WarmStart = (usize, f64, Weights, usize);

impl Cv<'_> {
    /// The model refined by `spec` on fold `fold`'s training rows (the model as given
    /// without a refinement).
    pub(super) fn model(&self, fold: usize, spec: &Option<String>) -> Result<Robot> {
        match spec {
            None => Ok(self.robot.clone()),
            Some(s) => Ok(refine(self.robot, &self.train[fold], s, self.opts.sigmas)?.0),
        }
    }

    /// The RBF hyperparameters of `encoding` from search start `start` (None: output by output
    /// the start of highest likelihood, as the final fit of a fixed RBF network searches) on
    /// all training rows (searched once, then cached), on the model as given's residual: a refinement's
    /// candidates are judged with them, and the final fit of a refined winner searches its
    /// own residual again. A search per refinement here (on the model refined on all rows)
    /// made training on 2000 poses 30 % slower and did not lower the held-out error over 28
    /// Series B runs (mean RMS +0.7 %).
    pub(super) fn hyper(&self, encoding: Encoding, start: Option<usize>) -> Result<Hyper> {
        if let Ok(h) = self.hypers.lock()
            && let Some(r) = h.get(&(encoding, start))
        {
            return r.clone().map_err(Error::Invalid);
        }
        let found = build(self.robot, self.set, Form::Pose, encoding)
            .and_then(|p| {
                let draw = self.opts.train.rbf_draw();
                rbf::search_start_without(&p.samples, start, draw, rbf::LeftOut::NONE)
            })
            .map(|f| f.hyper)
            .map_err(|e| e.to_string());
        if let Ok(mut h) = self.hypers.lock() {
            h.insert((encoding, start), found.clone());
        }
        found.map_err(Error::Invalid)
    }

    /// The RBF hyperparameters of `encoding` from search start `start` (None: the best,
    /// [`Cv::hyper`]) on fold `fold`'s
    /// training rows alone (searched once, then cached): from the start, as the final fit
    /// searches, on the rows the search on all training rows draws but the fold's held-out
    /// ones, for the model as given's residual ([`Cv::hyper`]).
    pub(super) fn hyper_without(
        &self,
        encoding: Encoding,
        start: Option<usize>,
        fold: usize,
    ) -> Result<Hyper> {
        let key = (encoding, start, fold);
        if let Ok(h) = self.fold_hypers.lock()
            && let Some(r) = h.get(&key)
        {
            return r.clone().map_err(Error::Invalid);
        }
        let left = rbf::LeftOut {
            rows: &self.held_index[fold],
            groups: &self.groups,
        };
        let found = build(self.robot, &self.train[fold], Form::Pose, encoding)
            .and_then(|p| {
                let draw = self.opts.train.rbf_draw();
                rbf::search_start_without(&p.samples, start, draw, left)
            })
            .map(|f| f.hyper)
            .map_err(|e| e.to_string());
        if let Ok(mut h) = self.fold_hypers.lock() {
            h.insert(key, found.clone());
        }
        found.map_err(Error::Invalid)
    }

    /// The training rows that the search on all of them ([`Cv::hyper`]) does not see, their
    /// arm configurations left out of its draw: where they are at least as many as a fold
    /// holds out, held-out rows among them are judged by hyperparameters and weights that
    /// never saw them (None: too few, or none where the draw takes every configuration; the
    /// folds then search their own, [`Hypers::FoldRows`]).
    pub(super) fn unseen(&self, encoding: Encoding) -> Result<Option<Vec<bool>>> {
        let p = build(self.robot, self.set, Form::Pose, encoding)?;
        let drawn: std::collections::HashSet<usize> =
            (rbf::drawn_rows(&p.samples, self.opts.train.rbf_draw())?.into_iter())
                .map(|r| self.groups[r])
                .collect();
        let unseen: Vec<bool> = self.groups.iter().map(|g| !drawn.contains(g)).collect();
        let count = unseen.iter().filter(|&&u| u).count();
        Ok((count > 0 && count * self.held.len() >= self.set.rows.len()).then_some(unseen))
    }

    /// Held-out sums of `settings` on one fold, one per MLP share of [`SHARES`] for a mixed
    /// network whose share is open, else one; warm starts come from rounds before `round`.
    pub(super) fn run(
        &self,
        fold: usize,
        settings: &Settings,
        model: &Robot,
        round: usize,
    ) -> Result<Vec<Sums>> {
        let c = self.fit(fold, settings, model, round)?;
        if open_share(settings) {
            return share_sums(&self.held[fold], &c, &SHARES);
        }
        let mut ws = Default::default();
        Ok(vec![sums(&self.held[fold], |q| c.predict(q, &mut ws))?])
    }

    /// The compensator of `settings` fitted on one fold's training rows.
    pub(super) fn fit(
        &self,
        fold: usize,
        settings: &Settings,
        model: &Robot,
        round: usize,
    ) -> Result<Compensator> {
        self.fit_as(fold, settings, model, round, Hypers::AllRows)
    }

    /// [`Cv::fit`] with an RBF network's hyperparameters searched on `hypers`.
    pub(super) fn fit_as(
        &self,
        fold: usize,
        settings: &Settings,
        model: &Robot,
        round: usize,
        hypers: Hypers,
    ) -> Result<Compensator> {
        if settings.has_rbf() {
            // None (a fixed RBF network without `--rbf-start`): the best start, as its final
            // fit takes; the search's candidates carry theirs.
            let start = settings.rbf_start;
            // The RBF network of one fold, shared by the candidate alone and mixed: one
            // factorisation per (refinement, encoding, start, fold, hyperparameters' rows).
            let key = (
                settings.refine.clone(),
                settings.encoding,
                start,
                fold,
                hypers,
            );
            let cached = self.rbf_fits.lock().ok().and_then(|f| f.get(&key).cloned());
            let alone = match cached {
                Some(c) => c,
                None => {
                    let rbf = Settings {
                        network: Network::Rbf,
                        form: Form::Pose,
                        hidden: 0,
                        penalty: 0.0,
                        members: 1,
                        rbf_start: start,
                        refine: None,
                        ..settings.clone()
                    };
                    let train = TrainOptions {
                        progress: None,
                        rbf_hyper: RbfHyper::Given(match hypers {
                            Hypers::AllRows => self.hyper(settings.encoding, start)?,
                            Hypers::FoldRows => {
                                self.hyper_without(settings.encoding, start, fold)?
                            }
                        }),
                        // On a set of more rows than units, the fold's units are the whole
                        // set's choice less the held-out rows ([`rbf::unit_rows`]).
                        rbf_left_out: self.held_index[fold].clone(),
                        rbf_whole_groups: self.groups.clone(),
                        ..self.opts.train.clone()
                    };
                    let c = crate::neural::fit::fit_with(
                        model,
                        &self.train[fold],
                        &rbf,
                        &train,
                        false,
                        false,
                        Vec::new(),
                    )?
                    .0;
                    if let Ok(mut f) = self.rbf_fits.lock() {
                        f.insert(key, c.clone());
                    }
                    c
                }
            };
            if settings.network != Network::Mix || settings.members == 0 {
                return Ok(alone);
            }
            // The MLPs' fit has the same normalisations (same rows, model, form and inputs).
            let mlp = Settings {
                network: Network::Mlp,
                rbf_start: None,
                ..settings.clone()
            };
            let mut c = self.fit(fold, &mlp, model, round)?;
            c.rbf = alone.rbf;
            c.mlp_share = settings.mlp_share.unwrap_or(MIX_SHARE);
            return Ok(c);
        }
        let key_all = (settings.describe(), fold);
        if let Ok(f) = self.fitted.lock()
            && let Some(c) = f.get(&key_all)
        {
            return Ok(c.clone());
        }
        let plain = Settings {
            refine: None,
            ..settings.clone()
        };
        let shape = (
            Settings {
                members: 1,
                penalty: 0.0,
                ..settings.clone()
            }
            .describe(),
            fold,
        );
        // Phase 1 (momentum) is left out of the candidates' fits: after it the weight-refining
        // phase reaches the same networks (held-out RMS equal to 1e-4 mm on real data), and it
        // costs most of a fit's time. The chosen settings are then fitted with both phases.
        // A single network whose settings differ from an earlier one's by the penalty only
        // starts from that network (the nearest penalty): a penalty path, as glmnet walks it,
        // needs a third of the work from a neighbour's optimum.
        let start = match self.warm.lock() {
            Ok(w) if settings.members == 1 && self.opts.budget => w.get(&shape).and_then(|list| {
                list.iter()
                    .filter(|(r, ..)| *r < round)
                    .min_by(|a, b| {
                        let d = |p: f64| (p.max(1e-300) / settings.penalty.max(1e-300)).ln().abs();
                        d(a.1).total_cmp(&d(b.1)).then(a.1.total_cmp(&b.1))
                    })
                    .map(|(_, _, w, e)| (w.clone(), *e))
            }),
            _ => None,
        };
        // The key keeps the refinement: a network is only valid for the model it was trained on.
        let key = (
            Settings {
                members: 1,
                ..settings.clone()
            }
            .describe(),
            fold,
        );
        let done: Option<Worked> = self.nets.lock().ok().and_then(|n| n.get(&key).cloned());
        let reuse = usize::from(done.is_some()).min(plain.members);
        let rows = self.train[fold].rows.len();
        // Members of one candidate get equal work: networks added to a reused (possibly
        // warm-started) one train as many epochs from scratch as lie behind it, or the
        // ensemble would be judged on weaker members than the single network it is held
        // against.
        let (epochs, behind) = match (&start, &done) {
            _ if !self.opts.budget => (self.opts.train.max_epochs, 0),
            (Some((_, e)), _) => (budget_epochs(CV_WORK / 3, rows, 4, 10), *e),
            (None, Some((_, e))) if reuse > 0 => (*e, 0),
            _ => (budget_epochs(CV_WORK, rows, 10, 25), 0),
        };
        let train = TrainOptions {
            momentum_epochs: 0,
            max_epochs: epochs,
            progress: None,
            start: start.map(|(w, _)| w),
            ..self.opts.train.clone()
        };
        let reused: Vec<Weights> = done.into_iter().take(reuse).map(|(w, _)| w).collect();
        let (c, ..) = crate::neural::fit::fit_with(
            model,
            &self.train[fold],
            &plain,
            &train,
            false,
            false,
            reused,
        )?;
        if plain.members == 1
            && let Ok(mut n) = self.nets.lock()
        {
            let work = behind + epochs;
            n.insert(key, (c.members[0].clone(), work));
            if let Ok(mut w) = self.warm.lock() {
                w.entry(shape).or_default().push((
                    round,
                    settings.penalty,
                    c.members[0].clone(),
                    work,
                ));
            }
        }
        if let Ok(mut f) = self.fitted.lock() {
            f.insert(key_all, c.clone());
        }
        Ok(c)
    }
}

/// The RBF hyperparameter searches `list` needs, run in parallel before its fold fits
/// (which would otherwise wait on one another for them).
pub(super) fn searches(cv: &Cv, list: &[Settings]) {
    let mut keys: Vec<(Encoding, Option<usize>)> = list
        .iter()
        .filter(|s| s.has_rbf())
        .map(|s| (s.encoding, s.rbf_start))
        .collect();
    keys.sort_by_key(|(e, k)| (e.name(), *k));
    keys.dedup();
    // Errors are cached with the results and reported by the candidates.
    let _ = parallel_map(keys.len(), |i| cv.hyper(keys[i].0, keys[i].1));
}
