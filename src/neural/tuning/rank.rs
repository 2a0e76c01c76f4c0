//! Ranking the scored candidates, and drawing the next ones from the best.

use crate::neural::selection::Candidate;
use crate::neural::settings::{Form, Network, Settings};

/// The best-scored pose-form MLP candidate, the partner of a mixed candidate.
pub(super) fn best_pose_mlp(candidates: &[Candidate]) -> Option<usize> {
    best_where(
        candidates,
        |c| c.form == Form::Pose && c.network == Network::Mlp && c.members > 0,
        cv_rms,
    )
}

/// The candidate whose settings pass `keep` with the lowest score `judged(candidates,
/// index)` (the first of equals), scored or not; None where none passes.
pub(super) fn best_where(
    candidates: &[Candidate],
    keep: impl Fn(&Settings) -> bool,
    judged: impl Fn(&[Candidate], usize) -> f64,
) -> Option<usize> {
    (0..candidates.len())
        .filter(|&i| keep(&candidates[i].settings))
        .fold(None, |b: Option<usize>, i| {
            Some(b.map_or(i, |b| better_by(candidates, b, i..i + 1, &judged)))
        })
}

/// Cross-validated position RMS of candidate `i` (mm); infinite when it has no score.
pub(super) fn cv_rms(candidates: &[Candidate], i: usize) -> f64 {
    candidates[i]
        .score
        .as_ref()
        .map_or(f64::INFINITY, |s| s.position_rms_mm)
}

/// The best of `current` and the candidates in `new` (ties keep the earlier one).
pub(super) fn better(
    candidates: &[Candidate],
    current: usize,
    new: std::ops::Range<usize>,
) -> usize {
    better_by(candidates, current, new, cv_rms)
}

/// [`better`] by the score `judged(candidates, index)` (lower is better).
pub(super) fn better_by(
    candidates: &[Candidate],
    current: usize,
    new: std::ops::Range<usize>,
    judged: impl Fn(&[Candidate], usize) -> f64,
) -> usize {
    new.fold(current, |b, i| {
        if judged(candidates, i) < judged(candidates, b) {
            i
        } else {
            b
        }
    })
}

/// Paired z of `a` against `b` (the same rows' errors, in the same order) with the rows in
/// clusters (`cluster[i]`: row i's, ids from 0), each cluster weighed once: the mean over
/// the G clusters of each cluster's mean difference d_g (of d = a - b) over its standard
/// error, sd(d_g) / sqrt(G). Rows of one cluster (repeats of one arm configuration) share
/// their error: counted as independent rows they would make the difference look surer than
/// it is, and a configuration measured fifty times among ten measured once would decide the
/// mean alone (a reviewer's repeatability run made a network that was 44 % worse on new rows
/// pass at z -5.0; each configuration weighed once, the same rows give -0.3). With every row
/// its own cluster this is the usual sd / sqrt(n), and with clusters of equal size it is the
/// cluster-robust standard error of the row mean. Negative where `a` is lower; 0 for fewer
/// than 2 clusters or where the differences are all equal to zero, and infinite (of the
/// mean's sign) where the clusters' means are all equal otherwise.
pub(super) fn paired_z(a: &[f64], b: &[f64], cluster: &[usize]) -> f64 {
    let n = a.len().min(b.len()).min(cluster.len());
    let means = cluster_means((0..n).map(|i| (cluster[i], a[i] - b[i])));
    if means.len() < 2 {
        return 0.0;
    }
    let c = means.len() as f64;
    let mean = means.iter().sum::<f64>() / c;
    let var = means.iter().map(|m| (m - mean).powi(2)).sum::<f64>() / (c - 1.0);
    let se = (var / c).sqrt();
    if se > 0.0 {
        mean / se
    } else if mean == 0.0 {
        0.0
    } else {
        mean.signum() * f64::INFINITY
    }
}

/// The mean value of each cluster among `(cluster, value)` pairs (ids from 0), in the
/// clusters' order, those without a value left out: each arm configuration as one value,
/// however often it was measured.
pub(super) fn cluster_means(pairs: impl IntoIterator<Item = (usize, f64)>) -> Vec<f64> {
    let (mut sums, mut counts): (Vec<f64>, Vec<usize>) = (Vec::new(), Vec::new());
    for (c, v) in pairs {
        if c >= sums.len() {
            sums.resize(c + 1, 0.0);
            counts.resize(c + 1, 0);
        }
        sums[c] += v;
        counts[c] += 1;
    }
    (sums.iter().zip(&counts))
        .filter(|(_, n)| **n > 0)
        .map(|(s, &n)| s / n as f64)
        .collect()
}

/// `x` to 3 significant digits (penalties read back as typed: 0.333, not 0.3333333333333333).
pub(super) fn significant3(x: f64) -> f64 {
    if x == 0.0 || !x.is_finite() {
        return x;
    }
    let scale = 10f64.powi(2 - x.abs().log10().floor() as i32);
    (x * scale).round() / scale
}

/// `base` with one setting changed to each of `values`.
pub(super) fn vary<T: Clone>(
    base: &Settings,
    values: &[T],
    set: impl Fn(&mut Settings, T),
) -> Vec<Settings> {
    values
        .iter()
        .map(|v| {
            let mut s = base.clone();
            set(&mut s, v.clone());
            s
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::neural::tuning::{FIT_WORK, budget_epochs};

    /// Against values computed by hand. Rows alone: differences -1, -2, -3 have mean -2 and
    /// standard deviation 1, so z = -2 / (1 / sqrt 3) = -2 sqrt 3. In clusters: differences
    /// -1, -1 | -3, -3 have cluster means -1 and -3, their mean -2 and standard deviation
    /// sqrt 2, so the standard error is sqrt 2 / sqrt 2 = 1 and z = -2, where the rows
    /// counted alone would give -2 / sqrt(4 / 3 / 4) = -2 sqrt 3.
    #[test]
    fn paired_z_is_the_mean_difference_over_its_standard_error() {
        let alone = [0, 1, 2];
        let z = paired_z(&[1.0, 2.0, 3.0], &[2.0, 4.0, 6.0], &alone);
        assert!((z + 2.0 * 3f64.sqrt()).abs() < 1e-12, "{z}");
        let z = paired_z(&[2.0, 4.0, 6.0], &[1.0, 2.0, 3.0], &alone);
        assert!((z - 2.0 * 3f64.sqrt()).abs() < 1e-12, "{z}");
        let (a, b) = ([0.0, 0.0, 0.0, 0.0], [1.0, 1.0, 3.0, 3.0]);
        let z = paired_z(&a, &b, &[0, 0, 1, 1]);
        assert!((z + 2.0).abs() < 1e-12, "{z}");
        let z = paired_z(&a, &b, &[0, 1, 2, 3]);
        assert!((z + 2.0 * 3f64.sqrt()).abs() < 1e-12, "{z}");
        assert_eq!(paired_z(&[1.0, 2.0], &[1.0, 2.0], &[0, 1]), 0.0);
        assert_eq!(
            paired_z(&[1.0, 2.0], &[2.0, 3.0], &[0, 1]),
            f64::NEG_INFINITY
        );
        assert_eq!(paired_z(&[1.0], &[5.0], &[0]), 0.0);
        // One configuration measured twice is one cluster: no test.
        assert_eq!(paired_z(&[1.0, 2.0], &[5.0, 7.0], &[3, 3]), 0.0);
        // Clusters of unequal size weigh alike: differences -1 x4 | 0 | 1 have cluster means
        // -1, 0, 1, mean 0: no difference, where the rows' mean (-0.5) would give z -1.3
        // with the cluster-robust error of the row mean.
        let d = [-1.0, -1.0, -1.0, -1.0, 0.0, 1.0];
        assert_eq!(paired_z(&d, &[0.0; 6], &[0, 0, 0, 0, 1, 2]), 0.0);
        // Cluster means -1, -2, -3 (sizes 3, 1, 2): mean -2, sd 1, z = -2 sqrt 3.
        let d = [-1.0, -0.5, -1.5, -2.0, -3.0, -3.0];
        let z = paired_z(&d, &[0.0; 6], &[0, 0, 0, 1, 2, 2]);
        assert!((z + 2.0 * 3f64.sqrt()).abs() < 1e-12, "{z}");
    }

    #[test]
    fn penalties_keep_three_significant_digits() {
        assert_eq!(significant3(1.0 / 3.0), 0.333);
        assert_eq!(significant3(0.1 * 3.0), 0.3);
        assert_eq!(significant3(30.000000000000004), 30.0);
        assert_eq!(budget_epochs(FIT_WORK, 2000, 50, 60), 50);
        assert_eq!(budget_epochs(FIT_WORK, 150, 50, 60), 60);
    }
}
