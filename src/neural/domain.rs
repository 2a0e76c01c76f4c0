//! A compensator's training domain: where its network has seen data. A network extrapolates
//! badly, so configurations outside the domain are flagged wherever a compensator is used.
//!
//! A configuration is inside when every joint lies within the range the training rows
//! covered and its distance to the nearest training configuration, measured in the network's
//! normalised input space, is at most the domain's radius: the distance that 99 % of the
//! training configurations are within of their nearest other configuration (a single
//! isolated training row would make the largest such distance meaningless); with a single
//! configuration, the distance within which a row of that configuration lies. Rows within
//! [`super::repeats::SAME_CONFIGURATION`] of each other in every joint are one configuration
//! ([`super::repeats::joint_groups`]), as in cross-validation.
//!
//! Beyond the radius the network is not trusted: its correction is scaled by the weight
//! w = 2 - d / radius, falling from 1 at the radius to 0 at twice the radius (d the distance to
//! the nearest training configuration), so far from its data the compensator is the model.

use super::encoding::Encoding;
use super::weights::Affine;
use crate::model::Robot;
use std::f64::consts::PI;

/// The training domain (joints in rad or mm; distances in normalised input units).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Domain {
    /// Smallest training value of each joint (rad or mm).
    pub joint_min: Vec<f64>,
    /// Largest training value of each joint (rad or mm).
    pub joint_max: Vec<f64>,
    /// The distinct training configurations as normalised network inputs.
    pub inputs: Vec<Vec<f64>>,
    /// Largest trusted distance to the nearest training configuration (normalised input
    /// units): the 99th percentile of the distances from each training configuration to the
    /// nearest other one, or for a single configuration the reach of its own rows (module
    /// doc).
    pub radius: f64,
}

/// How much wider than the raw range's own gap (rad, 90 deg) the widest gap between a
/// periodic joint's training values on the circle must be for the range to be the arc they
/// cover from it ([`Domain::fit`]).
pub const WRAP_GAP: f64 = PI / 2.0;

/// Relative tolerance of a joint's training range (of the value, at least 1 rad or mm): a
/// training row is inside its own range whatever the rounding of a turn or an arc's bound.
pub const RANGE_TOL: f64 = 1e-12;

/// Where one configuration stands against a domain.
#[derive(Debug, Clone, PartialEq)]
pub struct DomainCheck {
    /// Joints (0-based) outside the training range.
    pub joints_outside: Vec<usize>,
    /// Distance to the nearest training configuration (normalised input units).
    pub nearest: f64,
    /// The domain's radius (normalised input units).
    pub radius: f64,
    /// The weight of the network's correction there (module doc).
    pub weight: f64,
}

impl DomainCheck {
    /// Whether every joint is within its training range and `nearest` is within `radius`.
    pub fn inside(&self) -> bool {
        self.joints_outside.is_empty() && self.nearest <= self.radius
    }

    /// A short text for output files and warnings: `inside`, or what is outside.
    pub fn describe(&self) -> String {
        if self.inside() {
            return "inside".into();
        }
        let mut parts: Vec<String> = self
            .joints_outside
            .iter()
            .map(|j| format!("q{} outside the training range", j + 1))
            .collect();
        if self.nearest > self.radius {
            parts.push(format!(
                "{:.2} from the nearest training configuration (radius {:.2}): correction x{:.2}",
                self.nearest, self.radius, self.weight
            ));
        }
        parts.join("; ")
    }
}

/// The radius of a domain of one configuration, whose rows leave no gap to measure: the
/// distance (normalised input units) within which a row of the same configuration lies from
/// `q` (rad, mm), every joint within [`super::repeats::SAME_CONFIGURATION`] of it: the sum
/// over the joints of the distance a move of that size in the joint alone makes (to first
/// order a bound on a move of every joint at once, whatever the encoding: gravity inputs
/// turn with the sum of parallel joints).
/// Without it the radius was 0, and a row measured again at that configuration, its joints a
/// few encoder counts off the training rows', had its correction faded to nothing.
fn one_configuration_radius(
    robot: &Robot,
    encoding: Encoding,
    norm: &Affine,
    q: &[f64],
    ws: &mut crate::kinematics::Frames,
) -> f64 {
    let mut feat = Vec::new();
    let mut at = |q: &[f64]| normalised_input(robot, encoding, norm, q, ws, &mut feat);
    let x0 = at(q);
    let mut moved = q.to_vec();
    (0..q.len())
        .map(|j| {
            moved[j] = q[j] + super::repeats::SAME_CONFIGURATION;
            let d = distance2(&x0, &at(&moved)).sqrt();
            moved[j] = q[j];
            d
        })
        .sum()
}

/// The network input of joints `q` (rad, mm): the encoding's features (into the scratch
/// `feat`) under the input normalisation.
fn normalised_input(
    robot: &Robot,
    encoding: Encoding,
    norm: &Affine,
    q: &[f64],
    ws: &mut crate::kinematics::Frames,
    feat: &mut Vec<f64>,
) -> Vec<f64> {
    encoding.features(robot, q, ws, feat);
    let mut x = vec![0.0; feat.len()];
    norm.apply(feat, &mut x);
    x
}

fn distance2(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum()
}

impl Domain {
    /// The domain of training configurations `qs` (rad, mm) under an encoding and its
    /// input normalisation.
    pub fn fit(robot: &Robot, encoding: Encoding, norm: &Affine, qs: &[&[f64]]) -> Domain {
        let n = robot.dof();
        let mut joint_min = vec![f64::INFINITY; n];
        let mut joint_max = vec![f64::NEG_INFINITY; n];
        // Rows of one configuration (a repeat logs joints a few encoder counts apart) are one
        // point: their gap of nearly nothing would shrink the radius to nothing wherever
        // most configurations were measured twice, and switch the network off between them.
        // A revolute joint the inputs see modulo whole turns is grouped modulo whole turns:
        // q and q + 2 pi are one input, so one configuration.
        let joints = robot.joints();
        let periodic =
            |j: usize| (joints.get(j)).is_some_and(|joint| encoding.is_periodic(joint.joint_type));
        let groups = super::repeats::turn_groups(qs, periodic);
        let mut points: Vec<(Vec<f64>, usize)> = Vec::with_capacity(qs.len());
        let mut feat = Vec::new();
        let mut ws = crate::kinematics::Frames::new(robot);
        for (q, &group) in qs.iter().zip(&groups) {
            for j in 0..n {
                joint_min[j] = joint_min[j].min(q[j]);
                joint_max[j] = joint_max[j].max(q[j]);
            }
            let x = normalised_input(robot, encoding, norm, q, &mut ws, &mut feat);
            points.push((x, group));
        }
        points.sort_by(|a, b| {
            a.0.iter()
                .zip(&b.0)
                .fold(std::cmp::Ordering::Equal, |o, (x, y)| {
                    o.then(x.total_cmp(y))
                })
        });
        points.dedup_by(|a, b| a.0 == b.0);
        // Each configuration's gap: the least distance from one of its rows to another
        // configuration's.
        let mut gaps = vec![f64::INFINITY; super::repeats::group_count(&groups)];
        for (a, group) in &points {
            let nearest = points
                .iter()
                .filter(|(_, other)| other != group)
                .map(|(b, _)| distance2(a, b))
                .fold(f64::INFINITY, f64::min);
            gaps[*group] = gaps[*group].min(nearest);
        }
        // Such a joint's raw range misleads where its values lie a whole turn apart or either
        // side of +-180 deg: it spans (nearly) a turn and leaves no angle outside. Where the
        // widest gap between the values on the circle is wider than the raw range's own gap
        // by [`WRAP_GAP`] or more, the range is the arc the values cover from that gap (the
        // whole turn of it nearest the raw values); elsewhere, the raw range (a gap between
        // values inside it is the distance's to judge, not the range's).
        for j in (0..n).filter(|&j| periodic(j)) {
            let (cut, gap) = super::repeats::widest_gap(qs.iter().map(|q| q[j]));
            let own_gap = (2.0 * PI - (joint_max[j] - joint_min[j])).max(0.0);
            if gap - own_gap < WRAP_GAP {
                continue;
            }
            let (lo, hi) = (qs.iter().map(|q| super::repeats::from_cut(q[j], cut)))
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
                    (lo.min(v), hi.max(v))
                });
            if lo.is_finite() {
                let turns = ((joint_min[j] - lo) / (2.0 * PI)).round() * 2.0 * PI;
                (joint_min[j], joint_max[j]) = (lo + turns, hi + turns);
            }
        }
        gaps.retain(|d| d.is_finite());
        let inputs: Vec<Vec<f64>> = points.into_iter().map(|(x, _)| x).collect();
        gaps.sort_by(f64::total_cmp);
        let radius = match (gaps.len(), qs.first()) {
            (0, Some(q)) => {
                // One configuration: its rows' ranges are a point (or the encoder counts
                // between them), which a row measured again leaves; a row of the
                // configuration lies within the tolerance of them.
                for j in 0..n {
                    joint_min[j] -= super::repeats::SAME_CONFIGURATION;
                    joint_max[j] += super::repeats::SAME_CONFIGURATION;
                }
                one_configuration_radius(robot, encoding, norm, q, &mut ws)
            }
            (0, None) => 0.0,
            (n, _) => gaps[((0.99 * n as f64).ceil() as usize).clamp(1, n) - 1].sqrt(),
        };
        Domain {
            joint_min,
            joint_max,
            inputs,
            radius,
        }
    }

    /// Where `q` (rad, mm) stands; `x` is its normalised network input. A joint for which
    /// `periodic(j)` holds (the inputs see it modulo whole turns,
    /// [`Encoding::is_periodic`]) is within its training range when a whole turn of it is.
    pub fn check(&self, q: &[f64], x: &[f64], periodic: impl Fn(usize) -> bool) -> DomainCheck {
        let (_, nearest, weight) = self.trust(x);
        DomainCheck {
            joints_outside: self.joints_outside(q, periodic),
            nearest,
            radius: self.radius,
            weight,
        }
    }

    /// The joints (0-based) of `q` (rad, mm) outside their training range, a joint for
    /// which `periodic(j)` holds modulo whole turns (as [`Domain::check`]).
    pub fn joints_outside(&self, q: &[f64], periodic: impl Fn(usize) -> bool) -> Vec<usize> {
        let turn = 2.0 * PI;
        // A training value read back is inside to the last bits: the turn taken off it, or
        // its arc's bounds, round.
        let tol = |v: f64| RANGE_TOL * v.abs().max(1.0);
        (0..q.len())
            .filter(|&j| {
                let (lo, hi) = (self.joint_min[j], self.joint_max[j]);
                if periodic(j) {
                    // The turn of q[j] at or above lo (less the tolerance), nearest it.
                    let from = lo - tol(lo);
                    hi - lo < turn && from + (q[j] - from).rem_euclid(turn) > hi + tol(hi)
                } else {
                    q[j] < lo - tol(lo) || q[j] > hi + tol(hi)
                }
            })
            .collect()
    }

    /// The correction's weight at `x` as [`Domain::trust`] gives it, found fast: inside the
    /// domain any training configuration within the radius settles it (weight 1, no
    /// derivative), so the search starts at `hint` (the last call's neighbour: successive
    /// calls from an iterative solver move little) and stops at the first one within the
    /// radius; only outside is the exact nearest searched. Returns (index, distance, weight):
    /// the distance is exact only when the weight is below 1.
    pub fn weight(&self, x: &[f64], hint: &mut usize) -> (usize, f64, f64) {
        if self.inputs.is_empty() {
            return (0, 0.0, 1.0);
        }
        let r2 = self.radius * self.radius;
        let n = self.inputs.len();
        let start = (*hint).min(n - 1);
        for k in (start..n).chain(0..start) {
            let d2 = distance2(x, &self.inputs[k]);
            if d2 <= r2 {
                *hint = k;
                return (k, d2.sqrt(), 1.0);
            }
        }
        let found = self.trust(x);
        *hint = found.0;
        found
    }

    /// The nearest training configuration to `x` (index, distance) and the correction's
    /// weight there; an empty domain (cross-validation fits) trusts everywhere.
    pub fn trust(&self, x: &[f64]) -> (usize, f64, f64) {
        if self.inputs.is_empty() {
            return (0, 0.0, 1.0);
        }
        let (k, d2) = self
            .inputs
            .iter()
            .enumerate()
            .map(|(k, b)| (k, distance2(x, b)))
            .fold((0, f64::INFINITY), |a, b| if b.1 < a.1 { b } else { a });
        let d = d2.sqrt();
        let w = if d <= self.radius {
            1.0
        } else if self.radius > 0.0 {
            (2.0 - d / self.radius).max(0.0)
        } else {
            0.0
        };
        (k, d, w)
    }

    /// True when the sizes fit `dof` joints and `inputs` features and every number is finite.
    pub fn is_valid(&self, dof: usize, inputs: usize) -> bool {
        let bound = super::weights::VALUE_BOUND;
        self.joint_min.len() == dof
            && self.joint_max.len() == dof
            && self
                .joint_min
                .iter()
                .zip(&self.joint_max)
                .all(|(a, b)| a.abs() <= bound && b.abs() <= bound && a <= b)
            && (0.0..=bound).contains(&self.radius)
            && !self.inputs.is_empty()
            && self
                .inputs
                .iter()
                .all(|x| x.len() == inputs && x.iter().all(|v| v.abs() <= bound))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    #[test]
    fn repeated_configurations_keep_the_radius_of_the_distinct_ones() {
        let robot = crate::model::test_fanuc();
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(9);
        let qs: Vec<Vec<f64>> = (0..200)
            .map(|_| (0..6).map(|_| rng.random_range(-1.0..1.0)).collect())
            .collect();
        let norm = Affine {
            offset: vec![0.0; 12],
            scale: vec![1.0; 12],
        };
        let fit = |rows: &[&Vec<f64>]| {
            let rows: Vec<&[f64]> = rows.iter().map(|q| q.as_slice()).collect();
            Domain::fit(&robot, Encoding::SinCos, &norm, &rows)
        };
        // `first` measured again as `again`: the same configurations, so the same radius.
        let same_radius = |first: &[Vec<f64>], again: &[Vec<f64>]| {
            let alone = fit(&first.iter().collect::<Vec<_>>());
            let both = fit(&first.iter().chain(again).collect::<Vec<_>>());
            assert!(alone.radius > 0.1, "{}", alone.radius);
            assert!(
                (both.radius - alone.radius).abs() < 1e-4 * alone.radius,
                "{} against {}",
                both.radius,
                alone.radius
            );
            both
        };
        let moved = |rows: &[Vec<f64>], by: &dyn Fn(&mut Vec<f64>)| -> Vec<Vec<f64>> {
            (rows.iter().cloned())
                .map(|mut q| {
                    by(&mut q);
                    q
                })
                .collect()
        };
        // Joints logged 2e-6 rad apart (encoder counts): gaps between a row and its repeat
        // made the radius about 4e-6.
        let again = moved(&qs, &|q| q.iter_mut().for_each(|v| *v += 2e-6));
        assert_eq!(same_radius(&qs, &again).inputs.len(), 400);
        // A whole turn away in a joint the inputs see modulo turns: one input (their gap of
        // rounding, 1e-15, made the radius nothing).
        same_radius(&qs, &moved(&qs, &|q| q[5] += 2.0 * PI));
        // Either side of +-180 deg (a wrist logged at 179.9999999 and -179.9999999 deg).
        let seam = moved(&qs, &|q| q[5] = PI - 2e-9);
        same_radius(&seam, &moved(&seam, &|q| q[5] = -q[5]));
    }

    #[test]
    fn a_periodic_joints_range_is_the_arc_its_values_cover() {
        let robot = crate::model::test_fanuc();
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        // Joint 1 within [-0.5, 0.5] rad, joint 6 within 0.2 rad of +-pi.
        let mut qs: Vec<Vec<f64>> = (0..60)
            .map(|k| {
                let mut q: Vec<f64> = (0..6).map(|_| rng.random_range(-1.0..1.0)).collect();
                q[0] = -0.5 + k as f64 / 59.0;
                q[5] = PI - 0.2 + 0.4 * rng.random_range(0.0..1.0);
                q
            })
            .collect();
        // A few of them logged a whole turn away, as a wrist or base may be.
        for k in 0..5 {
            let mut q = qs[k].clone();
            q[0] += 2.0 * PI;
            qs.push(q);
        }
        let rows: Vec<&[f64]> = qs.iter().map(Vec::as_slice).collect();
        let fit = |e: Encoding| {
            let inputs = if e == Encoding::Angles { 6 } else { 12 };
            let norm = Affine {
                offset: vec![0.0; inputs],
                scale: vec![1.0; inputs],
            };
            (Domain::fit(&robot, e, &norm, &rows), vec![0.0; inputs])
        };
        let (d, x) = fit(Encoding::SinCos);
        assert!((d.joint_min[0] + 0.5).abs() < 1e-12 && (d.joint_max[0] - 0.5).abs() < 1e-12);
        let (lo, hi) = (d.joint_min[5], d.joint_max[5]);
        assert!(hi - lo < 0.4 + 1e-12 && lo <= PI && hi >= PI, "{lo} {hi}");
        let outside = |d: &Domain, x: &[f64], q: [f64; 6], periodic: bool| {
            d.check(&q, x, |_| periodic).joints_outside
        };
        // Beyond joint 1's arc, and joint 6 half a turn from its data: flagged (raw, the
        // ranges spanned a turn and more and flagged nothing).
        assert_eq!(
            outside(&d, &x, [1.0, 0.0, 0.0, 0.0, 0.0, PI], true),
            vec![0]
        );
        assert_eq!(
            outside(&d, &x, [0.0, 0.0, 0.0, 0.0, 0.0, 0.0], true),
            vec![5]
        );
        assert!(outside(&d, &x, [0.2 - 2.0 * PI, 0.0, 0.0, 0.0, 0.0, -PI], true).is_empty());
        // Every training row is inside its own ranges, to the last bit (its turn taken off
        // and the arc's bounds round: Series B's q5 from -2.53341 to 0.0881769 rad flagged
        // the rows at its top, lo + (hi - lo) being hi + 1.1e-16).
        for q in &qs {
            assert!(d.check(q, &x, |_| true).joints_outside.is_empty(), "{q:?}");
        }
        let b = Domain {
            joint_min: vec![-2.53341],
            joint_max: vec![0.0881769],
            inputs: vec![vec![0.0]],
            radius: 1.0,
        };
        assert!(
            b.check(&[0.0881769], &[0.0], |_| true)
                .joints_outside
                .is_empty()
        );
        assert_eq!(
            b.check(&[0.0881770], &[0.0], |_| true).joints_outside,
            vec![0]
        );
        // Values over the whole circle with a hole of 18 deg inside: the raw range, the hole
        // the distance's to judge (the arc without the hole flagged 16 more of the shipped
        // non-geometric robot's test rows).
        let round: Vec<Vec<f64>> = (0..100)
            .filter(|k| !(40..45).contains(k))
            .map(|k| {
                let mut q = qs[k % qs.len()].clone();
                q[0] = -PI + 0.01 + k as f64 * (2.0 * PI - 0.02) / 99.0;
                q
            })
            .collect();
        let rows: Vec<&[f64]> = round.iter().map(Vec::as_slice).collect();
        let norm = Affine {
            offset: vec![0.0; 12],
            scale: vec![1.0; 12],
        };
        let r = Domain::fit(&robot, Encoding::SinCos, &norm, &rows);
        assert_eq!(
            (r.joint_min[0], r.joint_max[0]),
            (round[0][0], round[94][0])
        );
        let hole = -PI + 0.01 + 42.0 * (2.0 * PI - 0.02) / 99.0;
        let mut q = round[0].clone();
        q[0] = hole;
        assert!(r.check(&q, &x, |_| true).joints_outside.is_empty());
        // Inputs that see the angle itself keep the raw range.
        let (a, x) = fit(Encoding::Angles);
        for q in &qs {
            assert!(a.check(q, &x, |_| false).joints_outside.is_empty(), "{q:?}");
        }
        assert!((a.joint_max[0] - (-0.5 + 4.0 / 59.0 + 2.0 * PI)).abs() < 1e-12);
        assert!(outside(&a, &x, [1.0, 0.0, 0.0, 0.0, 0.0, PI], false).is_empty());
    }

    #[test]
    fn a_periodic_joint_is_inside_its_range_a_whole_turn_away() {
        let d = Domain {
            joint_min: vec![-1.0, -4.0],
            joint_max: vec![1.0, 3.0],
            inputs: vec![vec![0.0]],
            radius: 1.0,
        };
        let turn = 2.0 * PI;
        let outside =
            |q: [f64; 2], periodic: bool| d.check(&q, &[0.0], |_| periodic).joints_outside;
        for q0 in [0.5, 0.5 + turn, 0.5 - 2.0 * turn, 1.0 + turn, -1.0 - turn] {
            assert!(outside([q0, 0.0], true).is_empty(), "{q0}");
        }
        assert_eq!(outside([0.5 + turn, 0.0], false), vec![0]);
        for q0 in [1.5, 1.5 + turn, -1.5 - turn, -2.0] {
            assert_eq!(outside([q0, 0.0], true), vec![0], "{q0}");
        }
        // A range of more than a turn holds every angle.
        assert!(outside([0.0, 20.0], true).is_empty());
        assert_eq!(outside([0.0, 20.0], false), vec![1]);
    }

    #[test]
    fn the_fast_search_gives_the_exact_weight() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(4);
        let inputs: Vec<Vec<f64>> = (0..300)
            .map(|_| (0..4).map(|_| rng.random_range(-1.0..1.0)).collect())
            .collect();
        let d = Domain {
            joint_min: vec![-1.0; 4],
            joint_max: vec![1.0; 4],
            inputs,
            radius: 0.3,
        };
        let mut hint = 0;
        let (mut inside, mut fading, mut outside) = (0, 0, 0);
        for _ in 0..2000 {
            let x: Vec<f64> = (0..4).map(|_| rng.random_range(-1.6..1.6)).collect();
            let (k, dist, w) = d.weight(&x, &mut hint);
            let exact = d.trust(&x);
            assert_eq!(w, exact.2, "{x:?}");
            if w < 1.0 {
                assert_eq!((k, dist), (exact.0, exact.1));
            }
            match w {
                1.0 => inside += 1,
                0.0 => outside += 1,
                _ => fading += 1,
            }
        }
        // The draw covers all three cases.
        assert!(
            inside > 100 && fading > 100 && outside > 100,
            "{inside} {fading} {outside}"
        );
    }

    #[test]
    fn one_configuration_trusts_its_own_repeats_only() {
        let robot = crate::model::test_fanuc();
        let norm = Affine {
            offset: vec![0.0; 12],
            scale: vec![1.0; 12],
        };
        let q = [0.1, -0.4, 0.3, 0.8, -0.5, 1.2];
        // Repeats a few encoder counts apart, and a row of that configuration and one of
        // another (each joint moved by a tenth, and by ten times, the tolerance).
        let repeat = |by: f64| -> Vec<f64> { q.iter().map(|v| v + by).collect() };
        let rows = [repeat(0.0), repeat(2e-6), repeat(-3e-6)];
        let rows: Vec<&[f64]> = rows.iter().map(Vec::as_slice).collect();
        let d = Domain::fit(&robot, Encoding::SinCos, &norm, &rows);
        let mut ws = crate::kinematics::Frames::new(&robot);
        let weight = |q: &[f64], ws: &mut crate::kinematics::Frames| {
            let mut feat = Vec::new();
            Encoding::SinCos.features(&robot, q, ws, &mut feat);
            d.trust(&feat).2
        };
        assert!(d.radius > 0.0, "{}", d.radius);
        let same = repeat(0.1 * crate::data::configuration::SAME_CONFIGURATION);
        assert_eq!(weight(&same, &mut ws), 1.0);
        let mut one_joint = q.to_vec();
        one_joint[2] -= crate::data::configuration::SAME_CONFIGURATION;
        assert_eq!(weight(&one_joint, &mut ws), 1.0);
        let other = repeat(10.0 * crate::data::configuration::SAME_CONFIGURATION);
        assert_eq!(weight(&other, &mut ws), 0.0);
        // Every joint of a row of the configuration lies within its range; the other's not.
        assert!(d.joints_outside(&same, |_| true).is_empty());
        assert!(d.joints_outside(&one_joint, |_| true).is_empty());
        assert_eq!(d.joints_outside(&other, |_| true).len(), 6);
    }
}
