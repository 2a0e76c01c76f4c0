//! Parameter deviations of a virtual robot: a TOML table of the model's parameter names with
//! lengths in mm and angles in mrad (as thesis Table 6.1), joint compliances in the robot
//! file's units (mrad per kN m; the mass-free coefficients in mrad per kN m times kg, or kg m).
//!
//! ```toml
//! a1 = 1.41          # mm
//! alpha1 = -1.72     # mrad
//! "base.d" = -0.02   # or, as a table: [base] d = -0.02
//! c2 = 0.5           # mrad per kN m
//! ```

use crate::error::{Error, Location, Result};
use crate::model::compliance::{MAX_COMPLIANCE_FILE, MAX_MOMENT_FILE};
use crate::model::{Field, ParamId, Robot};
use std::path::Path;

/// Deviations in internal units (mm, rad; a compliance in rad per N m), one per named
/// parameter.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Deviations(pub Vec<(ParamId, f64)>);

/// A deviation's unit in a deviations file and the bound on it there: the robot file's bound
/// on the parameter itself (100 m, 2 turns, its compliance bounds), so a deviated robot stays
/// loadable.
pub fn file_unit(field: Field) -> (&'static str, f64) {
    match field {
        Field::C => (field.file_unit(), MAX_COMPLIANCE_FILE),
        Field::K { .. } => (field.file_unit(), MAX_MOMENT_FILE),
        f if f.is_angle() => ("mrad", crate::model::file::MAX_ANGLE_DEG.to_radians() * 1e3),
        _ => ("mm", crate::model::file::MAX_LENGTH_MM),
    }
}

/// A deviation `v` of `field` from file units ([`file_unit`]) to internal ones (mm, rad, rad
/// per N m).
pub fn to_internal(field: Field, v: f64) -> f64 {
    match field {
        // A compliance as in robot files; only angles differ from them (mrad, not deg).
        Field::C | Field::K { .. } => field.to_internal(v),
        f if f.is_angle() => v * 1e-3,
        _ => v,
    }
}

/// A deviation `v` of `field` from internal units to file ones ([`file_unit`]).
pub fn to_file(field: Field, v: f64) -> f64 {
    match field {
        Field::C | Field::K { .. } => field.to_file(v),
        f if f.is_angle() => v * 1e3,
        _ => v,
    }
}

fn flatten(prefix: &str, table: &toml::Table, out: &mut Vec<(String, toml::Value)>) {
    for (k, v) in table {
        let name = if prefix.is_empty() {
            k.clone()
        } else {
            format!("{prefix}.{k}")
        };
        match v {
            toml::Value::Table(t) => flatten(&name, t, out),
            other => out.push((name, other.clone())),
        }
    }
}

impl Deviations {
    /// Reads a deviations file for `robot`; an unknown parameter or a non-number is an error
    /// naming the file, the line and the parameter.
    pub fn read(path: impl AsRef<Path>, robot: &Robot) -> Result<Self> {
        let path = path.as_ref();
        Deviations::parse(&crate::io::read_text(path)?, path, robot)
    }

    /// Parses deviations text (mm, mrad) for `robot`; `path` is used in messages.
    pub fn parse(text: &str, path: &Path, robot: &Robot) -> Result<Self> {
        let table: toml::Table = crate::io::parse_toml(text, path)?;
        let mut flat = Vec::new();
        flatten("", &table, &mut flat);
        // The line of each key by its full dotted name, from the parser's spans: a key under
        // a `[tool]` header, in an inline table or dotted is `tool.<key>`, a quoted `"tool.d"`
        // is `tool.d`; the n-th key of one name is on the n-th line that gives it.
        let key_lines = crate::io::key_lines(text);
        let mut seen: Vec<String> = Vec::new();
        let mut line_of_key = |name: &str| {
            let nth = seen.iter().filter(|s| *s == name).count();
            seen.push(name.to_string());
            (key_lines.iter())
                .filter(|(k, _)| k == name)
                .nth(nth)
                .map_or(0, |(_, line)| *line)
        };
        let mut out = Vec::with_capacity(flat.len());
        for (name, value) in flat {
            let line = line_of_key(&name);
            let at = || Location::at(path, line, name.clone());
            let id = robot.find_param(&name).ok_or_else(|| {
                Error::input(
                    at(),
                    format!("the robot `{}` has no parameter `{name}`", robot.name()),
                )
            })?;
            let v = match value {
                toml::Value::Float(f) if f.is_finite() => f,
                toml::Value::Integer(i) => i as f64,
                _ => {
                    return Err(Error::input(
                        at(),
                        "a deviation must be a finite number (mm, mrad, or a compliance's \
                         unit)",
                    ));
                }
            };
            let (unit, max) = file_unit(id.field);
            if v.abs() > max {
                return Err(Error::input(
                    at(),
                    format!("a deviation of {v:e} {unit} is beyond the bound of {max:.0} {unit}"),
                ));
            }
            if out.iter().any(|(o, _)| *o == id) {
                return Err(Error::input(at(), "this parameter is given twice"));
            }
            out.push((id, to_internal(id.field, v)));
        }
        Ok(Deviations(out))
    }

    /// The robot with every deviation added to its parameter.
    pub fn apply(&self, robot: &Robot) -> Result<Robot> {
        let values: Vec<(ParamId, f64)> = self
            .0
            .iter()
            .map(|&(id, d)| (id, robot.param(id) + d))
            .collect();
        robot.with_params(&values)
    }
}
