//! Reading measurement files: columns through a profile, units converted to mm and rad,
//! every value bounded, and what the read noticed (warnings, dropped rows).

use super::{JointInfo, Measurement, MeasurementSet, list_lines};
use crate::data::joint_columns;
use crate::data::profile::{AngleUnit, Orientation, Profile, SigmaAngles};
use crate::data::table::{Table, shown};
use crate::error::{Error, Location, Result};
use crate::geometry::rotation::EulerConvention;
use crate::model::{JointType, MAX_LENGTH_MM, Robot};
use nalgebra::{Quaternion, Rotation3, UnitQuaternion, Vector3};
use std::path::Path;

/// How far a quaternion's norm may be from 1: components rounded to 6 decimals move it by
/// 2e-6 at most; 1e-3 is a rounding to 3 decimals, and beyond it a column is not a quaternion's.
pub const QUATERNION_NORM_TOLERANCE: f64 = 1e-3;

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

/// The header's names that differ from `names` in letter case only, as "X for x".
fn other_case(t: &Table, names: &[String]) -> Vec<String> {
    (names.iter())
        .filter_map(|n| t.other_case(n).map(|h| format!("{} for {n}", shown(h))))
        .collect()
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
                format!(
                    "{what} columns must come as a group of three; missing column(s){}",
                    missing.iter().map(|n| t.case_hint(n)).collect::<String>()
                ),
            ))
        }
    }
}

/// Column indices of a quaternion (w, x, y, z); all present or all absent.
fn quaternion_group(t: &Table, names: &[String; 4]) -> Result<Option<[usize; 4]>> {
    let idx: Vec<Option<usize>> = names.iter().map(|n| t.column(n)).collect();
    match idx.iter().flatten().copied().collect::<Vec<usize>>()[..] {
        [] => Ok(None),
        [w, x, y, z] => Ok(Some([w, x, y, z])),
        _ => {
            let missing: Vec<&str> = (names.iter().zip(&idx))
                .filter(|(_, i)| i.is_none())
                .map(|(n, _)| n.as_str())
                .collect();
            Err(Error::input(
                Location::at(&t.path, 1, missing.join(", ")),
                "quaternion columns must come as a group of four (w, x, y, z); missing column(s)",
            ))
        }
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

/// The columns a table's measurements are read from (indices into its header).
struct Columns {
    joints: Vec<usize>,
    position: Option<[usize; 3]>,
    /// Three angles or a rotation vector (as the profile's orientation says).
    angles: Option<[usize; 3]>,
    quaternion: Option<[usize; 4]>,
    sigma_position: Option<[usize; 3]>,
    sigma_angles: Option<[usize; 3]>,
    distance: Option<usize>,
    id: Option<usize>,
    set: Option<usize>,
    pair: Option<usize>,
    /// The carried-through columns: every other one.
    extra: Vec<usize>,
}

impl Columns {
    /// The profile's columns in `t` for `n` joints; a missing joint column, a partial group
    /// or no measurement column at all is an error naming the file.
    fn resolve(t: &Table, n: usize, profile: &Profile) -> Result<Columns> {
        let cols = &profile.columns;
        if cols.joints.is_none() {
            crate::data::no_extra_joint(t, n)?;
        }
        let joint_names = cols.joints.clone().unwrap_or_else(|| joint_columns(n));
        if joint_names.len() != n {
            // The profile is what to mend: named where it was read from a file.
            let (at, data) = match &profile.path {
                Some(p) => (p, format!(" (reading {})", t.path.display())),
                None => (&t.path, String::new()),
            };
            return Err(Error::input(
                Location::file(at),
                format!(
                    "the profile names {} joint columns ({}), the robot has {n} joints{data}",
                    joint_names.len(),
                    joint_names.join(", ")
                ),
            ));
        }
        let joints: Vec<usize> = joint_names
            .iter()
            .map(|c| t.require(c))
            .collect::<Result<_>>()?;
        let position = group(t, &cols.position, "position")?;
        let (angles, quaternion) = match profile.orientation {
            Orientation::Quaternion => (None, quaternion_group(t, &cols.quaternion)?),
            _ => (group(t, &cols.angles, "orientation")?, None),
        };
        // A profile that says how the orientation is written (its form, or its columns'
        // names) expects one: without its columns the rows would be read as positions only.
        let defaults = Profile::default().columns;
        let expects_orientation =
            profile.orientation != Orientation::Euler || cols.angles != defaults.angles;
        if expects_orientation && angles.is_none() && quaternion.is_none() {
            let names = match profile.orientation {
                Orientation::Quaternion => cols.quaternion.join(", "),
                _ => cols.angles.join(", "),
            };
            return Err(Error::input(
                Location::file(&t.path),
                format!(
                    "the profile reads the orientation from columns {names}, which the file \
                     does not have (for positions only, leave `orientation` and the orientation \
                     columns out of the profile)"
                ),
            ));
        }
        let sigma_position = group(t, &cols.sigma_position, "position sigma")?;
        let sigma_angles = group(t, &cols.sigma_angles, "orientation sigma")?;
        let distance = t.column(&cols.distance);
        if position.is_none() && angles.is_none() && quaternion.is_none() && distance.is_none() {
            return Err(Error::input(
                Location::file(&t.path),
                format!(
                    "no measurement columns: expected position ({}), orientation ({}) or distance ({}){}",
                    cols.position.join(", "),
                    match profile.orientation {
                        Orientation::Quaternion => cols.quaternion.join(", "),
                        _ => cols.angles.join(", "),
                    },
                    cols.distance,
                    (cols.position.iter())
                        .chain(match profile.orientation {
                            Orientation::Quaternion => &cols.quaternion[..],
                            _ => &cols.angles[..],
                        })
                        .chain(std::iter::once(&cols.distance))
                        .map(|n| t.case_hint(n))
                        .collect::<String>()
                ),
            ));
        }
        let (id, set, pair) = (
            t.column(&cols.id),
            t.column(&cols.set),
            t.column(&cols.pair),
        );
        // An optional group the header holds in other letter case would be left out without a
        // word, and change what is measured (positions read as absent: an identification from
        // orientations alone; sigmas as absent: the defaults). Only groups that would be read
        // are checked: the profile's form of orientation, the sigmas of what is measured.
        let orientation = angles.is_some() || quaternion.is_some();
        let quaternions = profile.orientation == Orientation::Quaternion;
        let optional: [(&[String], bool, &str); 5] = [
            (&cols.position, position.is_none(), "position"),
            (&cols.angles, !orientation && !quaternions, "orientation"),
            (&cols.quaternion, !orientation && quaternions, "orientation"),
            (
                &cols.sigma_position,
                position.is_some() && sigma_position.is_none(),
                "position sigma",
            ),
            (
                &cols.sigma_angles,
                orientation && sigma_angles.is_none(),
                "orientation sigma",
            ),
        ];
        for (names, absent, what) in optional {
            let other = other_case(t, names);
            if absent && !other.is_empty() {
                return Err(Error::input(
                    Location::at(&t.path, 1, names.join(", ")),
                    format!(
                        "no {what} column(s) {}, but the header has {}: column names are \
                         case-sensitive, and the {what} would be read as absent; rename the \
                         column(s), or name them in a profile",
                        names.join(", "),
                        other.join(", ")
                    ),
                ));
            }
        }
        // A column the profile names for a label or a distance (not the default name) is one
        // the user expects read: a typo would silently leave it out (pairs chained in file
        // order, distances computed from positions).
        for (name, default, found, what) in [
            (&cols.distance, &defaults.distance, distance, "distance"),
            (&cols.id, &defaults.id, id, "id"),
            (&cols.set, &defaults.set, set, "set"),
            (&cols.pair, &defaults.pair, pair, "pair"),
        ] {
            if found.is_none() && name != default {
                let at = profile.path.as_deref().unwrap_or(&t.path);
                return Err(Error::input(
                    Location::file(at),
                    format!(
                        "the profile reads the {what} from column `{name}`, which {} does not \
                         have{} (its columns: {})",
                        t.path.display(),
                        t.case_hint(name),
                        t.header_list()
                    ),
                ));
            }
        }
        // Every column the measurements are read from, with the field that reads it: one
        // column read as two fields (a profile's `x = "q1"` beside the default joints) would
        // give both its numbers.
        let mut fields: Vec<(usize, &str)> = joints.iter().map(|&c| (c, "joints")).collect();
        for (g, name) in [
            (position, "position"),
            (angles, "orientation"),
            (sigma_position, "position sigma"),
            (sigma_angles, "orientation sigma"),
        ] {
            fields.extend(g.into_iter().flatten().map(|c| (c, name)));
        }
        fields.extend(quaternion.into_iter().flatten().map(|c| (c, "orientation")));
        for (c, name) in [
            (distance, "distance"),
            (id, "id"),
            (set, "set"),
            (pair, "pair"),
        ] {
            fields.extend(c.map(|c| (c, name)));
        }
        for (k, &(c, name)) in fields.iter().enumerate() {
            if let Some(&(_, first)) = fields[..k].iter().find(|(d, _)| *d == c) {
                let at = profile.path.as_deref().unwrap_or(&t.path);
                return Err(Error::input(
                    Location::file(at),
                    format!(
                        "column `{}` of {} would be read as {first} and as {name}: give each \
                         field its own column in the profile",
                        t.headers[c],
                        t.path.display()
                    ),
                ));
            }
        }
        let used: Vec<usize> = fields.iter().map(|&(c, _)| c).collect();
        let extra = (0..t.headers.len()).filter(|i| !used.contains(i)).collect();
        Ok(Columns {
            joints,
            position,
            angles,
            quaternion,
            sigma_position,
            sigma_angles,
            distance,
            id,
            set,
            pair,
            extra,
        })
    }
}

/// Row `r`'s cell at `col` beyond `max` (after unit conversion: mm, rad) as an error: a
/// finite 1e300 would otherwise reach the solvers (and read as a perfect fit).
fn bound(t: &Table, r: usize, col: usize, v: f64, max: f64, what: &str) -> Result<()> {
    if v.abs() > max {
        return Err(Error::input(
            t.location(r, col),
            format!("`{}` is beyond the bound of {what}", shown(&t.rows[r][col])),
        ));
    }
    Ok(())
}

/// Row `r` of `t` as a measurement (internal units), every value within its bounds.
fn parse_row(
    t: &Table,
    r: usize,
    c: &Columns,
    joints: &[JointInfo],
    profile: &Profile,
) -> Result<Measurement> {
    let (lu, au) = (profile.length_unit, profile.angle_unit);
    let raw = t.numbers(r, &c.joints)?;
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
    let mut m = Measurement::new(q);
    m.line = t.lines[r];
    if let Some(i) = c.position {
        m.position = Some(vec3(i, &|v| lu.to_mm(v))?);
    }
    // The angles (rad, about x, y, z), kept for their sigmas below.
    let mut angles = None;
    if let Some(i) = c.angles {
        let a = vec3(i, &|v| au.to_rad(v))?;
        angles = Some(a);
        for k in 0..3 {
            bound(
                t,
                r,
                i[k],
                a[k],
                crate::model::file::MAX_ANGLE_DEG.to_radians(),
                "an orientation angle (2 turns)",
            )?;
        }
        m.rotation = Some(if profile.orientation == Orientation::RotationVector {
            Rotation3::new(a)
        } else {
            // Columns are the angles about x, y, z; each convention takes them in its order.
            profile.euler.to_rotation(profile.euler.ordered(a))
        });
    }
    if let Some(i) = c.quaternion {
        let v = t.numbers(r, &i)?;
        let norm = v.iter().map(|x| x * x).sum::<f64>().sqrt();
        // Exports round each component; a norm off by more than their rounding is not a
        // rotation's.
        if !((1.0 - QUATERNION_NORM_TOLERANCE)..=(1.0 + QUATERNION_NORM_TOLERANCE)).contains(&norm)
        {
            return Err(Error::input(
                t.location(r, i[0]),
                format!(
                    "({}, {}, {}, {}) is not a unit quaternion (norm {norm:.6}, not within \
                     {QUATERNION_NORM_TOLERANCE:e} of 1)",
                    shown(&t.rows[r][i[0]]),
                    shown(&t.rows[r][i[1]]),
                    shown(&t.rows[r][i[2]]),
                    shown(&t.rows[r][i[3]]),
                ),
            ));
        }
        let q = UnitQuaternion::from_quaternion(Quaternion::new(v[0], v[1], v[2], v[3]));
        m.rotation = Some(q.to_rotation_matrix());
    }
    if let Some(i) = c.sigma_position {
        m.sigma_position = Some(vec3(i, &|v| lu.to_mm(v))?);
    }
    if let Some(i) = c.sigma_angles {
        m.sigma_rotation = Some(vec3(i, &|v| au.to_rad(v))?);
    }
    // The file's own values are checked, then an Euler angles' sigmas carried to the axes.
    check_bounds(t, r, c, &m, joints)?;
    if let (SigmaAngles::Angles, Some(a), Some(s)) =
        (profile.sigma_angles, angles, m.sigma_rotation)
    {
        m.sigma_rotation = Some(about_axes(profile.euler, a, s));
    }
    if let Some(i) = c.distance {
        m.distance = t.optional_number(r, i)?;
        if let Some(d) = m.distance {
            bound(t, r, i, lu.to_mm(d), MAX_LENGTH_MM, "a distance (100 m)")?;
        }
        // A zero distance between two tool positions is one point measured twice: fitted,
        // it shrinks the arm toward nothing.
        if m.distance.is_some_and(|d| d <= 0.0) {
            return Err(Error::input(
                t.location(r, i),
                "a distance must be positive",
            ));
        }
        m.distance = m.distance.map(|d| lu.to_mm(d));
    }
    let text = |i: Option<usize>| i.map(|i| t.rows[r][i].clone()).filter(|s| !s.is_empty());
    m.id = text(c.id);
    m.set = text(c.set);
    m.pair = text(c.pair);
    m.extra = c
        .extra
        .iter()
        .map(|&i| {
            let cell = &t.rows[r][i];
            // Numbers written with a decimal comma are carried as canonical numbers.
            if t.decimal_comma && cell.replace(',', ".").parse::<f64>().is_ok() {
                cell.replace(',', ".")
            } else {
                cell.clone()
            }
        })
        .collect();
    Ok(m)
}

/// The sigmas (rad) about the frame's x, y and z axes of Euler angles `angles` whose own
/// standard deviations are `sigmas` (rad; both in column order rx, ry, rz): first order
/// through the convention's angular Jacobian E, sqrt(diag(E diag(sigma^2) E^T))
/// ([`SigmaAngles::Angles`]), each at least a tenth of the smallest of `sigmas`: next to
/// the convention's gimbal lock E loses a direction, and an axis would get a sigma near zero
/// (a weight no instrument justifies) where the angles cannot tell a turn about it. Away
/// from it the floor does not bind (Series B: every axis at least 0.86 times the smallest).
fn about_axes(euler: EulerConvention, angles: Vector3<f64>, sigmas: Vector3<f64>) -> Vector3<f64> {
    // Each convention takes the columns in its own order, as the rotation does.
    let (e, s) = (
        euler.angular_jacobian(euler.ordered(angles)),
        euler.ordered(sigmas),
    );
    let floor = 0.1 * sigmas.min();
    Vector3::from_fn(|axis, _| {
        (0..3)
            .map(|k| (e[(axis, k)] * s[k]).powi(2))
            .sum::<f64>()
            .sqrt()
            .max(floor)
    })
}

/// The bounds of a parsed row's values (mm, rad): standard deviations positive, joints
/// within 4 turns (100 m), positions within 100 m, standard deviations from 1 nm (1 nrad)
/// to 1 m (1 rad): a smaller one weighs its row by 1e18 and more, which no instrument
/// justifies.
fn check_bounds(
    t: &Table,
    r: usize,
    c: &Columns,
    m: &Measurement,
    joints: &[JointInfo],
) -> Result<()> {
    for (idx, v) in [c.sigma_position, c.sigma_angles]
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
    let max_joint = crate::model::file::MAX_JOINT_DEG.to_radians();
    for ((&col, &v), j) in c.joints.iter().zip(&m.q).zip(joints) {
        match j.joint_type {
            JointType::Revolute => bound(t, r, col, v, max_joint, "a joint angle (4 turns)")?,
            JointType::Prismatic => bound(t, r, col, v, MAX_LENGTH_MM, "a joint length (100 m)")?,
        }
    }
    if let (Some(i), Some(p)) = (c.position, m.position) {
        for k in 0..3 {
            bound(t, r, i[k], p[k], MAX_LENGTH_MM, "a position (100 m)")?;
        }
    }
    for (idx, v, min, max, what) in [
        (
            c.sigma_position,
            m.sigma_position,
            1e-6,
            1e3,
            "a position standard deviation (1 nm to 1 m)",
        ),
        (
            c.sigma_angles,
            m.sigma_rotation,
            1e-9,
            1.0,
            "an orientation standard deviation (1 nrad to 1 rad)",
        ),
    ] {
        if let (Some(i), Some(v)) = (idx, v) {
            for k in 0..3 {
                bound(t, r, i[k], v[k], max, what)?;
                if v[k] < min {
                    return Err(Error::input(
                        t.location(r, i[k]),
                        format!("`{}` is below the bound of {what}", shown(&t.rows[r][i[k]])),
                    ));
                }
            }
        }
    }
    Ok(())
}

/// Warnings (errors with `strict`) about the rows as a whole: joints outside the limits, and
/// joint values that look like the other angle unit.
fn check_joints(
    t: &Table,
    rows: &[Measurement],
    joints: &[JointInfo],
    profile: &Profile,
    opts: &ReadOptions,
    report: &mut ReadReport,
) -> Result<()> {
    let outside: Vec<usize> = rows
        .iter()
        .filter(|m| JointInfo::outside(joints, &m.q))
        .map(|m| m.line)
        .collect();
    if !outside.is_empty() {
        let first =
            (rows.iter()).find_map(|m| JointInfo::first_outside(joints, &m.q).map(|w| (m.line, w)));
        let msg = format!(
            "{} row(s) have joints outside the robot's limits (lines {}){}",
            outside.len(),
            list_lines(&outside),
            first.map_or(String::new(), |(line, w)| format!("; line {line}: {w}"))
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
    let revolute = || {
        (rows.iter())
            .flat_map(|m| m.q.iter().zip(joints))
            .filter(|(_, j)| j.joint_type == JointType::Revolute)
    };
    let max_joint = revolute()
        .map(|(&q, _)| in_file_unit(q))
        .fold(0.0, f64::max);
    // Radians of a joint that turns more than a turn each way (+-400 deg) reach beyond 6.3:
    // within its range in radians, the values still read as radians.
    let within_radians = revolute().all(|(&q, j)| in_file_unit(q) <= j.span().max(6.3));
    if profile.joint_unit == AngleUnit::Deg && rows.len() >= 3 && max_joint > 0.0 && within_radians
    {
        report.warnings.push(
            "every joint value is within +-6.3 (or its joint's range in radians, where that \
             is wider) although the file's joints are in degrees: are they radians? (set \
             joint_unit = \"rad\" in a profile)"
                .to_string(),
        );
    }
    // And the reverse: beyond 7 (or the joint's range in radians, where that is wider).
    let beyond_radians = revolute().any(|(&q, j)| in_file_unit(q) > j.span().max(7.0));
    if profile.joint_unit == AngleUnit::Rad && beyond_radians {
        report.warnings.push(format!(
            "joint values reach {max_joint:.1} although the file's joints are in radians: are they degrees?"
        ));
    }
    Ok(())
}

/// Turns a table into measurements; see [`read_measurements`].
pub fn parse_measurements(
    t: &Table,
    joints: &[JointInfo],
    profile: &Profile,
    opts: &ReadOptions,
) -> Result<(MeasurementSet, ReadReport)> {
    let c = Columns::resolve(t, joints.len(), profile)?;
    let cols = &profile.columns;
    // The Euler angles' sigmas are carried to the axes through the angles themselves.
    if let (SigmaAngles::Angles, Some(i), None) = (profile.sigma_angles, c.sigma_angles, c.angles) {
        return Err(Error::input(
            Location::at(&t.path, 1, t.headers[i[0]].as_str()),
            format!(
                "the profile's sigma_angles = \"angles\" reads these columns as the standard \
                 deviations of Euler angles, but the file has no angle columns ({})",
                cols.angles.join(", ")
            ),
        ));
    }
    let mut report = ReadReport::default();
    // A distance or pair column in other letter case is read as absent: it counts only
    // under the pair measures (which `--measure` chooses later), which refuse it.
    let other_case_pair_columns =
        [(&cols.pair, c.pair), (&cols.distance, c.distance)].map(|(name, found)| {
            let header = t.other_case(name).filter(|_| found.is_none());
            header.map(|h| (name.clone(), h.to_string()))
        });
    if c.sigma_position.is_none() && cols.sigma_position[0] != "sx" {
        report.warnings.push(format!(
            "no position sigma columns ({}) in this file: the set-level sigma applies",
            cols.sigma_position.join(", ")
        ));
    }
    let mut bad: Vec<(usize, String)> = t
        .malformed
        .iter()
        .map(|(line, msg)| (*line, format!("{}:{line}: {msg}", t.path.display())))
        .collect();
    let rows = if opts.skip_bad_rows {
        let mut rows = Vec::with_capacity(t.rows.len());
        for r in 0..t.rows.len() {
            match parse_row(t, r, &c, joints, profile) {
                Ok(m) => rows.push(m),
                Err(e) => bad.push((t.lines[r], e.to_string())),
            }
        }
        rows
    } else {
        // The first bad line stops the read: a cell that does not parse or a row of the
        // wrong length.
        t.parse_rows(|r| parse_row(t, r, &c, joints, profile))?
    };
    bad.sort_by_key(|(line, _)| *line);
    // A dropped row between two kept ones breaks consecutive pairing there.
    // `bad` is sorted by line: the first bad line after row k - 1 decides.
    let chain_breaks: Vec<usize> = (rows.windows(2).enumerate())
        .filter(|(_, w)| {
            let next = bad.partition_point(|(l, _)| *l < w[0].line);
            bad.get(next).is_some_and(|(l, _)| *l < w[1].line)
        })
        .map(|(k, _)| k + 1)
        .collect();
    // What the breaks cost is said where a measure pairs rows
    // ([`crate::data::pairs::broken_pairs_warning`]), not for every measure.
    report.skipped = bad;
    if rows.is_empty() && !report.skipped.is_empty() {
        let shown: Vec<&str> = (report.skipped.iter().take(3))
            .map(|(_, why)| why.as_str())
            .collect();
        return Err(Error::Invalid(format!(
            "{}: no measurement rows: all {} rows were skipped as bad ({}{})",
            t.path.display(),
            report.skipped.len(),
            shown.join("; "),
            if report.skipped.len() > 3 {
                "; ..."
            } else {
                ""
            }
        )));
    }
    if rows.is_empty() {
        return Err(Error::input(Location::file(&t.path), "no measurement rows"));
    }
    check_joints(t, &rows, joints, profile, opts, &mut report)?;
    // Orientation angles (or a rotation vector) in degrees that all stay within a turn's
    // radians: a UR controller's rotation vector, say, in rad.
    if let Some(i) = c.angles
        && profile.angle_unit == AngleUnit::Deg
    {
        let values = (0..t.rows.len())
            .filter_map(|r| t.numbers(r, &i).ok())
            .flatten();
        if crate::data::joints::orientations_look_like_radians(rows.len(), values) {
            report.warnings.push(format!(
                "every orientation value ({}) is within +-6.3 although the file's angles are in \
                 degrees: are they radians? (set angle_unit = \"rad\" in a profile)",
                cols.angles.join(", ")
            ));
        }
    }
    Ok((
        MeasurementSet {
            source: t.path.clone(),
            rows,
            extra_columns: c.extra.iter().map(|&i| t.headers[i].clone()).collect(),
            chain_breaks,
            other_case_pair_columns,
        },
        report,
    ))
}
