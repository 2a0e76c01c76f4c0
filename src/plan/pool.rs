//! The candidate configurations a plan chooses from, and the cell's constraints on them.
//!
//! A candidate is a *unit* of measurement: one configuration for the pose, position and
//! orientation measures, a pair of configurations for the relative and distance measures
//! (both rows of a pair are measured).

use crate::data::pairs::Pair;
use crate::error::{Error, Result};
use crate::kinematics::{Frames, frames};
use crate::model::Robot;
use crate::sim::Region;
use nalgebra::Vector3;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// What the cell allows. Positions are those of the nominal model's tool origin in the
/// robot's world frame (after the base row), mm.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Constraints {
    /// Angle kept from every revolute joint's limits (rad); prismatic joints keep their
    /// limits.
    pub margin: f64,
    /// The tool origin's z must be at least this (mm).
    pub floor_mm: Option<f64>,
    /// The tool origin must lie outside this box, given by its corners (min, max) (mm).
    pub forbidden: Option<(Vector3<f64>, Vector3<f64>)>,
}

/// How far (rad, mm) a configuration may pass a limit (less its margin) and still be within
/// it, as the data readers and the kinematics judge limits.
const LIMIT_TOLERANCE: f64 = 1e-9;

/// Why a configuration was refused.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Refusal {
    /// A joint lies beyond its limits less the margin.
    Limits,
    /// The tool lies below the floor.
    Floor,
    /// The tool lies inside the forbidden box.
    Forbidden,
}

/// How many configurations each constraint refused.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct Refused {
    /// Beyond the joint limits less the margin.
    pub limits: usize,
    /// Tool below the floor.
    pub floor: usize,
    /// Tool inside the forbidden box.
    pub forbidden: usize,
}

impl Refused {
    fn count(&mut self, r: Refusal) {
        match r {
            Refusal::Limits => self.limits += 1,
            Refusal::Floor => self.floor += 1,
            Refusal::Forbidden => self.forbidden += 1,
        }
    }

    /// All refusals.
    pub fn total(&self) -> usize {
        self.limits + self.floor + self.forbidden
    }
}

impl Constraints {
    /// Checks configuration `q` (rad, mm) of `robot`; `ws` is scratch space.
    pub fn check(&self, robot: &Robot, q: &[f64], ws: &mut Frames) -> Option<Refusal> {
        for (v, j) in q.iter().zip(robot.joints()) {
            let [lo, hi] = j.limits_internal();
            let m = self.margin_of(j);
            // The tolerance of every other limit check (a file's 70 deg read back as radians).
            if *v < lo + m - LIMIT_TOLERANCE || *v > hi - m + LIMIT_TOLERANCE {
                return Some(Refusal::Limits);
            }
        }
        if self.floor_mm.is_none() && self.forbidden.is_none() {
            return None;
        }
        frames(robot, q, ws);
        let p = ws.tool.translation.vector;
        if self.floor_mm.is_some_and(|f| p.z < f) {
            return Some(Refusal::Floor);
        }
        if let Some((lo, hi)) = self.forbidden
            && (0..3).all(|i| p[i] >= lo[i] && p[i] <= hi[i])
        {
            return Some(Refusal::Forbidden);
        }
        None
    }

    fn margin_of(&self, j: &crate::model::Joint) -> f64 {
        match j.joint_type {
            crate::model::JointType::Revolute => self.margin,
            crate::model::JointType::Prismatic => 0.0,
        }
    }

    /// The region narrowed by the margin; an error when a joint has no room left (at most
    /// [`NO_ROOM`], where the region gave it some).
    pub fn narrow(&self, robot: &Robot, region: &Region) -> Result<Region> {
        let mut out = Vec::with_capacity(region.0.len());
        for (i, (&[lo, hi], j)) in region.0.iter().zip(robot.joints()).enumerate() {
            let [llo, lhi] = j.limits_internal();
            let m = self.margin_of(j);
            let (a, b) = (lo.max(llo + m), hi.min(lhi - m));
            // One value left of a range is no room either (a margin of half the limits' span
            // held a FANUC's joints 2 and 3 still, and the plan identified 22 parameters of
            // 30 without a word); a region that fixes the joint itself keeps it.
            if a > b || (b - a <= NO_ROOM && lo < hi) {
                let deg = |v: f64| match j.joint_type {
                    crate::model::JointType::Revolute => format!("{:.1} deg", v.to_degrees()),
                    crate::model::JointType::Prismatic => format!("{v:.1} mm"),
                };
                return Err(Error::Invalid(format!(
                    "joint {}: the margin ({}) leaves no room in its range ({} to {}{})",
                    i + 1,
                    deg(m),
                    deg(lo),
                    deg(hi),
                    if (lo, hi) == (llo, lhi) {
                        ", its limits"
                    } else {
                        ", the region's within its limits"
                    }
                )));
            }
            out.push([a, b]);
        }
        Ok(Region(out))
    }
}

/// The span (rad, mm) a margin may leave of a joint's range and still leave it no room: the
/// rounding of limits in degrees less a margin of half their span.
pub const NO_ROOM: f64 = 1e-9;

/// Candidate units: each one or two configurations (rad, mm).
#[derive(Debug, Clone, PartialEq)]
pub struct Pool {
    /// The units, each of `per_unit` configurations.
    pub units: Vec<Vec<Vec<f64>>>,
    /// What the constraints refused while the pool was made.
    pub refused: Refused,
    /// For a pool of given configurations, the index of each unit's configurations among
    /// them (where a plan's choice came from); empty for a drawn pool.
    pub sources: Vec<Vec<usize>>,
}

impl Pool {
    /// Every unit's configurations in order, one list (rad, mm): a pool of single
    /// configurations as a validation cloud.
    pub fn into_configurations(self) -> Vec<Vec<f64>> {
        self.units.into_iter().flatten().collect()
    }
}

/// Draws `count` units of `per_unit` configurations, uniform in `region` narrowed by the
/// margin, keeping those the constraints admit. Seeded: the same seed gives the same pool.
/// An error when fewer than one draw in 100 is admitted.
pub fn draw(
    robot: &Robot,
    region: &Region,
    constraints: &Constraints,
    count: usize,
    per_unit: usize,
    seed: u64,
) -> Result<Pool> {
    if region.0.len() != robot.dof() {
        return Err(Error::Invalid("region does not match the robot".into()));
    }
    let region = constraints.narrow(robot, region)?;
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut ws = Frames::new(robot);
    let mut refused = Refused::default();
    let mut units = Vec::with_capacity(count);
    let budget = 100 * (count * per_unit).max(1);
    let mut draws = 0;
    let mut unit: Vec<Vec<f64>> = Vec::with_capacity(per_unit);
    while units.len() < count {
        if draws >= budget {
            return Err(Error::Invalid(format!(
                "the constraints refuse nearly every configuration: {} of {draws} draws admitted \
                 (limits and margin {}, floor {}, forbidden box {})",
                draws - refused.total(),
                refused.limits,
                refused.floor,
                refused.forbidden
            )));
        }
        draws += 1;
        let q: Vec<f64> = region
            .0
            .iter()
            .map(|&[lo, hi]| {
                if lo < hi {
                    rng.random_range(lo..hi)
                } else {
                    lo
                }
            })
            .collect();
        match constraints.check(robot, &q, &mut ws) {
            Some(r) => refused.count(r),
            None => {
                unit.push(q);
                if unit.len() == per_unit {
                    units.push(std::mem::take(&mut unit));
                }
            }
        }
    }
    Ok(Pool {
        units,
        refused,
        sources: Vec::new(),
    })
}

/// Groups given configurations (rad, mm) into units of `per_unit` consecutive rows, leaving
/// out those the constraints refuse (a pair goes when either row is refused). `what` names
/// the source in errors (a file).
pub fn from_configurations(
    robot: &Robot,
    configurations: &[Vec<f64>],
    constraints: &Constraints,
    per_unit: usize,
    what: &str,
) -> Result<Pool> {
    if !configurations.len().is_multiple_of(per_unit) {
        return Err(Error::Invalid(format!(
            "{what}: {} rows do not form pairs of consecutive rows (relative and distance \
             measures measure pairs)",
            configurations.len()
        )));
    }
    let n = configurations.len();
    Ok(from_units(
        robot,
        configurations,
        (0..n)
            .step_by(per_unit)
            .map(|k| (k..k + per_unit).collect()),
        constraints,
    ))
}

/// Units of the rows of each pair of `configurations` (rad, mm), as `identify` pairs the
/// rows of a relative or distance measurement ([`crate::data::pairs::pairs_of`]: (1, 2),
/// (2, 3), ... or by label), leaving out those the constraints refuse.
pub fn from_pairs(
    robot: &Robot,
    configurations: &[Vec<f64>],
    pairs: &[Pair],
    constraints: &Constraints,
) -> Pool {
    from_units(
        robot,
        configurations,
        pairs.iter().map(|p| vec![p.a, p.b]),
        constraints,
    )
}

/// The pool of the units of `configurations` that `units` lists (indices), leaving out those
/// with a configuration the constraints refuse.
fn from_units(
    robot: &Robot,
    configurations: &[Vec<f64>],
    units: impl Iterator<Item = Vec<usize>>,
    constraints: &Constraints,
) -> Pool {
    let mut ws = Frames::new(robot);
    let mut pool = Pool {
        units: Vec::new(),
        refused: Refused::default(),
        sources: Vec::new(),
    };
    for unit in units {
        let mut ok = true;
        for &i in &unit {
            if let Some(r) = constraints.check(robot, &configurations[i], &mut ws) {
                pool.refused.count(r);
                ok = false;
            }
        }
        if ok {
            pool.units
                .push(unit.iter().map(|&i| configurations[i].clone()).collect());
            pool.sources.push(unit);
        }
    }
    pool
}

#[cfg(test)]
mod tests {
    use super::*;

    use crate::model::test_fanuc as fanuc;

    #[test]
    fn drawn_configurations_keep_every_constraint() {
        let robot = fanuc();
        let c = Constraints {
            margin: 10f64.to_radians(),
            floor_mm: Some(300.0),
            forbidden: Some((
                Vector3::new(500.0, -500.0, 0.0),
                Vector3::new(2500.0, 500.0, 800.0),
            )),
        };
        let pool = draw(&robot, &Region::limits(&robot), &c, 500, 1, 3).unwrap();
        assert_eq!(pool.units.len(), 500);
        // Each constraint refused some: the test exercises all three.
        assert!(
            pool.refused.floor > 0 && pool.refused.forbidden > 0,
            "{:?}",
            pool.refused
        );
        let mut ws = Frames::new(&robot);
        for u in &pool.units {
            let q = &u[0];
            assert_eq!(c.check(&robot, q, &mut ws), None);
            for (v, j) in q.iter().zip(robot.joints()) {
                let [lo, hi] = j.limits_internal();
                assert!(*v >= lo + c.margin - 1e-12 && *v <= hi - c.margin + 1e-12);
            }
            frames(&robot, q, &mut ws);
            let p = ws.tool.translation.vector;
            assert!(p.z >= 300.0);
            assert!(!(p.x >= 500.0 && p.x <= 2500.0 && p.y.abs() <= 500.0 && p.z <= 800.0));
        }
        // Seeded.
        assert_eq!(
            draw(&robot, &Region::limits(&robot), &c, 500, 1, 3).unwrap(),
            pool
        );
    }

    #[test]
    fn impossible_constraints_are_an_error_not_a_hang() {
        let robot = fanuc();
        let c = Constraints {
            floor_mm: Some(1e6),
            ..Default::default()
        };
        let e = draw(&robot, &Region::limits(&robot), &c, 10, 1, 1).unwrap_err();
        assert!(e.to_string().contains("refuse nearly every"), "{e}");
        let wide = Constraints {
            margin: 4.0,
            ..Default::default()
        };
        assert!(draw(&robot, &Region::limits(&robot), &wide, 10, 1, 1).is_err());
    }

    /// A margin of half a joint's span leaves it one value: no room, an error naming the
    /// joint (joint 2 of the FANUC, limits -50 to 70 deg, margin 60 deg); a region that fixes
    /// a joint itself keeps it fixed, and a margin just short of half the span leaves room.
    #[test]
    fn a_margin_of_half_a_joints_span_leaves_it_no_room() {
        let robot = fanuc();
        let margin = |deg: f64| Constraints {
            margin: deg.to_radians(),
            ..Default::default()
        };
        let limits = Region::limits(&robot);
        let e = margin(60.0)
            .narrow(&robot, &limits)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("joint 2: the margin (60.0 deg) leaves no room")
                && e.contains("(-50.0 deg to 70.0 deg, its limits)"),
            "{e}"
        );
        let narrowed = margin(59.9).narrow(&robot, &limits).unwrap();
        assert!(narrowed.0[1][1] - narrowed.0[1][0] > 0.003);
        let mut fixed = limits.clone();
        fixed.0[1] = [0.2, 0.2];
        fixed.0[2] = [0.0, 0.0];
        let kept = margin(30.0).narrow(&robot, &fixed).unwrap();
        assert_eq!((kept.0[1], kept.0[2]), ([0.2, 0.2], [0.0, 0.0]));
    }

    #[test]
    fn given_rows_form_units_and_refused_pairs_go_whole() {
        let robot = fanuc();
        let c = Constraints {
            margin: 0.0,
            floor_mm: Some(0.0),
            forbidden: None,
        };
        // Two drawn configurations, one above and one below a floor between them.
        let some = draw(
            &robot,
            &Region::limits(&robot),
            &Constraints::default(),
            20,
            1,
            5,
        )
        .unwrap();
        let mut ws = Frames::new(&robot);
        let mut z: Vec<(f64, Vec<f64>)> = some
            .units
            .iter()
            .map(|u| {
                frames(&robot, &u[0], &mut ws);
                (ws.tool.translation.vector.z, u[0].clone())
            })
            .collect();
        z.sort_by(|a, b| a.0.total_cmp(&b.0));
        let (down, up) = (z[0].1.clone(), z[19].1.clone());
        let c = Constraints {
            floor_mm: Some(0.5 * (z[0].0 + z[19].0)),
            ..c
        };
        assert_eq!(c.check(&robot, &down, &mut ws), Some(Refusal::Floor));
        assert_eq!(c.check(&robot, &up, &mut ws), None);
        let rows = vec![up.clone(), up.clone(), up.clone(), down.clone()];
        let pairs = from_configurations(&robot, &rows, &c, 2, "c.csv").unwrap();
        assert_eq!(pairs.units.len(), 1);
        assert_eq!(pairs.refused.floor, 1);
        let singles = from_configurations(&robot, &rows, &c, 1, "c.csv").unwrap();
        assert_eq!(singles.units.len(), 3);
        assert!(from_configurations(&robot, &rows[..3], &c, 2, "c.csv").is_err());
    }
}
