//! Measurement sets: joint configurations with what a sensor observed there.
//!
//! One row is one configuration. It may carry a position (mm), an orientation, a ball-bar
//! distance (mm, on the second row of a pair) and per-row standard deviations. How the rows are
//! used (full pose, position, orientation, relative position, distance) is chosen by the
//! consumer; [`pairs`](super::pairs) groups rows for relative and distance use.

use super::joint_columns;
use super::profile::{AngleUnit, Profile};
use super::table::{CsvOut, Table, shown};
use crate::error::{Error, IN_MEMORY, Location, Result};
use crate::geometry::Pose;
use crate::geometry::rotation::{EulerConvention, rotation_to_zyx};
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
}

impl MeasurementSet {
    /// A set built in code; its rows' `line` fields are theirs to set (0 for none), and
    /// errors name the set [`IN_MEMORY`].
    pub fn from_rows(rows: Vec<Measurement>) -> MeasurementSet {
        MeasurementSet {
            source: PathBuf::from(IN_MEMORY),
            rows,
            extra_columns: Vec::new(),
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

/// How strictly rows are read.
#[derive(Debug, Clone, Copy, Default)]
pub struct ReadOptions {
    /// Joints outside the limits are an error instead of a warning.
    pub strict: bool,
    /// Rows that do not parse are dropped and listed instead of stopping the read.
    pub skip_bad_rows: bool,
}

/// What a read noticed: warnings, and the rows it dropped (with `skip_bad_rows`).
#[derive(Debug, Clone, Default)]
pub struct ReadReport {
    /// Warnings for the user (joints outside limits, suspicious units, ...), one per message.
    pub warnings: Vec<String>,
    /// (line, reason) of each dropped row.
    pub skipped: Vec<(usize, String)>,
}

/// Column indices of one group of three (x, y, z style); all present or all absent.
fn group(t: &Table, names: &[String; 3], what: &str) -> Result<Option<[usize; 3]>> {
    let idx: Vec<Option<usize>> = names.iter().map(|n| t.column(n)).collect();
    match idx.iter().filter(|i| i.is_some()).count() {
        0 => Ok(None),
        3 => Ok(Some([
            idx[0].unwrap_or(0),
            idx[1].unwrap_or(0),
            idx[2].unwrap_or(0),
        ])),
        _ => {
            let missing: Vec<&str> = names
                .iter()
                .zip(&idx)
                .filter(|(_, i)| i.is_none())
                .map(|(n, _)| n.as_str())
                .collect();
            Err(Error::input(
                Location::at(&t.path, 1, missing.join(", ")),
                format!("{what} columns must come as a group of three; missing column(s)"),
            ))
        }
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
        joints.iter().zip(q).any(|(j, v)| {
            j.limits
                .is_some_and(|[lo, hi]| *v < lo - 1e-9 || *v > hi + 1e-9)
        })
    }
}

/// Reads a measurement file for `robot` through `profile` ([`Profile::default`] reads
/// canonical CSV).
pub fn read_measurements(
    path: &Path,
    robot: &Robot,
    profile: &Profile,
    opts: &ReadOptions,
) -> Result<(MeasurementSet, ReadReport)> {
    let t = Table::read_with(path, profile.delimiter, profile.decimal_comma)?;
    parse_measurements(&t, &JointInfo::of(robot), profile, opts)
}

/// Reads a canonical CSV measurement file (the shipped sets) with default options; what the
/// read noticed is dropped, so use [`read_measurements`] for user data.
pub fn read_canonical(path: &Path, robot: &Robot) -> Result<MeasurementSet> {
    Ok(read_measurements(path, robot, &Profile::default(), &ReadOptions::default())?.0)
}

/// Turns a table into measurements; see [`read_measurements`].
pub fn parse_measurements(
    t: &Table,
    joints: &[JointInfo],
    profile: &Profile,
    opts: &ReadOptions,
) -> Result<(MeasurementSet, ReadReport)> {
    let n = joints.len();
    let cols = &profile.columns;
    let joint_names = cols.joints.clone().unwrap_or_else(|| joint_columns(n));
    if joint_names.len() != n {
        return Err(Error::input(
            Location::file(&t.path),
            format!(
                "the profile names {} joint columns, the robot has {n} joints",
                joint_names.len()
            ),
        ));
    }
    let jidx: Vec<usize> = joint_names
        .iter()
        .map(|c| t.require(c))
        .collect::<Result<_>>()?;
    let pidx = group(t, &cols.position, "position")?;
    let aidx = group(t, &cols.angles, "orientation")?;
    let spidx = group(t, &cols.sigma_position, "position sigma")?;
    let saidx = group(t, &cols.sigma_angles, "orientation sigma")?;
    let didx = t.column(&cols.distance);
    let (id_i, set_i, pair_i) = (
        t.column(&cols.id),
        t.column(&cols.set),
        t.column(&cols.pair),
    );
    if pidx.is_none() && aidx.is_none() && didx.is_none() {
        return Err(Error::input(
            Location::file(&t.path),
            format!(
                "no measurement columns: expected position ({}), orientation ({}) or distance ({})",
                cols.position.join(", "),
                cols.angles.join(", "),
                cols.distance
            ),
        ));
    }
    let mut used: Vec<usize> = jidx.clone();
    for g in [pidx, aidx, spidx, saidx].into_iter().flatten() {
        used.extend(g);
    }
    used.extend([didx, id_i, set_i, pair_i].into_iter().flatten());
    let extra_idx: Vec<usize> = (0..t.headers.len()).filter(|i| !used.contains(i)).collect();
    let mut report = ReadReport::default();
    if spidx.is_none() && cols.sigma_position[0] != "sx" {
        report.warnings.push(format!(
            "no position sigma columns ({}) in this file: the set-level sigma applies",
            cols.sigma_position.join(", ")
        ));
    }

    let lu = profile.length_unit;
    let euler = profile.euler;
    let au = profile.angle_unit;
    let parse_row = |r: usize| -> Result<Measurement> {
        let raw = t.numbers(r, &jidx)?;
        let q: Vec<f64> = raw
            .iter()
            .zip(joints)
            .map(|(&v, j)| match j.joint_type {
                JointType::Revolute => profile.joint_unit.to_rad(v),
                JointType::Prismatic => lu.to_mm(v),
            })
            .collect();
        let vec3 = |idx: [usize; 3], f: &dyn Fn(f64) -> f64| -> Result<Vector3<f64>> {
            let v = t.numbers(r, &idx)?;
            Ok(Vector3::new(f(v[0]), f(v[1]), f(v[2])))
        };
        // Physical bounds, after unit conversion (mm, rad): a finite 1e300 would otherwise
        // reach the solvers (and read as a perfect fit).
        let bound = |col: usize, v: f64, max: f64, what: &str| -> Result<()> {
            if v.abs() > max {
                return Err(Error::input(
                    t.location(r, col),
                    format!(
                        "`{}` is beyond the bound of a {what}",
                        shown(&t.rows[r][col])
                    ),
                ));
            }
            Ok(())
        };
        let mut m = Measurement::new(q);
        m.line = t.lines[r];
        if let Some(i) = pidx {
            m.position = Some(vec3(i, &|v| lu.to_mm(v))?);
        }
        if let Some(i) = aidx {
            let a = vec3(i, &|v| au.to_rad(v))?;
            for k in 0..3 {
                bound(
                    i[k],
                    a[k],
                    crate::model::file::MAX_ANGLE_DEG.to_radians(),
                    "orientation angle (2 turns)",
                )?;
            }
            // Columns are the angles about x, y, z; each convention takes them in its order.
            let ordered = match euler {
                EulerConvention::Zyx => [a.z, a.y, a.x],
                EulerConvention::XyzIntrinsic | EulerConvention::XyzExtrinsic => [a.x, a.y, a.z],
            };
            m.rotation = Some(euler.to_rotation(ordered));
        }
        if let Some(i) = spidx {
            m.sigma_position = Some(vec3(i, &|v| lu.to_mm(v))?);
        }
        if let Some(i) = saidx {
            m.sigma_rotation = Some(vec3(i, &|v| au.to_rad(v))?);
        }
        for (idx, v) in [spidx, saidx]
            .iter()
            .zip([m.sigma_position, m.sigma_rotation])
            .filter_map(|(i, v)| i.zip(v))
        {
            if let Some(k) = (0..3).find(|&k| v[k] <= 0.0) {
                return Err(Error::input(
                    t.location(r, idx[k]),
                    "a standard deviation must be positive",
                ));
            }
        }
        let (max_mm, max_joint) = (
            crate::model::file::MAX_LENGTH_MM,
            crate::model::file::MAX_JOINT_DEG.to_radians(),
        );
        for ((&col, &v), j) in jidx.iter().zip(&m.q).zip(joints) {
            match j.joint_type {
                JointType::Revolute => bound(col, v, max_joint, "joint angle (4 turns)")?,
                JointType::Prismatic => bound(col, v, max_mm, "joint length (100 m)")?,
            }
        }
        if let (Some(i), Some(p)) = (pidx, m.position) {
            for k in 0..3 {
                bound(i[k], p[k], max_mm, "position (100 m)")?;
            }
        }
        // Standard deviations between 1 nm (1 nrad) and 1 m (1 rad): a smaller one weighs its
        // row by 1e18 and more, which no instrument justifies.
        for (idx, v, min, max, what) in [
            (
                spidx,
                m.sigma_position,
                1e-6,
                1e3,
                "position standard deviation (1 nm to 1 m)",
            ),
            (
                saidx,
                m.sigma_rotation,
                1e-9,
                1.0,
                "orientation standard deviation (1 nrad to 1 rad)",
            ),
        ] {
            if let (Some(i), Some(v)) = (idx, v) {
                for k in 0..3 {
                    bound(i[k], v[k], max, what)?;
                    if v[k] < min {
                        return Err(Error::input(
                            t.location(r, i[k]),
                            format!(
                                "`{}` is below the bound of a {what}",
                                shown(&t.rows[r][i[k]])
                            ),
                        ));
                    }
                }
            }
        }
        if let Some(i) = didx {
            m.distance = t.optional_number(r, i)?;
            if let Some(d) = m.distance {
                bound(i, lu.to_mm(d), max_mm, "distance (100 m)")?;
            }
            if m.distance.is_some_and(|d| d < 0.0) {
                return Err(Error::input(
                    t.location(r, i),
                    "a distance cannot be negative",
                ));
            }
            m.distance = m.distance.map(|d| lu.to_mm(d));
        }
        let text = |i: Option<usize>| i.map(|i| t.rows[r][i].clone()).filter(|s| !s.is_empty());
        m.id = text(id_i);
        m.set = text(set_i);
        m.pair = text(pair_i);
        m.extra = extra_idx
            .iter()
            .map(|&i| {
                let c = &t.rows[r][i];
                // Numbers written with a decimal comma are carried as canonical numbers.
                if t.decimal_comma && c.replace(',', ".").parse::<f64>().is_ok() {
                    c.replace(',', ".")
                } else {
                    c.clone()
                }
            })
            .collect();
        Ok(m)
    };

    if !opts.skip_bad_rows {
        t.reject_malformed()?;
    }
    let mut bad: Vec<(usize, String)> = t
        .malformed
        .iter()
        .map(|(line, msg)| (*line, format!("{}:{line}: {msg}", t.path.display())))
        .collect();
    let mut rows = Vec::with_capacity(t.rows.len());
    for r in 0..t.rows.len() {
        match parse_row(r) {
            Ok(m) => rows.push(m),
            Err(e) if opts.skip_bad_rows => bad.push((t.lines[r], e.to_string())),
            Err(e) => return Err(e),
        }
    }
    bad.sort_by_key(|(line, _)| *line);
    report.skipped = bad;
    if rows.is_empty() {
        return Err(Error::input(Location::file(&t.path), "no measurement rows"));
    }

    // Joint limits.
    let outside: Vec<usize> = rows
        .iter()
        .filter(|m| JointInfo::outside(joints, &m.q))
        .map(|m| m.line)
        .collect();
    if !outside.is_empty() {
        let msg = format!(
            "{} row(s) have joints outside the robot's limits (lines {})",
            outside.len(),
            list_lines(&outside)
        );
        if opts.strict {
            return Err(Error::input(Location::file(&t.path), msg));
        }
        report.warnings.push(msg);
    }
    // Units that look wrong: the largest revolute joint value, in the file's unit.
    let in_file_unit = |q: f64| match profile.joint_unit {
        AngleUnit::Deg => q.to_degrees().abs(),
        AngleUnit::Rad => q.abs(),
    };
    let max_joint = rows
        .iter()
        .flat_map(|m| m.q.iter().zip(joints))
        .filter(|(_, j)| j.joint_type == JointType::Revolute)
        .map(|(&q, _)| in_file_unit(q))
        .fold(0.0, f64::max);
    if profile.joint_unit == AngleUnit::Deg
        && rows.len() >= 3
        && max_joint > 0.0
        && max_joint <= 6.3
    {
        report.warnings.push(
            "every joint value is within +-6.3 although the file's joints are in degrees: \
             are they radians? (set joint_unit = \"rad\" in a profile)"
                .to_string(),
        );
    }
    if profile.joint_unit == AngleUnit::Rad && max_joint > 7.0 {
        report.warnings.push(format!(
            "joint values reach {max_joint:.1} although the file's joints are in radians: are they degrees?"
        ));
    }
    Ok((
        MeasurementSet {
            source: t.path.clone(),
            rows,
            extra_columns: extra_idx.iter().map(|&i| t.headers[i].clone()).collect(),
        },
        report,
    ))
}

/// "2, 5, 9" (at most 20 lines, then "...").
pub fn list_lines(lines: &[usize]) -> String {
    let mut s: Vec<String> = lines.iter().take(20).map(|l| l.to_string()).collect();
    if lines.len() > 20 {
        s.push(format!("... ({} more)", lines.len() - 20));
    }
    s.join(", ")
}

/// The columns of a canonical measurement CSV: which optional groups it has, and the
/// carried-through columns.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Layout {
    /// Has an `id` column.
    pub id: bool,
    /// Has a `set` column.
    pub set: bool,
    /// Has a `pair` column.
    pub pair: bool,
    /// Has the position columns `x, y, z` (mm).
    pub position: bool,
    /// Has the orientation columns `rz, ry, rx` (deg, R = Rz Ry Rx).
    pub rotation: bool,
    /// Has a `distance` column (mm).
    pub distance: bool,
    /// Has the position sigma columns `sx, sy, sz` (mm).
    pub sigma_position: bool,
    /// Has the orientation sigma columns `srx, sry, srz` (deg).
    pub sigma_rotation: bool,
    /// Names of the carried-through columns, written last in this order.
    pub extra: Vec<String>,
}

impl Layout {
    /// The groups some row of `set` has.
    pub fn of(set: &MeasurementSet) -> Layout {
        let any = |f: &dyn Fn(&Measurement) -> bool| set.rows.iter().any(f);
        Layout {
            id: any(&|m| m.id.is_some()),
            set: any(&|m| m.set.is_some()),
            pair: any(&|m| m.pair.is_some()),
            position: any(&|m| m.position.is_some()),
            rotation: any(&|m| m.rotation.is_some()),
            distance: any(&|m| m.distance.is_some()),
            sigma_position: any(&|m| m.sigma_position.is_some()),
            sigma_rotation: any(&|m| m.sigma_rotation.is_some()),
            extra: set.extra_columns.clone(),
        }
    }

    /// The header row (joints in file units: deg, or mm for prismatic).
    pub fn headers(&self, joints: &[JointInfo]) -> Vec<String> {
        let mut headers: Vec<String> = Vec::new();
        let joints = joint_columns(joints.len());
        let joints: Vec<&str> = joints.iter().map(String::as_str).collect();
        let mut push = |on: bool, names: &[&str]| {
            if on {
                headers.extend(names.iter().map(|s| s.to_string()));
            }
        };
        push(self.id, &["id"]);
        push(self.set, &["set"]);
        push(self.pair, &["pair"]);
        push(true, &joints);
        push(self.position, &["x", "y", "z"]);
        push(self.rotation, &["rz", "ry", "rx"]);
        push(self.distance, &["distance"]);
        push(self.sigma_position, &["sx", "sy", "sz"]);
        push(self.sigma_rotation, &["srx", "sry", "srz"]);
        headers.extend(self.extra.iter().cloned());
        headers
    }

    /// The cells of one row (mm, deg), blank where the row lacks a group the layout has.
    pub fn cells(&self, m: &Measurement, joints: &[JointInfo]) -> Vec<String> {
        let num = |v: f64| format!("{v}");
        let mut c: Vec<String> = Vec::new();
        let text = |o: &Option<String>| o.clone().unwrap_or_default();
        if self.id {
            c.push(text(&m.id));
        }
        if self.set {
            c.push(text(&m.set));
        }
        if self.pair {
            c.push(text(&m.pair));
        }
        c.extend(
            m.q.iter()
                .zip(joints)
                .map(|(&v, j)| num(j.joint_type.to_file(v))),
        );
        let opt3 = |c: &mut Vec<String>, on: bool, v: Option<[f64; 3]>| {
            if on {
                match v {
                    Some(v) => c.extend(v.map(num)),
                    None => c.extend([String::new(), String::new(), String::new()]),
                }
            }
        };
        opt3(&mut c, self.position, m.position.map(|p| [p.x, p.y, p.z]));
        opt3(
            &mut c,
            self.rotation,
            m.rotation.map(|r| rotation_to_zyx(&r).map(f64::to_degrees)),
        );
        if self.distance {
            c.push(m.distance.map(num).unwrap_or_default());
        }
        opt3(
            &mut c,
            self.sigma_position,
            m.sigma_position.map(|s| [s.x, s.y, s.z]),
        );
        opt3(
            &mut c,
            self.sigma_rotation,
            m.sigma_rotation
                .map(|s| [s.x, s.y, s.z].map(f64::to_degrees)),
        );
        c.extend(m.extra.iter().cloned());
        c
    }
}

/// A set as canonical CSV bytes.
pub fn measurements_to_csv(set: &MeasurementSet, joints: &[JointInfo]) -> Result<Vec<u8>> {
    let layout = Layout::of(set);
    let mut out = CsvOut::new(&layout.headers(joints))?;
    for m in &set.rows {
        out.row(&layout.cells(m, joints))?;
    }
    out.into_bytes()
}

/// Writes a set as canonical CSV, atomically.
pub fn write_measurements(set: &MeasurementSet, joints: &[JointInfo], path: &Path) -> Result<()> {
    crate::io::write_atomic(path, &measurements_to_csv(set, joints)?)
}

/// Canonical CSV streamed row by row to a file that appears whole on
/// [`MeasurementWriter::finish`] (a million simulated rows need no memory).
pub struct MeasurementWriter {
    w: csv::Writer<crate::io::AtomicWriter>,
    layout: Layout,
    joints: Vec<JointInfo>,
}

impl MeasurementWriter {
    /// Starts a file at `path` with `layout`'s columns and writes its header row; nothing
    /// appears at `path` until [`finish`](Self::finish).
    pub fn create(path: &Path, layout: Layout, joints: &[JointInfo]) -> Result<Self> {
        let mut w = csv::Writer::from_writer(crate::io::AtomicWriter::create(path)?);
        let csv_err = |e: csv::Error| Error::Invalid(format!("{}: {e}", path.display()));
        w.write_record(layout.headers(joints)).map_err(csv_err)?;
        Ok(MeasurementWriter {
            w,
            layout,
            joints: joints.to_vec(),
        })
    }

    /// Writes one row (in file units: deg, mm), blank where it lacks a group of the layout.
    pub fn write(&mut self, m: &Measurement) -> Result<()> {
        let cells = self.layout.cells(m, &self.joints);
        self.w
            .write_record(cells)
            .map_err(|e| Error::Invalid(format!("{}: {e}", self.w.get_ref().path().display())))
    }

    /// Flushes the rows and moves the file into place (or stages it for the open transaction).
    pub fn finish(self) -> Result<()> {
        let path = self.w.get_ref().path().to_path_buf();
        self.w
            .into_inner()
            .map_err(|e| Error::Invalid(format!("{}: {}", path.display(), e.error())))?
            .finish()
    }
}

/// Splits a set into two by a seeded random draw: `fraction` of the rows (rounded) go to the
/// first part; both keep file order.
pub fn split(set: &MeasurementSet, fraction: f64, seed: u64) -> (MeasurementSet, MeasurementSet) {
    use rand::SeedableRng;
    use rand::seq::SliceRandom;
    let n = set.rows.len();
    let mut idx: Vec<usize> = (0..n).collect();
    idx.shuffle(&mut rand_chacha::ChaCha8Rng::seed_from_u64(seed));
    let k = ((n as f64) * fraction.clamp(0.0, 1.0)).round() as usize;
    let mut first = vec![false; n];
    for &i in &idx[..k] {
        first[i] = true;
    }
    let part = |want: bool| MeasurementSet {
        source: set.source.clone(),
        rows: set
            .rows
            .iter()
            .zip(&first)
            .filter(|(_, f)| **f == want)
            .map(|(m, _)| m.clone())
            .collect(),
        extra_columns: set.extra_columns.clone(),
    };
    (part(true), part(false))
}
