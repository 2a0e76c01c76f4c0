//! Type-II maximum likelihood of each output's Gaussian process: L-BFGS on the log
//! hyperparameters from one of [`STARTS`] or from all of them, on at most [`HYPER_ROWS`] rows.

use super::likelihood::{Pairs, neg_log_likelihood, prior_mean};
use super::{Hyper, shape};
use crate::error::{Error, Result};
use crate::neural::lbfgs::{Next, minimize};
use crate::neural::parallel::parallel_map;
use crate::neural::samples::Samples;
use faer::Mat;
use rand::SeedableRng;
use rand::seq::SliceRandom;
use rand_chacha::ChaCha8Rng;

/// Rows on which the hyperparameters are fitted at most (the rest only enter the weights).
pub const HYPER_ROWS: usize = 500;
/// Gain in log likelihood (nats) below which a search step counts as idle.
pub const STALL_NATS: f64 = 1e-3;
/// L-BFGS iterations of each hyperparameter search.
pub const HYPER_ITERATIONS: usize = 60;

/// Where the hyperparameter searches start: (width of every standardised input, noise
/// variance as a fraction of the targets' mean square). The likelihood has several modes on
/// real tracker data: a smooth one, and rough ones that interpolate between repeated arm
/// configurations with narrow widths on a few joints and almost no noise. Each start leads to
/// one of them. Cross-validation tries the first (smooth) one unless told another; a fit
/// without a start takes, output by output, the start of highest likelihood.
pub const STARTS: [(f64, f64); 3] = [(1.0, 0.5), (0.2, 0.05), (0.05, 0.01)];

/// The result of one hyperparameter search.
#[derive(Debug, Clone, PartialEq)]
pub struct Search {
    /// Every output's [ln l_1 .. ln l_d, ln s^2, ln sigma^2], output after output ([`Hyper`]).
    pub hyper: Hyper,
    /// The minimised objective summed over the outputs: negative log marginal likelihood
    /// plus the prior's term (constants dropped).
    pub objective: f64,
}

/// Type-II maximum likelihood from [`STARTS`]`[start]`, output by output (L-BFGS on the log
/// hyperparameters, [`HYPER_ITERATIONS`] at most) on at most [`HYPER_ROWS`] rows of `s` (a
/// choice seeded by `seed` when there are more). The objective is the sum of the outputs'.
pub fn search(s: &Samples, start: usize, seed: u64) -> Result<Search> {
    let one = Searches::new(s, seed)?;
    let found = parallel_map(one.outputs, |j| one.output(j, start));
    Ok(join(found.into_iter().collect::<Result<Vec<_>>>()?))
}

/// The searches from every start (in parallel), keeping for each output the one of highest
/// likelihood.
pub fn search_best(s: &Samples, seed: u64) -> Result<Search> {
    let one = Searches::new(s, seed)?;
    let (o, starts) = (one.outputs, STARTS.len());
    let all = parallel_map(o * starts, |i| one.output(i / starts, i % starts));
    let mut best = Vec::with_capacity(o);
    let mut all = all.into_iter();
    for _ in 0..o {
        let mut pick: Option<Search> = None;
        let mut last_error = None;
        for r in all.by_ref().take(starts) {
            match r {
                Ok(f) if pick.as_ref().is_none_or(|b| f.objective < b.objective) => pick = Some(f),
                Ok(_) => {}
                Err(e) => last_error = Some(e),
            }
        }
        best.push(
            pick.ok_or_else(|| {
                last_error.unwrap_or_else(|| Error::Invalid("no RBF search".into()))
            })?,
        );
    }
    Ok(join(best))
}

/// The outputs' searches as one: their hyperparameters in output order, objectives summed.
fn join(per_output: Vec<Search>) -> Search {
    let hyper = Hyper::from_iterator(
        per_output.iter().map(|f| f.hyper.len()).sum(),
        per_output.iter().flat_map(|f| f.hyper.iter().copied()),
    );
    Search {
        hyper,
        objective: per_output.iter().map(|f| f.objective).sum(),
    }
}

/// What every output's search shares: the rows searched on and their pairs.
struct Searches<'a> {
    s: &'a Samples,
    /// Outputs of `s` (one search each).
    outputs: usize,
    rows: Vec<usize>,
    pairs: Pairs,
}

impl<'a> Searches<'a> {
    fn new(s: &'a Samples, seed: u64) -> Result<Searches<'a>> {
        let (n, _, outputs) = shape(s)?;
        let mut rows: Vec<usize> = (0..n).collect();
        if n > HYPER_ROWS {
            rows.shuffle(&mut ChaCha8Rng::seed_from_u64(seed ^ 0x7bf));
            rows.truncate(HYPER_ROWS);
            rows.sort_unstable();
        }
        let pairs = Pairs::new(&s.x, &rows);
        Ok(Searches {
            s,
            outputs,
            rows,
            pairs,
        })
    }

    /// Output `j`'s search from [`STARTS`]`[start]`: its d + 2 hyperparameters.
    fn output(&self, j: usize, start: usize) -> Result<Search> {
        let Some(&(width, noise)) = STARTS.get(start) else {
            return Err(Error::Invalid(format!(
                "RBF search start {start}: there are {} starts",
                STARTS.len()
            )));
        };
        let d = self.pairs.inputs();
        let y = Mat::<f64>::from_fn(self.rows.len(), 1, |i, _| self.s.b[self.rows[i]][j]);
        let square: f64 = (0..self.rows.len()).map(|i| y[(i, 0)] * y[(i, 0)]).sum();
        let var = (square / self.rows.len() as f64).max(1e-12);
        let prior = prior_mean(d, var);
        let mut h0 = Hyper::from_element(d + 2, width.ln());
        h0[d] = var.ln();
        h0[d + 1] = (noise * var).ln();
        let (mut last, mut idle) = (f64::INFINITY, 0);
        let (hyper, objective, _) = minimize(
            h0,
            8,
            HYPER_ITERATIONS,
            1e-6,
            |h, g| neg_log_likelihood(&self.pairs, &y, h, &prior, Some(g)),
            |_, value, _| {
                // Likelihood differences of a thousandth of a nat choose nothing: stop when
                // three steps in a row gain less.
                idle = if last - value < STALL_NATS {
                    idle + 1
                } else {
                    0
                };
                last = value;
                if idle >= 3 {
                    Next::Stop
                } else {
                    Next::Continue
                }
            },
        );
        if !objective.is_finite() {
            return Err(Error::Invalid(
                "the RBF network's hyperparameter search diverged".into(),
            ));
        }
        Ok(Search { hyper, objective })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::neural::rbf::Rbf;
    use crate::neural::rbf::tests::data;

    #[test]
    fn the_best_search_takes_each_outputs_lowest_objective_of_the_starts() {
        let (s, _) = data(80);
        let all: Vec<Search> = (0..STARTS.len())
            .map(|k| search(&s, k, 1).unwrap())
            .collect();
        let best = search_best(&s, 1).unwrap();
        let lowest = all
            .iter()
            .map(|f| f.objective)
            .fold(f64::INFINITY, f64::min);
        assert!(best.objective <= lowest, "{} {lowest}", best.objective);
        // Output by output, the start of lowest objective on that output's own column.
        let block = s.x[0].len() + 2;
        let mut total = 0.0;
        for j in 0..s.rows() {
            let mut one = s.clone();
            one.b = s.b.iter().map(|b| vec![b[j]]).collect();
            let own = (0..STARTS.len())
                .map(|k| search(&one, k, 1).unwrap())
                .min_by(|a, b| a.objective.total_cmp(&b.objective))
                .unwrap();
            assert_eq!(
                best.hyper.rows(j * block, block),
                own.hyper.rows(0, block),
                "{j}"
            );
            total += own.objective;
        }
        assert_eq!(best.objective, total);
        // The fit from a start is the network at that start's hyperparameters.
        let (rbf, found) = Rbf::fit(&s, Some(1), 1).unwrap();
        assert_eq!(found, all[1]);
        assert_eq!(rbf, Rbf::with_hyper(&s, &all[1].hyper).unwrap());
        assert!(search(&s, STARTS.len(), 1).is_err());
        assert!(Rbf::with_hyper(&s, &all[1].hyper.rows(0, block).into_owned()).is_err());
    }
}
