//! Type-II maximum likelihood of each output's Gaussian process: L-BFGS on the log
//! hyperparameters from one of [`STARTS`], from all of them, or from given hyperparameters
//! ([`search_from`]: the final fit's search without the rows it leaves out), on the rows
//! [`super::draw`] picks: at most [`HYPER_ROWS`](super::HYPER_ROWS) rows in a block, one per
//! arm configuration.

use super::Covariance;
use super::draw::{Draw, LeftOut, drawn_blocks};
use super::likelihood::{Pairs, Scratch, neg_log_likelihood_in, prior_mean};
use super::{Hyper, check_hyper, shape};
use crate::error::{Error, Result};
use crate::neural::lbfgs::{Next, minimize};
use crate::neural::parallel::parallel_map;
use crate::neural::samples::Samples;
use faer::Mat;
use nalgebra::DVector;

/// Gain in log likelihood (nats) below which a search step counts as idle: of the blocks'
/// summed objective (with K blocks, a stop about K times stricter for each).
pub const STALL_NATS: f64 = 1e-3;
/// L-BFGS iterations of each hyperparameter search.
pub const HYPER_ITERATIONS: usize = 60;

/// Where the hyperparameter searches start: (width of every standardised input, noise
/// variance as a fraction of the targets' mean square). The likelihood has several modes on
/// real tracker data: a smooth one, and rough ones that interpolate between nearby arm
/// configurations (one goal reached with several wrist angles) with narrow widths on a few
/// joints and almost no noise. Each start leads to one of them. Cross-validation tries the
/// first (smooth) one unless told another; a fit without a start takes, output by output, the
/// start of highest likelihood. A final fit that leaves rows out begins at the
/// hyperparameters cross-validation judged instead ([`search_from`]).
pub const STARTS: [(f64, f64); 3] = [(1.0, 0.5), (0.2, 0.05), (0.05, 0.01)];

/// Standard deviation (ln units) of the one-sided prior that holds each width at or above
/// its input's resolution ([`Samples::resolution`]): 0.5 (gap / sd)^2 nats where
/// ln l_d < ln r_d by gap, nothing above. On Series B (every flange kept level within
/// 0.04 deg) the orientation outputs' widths on the flange's gravity components came out at
/// 0.08 of the resolution: a 0.25 deg tilt of the flange, a target any task holds, then
/// moved the orientation correction by 0.5 mrad (its median is 0.74), a feature finer than
/// any configuration the data hold apart. Held there, the held-out position RMS of 11 of 14
/// Series A and B splits measured within 0.6 % of that without it, the other three 0.8, 1.1
/// and 1.7 % above (the means over each kind of split within 0.6 %).
pub const WIDTH_FLOOR_SD: f64 = 0.05;

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
    search_without(s, start, draw, LeftOut::NONE)
}

/// [`search()`] on `s`, a set taken from a whole set without the rows `left_out`: the rows
/// searched are those the search of the whole set draws, but those left out (the
/// hyperparameters of the set without a few mis-measured rows, not those of another draw of
/// rows; see [`LeftOut::groups`]).
pub fn search_without(s: &Samples, start: usize, draw: Draw, left_out: LeftOut) -> Result<Search> {
    let one = Searches::new(s, draw, left_out)?;
    let found = parallel_map(one.outputs, |j| one.output(j, Begin::Start(start)));
    Ok(join(found.into_iter().collect::<Result<Vec<_>>>()?))
}

/// [`search_without`] started at the hyperparameters `from` (every output's, see
/// [`Hyper`]) instead of at a start: those of a search on nearly the same rows, whose mode
/// it follows (a few steps where the rows differ little).
pub fn search_from(s: &Samples, from: &Hyper, draw: Draw, left_out: LeftOut) -> Result<Search> {
    let one = Searches::new(s, draw, left_out)?;
    check_hyper(from, one.inputs(), one.outputs)?;
    let block = one.inputs() + 2;
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
    search_best_without(s, draw, LeftOut::NONE)
}

/// [`search_best`] on a set from which the rows `left_out` were taken out, as
/// [`search_without`].
pub fn search_best_without(s: &Samples, draw: Draw, left_out: LeftOut) -> Result<Search> {
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
    left_out: LeftOut,
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

/// What every output's search shares: the blocks of rows searched on (indices in `s`) and
/// their pairs.
struct Searches<'a> {
    s: &'a Samples,
    /// Outputs of `s` (one search each).
    outputs: usize,
    /// At least one.
    blocks: Vec<(Vec<usize>, Pairs)>,
    covariance: Covariance,
}

impl<'a> Searches<'a> {
    fn new(s: &'a Samples, draw: Draw, left_out: LeftOut) -> Result<Searches<'a>> {
        let (_, _, outputs) = shape(s)?;
        let blocks = drawn_blocks(s, draw, left_out)?
            .into_iter()
            .map(|rows| {
                let pairs = Pairs::new(&s.x, &rows);
                (rows, pairs)
            })
            .collect();
        Ok(Searches {
            s,
            outputs,
            blocks,
            covariance: draw.covariance,
        })
    }

    /// Inputs per row.
    fn inputs(&self) -> usize {
        self.blocks[0].1.inputs()
    }

    /// Output `j`'s search from `begin`: its d + 2 hyperparameters.
    fn output(&self, j: usize, begin: Begin) -> Result<Search> {
        let d = self.inputs();
        let mut objective = Objective::new(self, j);
        let var = objective.var;
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
        let (hyper, objective, _) = minimize(
            h0,
            8,
            HYPER_ITERATIONS,
            1e-6,
            |h, g| objective.value(self, h, g),
            |_, value, _| {
                // Likelihood differences of a thousandth of a nat choose nothing: stop when
                // three steps in a row gain less (on the blocks' sum).
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

/// One output's objective over the blocks of a [`Searches`]: the first block's negative log
/// marginal likelihood and the prior's term, plus every other block's likelihood alone, and
/// its gradient. The blocks of one size share one scratch (they are evaluated one after
/// another): the memory of a search grows with the distinct sizes, not with the blocks.
struct Objective {
    /// Output j's targets at each block's rows.
    y: Vec<Mat<f64>>,
    /// Mean square of the targets over every block's rows.
    var: f64,
    prior: Hyper,
    /// ln of each input's resolution ([`WIDTH_FLOOR_SD`]); empty: no bound.
    floor: Vec<f64>,
    /// Scratch per distinct block size, and each block's.
    scratch: Vec<Scratch>,
    slot: Vec<usize>,
    block_grad: DVector<f64>,
}

impl Objective {
    fn new(one: &Searches, j: usize) -> Objective {
        let d = one.inputs();
        let y: Vec<Mat<f64>> = one
            .blocks
            .iter()
            .map(|(rows, _)| Mat::<f64>::from_fn(rows.len(), 1, |i, _| one.s.b[rows[i]][j]))
            .collect();
        let (square, count) = y.iter().fold((0.0, 0), |(sum, n), y| {
            let one: f64 = (0..y.nrows()).map(|i| y[(i, 0)] * y[(i, 0)]).sum();
            (sum + one, n + y.nrows())
        });
        let var = (square / count as f64).max(1e-12);
        let mut sizes: Vec<usize> = Vec::new();
        let slot = y
            .iter()
            .map(|y| {
                sizes
                    .iter()
                    .position(|&n| n == y.nrows())
                    .unwrap_or_else(|| {
                        sizes.push(y.nrows());
                        sizes.len() - 1
                    })
            })
            .collect();
        Objective {
            y,
            var,
            prior: prior_mean(d, var),
            floor: if one.s.resolution.len() == d {
                one.s.resolution.iter().map(|r| r.ln()).collect()
            } else {
                Vec::new()
            },
            scratch: sizes.iter().map(|&n| Scratch::new(n, 1)).collect(),
            slot,
            block_grad: DVector::zeros(d + 2),
        }
    }

    /// The objective at `h`, its gradient into `g` (infinite, `g` unspecified, where a
    /// block's kernel matrix is not positive definite).
    fn value(&mut self, one: &Searches, h: &Hyper, g: &mut DVector<f64>) -> f64 {
        let mut f = 0.0;
        for (b, ((_, pairs), y)) in one.blocks.iter().zip(&self.y).enumerate() {
            // The prior counted once, with the first block.
            let (prior, grad) = if b == 0 {
                (Some(&self.prior), &mut *g)
            } else {
                (None, &mut self.block_grad)
            };
            f += neg_log_likelihood_in(
                pairs,
                y,
                h,
                prior,
                one.covariance,
                Some(grad),
                &mut self.scratch[self.slot[b]],
            );
            if !f.is_finite() {
                return f;
            }
            if b > 0 {
                *g += &self.block_grad;
            }
        }
        // The widths' one-sided prior: a width below its input's resolution.
        let sd2 = WIDTH_FLOOR_SD * WIDTH_FLOOR_SD;
        for (i, lo) in self.floor.iter().enumerate() {
            let gap = lo - h[i];
            if gap > 0.0 {
                f += 0.5 * gap * gap / sd2;
                g[i] -= gap / sd2;
            }
        }
        f
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::neural::rbf::tests::data;
    use crate::neural::rbf::{HYPER_ROWS, Rbf, neg_log_likelihood};

    /// The rows `rows` left out, the whole set's groups not given.
    fn rows_out(rows: &[usize]) -> LeftOut<'_> {
        LeftOut { rows, groups: &[] }
    }

    /// `s` without the rows `out` (indices in `s`, any order).
    fn without(s: &Samples, out: &[usize]) -> Samples {
        let mut less = s.clone();
        let mut gone = out.to_vec();
        gone.sort_unstable();
        gone.dedup();
        for &r in gone.iter().rev() {
            less.x.remove(r);
            less.b.remove(r);
            if !less.groups.is_empty() {
                less.groups.remove(r);
            }
        }
        less
    }

    /// An input that barely varies (0.02 of its resolution) but carries a feature on its own
    /// tiny scale: the likelihood alone narrows the width to that scale; held at the
    /// input's resolution, the width stays near it, and the objective's gradient is the
    /// finite differences' with the one-sided prior active.
    #[test]
    fn widths_are_held_at_the_inputs_resolution() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
        let mut s = Samples::default();
        for _ in 0..120 {
            let x: Vec<f64> = vec![
                rng.random_range(-1.5..1.5),
                0.02 * rng.random_range(-1.0..1.0),
            ];
            s.b.push(vec![(2.0 * x[0]).sin() + 0.5 * (x[1] / 0.005).sin()]);
            s.x.push(x);
        }
        let width = |s: &Samples| search(s, 0, Draw::seeded(7)).unwrap().hyper[1].exp();
        let free = width(&s);
        assert!(free < 0.1, "without a resolution: width {free}");
        s.resolution = vec![0.2, 1.0];
        let held = width(&s);
        assert!(held > 0.85, "held at resolution 1: width {held}");
        // The gradient with the prior active (ln l_1 below ln 1), by central differences.
        let one = Searches::new(&s, Draw::seeded(7), LeftOut::NONE).unwrap();
        let mut objective = Objective::new(&one, 0);
        let h = Hyper::from_vec(vec![0.1, -0.7, 0.2, -3.0]);
        let mut g = DVector::zeros(4);
        objective.value(&one, &h, &mut g);
        for i in 0..4 {
            let step = 1e-6;
            let (mut up, mut down) = (h.clone(), h.clone());
            up[i] += step;
            down[i] -= step;
            let mut scratch = DVector::zeros(4);
            let fd = (objective.value(&one, &up, &mut scratch)
                - objective.value(&one, &down, &mut scratch))
                / (2.0 * step);
            assert!(
                (fd - g[i]).abs() <= 1e-5 * (1.0 + fd.abs()),
                "d/dh{i}: analytic {} fd {fd}",
                g[i]
            );
        }
    }

    /// `data(n)` whose rows come in configurations of three (groups k / 3), each
    /// configuration's rows the same inputs, their targets apart by the noise of a repeat.
    fn repeated(n: usize) -> Samples {
        let (mut s, _) = data(n);
        for k in 0..n {
            let first = k - k % 3;
            s.x[k] = s.x[first].clone();
            let shift = 1e-3 * (k % 3) as f64;
            s.b[k] = s.b[first].iter().map(|b| b + shift).collect();
        }
        s.groups = (0..n).map(|k| k / 3).collect();
        s
    }

    /// A search sees one row of each configuration: on a small set all configurations, on a
    /// large one blocks of distinct configurations; the search is the one on the set of those
    /// rows alone, bit for bit (a repeat's row cannot enter it). Rows left out leave the whole
    /// set's draw but those when its groups are given.
    #[test]
    fn a_search_sees_one_row_per_configuration() {
        let s = repeated(60);
        let groups_of = |rows: &[usize]| -> Vec<usize> {
            let mut g: Vec<usize> = rows.iter().map(|&r| s.groups[r]).collect();
            g.sort_unstable();
            g
        };
        let one = Searches::new(&s, Draw::seeded(7), LeftOut::NONE).unwrap();
        assert_eq!(one.blocks.len(), 1);
        let drawn = one.blocks[0].0.clone();
        assert_eq!(groups_of(&drawn), (0..20).collect::<Vec<_>>());
        // Not always a configuration's first row: the choice is the shuffle's.
        assert!(drawn.iter().any(|r| r % 3 != 0), "{drawn:?}");
        let mut distinct = Samples::default();
        for &r in &drawn {
            distinct.x.push(s.x[r].clone());
            distinct.b.push(s.b[r].clone());
        }
        assert_eq!(
            search(&s, 0, Draw::seeded(7)).unwrap(),
            search(&distinct, 0, Draw::seeded(7)).unwrap()
        );
        // Two blocks of 8 rows from 16 distinct configurations.
        let small = Draw {
            rows: 8,
            blocks: 2,
            ..Draw::seeded(7)
        };
        let two = Searches::new(&s, small, LeftOut::NONE).unwrap().blocks;
        assert_eq!(two.iter().map(|b| b.0.len()).collect::<Vec<_>>(), [8, 8]);
        let both: Vec<usize> = two.iter().flat_map(|b| b.0.iter().copied()).collect();
        let mut g = groups_of(&both);
        g.dedup();
        assert_eq!(g.len(), 16);
        // The drawn row of configuration 5 left out. With the whole set's groups, the rows
        // searched are the whole set's but that one: configuration 5 is not searched.
        let gone = *drawn.iter().find(|&&r| s.groups[r] == 5).unwrap();
        let less = without(&s, &[gone]);
        let exact = Searches::new(
            &less,
            Draw::seeded(7),
            LeftOut {
                rows: &[gone],
                groups: &s.groups,
            },
        )
        .unwrap()
        .blocks[0]
            .0
            .clone();
        let renumbered: Vec<usize> = drawn
            .iter()
            .filter(|&&r| r != gone)
            .map(|&r| if r > gone { r - 1 } else { r })
            .collect();
        assert_eq!(exact, renumbered);
        // Without them, the row left out is a configuration of its own, and configuration 5
        // keeps another of its rows (`less` no longer holds the one left out).
        let rows = Searches::new(&less, Draw::seeded(7), rows_out(&[gone]))
            .unwrap()
            .blocks[0]
            .0
            .clone();
        assert_eq!(rows.len(), 20);
        assert_eq!(rows.iter().filter(|&&r| less.groups[r] == 5).count(), 1);
        // One configuration measured again and again: its rows are all there is to search on.
        let mut once = repeated(20);
        once.groups = vec![0; 20];
        let all = Searches::new(&once, Draw::seeded(7), LeftOut::NONE)
            .unwrap()
            .blocks;
        assert_eq!(all[0].0, (0..20).collect::<Vec<_>>());
        // Groups of another length than the whole set are refused.
        let short = LeftOut {
            rows: &[gone],
            groups: &s.groups[1..],
        };
        assert!(Searches::new(&less, Draw::seeded(7), short).is_err());
    }

    /// The blocks are disjoint runs of one seeded shuffle of the rows: the first is the
    /// draw of a single block, the others follow it; rows left out leave their block.
    #[test]
    fn blocks_are_disjoint_draws_and_the_first_is_the_single_blocks() {
        let (s, _) = data(260);
        let two = Draw {
            rows: 100,
            blocks: 2,
            ..Draw::seeded(5)
        };
        let one = Draw { blocks: 1, ..two };
        let blocks = Searches::new(&s, two, LeftOut::NONE).unwrap().blocks;
        let single = Searches::new(&s, one, LeftOut::NONE).unwrap().blocks;
        assert_eq!(blocks.len(), 2);
        assert_eq!(single.len(), 1);
        assert_eq!(blocks[0].0, single[0].0);
        assert_eq!(blocks[1].0.len(), 100);
        assert!(blocks[1].0.iter().all(|r| !blocks[0].0.contains(r)));
        assert!(blocks.iter().all(|(b, _)| b.is_sorted()));
        // Three blocks: the third (60 rows, more than half a block) is the rest.
        let three = Searches::new(&s, Draw { blocks: 3, ..two }, LeftOut::NONE)
            .unwrap()
            .blocks;
        let mut all: Vec<usize> = three.iter().flat_map(|(b, _)| b.clone()).collect();
        all.sort_unstable();
        assert_eq!(all, (0..260).collect::<Vec<_>>());
        assert_eq!(three[1].0, blocks[1].0);
        // Rows left out of both blocks: gone from them, the others renumbered.
        let out = [blocks[0].0[7], blocks[1].0[3]];
        let less = without(&s, &out);
        let left = Searches::new(&less, two, rows_out(&out)).unwrap().blocks;
        for ((rows, _), (whole, _)) in left.iter().zip(&blocks) {
            assert_eq!(rows.len(), whole.len() - 1);
            let got: Vec<&Vec<f64>> = rows.iter().map(|&r| &less.x[r]).collect();
            let expected: Vec<&Vec<f64>> = whole
                .iter()
                .filter(|r| !out.contains(r))
                .map(|&r| &s.x[r])
                .collect();
            assert_eq!(got, expected);
        }
        assert!(Searches::new(&s, Draw { blocks: 0, ..two }, LeftOut::NONE).is_err());
        // Blocks of 3 rows on 6: a block left with one row is dropped, the other kept, even
        // the first; with none of 2 rows or more left, an error.
        let (six, _) = data(6);
        let small = Draw {
            rows: 3,
            blocks: 2,
            ..Draw::seeded(5)
        };
        let whole = Searches::new(&six, small, LeftOut::NONE).unwrap().blocks;
        for b in 0..2 {
            let out = [whole[b].0[0], whole[b].0[2]];
            let less = without(&six, &out);
            let kept = Searches::new(&less, small, rows_out(&out)).unwrap().blocks;
            assert_eq!(kept.len(), 1, "{b}");
            let got: Vec<&Vec<f64>> = kept[0].0.iter().map(|&r| &less.x[r]).collect();
            let expected: Vec<&Vec<f64>> = whole[1 - b].0.iter().map(|&r| &six.x[r]).collect();
            assert_eq!(got, expected, "{b}");
        }
        let out = [whole[0].0[0], whole[0].0[1], whole[1].0[0], whole[1].0[1]];
        let two_left = without(&six, &out);
        let e = Searches::new(&two_left, small, rows_out(&out))
            .err()
            .unwrap();
        assert!(
            e.to_string()
                .contains("6 rows (4 left out, one row searched per arm configuration) leave 2"),
            "{e}"
        );
    }

    /// The objective over blocks (rows left out of two of them; blocks of one size sharing a
    /// scratch) has its central differences as its gradient, and is the sum of the blocks'
    /// likelihoods each computed on its own rows, the first with the prior, for 2 and 3
    /// blocks.
    #[test]
    fn the_blocks_objective_has_its_central_differences_as_gradient() {
        let (s, _) = data(200);
        for blocks in [2, 3] {
            let draw = Draw {
                rows: 70,
                blocks,
                ..Draw::seeded(4)
            };
            let whole = Searches::new(&s, draw, LeftOut::NONE).unwrap();
            let out = vec![whole.blocks[0].0[5], whole.blocks[1].0[9]];
            let less = without(&s, &out);
            let one = Searches::new(&less, draw, rows_out(&out)).unwrap();
            assert_eq!(one.blocks.len(), blocks);
            let d = one.inputs();
            for j in 0..less.rows() {
                let mut objective = Objective::new(&one, j);
                assert_eq!(objective.scratch.len(), blocks - 1, "69 + 69 (+ 60) rows");
                let mut h = Hyper::from_element(d + 2, 0.4f64.ln());
                h[0] = 0.9f64.ln();
                h[d] = objective.var.ln();
                h[d + 1] = (0.05 * objective.var).ln();
                let mut g = DVector::zeros(d + 2);
                let f = objective.value(&one, &h, &mut g);
                assert!(f.is_finite());
                let mut unused = DVector::zeros(d + 2);
                for c in 0..d + 2 {
                    let step = 1e-5;
                    let (mut a, mut b) = (h.clone(), h.clone());
                    a[c] += step;
                    b[c] -= step;
                    let fd = (objective.value(&one, &a, &mut unused)
                        - objective.value(&one, &b, &mut unused))
                        / (2.0 * step);
                    assert!(
                        (fd - g[c]).abs() <= 1e-6 * (1.0 + fd.abs()),
                        "{blocks} blocks, output {j}, component {c}: analytic {} numeric {fd}",
                        g[c]
                    );
                }
                let cov = draw.covariance;
                let y = &objective.y;
                let mut sum = neg_log_likelihood(
                    &one.blocks[0].1,
                    &y[0],
                    &h,
                    Some(&objective.prior),
                    cov,
                    None,
                );
                for ((_, pairs), y) in one.blocks.iter().zip(y).skip(1) {
                    sum += neg_log_likelihood(pairs, y, &h, None, cov, None);
                }
                assert!((f - sum).abs() <= 1e-9 * sum.abs(), "{f} {sum}");
            }
        }
    }

    /// A search on two blocks minimises, output by output, the first block's objective
    /// (likelihood and prior) plus the second's likelihood alone, each computed on its own
    /// rows: its objective is that sum at its hyperparameters, which beat the first block's
    /// search alone on the sum, and lose to it on the first block.
    #[test]
    fn a_search_on_blocks_adds_their_likelihoods_and_the_prior_once() {
        let (s, _) = data(200);
        let two = Draw {
            rows: 100,
            blocks: 2,
            ..Draw::seeded(3)
        };
        let found = search(&s, 0, two).unwrap();
        let first_only = search(&s, 0, Draw { blocks: 1, ..two }).unwrap();
        let blocks = Searches::new(&s, two, LeftOut::NONE).unwrap().blocks;
        let d = s.x[0].len();
        let cov = two.covariance;
        let mut total = 0.0;
        for j in 0..s.rows() {
            let y: Vec<Mat<f64>> = blocks
                .iter()
                .map(|(rows, _)| Mat::from_fn(rows.len(), 1, |i, _| s.b[rows[i]][j]))
                .collect();
            let square: f64 = s.b.iter().map(|b| b[j] * b[j]).sum();
            let prior = prior_mean(d, square / s.len() as f64);
            // (first block with the prior, second block without) at hyperparameters `h`.
            let parts = |h: &Hyper| {
                let h = h.rows(j * (d + 2), d + 2).into_owned();
                (
                    neg_log_likelihood(&blocks[0].1, &y[0], &h, Some(&prior), cov, None),
                    neg_log_likelihood(&blocks[1].1, &y[1], &h, None, cov, None),
                )
            };
            let (a, b) = parts(&found.hyper);
            let (a1, b1) = parts(&first_only.hyper);
            total += a + b;
            assert!(a + b < a1 + b1, "{j}: {} {}", a + b, a1 + b1);
            assert!(a1 < a, "{j}: {a1} {a}");
        }
        assert!(
            (found.objective - total).abs() < 1e-9 * total.abs(),
            "{} {total}",
            found.objective
        );
    }

    /// A set without a few rows searches on the whole set's draw of rows but those: the same
    /// rows, numbered in the smaller set, and the same search as on the whole set when none
    /// is left out.
    #[test]
    fn a_search_without_rows_draws_the_whole_sets_rows_but_those() {
        let (whole, _) = data(HYPER_ROWS + 100);
        let drawn = Searches::new(&whole, Draw::seeded(7), LeftOut::NONE)
            .unwrap()
            .blocks[0]
            .0
            .clone();
        assert_eq!(drawn.len(), HYPER_ROWS);
        // Two rows of the draw and one outside it left out, given unsorted and twice.
        let outside = (0..whole.len()).find(|r| !drawn.contains(r)).unwrap();
        let left_out = vec![drawn[300], outside, drawn[3], drawn[300]];
        let less = without(&whole, &left_out);
        let rows = Searches::new(&less, Draw::seeded(7), rows_out(&left_out))
            .unwrap()
            .blocks[0]
            .0
            .clone();
        assert_eq!(rows.len(), HYPER_ROWS - 2);
        // Each row searched is the same measurement as the whole set's drawn row.
        let expected: Vec<&Vec<f64>> = drawn
            .iter()
            .filter(|r| !left_out.contains(r))
            .map(|&r| &whole.x[r])
            .collect();
        let got: Vec<&Vec<f64>> = rows.iter().map(|&r| &less.x[r]).collect();
        assert_eq!(got, expected);
        // A small set: every row but those left out.
        let (small, _) = data(30);
        let mut fewer = small.clone();
        fewer.x.remove(4);
        fewer.b.remove(4);
        let rows = Searches::new(&fewer, Draw::seeded(7), rows_out(&[4]))
            .unwrap()
            .blocks[0]
            .0
            .clone();
        assert_eq!(rows, (0..29).collect::<Vec<_>>());
        assert_eq!(
            search_without(&fewer, 0, Draw::seeded(7), rows_out(&[4])).unwrap(),
            search(&fewer, 0, Draw::seeded(7)).unwrap()
        );
        // An index beyond the whole set is refused, on a small set and on a large one.
        assert!(Searches::new(&fewer, Draw::seeded(7), rows_out(&[29, 31])).is_err());
        assert!(
            Searches::new(
                &less,
                Draw::seeded(7),
                rows_out(&[drawn[3], whole.len() + 50])
            )
            .is_err()
        );
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
                search_from(&s, &h0, Draw::seeded(1), LeftOut::NONE).unwrap(),
                search(&s, k, Draw::seeded(1)).unwrap()
            );
        }
        let cold = search(&s, 1, Draw::seeded(1)).unwrap();
        let warm = search_from(&s, &cold.hyper, Draw::seeded(1), LeftOut::NONE).unwrap();
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
                LeftOut::NONE
            )
            .is_err()
        );
        let mut bad = cold.hyper.clone();
        bad[0] = f64::NAN;
        assert!(search_from(&s, &bad, Draw::seeded(1), LeftOut::NONE).is_err());
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
