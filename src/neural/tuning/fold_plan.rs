//! Cross-validation's folds of a training set, and whether its rows are enough to
//! cross-validate what the options leave open.

use super::MANY;
use super::rows::folds;
use crate::data::MeasurementSet;
use crate::model::Robot;
use crate::neural::settings::{CompensatorOptions, Network};
use crate::neural::train::MIN_ROWS;

/// The fewest training rows `network` needs: the RBF network's
/// ([`crate::neural::rbf::MIN_ROWS`]) alone, [`MIN_ROWS`] where MLPs take part.
pub fn rows_needed(network: Network) -> usize {
    match network {
        Network::Rbf => crate::neural::rbf::MIN_ROWS,
        Network::Mlp | Network::Mix => MIN_ROWS,
    }
}

/// The fewest training rows a network the options allow needs ([`rows_needed`]; MLPs where
/// the network is open); None where they fix the members at 0 (no network).
pub(super) fn network_rows(opts: &CompensatorOptions) -> Option<usize> {
    match opts.members {
        Some(0) => None,
        _ => Some(rows_needed(opts.network.unwrap_or(Network::Mlp))),
    }
}

/// Cross-validation's folds of a set: its configuration groups, how many distinct, the folds
/// asked for (`--folds`, else 4 from [`MANY`] configurations on, else 5), each row's fold and
/// the number of folds drawn (whole configurations each, seeded).
pub(super) struct Folds {
    pub(super) groups: Vec<usize>,
    pub(super) distinct: usize,
    pub(super) want: usize,
    pub(super) fold_of: Vec<usize>,
    pub(super) k: usize,
}

/// [`Folds`] of `set` under `opts`: the one draw
/// [`select_settings`](super::select_settings) and [`too_few_rows`] both see.
pub(super) fn fold_plan(robot: &Robot, set: &MeasurementSet, opts: &CompensatorOptions) -> Folds {
    let groups = crate::neural::repeats::configuration_groups(robot, set);
    let distinct = crate::neural::repeats::group_count(&groups);
    // Fewer folds train candidates on a smaller part of the set; where the held-out error
    // still falls steeply with more rows (real tracker data), 3 folds chose penalties ten
    // times too large. From MANY configurations on, candidate fits sit at their iteration
    // floor and the cost grows with the folds: 4 there.
    let want = opts.folds.unwrap_or(if distinct >= MANY { 4 } else { 5 });
    let fold_of = folds(&groups, want.max(2), opts.train.seed);
    let k = fold_of.iter().max().map_or(0, |m| m + 1);
    Folds {
        groups,
        distinct,
        want,
        fold_of,
        k,
    }
}

/// Why the rows of `set` are too few to cross-validate what the options leave open: fewer than
/// 2 folds of distinct configurations (as [`select_settings`](super::select_settings) draws
/// them), or folds of which some leaves fewer rows to train on than a network the options
/// allow needs. None where they suffice.
pub fn too_few_rows(
    robot: &Robot,
    set: &MeasurementSet,
    opts: &CompensatorOptions,
) -> Option<String> {
    let n = set.rows.len();
    let Folds {
        distinct,
        fold_of,
        k,
        ..
    } = fold_plan(robot, set, opts);
    let what = if network_rows(opts).is_some() {
        "a network"
    } else {
        "a refinement"
    };
    if k < 2 {
        return Some(format!(
            "{n} training row(s) of {distinct} distinct configuration(s) are too few to \
             cross-validate {what}: it needs 2 folds of distinct configurations"
        ));
    }
    let need = network_rows(opts)?;
    let largest = (0..k)
        .map(|f| fold_of.iter().filter(|&&g| g == f).count())
        .max()
        .unwrap_or(n);
    (n - largest < need).then(|| {
        format!(
            "{n} training row(s) of {distinct} distinct configuration(s) are too few to \
             cross-validate {what}: each fold must leave at least {need} rows to train on"
        )
    })
}

/// Whether more folds than `folds` would let cross-validation train a network of `need`
/// rows on `set`: there are more distinct configurations than folds, and one fold per
/// configuration leaves at least `need` rows in every fold's training part.
pub(super) fn more_folds_help(
    robot: &Robot,
    set: &MeasurementSet,
    folds: usize,
    need: usize,
) -> bool {
    let groups = crate::neural::repeats::configuration_groups(robot, set);
    let distinct = crate::neural::repeats::group_count(&groups);
    let mut sizes = vec![0; distinct];
    for &g in &groups {
        sizes[g] += 1;
    }
    let largest = sizes.into_iter().max().unwrap_or(0);
    distinct >= 2 && folds < distinct && set.rows.len() - largest >= need
}
