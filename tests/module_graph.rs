//! Issue 13, item 1: the library's module graph runs one way. Every `crate::` and `super::`
//! path in `src/` is resolved to the file that defines its module; a cycle between files, or
//! between top-level modules (folders and top-level files), fails this test with the cycle.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

fn src() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("src")
}

/// Every `.rs` file under `dir`.
fn files(dir: &Path, out: &mut Vec<PathBuf>) {
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        if p.is_dir() {
            files(&p, out);
        } else if p.extension().is_some_and(|x| x == "rs") {
            out.push(p);
        }
    }
}

/// The module path of a file: `src/neural/shrink.rs` -> ["neural", "shrink"]; `mod.rs` and `lib.rs`
/// name their folder.
fn module_of(file: &Path) -> Vec<String> {
    let rel = file.strip_prefix(src()).unwrap();
    let mut parts: Vec<String> = rel
        .iter()
        .map(|s| s.to_string_lossy().trim_end_matches(".rs").to_string())
        .collect();
    if matches!(
        parts.last().map(String::as_str),
        Some("mod" | "lib" | "main")
    ) {
        parts.pop();
    }
    parts
}

/// The file of the longest prefix of `path` that is a module.
fn file_of(modules: &BTreeMap<Vec<String>, PathBuf>, path: &[String]) -> Option<PathBuf> {
    (1..=path.len())
        .rev()
        .find_map(|n| modules.get(&path[..n]).cloned())
}

/// Paths written after `crate::` or `super::` (with `{a, b::c}` groups expanded), as
/// segment lists relative to the crate root or to the parent module.
fn paths_after(text: &str, prefix: &str) -> Vec<Vec<String>> {
    let mut out = Vec::new();
    let b = text.as_bytes();
    let mut start = 0;
    while let Some(i) = text[start..].find(prefix) {
        let at = start + i;
        start = at + prefix.len();
        // `super::super::x` is read from its first `super::` only.
        if at > 0 && (b[at - 1].is_ascii_alphanumeric() || b[at - 1] == b'_' || b[at - 1] == b':') {
            continue;
        }
        expand(&text[start..], &[], &mut out);
    }
    out
}

/// Reads one path (maybe a `{...}` group) from the start of `rest`.
fn expand(rest: &str, base: &[String], out: &mut Vec<Vec<String>>) {
    let mut segs = base.to_vec();
    let mut s = rest;
    loop {
        if let Some(inner) = s.strip_prefix('{') {
            // Split the group at top-level commas.
            let mut depth = 0;
            let mut item = 0;
            for (k, c) in inner.char_indices() {
                match c {
                    '{' => depth += 1,
                    '}' if depth == 0 => {
                        expand(&inner[item..k], &segs, out);
                        return;
                    }
                    '}' => depth -= 1,
                    ',' if depth == 0 => {
                        expand(&inner[item..k], &segs, out);
                        item = k + 1;
                    }
                    _ => {}
                }
            }
            return;
        }
        let t = s.trim_start();
        let n = t
            .find(|c: char| !(c.is_ascii_alphanumeric() || c == '_'))
            .unwrap_or(t.len());
        if n == 0 {
            break;
        }
        segs.push(t[..n].to_string());
        s = &t[n..];
        match s.strip_prefix("::") {
            Some(r) => s = r,
            None => break,
        }
    }
    if !segs.is_empty() {
        out.push(segs);
    }
}

/// Text without comments and string literals (doc examples name paths that are not uses).
fn code(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for line in text.lines() {
        let mut l = line;
        if let Some(i) = l.find("//") {
            l = &l[..i];
        }
        let mut quoted = false;
        let mut prev = ' ';
        for c in l.chars() {
            if c == '"' && prev != '\\' {
                quoted = !quoted;
            } else if !quoted {
                out.push(c);
            }
            prev = c;
        }
        out.push('\n');
    }
    out
}

/// Edges between files (by module path), CLI included.
fn file_graph() -> BTreeMap<PathBuf, BTreeSet<PathBuf>> {
    let mut all = Vec::new();
    files(&src(), &mut all);
    let modules: BTreeMap<Vec<String>, PathBuf> = all
        .iter()
        .filter(|f| !f.ends_with("main.rs"))
        .map(|f| (module_of(f), f.clone()))
        .collect();
    let mut graph: BTreeMap<PathBuf, BTreeSet<PathBuf>> = BTreeMap::new();
    for f in &all {
        let text = code(&std::fs::read_to_string(f).unwrap());
        let here = module_of(f);
        // A `mod.rs` is its folder's module: `super` is the folder's parent.
        let parent: Vec<String> = here[..here.len().saturating_sub(1)].to_vec();
        let mut targets = Vec::new();
        for p in paths_after(&text, "crate::") {
            targets.push(p);
        }
        for p in paths_after(&text, "super::") {
            let mut full = parent.clone();
            full.extend(p);
            targets.push(full);
        }
        for p in paths_after(&text, "self::") {
            let mut full = here.clone();
            full.extend(p);
            targets.push(full);
        }
        let entry = graph.entry(f.clone()).or_default();
        for t in targets {
            if let Some(to) = file_of(&modules, &t)
                && &to != f
                && !to.ends_with("lib.rs")
            {
                entry.insert(to);
            }
        }
    }
    graph
}

/// A cycle of `graph`, if any (depth-first search).
fn cycle<T: Ord + Clone>(graph: &BTreeMap<T, BTreeSet<T>>) -> Option<Vec<T>> {
    fn visit<T: Ord + Clone>(
        n: &T,
        g: &BTreeMap<T, BTreeSet<T>>,
        state: &mut BTreeMap<T, u8>,
        stack: &mut Vec<T>,
    ) -> Option<Vec<T>> {
        state.insert(n.clone(), 1);
        stack.push(n.clone());
        for m in g.get(n).into_iter().flatten() {
            match state.get(m).copied().unwrap_or(0) {
                1 => {
                    let from = stack.iter().position(|x| x == m).unwrap();
                    let mut c = stack[from..].to_vec();
                    c.push(m.clone());
                    return Some(c);
                }
                0 => {
                    if let Some(c) = visit(m, g, state, stack) {
                        return Some(c);
                    }
                }
                _ => {}
            }
        }
        stack.pop();
        state.insert(n.clone(), 2);
        None
    }
    let mut state = BTreeMap::new();
    for n in graph.keys() {
        if state.get(n).copied().unwrap_or(0) == 0 {
            let mut stack = Vec::new();
            if let Some(c) = visit(n, graph, &mut state, &mut stack) {
                return Some(c);
            }
        }
    }
    None
}

/// Every group of nodes that reach each other (strongly connected, two or more), as the
/// message of a failure.
fn tangles<T: Ord + Clone>(graph: &BTreeMap<T, BTreeSet<T>>) -> Vec<Vec<T>> {
    let nodes: BTreeSet<T> = graph
        .iter()
        .flat_map(|(a, bs)| std::iter::once(a.clone()).chain(bs.iter().cloned()))
        .collect();
    let reach = |from: &T| {
        let mut seen = BTreeSet::new();
        let mut todo = vec![from.clone()];
        while let Some(n) = todo.pop() {
            for m in graph.get(&n).into_iter().flatten() {
                if seen.insert(m.clone()) {
                    todo.push(m.clone());
                }
            }
        }
        seen
    };
    let reached: BTreeMap<T, BTreeSet<T>> = nodes.iter().map(|n| (n.clone(), reach(n))).collect();
    let mut out: Vec<Vec<T>> = Vec::new();
    for n in &nodes {
        if out.iter().any(|g| g.contains(n)) {
            continue;
        }
        let group: Vec<T> = nodes
            .iter()
            .filter(|m| *m == n || (reached[n].contains(*m) && reached[*m].contains(n)))
            .cloned()
            .collect();
        if group.len() > 1 {
            out.push(group);
        }
    }
    out
}

fn show(p: &Path) -> String {
    p.strip_prefix(src()).unwrap().display().to_string()
}

#[test]
fn no_cycle_between_files() {
    let g = file_graph();
    if let Some(c) = cycle(&g) {
        let names: Vec<String> = c.iter().map(|p| show(p)).collect();
        let groups: Vec<String> = tangles(&g)
            .iter()
            .map(|t| t.iter().map(|p| show(p)).collect::<Vec<_>>().join(", "))
            .collect();
        panic!(
            "a cycle between files: {}\nfiles that reach each other:\n  {}",
            names.join(" -> "),
            groups.join("\n  ")
        );
    }
}

#[test]
fn no_cycle_between_top_level_modules() {
    let top = |p: &PathBuf| module_of(p).first().cloned().unwrap_or_default();
    let mut g: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for (from, tos) in file_graph() {
        let a = top(&from);
        for to in tos {
            let b = top(&to);
            if a != b {
                g.entry(a.clone()).or_default().insert(b);
            }
        }
    }
    if let Some(c) = cycle(&g) {
        let groups: Vec<String> = tangles(&g).iter().map(|t| t.join(", ")).collect();
        panic!(
            "a cycle between top-level modules: {}\nmodules that reach each other:\n  {}",
            c.join(" -> "),
            groups.join("\n  ")
        );
    }
}

/// The parser of this test: groups, `super`, and nested paths resolve as rustc would.
#[test]
fn paths_are_read_with_their_groups() {
    let p = paths_after("use crate::{model::{Robot, file::line_of}, io};", "crate::");
    assert_eq!(
        p,
        vec![
            vec!["model".to_string(), "Robot".into()],
            vec!["model".into(), "file".into(), "line_of".into()],
            vec!["io".into()],
        ]
    );
    let g: BTreeMap<u8, BTreeSet<u8>> = [(1, [2].into()), (2, [3].into()), (3, [1].into())].into();
    assert_eq!(cycle(&g), Some(vec![1, 2, 3, 1]));
    let g: BTreeMap<u8, BTreeSet<u8>> = [(1, [2].into()), (2, [3].into())].into();
    assert_eq!(cycle(&g), None);
}

/// The layers of the library, lowest first (issue 13): a module may use its own layer and
/// the ones below, never one above.
const LAYERS: &[&[&str]] = &[
    &["error", "io", "stats"],
    &["geometry"],
    &["model"],
    &["kinematics"],
    &["data"],
    &["identify", "sim", "evaluate"],
    &["plan"],
    &["neural"],
    &["compensation"],
    &["plot"],
    &["studies"],
    &["reports"],
    &["cli"],
];

#[test]
fn layers_run_one_way() {
    let layer = |m: &str| LAYERS.iter().position(|l| l.contains(&m));
    let top = |p: &PathBuf| module_of(p).first().cloned().unwrap_or_default();
    let mut wrong = BTreeSet::new();
    let mut unknown = BTreeSet::new();
    for (from, tos) in file_graph() {
        let a = top(&from);
        for to in tos {
            let b = top(&to);
            match (layer(&a), layer(&b)) {
                (Some(x), Some(y)) if y > x => {
                    wrong.insert(format!("{} -> {} ({a} uses {b})", show(&from), show(&to)));
                }
                (None, _) => {
                    unknown.insert(a.clone());
                }
                (_, None) => {
                    unknown.insert(b.clone());
                }
                _ => {}
            }
        }
    }
    assert!(unknown.is_empty(), "modules without a layer: {unknown:?}");
    assert!(
        wrong.is_empty(),
        "uses of a higher layer:\n  {}",
        wrong.into_iter().collect::<Vec<_>>().join("\n  ")
    );
}
