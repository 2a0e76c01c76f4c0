//! Readings two configurations share: a tracker reading logged with another pose's joints.
//!
//! A robot reaches one target in several configurations (inverse-kinematics branches), and
//! its errors differ between them: a calibrated model predicts where each puts the probe.
//! Two rows of different configurations whose readings agree within [`POSITION_MM`] and
//! [`ORIENTATION_DEG`] although the model puts the two configurations [`SEPARATION_MM`] or
//! more apart cannot both be readings of their own configurations: the robot would have had to
//! cancel a separation the model predicts (at least ten times the agreement) to a tracker's
//! precision in position and orientation at once, by chance (its orientation errors differ by
//! about 0.1 deg between configurations).
//!
//! Position alone is not enough: a grid turned about the probe point reads one position in
//! several configurations by design, and a model 0.4 mm RMS off can be 1.3 mm off the relative
//! position of two of them. On Series A (11,911 poses, about 2,000 pairs of different
//! configurations within 0.1 mm) two such pairs would have passed for shared readings in
//! position; their orientations are 10 and 20 deg apart. Rows without a measured orientation
//! therefore take no part.
//!
//! A logger that attaches a reading to the wrong joints produces exactly this: on the shipped
//! UR10 Series B, lines 534 and 1065 hold the very numbers of lines 533 and 1064 (standard
//! deviations included), line 856 reads line 855's pose to 0.02 mm, and line 857 reads the
//! pose line 864 measured later (0.03 mm): each pair is one target reached in two elbow
//! configurations, which the model identified on the whole series puts 1.2-2.0 mm apart,
//! while the file's other 729 consecutive rows of one target in two configurations measure
//! 0.26-3.15 mm apart (median 2.05). Of each pair, the row the model misses more is the
//! suspect (by 0.94-1.92 mm, against 0.25-0.52 mm for its partner): its reading is the other
//! configuration's pose.
//!
//! Under the nominal model two branches of one target coincide by construction, so the check
//! needs a calibrated model; it finds nothing under a model that does not separate them.

use super::configuration::same_configuration;
use super::measurement::{Measurement, MeasurementSet, row_name};
use crate::geometry::rotation::angle_between;
use crate::kinematics::tool_pose;
use crate::model::Robot;
use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

/// Largest distance (mm) at which two readings are one: a laser tracker's reading agrees with
/// itself to a few hundredths of a mm (Series B's repeats: 0.04 mm median), and a maximum
/// permissible error of 15 um + 6 um/m stays below 0.1 mm to 14 m.
pub const POSITION_MM: f64 = 0.1;

/// Largest angle (deg) between two orientation readings that are one: twice a 6-DOF probe's
/// stated accuracy of 0.01 deg.
pub const ORIENTATION_DEG: f64 = 0.02;

/// Smallest distance (mm) between the model's positions of the two configurations for their
/// one reading to be a logging fault: ten times [`POSITION_MM`].
pub const SEPARATION_MM: f64 = 10.0 * POSITION_MM;

/// A row whose reading another row of a different configuration shares, while the model puts
/// the two configurations apart: a reading of the other configuration's pose.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SharedReading {
    /// Index in the set's rows of the suspect row: the one the model misses more.
    pub row: usize,
    /// Its source-file line (0 for rows built in code).
    pub line: usize,
    /// Index of the row whose reading it shares (the closest reading where several do): in
    /// the set's rows, or in the reference set's where [`SharedReading::other_source`] names
    /// one.
    pub other_row: usize,
    /// That row's source-file line.
    pub other_line: usize,
    /// Distance between the two readings' positions (mm).
    #[serde(with = "crate::io::json_number")]
    pub reading_mm: f64,
    /// Angle between the two readings' orientations (deg).
    #[serde(with = "crate::io::json_number")]
    pub reading_deg: f64,
    /// Distance between the model's positions of the two configurations (mm).
    #[serde(with = "crate::io::json_number")]
    pub model_mm: f64,
    /// The suspect row's position error under the model (mm).
    #[serde(with = "crate::io::json_number")]
    pub residual_mm: f64,
    /// The other row's position error under the model (mm).
    #[serde(with = "crate::io::json_number")]
    pub other_residual_mm: f64,
    /// The file of the other row when it is not of this row's set (a reference set, see
    /// [`shared_readings_with`]); `other_row` then indexes that set's rows.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub other_source: Option<String>,
}

impl SharedReading {
    /// One line for people: which row, whose reading, how far apart.
    pub fn describe(&self) -> String {
        let me = row_name(self.line, self.row);
        let other = match &self.other_source {
            Some(file) => format!("{} of {file}", row_name(self.other_line, self.other_row)),
            None => row_name(self.other_line, self.other_row),
        };
        format!(
            "{me} carries the reading of {other} ({:.4} mm and {:.4} deg apart) although the \
             model puts the two configurations {:.4} mm apart; the model misses {me} by {:.4} \
             mm and {other} by {:.4} mm",
            self.reading_mm,
            self.reading_deg,
            self.model_mm,
            self.residual_mm,
            self.other_residual_mm,
        )
    }
}

/// The rows of `set` whose reading a row of another configuration shares under `model` (see
/// the module's documentation), one per suspect row, in row order. Rows without a measured
/// position and orientation (or with another number of joints than `model`'s) take no part.
/// The readings are swept in the order of the coordinate that spreads widest, each against
/// those within [`POSITION_MM`] of it there, so the cost grows with the rows (and the readings
/// that close), not with all their pairs.
pub fn shared_readings(model: &Robot, set: &MeasurementSet) -> Vec<SharedReading> {
    let rows: Vec<&Measurement> = set.rows.iter().collect();
    sweep(model, &rows, rows.len())
}

/// The rows of `set` whose reading a row of another configuration shares under `model`, a row
/// of `set` or of `reference` (other measurements of the same robot, such as the training rows
/// of a validation set), one per suspect row of `set`, in row order. A suspect of `reference`
/// is not named (its reading may be a row of `set`'s: `reference` is checked on its own), and a
/// row of `set` whose reading a suspect of `reference` carries keeps its own. Where the other
/// row is one of `reference`'s, [`SharedReading::other_source`] names `reference`'s file and
/// `other_row` indexes its rows. With an empty `reference` this is [`shared_readings`].
pub fn shared_readings_with(
    model: &Robot,
    set: &MeasurementSet,
    reference: &MeasurementSet,
) -> Vec<SharedReading> {
    let n = set.rows.len();
    let rows: Vec<&Measurement> = set.rows.iter().chain(&reference.rows).collect();
    let mut found = sweep(model, &rows, n);
    for s in &mut found {
        if s.other_row >= n {
            s.other_row -= n;
            s.other_source = Some(reference.source.display().to_string());
        }
    }
    found
}

/// How many rows of `set` take part in the check under `model`: those with a measured position
/// and orientation and `model`'s number of joints.
pub fn rows_checked(model: &Robot, set: &MeasurementSet) -> usize {
    set.rows.iter().filter(|m| has_reading(model, m)).count()
}

/// Whether row `m` takes part: a finite measured position, an orientation, and `model`'s
/// number of joints (a row of another robot has no pose under `model`).
fn has_reading(model: &Robot, m: &Measurement) -> bool {
    m.rotation.is_some()
        && m.position.is_some_and(|p| p.iter().all(|v| v.is_finite()))
        && m.q.len() == model.dof()
}

/// The suspects among the first `named` of `rows` (see [`shared_readings`]); `other_row`
/// indexes `rows`.
fn sweep(model: &Robot, rows: &[&Measurement], named: usize) -> Vec<SharedReading> {
    let reading = |i: usize| match (&rows[i].position, &rows[i].rotation) {
        (Some(p), Some(r)) if has_reading(model, rows[i]) => Some((p, r)),
        _ => None,
    };
    let mut order: Vec<usize> = (0..rows.len()).filter(|&i| reading(i).is_some()).collect();
    // Sweep the readings in the order of the coordinate that spreads widest: only readings
    // within POSITION_MM in it can be one.
    let at = |i: usize, k: usize| rows[i].position.map_or(0.0, |p| p[k]);
    let spread = |k: usize| {
        let (lo, hi) = order
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &i| {
                (lo.min(at(i, k)), hi.max(at(i, k)))
            });
        hi - lo
    };
    let key = (0..3)
        .max_by(|&a, &b| spread(a).total_cmp(&spread(b)))
        .unwrap_or(0);
    order.sort_by(|&a, &b| at(a, key).total_cmp(&at(b, key)));
    let mut model_at: Vec<Option<Vector3<f64>>> = vec![None; rows.len()];
    let mut position = |i: usize| -> Vector3<f64> {
        *model_at[i].get_or_insert_with(|| tool_pose(model, &rows[i].q).translation.vector)
    };
    let mut found: Vec<Option<SharedReading>> = vec![None; named];
    let limit = ORIENTATION_DEG.to_radians();
    for (k, &i) in order.iter().enumerate() {
        let (pa, ra) = reading(i).expect("only rows with a reading are swept");
        for &j in order[k + 1..]
            .iter()
            .take_while(|&&j| at(j, key) - at(i, key) <= POSITION_MM)
        {
            if i >= named && j >= named {
                continue;
            }
            let (pb, rb) = reading(j).expect("only rows with a reading are swept");
            let reading_mm = (pa - pb).norm();
            if reading_mm > POSITION_MM || same_configuration(&rows[i].q, &rows[j].q) {
                continue;
            }
            let angle = angle_between(ra, rb);
            if angle.is_nan() || angle > limit {
                continue;
            }
            let (ma, mb) = (position(i), position(j));
            let model_mm = (ma - mb).norm();
            if model_mm.is_nan() || model_mm < SEPARATION_MM {
                continue;
            }
            let (ea, eb) = ((pa - ma).norm(), (pb - mb).norm());
            // The later row on a tie (a choice: nothing tells the two apart then).
            let (s, o, es, eo) = if ea > eb || (ea == eb && i > j) {
                (i, j, ea, eb)
            } else {
                (j, i, eb, ea)
            };
            // The closest reading where several are shared (the first row on a tie).
            if s >= named
                || found[s].as_ref().is_some_and(|f| {
                    f.reading_mm < reading_mm || (f.reading_mm == reading_mm && f.other_row < o)
                })
            {
                continue;
            }
            found[s] = Some(SharedReading {
                row: s,
                line: rows[s].line,
                other_row: o,
                other_line: rows[o].line,
                reading_mm,
                reading_deg: angle.to_degrees(),
                model_mm,
                residual_mm: es,
                other_residual_mm: eo,
                other_source: None,
            });
        }
    }
    found.into_iter().flatten().collect()
}

/// The row indices of `shared` (ascending, as [`shared_readings`] gives them).
pub fn suspect_rows(shared: &[SharedReading]) -> Vec<usize> {
    shared.iter().map(|s| s.row).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::data::Measurement;
    use crate::model::test_ur10 as ur10;
    use nalgebra::Rotation3;

    /// A row at joints `q` (rad) whose reading is the model's pose at `at` (rad), moved by
    /// `off` (mm) and turned by `turn` (rad about x), on `line`.
    fn row(
        robot: &Robot,
        q: [f64; 6],
        at: [f64; 6],
        off: [f64; 3],
        turn: f64,
        line: usize,
    ) -> Measurement {
        let pose = tool_pose(robot, &at);
        let mut m = Measurement::new(q.to_vec());
        m.position = Some(pose.translation.vector + Vector3::from(off));
        m.rotation = Some(pose.rotation * Rotation3::from_euler_angles(turn, 0.0, 0.0));
        m.line = line;
        m
    }

    #[test]
    fn a_reading_logged_with_another_configuration_is_found_and_its_row_named() {
        let robot = ur10();
        let a = [0.3, -1.2, 1.4, -1.8, -1.5, 0.2];
        let b = [1.1, -0.7, 1.5, -0.3, 0.4, 0.5];
        let c = [-1.0, -2.0, 1.0, 0.0, -1.0, 2.0];
        let a_again = [a[0] + 5e-3, a[1], a[2], a[3], a[4], a[5]];
        assert!(
            (tool_pose(&robot, &a_again).translation.vector
                - tool_pose(&robot, &a).translation.vector)
                .norm()
                > 2.0 * SEPARATION_MM
        );
        let pa = tool_pose(&robot, &a).translation.vector;
        let pb = tool_pose(&robot, &b).translation.vector;
        assert!((pa - pb).norm() > 100.0);
        let rows = vec![
            row(&robot, a, a, [0.2, 0.0, -0.1], 0.0, 2),
            // b's row carries a's reading (0.03 mm and 1e-4 rad = 0.0057 deg from it).
            row(&robot, b, a, [0.2, 0.03, -0.1], 1e-4, 3),
            row(&robot, c, c, [0.0, 0.3, 0.0], 0.0, 4),
            // a measured again, its joints logged 5e-3 rad apart (the model moves the tool
            // by about 5 mm): one configuration, so not a shared reading with line 2 (0.05
            // mm); 0.058 mm from line 3's reading.
            row(&robot, a_again, a, [0.2, 0.0, -0.05], 0.0, 5),
        ];
        let set = MeasurementSet::from_rows(rows);
        let found = shared_readings(&robot, &set);
        assert_eq!(found.len(), 1, "{found:?}");
        let s = &found[0];
        assert_eq!((s.row, s.line), (1, 3));
        // The closest reading: line 2's (0.03 mm), not line 5's (0.058 mm).
        assert_eq!((s.other_row, s.other_line), (0, 2));
        assert!((s.reading_mm - 0.03).abs() < 1e-9, "{s:?}");
        assert!((s.reading_deg - 1e-4f64.to_degrees()).abs() < 1e-9);
        assert!((s.model_mm - (pa - pb).norm()).abs() < 1e-9);
        assert!((s.other_residual_mm - 0.2f64.hypot(0.1)).abs() < 1e-9);
        assert!((s.residual_mm - (pa - pb).norm()).abs() < 1.0);
        assert_eq!(suspect_rows(&found), vec![1]);
        assert!(
            s.describe()
                .starts_with("line 3 carries the reading of line 2 (0.0300 mm")
        );
    }

    #[test]
    fn a_reading_shared_with_a_reference_row_is_found_in_the_set_only() {
        let robot = ur10();
        let a = [0.3, -1.2, 1.4, -1.8, -1.5, 0.2];
        let b = [1.1, -0.7, 1.5, -0.3, 0.4, 0.5];
        let c = [-1.0, -2.0, 1.0, 0.0, -1.0, 2.0];
        let d = [0.5, -1.5, 2.0, -0.5, 1.0, -1.0];
        // The validation rows: b carries the reading of a training row (a), 0.03 mm off.
        let set = MeasurementSet::from_rows(vec![
            row(&robot, c, c, [0.1, 0.0, 0.0], 0.0, 2),
            row(&robot, b, a, [0.2, 0.03, -0.1], 1e-4, 3),
        ]);
        let mut training = MeasurementSet::from_rows(vec![
            row(&robot, d, d, [0.0; 3], 0.0, 7),
            row(&robot, a, a, [0.2, 0.0, -0.1], 0.0, 8),
        ]);
        training.source = "training.csv".into();
        assert!(shared_readings(&robot, &set).is_empty());
        assert!(shared_readings(&robot, &training).is_empty());
        let found = shared_readings_with(&robot, &set, &training);
        assert_eq!(found.len(), 1, "{found:?}");
        let s = &found[0];
        assert_eq!((s.row, s.line, s.other_row, s.other_line), (1, 3, 1, 8));
        assert_eq!(s.other_source.as_deref(), Some("training.csv"));
        assert!((s.reading_mm - 0.03).abs() < 1e-9, "{s:?}");
        assert!(
            s.describe()
                .starts_with("line 3 carries the reading of line 8 of training.csv (0.0300 mm"),
            "{}",
            s.describe()
        );
        // The other way round the suspect is a reference row: not named, and the set's row
        // keeps its reading.
        let mut swapped = set.clone();
        swapped.source = "validation.csv".into();
        assert!(shared_readings_with(&robot, &training, &swapped).is_empty());
        // Without a reference, or with the set itself as its reference (every row the same
        // configuration as its copy), the set's own check.
        let mut own = set.clone();
        own.rows.push(row(&robot, a, a, [0.2, 0.0, -0.1], 0.0, 4));
        let alone = shared_readings(&robot, &own);
        assert_eq!(alone.len(), 1);
        assert_eq!(alone[0].other_source, None);
        for reference in [MeasurementSet::from_rows(Vec::new()), own.clone()] {
            assert_eq!(shared_readings_with(&robot, &own, &reference), alone);
        }
        // A reading both files share: the closest is named, here the reference's (exactly the
        // suspect's reading) before the set's (0.03 mm).
        let mut exact = training.clone();
        exact.rows[1] = row(&robot, a, a, [0.2, 0.03, -0.1], 1e-4, 9);
        let closest = shared_readings_with(&robot, &own, &exact);
        assert_eq!(closest.len(), 1);
        assert_eq!((closest[0].other_line, closest[0].reading_mm), (9, 0.0));
        // A slip within the reference is the reference's own (not named here), and an empty
        // set has nothing to name.
        let mut slipped = training.clone();
        slipped
            .rows
            .push(row(&robot, c, d, [0.01, 0.0, 0.0], 0.0, 10));
        assert_eq!(shared_readings(&robot, &slipped).len(), 1);
        assert_eq!(shared_readings_with(&robot, &set, &slipped), found);
        let none = MeasurementSet::from_rows(Vec::new());
        assert!(shared_readings_with(&robot, &none, &slipped).is_empty());
        // A row of another robot (five joints) takes no part, and does not stop the check.
        let mut other_robot = training.clone();
        let mut five = row(&robot, a, a, [0.2, 0.03, -0.1], 1e-4, 11);
        five.q.pop();
        other_robot.rows.push(five);
        assert_eq!(shared_readings_with(&robot, &set, &other_robot), found);
        assert_eq!(
            (
                rows_checked(&robot, &training),
                rows_checked(&robot, &other_robot)
            ),
            (2, 2)
        );
        let mut no_orientation = training.clone();
        no_orientation.rows[0].rotation = None;
        assert_eq!(rows_checked(&robot, &no_orientation), 1);
        // The JSON form names the other file only where there is one.
        let json = serde_json::to_string(&alone[0]).unwrap();
        assert!(!json.contains("other_source"), "{json}");
        let back: SharedReading = serde_json::from_str(&json).unwrap();
        assert_eq!(back, alone[0]);
        let json = serde_json::to_string(&found[0]).unwrap();
        assert!(json.contains("\"other_source\":\"training.csv\""), "{json}");
    }

    #[test]
    fn readings_close_in_one_coordinate_only_are_not_one() {
        let robot = ur10();
        let a = [0.3, -1.2, 1.4, -1.8, -1.5, 0.2];
        let b = [1.1, -0.7, 1.5, -0.3, 0.4, 0.5];
        let c = [-1.0, -2.0, 1.0, 0.0, -1.0, 2.0];
        // Within 0.05 mm in two coordinates but 0.15 mm apart in the third: not one reading,
        // whichever coordinate the sweep runs along.
        for k in 0..3 {
            let mut off = [0.05, -0.05, 0.05];
            off[k] = 0.15;
            let apart = MeasurementSet::from_rows(vec![
                row(&robot, a, a, [0.0; 3], 0.0, 2),
                row(&robot, b, a, off, 0.0, 3),
                row(&robot, c, c, [0.0; 3], 0.0, 4),
            ]);
            assert!(shared_readings(&robot, &apart).is_empty(), "{k}");
            // 0.09 mm in that coordinate alone: one reading.
            let mut shifted = [0.0; 3];
            shifted[k] = 0.09;
            let close = MeasurementSet::from_rows(vec![
                row(&robot, a, a, [0.0; 3], 0.0, 2),
                row(&robot, b, a, shifted, 0.0, 3),
                row(&robot, c, c, [0.0; 3], 0.0, 4),
            ]);
            let found = shared_readings(&robot, &close);
            assert_eq!(found.len(), 1, "{k}");
            assert_eq!((found[0].row, found[0].other_row), (1, 0));
        }
    }

    #[test]
    fn readings_apart_or_configurations_the_model_does_not_separate_are_not_shared() {
        let robot = ur10();
        let a = [0.3, -1.2, 1.4, -1.8, -1.5, 0.2];
        let b = [1.1, -0.7, 1.5, -0.3, 0.4, 0.5];
        // Beyond the position tolerance.
        let apart = MeasurementSet::from_rows(vec![
            row(&robot, a, a, [0.0; 3], 0.0, 2),
            row(&robot, b, a, [0.0, 0.0, 1.01 * POSITION_MM], 0.0, 3),
        ]);
        assert!(shared_readings(&robot, &apart).is_empty());
        // Beyond the orientation tolerance (turned 0.03 deg).
        let turned = MeasurementSet::from_rows(vec![
            row(&robot, a, a, [0.0; 3], 0.0, 2),
            row(&robot, b, a, [0.0; 3], 0.03f64.to_radians(), 3),
        ]);
        assert!(shared_readings(&robot, &turned).is_empty());
        // The same reading without orientations is not judged: a position alone does not
        // tell a turn about the probe point from a reading of another pose.
        let mut positions = turned.clone();
        for m in &mut positions.rows {
            m.rotation = None;
        }
        assert!(shared_readings(&robot, &positions).is_empty());
        let mut shared = positions.clone();
        for m in &mut shared.rows {
            m.rotation = Some(Rotation3::identity());
        }
        assert_eq!(shared_readings(&robot, &shared).len(), 1);
        shared.rows[0].rotation = None;
        assert!(shared_readings(&robot, &shared).is_empty());
        // The model puts two configurations at one pose (within SEPARATION_MM): joint 6 turned
        // by a whole turn, which the repeat rule does not take for one configuration.
        let mut whole_turn = a;
        whole_turn[5] += std::f64::consts::TAU;
        let one_point = MeasurementSet::from_rows(vec![
            row(&robot, a, a, [0.0; 3], 0.0, 2),
            row(&robot, whole_turn, a, [0.0, 0.02, 0.0], 1e-5, 3),
        ]);
        assert!(shared_readings(&robot, &one_point).is_empty());
    }
}
