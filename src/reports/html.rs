//! `robocal report`: one self-contained HTML page from a run folder, for a person to read.
//!
//! The folder holds the typed JSON reports ([`Report`]: `--report` of identify, train,
//! evaluate, compensate, case-d and reproduce) and pictures (`--plot`, listed in
//! `figures.json`). Each report's accuracy rows ([`Report::accuracy`]) make its accuracy
//! table; its other fields follow in the order the type declares them: lists of records
//! (parameters, correlations, ...) as tables, other values in a key-value table, absent
//! values as "none", infinite ones as "inf", numbers to 5 significant digits and at least 4
//! decimals below 1e6, lists of sentences one a line. Pictures are
//! embedded as base64 PNG, so the page needs no other file and no network. A JSON file that
//! is not a robocal report is an error naming it.

use super::{Accuracy, Node, Report};
use crate::error::{Error, Result};
use crate::plot::{Figure, read_manifest};
use base64::Engine;
use std::fmt::Write;
use std::path::Path;

/// Escapes text for HTML.
fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// A number to 5 significant digits, and at least 4 decimals below 1e6 (as the terminal gives
/// mm and deg: a link of 1074.871985 mm read 1074.9, hiding an identified change of 0.04 mm,
/// a helper's); integers as integers; |x| < 1e-12 (float noise in mm, rad or a coefficient)
/// as 0.
fn number(x: f64) -> String {
    if x.abs() < 1e-12 {
        "0".into()
    } else if x.fract() == 0.0 && x.abs() < 1e15 {
        format!("{x:.0}")
    } else {
        // The decade of x rounded to 5 digits, not of x: 0.99999953 is 1.0000, not 1.00000.
        let scientific = format!("{x:.4e}");
        let decade = (scientific.split_once('e'))
            .and_then(|(_, e)| e.parse::<i32>().ok())
            .unwrap_or(0);
        if (-3..6).contains(&decade) {
            let digits = (4 - decade).clamp(4, 8) as usize;
            format!("{x:.digits$}")
        } else {
            scientific
        }
    }
}

/// A cell: "none" for an absent value, numbers as [`number`] gives them, lists joined (lists
/// of sentences one a line; lists of records: each record's fields with their names,
/// records separated by semicolons; a list of more than 12 numbers or records cut there
/// with its count, a list of names given whole).
fn cell(v: &Node) -> String {
    match v {
        Node::Null => "none".into(),
        Node::Number(x) => number(*x),
        // A note of several lines (another model; no network) keeps its lines apart.
        Node::Text(s) => esc(s).replace('\n', "<br>"),
        Node::Bool(b) => if *b { "yes" } else { "no" }.into(),
        Node::List(a) if a.is_empty() => "none".into(),
        Node::List(a) => {
            let items: Vec<String> = a
                .iter()
                .map(|x| match x {
                    // Named: a reviewer could not tell `reproduce`'s before from its after.
                    Node::Record(_) => cell(x),
                    Node::List(l) => {
                        format!("({})", l.iter().map(cell).collect::<Vec<_>>().join(" "))
                    }
                    other => cell(other),
                })
                .collect();
            // Sentences (notes, warnings) hold commas and semicolons of their own: one a line.
            let sentences = (a.iter()).any(|x| matches!(x, Node::Text(t) if t.contains(' ')));
            let sep = if sentences {
                "<br>"
            } else if a.iter().any(|x| matches!(x, Node::Record(_))) {
                "; "
            } else {
                ", "
            };
            let names = a.iter().all(|x| matches!(x, Node::Text(_)));
            if items.len() > 12 && !names {
                format!("{} ... ({} values)", items[..12].join(sep), items.len())
            } else {
                items.join(sep)
            }
        }
        Node::Record(r) => r
            .iter()
            .map(|(k, v)| format!("{} {}", esc(k), cell(v)))
            .collect::<Vec<_>>()
            .join(", "),
    }
}

fn stats_table(rows: &[Accuracy], html: &mut String) {
    let outside = rows.iter().any(|r| r.rows_outside_domain.is_some());
    html.push_str(
        "<table class=\"stats\"><thead><tr><th>data</th><th>model</th><th>rows</th>\
         <th>mean position (mm)</th><th>rms position (mm)</th><th>p95 position (mm)</th>\
         <th>max position (mm)</th><th>mean per coordinate (mm)</th>\
         <th>mean orientation (deg)</th><th>max orientation (deg)</th>",
    );
    if outside {
        html.push_str("<th>rows outside the training domain</th>");
    }
    html.push_str("</tr></thead><tbody>");
    let opt = |v: Option<f64>| v.map_or_else(|| "none".to_string(), number);
    for r in rows {
        let s = &r.stats;
        let p = s.position_mm;
        let o = s.orientation_deg;
        let _ = write!(
            html,
            "<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td>\
             <td>{}</td><td>{}</td><td>{}</td>",
            esc(&r.data),
            esc(&r.model),
            s.count,
            opt(p.map(|p| p.mean)),
            opt(p.map(|p| p.rms)),
            opt(p.map(|p| p.p95)),
            opt(p.map(|p| p.max)),
            opt(s.position_per_coordinate_mean_mm),
            opt(o.map(|o| o.mean)),
            opt(o.map(|o| o.max)),
        );
        if outside {
            let _ = write!(
                html,
                "<td>{}</td>",
                opt(r.rows_outside_domain.map(|n| n as f64))
            );
        }
        html.push_str("</tr>");
    }
    html.push_str("</tbody></table>\n");
}

/// Records nested deeper than this many leaves get their own section instead of columns.
const WIDE: usize = 12;

/// Where a record's wide parts are: its own sections below the table.
static BELOW: std::sync::LazyLock<Node> = std::sync::LazyLock::new(|| Node::Text("(below)".into()));
/// Where a record's long series are: the JSON report (and its figures).
static IN_FILE: std::sync::LazyLock<Node> =
    std::sync::LazyLock::new(|| Node::Text("(in the JSON report)".into()));

/// The scalar leaves of a record as (dotted name, value), in order: nested small records are
/// flattened; wide ones and lists of records (shown in sections below) and long series (left
/// in the JSON report) say so.
fn leaves<'a>(v: &'a Node, prefix: &str, out: &mut Vec<(String, &'a Node)>) {
    if let Node::Record(m) = v {
        for (k, x) in m {
            let name = if prefix.is_empty() {
                k.clone()
            } else {
                format!("{prefix}.{k}")
            };
            match x {
                Node::Record(_) if count_leaves(x) > WIDE => out.push((name, &BELOW)),
                Node::Record(_) => leaves(x, &name, out),
                Node::List(_) if is_records(x) && !is_small_records(x) => out.push((name, &BELOW)),
                Node::List(a) if a.len() > LONG => out.push((name, &IN_FILE)),
                _ => out.push((name, x)),
            }
        }
    }
}

fn count_leaves(v: &Node) -> usize {
    match v {
        Node::Record(m) => m.iter().map(|(_, x)| count_leaves(x)).sum(),
        _ => 1,
    }
}

/// Long numeric series (training curves) are summarised rather than tabulated.
const LONG: usize = 40;

fn is_records(v: &Node) -> bool {
    matches!(v, Node::List(a) if a.iter().any(|x| matches!(x, Node::Record(_))))
}

/// A short list of small records (a regrouping's terms): shown in one cell.
fn is_small_records(v: &Node) -> bool {
    matches!(v, Node::List(a) if a.len() <= 12
        && a.iter().all(|x| matches!(x, Node::Record(r) if r.len() <= 4
            && r.iter().all(|(_, f)| !matches!(f, Node::Record(_) | Node::List(_))))))
}

fn section(title: &str, m: &[(String, Node)], depth: usize, html: &mut String) {
    let h = (depth + 2).min(6);
    let _ = writeln!(html, "<h{h}>{}</h{h}>", esc(title));
    let scalars: Vec<&(String, Node)> = m
        .iter()
        .filter(|(_, v)| match v {
            Node::List(a) => {
                a.len() <= LONG && !is_records(v) && !a.iter().any(|x| matches!(x, Node::List(_)))
            }
            Node::Record(_) => false,
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
            Node::List(a) if is_records(v) => {
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
                // A record's own values before its parts' (a candidate's label before its
                // settings' fields, which for the model alone still name the network it was
                // held against).
                let (own, parts): (Vec<String>, Vec<String>) =
                    cols.into_iter().partition(|c| !c.contains('.'));
                let cols: Vec<String> = own.into_iter().chain(parts).collect();
                let h2 = (h + 1).min(6);
                let _ = write!(html, "<h{h2}>{}</h{h2}>", esc(k));
                if !cols.is_empty() {
                    // The row's index as the JSON's indices count (`chosen`, a test's
                    // `network` and `alone`): from 0.
                    html.push_str(
                        "<table class=\"records\"><thead><tr><th title=\"from 0, as the JSON \
                         report's indices\">#</th>",
                    );
                    for c in &cols {
                        let _ = write!(html, "<th>{}</th>", esc(c));
                    }
                    html.push_str("</tr></thead><tbody>");
                    for (i, r) in a.iter().enumerate() {
                        let mut l = Vec::new();
                        leaves(r, "", &mut l);
                        let _ = write!(html, "<tr><td>{i}</td>");
                        for c in &cols {
                            let v = l
                                .iter()
                                .find(|(n, _)| n == c)
                                .map_or(&Node::Null, |(_, v)| v);
                            let _ = write!(html, "<td>{}</td>", cell(v));
                        }
                        html.push_str("</tr>");
                    }
                    html.push_str("</tbody></table>\n");
                }
                // What did not fit in columns: wide records and lists of records, per row.
                for (i, r) in a.iter().enumerate() {
                    let Node::Record(fields) = r else { continue };
                    let name = fields
                        .iter()
                        .find_map(|(_, v)| match v {
                            Node::Text(t) => Some(t.clone()),
                            _ => None,
                        })
                        .unwrap_or_else(|| format!("{}", i + 1));
                    for (fk, fv) in fields {
                        let wide = matches!(fv, Node::Record(_)) && count_leaves(fv) > WIDE;
                        if wide || (is_records(fv) && !is_small_records(fv)) {
                            let sub = [(fk.clone(), fv.clone())];
                            let title = format!("{k} {name}");
                            section(&title, &sub, depth + 1, html);
                        }
                    }
                }
            }
            Node::List(a) if a.len() > LONG || a.iter().any(|x| matches!(x, Node::List(_))) => {
                let _ = writeln!(
                    html,
                    "<p class=\"note\">{}: {} entries (in the JSON report)</p>",
                    esc(k),
                    a.len()
                );
            }
            Node::Record(sub) => section(k, sub, depth + 1, html),
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
    // Found from the name: a missing file out there is no less outside.
    let leaves = Path::new(name).components().any(|c| {
        use std::path::Component::{ParentDir, Prefix, RootDir};
        matches!(c, ParentDir | RootDir | Prefix(_))
    });
    if leaves {
        return Err(outside());
    }
    let root = dir.canonicalize().map_err(|e| Error::io(dir, e))?;
    let real = path.canonicalize().map_err(|e| {
        if e.kind() == std::io::ErrorKind::NotFound {
            Error::Invalid(format!(
                "{}: lists `{name}`, which is not in {}: draw the pictures again (--plot {}) or \
                 remove its entry",
                crate::plot::manifest_path(dir).display(),
                dir.display(),
                dir.display()
            ))
        } else {
            Error::io(&path, e)
        }
    })?;
    if !real.starts_with(&root) {
        return Err(outside());
    }
    Ok(path)
}

fn figure(dir: &Path, f: &Figure, html: &mut String) -> Result<()> {
    let path = inside(dir, &f.png)?;
    let bytes = crate::io::read_capped(&path, MAX_EMBED_BYTES)?;
    // A browser shows a broken picture without a word: an empty, cut or foreign file is
    // refused here, as a missing one is.
    if let Err(e) = image::load_from_memory_with_format(&bytes, image::ImageFormat::Png) {
        return Err(Error::Invalid(format!(
            "{}: not a whole PNG picture ({e}): draw the pictures again (--plot {})",
            path.display(),
            dir.display()
        )));
    }
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

/// The pictures (`*.png`, `*.svg`, any letter case) in run folder `dir` that its figure list
/// does not name, one entry per name without its extension (`extra.png`, or
/// `identify_validation_position.png/.svg`): the page leaves them out (it shows a picture
/// with the title and caption its list gives), and `report` says so rather than drop them
/// silently. They are an earlier run's (a command's later run in the folder takes its
/// earlier pictures off the list, [`crate::plot::forget_earlier`]) or copied in without it.
pub fn unlisted_pictures(dir: &Path) -> Result<Vec<String>> {
    let listed: Vec<String> = (crate::plot::read_manifest(dir)?.into_iter())
        .flat_map(|f| [f.png, f.svg])
        .collect();
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .map_err(|e| Error::io(dir, e))?
        .filter_map(|e| e.ok())
        .filter(|e| e.path().is_file())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| crate::plot::is_picture(n) && !listed.contains(n))
        .collect();
    names.sort();
    // Extensions are 4 ASCII bytes (".png", ".svg", `is_picture`'s): a picture's files are
    // one entry, by name (sorted, `x.q.png` falls between `x.png` and `x.svg`).
    let mut grouped: std::collections::BTreeMap<String, Vec<String>> = Default::default();
    for n in names {
        let (stem, ext) = n.split_at(n.len() - 4);
        grouped
            .entry(stem.to_string())
            .or_default()
            .push(ext.to_string());
    }
    Ok(grouped
        .into_iter()
        .map(|(stem, exts)| format!("{stem}{}", exts.join("/")))
        .collect())
}

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
        let report = Report::from_json(crate::io::without_bom(&text), path)?;
        let name = path
            .file_name()
            .map_or_else(String::new, |n| n.to_string_lossy().into_owned());
        let _ = writeln!(
            html,
            "<h2>Report {} (<code>{}</code>)</h2>",
            esc(&name),
            report.kind()
        );
        let accuracy = report.accuracy();
        if !accuracy.is_empty() {
            html.push_str("<h3>Accuracy</h3>\n");
            stats_table(&accuracy, &mut html);
        }
        if let Node::Record(fields) = report.to_node()? {
            let details: Vec<(String, Node)> = fields
                .into_iter()
                .filter(|(k, _)| k != "kind" && k != "accuracy")
                .collect();
            section("Details", &details, 1, &mut html);
        }
        if html.len() as u64 > MAX_PAGE_BYTES {
            return Err(Error::Invalid(format!(
                "{}: the page would pass {} MB; report fewer runs per folder",
                path.display(),
                MAX_PAGE_BYTES >> 20
            )));
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cells_spell_out_none_and_round_numbers() {
        assert_eq!(cell(&Node::Null), "none");
        assert_eq!(cell(&Node::List(Vec::new())), "none");
        assert_eq!(cell(&Node::Text("inf".into())), "inf");
        assert_eq!(cell(&Node::Text("a < b\nc".into())), "a &lt; b<br>c");
        assert_eq!(number(-2.5105e-14), "0");
        assert_eq!(number(30.0), "30");
        assert_eq!(number(0.45381234), "0.45381");
        assert_eq!(number(12.7709), "12.7709");
        assert_eq!(number(1074.871985), "1074.8720");
        assert_eq!(number(-2.3592e-4), "-2.3592e-4");
        assert_eq!(number(1.23456789e7), "1.2346e7");
        assert_eq!(number(1.23e7), "12300000");
        // Rounding that carries into the next decade keeps 5 significant digits.
        assert_eq!(number(0.9999953529), "1.0000");
        // Sentences one a line; names joined with commas.
        let notes = Node::List(vec![
            Node::Text("a note, with a comma".into()),
            Node::Text("another".into()),
        ]);
        assert_eq!(cell(&notes), "a note, with a comma<br>another");
        let names = Node::List(vec![Node::Text("a1".into()), Node::Text("d2".into())]);
        assert_eq!(cell(&names), "a1, d2");
        assert_eq!(number(-9.99996), "-10.0000");
        assert_eq!(number(999999.7), "1.0000e6");
        assert_eq!(number(9.99996e-4), "0.0010000");
        let terms = Node::List(vec![
            Node::Record(vec![
                ("name".into(), Node::Text("base.rz".into())),
                ("coefficient".into(), Node::Number(1.0)),
            ]),
            Node::Record(vec![
                ("name".into(), Node::Text("base.ry".into())),
                ("coefficient".into(), Node::Number(0.0010751)),
            ]),
        ]);
        assert_eq!(
            cell(&terms),
            "name base.rz, coefficient 1; name base.ry, coefficient 0.0010751"
        );
        // Names are given whole, numbers cut at 12 with their count.
        let names = Node::List((0..15).map(|k| Node::Text(format!("p{k}"))).collect());
        assert!(cell(&names).ends_with("p13, p14"), "{}", cell(&names));
        let numbers = Node::List((0..15).map(|k| Node::Number(k as f64)).collect());
        assert!(
            cell(&numbers).ends_with("11 ... (15 values)"),
            "{}",
            cell(&numbers)
        );
    }

    #[test]
    fn record_tables_put_own_values_first_and_count_rows_from_zero() {
        let candidate = |label: &str| {
            Node::Record(vec![
                ("stage".into(), Node::Number(5.0)),
                (
                    "settings".into(),
                    Node::Record(vec![("network".into(), Node::Text("mlp".into()))]),
                ),
                ("label".into(), Node::Text(label.into())),
            ])
        };
        let list = Node::List(vec![candidate("pose/sincos/32"), candidate("model alone")]);
        let mut html = String::new();
        section("selection", &[("candidates".into(), list)], 0, &mut html);
        let mut heads: Vec<&str> = html
            .split("</th>")
            .map(|t| &t[t.rfind('>').map_or(0, |i| i + 1)..])
            .collect();
        heads.pop();
        assert_eq!(heads, ["#", "stage", "label", "settings.network"], "{html}");
        assert!(
            html.contains("<tr><td>1</td><td>5</td><td>model alone</td><td>mlp</td></tr>"),
            "{html}"
        );
    }
}
