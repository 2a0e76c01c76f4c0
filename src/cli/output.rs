//! Shared pieces of command output: numbers, parsing of lists, CSV or JSON to a file or stdout.

use anyhow::{Context, Result};
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
    /// The output file for [`super::paths::guard`]'s list, once its name agrees with the
    /// format: JSON under a `.csv` name (or CSV under `.json`) would pass for the other.
    pub fn out_named(&self) -> Result<super::paths::Named<'_>> {
        let Some(out) = self.out.as_deref() else {
            return Ok(None);
        };
        let ext = (out.extension().and_then(|e| e.to_str())).map(str::to_ascii_lowercase);
        let (given, fix) = match (ext.as_deref(), self.json) {
            (Some("csv"), true) => ("JSON (--json)", "a .json name, or leave out --json"),
            (Some("json"), false) => ("CSV", "--json for JSON, or a .csv name"),
            _ => return Ok(Some(("--out", out))),
        };
        usage!(
            "--out {}: the output is {given}, under a name that says otherwise (give {fix})",
            out.display()
        )
    }

    /// Writes rows as CSV or JSON, to the file or stdout; the last `written` columns are the
    /// command's, the others carried from its input ([`rows_to_json`]).
    pub fn emit(&self, headers: &[String], rows: &[Vec<String>], written: usize) -> Result<()> {
        emit(headers, rows, written, self.json, self.out.as_deref())
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
                _ => usage!("{what}: value {} `{t}` is not a finite number", i + 1),
            }
        })
        .collect::<Result<_>>()?;
    if vals.len() != expected {
        usage!("{what}: {} values given, {expected} expected", vals.len());
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
            usage!(
                "{what}: value {} ({v:e}) is beyond the bound of {}",
                i + 1,
                robocal::data::joints::joint_bound_text(j.joint_type)
            );
        }
    }
    // As a joint file's columns are checked (`fk::warn_if_radians`): a seed typed in radians
    // solves for another branch, or each target's orientation at the wrong joints, without
    // a word. One vector typed by hand is less evidence than a file's rows: whole numbers
    // (`--q 1,2,3,4,5,6`) are taken for degrees, as radians are seldom typed so.
    if robocal::data::joints::look_like_radians(robot, std::iter::once(q.as_slice()))
        && q.iter().any(|v| v.fract() != 0.0)
    {
        eprintln!(
            "warning: {what}: every joint angle lies within +-{:.2}, one turn in radians (or \
             its joint's range in radians, where that is wider): the values are read in \
             degrees; if they hold radians, convert them to degrees",
            std::f64::consts::TAU
        );
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
            usage!(
                "{what}: value {} ({x:e}) is beyond the bound of {}",
                i + 1,
                robocal::data::targets::pose_bound_text(i)
            );
        }
    }
    Ok(v)
}

/// A cell the command reads or writes as a number, as JSON: a number when finite, `null`
/// when empty (no value), else its text (`inf`, `nan`, a status word).
pub fn json_cell(cell: &str) -> serde_json::Value {
    match cell.parse::<f64>() {
        Ok(v) if v.is_finite() => serde_json::json!(v),
        _ if cell.is_empty() => serde_json::Value::Null,
        _ => serde_json::Value::String(cell.to_string()),
    }
}

/// Whether a carried input column holds numbers the command read (joints q1.., the pose's
/// x y z rz ry rx; renamed `input_...` where the output has its own, seeds `seed_q1..`):
/// the other carried columns (ids, labels) are text, kept as written (`007` is not 7).
fn read_as_number(header: &str) -> bool {
    let mut name = header;
    while let Some(inner) = name.strip_prefix("input_") {
        name = inner;
    }
    let name = name.strip_prefix("seed_").unwrap_or(name);
    robocal::data::POSE_COLUMNS.contains(&name)
        || name
            .strip_prefix('q')
            .is_some_and(|d| !d.is_empty() && d.bytes().all(|b| b.is_ascii_digit()))
}

/// Rows as JSON objects, keys in column order; the last `written` columns are the command's
/// ([`json_cell`]), the carried ones text unless the command read them as numbers.
pub fn rows_to_json(headers: &[String], rows: &[Vec<String>], written: usize) -> String {
    let carried = headers.len().saturating_sub(written);
    let numeric: Vec<bool> = (headers.iter().enumerate())
        .map(|(i, h)| i >= carried || read_as_number(h))
        .collect();
    let mut out = String::from("[");
    for (r, row) in rows.iter().enumerate() {
        out.push_str(if r == 0 { "\n  {" } else { ",\n  {" });
        for (i, (h, c)) in headers.iter().zip(row).enumerate() {
            let value = if numeric[i] {
                json_cell(c)
            } else {
                serde_json::Value::String(c.clone())
            };
            out.push_str(if i == 0 { "\n    " } else { ",\n    " });
            out.push_str(&serde_json::Value::from(h.as_str()).to_string());
            out.push_str(": ");
            out.push_str(&value.to_string());
        }
        out.push_str("\n  }");
    }
    out.push_str(if rows.is_empty() { "]\n" } else { "\n]\n" });
    out
}

/// Writes rows as CSV (or JSON) to `out`, atomically, or to stdout when `out` is None.
pub fn emit(
    headers: &[String],
    rows: &[Vec<String>],
    written: usize,
    json: bool,
    out: Option<&Path>,
) -> Result<()> {
    let bytes = if json {
        rows_to_json(headers, rows, written).into_bytes()
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

/// The note naming the carried columns of `layout` written under another name
/// ([`robocal::data::measurement::Layout::carried_names`]), None where none is.
pub(super) fn renamed_note(
    layout: &robocal::data::measurement::Layout,
    joints: usize,
) -> Option<String> {
    let written = layout.carried_names(joints);
    let renamed: Vec<String> = (layout.extra.iter().zip(&written))
        .filter(|(a, b)| a != b)
        .map(|(a, b)| format!("{a} as {b}"))
        .collect();
    (!renamed.is_empty()).then(|| {
        format!(
            "note: carried column(s) a canonical reader would take as fields were renamed: {}",
            renamed.join(", ")
        )
    })
}

#[cfg(test)]
mod tests {
    use super::rows_to_json;

    #[test]
    fn json_keeps_carried_text_as_written_and_the_column_order() {
        let headers: Vec<String> = ["id", "q1", "note", "input_x", "seed_q2", "z", "x", "status"]
            .map(String::from)
            .into();
        let rows = vec![
            ["007", "1.5", "1e5", "3", "7", "", "2.25", "ok"]
                .map(String::from)
                .into(),
            ["1.0", "-0", "", "4", "", "inf", "nan", "unreachable"]
                .map(String::from)
                .into(),
        ];
        let text = rows_to_json(&headers, &rows, 3);
        let v: serde_json::Value = serde_json::from_str(&text).unwrap();
        let want = serde_json::json!([
            {"id": "007", "q1": 1.5, "note": "1e5", "input_x": 3.0, "seed_q2": 7.0, "z": null,
             "x": 2.25, "status": "ok"},
            {"id": "1.0", "q1": -0.0, "note": "", "input_x": 4.0, "seed_q2": null, "z": "inf",
             "x": "nan", "status": "unreachable"},
        ]);
        assert_eq!(v, want);
        // Keys in column order.
        let keys: Vec<usize> = headers
            .iter()
            .map(|h| text.find(&format!("\"{h}\"")).unwrap())
            .collect();
        assert!(keys.is_sorted(), "{text}");
        // Laid out as serde_json's pretty printer lays out an array of objects.
        let one = rows_to_json(&headers[..2], &[rows[0][..2].to_vec()], 1);
        let pretty = serde_json::to_string_pretty(&serde_json::json!([{"id": "007"}])).unwrap();
        assert_eq!(
            one,
            pretty.replace("\"007\"", "\"007\",\n    \"q1\": 1.5") + "\n"
        );
        assert_eq!(rows_to_json(&headers, &[], 3), "[]\n");
    }
}
