//! The rows of cross-validation: folds of whole configurations, subsets, held-out errors
//! and their sums, and the rows whose held-out error is far out.

use crate::data::MeasurementSet;
use crate::error::Result;
use crate::evaluate::row_errors;
use crate::identify::Measure;
use crate::neural::compensator::Compensator;
use crate::neural::repeats::group_count;
use crate::neural::selection::Outlier;
use crate::neural::selection::Sums;
use rand::SeedableRng;
use rand::seq::SliceRandom;
use rand_chacha::ChaCha8Rng;

/// Fold of each row from its configuration group (ids 0..G,
/// [`crate::neural::repeats::configuration_groups`]): whole configurations, shuffled by
/// `seed`, dealt round-robin.
pub fn folds(groups: &[usize], k: usize, seed: u64) -> Vec<usize> {
    let mut ids: Vec<usize> = (0..group_count(groups)).collect();
    ids.shuffle(&mut ChaCha8Rng::seed_from_u64(seed ^ 0xf01d));
    let mut fold_of_group = vec![0; ids.len()];
    for (i, g) in ids.iter().enumerate() {
        fold_of_group[*g] = i % k;
    }
    groups.iter().map(|g| fold_of_group[*g]).collect()
}

pub use crate::data::measurement::subset;

/// Each held-out row's errors under `predict`: pose where the set has orientations, else
/// position.
pub(super) fn held_errors(
    set: &MeasurementSet,
    predict: impl FnMut(&[f64]) -> crate::Pose,
) -> Result<Vec<crate::evaluate::RowError>> {
    let measure = if set.has_rotation() {
        Measure::Pose
    } else {
        Measure::Position
    };
    row_errors(set, measure, predict)
}

pub(super) fn sums(
    set: &MeasurementSet,
    predict: impl FnMut(&[f64]) -> crate::Pose,
) -> Result<Sums> {
    let rows = held_errors(set, predict)?;
    let mut s = Sums::default();
    for r in rows {
        s.pos += r.position_mm.unwrap_or(0.0).powi(2);
        if let Some(o) = r.orientation_deg {
            s.rot += o * o;
            s.with_rotation = true;
        }
        s.rows += 1;
    }
    Ok(s)
}

/// Held-out sums of compensator `c` on `set` with the MLPs' share set to each of `shares`
/// (the networks run once per row: [`Compensator::predict_shares`]).
pub(super) fn share_sums(
    set: &MeasurementSet,
    c: &Compensator,
    shares: &[f64],
) -> Result<Vec<Sums>> {
    let mut ws = Default::default();
    let mut poses: Vec<Vec<crate::Pose>> = (0..shares.len())
        .map(|_| Vec::with_capacity(set.rows.len()))
        .collect();
    for m in &set.rows {
        c.predict_shares(&m.q, shares, &mut ws, |i, p| poses[i].push(p));
    }
    poses
        .iter()
        .map(|p| {
            // One prediction per row, in order (held_errors measures pose or position).
            let mut next = p.iter();
            sums(set, |_| *next.next().expect("one pose per row"))
        })
        .collect()
}

/// The rows of `set` whose held-out errors `held` (mm, deg per row) lie beyond `k` robust
/// sigmas ([`crate::stats::robust_sigma`]) of their column; none for an infinite or NaN `k`.
/// The scale weighs each arm configuration once (`groups[i]`: row i's, ids from 0; the
/// robust sigma of each configuration's mean error): a configuration measured thirty times
/// would otherwise be the median, and its error the scale (a reviewer's repeatability run
/// put an ordinary row at 6.6 sigmas).
pub fn outliers_of(
    set: &MeasurementSet,
    held: &[(f64, Option<f64>)],
    groups: &[usize],
    k: f64,
) -> Vec<Outlier> {
    if !k.is_finite() {
        return Vec::new();
    }
    let per_configuration = |value: fn(&(f64, Option<f64>)) -> Option<f64>| {
        let pairs = (groups.iter().zip(held)).filter_map(|(&g, h)| value(h).map(|v| (g, v)));
        let means = super::rank::cluster_means(pairs);
        (!means.is_empty()).then(|| crate::stats::robust_sigma(&means))
    };
    let pos = per_configuration(|h| Some(h.0)).unwrap_or(0.0);
    let rot = per_configuration(|h| h.1).unwrap_or(0.0);
    let sigmas = |e: f64, s: f64| if s > 0.0 { e / s } else { 0.0 };
    held.iter()
        .zip(&set.rows)
        .enumerate()
        .filter_map(|(row, (&(p, r), m))| {
            let z = sigmas(p, pos).max(r.map_or(0.0, |r| sigmas(r, rot)));
            (z > k).then_some(Outlier {
                row,
                line: m.line,
                position_mm: p,
                orientation_deg: r,
                robust_sigmas: z,
            })
        })
        .collect()
}

/// The number of distinct configurations among rows' configuration ids `clusters` (a subset
/// of rows holds fewer than the largest id + 1: the unseen test's 90 rows read 146, a
/// helper's).
pub(super) fn distinct(clusters: &[usize]) -> usize {
    let mut ids = clusters.to_vec();
    ids.sort_unstable();
    ids.dedup();
    ids.len()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::data::Measurement;

    #[test]
    fn distinct_counts_ids_not_the_largest() {
        assert_eq!(distinct(&[7, 3, 7, 146, 3]), 3);
        assert_eq!(distinct(&[]), 0);
    }

    #[test]
    fn folds_keep_repeated_configurations_together_and_balance() {
        // 30 configurations, the first 10 measured three times with the encoders' noise.
        let mut rows = Vec::new();
        let mut config = Vec::new();
        for k in 0..30 {
            let times = if k < 10 { 3 } else { 1 };
            for t in 0..times {
                let noise = t as f64 * 2e-3;
                rows.push(Measurement::new(vec![
                    k as f64 * 0.05 + noise,
                    0.2,
                    0.3 - noise,
                ]));
                config.push(k);
            }
        }
        let set = MeasurementSet::from_rows(rows);
        let qs: Vec<&[f64]> = set.rows.iter().map(|m| m.q.as_slice()).collect();
        let groups = crate::neural::repeats::joint_groups(&qs);
        let f = folds(&groups, 5, 7);
        assert_eq!(f.len(), 50);
        for i in 0..50 {
            for j in 0..50 {
                if config[i] == config[j] {
                    assert_eq!(f[i], f[j], "rows {i} and {j} repeat one configuration");
                }
            }
        }
        // Configurations are dealt round-robin: 6 per fold.
        let configurations = |k: usize| {
            let mut c: Vec<usize> = (0..50).filter(|&i| f[i] == k).map(|i| config[i]).collect();
            c.dedup();
            c.len()
        };
        assert!((0..5).all(|k| configurations(k) == 6));
        assert_ne!(f, folds(&groups, 5, 8), "the seed shuffles");
    }

    /// The outlier scale weighs each configuration once: 30 rows of one configuration held
    /// out at 0.05 mm beside 11 others (0.3-0.65 mm, 0.9 and 5 mm) put the rows' median at
    /// 0.05 mm, and every ordinary row from 0.4 mm up beyond 5 robust sigmas; over the 12
    /// configurations (median 0.5 mm) the 0.9 mm row is 1.2 sigmas out, and the 5 mm row is
    /// still named.
    #[test]
    fn a_repeated_configuration_is_one_value_of_the_outlier_scale() {
        let mut rows = vec![Measurement::new(vec![0.1, 0.2, 0.3]); 30];
        let mut held = vec![(0.05, None); 30];
        let mut groups = vec![0; 30];
        for k in 0..11 {
            rows.push(Measurement::new(vec![0.5 + 0.1 * k as f64, 0.2, 0.3]));
            held.push((if k == 10 { 5.0 } else { 0.3 + 0.05 * k as f64 }, None));
            groups.push(k + 1);
        }
        held[39].0 = 0.9;
        let set = MeasurementSet::from_rows(rows);
        let named: Vec<usize> = outliers_of(&set, &held, &groups, 5.0)
            .iter()
            .map(|o| o.row)
            .collect();
        assert_eq!(named, vec![40]);
        // Each row its own configuration, as before: every row from 0.4 mm up is named.
        let alone: Vec<usize> = (0..held.len()).collect();
        let named: Vec<usize> = outliers_of(&set, &held, &alone, 5.0)
            .iter()
            .map(|o| o.row)
            .collect();
        assert_eq!(named, (32..41).collect::<Vec<_>>());
    }
}
