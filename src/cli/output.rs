//! Shared pieces of command output: numbers, parsing of lists, CSV or JSON to a file or stdout.

use anyhow::{Context, Result, bail};
use clap::Args;
use std::path::{Path, PathBuf};

/// `r` with "writing PATH" as context, unless its error already names `path` (an OS error
/// from [`robocal::io::write_atomic`]): a path is named once.
pub fn writing<T>(r: robocal::error::Result<T>, path: &Path) -> Result<T> {
    match r {
        Err(robocal::error::Error::Io { path: p, cause }) if p == path => {
            Err(robocal::error::Error::Io { path: p, cause }.into())
        }
        r => r.with_context(|| format!("writing {}", path.display())),
    }
}

/// Output flags of the batch commands.
#[derive(Args)]
pub struct OutputArgs {
    /// Output file (CSV, or JSON with --json); stdout when absent. Written atomically.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// JSON instead of CSV: an array of objects keyed by column name.
    #[arg(long)]
    pub json: bool,
    /// Round output numbers to this many decimals, 0 to 17 (default: shortest exact form).
    #[arg(long, value_parser = super::bounds::decimals)]
    pub decimals: Option<usize>,
}

impl OutputArgs {
    /// Writes rows as CSV or JSON, to the file or stdout.
    pub fn emit(&self, headers: &[String], rows: &[Vec<String>]) -> Result<()> {
        emit(headers, rows, self.json, self.out.as_deref())
    }
}

/// Formats a number: shortest exact form, or rounded to `decimals` places.
pub fn num(v: f64, decimals: Option<usize>) -> String {
    match decimals {
        Some(d) => {
            let s = format!("{v:.d$}");
            // Avoid "-0.000" for values that round to zero.
            if s.trim_start_matches('-')
                .chars()
                .all(|c| c == '0' || c == '.')
            {
                s.trim_start_matches('-').to_string()
            } else {
                s
            }
        }
        None => format!("{v}"),
    }
}

/// Parses "a,b,c" into numbers; `what` names the option in messages.
pub fn parse_list(s: &str, what: &str, expected: usize) -> Result<Vec<f64>> {
    let vals: Vec<f64> = s
        .split(',')
        .enumerate()
        .map(|(i, t)| {
            let t = t.trim();
            match t.parse::<f64>() {
                Ok(v) if v.is_finite() => Ok(v),
                _ => bail!("{what}: value {} `{t}` is not a finite number", i + 1),
            }
        })
        .collect::<Result<_>>()?;
    if vals.len() != expected {
        bail!("{what}: {} values given, {expected} expected", vals.len());
    }
    Ok(vals)
}

/// Joints given on the command line (deg, mm for prismatic joints), within the bounds a
/// file's joints have (4 turns, 100 m).
pub fn joints_arg(robot: &robocal::model::Robot, s: &str, what: &str) -> Result<Vec<f64>> {
    let q = parse_list(s, what, robot.dof())?;
    for (i, (v, j)) in q.iter().zip(robot.joints()).enumerate() {
        let max = robocal::data::joints::joint_bound(j.joint_type);
        if v.abs() > max {
            bail!(
                "{what}: value {} ({v:e}) is beyond the bound of {max}",
                i + 1
            );
        }
    }
    Ok(q)
}

/// A pose given on the command line: x, y, z (mm) within 100 m and rz, ry, rx (deg) within 2
/// turns, as a measurement file's.
pub fn pose_arg(s: &str, what: &str) -> Result<Vec<f64>> {
    let v = parse_list(s, what, 6)?;
    for (i, x) in v.iter().enumerate() {
        let max = robocal::data::targets::pose_bound(i);
        if x.abs() > max {
            bail!(
                "{what}: value {} ({x:e}) is beyond the bound of {max}",
                i + 1
            );
        }
    }
    Ok(v)
}

/// A cell as JSON: a number when it reads as one, else a string.
pub fn json_cell(cell: &str) -> serde_json::Value {
    match cell.parse::<f64>() {
        Ok(v) if v.is_finite() => serde_json::json!(v),
        _ => serde_json::Value::String(cell.to_string()),
    }
}

/// Rows as JSON objects keyed by the headers.
pub fn rows_to_json(headers: &[String], rows: &[Vec<String>]) -> serde_json::Value {
    serde_json::Value::Array(
        rows.iter()
            .map(|r| {
                let obj = headers
                    .iter()
                    .zip(r)
                    .map(|(h, c)| (h.clone(), json_cell(c)))
                    .collect();
                serde_json::Value::Object(obj)
            })
            .collect(),
    )
}

/// Writes rows as CSV (or JSON) to `out`, atomically, or to stdout when `out` is None.
pub fn emit(
    headers: &[String],
    rows: &[Vec<String>],
    json: bool,
    out: Option<&Path>,
) -> Result<()> {
    let bytes = if json {
        let mut b = serde_json::to_vec_pretty(&rows_to_json(headers, rows))?;
        b.push(b'\n');
        b
    } else {
        let mut w = robocal::data::table::CsvOut::new(headers)?;
        for r in rows {
            w.row(r)?;
        }
        w.into_bytes()?
    };
    match out {
        Some(p) => writing(robocal::io::write_atomic(p, &bytes), p),
        None => {
            use std::io::Write;
            std::io::stdout()
                .write_all(&bytes)
                .context("writing to stdout")
        }
    }
}
