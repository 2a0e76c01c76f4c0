//! `robocal report`: one self-contained HTML page from a run folder, for a person to read.
//!
//! The folder holds the JSON reports (`--report`) and pictures (`--plot`, listed in
//! `figures.json`) of identify, train, evaluate and case-d runs. Every accuracy block of a
//! report (an object with `count` and `position_mm` or `orientation_deg`) becomes a row of
//! that report's accuracy table; lists of records (parameters, correlations, ...) become
//! tables; other values a key-value table. Pictures are embedded as base64 PNG, so the page
//! needs no other file and no network.

use crate::error::{Error, Result};
use crate::plot::{Figure, read_manifest};
use base64::Engine;
use serde_json::{Map, Value};
use std::fmt::Write;
use std::path::Path;

/// Escapes text for HTML.
fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// A cell: numbers with up to 6 significant digits, nothing for null.
fn cell(v: &Value) -> String {
    match v {
        Value::Null => String::new(),
        Value::Number(n) => match n.as_f64() {
            Some(x) if n.is_f64() => {
                if x == 0.0 {
                    "0".into()
                } else if x.abs() >= 1e-3 && x.abs() < 1e6 {
                    let digits = (5 - x.abs().log10().floor() as i32).clamp(0, 8) as usize;
                    format!("{x:.digits$}")
                } else {
                    format!("{x:.4e}")
                }
            }
            _ => n.to_string(),
        },
        Value::String(s) => esc(s),
        Value::Bool(b) => b.to_string(),
        Value::Array(a) if a.iter().all(|x| !x.is_object() && !x.is_array()) => {
            let items: Vec<String> = a.iter().map(cell).collect();
            if items.len() > 12 {
                format!("{} ... ({} values)", items[..12].join(", "), items.len())
            } else {
                items.join(", ")
            }
        }
        other => esc(&other.to_string()),
    }
}

/// Whether `v` is an accuracy block (see `evaluate::ErrorStats`).
fn is_stats(v: &Value) -> bool {
    v.get("count").is_some()
        && (v.get("position_mm").is_some() || v.get("orientation_deg").is_some())
}

/// Pulls every accuracy block out of `v` (depth first) with a label made of the path's
/// names, and the `set` / `stage` strings of the objects on the way.
fn collect_stats(v: &Value, label: &mut Vec<String>, out: &mut Vec<(String, Value)>) {
    match v {
        Value::Object(m) => {
            let mut pushed = 0;
            for k in ["set", "stage"] {
                if let Some(Value::String(s)) = m.get(k) {
                    label.push(s.clone());
                    pushed += 1;
                }
            }
            for (k, x) in m {
                if is_stats(x) {
                    let mut l = label.clone();
                    l.push(k.clone());
                    out.push((l.join(" / "), x.clone()));
                } else if x.is_object() || x.is_array() {
                    // Records that name themselves (set, stage) need no list name.
                    let named = x.as_array().is_some_and(|a| {
                        a.iter()
                            .any(|r| r.get("set").is_some() || r.get("stage").is_some())
                    });
                    if !named {
                        label.push(k.clone());
                    }
                    collect_stats(x, label, out);
                    if !named {
                        label.pop();
                    }
                }
            }
            label.truncate(label.len() - pushed);
        }
        Value::Array(a) => {
            for x in a {
                collect_stats(x, label, out);
            }
        }
        _ => {}
    }
}

fn stats_table(rows: &[(String, Value)], html: &mut String) {
    html.push_str(
        "<table class=\"stats\"><thead><tr><th>what</th><th>rows</th><th>mean position (mm)</th>\
         <th>rms position (mm)</th><th>max position (mm)</th><th>mean per coordinate (mm)</th>\
         <th>mean orientation (deg)</th><th>max orientation (deg)</th></tr></thead><tbody>",
    );
    for (label, s) in rows {
        let g = |a: &str, b: &str| cell(s.get(a).and_then(|x| x.get(b)).unwrap_or(&Value::Null));
        let _ = write!(
            html,
            "<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>",
            esc(label),
            cell(&s["count"]),
            g("position_mm", "mean"),
            g("position_mm", "rms"),
            g("position_mm", "max"),
            cell(
                s.get("position_per_coordinate_mean_mm")
                    .unwrap_or(&Value::Null)
            ),
            g("orientation_deg", "mean"),
            g("orientation_deg", "max"),
        );
    }
    html.push_str("</tbody></table>\n");
}

/// The scalar leaves of a record as (dotted name, value): nested records are flattened,
/// accuracy blocks (in the accuracy table) and lists of records or long lists are left out.
fn leaves<'a>(v: &'a Value, prefix: &str, out: &mut Vec<(String, &'a Value)>) {
    if let Value::Object(m) = v {
        for (k, x) in m {
            let name = if prefix.is_empty() {
                k.clone()
            } else {
                format!("{prefix}.{k}")
            };
            match x {
                Value::Object(_) if is_stats(x) => {}
                Value::Object(_) => leaves(x, &name, out),
                Value::Array(a)
                    if a.len() > 12 || a.iter().any(|e| e.is_object() || e.is_array()) => {}
                _ => out.push((name, x)),
            }
        }
    }
}

/// Columns of a list of records: the union of their leaves, in first-seen order.
fn record_columns(a: &[Value]) -> Vec<String> {
    let mut cols: Vec<String> = Vec::new();
    for r in a {
        let mut l = Vec::new();
        leaves(r, "", &mut l);
        for (n, _) in l {
            if !cols.contains(&n) {
                cols.push(n);
            }
        }
    }
    cols
}

/// Long numeric series (training curves) are summarised rather than tabulated.
const LONG: usize = 40;

fn section(title: &str, m: &Map<String, Value>, depth: usize, html: &mut String) {
    let h = (depth + 2).min(6);
    let _ = writeln!(html, "<h{h}>{}</h{h}>", esc(title));
    let scalars: Vec<(&String, &Value)> = m
        .iter()
        .filter(|(_, v)| match v {
            Value::Array(a) => a.iter().all(|x| !x.is_object() && !x.is_array()) && a.len() <= LONG,
            Value::Object(_) => false,
            _ => true,
        })
        .collect();
    if !scalars.is_empty() {
        html.push_str("<table class=\"kv\"><tbody>");
        for (k, v) in scalars {
            let _ = write!(html, "<tr><th>{}</th><td>{}</td></tr>", esc(k), cell(v));
        }
        html.push_str("</tbody></table>\n");
    }
    for (k, v) in m {
        match v {
            Value::Array(a) if a.iter().any(Value::is_object) => {
                let cols = record_columns(a);
                if cols.is_empty() {
                    continue;
                }
                let _ = write!(
                    html,
                    "<h{}>{}</h{}>",
                    (h + 1).min(6),
                    esc(k),
                    (h + 1).min(6)
                );
                html.push_str("<table class=\"records\"><thead><tr>");
                for c in &cols {
                    let _ = write!(html, "<th>{}</th>", esc(c));
                }
                html.push_str("</tr></thead><tbody>");
                for r in a {
                    let mut l = Vec::new();
                    leaves(r, "", &mut l);
                    html.push_str("<tr>");
                    for c in &cols {
                        let v = l
                            .iter()
                            .find(|(n, _)| n == c)
                            .map_or(&Value::Null, |(_, v)| v);
                        let _ = write!(html, "<td>{}</td>", cell(v));
                    }
                    html.push_str("</tr>");
                }
                html.push_str("</tbody></table>\n");
            }
            Value::Array(a) if a.len() > LONG || a.iter().any(Value::is_array) => {
                let _ = writeln!(
                    html,
                    "<p class=\"note\">{}: {} entries (see the figures)</p>",
                    esc(k),
                    a.len()
                );
            }
            Value::Object(sub) if !is_stats(v) => section(k, sub, depth + 1, html),
            _ => {}
        }
    }
}

/// The largest page `report` writes (bytes).
pub const MAX_PAGE_BYTES: u64 = 256 << 20;

/// The largest picture or report a page embeds (bytes).
pub const MAX_EMBED_BYTES: u64 = 32 << 20;

/// `name` from a run folder's figure list as a path inside `dir`: a name that leads out of
/// the folder (`/etc/hostname`, `../x.png`, a link to elsewhere) is refused.
fn inside(dir: &Path, name: &str) -> Result<std::path::PathBuf> {
    let path = dir.join(name);
    let outside = || {
        Error::Invalid(format!(
            "{}: `{name}` lies outside the run folder; only pictures inside it are embedded",
            crate::plot::manifest_path(dir).display()
        ))
    };
    let root = dir.canonicalize().map_err(|e| Error::io(dir, e))?;
    let real = path.canonicalize().map_err(|e| Error::io(&path, e))?;
    if !real.starts_with(&root) {
        return Err(outside());
    }
    Ok(path)
}

fn figure(dir: &Path, f: &Figure, html: &mut String) -> Result<()> {
    let path = inside(dir, &f.png)?;
    let bytes = crate::io::read_capped(&path, MAX_EMBED_BYTES)?;
    let b64 = base64::engine::general_purpose::STANDARD.encode(bytes);
    let _ = writeln!(
        html,
        "<figure><img src=\"data:image/png;base64,{b64}\" alt=\"{}\"><figcaption><b>{}.</b> {} \
         <span class=\"file\">({}, {})</span></figcaption></figure>",
        esc(&f.title),
        esc(&f.title),
        esc(&f.caption),
        esc(&f.png),
        esc(&f.svg)
    );
    Ok(())
}

const STYLE: &str = "body{font-family:system-ui,'DejaVu Sans',sans-serif;max-width:1180px;\
margin:2em auto;padding:0 1em;color:#222}h1{font-size:1.7em}h2{border-bottom:2px solid #ccc;\
padding-bottom:.2em;margin-top:2em}table{border-collapse:collapse;margin:.6em 0 1.2em;\
font-size:.9em}th,td{border:1px solid #ccc;padding:.25em .6em;text-align:left;\
vertical-align:top}table.records{display:block;overflow-x:auto}td{font-variant-numeric:tabular-nums}table.stats td:not(:first-child)\
{text-align:right}thead th{background:#f0f3f7}table.kv th{background:#f7f7f7;font-weight:600}\
figure{margin:1.5em 0}figure img{max-width:100%;border:1px solid #ddd}figcaption{font-size:.9em;\
color:#444;margin-top:.3em}.file,.note{color:#777;font-size:.85em}";

/// The page for run folder `dir`: every `*.json` report (but `figures.json`) and every
/// listed picture. An empty folder is an error.
pub fn render(dir: &Path) -> Result<String> {
    let mut reports: Vec<_> = std::fs::read_dir(dir)
        .map_err(|e| Error::io(dir, e))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| {
            p.extension().is_some_and(|e| e == "json")
                && p.file_name().is_some_and(|n| n != "figures.json")
        })
        .collect();
    reports.sort();
    let figures = read_manifest(dir)?;
    if reports.is_empty() && figures.is_empty() {
        return Err(Error::Invalid(format!(
            "{}: no reports (*.json) and no pictures (figures.json)",
            dir.display()
        )));
    }
    let mut html = String::new();
    let _ = write!(
        html,
        "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>robocal report: \
         {0}</title><style>{STYLE}</style></head><body>\n<h1>robocal report: {0}</h1>\n<p>{1} \
         report(s) and {2} figure(s) from <code>{0}</code>, made by robocal {3}. Lengths in mm, \
         angles in degrees.</p>\n",
        esc(&dir.display().to_string()),
        reports.len(),
        figures.len(),
        env!("CARGO_PKG_VERSION")
    );
    for path in &reports {
        let bytes = crate::io::read_capped(path, MAX_EMBED_BYTES)?;
        let text = String::from_utf8(bytes)
            .map_err(|_| Error::Invalid(format!("{}: not UTF-8 text", path.display())))?;
        let v: Value = serde_json::from_str(&text).map_err(|e| {
            Error::Invalid(format!(
                "{}:{}:{}: not JSON: {e}",
                path.display(),
                e.line(),
                e.column()
            ))
        })?;
        let name = path
            .file_name()
            .map_or_else(String::new, |n| n.to_string_lossy().into_owned());
        let _ = writeln!(html, "<h2>Report {}</h2>", esc(&name));
        let mut stats = Vec::new();
        collect_stats(&v, &mut Vec::new(), &mut stats);
        if !stats.is_empty() {
            html.push_str("<h3>Accuracy</h3>\n");
            stats_table(&stats, &mut html);
        }
        match &v {
            Value::Object(m) => section("Details", m, 1, &mut html),
            other => {
                let _ = writeln!(html, "<p>{}</p>", cell(other));
            }
        }
    }
    if !figures.is_empty() {
        html.push_str("<h2>Figures</h2>\n");
        for f in &figures {
            figure(dir, f, &mut html)?;
            if html.len() as u64 > MAX_PAGE_BYTES {
                return Err(Error::Invalid(format!(
                    "{}: the page would pass {} MB ({} pictures listed); list fewer",
                    crate::plot::manifest_path(dir).display(),
                    MAX_PAGE_BYTES >> 20,
                    figures.len()
                )));
            }
        }
    }
    html.push_str("</body></html>\n");
    Ok(html)
}
