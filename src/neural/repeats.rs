//! Which rows are one configuration: the unit that cross-validation folds and the
//! validation-failure hold-out keep together, so that a held-out row is never predicted from
//! its own repeat.
//!
//! Two measurements of one commanded pose do not log the same joint values (see
//! [`crate::data::configuration`]). Grouping only bit-equal joint values split every repeated
//! pair of the shipped UR10 series across folds and leaked each held-out row's own
//! measurement into its training part. Rows closer than [`SAME_CONFIGURATION`] in every joint
//! are therefore one configuration: at that distance the model's residual field, which the
//! network learns, barely moves, so two such rows are one sample whether or not they were
//! commanded alike.

use crate::data::MeasurementSet;
use crate::data::configuration::same_configuration;
use crate::data::measurement::copied_rows;
use crate::kinematics::tool_pose;
use crate::model::{JointType, Robot};
use nalgebra::Vector3;
use std::f64::consts::PI;

pub use crate::data::configuration::SAME_CONFIGURATION;

/// Group id of every row: a row joins the group of the first row (in the sweep's order, the
/// order of the joint whose values spread widest) whose joint values all lie within
/// [`SAME_CONFIGURATION`] (rad or mm) of its own; otherwise it starts a group. Groups do not
/// chain: a path sampled every 0.5 deg is many configurations, not one. Ids count from 0 in
/// the order of each group's first row in the file.
///
/// A revolute joint of `robot` is compared modulo whole turns ([`turn_groups`]): q and
/// q + 2 pi put the arm in one pose, and a wrist logged at 179.9999 and -179.9999 deg is one
/// configuration, so a fold never predicts a row from such a twin.
pub fn configuration_groups(robot: &Robot, set: &MeasurementSet) -> Vec<usize> {
    let qs: Vec<&[f64]> = set.rows.iter().map(|m| m.q.as_slice()).collect();
    let joints = robot.joints();
    turn_groups(&qs, |j| {
        joints
            .get(j)
            .is_some_and(|joint| joint.joint_type == JointType::Revolute)
    })
}

/// An angle (rad) in the middle of the widest gap between `angles` on the circle: cut there,
/// the circle leaves every cluster of them whole. 0 for no angles.
pub fn widest_gap_cut(angles: impl Iterator<Item = f64>) -> f64 {
    let (cut, _) = widest_gap(angles);
    cut
}

/// [`widest_gap_cut`] and the width of that gap (rad; 2 pi for fewer than two angles).
pub fn widest_gap(angles: impl Iterator<Item = f64>) -> (f64, f64) {
    let mut a: Vec<f64> = angles.map(|v| v.rem_euclid(2.0 * PI)).collect();
    a.sort_by(f64::total_cmp);
    let (Some(&first), Some(&last)) = (a.first(), a.last()) else {
        return (0.0, 2.0 * PI);
    };
    // The gap from the last angle round to the first, then those between neighbours.
    let mut best = (first + 2.0 * PI - last, last);
    for w in a.windows(2) {
        if w[1] - w[0] > best.0 {
            best = (w[1] - w[0], w[0]);
        }
    }
    (best.1 + best.0 / 2.0, best.0)
}

/// Angle `v` (rad) a whole number of turns into [cut, cut + 2 pi).
pub fn from_cut(v: f64, cut: f64) -> f64 {
    cut + (v - cut).rem_euclid(2.0 * PI)
}

/// [`joint_groups`] with every joint for which `periodic(j)` holds compared modulo whole
/// turns: q and q + 2 pi are one value, and so are 179.9999 and -179.9999 deg. The raw values'
/// groups are grouped again, each by its first row in the sweep (its leader), the same way
/// with the joints compared modulo turns: a group joins the first group whose leader is within
/// [`SAME_CONFIGURATION`] of its own leader modulo turns (so every row lies within twice the
/// tolerance of its group's first leader: groups do not chain). Raw leaders are never within
/// the tolerance of each other on raw values, so where no two rows are one configuration only
/// modulo turns, the groups are the raw values' exactly. The second sweep runs on each such
/// joint taken from a cut in the widest gap between its values on the circle (a joint whose
/// values leave no gap of [`SAME_CONFIGURATION`] round the whole circle, where leaders could
/// lie across the cut, does not order it unless every joint is such).
pub fn turn_groups(qs: &[&[f64]], periodic: impl Fn(usize) -> bool) -> Vec<usize> {
    let leader = raw_leaders(qs);
    let dof = qs.iter().map(|q| q.len()).min().unwrap_or(0);
    let gaps: Vec<Option<(f64, f64)>> = (0..dof)
        .map(|j| periodic(j).then(|| widest_gap(qs.iter().map(|q| q[j]))))
        .collect();
    if qs.is_empty() || gaps.iter().all(Option::is_none) {
        return ids_in_file_order(&leader);
    }
    let cuts: Vec<Option<f64>> = gaps.iter().map(|g| g.map(|(cut, _)| cut)).collect();
    let dense = |j: usize| gaps[j].is_some_and(|(_, gap)| gap < SAME_CONFIGURATION);
    let key_joint = |j: usize| !dense(j) || (0..dof).all(dense);
    let wrapped: Vec<Vec<f64>> = qs
        .iter()
        .map(|q| {
            q.iter()
                .enumerate()
                .map(|(j, &v)| match cuts.get(j).copied().flatten() {
                    Some(c) => from_cut(v, c),
                    None => v,
                })
                .collect()
        })
        .collect();
    let wrapped: Vec<&[f64]> = wrapped.iter().map(Vec::as_slice).collect();
    let modulo_turns = |a: &[f64], b: &[f64]| {
        a.len() == b.len()
            && (a.iter().zip(b).enumerate()).all(|(j, (x, y))| {
                let d = (x - y).abs();
                let d = match cuts.get(j).copied().flatten() {
                    Some(_) => d.min(2.0 * PI - d),
                    None => d,
                };
                d < SAME_CONFIGURATION
            })
    };
    let key = sweep_key(&wrapped, key_joint);
    let mut leaders: Vec<usize> = leader.clone();
    leaders.sort_unstable();
    leaders.dedup();
    let joined = sweep(
        &leaders,
        |i| wrapped[i][key],
        |i, j| modulo_turns(wrapped[i], wrapped[j]),
    );
    // Each raw leader's group leader, then each row's.
    let mut of = vec![usize::MAX; qs.len()];
    for (&l, &g) in leaders.iter().zip(&joined) {
        of[l] = g;
    }
    let rows: Vec<usize> = leader.iter().map(|&l| of[l]).collect();
    ids_in_file_order(&rows)
}

/// [`configuration_groups`] of bare joint vectors (rad, mm), in their order.
pub fn joint_groups(qs: &[&[f64]]) -> Vec<usize> {
    ids_in_file_order(&raw_leaders(qs))
}

/// Each row's group leader on the raw values ([`joint_groups`]).
fn raw_leaders(qs: &[&[f64]]) -> Vec<usize> {
    // Sweep the rows in the order of the joint whose values spread widest (a joint held
    // still would make every pair a candidate): only rows within the tolerance in that joint
    // can be the same configuration.
    let key = sweep_key(qs, |_| true);
    let all: Vec<usize> = (0..qs.len()).collect();
    sweep(
        &all,
        |i| qs[i][key],
        |i, j| same_configuration(qs[i], qs[j]),
    )
}

/// The leader of each of `rows` (row indices): sweeping them in the order of `at`, a row joins
/// the first leader (in that order) within [`SAME_CONFIGURATION`] of it in `at` for which
/// `close(leader, row)` holds; otherwise it leads a group of its own. Leaders do not chain.
fn sweep(
    rows: &[usize],
    at: impl Fn(usize) -> f64,
    close: impl Fn(usize, usize) -> bool,
) -> Vec<usize> {
    let mut order: Vec<usize> = (0..rows.len()).collect();
    order.sort_by(|&a, &b| at(rows[a]).total_cmp(&at(rows[b])));
    // Each group's first row in the sweep, in the sweep's order (so their keys ascend and
    // those too far below the current row leave from the front).
    let mut leaders: Vec<usize> = Vec::new();
    let mut open = 0;
    let mut leader = vec![0; rows.len()];
    for &k in &order {
        let i = rows[k];
        while open < leaders.len() && at(i) - at(leaders[open]) >= SAME_CONFIGURATION {
            open += 1;
        }
        leader[k] = match leaders[open..].iter().find(|&&l| close(l, i)) {
            Some(&l) => l,
            None => {
                leaders.push(i);
                i
            }
        };
    }
    leader
}

/// Group ids (from 0, in the order of each group's first row in the file) of rows given
/// their groups' leader rows.
fn ids_in_file_order(leader: &[usize]) -> Vec<usize> {
    let mut id = std::collections::HashMap::new();
    leader
        .iter()
        .map(|l| {
            let next = id.len();
            *id.entry(*l).or_insert(next)
        })
        .collect()
}

/// The joint to sweep rows along: of those for which `key_joint` holds, the one whose values
/// spread widest (0 for none).
fn sweep_key(qs: &[&[f64]], key_joint: impl Fn(usize) -> bool) -> usize {
    let dof = qs.iter().map(|q| q.len()).min().unwrap_or(0);
    let spread = |k: usize| {
        let (lo, hi) = qs
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), q| {
                (lo.min(q[k]), hi.max(q[k]))
            });
        hi - lo
    };
    (0..dof)
        .filter(|&j| key_joint(j))
        .max_by(|&a, &b| spread(a).total_cmp(&spread(b)))
        .unwrap_or(0)
}

/// The number of groups (distinct configurations) in ids from [`configuration_groups`].
pub fn group_count(groups: &[usize]) -> usize {
    groups.iter().max().map_or(0, |m| m + 1)
}

/// How far the model's position residuals of repeated configurations disagree. The network's
/// input (the joints) is the same for every row of a configuration, so no compensator can
/// follow these differences: they are the data's own floor.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Repeats {
    /// Configurations measured more than once (rows with a measured position).
    pub configurations: usize,
    /// Rows in them (a pasted copy of a row, [`copied_rows`], is none).
    pub rows: usize,
    /// Pure error (mm): sqrt(sum_g sum_i |e_i - ebar_g|^2 / sum_g (n_g - 1)), e_i the
    /// position residual of row i (measured minus model), ebar_g its configuration's mean and
    /// n_g its rows; the RMS position error a perfect compensator would leave on one row.
    pub pure_error_rms_mm: f64,
    /// Median over the configurations of the largest distance between two of their rows'
    /// residuals (mm).
    pub median_spread_mm: f64,
    /// The largest such distance (mm).
    pub max_spread_mm: f64,
    /// The source-file lines of the two rows that differ by `max_spread_mm` (0 for rows built
    /// in code).
    pub max_spread_lines: [usize; 2],
}

impl Repeats {
    /// The repeats of `set` under `model`; None when no configuration has two rows with
    /// positions.
    pub fn of(model: &Robot, set: &MeasurementSet) -> Option<Repeats> {
        let groups = configuration_groups(model, set);
        let count = group_count(&groups);
        let mut members: Vec<Vec<(usize, Vector3<f64>)>> = vec![Vec::new(); count];
        let mut sizes = vec![0usize; count];
        for g in &groups {
            sizes[*g] += 1;
        }
        // A pasted copy of a row ([`copied_rows`]) is no second reading of its pose.
        let mut copy = vec![false; set.rows.len()];
        for (c, _) in copied_rows(set) {
            copy[c] = true;
        }
        for (i, m) in set.rows.iter().enumerate() {
            if sizes[groups[i]] < 2 || copy[i] {
                continue;
            }
            if let Some(p) = m.position {
                let dp = p - tool_pose(model, &m.q).translation.vector;
                members[groups[i]].push((m.line, dp));
            }
        }
        members.retain(|g| g.len() >= 2);
        if members.is_empty() {
            return None;
        }
        let (mut squares, mut dof, mut rows) = (0.0, 0usize, 0usize);
        let mut spreads = Vec::with_capacity(members.len());
        let mut worst: Option<(f64, [usize; 2])> = None;
        for g in &members {
            let mean = g.iter().map(|(_, e)| e).sum::<Vector3<f64>>() / g.len() as f64;
            squares += g
                .iter()
                .map(|(_, e)| (e - mean).norm_squared())
                .sum::<f64>();
            dof += g.len() - 1;
            rows += g.len();
            let mut spread = 0.0;
            for (a, (la, ea)) in g.iter().enumerate() {
                for (lb, eb) in &g[a + 1..] {
                    let d = (ea - eb).norm();
                    if d > spread {
                        spread = d;
                    }
                    if worst.is_none_or(|(w, _)| d > w) {
                        worst = Some((d, [*la, *lb]));
                    }
                }
            }
            spreads.push(spread);
        }
        let (n, median) = (spreads.len(), crate::stats::median(&spreads));
        let (max_spread_mm, max_spread_lines) = worst?;
        Some(Repeats {
            configurations: n,
            rows,
            pure_error_rms_mm: (squares / dof as f64).sqrt(),
            median_spread_mm: median,
            max_spread_mm,
            max_spread_lines,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::data::Measurement;

    fn set(qs: &[[f64; 6]]) -> MeasurementSet {
        MeasurementSet::from_rows(qs.iter().map(|q| Measurement::new(q.to_vec())).collect())
    }

    fn rows(set: &MeasurementSet) -> Vec<&[f64]> {
        set.rows.iter().map(|m| m.q.as_slice()).collect()
    }

    #[test]
    fn a_revolute_joint_is_one_configuration_a_whole_turn_away_a_prismatic_one_is_not() {
        let robot = crate::model::test_rpr_arm();
        let turn = 2.0 * PI;
        let set3 = |qs: &[[f64; 3]]| {
            MeasurementSet::from_rows(qs.iter().map(|q| Measurement::new(q.to_vec())).collect())
        };
        let a = [0.3, 5.0, -1.0];
        let twins = set3(&[
            a,
            [0.3 + turn, 5.0, -1.0],        // joint 1 a turn on
            [0.3, 5.0, -1.0 - turn + 4e-3], // joint 3 a turn back, with encoder noise
            [0.3, 5.0 + turn, -1.0],        // the prismatic joint 2 pi mm on: elsewhere
            [PI - 1e-9, 5.0, 1.0],          // either side of +-180 deg
            [-PI + 1e-9, 5.0, 1.0],
        ]);
        assert_eq!(configuration_groups(&robot, &twins), vec![0, 0, 0, 1, 2, 2]);
        // On raw values, as without the turns, every row but the seam's is its own.
        assert_eq!(joint_groups(&rows(&twins)), vec![0, 1, 2, 3, 4, 5]);
        // Rows no whole turn apart group as on raw values, whatever the cut.
        let spread: Vec<[f64; 6]> = (0..40)
            .map(|k| {
                let t = -3.1 + k as f64 * 0.155;
                [t, 0.5 * t, -t, 0.0, 1.0, t + 1e-3 * (k % 2) as f64]
            })
            .collect();
        let ur10 = crate::model::read_robot(
            std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("datasets/robots/ur10.toml"),
        )
        .unwrap();
        let s = set(&spread);
        assert_eq!(configuration_groups(&ur10, &s), joint_groups(&rows(&s)));
        // A wrist logged every 0.5 deg round the whole circle, its widest gap (0.55 deg,
        // within the tolerance) between two rows of one configuration a turn apart: the cut
        // lies between them, and they are still found to be one configuration.
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
        let mut wrist: Vec<f64> = (0..=200).map(|k| k as f64 * 0.5).collect();
        wrist.extend((0..=518).map(|k| 100.55 + k as f64 * 0.5));
        let dense: Vec<[f64; 6]> = (wrist.iter())
            .map(|&w| {
                let mut q = [0.0; 6];
                q[..5]
                    .iter_mut()
                    .for_each(|v| *v = rng.random_range(-3.0..3.0));
                q[5] = w.to_radians();
                q
            })
            .collect();
        let mut dense = dense;
        let (a, b) = (200, 201);
        let a_joints = dense[a];
        dense[b][..5].copy_from_slice(&a_joints[..5]);
        dense[b][5] += 2.0 * PI;
        let s = set(&dense);
        let g = configuration_groups(&ur10, &s);
        assert_eq!(g[a], g[b]);
        assert_eq!(group_count(&g), dense.len() - 1);
        let raw = joint_groups(&rows(&s));
        assert_ne!(raw[a], raw[b]);
        assert_eq!(group_count(&raw), dense.len());
        // A path sampled every 0.5 deg across +-180 deg (groups that depend on the sweep's
        // order): no two rows a turn apart, so the raw values' groups exactly (a reviewer's
        // rows: joint 1 at 0, -0.5, -1 deg, joint 6 at 177.6 or -177.6 deg).
        let deg = |q: [f64; 6]| q.map(f64::to_radians);
        // Twins do not chain groups: 0 and 360.5 deg are one configuration, 360.5 and 1 deg
        // too, but 0 and 1 deg are not (a reviewer's rows, all three joined before).
        let three = set(&[
            deg([10.0, -90.0, 90.0, 0.0, 90.0, 0.0]),
            deg([10.0, -90.0, 90.0, 0.0, 90.0, 360.5]),
            deg([10.0, -90.0, 90.0, 0.0, 90.0, 1.0]),
        ]);
        let g = configuration_groups(&ur10, &three);
        assert_eq!(group_count(&g), 2, "{g:?}");
        assert_ne!(g[0], g[2]);
        // Three rows, each two of them twins: one configuration in every order (a group
        // joined by another could join no third).
        let rows3 = [
            deg([10.2, -80.0, 70.0, -60.0, 80.0, 0.0]),
            deg([10.0, -80.0, 70.0, -60.0, 80.0, 360.0]),
            deg([10.1, -80.0, 70.0, -60.0, 80.0, -360.0]),
        ];
        for order in [[0, 1, 2], [1, 0, 2], [2, 1, 0], [1, 2, 0]] {
            let g = configuration_groups(&ur10, &set(&order.map(|k| rows3[k])));
            assert_eq!(group_count(&g), 1, "{order:?}: {g:?}");
        }
        // A twin of a group's leader's neighbour joins it, whichever row of the group comes
        // first in the file (its first row is not its leader).
        let group = [
            deg([10.0, -80.0, 70.0, -60.0, 79.5, 0.1]),
            deg([10.0, -80.0, 70.0, -60.0, 80.0, 0.0]),
            deg([10.0, -80.0, 70.0, -60.0, 80.5, 0.2]),
            deg([10.0, -80.0, 70.0, -60.0, 80.5, 360.2]),
        ];
        for order in [[0, 1, 2, 3], [1, 0, 2, 3], [3, 2, 1, 0]] {
            let g = configuration_groups(&ur10, &set(&order.map(|k| group[k])));
            assert_eq!(group_count(&g), 1, "{order:?}: {g:?}");
        }
        let chain = set(&[
            deg([0.0, -90.0, 90.0, 0.0, 90.0, 177.6]),
            deg([-0.5, -90.0, 90.0, 0.0, 90.0, 177.6]),
            deg([-1.0, -90.0, 90.0, 0.0, 90.0, 177.6]),
            deg([60.0, -80.0, 70.0, 10.0, 80.0, -177.6]),
            deg([30.0, -70.0, 60.0, 20.0, 70.0, -177.6]),
        ]);
        assert_eq!(
            configuration_groups(&ur10, &chain),
            joint_groups(&rows(&chain))
        );
    }

    #[test]
    fn the_cut_lies_in_the_widest_gap() {
        let cut = |v: &[f64]| widest_gap_cut(v.iter().copied());
        // Values around +-pi: the widest gap is around 0.
        let c = cut(&[3.1, -3.1, 3.0, -3.0]);
        assert!(
            (c - 0.0).abs() < 1e-12 || (c - 2.0 * PI).abs() < 1e-12,
            "{c}"
        );
        // Values around 0: the cut lies opposite, at pi.
        assert!((cut(&[-0.5, 0.5, 0.1]) - PI).abs() < 1e-12);
        assert_eq!(cut(&[]), 0.0);
    }

    #[test]
    fn repeats_within_the_tolerance_are_one_configuration_and_groups_do_not_chain() {
        let a = [0.1, -1.2, 0.8, 0.3, 1.0, -0.5];
        let mut a_again = a;
        a_again[2] += 3e-3;
        a_again[5] -= 6e-3;
        let mut b = a;
        b[4] += 2e-2; // one joint 1.15 deg away: another configuration
        let mut c = b;
        c[0] -= 0.9e-2; // within the tolerance of b: b's group
        let mut d = c;
        d[0] -= 0.9e-2; // 1.8e-2 from b, within the tolerance of c only: a group of its own
        let other = [-2.0, 0.4, -0.3, 1.1, -1.0, 2.0];
        let s = set(&[a, b, other, a_again, d, c, other]);
        let g = joint_groups(&rows(&s));
        assert_eq!(g, vec![0, 1, 2, 0, 3, 1, 2]);
        assert_eq!(group_count(&g), 4);
        // A path sampled every 0.5 deg (8.7e-3 rad) is not one configuration: each group
        // spans less than the tolerance.
        let path: Vec<[f64; 6]> = (0..120)
            .map(|k| [-0.5 + k as f64 * 8.7e-3, -1.0, 0.5, 0.0, 1.0, 0.0])
            .collect();
        let g = joint_groups(&rows(&set(&path)));
        assert!(group_count(&g) >= 60, "{}", group_count(&g));
        for (i, gi) in g.iter().enumerate() {
            for (j, gj) in g.iter().enumerate() {
                if gi == gj {
                    assert!((path[i][0] - path[j][0]).abs() < SAME_CONFIGURATION);
                }
            }
        }
    }

    #[test]
    fn a_joint_held_still_does_not_hide_close_rows() {
        // Joint 1 never moves; rows are told apart by joint 2.
        let mut qs = Vec::new();
        for k in 0..20 {
            qs.push([0.5, k as f64 * 0.1, 0.0, 0.0, 0.0, 0.0]);
        }
        qs.push([0.5 + 5e-3, 1.0 + 5e-3, 0.0, 0.0, 0.0, 0.0]); // row 10 again
        qs.push([0.6, 1.0, 0.0, 0.0, 0.0, 0.0]); // close to row 10 in joint 2 only
        let g = joint_groups(&rows(&set(&qs)));
        assert_eq!(g[20], g[10]);
        assert_ne!(g[21], g[10]);
        assert_eq!(group_count(&g), 21);
    }

    #[test]
    fn repeats_measure_how_far_the_residuals_of_one_configuration_disagree() {
        let robot = crate::model::read_robot(
            std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("datasets/robots/ur10.toml"),
        )
        .unwrap();
        let row = |q: [f64; 6], off: [f64; 3], line: usize| {
            let mut m = Measurement::new(q.to_vec());
            // The position the model gives at the commanded joints, moved by `off` (mm).
            let p = tool_pose(&robot, &q).translation.vector;
            m.position = Some(p + Vector3::from(off));
            m.line = line;
            m
        };
        let a = [0.1, -1.2, 0.8, 0.3, 1.0, -0.5];
        let b = [1.1, -0.7, 1.5, -0.3, 0.4, 0.5];
        let c = [-1.0, -2.0, 1.0, 0.0, -1.0, 2.0];
        let set = MeasurementSet::from_rows(vec![
            row(a, [0.0, 0.0, 0.0], 2),
            row(b, [1.0, 0.0, 0.0], 3),
            row(a, [0.0, 0.3, 0.4], 4),
            row(b, [1.0, 0.0, 0.1], 5),
            row(c, [5.0, 5.0, 5.0], 6),
            row(b, [1.0, 0.0, -0.1], 7),
        ]);
        let r = Repeats::of(&robot, &set).unwrap();
        assert_eq!((r.configurations, r.rows), (2, 5));
        // a: one pair 0.5 apart (squares 0.125 about the mean, 1 dof); b: three rows at
        // z = 0, 0.1, -0.1 (squares 0.02, 2 dof).
        assert!(
            (r.pure_error_rms_mm - (0.145f64 / 3.0).sqrt()).abs() < 1e-9,
            "{r:?}"
        );
        assert!((r.median_spread_mm - 0.35).abs() < 1e-9);
        assert!((r.max_spread_mm - 0.5).abs() < 1e-9);
        assert_eq!(r.max_spread_lines, [2, 4]);
        // A row pasted twice is no repeat: alone, nothing to report; beside real repeats, it
        // leaves every figure as it was (counted, it would add a zero residual and a degree
        // of freedom).
        let twice = MeasurementSet::from_rows(vec![row(c, [0.0; 3], 3), row(c, [0.0; 3], 9)]);
        assert!(Repeats::of(&robot, &twice).is_none());
        let mut pasted = set.clone();
        pasted.rows.push(row(b, [1.0, 0.0, 0.0], 8));
        assert_eq!(Repeats::of(&robot, &pasted).unwrap(), r);
        // Without a repeat there is nothing to report.
        assert!(
            Repeats::of(
                &robot,
                &MeasurementSet::from_rows(vec![row(c, [0.0; 3], 2)])
            )
            .is_none()
        );
    }
}
