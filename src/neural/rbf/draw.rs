//! Which rows a hyperparameter search sees ([`Draw`]): one row per arm configuration, in
//! blocks of a seeded shuffle, at most [`HYPER_ROWS`] rows in each, the rows a set was taken
//! without left out as the whole set's search would have them ([`LeftOut`]).

use super::Covariance;
use crate::error::{Error, Result};
use crate::neural::samples::Samples;
use rand::SeedableRng;
use rand::seq::SliceRandom;
use rand_chacha::ChaCha8Rng;

/// Rows on which the hyperparameters are fitted at most by default ([`Draw::seeded`]; the
/// rest only enter the weights).
pub const HYPER_ROWS: usize = 500;
/// Disjoint blocks of [`HYPER_ROWS`] rows a search sees at most by default ([`Draw::seeded`]).
/// Each block's rows are one Gaussian process; the search maximises the sum of the blocks'
/// log likelihoods (the whole likelihood with the covariances between blocks taken as zero, a
/// block-diagonal approximation), at a cost linear in the blocks instead of cubic in the rows.
/// One by default: on real UR10 data, the default `train` with two blocks instead of one
/// lowered the held-out position RMS over 16 Series B runs with pools of 1000 (4 splits,
/// training seeds 1-4; fourteenth session, outlier cut 4) from 0.2081 to 0.2072 mm (the worst
/// run 0.2289 -> 0.2244) and on Series A's pool of 2000 (seeds 1-3) from 0.1400 to 0.1380
/// (lower in all three), but every step of the search then evaluates two likelihoods (as
/// many steps as one block's), which doubles its time: 5.3 -> 7.1 s on those 2000 poses,
/// 5.9 -> 8.3 s on Series B's README split (1000 poses). (Before the draw of one row per
/// configuration, two blocks had taken the Series B mean from 0.2144 to 0.2108 mm.)
pub const HYPER_BLOCKS: usize = 1;

/// Which rows of a set a hyperparameter search sees, and the covariance function whose
/// hyperparameters it fits: one row per configuration (a seeded choice among a repeated
/// configuration's rows, see [`Samples::groups`]); all of them where they are at most `rows`,
/// else blocks of `rows` in the order of a shuffle seeded by `seed`: the first block, then up
/// to `blocks - 1` more, a last one of fewer rows only if it has `rows / 2` or more and 2
/// ([`Draw::block_sizes`]);
/// a block that rows left out leave with fewer than 2 is dropped. A block's cost is cubic in its
/// rows (a Cholesky factor and an inverse of the n x n kernel matrix per evaluation).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Draw {
    /// Seed of the shuffle.
    pub seed: u64,
    /// Rows searched at most (at least 2).
    pub rows: usize,
    /// The covariance function.
    pub covariance: Covariance,
    /// Blocks of at most `rows` searched at most (at least 1), their likelihoods summed.
    pub blocks: usize,
}

impl Draw {
    /// The default draw of `seed`: at most [`HYPER_BLOCKS`] blocks of [`HYPER_ROWS`] rows,
    /// [`Covariance::DEFAULT`].
    pub fn seeded(seed: u64) -> Draw {
        Draw {
            seed,
            rows: HYPER_ROWS,
            covariance: Covariance::DEFAULT,
            blocks: HYPER_BLOCKS,
        }
    }

    /// The sizes of the blocks a search of a set of `n` configurations sees (none left out;
    /// one row per configuration): blocks of `rows` while there are rows and blocks, a last
    /// smaller one only if it has at least `rows / 2` rows and 2 (and the first always).
    pub fn block_sizes(&self, n: usize) -> Vec<usize> {
        let (rows, blocks) = (self.rows.max(1), self.blocks.max(1));
        (0..blocks)
            .map(|b| n.saturating_sub(b * rows).min(rows))
            .enumerate()
            .filter(|&(b, size)| b == 0 || size >= (rows / 2).max(2))
            .map(|(_, size)| size)
            .collect()
    }

    /// [`Draw::block_sizes`] of a set whose rows are the configuration `groups` (ids as
    /// [`Samples::groups`]; none left out): the rows the search of that set sees.
    pub fn block_sizes_of(&self, groups: &[usize]) -> Vec<usize> {
        let distinct = groups
            .iter()
            .collect::<std::collections::HashSet<_>>()
            .len();
        self.block_sizes(searched_rows(groups.len(), distinct))
    }
}

/// Rows a search takes its blocks from on `rows` rows of `configurations` configurations: one
/// per configuration, or every row where they are one configuration (measured again and
/// again, it says nothing of how the error varies between configurations; its rows are all
/// there is to fit the noise and signal levels on, and the network can learn a constant only,
/// which `train` notes).
fn searched_rows(rows: usize, configurations: usize) -> usize {
    if configurations < 2 {
        rows
    } else {
        configurations
    }
}

/// Rows a set was taken from a whole set without, for a search that should see the rows the
/// whole set's search draws, but those.
#[derive(Debug, Clone, Copy, Default)]
pub struct LeftOut<'a> {
    /// Indices in the whole set of the rows taken out (any order; repeats allowed).
    pub rows: &'a [usize],
    /// The whole set's configuration group of each of its rows (its [`Samples::groups`]),
    /// which the draw of one row per configuration needs. Empty: the set's own groups for its
    /// rows and each row taken out a configuration of its own, exact where no configuration
    /// repeats; otherwise a configuration whose drawn row is taken out keeps another, the
    /// rows taken out still count toward the blocks, and the set's groups may part rows that
    /// a row taken out had joined.
    pub groups: &'a [usize],
}

impl LeftOut<'_> {
    /// Nothing left out: the set is whole.
    pub const NONE: LeftOut<'static> = LeftOut {
        rows: &[],
        groups: &[],
    };
}

/// The rows of the whole set (`s` less the sorted rows `left_out`, its rows in the order of
/// [`shuffled`]) that a search takes its blocks from, in the order it takes them: of the
/// shuffle `all` only the first row of each configuration (every row where the whole set is
/// one configuration). The
/// configurations are `whole_groups` (the whole set's groups), or where that is empty the
/// groups of `s` ([`Samples::groups`]) with each row left out a configuration of its own.
///
/// One row per configuration because repeated measurements of one arm configuration agree to
/// the data's repeatability (0.034 mm on Series B's pool), far closer than rows of different
/// configurations follow the function of the joints the network learns. Pairs of repeats in
/// the likelihood pull its noise variance toward that repeatability and its widths narrower,
/// and the fit then follows its rows too closely between configurations, where it is judged.
/// On 16 Series B runs with pools of 1000 (4 splits, training seeds 1-4), the default `train`'s
/// held-out position RMS: 0.2144 mm with rows drawn one by one (as before), 0.2223 with each
/// configuration's rows drawn together, 0.2081 with one row per configuration.
fn configurations_in_draw_order(
    s: &Samples,
    left_out: &[usize],
    whole_groups: &[usize],
    all: Vec<usize>,
) -> Vec<usize> {
    // A configuration: (false, group) for a group, (true, row) for a row left out alone.
    let configuration = |r: usize| -> (bool, usize) {
        if !whole_groups.is_empty() {
            return (false, whole_groups[r]);
        }
        match left_out.binary_search(&r) {
            Ok(_) => (true, r),
            Err(before) => (false, s.group(r - before)),
        }
    };
    let mut seen = std::collections::HashSet::new();
    let first: Vec<usize> = all
        .iter()
        .copied()
        .filter(|&r| seen.insert(configuration(r)))
        .collect();
    if searched_rows(all.len(), seen.len()) == all.len() {
        all
    } else {
        first
    }
}

/// Units an RBF network carries at most by default
/// ([`crate::neural::train::TrainOptions::rbf_units`]). Its weights solve one n x n kernel
/// matrix per output (n^2 numbers, a factorisation cubic in n: 72 MB and about 9 GFLOP per
/// output at 3000), so on larger sets the units are centred on a choice of the rows
/// ([`unit_rows`]: a subset-of-data Gaussian process) and the other rows train the MLPs
/// only. Before, sets of more than 3000 rows were given no RBF network at all where the
/// network was left open (a fixed one put a unit on every row), and more data made a worse
/// compensator: on real UR10 data (Series A, 1412 held-out poses) the
/// default `train` on a pool of 8003 reached 0.1537 mm RMS (MLPs alone), on 2001 of those
/// rows 0.1383 and on 2961 of them 0.1278 (both with an RBF network); with 3000 units on a
/// choice of the 8003, 0.1323. More units keep helping, at a cost cubic in them: on two
/// pools of 5178 (4237 held out) 0.1545 and 0.1574 mm with MLPs alone (25 and 26 s), 0.1310
/// and 0.1417 with 2000 units (30 and 21 s), 0.1214 and 0.1336 with 3000 (45 and 34 s),
/// 0.1136 and 0.1245 with 4500 (59 and 52 s). 3000 was the largest set given an RBF
/// network before: sets up to it are fitted as they were. Sets a little larger (up to 4000
/// with 4 folds) carry a unit on every row in the folds and 3000 in the final fit.
pub const MAX_UNITS: usize = 3000;

/// The rows of a whole set of `whole` rows in the order of the search's seeded shuffle.
fn shuffled(whole: usize, seed: u64) -> Vec<usize> {
    let mut all: Vec<usize> = (0..whole).collect();
    all.shuffle(&mut ChaCha8Rng::seed_from_u64(seed ^ 0x7bf));
    all
}

/// The rows `left_out` sorted and without repeats, and the number of rows of the whole set
/// `s` was taken from; an error where they do not fit it.
fn whole_set(s: &Samples, left_out: LeftOut) -> Result<(Vec<usize>, usize)> {
    let mut left = left_out.rows.to_vec();
    left.sort_unstable();
    left.dedup();
    let whole = s.x.len() + left.len();
    if let Some(&last) = left.last()
        && last >= whole
    {
        return Err(Error::Invalid(format!(
            "the RBF network's rows: row {last} left out of a set of {whole} rows"
        )));
    }
    if !left_out.groups.is_empty() && left_out.groups.len() != whole {
        return Err(Error::Invalid(format!(
            "the RBF network's rows: configuration groups of {} rows for a whole set of \
             {whole}",
            left_out.groups.len()
        )));
    }
    Ok((left, whole))
}

/// Rows of the whole set (indices in it) numbered as in the set less the sorted rows `left`,
/// those left out dropped.
fn renumbered(rows: impl Iterator<Item = usize>, left: &[usize]) -> impl Iterator<Item = usize> {
    rows.filter(|r| left.binary_search(r).is_err())
        .map(|r| r - left.partition_point(|&o| o < r))
}

/// The rows of `s` (ascending) on which an RBF network of at most `max` units centres them,
/// None where every row carries one (`s` has `max` rows or fewer). The whole set's rows (`s`
/// and the rows `left_out`, as for the search) are taken in the order of the search's draw of
/// `seed` ([`Draw`]: a seeded shuffle, one row per configuration), then its configurations'
/// other rows in the same shuffle; of these, the first `max` that `s` holds. So the rows a
/// search of `s` by `seed` with the same `left_out` sees are among them where its blocks hold
/// `max` rows or fewer, and a set taken from a larger one without some rows (a fold's
/// training rows) centres its units on the larger set's choice, less those rows, topped up
/// in the same order. Spread over the configurations first because repeats of one
/// configuration add little where the other configurations are missing (the reasons the
/// search's draw takes one row per configuration). An error for fewer than 2 units or
/// where `left_out` does not fit.
pub fn unit_rows(
    s: &Samples,
    seed: u64,
    max: usize,
    left_out: LeftOut,
) -> Result<Option<Vec<usize>>> {
    if max < 2 {
        return Err(Error::Invalid(format!(
            "an RBF network of at most {max} units: it needs at least 2"
        )));
    }
    if s.x.len() <= max {
        return Ok(None);
    }
    let (left, whole) = whole_set(s, left_out)?;
    let all = shuffled(whole, seed);
    let first = configurations_in_draw_order(s, &left, left_out.groups, all.clone());
    let mut taken = vec![false; whole];
    for &r in &first {
        taken[r] = true;
    }
    let order = first
        .into_iter()
        .chain(all.into_iter().filter(|&r| !taken[r]));
    let mut rows: Vec<usize> = renumbered(order, &left).take(max).collect();
    rows.sort_unstable();
    Ok(Some(rows))
}

/// The blocks of rows (indices in `s`, ascending in each block) a search of `s` sees under
/// `draw`: those the search of the whole set draws, but the rows `left_out` (module doc). An
/// error where the draw asks for fewer than 2 rows or no block, where `left_out` does not fit
/// the whole set, or where no block of 2 rows or more is left.
pub(super) fn drawn_blocks(s: &Samples, draw: Draw, left_out: LeftOut) -> Result<Vec<Vec<usize>>> {
    if draw.rows < 2 {
        return Err(Error::Invalid(format!(
            "the RBF network's hyperparameter search on {} rows: it needs at least 2",
            draw.rows
        )));
    }
    if draw.blocks == 0 {
        return Err(Error::Invalid(
            "the RBF network's hyperparameter search on 0 blocks of rows: it needs at least 1"
                .into(),
        ));
    }
    let whole_groups = left_out.groups;
    // The whole set's rows, drawn as its own search draws them.
    let (left_out, whole) = whole_set(s, left_out)?;
    let all = configurations_in_draw_order(s, &left_out, whole_groups, shuffled(whole, draw.seed));
    // Those left out dropped, the others numbered as in `s`.
    let renumber = |block: &[usize]| -> Vec<usize> {
        let mut rows = block.to_vec();
        rows.sort_unstable();
        renumbered(rows.into_iter(), &left_out).collect()
    };
    let mut at = 0;
    let drawn: Vec<Vec<usize>> = draw
        .block_sizes(all.len())
        .into_iter()
        .map(|size| {
            at += size;
            renumber(&all[at - size..at])
        })
        .collect();
    let left: usize = drawn.iter().map(Vec::len).sum();
    let blocks: Vec<Vec<usize>> = drawn
        .into_iter()
        // A block that rows left out leave with fewer than 2 rows says nothing of a
        // width.
        .filter(|rows| rows.len() >= 2)
        .collect();
    if blocks.is_empty() {
        return Err(Error::Invalid(format!(
            "the RBF network's hyperparameter search: {whole} rows ({} left out, one row \
             searched per arm configuration) leave {left} to search on, no block of them \
             2 or more",
            left_out.len(),
        )));
    }
    Ok(blocks)
}

/// The rows of `s` (ascending) that its own search under `draw` sees: the blocks of the
/// whole set (module doc), the rows whose values the hyperparameters depend on. An error
/// where the draw asks for fewer than 2 rows or no block.
pub fn drawn_rows(s: &Samples, draw: Draw) -> Result<Vec<usize>> {
    let mut rows = drawn_blocks(s, draw, LeftOut::NONE)?.concat();
    rows.sort_unstable();
    Ok(rows)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Twelve configurations, the first four measured three times: units on a choice of the
    /// rows take every configuration before any repeat, hold the rows the search of the same
    /// seed draws (also where they are fewer than the configurations), grow as prefixes of one
    /// order, and are a seeded choice; a set taken from the whole without some rows centres
    /// on the whole set's choice less those rows, and the search of that set (told the rows
    /// left out) draws among them.
    #[test]
    fn unit_rows_spread_over_the_configurations_first() {
        let mut s = Samples::default();
        for c in 0..12usize {
            for _ in 0..if c < 4 { 3 } else { 1 } {
                s.x.push(vec![c as f64]);
                s.b.push(vec![0.0]);
                s.groups.push(c);
            }
        }
        let units = |s: &Samples, seed, max, left| unit_rows(s, seed, max, left).unwrap();
        let configurations = |s: &Samples, rows: &[usize]| {
            rows.iter()
                .map(|&r| s.group(r))
                .collect::<std::collections::HashSet<usize>>()
                .len()
        };
        assert_eq!(s.len(), 20);
        assert_eq!(units(&s, 1, 20, LeftOut::NONE), None);
        assert!(unit_rows(&s, 1, 1, LeftOut::NONE).is_err());
        for seed in [1, 2, 3] {
            let mut before: Vec<usize> = Vec::new();
            for max in 2..20 {
                let rows = units(&s, seed, max, LeftOut::NONE).unwrap();
                assert_eq!(rows.len(), max);
                assert!(rows.windows(2).all(|w| w[0] < w[1]), "{rows:?}");
                assert_eq!(configurations(&s, &rows), max.min(12), "{seed} {max}");
                assert!(before.iter().all(|r| rows.contains(r)), "{seed} {max}");
                before = rows.clone();
                for (rows_searched, blocks) in [(max, 1), (2, 1), (max / 2, 2)] {
                    if rows_searched < 2 {
                        continue;
                    }
                    let draw = Draw {
                        rows: rows_searched,
                        blocks,
                        ..Draw::seeded(seed)
                    };
                    let searched = drawn_rows(&s, draw).unwrap();
                    assert!(
                        searched.iter().all(|r| rows.contains(r)),
                        "{seed} {max}: {searched:?} {rows:?}"
                    );
                }
            }
        }
        assert_ne!(
            units(&s, 1, 15, LeftOut::NONE),
            units(&s, 2, 15, LeftOut::NONE)
        );
        // Rows 0 and 5 (of configurations 0 and 1) and 13 (configuration 7) left out.
        let left = [13, 0, 5];
        let kept: Vec<usize> = (0..20).filter(|r| !left.contains(r)).collect();
        let part = s.pick(&kept);
        for (seed, max) in [(1, 6), (2, 9), (3, 14)] {
            let whole = LeftOut {
                rows: &left,
                groups: &s.groups,
            };
            let rows = units(&part, seed, max, whole).unwrap();
            assert_eq!(rows.len(), max);
            // The whole set's first units that the part holds: its choice of max + 3 less
            // the rows left out holds them all.
            let of_whole = units(&s, seed, max + left.len(), LeftOut::NONE).unwrap();
            assert!(
                rows.iter().all(|&r| of_whole.contains(&kept[r])),
                "{seed} {max}: {rows:?} {of_whole:?}"
            );
            let draw = Draw {
                rows: max.min(5),
                ..Draw::seeded(seed)
            };
            let searched = drawn_blocks(&part, draw, whole).unwrap().concat();
            assert!(searched.iter().all(|r| rows.contains(r)), "{searched:?}");
        }
        let wrong = LeftOut {
            rows: &[40],
            groups: &[],
        };
        assert!(unit_rows(&part, 1, 5, wrong).is_err());
    }

    /// Blocks of `rows` while there are rows and blocks; a short last block only from half
    /// a block; the first block always, however short.
    #[test]
    fn block_sizes_fill_whole_blocks_and_keep_a_last_one_of_half_a_block() {
        let draw = |rows, blocks| Draw {
            rows,
            blocks,
            ..Draw::seeded(1)
        };
        assert_eq!(draw(500, 2).block_sizes(2000), vec![500, 500]);
        assert_eq!(draw(500, 2).block_sizes(1000), vec![500, 500]);
        assert_eq!(draw(500, 2).block_sizes(750), vec![500, 250]);
        assert_eq!(draw(500, 2).block_sizes(749), vec![500]);
        assert_eq!(draw(500, 2).block_sizes(300), vec![300]);
        assert_eq!(draw(500, 1).block_sizes(2000), vec![500]);
        assert_eq!(draw(50, 3).block_sizes(150), vec![50, 50, 50]);
        assert_eq!(draw(100, 4).block_sizes(150), vec![100, 50]);
        assert_eq!(draw(60, 2).block_sizes(150), vec![60, 60]);
        assert_eq!(draw(2, 2).block_sizes(1), vec![1]);
        // A last block of one row is none, whatever half a block is.
        assert_eq!(draw(3, 2).block_sizes(4), vec![3]);
        assert_eq!(draw(2, 3).block_sizes(5), vec![2, 2]);
        assert_eq!(Draw::seeded(1).blocks, HYPER_BLOCKS);
    }
}
