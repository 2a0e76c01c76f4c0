//! Type-II maximum likelihood of each output's Gaussian process: L-BFGS on the log
//! hyperparameters from one of [`STARTS`], from all of them, or from given hyperparameters
//! ([`search_from`]: the final fit's search without the rows it leaves out), on at most
//! [`HYPER_ROWS`] rows.

use super::Covariance;
use super::likelihood::{Pairs, Scratch, neg_log_likelihood_in, prior_mean};
use super::{Hyper, check_hyper, shape};
use crate::error::{Error, Result};
use crate::neural::lbfgs::{Next, minimize};
use crate::neural::parallel::parallel_map;
use crate::neural::samples::Samples;
use faer::Mat;
use rand::SeedableRng;
use rand::seq::SliceRandom;
use rand_chacha::ChaCha8Rng;

/// Rows on which the hyperparameters are fitted at most by default ([`Draw::seeded`]; the
/// rest only enter the weights).
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
/// without a start takes, output by output, the start of highest likelihood. A final fit that
/// leaves rows out begins at the hyperparameters cross-validation judged instead
/// ([`search_from`]).
pub const STARTS: [(f64, f64); 3] = [(1.0, 0.5), (0.2, 0.05), (0.05, 0.01)];

/// Which rows of a set a hyperparameter search sees, and the covariance function whose
/// hyperparameters it fits: every row of a set of at most `rows`, else `rows` of them drawn
/// by a shuffle seeded by `seed`. A search's cost is cubic in its rows (a Cholesky factor and
/// an inverse of the n x n kernel matrix per evaluation).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Draw {
    /// Seed of the shuffle.
    pub seed: u64,
    /// Rows searched at most (at least 2).
    pub rows: usize,
    /// The covariance function.
    pub covariance: Covariance,
}

impl Draw {
    /// The default draw of `seed`: at most [`HYPER_ROWS`] rows, [`Covariance::DEFAULT`].
    pub fn seeded(seed: u64) -> Draw {
        Draw {
            seed,
            rows: HYPER_ROWS,
            covariance: Covariance::DEFAULT,
        }
    }
}

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
/// hyperparameters, [`HYPER_ITERATIONS`] at most) on the rows of `s` that `draw` picks. The
/// objective is the sum of the outputs'.
pub fn search(s: &Samples, start: usize, draw: Draw) -> Result<Search> {
    search_without(s, start, draw, &[])
}

/// [`search()`] on `s`, a set from which the rows `left_out` (indices in the whole set) were
/// taken out: the rows searched are those the search of the whole set draws, but those left
/// out (the hyperparameters of the set without a few mis-measured rows, not those of another
/// draw of rows).
pub fn search_without(s: &Samples, start: usize, draw: Draw, left_out: &[usize]) -> Result<Search> {
    let one = Searches::new(s, draw, left_out)?;
    let found = parallel_map(one.outputs, |j| one.output(j, Begin::Start(start)));
    Ok(join(found.into_iter().collect::<Result<Vec<_>>>()?))
}

/// [`search_without`] started at the hyperparameters `from` (every output's, see
/// [`Hyper`]) instead of at a start: those of a search on nearly the same rows, whose mode
/// it follows (a few steps where the rows differ little).
pub fn search_from(s: &Samples, from: &Hyper, draw: Draw, left_out: &[usize]) -> Result<Search> {
    let one = Searches::new(s, draw, left_out)?;
    check_hyper(from, one.pairs.inputs(), one.outputs)?;
    let block = one.pairs.inputs() + 2;
    let found = parallel_map(one.outputs, |j| {
        one.output(j, Begin::At(from.rows(j * block, block).into_owned()))
    });
    Ok(join(found.into_iter().collect::<Result<Vec<_>>>()?))
}

/// Where one output's search begins.
enum Begin {
    /// At [`STARTS`]`[k]`.
    Start(usize),
    /// At these hyperparameters (the output's d + 2).
    At(Hyper),
}

/// The searches from every start (in parallel), keeping for each output the one of highest
/// likelihood.
pub fn search_best(s: &Samples, draw: Draw) -> Result<Search> {
    search_best_without(s, draw, &[])
}

/// [`search_best`] on a set from which the rows `left_out` were taken out, as
/// [`search_without`].
pub fn search_best_without(s: &Samples, draw: Draw, left_out: &[usize]) -> Result<Search> {
    let one = Searches::new(s, draw, left_out)?;
    let (o, starts) = (one.outputs, STARTS.len());
    let all = parallel_map(o * starts, |i| {
        one.output(i / starts, Begin::Start(i % starts))
    });
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

/// [`search_without`] from [`STARTS`]`[k]` for `start` Some(k), else [`search_best_without`].
pub fn search_start_without(
    s: &Samples,
    start: Option<usize>,
    draw: Draw,
    left_out: &[usize],
) -> Result<Search> {
    match start {
        Some(k) => search_without(s, k, draw, left_out),
        None => search_best_without(s, draw, left_out),
    }
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
    covariance: Covariance,
}

impl<'a> Searches<'a> {
    fn new(s: &'a Samples, draw: Draw, left_out: &[usize]) -> Result<Searches<'a>> {
        let (n, _, outputs) = shape(s)?;
        if draw.rows < 2 {
            return Err(Error::Invalid(format!(
                "the RBF network's hyperparameter search on {} rows: it needs at least 2",
                draw.rows
            )));
        }
        let mut left_out = left_out.to_vec();
        left_out.sort_unstable();
        left_out.dedup();
        // The whole set's rows, drawn as its own search draws them.
        let whole = n + left_out.len();
        if let Some(&last) = left_out.last()
            && last >= whole
        {
            return Err(Error::Invalid(format!(
                "the RBF network's hyperparameter search: row {last} left out of a set of \
                 {whole} rows"
            )));
        }
        let mut rows: Vec<usize> = (0..whole).collect();
        if whole > draw.rows {
            rows.shuffle(&mut ChaCha8Rng::seed_from_u64(draw.seed ^ 0x7bf));
            rows.truncate(draw.rows);
            rows.sort_unstable();
        }
        // Those left out dropped, the others numbered as in `s`.
        let rows: Vec<usize> = rows
            .into_iter()
            .filter(|r| left_out.binary_search(r).is_err())
            .map(|r| r - left_out.partition_point(|&o| o < r))
            .collect();
        if rows.len() < 2 {
            return Err(Error::Invalid(format!(
                "the RBF network's hyperparameter search: {} rows left out of {whole} leave {} \
                 to search on",
                left_out.len(),
                rows.len()
            )));
        }
        let pairs = Pairs::new(&s.x, &rows);
        Ok(Searches {
            s,
            outputs,
            rows,
            pairs,
            covariance: draw.covariance,
        })
    }

    /// Output `j`'s search from `begin`: its d + 2 hyperparameters.
    fn output(&self, j: usize, begin: Begin) -> Result<Search> {
        let d = self.pairs.inputs();
        let y = Mat::<f64>::from_fn(self.rows.len(), 1, |i, _| self.s.b[self.rows[i]][j]);
        let square: f64 = (0..self.rows.len()).map(|i| y[(i, 0)] * y[(i, 0)]).sum();
        let var = (square / self.rows.len() as f64).max(1e-12);
        let prior = prior_mean(d, var);
        let h0 = match begin {
            Begin::Start(start) => {
                let Some(&(width, noise)) = STARTS.get(start) else {
                    return Err(Error::Invalid(format!(
                        "RBF search start {start}: there are {} starts",
                        STARTS.len()
                    )));
                };
                let mut h0 = Hyper::from_element(d + 2, width.ln());
                h0[d] = var.ln();
                h0[d + 1] = (noise * var).ln();
                h0
            }
            Begin::At(h) => h,
        };
        let (mut last, mut idle) = (f64::INFINITY, 0);
        let mut scratch = Scratch::new(self.rows.len(), 1);
        let (hyper, objective, _) = minimize(
            h0,
            8,
            HYPER_ITERATIONS,
            1e-6,
            |h, g| {
                neg_log_likelihood_in(
                    &self.pairs,
                    &y,
                    h,
                    &prior,
                    self.covariance,
                    Some(g),
                    &mut scratch,
                )
            },
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

    /// A set without a few rows searches on the whole set's draw of rows but those: the same
    /// rows, numbered in the smaller set, and the same search as on the whole set when none
    /// is left out.
    #[test]
    fn a_search_without_rows_draws_the_whole_sets_rows_but_those() {
        let (whole, _) = data(HYPER_ROWS + 100);
        let drawn = Searches::new(&whole, Draw::seeded(7), &[]).unwrap().rows;
        assert_eq!(drawn.len(), HYPER_ROWS);
        // Two rows of the draw and one outside it left out, given unsorted and twice.
        let outside = (0..whole.len()).find(|r| !drawn.contains(r)).unwrap();
        let left_out = vec![drawn[300], outside, drawn[3], drawn[300]];
        let mut less = whole.clone();
        let mut gone = left_out.clone();
        gone.sort_unstable();
        gone.dedup();
        for &r in gone.iter().rev() {
            less.x.remove(r);
            less.b.remove(r);
        }
        let rows = Searches::new(&less, Draw::seeded(7), &left_out)
            .unwrap()
            .rows;
        assert_eq!(rows.len(), HYPER_ROWS - 2);
        // Each row searched is the same measurement as the whole set's drawn row.
        let expected: Vec<&Vec<f64>> = drawn
            .iter()
            .filter(|r| !gone.contains(r))
            .map(|&r| &whole.x[r])
            .collect();
        let got: Vec<&Vec<f64>> = rows.iter().map(|&r| &less.x[r]).collect();
        assert_eq!(got, expected);
        // A small set: every row but those left out.
        let (small, _) = data(30);
        let mut fewer = small.clone();
        fewer.x.remove(4);
        fewer.b.remove(4);
        let rows = Searches::new(&fewer, Draw::seeded(7), &[4]).unwrap().rows;
        assert_eq!(rows, (0..29).collect::<Vec<_>>());
        assert_eq!(
            search_without(&fewer, 0, Draw::seeded(7), &[4]).unwrap(),
            search(&fewer, 0, Draw::seeded(7)).unwrap()
        );
        // An index beyond the whole set is refused, on a small set and on a large one.
        assert!(Searches::new(&fewer, Draw::seeded(7), &[29, 31]).is_err());
        assert!(Searches::new(&less, Draw::seeded(7), &[drawn[3], whole.len() + 50]).is_err());
    }

    /// A search begun at given hyperparameters is, output by output, the search from them:
    /// begun where a start begins, it is that start's search bit for bit; begun at another
    /// search's result, it ends no worse. A start of the wrong length or not finite is
    /// refused.
    #[test]
    fn a_search_from_hyperparameters_continues_there() {
        let (s, _) = data(80);
        let d = s.x[0].len();
        for (k, &(width, noise)) in STARTS.iter().enumerate() {
            let mut h0 = Hyper::zeros(s.rows() * (d + 2));
            for j in 0..s.rows() {
                let square: f64 = s.b.iter().map(|b| b[j] * b[j]).sum();
                let var = (square / s.len() as f64).max(1e-12);
                let at = j * (d + 2);
                h0.rows_mut(at, d).fill(width.ln());
                h0[at + d] = var.ln();
                h0[at + d + 1] = (noise * var).ln();
            }
            assert_eq!(
                search_from(&s, &h0, Draw::seeded(1), &[]).unwrap(),
                search(&s, k, Draw::seeded(1)).unwrap()
            );
        }
        let cold = search(&s, 1, Draw::seeded(1)).unwrap();
        let warm = search_from(&s, &cold.hyper, Draw::seeded(1), &[]).unwrap();
        assert!(
            warm.objective <= cold.objective,
            "{} {}",
            warm.objective,
            cold.objective
        );
        assert!(
            search_from(
                &s,
                &cold.hyper.rows(0, 3).into_owned(),
                Draw::seeded(1),
                &[]
            )
            .is_err()
        );
        let mut bad = cold.hyper.clone();
        bad[0] = f64::NAN;
        assert!(search_from(&s, &bad, Draw::seeded(1), &[]).is_err());
    }

    #[test]
    fn the_best_search_takes_each_outputs_lowest_objective_of_the_starts() {
        let (s, _) = data(80);
        let all: Vec<Search> = (0..STARTS.len())
            .map(|k| search(&s, k, Draw::seeded(1)).unwrap())
            .collect();
        let best = search_best(&s, Draw::seeded(1)).unwrap();
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
                .map(|k| search(&one, k, Draw::seeded(1)).unwrap())
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
        assert_eq!(
            rbf,
            Rbf::with_hyper(&s, &all[1].hyper, Covariance::DEFAULT).unwrap()
        );
        assert!(search(&s, STARTS.len(), Draw::seeded(1)).is_err());
        assert!(
            Rbf::with_hyper(
                &s,
                &all[1].hyper.rows(0, block).into_owned(),
                Covariance::DEFAULT
            )
            .is_err()
        );
    }
}
