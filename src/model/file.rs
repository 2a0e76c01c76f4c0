//! Robot files: TOML, lengths in mm, angles in degrees.
//!
//! ```toml
//! name = "example"
//!
//! [base]                    # any convention; usually mdh or transform
//! convention = "transform"  # T = Trans(x, y, z) RotZ(rz) RotY(ry) RotX(rx)
//! x = 0.0
//! ...
//!
//! [[joint]]                 # one table per joint, in chain order
//! convention = "mdh"        # mdh | hayati | dh
//! type = "revolute"         # revolute (default) | prismatic
//! alpha = 0.0
//! a = 0.0
//! theta = 0.0               # constant offset added to the joint variable
//! d = 670.0
//! limits = [-150.0, 150.0]  # deg (mm for prismatic)
//!
//! [tool]
//! convention = "mdh"
//! ...
//!
//! [calibration]             # written by `robocal identify`, when its data left some unseen
//! unobserved = ["tool.rz", "tool.ry", "tool.rx"]
//! ```
//!
//! `unobserved` lists the parameters the calibration's measurements did not observe (no
//! effect on them: a position-only tracker does not see the tool's rotation); they keep the
//! values the calibration started from, and results that depend on them are flagged
//! (`kinematics::unobserved`, which reads it).
//!
//! A field the convention has but the file omits is 0 (the thesis's "-"); a field the
//! convention does not have is an error. Writing uses the shortest decimal form that reads
//! back to the same bits, so write -> read is lossless.

use super::compliance::Compliance;
use super::mass::{BodyMass, MassProperties};
use super::robot::{Joint, JointType, Robot};
use super::row::{Convention, Field, Row};
use crate::error::{Error, IN_MEMORY, Location, Result};
use crate::io::line_of;
use nalgebra::Vector3;
use serde::Deserialize;
use std::f64::consts::{FRAC_PI_2, PI};
use std::fmt::Write as _;
use std::path::Path;
use toml::Spanned;

pub use super::robot::{MAX_ANGLE_DEG, MAX_JOINT_DEG, MAX_LENGTH_MM};

/// A TOML number: integers are accepted where a float is meant (`d = 670`).
#[derive(Debug, Clone, Copy)]
struct Number(f64);

impl<'de> Deserialize<'de> for Number {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> std::result::Result<Self, D::Error> {
        struct V;
        impl serde::de::Visitor<'_> for V {
            type Value = Number;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("a number")
            }
            fn visit_f64<E>(self, v: f64) -> std::result::Result<Number, E> {
                Ok(Number(v))
            }
            fn visit_i64<E>(self, v: i64) -> std::result::Result<Number, E> {
                Ok(Number(v as f64))
            }
            fn visit_u64<E>(self, v: u64) -> std::result::Result<Number, E> {
                Ok(Number(v as f64))
            }
        }
        d.deserialize_any(V)
    }
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RobotFile {
    name: Option<String>,
    base: Option<Spanned<RowFile>>,
    #[serde(default)]
    joint: Vec<Spanned<RowFile>>,
    tool: Option<Spanned<RowFile>>,
    mass: Option<Spanned<MassFile>>,
    compliance: Option<Spanned<ComplianceFile>>,
    calibration: Option<Spanned<CalibrationFile>>,
}

/// The `[calibration]` table `robocal identify` writes: what its measurements did not
/// observe.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct CalibrationFile {
    #[serde(default)]
    unobserved: Vec<Spanned<String>>,
}

/// The `[compliance]` table ([`super::compliance`]).
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ComplianceFile {
    joints: Option<Spanned<Vec<Number>>>,
    moments: Option<Spanned<Vec<Vec<Vec<Number>>>>>,
}

/// The `[mass]` table ([`super::mass`]).
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct MassFile {
    gravity: Option<Spanned<Vec<Number>>>,
    link_kg: Option<Spanned<Vec<Number>>>,
    link_com_mm: Option<Spanned<Vec<Vec<Number>>>>,
    #[serde(default)]
    payload_kg: Option<Spanned<Number>>,
    payload_com_mm: Option<Spanned<Vec<Number>>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RowFile {
    convention: Spanned<String>,
    #[serde(rename = "type")]
    joint_type: Option<Spanned<String>>,
    limits: Option<Spanned<Vec<Number>>>,
    // Every field of every convention; which ones a row may have is checked after parsing.
    // (Listed one by one: spans do not survive `#[serde(flatten)]`.)
    a: Option<Spanned<Number>>,
    alpha: Option<Spanned<Number>>,
    d: Option<Spanned<Number>>,
    theta: Option<Spanned<Number>>,
    beta: Option<Spanned<Number>>,
    x: Option<Spanned<Number>>,
    y: Option<Spanned<Number>>,
    z: Option<Spanned<Number>>,
    rz: Option<Spanned<Number>>,
    ry: Option<Spanned<Number>>,
    rx: Option<Spanned<Number>>,
}

impl RowFile {
    /// The numeric fields present in the file, with their spans.
    fn values(&self) -> Vec<(Field, &Spanned<Number>)> {
        let all = [
            (Field::A, &self.a),
            (Field::Alpha, &self.alpha),
            (Field::D, &self.d),
            (Field::Theta, &self.theta),
            (Field::Beta, &self.beta),
            (Field::X, &self.x),
            (Field::Y, &self.y),
            (Field::Z, &self.z),
            (Field::Rz, &self.rz),
            (Field::Ry, &self.ry),
            (Field::Rx, &self.rx),
        ];
        all.into_iter()
            .filter_map(|(f, v)| v.as_ref().map(|v| (f, v)))
            .collect()
    }
}

/// A number as a message shows it: 1e308 in exponent form, not as 309 digits.
fn short(v: f64) -> String {
    if v.abs() >= 1e6 {
        format!("{v:e}")
    } else {
        v.to_string()
    }
}

/// How near (deg) an angle of a robot file must be to pi/2 or pi to be taken as radians:
/// 1.57 and 3.14 are (0.0008 and 0.0016 off).
const RADIAN_TOLERANCE: f64 = 2e-3;

/// Reads a robot file.
pub fn read_robot(path: impl AsRef<Path>) -> Result<Robot> {
    let path = path.as_ref();
    parse_robot(&crate::io::read_text(path)?, path)
}

impl Robot {
    /// Parses robot-file text given in code (TOML; mm, deg); errors name [`IN_MEMORY`].
    pub fn from_toml(text: &str) -> Result<Robot> {
        parse_robot(text, Path::new(IN_MEMORY))
    }
}

/// Parses robot-file text; `path` is used in error messages.
pub fn parse_robot(text: &str, path: &Path) -> Result<Robot> {
    let file: RobotFile = crate::io::parse_toml(text, path)?;
    let rows = RowReader { text, path };
    let fixed = |r: &Option<Spanned<RowFile>>, what: &str| -> Result<Row> {
        match r {
            None => Ok(Row::zero(Convention::Transform)),
            Some(r) => rows.row(r.get_ref(), what, false).map(|(row, _, _)| row),
        }
    };
    let base = fixed(&file.base, "base")?;
    let tool = fixed(&file.tool, "tool")?;
    if file.joint.is_empty() {
        return Err(Error::input(
            Location::file(path),
            "no joints: add one [[joint]] table per joint",
        ));
    }
    let mut joints = Vec::with_capacity(file.joint.len());
    for (i, j) in file.joint.iter().enumerate() {
        let (row, joint_type, limits) = rows.row(j.get_ref(), &format!("joint {}", i + 1), true)?;
        joints.push(Joint {
            row,
            joint_type,
            limits,
        });
    }
    // A quarter or half turn written in radians (1.5708 deg): no robot's geometry holds such
    // angles in degrees, and read as them it is a robot of another shape. Two are needed (a
    // calibrated angle may land on one).
    let radian_turn = |v: f64| {
        [FRAC_PI_2, PI]
            .iter()
            .any(|t| (v.abs() - t).abs() < RADIAN_TOLERANCE)
    };
    let named = (file.base.iter().map(|r| ("base".to_string(), r)))
        .chain(file.tool.iter().map(|r| ("tool".to_string(), r)))
        .chain((file.joint.iter().enumerate()).map(|(i, j)| (format!("joint {}", i + 1), j)));
    let mut turns: Vec<(Location, String)> = named
        .flat_map(|(what, r)| {
            (r.get_ref().values().into_iter())
                .filter(|(f, v)| f.is_angle() && radian_turn(v.get_ref().0))
                .map(|(f, v)| {
                    (
                        rows.at(v.span(), f.name()),
                        format!("{what}: {} = {} deg", f.name(), short(v.get_ref().0)),
                    )
                })
                .collect::<Vec<_>>()
        })
        .collect();
    turns.sort_by_key(|(at, _)| at.line);
    if let [(at, first), (_, second), ..] = &turns[..] {
        return Err(Error::input(
            at.clone(),
            format!(
                "{first} and {second}{} are quarter or half turns in radians: robot files give \
                 angles in degrees (90, 180)",
                if turns.len() > 2 {
                    format!(" ({} angles in all)", turns.len())
                } else {
                    String::new()
                }
            ),
        ));
    }
    let name = file.name.unwrap_or_else(|| {
        path.file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default()
    });
    let robot = Robot::new(name, base, joints, tool)
        .map_err(|e| Error::input(Location::file(path), e.to_string()))?;
    let robot = match &file.mass {
        None => robot,
        Some(m) => {
            let masses = rows.masses(m.get_ref(), m.span(), robot.dof())?;
            robot
                .with_masses(Some(masses))
                .map_err(|e| Error::input(rows.at(m.span(), "mass"), e.to_string()))?
        }
    };
    let robot = match &file.compliance {
        None => robot,
        Some(c) => {
            let cf = c.get_ref();
            let n = robot.dof();
            let mut comp = Compliance::default();
            if let Some(j) = &cf.joints {
                comp.joints = j.get_ref().iter().map(|v| v.0).collect();
            }
            if let Some(m) = &cf.moments {
                let shape = m.get_ref().len() == n
                    && m.get_ref()
                        .iter()
                        .all(|bodies| bodies.len() == n + 1 && bodies.iter().all(|k| k.len() == 4));
                if !shape {
                    return Err(Error::input(
                        rows.at(m.span(), "moments"),
                        format!(
                            "[compliance]: moments need {n} lists (one per joint) of {} bodies \
                             (links 1..{n}, then the payload) of 4 values [k0, k1, k2, k3]",
                            n + 1
                        ),
                    ));
                }
                comp.moments = m
                    .get_ref()
                    .iter()
                    .flatten()
                    .flatten()
                    .map(|v| v.0)
                    .collect();
            }
            robot.with_compliance(Some(comp)).map_err(|e| {
                // The line of the list at fault (the table's header when masses are missing).
                let text = e.to_string();
                let at = match (&cf.joints, &cf.moments) {
                    (_, Some(m)) if text.contains("moment") => rows.at(m.span(), "moments"),
                    (Some(j), _) if robot.masses().is_some() => rows.at(j.span(), "joints"),
                    _ => rows.at(c.span(), "compliance"),
                };
                Error::input(at, format!("[compliance]: {e}"))
            })?
        }
    };
    match &file.calibration {
        None => Ok(robot),
        Some(c) => {
            let mut ids = Vec::new();
            for name in &c.get_ref().unobserved {
                let id = robot.find_param(name.get_ref()).ok_or_else(|| {
                    Error::input(
                        rows.at(name.span(), "unobserved"),
                        format!(
                            "[calibration]: unobserved names {:?}, which is not a parameter of \
                             this model (names as `identify` prints them: a3, base.x, tool.rz)",
                            name.get_ref()
                        ),
                    )
                })?;
                ids.push(id);
            }
            robot.with_unobserved(&ids).map_err(|e| {
                Error::input(
                    rows.at(c.span(), "unobserved"),
                    format!("[calibration]: {e}"),
                )
            })
        }
    }
}

/// Reads the rows of one robot file, naming the line and field of every error.
struct RowReader<'a> {
    text: &'a str,
    path: &'a Path,
}

impl RowReader<'_> {
    fn at(&self, span: std::ops::Range<usize>, field: &str) -> Location {
        Location::at(self.path, line_of(self.text, span.start), field)
    }

    /// The `[mass]` table for `n` joints: masses in [0, 1e5] kg, centres of mass of three
    /// coordinates within 100 m, gravity of three components within 100 m/s^2.
    fn masses(
        &self,
        m: &MassFile,
        table: std::ops::Range<usize>,
        n: usize,
    ) -> Result<MassProperties> {
        // Masses are optional (a table may give gravity alone, for mass-free compliance), but
        // not in part: a key left out would be taken as zero (links without weight, a centre
        // of mass at its frame's origin), and the gravity torques, and every compliance
        // identified from them, would be wrong by that much without a word. Only the payload
        // may be left out (none).
        let payload = m.payload_kg.as_ref().filter(|p| p.get_ref().0 != 0.0);
        let part = |key: &str, span: std::ops::Range<usize>, without: &str, why: &str| {
            Err(Error::input(
                self.at(span, key),
                format!(
                    "[mass]: {key} given without {without}: {why}; give both (zeros where they \
                     are meant), or gravity alone for the mass-free compliance coefficients"
                ),
            ))
        };
        match (&m.link_kg, &m.link_com_mm) {
            (Some(k), None) => {
                return part(
                    "link_kg",
                    k.span(),
                    "link_com_mm",
                    "every link's centre of mass would be taken at its joint's origin",
                );
            }
            (None, Some(c)) => {
                return part(
                    "link_com_mm",
                    c.span(),
                    "link_kg",
                    "the links would be taken as weightless",
                );
            }
            (None, None) if let Some(p) = payload => {
                return part(
                    "payload_kg",
                    p.span(),
                    "link_kg and link_com_mm",
                    "the links would be taken as weightless, the arm's own weight left out of every gravity torque",
                );
            }
            _ => {}
        }
        match (payload, &m.payload_com_mm) {
            (Some(p), None) => {
                return part(
                    "payload_kg",
                    p.span(),
                    "payload_com_mm",
                    "the payload's centre of mass would be taken at the tool's origin (give [0, 0, 0] where it is)",
                );
            }
            (None, Some(c)) if m.payload_kg.is_none() => {
                return part(
                    "payload_com_mm",
                    c.span(),
                    "payload_kg",
                    "a centre of mass without a mass is no payload",
                );
            }
            _ => {}
        }
        let kg_span = m.link_kg.as_ref().map_or(table.clone(), |k| k.span());
        let com_span = m.link_com_mm.as_ref().map_or(table.clone(), |c| c.span());
        let zero = Number(0.0);
        let kg: Vec<Number> = match &m.link_kg {
            Some(k) => k.get_ref().clone(),
            None => vec![zero; n],
        };
        let com: Vec<Vec<Number>> = match &m.link_com_mm {
            Some(c) => c.get_ref().clone(),
            None => vec![vec![zero; 3]; n],
        };
        let three = |v: &[Number], span: std::ops::Range<usize>, key: &str| match v {
            [x, y, z] => Ok(Vector3::new(x.0, y.0, z.0)),
            _ => Err(Error::input(
                self.at(span, key),
                format!("[mass]: {key} needs 3 values, got {}", v.len()),
            )),
        };
        if kg.len() != n || com.len() != n {
            return Err(Error::input(
                self.at(kg_span.clone(), "link_kg"),
                format!(
                    "[mass]: {} link masses and {} centres of mass for a robot with {n} joints",
                    kg.len(),
                    com.len()
                ),
            ));
        }
        let links = kg
            .iter()
            .zip(com)
            .map(|(k, c)| {
                Ok(BodyMass {
                    mass_kg: k.0,
                    com_mm: three(&c, com_span.clone(), "link_com_mm")?,
                })
            })
            .collect::<Result<Vec<_>>>()?;
        let payload = BodyMass {
            mass_kg: m.payload_kg.as_ref().map_or(0.0, |p| p.get_ref().0),
            com_mm: match &m.payload_com_mm {
                Some(c) => three(c.get_ref(), c.span(), "payload_com_mm")?,
                None => Vector3::zeros(),
            },
        };
        let gravity = match &m.gravity {
            Some(g) => three(g.get_ref(), g.span(), "gravity")?,
            None => Vector3::new(0.0, 0.0, -9.81),
        };
        let props = MassProperties {
            links,
            payload,
            gravity,
        };
        match props.fault(n) {
            Some(f) => {
                // The line of the value at fault.
                let payload_com = (f.starts_with("payload") && f.contains("centre of mass"))
                    .then_some(m.payload_com_mm.as_ref())
                    .flatten();
                let at = if let (true, Some(g)) = (f.starts_with("gravity"), &m.gravity) {
                    self.at(g.span(), "gravity")
                } else if let Some(c) = payload_com {
                    self.at(c.span(), "payload_com_mm")
                } else if let (true, Some(p)) = (f.starts_with("payload"), &m.payload_kg) {
                    self.at(p.span(), "payload_kg")
                } else if f.contains("centre of mass") {
                    self.at(com_span, "link_com_mm")
                } else {
                    self.at(kg_span, "link_kg")
                };
                Err(Error::input(at, format!("[mass]: {f}")))
            }
            None => Ok(props),
        }
    }

    /// A base, tool (`is_joint` false) or joint row: its values (file units: mm, deg), its
    /// joint type and its limits.
    fn row(&self, rf: &RowFile, what: &str, is_joint: bool) -> Result<(Row, JointType, [f64; 2])> {
        let conv_name = rf.convention.get_ref();
        let conv = Convention::from_name(conv_name).ok_or_else(|| {
            Error::input(
                self.at(rf.convention.span(), "convention"),
                format!("{what}: unknown convention `{conv_name}` (expected mdh, hayati, dh or transform)"),
            )
        })?;
        let row = self.values(rf, what, conv)?;
        let joint_type = self.joint_type(rf, what, is_joint)?;
        let limits = self.limits(rf, what, is_joint, joint_type)?;
        if is_joint {
            match (conv, joint_type) {
                (Convention::Transform, _) => {
                    return Err(Error::input(
                        self.at(rf.convention.span(), "convention"),
                        format!(
                            "{what}: a joint cannot be a 6-DOF transform; use mdh, hayati or dh"
                        ),
                    ));
                }
                (Convention::Hayati, JointType::Prismatic) => {
                    return Err(Error::input(
                        self.at(rf.convention.span(), "type"),
                        format!("{what}: a Hayati row has no d, so it cannot be prismatic"),
                    ));
                }
                _ => {}
            }
        }
        Ok((row, joint_type, limits))
    }

    /// The row's fields: each one of its convention's, finite and within 100 m (2 turns).
    fn values(&self, rf: &RowFile, what: &str, conv: Convention) -> Result<Row> {
        let mut row = Row::zero(conv);
        for (field, value) in rf.values() {
            let key = field.name();
            if !conv.fields().contains(&field) {
                let allowed: Vec<_> = conv.fields().iter().map(|f| f.name()).collect();
                return Err(Error::input(
                    self.at(value.span(), key),
                    format!(
                        "{what}: a {} row has no field `{key}` (its fields: {})",
                        conv.name(),
                        allowed.join(", ")
                    ),
                ));
            }
            let v = value.get_ref().0;
            if !v.is_finite() {
                return Err(Error::input(
                    self.at(value.span(), key),
                    format!("{what}: {key} must be finite"),
                ));
            }
            let bound = if field.is_angle() {
                MAX_ANGLE_DEG
            } else {
                MAX_LENGTH_MM
            };
            if v.abs() > bound {
                return Err(Error::input(
                    self.at(value.span(), key),
                    format!(
                        "{what}: {key} = {} {} is beyond the physical bound of {bound} {}",
                        short(v),
                        field.file_unit(),
                        field.file_unit()
                    ),
                ));
            }
            row.set_file_value(field, v);
        }
        Ok(row)
    }

    /// The joint type (revolute unless said); only joints have one.
    fn joint_type(&self, rf: &RowFile, what: &str, is_joint: bool) -> Result<JointType> {
        Ok(match &rf.joint_type {
            None => JointType::Revolute,
            Some(t) if !is_joint => {
                return Err(Error::input(
                    self.at(t.span(), "type"),
                    format!("{what}: only joints have a type"),
                ));
            }
            Some(t) => match t.get_ref().as_str() {
                "revolute" => JointType::Revolute,
                "prismatic" => JointType::Prismatic,
                other => {
                    return Err(Error::input(
                        self.at(t.span(), "type"),
                        format!(
                            "{what}: unknown joint type `{other}` (expected revolute or prismatic)"
                        ),
                    ));
                }
            },
        })
    }

    /// The joint limits (deg or mm): required for a joint, finite, ordered, within 4 turns
    /// (100 m); only joints have them.
    fn limits(
        &self,
        rf: &RowFile,
        what: &str,
        is_joint: bool,
        joint_type: JointType,
    ) -> Result<[f64; 2]> {
        let limits = match &rf.limits {
            None if is_joint => {
                return Err(Error::input(
                    Location::at(
                        self.path,
                        line_of(self.text, rf.convention.span().start),
                        "limits",
                    ),
                    format!(
                        "{what}: missing `limits = [min, max]` ({})",
                        joint_type.file_unit()
                    ),
                ));
            }
            None => [0.0, 0.0],
            Some(l) if !is_joint => {
                return Err(Error::input(
                    self.at(l.span(), "limits"),
                    format!("{what}: only joints have limits"),
                ));
            }
            Some(l) => match l.get_ref().as_slice() {
                [lo, hi] if lo.0.is_finite() && hi.0.is_finite() && lo.0 <= hi.0 => [lo.0, hi.0],
                _ => {
                    return Err(Error::input(
                        self.at(l.span(), "limits"),
                        format!("{what}: limits must be [min, max] with finite min <= max"),
                    ));
                }
            },
        };
        // Searches over the joint range (IK seeds, branch scans) take time in proportion to
        // its width: +-1e8 deg took minutes. No joint turns more than a few times.
        let bound = match joint_type {
            JointType::Revolute => MAX_JOINT_DEG,
            JointType::Prismatic => MAX_LENGTH_MM,
        };
        if limits.iter().any(|v| v.abs() > bound) {
            let at_limits = rf.limits.as_ref().map_or(
                Location::at(
                    self.path,
                    line_of(self.text, rf.convention.span().start),
                    "limits",
                ),
                |l| self.at(l.span(), "limits"),
            );
            return Err(Error::input(
                at_limits,
                format!(
                    "{what}: limits [{}, {}] beyond +-{bound} {}",
                    short(limits[0]),
                    short(limits[1]),
                    joint_type.file_unit()
                ),
            ));
        }
        Ok(limits)
    }
}

/// Shortest decimal that reads back to the same f64, always with a decimal point or exponent
/// so that TOML reads it as a float.
pub(crate) fn float_text(v: f64) -> String {
    let s = format!("{v:?}");
    if s.contains('.') || s.contains('e') || s.contains("inf") || s.contains("NaN") {
        s
    } else {
        format!("{s}.0")
    }
}

/// The robot file text of a model.
pub fn robot_to_toml(robot: &Robot) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "# robocal robot model. Lengths in mm, angles in degrees."
    );
    let _ = writeln!(
        s,
        "name = {}",
        toml::Value::String(robot.name().to_string())
    );
    let write_row = |s: &mut String, row: &Row| {
        // A frame rebased for a solve is written as the same frame in its file's angles.
        let row = &row.plain();
        let conv = row.convention();
        let _ = writeln!(s, "convention = \"{}\"  # {}", conv.name(), conv.formula());
        for &f in conv.fields() {
            let v = row.file_value(f).unwrap_or(0.0);
            let _ = writeln!(s, "{} = {}", f.name(), float_text(v));
        }
    };
    let _ = writeln!(s, "\n[base]");
    write_row(&mut s, robot.base());
    for (i, j) in robot.joints().iter().enumerate() {
        let _ = writeln!(s, "\n[[joint]]  # joint {}", i + 1);
        write_row(&mut s, &j.row);
        let _ = writeln!(s, "type = \"{}\"", j.joint_type.name());
        let _ = writeln!(
            s,
            "limits = [{}, {}]  # {}",
            float_text(j.limits[0]),
            float_text(j.limits[1]),
            j.joint_type.file_unit()
        );
    }
    let _ = writeln!(s, "\n[tool]");
    write_row(&mut s, robot.tool());
    if let Some(m) = robot.masses() {
        let v3 = |v: &Vector3<f64>| {
            format!(
                "[{}, {}, {}]",
                float_text(v.x),
                float_text(v.y),
                float_text(v.z)
            )
        };
        let list =
            |f: &dyn Fn(&BodyMass) -> String| m.links.iter().map(f).collect::<Vec<_>>().join(", ");
        let _ = writeln!(
            s,
            "\n[mass]  # kg; centres of mass in mm, each in its joint's frame"
        );
        let _ = writeln!(s, "gravity = {}  # m/s^2, base frame", v3(&m.gravity));
        let _ = writeln!(s, "link_kg = [{}]", list(&|b| float_text(b.mass_kg)));
        let _ = writeln!(s, "link_com_mm = [{}]", list(&|b| v3(&b.com_mm)));
        let _ = writeln!(s, "payload_kg = {}", float_text(m.payload.mass_kg));
        let _ = writeln!(
            s,
            "payload_com_mm = {}  # tool frame",
            v3(&m.payload.com_mm)
        );
    }
    if let Some(c) = robot.compliance() {
        let list = |v: &[f64]| {
            v.iter()
                .map(|&x| float_text(x))
                .collect::<Vec<_>>()
                .join(", ")
        };
        let _ = writeln!(s, "\n[compliance]");
        if !c.joints.is_empty() {
            let _ = writeln!(
                s,
                "joints = [{}]  # mrad per kN m (um per kN for a prismatic joint)",
                list(&c.joints)
            );
        }
        if !c.moments.is_empty() {
            let n = robot.dof();
            let _ = writeln!(
                s,
                "# per joint, per body (links 1..{n}, then the payload): [k0, k1, k2, k3], mrad per \
                 kN m times kg (k0) and kg m (k1-k3)\nmoments = ["
            );
            for joint in c.moments.chunks(4 * (n + 1)) {
                let bodies: Vec<String> =
                    joint.chunks(4).map(|k| format!("[{}]", list(k))).collect();
                let _ = writeln!(s, "  [{}],", bodies.join(", "));
            }
            let _ = writeln!(s, "]");
        }
    }
    if !robot.unobserved().is_empty() {
        let names: Vec<String> = (robot.unobserved().iter())
            .map(|p| toml::Value::String(p.name()).to_string())
            .collect();
        let _ = writeln!(
            s,
            "\n[calibration]\n# Parameters the calibration's measurements did not observe (no effect on \
             them): they keep\n# the values it started from, and what depends on them is \
             unchecked.\nunobserved = [{}]",
            names.join(", ")
        );
    }
    s
}

/// Writes a robot file atomically (temporary file, then rename).
pub fn write_robot(robot: &Robot, path: impl AsRef<Path>) -> Result<()> {
    crate::io::write_atomic(path.as_ref(), robot_to_toml(robot).as_bytes())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<Robot> {
        parse_robot(text, Path::new("r.toml"))
    }

    const ONE_JOINT: &str = "name = \"t\"\n[base]\nconvention = \"mdh\"\nd = 5\n\n[[joint]]\nconvention = \"mdh\"\nalpha = 90\na = 100\nlimits = [-90, 90]\n\n[tool]\nconvention = \"transform\"\nz = 10.5\n";

    /// A robot file in radians is refused where it shows: two angles at a quarter or half
    /// turn in radians (a reviewer's ABB in standard DH, alpha = -1.5707963). One such angle
    /// and near misses read.
    #[test]
    fn angles_and_limits_in_radians_are_refused() {
        let radians = ONE_JOINT
            .replace("alpha = 90", "alpha = -1.5707963")
            .replace("z = 10.5", "z = 10.5\nrx = 3.1416");
        let e = parse(&radians).unwrap_err().to_string();
        assert!(
            e.starts_with(
                "r.toml:8: field `alpha`: joint 1: alpha = -1.5707963 deg and tool: rx = \
                 3.1416 deg are quarter or half turns in radians"
            ),
            "{e}"
        );
        // One such angle reads (a calibration may land on it), and so do near misses.
        assert!(parse(&ONE_JOINT.replace("alpha = 90", "alpha = -1.5707963")).is_ok());
        assert!(parse(&radians.replace("3.1416", "3.15")).is_ok());
        // Two decimals are radians too; limits of a few degrees are a rig's, not radians.
        let short = ONE_JOINT
            .replace("alpha = 90", "alpha = 1.57")
            .replace("z = 10.5", "z = 10.5\nrz = -3.14");
        assert!(parse(&short).is_err());
        assert!(parse(&ONE_JOINT.replace("[-90, 90]", "[-3, 3]")).is_ok());
        let rig = ONE_JOINT.replace("[-90, 90]", "[-5, 5]").replace(
            "\n[tool]",
            "\n[[joint]]\nconvention = \"mdh\"\nalpha = 90\nlimits = [-5, 5]\n\n[tool]",
        );
        assert_eq!(parse(&rig).map(|r| r.dof()).ok(), Some(2));
    }

    #[test]
    fn integers_and_missing_fields_read_as_numbers_and_zero() {
        let r = parse(ONE_JOINT).unwrap();
        assert_eq!(r.dof(), 1);
        assert_eq!(r.base().file_value(Field::D), Some(5.0));
        assert_eq!(r.joints()[0].row.file_value(Field::Theta), Some(0.0));
        assert_eq!(r.joints()[0].limits, [-90.0, 90.0]);
        assert_eq!(r.tool().file_value(Field::Z), Some(10.5));
    }

    #[test]
    fn write_then_read_is_bit_exact() {
        let r = parse(ONE_JOINT).unwrap();
        let mut r2 = r
            .with_param(
                r.find_param("alpha1").unwrap(),
                0.1_f64.sqrt() * std::f64::consts::E,
            )
            .unwrap();
        r2 = r2
            .with_param(r2.find_param("tool.z").unwrap(), 1.0 / 3.0)
            .unwrap();
        let text = robot_to_toml(&r2);
        let back = parse(&text).unwrap();
        assert_eq!(back, r2);
        for id in r2.parameters() {
            assert_eq!(
                back.param(id).to_bits(),
                r2.param(id).to_bits(),
                "{}",
                id.name()
            );
        }
    }

    fn err_text(text: &str) -> String {
        parse(text).unwrap_err().to_string()
    }

    #[test]
    fn bad_files_name_line_and_field() {
        // A field the convention does not have, on line 9.
        let bad = ONE_JOINT.replace("a = 100", "a = 100\nbeta = 1");
        let e = err_text(&bad);
        assert!(e.contains("r.toml:10") && e.contains("beta"), "{e}");
        // A misspelt key is an unknown field.
        let e = err_text(&ONE_JOINT.replace("alpha = 90", "alpah = 90"));
        assert!(e.contains("r.toml:8") && e.contains("alpah"), "{e}");
        // A string where a number belongs.
        let e = err_text(&ONE_JOINT.replace("a = 100", "a = \"x\""));
        assert!(e.contains("r.toml:9"), "{e}");
        // Limits out of order.
        let e = err_text(&ONE_JOINT.replace("[-90, 90]", "[90, -90]"));
        assert!(e.contains("r.toml:10") && e.contains("limits"), "{e}");
        // Unknown convention.
        let e = err_text(
            &ONE_JOINT.replace("convention = \"mdh\"\nalpha", "convention = \"foo\"\nalpha"),
        );
        assert!(e.contains("r.toml:7") && e.contains("foo"), "{e}");
        // Missing limits.
        let e = err_text(&ONE_JOINT.replace("limits = [-90, 90]\n", ""));
        assert!(e.contains("limits"), "{e}");
        // TOML syntax error.
        let e = err_text(&ONE_JOINT.replace("d = 5", "d = = 5"));
        assert!(e.contains("r.toml:4"), "{e}");
        // No joints.
        let e = err_text("[base]\nconvention = \"mdh\"\n");
        assert!(e.contains("no joints"), "{e}");
    }

    #[test]
    fn unobserved_parameters_round_trip_and_bad_names_are_located() {
        let text = format!("{ONE_JOINT}\n[calibration]\nunobserved = [\"tool.rz\", \"a1\"]\n");
        let r = parse(&text).unwrap();
        let names: Vec<String> = r.unobserved().iter().map(|p| p.name()).collect();
        // In parameter order, whatever the file's.
        assert_eq!(names, ["a1", "tool.rz"]);
        let back = parse(&robot_to_toml(&r)).unwrap();
        assert_eq!(back, r);
        assert!(robot_to_toml(&r).contains("unobserved = [\"a1\", \"tool.rz\"]"));
        // An unmarked model writes no table.
        assert!(!robot_to_toml(&parse(ONE_JOINT).unwrap()).contains("[calibration]"));
        // A name the model does not have, on line 17.
        let e = err_text(&text.replace("\"a1\"", "\"a7\""));
        assert!(e.contains("r.toml:17") && e.contains("a7"), "{e}");
        let e = err_text(&text.replace("unobserved", "unobserve"));
        assert!(e.contains("unobserve"), "{e}");
        // A parameter changed in code keeps its marks.
        let id = r.find_param("a1").unwrap();
        assert_eq!(r.with_param(id, 3.0).unwrap().unobserved(), r.unobserved());
    }
}
