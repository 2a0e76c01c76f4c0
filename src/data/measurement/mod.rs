//! Measurement sets: joint configurations with what a sensor observed there.
//!
//! One row is one configuration. It may carry a position (mm), an orientation, a ball-bar
//! distance (mm, on the second row of a pair) and per-row standard deviations. How the rows are
//! used (full pose, position, orientation, relative position, distance) is chosen by the
//! consumer; [`pairs`](super::pairs) groups rows for relative and distance use.

mod cells;
mod read;
mod write;

pub use read::{ReadOptions, ReadReport, parse_measurements, read_canonical, read_measurements};
pub use write::{Layout, MeasurementWriter, measurements_to_csv, write_measurements};

use super::profile::Profile;
use super::table::Table;
use crate::error::{IN_MEMORY, Result};
use crate::geometry::Pose;
use crate::model::{JointType, Robot};
use nalgebra::{Rotation3, Translation3, Vector3};
use std::path::{Path, PathBuf};

/// One measured configuration (internal units: rad, mm).
#[derive(Debug, Clone, PartialEq)]
pub struct Measurement {
    /// 1-based line in the source file (0 for generated rows).
    pub line: usize,
    /// Free-text row label from the `id` column, if any.
    pub id: Option<String>,
    /// Free-text group label from the `set` column, if any.
    pub set: Option<String>,
    /// Pair label from the `pair` column: the two rows sharing it form a relative or distance
    /// pair (see [`pairs`](super::pairs)).
    pub pair: Option<String>,
    /// Joints (rad, or mm for prismatic).
    pub q: Vec<f64>,
    /// Measured tool position (mm).
    pub position: Option<Vector3<f64>>,
    /// Measured tool orientation.
    pub rotation: Option<Rotation3<f64>>,
    /// Measured distance to the other row of its pair (mm), as a ball-bar gives.
    pub distance: Option<f64>,
    /// Standard deviation of each position coordinate (mm).
    pub sigma_position: Option<Vector3<f64>>,
    /// Standard deviation of each orientation component (rad).
    pub sigma_rotation: Option<Vector3<f64>>,
    /// Cells of the carried-through columns.
    pub extra: Vec<String>,
}

impl Measurement {
    /// A row with joints only.
    pub fn new(q: Vec<f64>) -> Self {
        Measurement {
            line: 0,
            id: None,
            set: None,
            pair: None,
            q,
            position: None,
            rotation: None,
            distance: None,
            sigma_position: None,
            sigma_rotation: None,
            extra: Vec::new(),
        }
    }

    /// The measured pose, when both position and orientation are present.
    pub fn pose(&self) -> Option<Pose> {
        Some(Pose::from_parts(
            Translation3::from(self.position?),
            self.rotation?,
        ))
    }
}

/// A measurement file's rows.
#[derive(Debug, Clone, PartialEq)]
pub struct MeasurementSet {
    /// The file the rows were read from ([`IN_MEMORY`] for a set built in code).
    pub source: PathBuf,
    /// The measured configurations, in file order.
    pub rows: Vec<Measurement>,
    /// Names of the carried-through columns.
    pub extra_columns: Vec<String>,
    /// Indices k of rows that do not pair with row k - 1 under consecutive pairing
    /// ([`crate::data::pairs::pairs`]): a row between them in the file was dropped (a bad row
    /// skipped, or left out of a subset), so their displacement is not one measured step.
    /// Ascending.
    pub chain_breaks: Vec<usize>,
    /// The pair label's column name (first) or the distance's (second), with a header name
    /// that differs from it in letter case only and is read as absent: the pair measures that
    /// would read that column refuse it (`identify::problem::Observations::new`);
    /// the other measures read no such column.
    pub other_case_pair_columns: [Option<(String, String)>; 2],
}

impl MeasurementSet {
    /// A set built in code; its rows' `line` fields are theirs to set (0 for none), and
    /// errors name the set [`IN_MEMORY`].
    pub fn from_rows(rows: Vec<Measurement>) -> MeasurementSet {
        MeasurementSet {
            source: PathBuf::from(IN_MEMORY),
            rows,
            extra_columns: Vec::new(),
            chain_breaks: Vec::new(),
            other_case_pair_columns: [None, None],
        }
    }

    /// Parses canonical measurement CSV given as text (in code) for `robot`, with the rules
    /// of [`read_measurements`] and default options; errors name [`IN_MEMORY`] and the line.
    pub fn from_csv(text: &str, robot: &Robot) -> Result<(MeasurementSet, ReadReport)> {
        let t = Table::parse(text.as_bytes(), Path::new(IN_MEMORY), b',', false)?;
        parse_measurements(
            &t,
            &JointInfo::of(robot),
            &Profile::default(),
            &ReadOptions::default(),
        )
    }

    /// Refuses rows `robot` cannot be evaluated at: joints not one finite value per joint
    /// (rad, mm), a position, orientation or distance not finite, or a sigma not finite and
    /// positive. A file's reader refuses these cell by cell; a set built in code meets the
    /// check here (`identify`, `evaluate_model` and compensator training call it first), not a
    /// panic or NaN figures further on. The error names the row (its line where it has one).
    pub fn check_rows(&self, robot: &Robot) -> Result<()> {
        let bad = |i: usize, what: String| {
            Err(crate::error::Error::Invalid(format!(
                "{}: {}: {what}",
                self.source.display(),
                row_name(self.rows[i].line, i)
            )))
        };
        let finite = |v: &[f64]| v.iter().all(|x| x.is_finite());
        let sigma = |v: &Vector3<f64>| v.iter().all(|x| x.is_finite() && *x > 0.0);
        for (i, r) in self.rows.iter().enumerate() {
            if r.q.len() != robot.dof() {
                return bad(
                    i,
                    format!(
                        "{} joint values for a robot with {} joints",
                        r.q.len(),
                        robot.dof()
                    ),
                );
            }
            if !finite(&r.q) {
                return bad(i, "a joint value is not finite".into());
            }
            if r.position.is_some_and(|p| !finite(p.as_slice())) {
                return bad(i, "its position is not finite".into());
            }
            if r.rotation.is_some_and(|m| !finite(m.matrix().as_slice())) {
                return bad(i, "its orientation is not finite".into());
            }
            if r.distance.is_some_and(|d| !d.is_finite()) {
                return bad(i, "its distance is not finite".into());
            }
            if r.sigma_position.is_some_and(|s| !sigma(&s))
                || r.sigma_rotation.is_some_and(|s| !sigma(&s))
            {
                return bad(i, "a sigma is not finite and positive".into());
            }
        }
        Ok(())
    }

    /// Whether every row has a measured position.
    pub fn has_position(&self) -> bool {
        !self.rows.is_empty() && self.rows.iter().all(|r| r.position.is_some())
    }

    /// Whether every row has a measured orientation.
    pub fn has_rotation(&self) -> bool {
        !self.rows.is_empty() && self.rows.iter().all(|r| r.rotation.is_some())
    }

    /// Whether some row has a measured distance.
    pub fn has_distance(&self) -> bool {
        self.rows.iter().any(|r| r.distance.is_some())
    }
}

/// What reading and writing need to know of each joint.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JointInfo {
    /// Revolute (values in rad) or prismatic (values in mm).
    pub joint_type: JointType,
    /// Limits (rad or mm); None when no robot is known and limits cannot be checked.
    pub limits: Option<[f64; 2]>,
}

impl JointInfo {
    /// The joints of a robot, with their limits.
    pub fn of(robot: &Robot) -> Vec<JointInfo> {
        robot
            .joints()
            .iter()
            .map(|j| JointInfo {
                joint_type: j.joint_type,
                limits: Some(j.limits_internal()),
            })
            .collect()
    }

    /// The largest magnitude of the joint's limits (rad or mm), or 0 where they are unknown:
    /// a revolute joint of +-400 deg holds radians up to 6.98 (the units checks' span).
    pub fn span(&self) -> f64 {
        self.limits.map_or(0.0, |[lo, hi]| lo.abs().max(hi.abs()))
    }

    /// N revolute joints without limits (for reading without a robot file).
    pub fn revolute(n: usize) -> Vec<JointInfo> {
        vec![
            JointInfo {
                joint_type: JointType::Revolute,
                limits: None,
            };
            n
        ]
    }

    fn outside(joints: &[JointInfo], q: &[f64]) -> bool {
        Self::first_outside(joints, q).is_some()
    }

    /// The first joint of `q` beyond its limits, in words (file units: deg, mm): "joint 2 at
    /// 75 deg, beyond [-50, 70]".
    pub fn first_outside(joints: &[JointInfo], q: &[f64]) -> Option<String> {
        Self::first_outside_at(joints, q).map(|(_, why)| why)
    }

    /// [`Self::first_outside`] with the joint's index (0-based), for a message naming its
    /// column.
    pub fn first_outside_at(joints: &[JointInfo], q: &[f64]) -> Option<(usize, String)> {
        (joints.iter().zip(q).enumerate()).find_map(|(i, (j, &v))| {
            let [lo, hi] = j.limits?;
            (v < lo - 1e-9 || v > hi + 1e-9).then(|| {
                let f = |x: f64| j.joint_type.to_file(x);
                let unit = j.joint_type.file_unit();
                // The limits as the robot file gives them.
                let (low, high) = (as_typed(f(lo)), as_typed(f(hi)));
                // 4 decimals, unless they would read as inside the range as printed
                // (70.00000006 beyond [-50, 70] printed as 70.0000): then every digit.
                let mut at = format!("{:.4}", f(v));
                let read = |s: &str| s.parse::<f64>().unwrap_or(f64::NAN);
                if read(&at) >= read(&low) && read(&at) <= read(&high) {
                    at = f(v).to_string();
                }
                (
                    i,
                    format!("joint {} at {at} {unit}, beyond [{low}, {high}]", i + 1),
                )
            })
        })
    }
}

/// A value in file units as a file gives it: the trip through internal units leaves float
/// dust (60 deg read back as 59.99999999999999, 123.4 mrad as 123.40000000000002), so 9
/// decimals, trailing zeros dropped, -0 as 0.
pub fn as_typed(x: f64) -> String {
    let s = format!("{x:.9}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s == "-0" { "0".into() } else { s.into() }
}

/// "2, 5, 9" (at most 20 lines, or other items, then "... (N more)").
pub fn list_lines<T: std::fmt::Display>(lines: &[T]) -> String {
    let mut s: Vec<String> = lines.iter().take(20).map(|l| l.to_string()).collect();
    if lines.len() > 20 {
        s.push(format!("... ({} more)", lines.len() - 20));
    }
    s.join(", ")
}

/// A row's name in messages: `line L` of its file, or `row R` (1-based index `row` + 1) for a
/// row built in code (`line` 0).
pub fn row_name(line: usize, row: usize) -> String {
    match line {
        0 => format!("row {}", row + 1),
        l => format!("line {l}"),
    }
}

/// Rows that repeat an earlier row to the last bit: joints, position, orientation and
/// distance (a row with none of the three measured, or with a pair label, takes no part), as
/// (row, earlier row) indices. A real repeat of a configuration reads differently in the last digits; a copied
/// row counts its reading twice.
pub fn copied_rows(set: &MeasurementSet) -> Vec<(usize, usize)> {
    let mut first: std::collections::HashMap<Vec<u64>, usize> = Default::default();
    let mut out = Vec::new();
    for (i, m) in set.rows.iter().enumerate() {
        let Some(k) = reading_key(m) else { continue };
        match first.get(&k) {
            Some(&j) => out.push((i, j)),
            None => {
                first.insert(k, i);
            }
        }
    }
    out
}

/// A row's joints and reading to the last bit ([`copied_rows`]), -0 as 0 (files write -0 as
/// 0, and the two are one value); None for a row with nothing measured or with a pair label
/// (a labelled chain repeats each inner row under two pair labels by design).
fn reading_key(m: &Measurement) -> Option<Vec<u64>> {
    let measured = m.position.is_some() || m.rotation.is_some() || m.distance.is_some();
    if !measured || m.pair.is_some() {
        return None;
    }
    let rot = m.rotation.map(|r| *r.matrix());
    let values = (m.q.iter().copied())
        .chain(m.position.iter().flat_map(|p| p.iter().copied()))
        .chain(rot.iter().flat_map(|r| r.iter().copied()))
        .chain(m.distance);
    Some(values.map(|v| (v + 0.0).to_bits()).collect())
}

/// The 1-based file lines of the rows of `set` that are rows of `other` too, joints and
/// reading to the last bit (as [`copied_rows`] compares): a validation file that shares rows
/// with the training file (the same file, or a split gone wrong) does not hold them out.
pub fn lines_also_in(set: &MeasurementSet, other: &MeasurementSet) -> Vec<usize> {
    let seen: std::collections::HashSet<Vec<u64>> =
        other.rows.iter().filter_map(reading_key).collect();
    (set.rows.iter())
        .filter(|m| reading_key(m).is_some_and(|k| seen.contains(&k)))
        .map(|m| m.line)
        .collect()
}

/// The rows of `set` whose index `keep` accepts, in order (same source and columns); the
/// chain breaks where a row between two kept ones was left out or the chain already broke.
pub fn subset(set: &MeasurementSet, keep: impl Fn(usize) -> bool) -> MeasurementSet {
    let kept: Vec<usize> = (0..set.rows.len()).filter(|&i| keep(i)).collect();
    let chain_breaks = (kept.windows(2).enumerate())
        .filter(|(_, w)| w[1] != w[0] + 1 || set.chain_breaks.binary_search(&w[1]).is_ok())
        .map(|(k, _)| k + 1)
        .collect();
    MeasurementSet {
        source: set.source.clone(),
        rows: kept.iter().map(|&i| set.rows[i].clone()).collect(),
        extra_columns: set.extra_columns.clone(),
        chain_breaks,
        other_case_pair_columns: set.other_case_pair_columns.clone(),
    }
}

/// Splits a set into two by a seeded random draw: `fraction` of the rows (rounded) go to the
/// first part; both keep file order. Rows that share a pair label (a relative or distance
/// pair, [`crate::data::pairs`]) go to one part together: the draw is then over the labels
/// (and the unlabelled rows, one by one), and the first part takes them in the drawn order
/// until it holds the rounded fraction of the rows or, with a pair that crosses it, one more,
/// but never every row where the fraction asks for fewer (the second part would be empty).
/// A set without pair labels is drawn row by row.
pub fn split(set: &MeasurementSet, fraction: f64, seed: u64) -> (MeasurementSet, MeasurementSet) {
    use rand::SeedableRng;
    use rand::seq::SliceRandom;
    let n = set.rows.len();
    let k = ((n as f64) * fraction.clamp(0.0, 1.0)).round() as usize;
    let mut units = pair_units(set);
    units.shuffle(&mut rand_chacha::ChaCha8Rng::seed_from_u64(seed));
    let mut first = vec![false; n];
    let mut taken = 0;
    for unit in &units {
        if taken >= k || (taken + unit.len() == n && k < n) {
            break;
        }
        for &i in unit {
            first[i] = true;
        }
        taken += unit.len();
    }
    let part = |want: bool| subset(set, |i| first[i] == want);
    (part(true), part(false))
}

/// The rows of `set` that [`split`] keeps together, in file order of their first row: the rows
/// of each pair label, and each unlabelled row alone.
pub fn pair_units(set: &MeasurementSet) -> Vec<Vec<usize>> {
    let mut units: Vec<Vec<usize>> = Vec::with_capacity(set.rows.len());
    let mut of_label: std::collections::HashMap<&str, usize> = Default::default();
    for (i, m) in set.rows.iter().enumerate() {
        match m.pair.as_deref() {
            Some(label) => match of_label.get(label) {
                Some(&u) => units[u].push(i),
                None => {
                    of_label.insert(label, units.len());
                    units.push(vec![i]);
                }
            },
            None => units.push(vec![i]),
        }
    }
    units
}

/// The 1-based file lines of the rows whose pair label no other row carries: a pair's partner
/// dropped (a bad row skipped) or missing, which the pair measures cannot use.
pub fn lone_pair_lines(set: &MeasurementSet) -> Vec<usize> {
    (pair_units(set).iter())
        .filter(|u| u.len() == 1 && set.rows[u[0]].pair.is_some())
        .map(|u| set.rows[u[0]].line)
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn split_keeps_labelled_pairs_whole_and_draws_unlabelled_rows_as_before() {
        use rand::SeedableRng;
        use rand::seq::SliceRandom;
        let row = |i: usize, pair: Option<String>| Measurement {
            line: i + 2,
            pair,
            ..Measurement::new(vec![i as f64])
        };
        // Unlabelled: the rows of a seeded shuffle of the indices, the first k of them.
        let plain = MeasurementSet::from_rows((0..41).map(|i| row(i, None)).collect());
        for (fraction, seed) in [(0.3f64, 1), (0.5, 7), (0.9, 11)] {
            let mut idx: Vec<usize> = (0..41).collect();
            idx.shuffle(&mut rand_chacha::ChaCha8Rng::seed_from_u64(seed));
            let k = (41.0 * fraction).round() as usize;
            let mut want: Vec<usize> = idx[..k].iter().map(|&i| i + 2).collect();
            want.sort_unstable();
            let (a, b) = split(&plain, fraction, seed);
            let lines: Vec<usize> = a.rows.iter().map(|m| m.line).collect();
            assert_eq!(lines, want);
            assert_eq!(a.rows.len() + b.rows.len(), 41);
        }
        // 20 pairs p0..p19 (rows 2j, 2j + 1) and 3 unlabelled rows: no label in both parts.
        let mut rows: Vec<Measurement> = (0..40)
            .map(|i| row(i, Some(format!("p{}", i / 2))))
            .collect();
        rows.extend((40..43).map(|i| row(i, None)));
        let paired = MeasurementSet::from_rows(rows);
        assert_eq!(pair_units(&paired).len(), 23);
        for seed in 0..20 {
            let (a, b) = split(&paired, 0.5, seed);
            let labels = |s: &MeasurementSet| -> Vec<String> {
                s.rows.iter().filter_map(|m| m.pair.clone()).collect()
            };
            let (la, lb) = (labels(&a), labels(&b));
            assert!(la.iter().all(|l| !lb.contains(l)), "seed {seed}");
            for l in la.iter().chain(&lb) {
                let count = la.iter().chain(&lb).filter(|x| *x == l).count();
                assert_eq!(count, 2, "seed {seed}: {l}");
            }
            // round(21.5) = 22 rows asked for; a pair crossing it adds one.
            assert!(
                (22..=23).contains(&a.rows.len()),
                "seed {seed}: {}",
                a.rows.len()
            );
            assert_eq!(a.rows.len() + b.rows.len(), 43);
        }
        // Pairs alone, 39 of 40 rows asked for: the second part keeps a pair; 1 of 40, the
        // first takes one; all of them, all.
        let pairs_only = MeasurementSet::from_rows(paired.rows[..40].to_vec());
        for seed in 0..10 {
            for (fraction, first) in [(0.98, 38), (0.02, 2), (1.0, 40), (0.0, 0)] {
                let (a, _) = split(&pairs_only, fraction, seed);
                assert_eq!(a.rows.len(), first, "{fraction} seed {seed}");
            }
        }
    }

    #[test]
    fn a_joint_just_beyond_its_limit_is_not_printed_as_inside() {
        let joints = vec![JointInfo {
            joint_type: JointType::Revolute,
            limits: Some([(-50f64).to_radians(), 70f64.to_radians()]),
        }];
        // 6e-8 deg beyond: outside by more than the 1e-9 rad tolerance, 70.0000 to 4 decimals.
        let q = [(70.0 + 6e-8f64).to_radians()];
        let said = JointInfo::first_outside(&joints, &q).unwrap();
        assert!(said.starts_with("joint 1 at 70.00000006"), "{said}");
        assert!(said.ends_with("deg, beyond [-50, 70]"), "{said}");
        // Clearly beyond: 4 decimals.
        let said = JointInfo::first_outside(&joints, &[75f64.to_radians()]).unwrap();
        assert_eq!(said, "joint 1 at 75.0000 deg, beyond [-50, 70]");
        assert!(JointInfo::first_outside(&joints, &[70f64.to_radians()]).is_none());
        // Limits read back from radians as the file gives them (60 comes back as
        // 59.99999999999999).
        assert_ne!(60f64.to_radians().to_degrees(), 60.0);
        let joints = vec![JointInfo {
            joint_type: JointType::Revolute,
            limits: Some([(-55f64).to_radians(), 60f64.to_radians()]),
        }];
        let said = JointInfo::first_outside(&joints, &[61f64.to_radians()]).unwrap();
        assert_eq!(said, "joint 1 at 61.0000 deg, beyond [-55, 60]");
        // Just beyond the limit as printed: every digit, not 60.0000.
        let said = JointInfo::first_outside(&joints, &[60.00001f64.to_radians()]).unwrap();
        assert!(said.starts_with("joint 1 at 60.0000"), "{said}");
        assert_ne!(said, "joint 1 at 60.0000 deg, beyond [-55, 60]");
    }
}
