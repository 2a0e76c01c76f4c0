//! Import profiles: how a foreign CSV export maps onto robocal's measurement fields.
//!
//! ```toml
//! delimiter = ";"            # one character; default ","
//! decimal_comma = true       # "1,5" means 1.5; default false
//! joint_unit = "rad"         # deg | rad (prismatic joints: the length unit)
//! length_unit = "mm"         # mm | m (positions and their sigmas)
//! angle_unit = "deg"         # deg | rad (orientation angles and their sigmas)
//! orientation = "euler"      # euler (three angles, composed as `euler` says; default)
//!                            # | rotation_vector (rx, ry, rz: axis times angle, as a UR
//!                            #   controller reports; angle_unit) | quaternion (qw, qx, qy, qz)
//! euler = "xyz_intrinsic"    # zyx (R = Rz Ry Rx) | xyz_intrinsic (R = Rx Ry Rz)
//!                            # | xyz_extrinsic (R = Rz Ry Rx, roll-pitch-yaw about fixed axes)
//! sigma_angles = "angles"    # axes (srx, sry, srz: small rotations about x, y, z; default)
//!                            # | angles (standard deviations of the three Euler angles, as a
//!                            #   Leica T-Mac exports them; orientation = "euler" only)
//! [columns]
//! joints = ["j1", "j2", ...] # in chain order; default q1..qN
//! x = "X"                    # positions; default x, y, z
//! rx = "RX"                  # the angle about each axis; default rx, ry, rz
//! qw = "Q0"                  # quaternion (orientation = "quaternion"); default qw, qx, qy, qz
//! sx = "SX"                  # sigmas (optional): sx sy sz srx sry srz
//! id = "Timestamp"           # optional: id, set, pair, distance
//! ```
//!
//! The default profile is the canonical form: comma, decimal point, deg, mm, Z-Y-X.

use crate::error::{Error, Location, Result};
use crate::geometry::rotation::EulerConvention;
use serde::Deserialize;
use std::path::Path;

/// The unit of an angle column.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AngleUnit {
    /// Degrees.
    Deg,
    /// Radians.
    Rad,
}

impl AngleUnit {
    /// Converts to rad.
    pub fn to_rad(self, v: f64) -> f64 {
        match self {
            AngleUnit::Deg => v.to_radians(),
            AngleUnit::Rad => v,
        }
    }
}

/// The unit of a length column.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LengthUnit {
    /// Millimetres.
    Mm,
    /// Metres.
    M,
}

impl LengthUnit {
    /// Converts to mm.
    pub fn to_mm(self, v: f64) -> f64 {
        match self {
            LengthUnit::Mm => v,
            LengthUnit::M => v * 1000.0,
        }
    }
}

/// How a row's orientation is written.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Orientation {
    /// Three angles about x, y and z (angle unit), composed as the profile's `euler` says.
    Euler,
    /// The rotation vector (rx, ry, rz): the axis times the angle (angle unit), R = exp(\[r\]x),
    /// as a UR controller reports its tool pose.
    RotationVector,
    /// A unit quaternion (qw, qx, qy, qz), scalar first: within 1e-3 of unit norm, normalised.
    Quaternion,
}

/// What the orientation sigma columns (srx, sry, srz) hold.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SigmaAngles {
    /// Standard deviations (angle unit) of small rotations about the frame's x, y and z
    /// axes: the canonical form's, whatever the orientation's form.
    Axes,
    /// Standard deviations of the three Euler angles themselves (each with its angle's
    /// column: srx with rx), as a tracker that exports Euler angles gives them. They are
    /// carried to the axes to first order through the convention's angular Jacobian E
    /// ([`EulerConvention::angular_jacobian`]): the sigma about each axis is the square root
    /// of that axis's diagonal entry of E diag(sigma^2) E^T (the off-diagonal covariances,
    /// which the rows' weights have no place for, are left out).
    Angles,
}

/// Column names of each measurement field in the source file.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Columns {
    /// Joint columns in chain order; None means `q1..qN`.
    pub joints: Option<Vec<String>>,
    /// Position x, y and z (length unit); default `x, y, z`.
    pub position: [String; 3],
    /// Angle about x, y and z (whatever the convention's order of composition), or the
    /// rotation vector's x, y and z; default `rx, ry, rz`.
    pub angles: [String; 3],
    /// Quaternion w, x, y and z (orientation = "quaternion"); default `qw, qx, qy, qz`.
    pub quaternion: [String; 4],
    /// Standard deviations of x, y and z (length unit); default `sx, sy, sz`.
    pub sigma_position: [String; 3],
    /// Standard deviations of the angles about x, y and z (angle unit); default
    /// `srx, sry, srz`.
    pub sigma_angles: [String; 3],
    /// Row label column; default `id`.
    pub id: String,
    /// Group label column; default `set`.
    pub set: String,
    /// Pair label column; default `pair`.
    pub pair: String,
    /// Ball-bar distance column (length unit); default `distance`.
    pub distance: String,
}

/// An import profile; [`Profile::default`] is the canonical form.
#[derive(Debug, Clone, PartialEq)]
pub struct Profile {
    /// Field delimiter, one ASCII byte; default `,`.
    pub delimiter: u8,
    /// Numbers are written with a decimal comma ("1,5" is 1.5); needs another delimiter.
    pub decimal_comma: bool,
    /// Unit of revolute joint values (prismatic joints use `length_unit`).
    pub joint_unit: AngleUnit,
    /// Unit of positions, their sigmas, distances and prismatic joints.
    pub length_unit: LengthUnit,
    /// Unit of orientation angles and their sigmas.
    pub angle_unit: AngleUnit,
    /// How the orientation is written.
    pub orientation: Orientation,
    /// How the three orientation angles compose into a rotation (orientation = "euler").
    pub euler: EulerConvention,
    /// What the orientation sigma columns hold.
    pub sigma_angles: SigmaAngles,
    /// Column name of each field.
    pub columns: Columns,
    /// The file the profile was read from, which messages about it name; None for the
    /// canonical form.
    pub path: Option<std::path::PathBuf>,
}

impl Default for Profile {
    fn default() -> Self {
        let s = |v: [&str; 3]| v.map(String::from);
        Profile {
            delimiter: b',',
            decimal_comma: false,
            joint_unit: AngleUnit::Deg,
            length_unit: LengthUnit::Mm,
            angle_unit: AngleUnit::Deg,
            orientation: Orientation::Euler,
            euler: EulerConvention::Zyx,
            sigma_angles: SigmaAngles::Axes,
            columns: Columns {
                joints: None,
                position: s(["x", "y", "z"]),
                angles: s(["rx", "ry", "rz"]),
                quaternion: ["qw", "qx", "qy", "qz"].map(String::from),
                sigma_position: s(["sx", "sy", "sz"]),
                sigma_angles: s(["srx", "sry", "srz"]),
                id: "id".into(),
                set: "set".into(),
                pair: "pair".into(),
                distance: "distance".into(),
            },
            path: None,
        }
    }
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ProfileFile {
    delimiter: Option<String>,
    decimal_comma: Option<bool>,
    joint_unit: Option<String>,
    length_unit: Option<String>,
    angle_unit: Option<String>,
    orientation: Option<String>,
    euler: Option<String>,
    sigma_angles: Option<String>,
    #[serde(default)]
    columns: ColumnsFile,
}

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct ColumnsFile {
    joints: Option<Vec<String>>,
    x: Option<String>,
    y: Option<String>,
    z: Option<String>,
    rx: Option<String>,
    ry: Option<String>,
    rz: Option<String>,
    qw: Option<String>,
    qx: Option<String>,
    qy: Option<String>,
    qz: Option<String>,
    sx: Option<String>,
    sy: Option<String>,
    sz: Option<String>,
    srx: Option<String>,
    sry: Option<String>,
    srz: Option<String>,
    id: Option<String>,
    set: Option<String>,
    pair: Option<String>,
    distance: Option<String>,
}

impl Profile {
    /// Reads a profile file; errors name the file, line and field.
    pub fn read(path: impl AsRef<Path>) -> Result<Profile> {
        let path = path.as_ref();
        Profile::parse(&crate::io::read_text(path)?, path)
    }

    /// Parses profile text; `path` is used in messages.
    pub fn parse(text: &str, path: &Path) -> Result<Profile> {
        let f: ProfileFile = crate::io::parse_toml(text, path)?;
        // A field's line from the parser's spans: a top-level key, or one of `[columns]`
        // (under the header, dotted or inline; the two share no name).
        let key_lines = crate::io::key_lines(text);
        let bad = |field: &str, msg: String| {
            let line = (key_lines.iter())
                .find(|(k, _)| k == field || k.strip_prefix("columns.") == Some(field))
                .map(|(_, line)| *line);
            Error::input(
                Location {
                    file: path.to_path_buf(),
                    line,
                    field: Some(field.into()),
                },
                msg,
            )
        };
        // A keyword field: absent is the first choice; another word is an error listing them.
        fn pick<T: Copy>(
            v: &Option<String>,
            choices: &[(&str, T)],
            unknown: impl FnOnce(String) -> Error,
        ) -> Result<T> {
            let Some(word) = v.as_deref() else {
                return Ok(choices[0].1);
            };
            if let Some((_, t)) = choices.iter().find(|(w, _)| *w == word) {
                return Ok(*t);
            }
            let names: Vec<&str> = choices.iter().map(|(w, _)| *w).collect();
            let (last, rest) = names.split_last().expect("choices are given");
            Err(unknown(format!(
                "`{word}` (expected {} or {last})",
                rest.join(", ")
            )))
        }
        let angle = |v: &Option<String>, field: &str| {
            let units = [("deg", AngleUnit::Deg), ("rad", AngleUnit::Rad)];
            pick(v, &units, |w| bad(field, format!("unknown unit {w}")))
        };
        let mut p = Profile {
            path: Some(path.to_path_buf()),
            ..Profile::default()
        };
        if let Some(d) = &f.delimiter {
            let b = d.as_bytes();
            if b.len() != 1 {
                return Err(bad(
                    "delimiter",
                    format!("`{d}` is not one ASCII character"),
                ));
            }
            // A byte a number or a quoted cell holds would cut them apart (`1.5` at `.`,
            // `-2` at `-`), and a line break ends the row.
            let c = b[0] as char;
            if c.is_ascii_alphanumeric() || "\"'.+-\r\n".contains(c) {
                return Err(bad(
                    "delimiter",
                    format!(
                        "`{}` cannot separate fields: numbers, quotes or line breaks hold it \
                         (use `,`, `;`, a tab `\\t` or `|`)",
                        d.escape_default()
                    ),
                ));
            }
            p.delimiter = b[0];
        }
        p.decimal_comma = f.decimal_comma.unwrap_or(false);
        if p.decimal_comma && p.delimiter == b',' {
            return Err(bad(
                "decimal_comma",
                "a decimal comma needs another delimiter (e.g. \";\")".into(),
            ));
        }
        p.joint_unit = angle(&f.joint_unit, "joint_unit")?;
        p.angle_unit = angle(&f.angle_unit, "angle_unit")?;
        p.length_unit = pick(
            &f.length_unit,
            &[("mm", LengthUnit::Mm), ("m", LengthUnit::M)],
            |w| bad("length_unit", format!("unknown unit {w}")),
        )?;
        p.orientation = pick(
            &f.orientation,
            &[
                ("euler", Orientation::Euler),
                ("rotation_vector", Orientation::RotationVector),
                ("quaternion", Orientation::Quaternion),
            ],
            |w| bad("orientation", format!("unknown orientation {w}")),
        )?;
        if p.orientation != Orientation::Euler && f.euler.is_some() {
            return Err(bad(
                "euler",
                "`euler` composes three angles: it does not apply to a rotation vector or a \
                 quaternion (orientation)"
                    .into(),
            ));
        }
        p.euler = pick(
            &f.euler,
            &[
                ("zyx", EulerConvention::Zyx),
                ("xyz_intrinsic", EulerConvention::XyzIntrinsic),
                ("xyz_extrinsic", EulerConvention::XyzExtrinsic),
            ],
            |w| bad("euler", format!("unknown convention {w}")),
        )?;
        p.sigma_angles = pick(
            &f.sigma_angles,
            &[("axes", SigmaAngles::Axes), ("angles", SigmaAngles::Angles)],
            |w| bad("sigma_angles", format!("unknown meaning {w}")),
        )?;
        if p.orientation != Orientation::Euler && p.sigma_angles == SigmaAngles::Angles {
            return Err(bad(
                "sigma_angles",
                "\"angles\" are the standard deviations of three Euler angles: a rotation \
                 vector's or a quaternion's sigmas are small rotations about the axes \
                 (\"axes\")"
                    .into(),
            ));
        }
        let c = f.columns;
        let set = |slot: &mut String, v: Option<String>| {
            if let Some(v) = v {
                *slot = v;
            }
        };
        if p.orientation != Orientation::Quaternion {
            let named = [("qw", &c.qw), ("qx", &c.qx), ("qy", &c.qy), ("qz", &c.qz)];
            if let Some((field, _)) = named.iter().find(|(_, v)| v.is_some()) {
                return Err(bad(
                    field,
                    "a quaternion column, but the profile's orientation is not \
                     \"quaternion\" (set orientation = \"quaternion\")"
                        .into(),
                ));
            }
        }
        if c.joints.as_ref().is_some_and(Vec::is_empty) {
            return Err(bad(
                "joints",
                "the profile names no joint columns: name them in chain order, or leave \
                 `joints` out for q1..qN"
                    .into(),
            ));
        }
        let cols = &mut p.columns;
        cols.joints = c.joints;
        for (slot, v) in cols.position.iter_mut().zip([c.x, c.y, c.z]) {
            set(slot, v);
        }
        for (slot, v) in cols.angles.iter_mut().zip([c.rx, c.ry, c.rz]) {
            set(slot, v);
        }
        for (slot, v) in (cols.quaternion.iter_mut()).zip([c.qw, c.qx, c.qy, c.qz]) {
            set(slot, v);
        }
        for (slot, v) in cols.sigma_position.iter_mut().zip([c.sx, c.sy, c.sz]) {
            set(slot, v);
        }
        for (slot, v) in cols.sigma_angles.iter_mut().zip([c.srx, c.sry, c.srz]) {
            set(slot, v);
        }
        set(&mut cols.id, c.id);
        set(&mut cols.set, c.set);
        set(&mut cols.pair, c.pair);
        set(&mut cols.distance, c.distance);
        // Two fields read from one column would silently read the same numbers twice.
        let mut fields: Vec<(String, &String)> = Vec::new();
        if let Some(j) = &cols.joints {
            fields.extend(j.iter().map(|c| ("joints".to_string(), c)));
        }
        // The orientation's columns: the quaternion's, or the three angles' (the other
        // form's names are not read, so they may name anything).
        let orientation: Vec<(&str, &String)> = if p.orientation == Orientation::Quaternion {
            ["qw", "qx", "qy", "qz"]
                .into_iter()
                .zip(&cols.quaternion)
                .collect()
        } else {
            ["rx", "ry", "rz"].into_iter().zip(&cols.angles).collect()
        };
        let named = [
            ("x", &cols.position[0]),
            ("y", &cols.position[1]),
            ("z", &cols.position[2]),
            ("sx", &cols.sigma_position[0]),
            ("sy", &cols.sigma_position[1]),
            ("sz", &cols.sigma_position[2]),
            ("srx", &cols.sigma_angles[0]),
            ("sry", &cols.sigma_angles[1]),
            ("srz", &cols.sigma_angles[2]),
            ("id", &cols.id),
            ("set", &cols.set),
            ("pair", &cols.pair),
            ("distance", &cols.distance),
        ];
        fields.extend((orientation.iter().chain(&named)).map(|(f, c)| (f.to_string(), *c)));
        for (i, (field, column)) in fields.iter().enumerate() {
            if let Some((first, _)) = fields[..i].iter().find(|(_, c)| c == column) {
                return Err(bad(
                    field,
                    format!(
                        "column `{column}` is already read as `{first}`: give each field its own \
                         column"
                    ),
                ));
            }
        }
        Ok(p)
    }

    /// Reads `path` if given, else the canonical profile.
    pub fn read_or_default(path: Option<&Path>) -> Result<Profile> {
        path.map_or_else(|| Ok(Profile::default()), Profile::read)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn two_fields_from_one_column_are_refused() {
        for (text, field) in [
            ("[columns]\nx = \"A\"\ny = \"A\"\n", "y"),
            ("[columns]\nid = \"z\"\n", "id"),
            ("[columns]\njoints = [\"a\", \"a\"]\n", "joints"),
        ] {
            let e = Profile::parse(text, Path::new("p.toml"))
                .unwrap_err()
                .to_string();
            assert!(
                e.contains(&format!("field `{field}`")) && e.contains("already read"),
                "{e}"
            );
        }
        // Distinct columns pass.
        Profile::parse("[columns]\nx = \"A\"\ny = \"B\"\n", Path::new("p.toml")).unwrap();
    }

    #[test]
    fn profile_fields_and_errors() {
        let p = Profile::parse(
            "delimiter = \";\"\ndecimal_comma = true\njoint_unit = \"rad\"\nlength_unit = \"m\"\neuler = \"xyz_intrinsic\"\n[columns]\nx = \"X\"\nid = \"T\"\n",
            Path::new("p.toml"),
        )
        .unwrap();
        assert_eq!(p.delimiter, b';');
        assert!(p.decimal_comma);
        assert_eq!(p.joint_unit, AngleUnit::Rad);
        assert_eq!(p.length_unit.to_mm(1.5), 1500.0);
        assert_eq!(p.euler, EulerConvention::XyzIntrinsic);
        assert_eq!(p.columns.position[0], "X");
        assert_eq!(p.columns.position[1], "y");
        assert_eq!(p.columns.id, "T");
        let e = Profile::parse("joint_unit = \"grad\"\n", Path::new("p.toml"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("p.toml:1") && e.contains("grad"), "{e}");
        let e = Profile::parse("[columns]\nq = \"a\"\n", Path::new("p.toml"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("p.toml:2") && e.contains("unknown field"), "{e}");
        let e = Profile::parse("decimal_comma = true\n", Path::new("p.toml"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("delimiter"), "{e}");
        // A delimiter a number, a quote or a line break holds is refused; a tab is not.
        for d in ["\\\"", "'", "7", "e", ".", "-", "+", "\\n"] {
            let e = Profile::parse(&format!("delimiter = \"{d}\"\n"), Path::new("p.toml"))
                .unwrap_err()
                .to_string();
            assert!(e.contains("cannot separate fields"), "{d}: {e}");
        }
        let tab = Profile::parse("delimiter = \"\\t\"\n", Path::new("p.toml")).unwrap();
        assert_eq!(tab.delimiter, b'\t');
        // The orientation sigmas: small rotations about the axes unless said otherwise; the
        // Euler angles' own only with Euler angles.
        assert_eq!(p.sigma_angles, SigmaAngles::Axes);
        let a = Profile::parse("sigma_angles = \"angles\"\n", Path::new("p.toml")).unwrap();
        assert_eq!(a.sigma_angles, SigmaAngles::Angles);
        for (text, want) in [
            (
                "sigma_angles = \"euler\"\n",
                "p.toml:1: field `sigma_angles`: unknown meaning `euler`",
            ),
            (
                "orientation = \"quaternion\"\nsigma_angles = \"angles\"\n",
                "p.toml:2: field `sigma_angles`: \"angles\" are the standard deviations of three",
            ),
        ] {
            let e = Profile::parse(text, Path::new("p.toml"))
                .unwrap_err()
                .to_string();
            assert!(e.contains(want), "{e}");
        }
    }

    /// A field's error names its line however the key is written: under `[columns]`, dotted,
    /// quoted or in an inline table (a dotted key had lost its line), and not a line that
    /// merely starts with the field's name (`x` is not `xyz_note`'s line).
    #[test]
    fn errors_name_the_line_of_the_key_however_written() {
        for (text, line) in [
            ("# z\n\n[columns]\nx = \"A\"\ny = \"A\"\n", 5),
            (
                "orientation = \"euler\"\ncolumns.x = \"A\"\n\ncolumns.y = \"A\"\n",
                4,
            ),
            ("[columns]\nx = \"A\"\n\"y\" = \"A\"\n", 3),
            ("\ncolumns = { x = \"A\", y = \"A\" }\n", 2),
            ("[columns]\nx = \"A\"\n\n\n  y = \"A\"\n", 5),
        ] {
            let e = Profile::parse(text, Path::new("p.toml"))
                .unwrap_err()
                .to_string();
            assert!(
                e.contains(&format!(
                    "p.toml:{line}: field `y`: column `A` is already read"
                )),
                "{text}: {e}"
            );
        }
        let e = Profile::parse("\n\nmy.delimiter = 1\n", Path::new("p.toml"));
        assert!(e.is_err());
        let e = Profile::parse("\n\ndelimiter = \"ab\"\n", Path::new("p.toml"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("p.toml:3: field `delimiter`"), "{e}");
    }
}
