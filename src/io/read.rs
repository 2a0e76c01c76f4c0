//! Reading input files: text (refused by line where it is not UTF-8), size-capped bytes, and
//! TOML whose errors name the file, the line and the key.

use crate::error::{Error, Location, Result};
use std::path::Path;

/// `text` without the byte-order mark some Windows editors put before UTF-8 (not part of
/// JSON or CSV).
pub fn without_bom(text: &str) -> &str {
    text.strip_prefix('\u{feff}').unwrap_or(text)
}

/// Reads a regular file of at most `cap` bytes: a device (`/dev/zero`), a folder or a larger
/// file is refused by name instead of read until memory runs out.
pub fn read_capped(path: &Path, cap: u64) -> Result<Vec<u8>> {
    use std::io::Read;
    // Checked before opening: opening a FIFO blocks until a writer comes.
    let meta = std::fs::metadata(path).map_err(|e| Error::io(path, e))?;
    if !meta.is_file() {
        return Err(Error::Invalid(format!(
            "{}: not a regular file",
            path.display()
        )));
    }
    let file = std::fs::File::open(path).map_err(|e| Error::io(path, e))?;
    let mut bytes = Vec::new();
    file.take(cap + 1)
        .read_to_end(&mut bytes)
        .map_err(|e| Error::io(path, e))?;
    if bytes.len() as u64 > cap {
        return Err(Error::Invalid(format!(
            "{}: larger than {} MB",
            path.display(),
            cap >> 20
        )));
    }
    Ok(bytes)
}

/// Reads a text file, naming it in the error.
/// Invalid UTF-8 is refused with its line.
pub fn read_text(path: &Path) -> Result<String> {
    let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    String::from_utf8(bytes).map_err(|e| {
        let at = e.utf8_error().valid_up_to();
        let before = &e.as_bytes()[..at];
        let line = before.iter().filter(|&&b| b == b'\n').count() + 1;
        let column = at
            - before
                .iter()
                .rposition(|&b| b == b'\n')
                .map_or(0, |p| p + 1)
            + 1;
        Error::input(
            Location {
                file: path.to_path_buf(),
                line: Some(line),
                field: None,
            },
            format!("invalid UTF-8 at byte {column} of the line"),
        )
    })
}

/// 1-based line of a byte offset of `text`.
pub fn line_of(text: &str, offset: usize) -> usize {
    text.as_bytes()[..offset.min(text.len())]
        .iter()
        .filter(|&&b| b == b'\n')
        .count()
        + 1
}

/// The full dotted name (`tool.d`) and the 1-based line of every value (not table) of TOML
/// text, in file order, from the parser's spans: a key under a `[tool]` header, in an inline
/// table or dotted is `tool.<key>`, a quoted `"tool.d"` is `tool.d`. Empty for text that does
/// not parse.
pub fn key_lines(text: &str) -> Vec<(String, usize)> {
    fn walk(
        prefix: &str,
        table: &toml::de::DeTable<'_>,
        text: &str,
        out: &mut Vec<(String, usize)>,
    ) {
        for (k, v) in table {
            let name = if prefix.is_empty() {
                k.get_ref().to_string()
            } else {
                format!("{prefix}.{}", k.get_ref())
            };
            match v.get_ref() {
                toml::de::DeValue::Table(t) => walk(&name, t, text, out),
                _ => out.push((name, line_of(text, k.span().start))),
            }
        }
    }
    let mut out = Vec::new();
    if let Ok(spanned) = toml::de::DeTable::parse(text) {
        walk("", spanned.get_ref(), text, &mut out);
    }
    out
}

/// Parses TOML text into `T`; a syntax or type error names the file, the line and the key.
pub fn parse_toml<T: serde::de::DeserializeOwned>(text: &str, path: &Path) -> Result<T> {
    toml::from_str(text).map_err(|e| {
        let (line, field) = match e.span() {
            Some(s) => (Some(line_of(text, s.start)), key_at(text, s)),
            None => (None, None),
        };
        Error::input(
            Location {
                file: path.to_path_buf(),
                line,
                field,
            },
            e.message().trim().to_string(),
        )
    })
}

/// The key an error span points at: the key itself, or the key of `key = value` when the span
/// is the value.
fn key_at(text: &str, span: std::ops::Range<usize>) -> Option<String> {
    let start = span.start.min(text.len());
    let line_start = text[..start].rfind('\n').map_or(0, |i| i + 1);
    let before = &text[line_start..start];
    if let Some(eq) = before.find('=') {
        let key = before[..eq].trim();
        if !key.is_empty() {
            return Some(key.to_string());
        }
    }
    let snippet = text.get(span)?.trim();
    (!snippet.is_empty() && snippet.len() <= 40 && !snippet.contains('\n'))
        .then(|| snippet.to_string())
}
