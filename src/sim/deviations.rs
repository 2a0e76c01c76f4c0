//! Parameter deviations of a virtual robot: a TOML table of the model's parameter names with
//! lengths in mm and angles in mrad (as thesis Table 6.1).
//!
//! ```toml
//! a1 = 1.41          # mm
//! alpha1 = -1.72     # mrad
//! "base.d" = -0.02   # or, as a table: [base] d = -0.02
//! ```

use crate::error::{Error, Location, Result};
use crate::model::{ParamId, Robot};
use std::path::Path;

/// Deviations in internal units (mm, rad), one per named parameter.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Deviations(pub Vec<(ParamId, f64)>);

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
                        "a deviation must be a finite number (mm or mrad)",
                    ));
                }
            };
            // A deviation is small against its parameter: at most the robot file's bound on
            // the parameter itself (100 m, 2 turns), so a deviated robot stays loadable.
            let (max, unit) = if id.field.is_angle() {
                (crate::model::file::MAX_ANGLE_DEG.to_radians() * 1e3, "mrad")
            } else {
                (crate::model::file::MAX_LENGTH_MM, "mm")
            };
            if v.abs() > max {
                return Err(Error::input(
                    at(),
                    format!("a deviation of {v:e} {unit} is beyond the bound of {max:.0} {unit}"),
                ));
            }
            if out.iter().any(|(o, _)| *o == id) {
                return Err(Error::input(at(), "this parameter is given twice"));
            }
            out.push((id, if id.field.is_angle() { v * 1e-3 } else { v }));
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
