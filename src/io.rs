//! File output that never leaves a half-written file behind.

use crate::error::{Error, Location, Result};
use std::io::Write;
use std::path::Path;

/// Writes `bytes` to `path` through a temporary file in the same folder and a rename, so that
/// a reader sees either the old file or the whole new one.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    let mut tmp = tempfile::NamedTempFile::new_in(dir).map_err(|e| Error::io(dir, e))?;
    tmp.write_all(bytes).map_err(|e| Error::io(path, e))?;
    tmp.as_file().sync_all().map_err(|e| Error::io(path, e))?;
    tmp.persist(path).map_err(|e| Error::io(path, e.error))?;
    Ok(())
}

/// Reads a text file, naming it in the error.
pub fn read_text(path: &Path) -> Result<String> {
    std::fs::read_to_string(path).map_err(|e| Error::io(path, e))
}

/// Parses TOML text into `T`; a syntax or type error names the file, the line and the key.
pub fn parse_toml<T: serde::de::DeserializeOwned>(text: &str, path: &Path) -> Result<T> {
    toml::from_str(text).map_err(|e| {
        let (line, field) = match e.span() {
            Some(s) => (
                Some(crate::model::file::line_of(text, s.start)),
                key_at(text, s),
            ),
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
