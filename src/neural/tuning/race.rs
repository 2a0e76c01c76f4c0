//! The race that scores candidates on the cross-validation folds.

use super::cv::{Cv, Hypers};
use super::rows::held_errors;
use super::shares::{add_shares, best_share, open_share};
use super::{RACE_MARGIN, SHARES};
use crate::error::{Error, Result};
use crate::evaluate::RowError;
use crate::model::Robot;
use crate::neural::parallel::parallel_map;
use crate::neural::selection::{Candidate, Sums};
use crate::neural::settings::Settings;
use std::collections::HashMap;
use std::sync::atomic::{AtomicUsize, Ordering};

/// The race that scores candidates: each is fitted on the race folds first and dropped there
/// when clearly worse than the best so far on the same folds ([`RACE_MARGIN`]); survivors
/// are fitted on the other folds (proxies, [`Race::proxies`], never are).
pub(super) struct Race<'a, 'c> {
    pub(super) cv: &'a Cv<'c>,
    /// Each refinement candidates can name, with its model per fold (the first alone until
    /// the others' models are in, see [`super::select_settings`]).
    pub(super) refined: Vec<(Option<String>, Vec<Result<Robot>>)>,
    /// Folds.
    pub(super) k: usize,
    /// Race folds.
    pub(super) race: usize,
    /// Fold fits done (for progress).
    pub(super) done: AtomicUsize,
    /// Evaluation rounds so far (warm starts come from earlier rounds).
    pub(super) rounds: &'a AtomicUsize,
    pub(super) progress: &'a (dyn Fn(usize, usize) + Sync),
}

impl Race<'_, '_> {
    /// Fold `fold`'s model under the refinement `refine` (the first refinement's where the
    /// race does not hold `refine`).
    fn model(&self, refine: &Option<String>, fold: usize) -> Result<&Robot> {
        let (_, models) = (self.refined.iter())
            .find(|(r, _)| r == refine)
            .unwrap_or(&self.refined[0]);
        models[fold]
            .as_ref()
            .map_err(|e| Error::Invalid(e.to_string()))
    }

    /// Held-out errors of `settings` on every fold, fold by fold, in each fold's row order
    /// (the folds' fits are cached: predicting is the work, folds in parallel).
    pub(super) fn held_rows(&self, settings: &Settings) -> Result<Vec<Vec<RowError>>> {
        self.held_rows_as(settings, Hypers::AllRows)
    }

    /// [`Race::held_rows`] with an RBF network's hyperparameters searched on `hypers`.
    pub(super) fn held_rows_as(
        &self,
        settings: &Settings,
        hypers: Hypers,
    ) -> Result<Vec<Vec<RowError>>> {
        let round = self.rounds.load(Ordering::Relaxed);
        parallel_map(self.k, |f| {
            let model = self.model(&settings.refine, f)?;
            let c = self.cv.fit_as(f, settings, model, round, hypers)?;
            let mut ws = Default::default();
            held_errors(&self.cv.held[f], |q| c.predict(q, &mut ws))
        })
        .into_iter()
        .collect()
    }

    /// Scores the settings of `list` not yet in `candidates` and appends them (stage
    /// `stage`).
    pub(super) fn evaluate(
        &self,
        stage: usize,
        list: Vec<Settings>,
        candidates: &mut Vec<Candidate>,
    ) {
        self.score(stage, list, candidates, false);
    }

    /// Scores the settings of `list` not yet in `candidates` on the race folds only and
    /// appends them as proxies, never chosen ([`Candidate::proxy`]; stage `stage`).
    pub(super) fn proxies(
        &self,
        stage: usize,
        list: Vec<Settings>,
        candidates: &mut Vec<Candidate>,
    ) {
        self.score(stage, list, candidates, true);
    }

    /// [`Race::evaluate`], or [`Race::proxies`] with `proxy`.
    fn score(
        &self,
        stage: usize,
        list: Vec<Settings>,
        candidates: &mut Vec<Candidate>,
        proxy: bool,
    ) {
        let list: Vec<Settings> = list
            .into_iter()
            .filter(|s| !candidates.iter().any(|c| &c.settings == s))
            .collect();
        let folds = if proxy { self.race } else { self.k };
        let total_now = self.done.load(Ordering::Relaxed) + list.len() * folds;
        let round = self.rounds.fetch_add(1, Ordering::Relaxed);
        let run = |jobs: &[(usize, usize)]| {
            parallel_map(jobs.len(), |j| {
                let (c, f) = jobs[j];
                let s = &list[c];
                let out = self
                    .model(&s.refine, f)
                    .and_then(|m| self.cv.run(f, s, m, round));
                (self.progress)(self.done.fetch_add(1, Ordering::Relaxed) + 1, total_now);
                out
            })
        };
        let fold_jobs = |cs: &[usize], fs: std::ops::Range<usize>| -> Vec<(usize, usize)> {
            cs.iter()
                .flat_map(|&c| fs.clone().map(move |f| (c, f)))
                .collect()
        };
        let all: Vec<usize> = (0..list.len()).collect();
        let first = fold_jobs(&all, 0..self.race);
        let mut results: HashMap<(usize, usize), Result<Vec<Sums>>> =
            first.iter().copied().zip(run(&first)).collect();
        // Over the race folds, at the candidate's best share.
        let race_sums = |c: usize, results: &HashMap<(usize, usize), Result<Vec<Sums>>>| {
            let mut t = Vec::new();
            for f in 0..self.race {
                add_shares(&mut t, results[&(c, f)].as_ref().ok()?);
            }
            Some(best_share(&t).1)
        };
        let rms = |t: &Sums| t.score().position_rms_mm;
        let reference = candidates
            .iter()
            .filter(|c| c.score.is_some())
            .filter_map(|c| c.race.as_ref().map(rms))
            .chain(
                all.iter()
                    .filter_map(|&c| race_sums(c, &results).as_ref().map(rms)),
            )
            .fold(f64::INFINITY, f64::min);
        let survivors: Vec<usize> = all
            .iter()
            .copied()
            .filter(|&c| {
                // The model alone fits nothing: nothing to save by dropping it.
                !proxy
                    && race_sums(c, &results).is_some_and(|t| {
                        list[c].members == 0 || rms(&t) <= reference * (1.0 + RACE_MARGIN)
                    })
            })
            .collect();
        let rest = fold_jobs(&survivors, self.race..self.k);
        results.extend(rest.iter().copied().zip(run(&rest)));
        (self.progress)(total_now, total_now);
        self.done.store(total_now, Ordering::Relaxed);
        for (c, mut s) in list.into_iter().enumerate() {
            let raced = race_sums(c, &results);
            let mut total = Vec::new();
            let mut error = None;
            for f in 0..self.k {
                match results.get(&(c, f)) {
                    Some(Ok(x)) => add_shares(&mut total, x),
                    Some(Err(e)) => error = Some(e.to_string()),
                    None => {}
                }
            }
            let (share, total) = best_share(&total);
            if open_share(&s) && error.is_none() && total.rows > 0 {
                s.mlp_share = Some(SHARES[share]);
            }
            let kept = survivors.contains(&c);
            candidates.push(Candidate {
                stage,
                label: s.describe(),
                settings: s,
                score: (error.is_none() && kept).then(|| total.score()),
                pruned: (error.is_none() && !kept).then(|| total.score()),
                proxy,
                error,
                race: raced,
            });
        }
    }
}
