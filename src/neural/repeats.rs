//! Which rows are one configuration: the unit that cross-validation folds and the
//! validation-failure hold-out keep together, so that a held-out row is never predicted from
//! its own repeat.
//!
//! A tracker campaign that measures a configuration twice commands the same joint targets, yet
//! the joint values it logs differ by the encoders' noise: on the shipped UR10 Series B the
//! 293 repeated pairs differ by up to 3e-4 rad in some joint (no two other rows come closer
//! than 1e-2 rad). Grouping only bit-equal joint values would split those pairs across folds and
//! leak each held-out row's own measurement into its training part. Rows closer than
//! [`SAME_CONFIGURATION`] in every joint are therefore one configuration, transitively: at that
//! distance the model's residual field, which the network learns, cannot differ beyond the
//! tracker's noise, so two such rows are one sample whether or not they were commanded alike.

use crate::data::MeasurementSet;

/// Largest difference in every joint (rad; 1e-3 rad = 0.057 deg) at which two rows are the
/// same configuration.
pub const SAME_CONFIGURATION: f64 = 1e-3;

/// Group id of every row: rows whose joint values all differ by less than
/// [`SAME_CONFIGURATION`] (rad) share one, and so do chains of such rows. Ids count from 0 in
/// the order of each group's first row.
pub fn configuration_groups(set: &MeasurementSet) -> Vec<usize> {
    let rows = &set.rows;
    let n = rows.len();
    // Sweep the rows in the order of their first joint: only rows within the tolerance in that
    // joint can be the same configuration.
    let first = |i: usize| rows[i].q.first().copied().unwrap_or(0.0);
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by(|&a, &b| first(a).total_cmp(&first(b)));
    let mut root: Vec<usize> = (0..n).collect();
    for (a, &i) in order.iter().enumerate() {
        for &j in &order[a + 1..] {
            if first(j) - first(i) >= SAME_CONFIGURATION {
                break;
            }
            let close = rows[i].q.len() == rows[j].q.len()
                && rows[i]
                    .q
                    .iter()
                    .zip(&rows[j].q)
                    .all(|(x, y)| (x - y).abs() < SAME_CONFIGURATION);
            if close {
                let (ri, rj) = (find(&mut root, i), find(&mut root, j));
                // The smaller row index becomes the root, so ids follow first appearance.
                root[ri.max(rj)] = ri.min(rj);
            }
        }
    }
    let mut id = vec![usize::MAX; n];
    let mut next = 0;
    (0..n)
        .map(|i| {
            let r = find(&mut root, i);
            if id[r] == usize::MAX {
                id[r] = next;
                next += 1;
            }
            id[r]
        })
        .collect()
}

/// The root of `i`'s group, halving the path on the way.
fn find(root: &mut [usize], mut i: usize) -> usize {
    while root[i] != i {
        root[i] = root[root[i]];
        i = root[i];
    }
    i
}

/// The number of distinct configurations of `set` (see [`configuration_groups`]).
pub fn distinct_configurations(set: &MeasurementSet) -> usize {
    configuration_groups(set)
        .into_iter()
        .max()
        .map_or(0, |m| m + 1)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::data::Measurement;

    fn set(qs: &[[f64; 6]]) -> MeasurementSet {
        MeasurementSet::from_rows(qs.iter().map(|q| Measurement::new(q.to_vec())).collect())
    }

    #[test]
    fn repeats_within_the_encoders_noise_are_one_configuration() {
        let a = [0.1, -1.2, 0.8, 0.3, 1.0, -0.5];
        let mut a_again = a;
        a_again[2] += 3e-4;
        a_again[5] -= 2e-4;
        let mut b = a;
        b[4] += 2e-3; // one joint 0.11 deg away: another configuration
        let mut c = b;
        c[0] -= 0.9e-3; // within the tolerance of b only
        let mut d = c;
        d[1] += 0.9e-3; // chains to b through c
        let other = [-2.0, 0.4, -0.3, 1.1, -1.0, 2.0];
        let s = set(&[a, b, other, a_again, c, d, other]);
        assert_eq!(configuration_groups(&s), vec![0, 1, 2, 0, 1, 1, 2]);
        assert_eq!(distinct_configurations(&s), 3);
    }

    #[test]
    fn rows_sorted_apart_by_other_joints_are_still_compared() {
        // Many rows share the first joint; the sweep must not stop at the first mismatch.
        let mut qs = Vec::new();
        for k in 0..20 {
            qs.push([0.5, k as f64 * 0.1, 0.0, 0.0, 0.0, 0.0]);
        }
        qs.push([0.5 + 5e-4, 1.0 + 1e-4, 0.0, 0.0, 0.0, 0.0]);
        let g = configuration_groups(&set(&qs));
        assert_eq!(g[20], g[10]);
        assert_eq!(distinct_configurations(&set(&qs)), 20);
    }
}
