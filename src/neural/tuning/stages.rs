//! The stages of the search ([`super`]'s doc): each scores its candidates in the race, starting
//! from the best so far, and moves the choice.

use super::cv::{Hypers, searches};
use super::race::Race;
use super::rank::{
    best_pose_mlp, best_where, better, better_by, cv_rms, paired_z, significant3, vary,
};
use super::space::Space;
use super::{
    COMPLIANCE_MARGIN, ENSEMBLE_PROBE, ENSEMBLE_TIE, NETWORK_MARGIN, NETWORK_Z, PENALTY_STEP,
    REFINEMENT_MARGIN, REFINEMENT_Z,
};
use crate::error::{Error, Result};
use crate::evaluate::RowError;
use crate::neural::selection::{Candidate, NetworkTest, Unseen, UnseenTest};
use crate::neural::settings::{CompensatorOptions, Form, Network, Settings};

/// The search's state between stages: what it draws from, the candidates scored so far and
/// the one chosen so far.
pub(super) struct Search<'r, 'a, 'c> {
    pub(super) race: &'r Race<'a, 'c>,
    pub(super) space: &'r Space,
    pub(super) opts: &'r CompensatorOptions,
    pub(super) candidates: Vec<Candidate>,
    /// Index of the chosen candidate so far.
    pub(super) chosen: usize,
    /// Stage 5's test of the network chosen so far against the best model alone.
    pub(super) network_test: Option<NetworkTest>,
    /// The held-out errors of the candidate stage 5 chose, fold by fold
    /// ([`Race::held_rows`]), where it computed them.
    pub(super) chosen_rows: Option<Vec<Vec<RowError>>>,
    /// Stage 5's test of a network with an RBF network that rows no hyperparameter search saw
    /// failed, where `network_test` then held another network against the model alone.
    pub(super) rbf_network_test: Option<NetworkTest>,
    /// Why the test on rows no hyperparameter search saw could not be run, where it could not
    /// (the candidates' figures then decided).
    pub(super) unseen_error: Option<String>,
    /// Stages 4 and 5's tests of a refinement that cross-validation ranked first against the
    /// best candidate without it ([`Search::refinement_test_of`]), in order.
    pub(super) refinement_tests: Vec<NetworkTest>,
    /// The MLPs' choice of stages 1-3 (the ensemble's tie rule applied), before the RBF
    /// network's candidates.
    mlp_chosen: Option<usize>,
    /// Stage 5's test of a network the options fix (`--members`), kept whatever it says.
    pub(super) fixed_network_test: Option<NetworkTest>,
}

/// What stages 1-3 found: the state the later stages go on from, in a search of their own
/// (their race holds the refinements' models).
pub(super) struct Found {
    candidates: Vec<Candidate>,
    chosen: usize,
    mlp_chosen: Option<usize>,
}

impl<'r, 'a, 'c> Search<'r, 'a, 'c> {
    /// A search with no candidate yet.
    pub(super) fn new(
        race: &'r Race<'a, 'c>,
        space: &'r Space,
        opts: &'r CompensatorOptions,
    ) -> Self {
        Search {
            race,
            space,
            opts,
            candidates: Vec::new(),
            chosen: 0,
            network_test: None,
            chosen_rows: None,
            rbf_network_test: None,
            unseen_error: None,
            refinement_tests: Vec::new(),
            mlp_chosen: None,
            fixed_network_test: None,
        }
    }

    /// What stages 1-3 found, to go on from ([`Search::resume`]).
    pub(super) fn found(self) -> Found {
        Found {
            candidates: self.candidates,
            chosen: self.chosen,
            mlp_chosen: self.mlp_chosen,
        }
    }

    /// A search that goes on from what stages 1-3 `found`, in `race`.
    pub(super) fn resume(
        race: &'r Race<'a, 'c>,
        space: &'r Space,
        opts: &'r CompensatorOptions,
        found: Found,
    ) -> Self {
        Search {
            candidates: found.candidates,
            chosen: found.chosen,
            mlp_chosen: found.mlp_chosen,
            ..Search::new(race, space, opts)
        }
    }

    /// Scores the settings of `list` not yet among the candidates, whatever their outcome
    /// there (stage `stage`).
    fn evaluate(&mut self, stage: usize, list: Vec<Settings>) {
        self.race.evaluate(stage, list, &mut self.candidates);
    }

    /// The best-scored candidate so far (the first of equals).
    pub(super) fn best(&self) -> usize {
        better(&self.candidates, 0, 1..self.candidates.len())
    }

    /// The factor a candidate of refinement `r` is judged by: the compliance refinement that
    /// cross-validation adds on its own must win by [`COMPLIANCE_MARGIN`].
    fn margin(&self, r: &Option<String>) -> f64 {
        if self.space.auto_compliance.is_some() && *r == self.space.auto_compliance {
            1.0 + COMPLIANCE_MARGIN
        } else {
            1.0
        }
    }

    /// Candidate `i`'s cross-validated RMS times its refinement's margin.
    fn judged(&self, candidates: &[Candidate], i: usize) -> f64 {
        cv_rms(candidates, i) * self.margin(&candidates[i].settings.refine)
    }

    /// Stage 1's first step: the forms (gravity inputs, middle size and penalty), or for a
    /// fixed RBF network its encodings (its search start is the smooth one unless given).
    pub(super) fn first(&mut self) {
        let space = self.space;
        if space.rbf_only {
            let mut list = Vec::new();
            for &e in &space.encodings {
                list.push(Settings {
                    encoding: e,
                    rbf_start: space.rbf_start,
                    members: 1,
                    ..space.base.clone()
                });
            }
            searches(self.race.cv, &list);
            self.evaluate(1, list);
        } else {
            self.evaluate(1, vary(&space.base, &space.forms, |s, f| s.form = f));
        }
    }

    /// Stages 1 to 3 of the MLPs: the penalty decade and the other encodings for the best
    /// so far, then hidden units and a finer penalty step, then the ensemble. With `with_rbf`,
    /// the RBF hyperparameter search runs beside stages 2 and 3 (whose fits leave cores idle
    /// between rounds) once stage 1 has fixed the pose form's encoding.
    pub(super) fn mlps(&mut self, with_rbf: bool) {
        let space = self.space;
        let cv = self.race.cv;
        std::thread::scope(|scope| {
            let w = self.candidates[self.best()].settings.clone();
            self.evaluate(1, vary(&w, &space.penalties, |s, p| s.penalty = p));
            let w = self.candidates[self.best()].settings.clone();
            self.evaluate(1, vary(&w, &space.encodings, |s, e| s.encoding = e));
            if with_rbf && let Some(p) = best_pose_mlp(&self.candidates) {
                let e = self.candidates[p].settings.encoding;
                let start = space.rbf_start;
                scope.spawn(move || cv.hyper(e, start));
            }
            // Stage 2: hidden units, then a finer penalty step around the best.
            let w = self.candidates[self.best()].settings.clone();
            self.evaluate(2, vary(&w, &space.hiddens, |s, h| s.hidden = h));
            let w = self.candidates[self.best()].settings.clone();
            // (Not where the penalty is fixed, by its flag or by the model alone's having none.)
            if space.penalties.len() > 1 {
                let step = [w.penalty / PENALTY_STEP, w.penalty * PENALTY_STEP].map(significant3);
                self.evaluate(2, vary(&w, &step, |s, p| s.penalty = p));
            }
            self.chosen = self.best();
            // Stage 3: the ensemble. The mean of several networks has at most the mean squared
            // error of its members (convexity), so a tie within ENSEMBLE_TIE goes to the
            // ensemble.
            if self.opts.members.is_none() {
                let single = self.candidates[self.chosen].settings.clone();
                self.evaluate(
                    3,
                    vec![Settings {
                        members: ENSEMBLE_PROBE,
                        ..single
                    }],
                );
                let probe = self.candidates.len() - 1;
                if cv_rms(&self.candidates, probe)
                    <= cv_rms(&self.candidates, self.chosen) * (1.0 + ENSEMBLE_TIE)
                {
                    self.chosen = probe;
                }
            }
        });
    }

    /// Stage 3b: an RBF network from its search start, with the best pose-form MLPs (their
    /// mean and the RBF network's blended at the best share) and alone (unless the MLPs' hidden
    /// units or penalty are given: those ask for MLPs), against the best so
    /// far. The hyperparameters come from all training rows once; each fold fits only the
    /// weights. An error where the network is fixed to a blend and no MLP was fitted.
    pub(super) fn rbf(&mut self) -> Result<()> {
        let space = self.space;
        if !self.candidates.is_empty() {
            self.mlp_chosen = Some(self.chosen);
        }
        let pose_mlp = best_pose_mlp(&self.candidates);
        let first = self.candidates.len();
        let mut list = Vec::new();
        if let Some(p) = pose_mlp {
            list.push(Settings {
                network: Network::Mix,
                rbf_start: space.rbf_start,
                mlp_share: self.opts.mlp_share,
                ..self.candidates[p].settings.clone()
            });
        }
        if !space.mix_only && space.rbf_alone {
            list.push(Settings {
                network: Network::Rbf,
                form: Form::Pose,
                encoding: pose_mlp.map_or(space.base.encoding, |p| {
                    self.candidates[p].settings.encoding
                }),
                hidden: 0,
                penalty: 0.0,
                members: 1,
                rbf_start: space.rbf_start,
                refine: space.refines[0].clone(),
                mlp_share: None,
            });
        }
        searches(self.race.cv, &list);
        self.evaluate(3, list);
        let new = first..self.candidates.len();
        self.chosen = if space.mix_only {
            // The network is fixed: the best of its own candidates, which need pose-form MLPs.
            if !new.clone().any(|i| self.candidates[i].score.is_some()) {
                return Err(Error::Invalid(
                    "a mixed network: no pose-form MLP was fitted to mix the RBF network with \
                     (no members asked for, or every MLP candidate failed)"
                        .into(),
                ));
            }
            better(&self.candidates, first, new)
        } else {
            better(&self.candidates, self.chosen, new)
        };
        Ok(())
    }

    /// Stage 4: refinement, judged for the network it will carry (early in the search, with
    /// an unregularised single network, it looked worse where it finally helped 1.3x; judged
    /// with one network instead of the ensemble, it lost by 0.6 % where the ensemble kept it
    /// 1.1 % better on held-out real data). The leader is refined, and the best of the other
    /// family (the MLPs' choice where the leader carries an RBF network, the best network
    /// with an RBF network where it does not) where the refinement could carry it past the
    /// leader ([`Search::may_overtake`]): a refinement changes the residual the networks
    /// learn, and the two families answer it differently. On a simulated FANUC with joint
    /// compliance and gear errors (2000 poses, the shipped non-geometric robot's errors, 1000
    /// test poses), the RBF network led unrefined (0.0915 mm against the MLPs' 0.1669) and was
    /// the only one refined (0.0755 with the compliances), while the MLPs refined with the
    /// compliances reach 0.0655; against the truth 0.0276 against 0.0245 mm RMS, 0.0072
    /// against 0.0033 deg.
    pub(super) fn refinement(&mut self) {
        let space = self.space;
        let leader = self.chosen;
        let w = self.candidates[leader].settings.clone();
        let first = self.candidates.len();
        let mut list = self.refinements_of(&w);
        if !space.rbf_only && !space.mix_only {
            let rival = if w.has_rbf() {
                self.mlp_chosen
            } else {
                best_where(&self.candidates[..first], Settings::has_rbf, |c, i| {
                    self.judged(c, i)
                })
            }
            .filter(|&r| {
                r != leader && self.candidates[r].score.is_some() && self.may_overtake(leader, r)
            });
            if let Some(r) = rival {
                let rs = self.candidates[r].settings.clone();
                list.extend(self.refinements_of(&rs));
            }
        }
        self.evaluate(4, list);
        // A fixed mixed network stays one.
        let mix_only = space.mix_only;
        let eligible = |candidates: &[Candidate], i: usize| {
            if mix_only && candidates[i].settings.network != Network::Mix {
                f64::INFINITY
            } else {
                self.judged(candidates, i)
            }
        };
        let best = better_by(
            &self.candidates,
            self.chosen,
            first..self.candidates.len(),
            eligible,
        );
        self.chosen = self.refinement_test_of(best, leader);
    }

    /// Candidate `refined` (ranked first, its model refined) against `base` (the best
    /// candidate without that refinement), both judged as every candidate is: the refinement
    /// is kept where lower by [`REFINEMENT_MARGIN`] and significantly lower row by row
    /// ([`REFINEMENT_Z`]); the candidate kept. A refinement re-estimates parameters on the
    /// training rows that act everywhere, and cross-validation of a few rows (or of rows
    /// from one region) ranks a refinement first by chance: on 30 rows of the real UR10,
    /// `full` 3.8 % ahead in cross-validation (28 parameters) raised the error on 495
    /// held-out rows from 0.4557 to 0.8379 mm RMS, and on an exact model measured with noise
    /// 0.14 % ahead it moved the model 0.011 mm from the truth.
    fn refinement_test_of(&mut self, refined: usize, base: usize) -> usize {
        let (kept, test) = self.refinement_choice(refined, base);
        self.refinement_tests.extend(test);
        kept
    }

    /// [`Search::refinement_test_of`]'s choice and its test (none where there was nothing to
    /// test), without recording the test.
    fn refinement_choice(&self, refined: usize, base: usize) -> (usize, Option<NetworkTest>) {
        let c = &self.candidates;
        if refined == base
            || c[refined].settings.refine == c[base].settings.refine
            || c[refined].settings.refine.is_none()
            || !self.judged(c, base).is_finite()
        {
            return (refined, None);
        }
        let (test, _) = self.test_of(refined, base, REFINEMENT_MARGIN, REFINEMENT_Z);
        (if test.kept { refined } else { base }, Some(test))
    }

    /// The refinements of candidate settings `w` to try: each of the space's, or for a blend
    /// the best by its proxies and its own (see below).
    fn refinements_of(&mut self, w: &Settings) -> Vec<Settings> {
        let refines = &self.space.refines;
        // A mixed network's share is chosen again for each other refinement.
        let share = self.opts.mlp_share;
        let other = |s: &mut Settings, r: Option<String>| {
            if s.network == Network::Mix && s.refine != r {
                s.mlp_share = share;
            }
            s.refine = r;
        };
        let mut list = vary(w, refines, other);
        if w.network == Network::Mix {
            // A blend's MLPs cost most of its fits, and a refinement changes the residual they
            // learn. The refinements are judged first with the RBF network alone (the blend's
            // larger part: shares of 0.05-0.4 on real data) on the race folds, where every
            // candidate has been scored, and only the best of them is tried with the blend.
            // These proxies are fitted on the race folds only: the blend tried with the best
            // refinement is the candidate (on Series A's pool of 2000, the proxies' other
            // folds were 0.8 s of a 7.2 s training).
            let alone = Settings {
                network: Network::Rbf,
                hidden: 0,
                penalty: 0.0,
                members: 1,
                mlp_share: None,
                ..w.clone()
            };
            self.race.proxies(
                4,
                vary(&alone, refines, |s, r| s.refine = r),
                &mut self.candidates,
            );
            let proxy = |r: &Option<String>| {
                let raced = self
                    .candidates
                    .iter()
                    .find(|c| {
                        c.settings
                            == Settings {
                                refine: r.clone(),
                                ..alone.clone()
                            }
                    })
                    .and_then(|c| c.race.as_ref());
                raced.map_or(f64::INFINITY, |t| t.score().position_rms_mm) * self.margin(r)
            };
            let best = refines
                .iter()
                .min_by(|a, b| proxy(a).total_cmp(&proxy(b)))
                .cloned();
            list.retain(|s| s.refine == w.refine || Some(&s.refine) == best.as_ref());
        }
        list
    }

    /// Whether a refinement could carry candidate `rival` past the candidate `leader` (both
    /// unrefined, stages 1-3): whether for some refinement the rival's cross-validated mean
    /// square, less the part of the model alone's that the refinement removes (on the
    /// held-out rows, as stage 5 scores the model alone), judged with the refinement's margin,
    /// falls below the leader's. A refinement removes from a network's residual about what
    /// it removes from the model's, less what the network had learnt of it. On real tracker
    /// data a refinement removes little (Series A's pool of 2000: the model alone's RMS 0.4379
    /// -> 0.4208 mm with the compliances), far less than the MLPs trail the RBF network by
    /// (0.2263 against 0.1412 mm), and the MLPs' refinements are not tried (tried, they took the
    /// training from 7.1-7.8 s to 8.85 s there and changed nothing); on the simulated compliant
    /// robot above the compliances take the model alone from 0.5107 to 0.0815 mm, more than
    /// the whole of the MLPs' 0.1669. Where a score cannot be had, the rival is tried.
    fn may_overtake(&self, leader: usize, rival: usize) -> bool {
        let w = &self.candidates[leader].settings;
        let mean_square = |r: &Option<String>| {
            let alone = Settings {
                refine: r.clone(),
                ..model_alone_of(w)
            };
            Some(mean(&squares(&self.race.held_rows(&alone).ok()?)))
        };
        let Some(unrefined) = mean_square(&w.refine) else {
            return true;
        };
        let lead = self.judged(&self.candidates, leader);
        let rival = cv_rms(&self.candidates, rival).powi(2);
        self.space
            .refines
            .iter()
            .filter(|r| **r != w.refine)
            .any(|r| {
                mean_square(r).is_none_or(|m| {
                    (rival - (unrefined - m)).max(0.0).sqrt() * self.margin(r) < lead
                })
            })
    }

    /// Stage 5: the model alone, without a network, as given and refined (no fits: a refined
    /// model alone can win where the refined model with a network lost the race). A network
    /// must beat the best of them by [`NETWORK_MARGIN`] in cross-validated RMS, and row by
    /// row with a paired z of [`NETWORK_Z`] or more, to be kept; one with an RBF network, on
    /// held-out rows no hyperparameter search saw as well ([`Search::unseen_test`], which
    /// searches and fits again where the folds must search their own).
    ///
    /// With the network `fixed` (`--members` given) the network chosen is kept, and only
    /// held against the model alone ([`Search::fixed_network_test`]), for the user to know.
    pub(super) fn model_alone(&mut self, fixed: bool) {
        if fixed && !self.candidates[self.chosen].settings.has_network() {
            return;
        }
        let alone = model_alone_of(&self.candidates[self.chosen].settings);
        let first = self.candidates.len();
        self.evaluate(5, vary(&alone, &self.space.refines, |s, r| s.refine = r));
        let new = first..self.candidates.len();
        if new.is_empty() {
            return;
        }
        let best_alone = better_by(&self.candidates, first, new.clone(), |c, i| {
            self.judged(c, i)
        });
        // The model as given, where it is a candidate: a refined model alone must beat it as
        // a refinement must.
        // With the network fixed no model alone is chosen: its refinement's test is no
        // choice to tell of, and is not recorded.
        let best_alone = match new
            .clone()
            .find(|&i| self.candidates[i].settings.refine.is_none())
        {
            Some(given) if fixed => self.refinement_choice(best_alone, given).0,
            Some(given) => self.refinement_test_of(best_alone, given),
            None => best_alone,
        };
        if !self.candidates[self.chosen].settings.has_network() {
            if self.judged(&self.candidates, best_alone)
                < self.judged(&self.candidates, self.chosen)
            {
                self.chosen = best_alone;
            }
            return;
        }
        // A model alone that failed on some fold cannot replace the network.
        if !self.judged(&self.candidates, best_alone).is_finite() {
            return;
        }
        let (mut test, mut rows) = self.network_test_of(self.chosen, best_alone);
        if fixed {
            self.fixed_network_test = Some(test);
            return;
        }
        // A network with an RBF network that passed on the candidates' figures: its
        // hyperparameters saw the rows the folds hold out, so it is judged again on rows no
        // search saw. Where it fails there, the best network without one (whose figures never
        // saw their rows), unless the network is fixed to one with an RBF network, is held
        // against the model alone instead.
        if test.kept && self.candidates[test.network].settings.has_rbf() {
            match self.unseen_test(test.clone(), rows.as_deref()) {
                Ok(t) if t.kept => test = t,
                Ok(t) => {
                    let fixed = self.space.rbf_only || self.space.mix_only;
                    // Refined as the network tested or not at all: another refinement did
                    // not pass its test (stage 4 tests the leader's alone; a helper's).
                    let refine = self.candidates[test.network].settings.refine.clone();
                    let other = best_where(
                        &self.candidates,
                        |c| {
                            !fixed
                                && c.has_network()
                                && !c.has_rbf()
                                && (c.refine.is_none() || c.refine == refine)
                        },
                        |c, i| self.judged(c, i),
                    )
                    .filter(|&i| self.judged(&self.candidates, i).is_finite());
                    (test, rows) = match other {
                        Some(i) => {
                            self.rbf_network_test = Some(t);
                            self.network_test_of(i, best_alone)
                        }
                        None => (t, None),
                    };
                }
                Err(e) => self.unseen_error = Some(e.to_string()),
            }
        }
        self.chosen = if test.kept { test.network } else { best_alone };
        self.chosen_rows = rows;
        self.network_test = Some(test);
    }

    /// Candidate `net` (a network) against `alone` (a model alone) on every held-out row,
    /// both judged as every candidate is (a refinement with the compliances that
    /// cross-validation adds on its own carries [`COMPLIANCE_MARGIN`] on either side): kept
    /// where lower by [`NETWORK_MARGIN`] and significantly lower row by row ([`NETWORK_Z`]).
    /// With it, the held-out rows of the one it keeps, fold by fold, where they could be had
    /// again as they were scored.
    fn network_test_of(
        &self,
        net: usize,
        alone: usize,
    ) -> (NetworkTest, Option<Vec<Vec<RowError>>>) {
        self.test_of(net, alone, NETWORK_MARGIN, NETWORK_Z)
    }

    /// Candidate `net` against candidate `alone` on every held-out row, both judged as every
    /// candidate is: kept where lower by `margin` (relative) and with a paired z of `-z` or
    /// lower ([`Search::network_test_of`]'s test, with its margin and level as given).
    fn test_of(
        &self,
        net: usize,
        alone: usize,
        margin: f64,
        level: f64,
    ) -> (NetworkTest, Option<Vec<Vec<RowError>>>) {
        let ratio = self.judged(&self.candidates, net) / self.judged(&self.candidates, alone);
        // Each fold's held-out errors: the rows that gave the candidate's score (its fits
        // are cached), checked against it.
        // With them, each row's squared position error (mm^2), fold after fold.
        let held = |i: usize| -> Option<(Vec<Vec<RowError>>, Vec<f64>)> {
            let folds = self.race.held_rows(&self.candidates[i].settings).ok()?;
            let squares = squares(&folds);
            let rms = root_mean(&squares);
            let scored = cv_rms(&self.candidates, i);
            ((rms - scored).abs() <= 1e-9 * scored.max(1e-12)).then_some((folds, squares))
        };
        let (network, alone_rows) = (held(net), held(alone));
        let clusters = self.clusters();
        let paired = match (&network, &alone_rows) {
            (Some((_, a)), Some((_, b))) => Some((paired_z(a, b, &clusters), a.len())),
            _ => None,
        };
        // Where the rows cannot be had again as they were scored (not expected: every fit
        // is cached), the margin alone decides, as it did before the test.
        let significant = paired.is_none_or(|(z, _)| z <= -level);
        let (z, rows) = paired.unwrap_or((f64::NAN, 0));
        let kept = ratio * (1.0 + margin) <= 1.0 && significant;
        let test = NetworkTest {
            network: net,
            alone,
            ratio,
            z,
            rows,
            configurations: if rows > 0 {
                super::rows::distinct(&clusters)
            } else {
                0
            },
            kept,
            unseen: None,
        };
        (
            test,
            if kept { network } else { alone_rows }.map(|(folds, _)| folds),
        )
    }

    /// Each held-out row's arm configuration, fold after fold.
    fn clusters(&self) -> Vec<usize> {
        let cv = self.race.cv;
        (cv.held_index.concat().iter())
            .map(|&i| cv.groups[i])
            .collect()
    }

    /// `t`, a network with an RBF network kept on the candidates' figures, tested again as
    /// [`Search::network_test_of`] on held-out rows whose values neither its weights nor its
    /// hyperparameters saw ([`Cv::unseen`](super::cv::Cv::unseen)): `t` with its figures there
    /// and their verdict. `held`: the network's held-out rows as scored, where they are had.
    fn unseen_test(&self, t: NetworkTest, held: Option<&[Vec<RowError>]>) -> Result<NetworkTest> {
        let net = &self.candidates[t.network].settings;
        let alone = &self.candidates[t.alone].settings;
        let (a, unseen) = match (self.race.cv.unseen(net.encoding)?, held) {
            (Some(unseen), Some(held)) => (squares(held), Some(unseen)),
            (Some(unseen), None) => (squares(&self.race.held_rows(net)?), Some(unseen)),
            (None, _) => (
                squares(&self.race.held_rows_as(net, Hypers::FoldRows)?),
                None,
            ),
        };
        let b = squares(&self.race.held_rows(alone)?);
        let order = self.race.cv.held_index.concat();
        if a.len() != order.len() || b.len() != order.len() {
            return Err(Error::Invalid(format!(
                "{} and {} held-out rows of the network and the model alone, of {}",
                a.len(),
                b.len(),
                order.len()
            )));
        }
        let clusters = self.clusters();
        let rows: Vec<usize> = (0..order.len())
            .filter(|&k| unseen.as_ref().is_none_or(|u| u[order[k]]))
            .collect();
        let pick = |v: &[f64]| -> Vec<f64> { rows.iter().map(|&k| v[k]).collect() };
        let (a, b, clusters) = (
            pick(&a),
            pick(&b),
            rows.iter().map(|&k| clusters[k]).collect::<Vec<_>>(),
        );
        let ratio =
            root_mean(&a) * self.margin(&net.refine) / (root_mean(&b) * self.margin(&alone.refine));
        let z = paired_z(&a, &b, &clusters);
        Ok(NetworkTest {
            kept: ratio * (1.0 + NETWORK_MARGIN) <= 1.0 && z <= -NETWORK_Z,
            unseen: Some(UnseenTest {
                by: if unseen.is_some() {
                    Unseen::Rows
                } else {
                    Unseen::Folds
                },
                ratio,
                z,
                rows: rows.len(),
                configurations: super::rows::distinct(&clusters),
            }),
            ..t
        })
    }
}

/// The settings of the model alone, without a network, as `w` names the model and its
/// refinement.
pub(super) fn model_alone_of(w: &Settings) -> Settings {
    Settings {
        network: Network::Mlp,
        members: 0,
        rbf_start: None,
        mlp_share: None,
        ..w.clone()
    }
}

/// The mean of `values` (0 for none).
fn mean(values: &[f64]) -> f64 {
    values.iter().sum::<f64>() / values.len().max(1) as f64
}

/// The root of the mean of `squares` (0 for none).
fn root_mean(squares: &[f64]) -> f64 {
    mean(squares).sqrt()
}

/// Each held-out row's squared position error (mm^2), fold after fold.
fn squares(folds: &[Vec<RowError>]) -> Vec<f64> {
    folds
        .iter()
        .flatten()
        .map(|r| r.position_mm.unwrap_or(0.0).powi(2))
        .collect()
}
