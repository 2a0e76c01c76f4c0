//! A CSV table read whole, with the line of every row, so that every error can name the file,
//! the line and the column.

use crate::error::{Error, IN_MEMORY, Location, Result};
use std::path::{Path, PathBuf};

/// A CSV file: header row and text cells.
#[derive(Debug, Clone)]
pub struct Table {
    /// The file read ([`IN_MEMORY`] for text given in code); errors name it.
    pub path: PathBuf,
    /// Column names from the header row.
    pub headers: Vec<String>,
    /// Text cells of each data row, one per header.
    pub rows: Vec<Vec<String>>,
    /// 1-based file line of each row.
    pub lines: Vec<usize>,
    /// Numbers use a decimal comma (`1,5`), as European exports do.
    pub decimal_comma: bool,
    /// Rows left out of `rows` because their cell count differs from the header's or a cell
    /// is not UTF-8 text: (line, message). [`Table::read`] makes the first one an error, [`Table::parse_rows`]
    /// unless an earlier line is bad; measurement reading does the latter, or drops and lists
    /// them (`--skip-bad-rows`).
    pub malformed: Vec<(usize, String)>,
}

/// The byte offset of a quote that opens a cell and is never closed, as the csv crate reads
/// quotes: one opens a cell only as its first byte, two in a quoted cell are one quote, and
/// one closes it. The crate takes the rest of the file into such a cell without a word.
fn unclosed_quote(bytes: &[u8], delimiter: u8) -> Option<usize> {
    let mut open: Option<usize> = None;
    let mut cell_start = true;
    let mut i = if bytes.starts_with(b"\xef\xbb\xbf") {
        3
    } else {
        0
    };
    while i < bytes.len() {
        let b = bytes[i];
        if open.is_some() {
            if b == b'"' {
                if bytes.get(i + 1) == Some(&b'"') {
                    i += 1;
                } else {
                    open = None;
                    cell_start = false;
                }
            }
        } else if b == b'"' && cell_start {
            open = Some(i);
        } else {
            cell_start = b == delimiter || b == b'\n' || b == b'\r';
        }
        i += 1;
    }
    open
}

/// The byte offset of every line end of `bytes`: a line feed, a carriage return followed by
/// one (counted once, at the feed) or a carriage return alone (the line end of old Mac and
/// some spreadsheet exports, which the csv crate reads as one too).
fn line_ends(bytes: &[u8]) -> Vec<usize> {
    (0..bytes.len())
        .filter(|&i| bytes[i] == b'\n' || (bytes[i] == b'\r' && bytes.get(i + 1) != Some(&b'\n')))
        .collect()
}

impl Table {
    /// Reads a comma-separated file with one header row. Every row must have as many cells
    /// as the header, each UTF-8 text; header names must be unique; blank lines, and rows
    /// whose every cell is empty, are skipped.
    /// Lines end with a line feed, a carriage return and line feed, or a carriage return alone.
    pub fn read(path: impl AsRef<Path>) -> Result<Table> {
        let t = Table::read_keeping_malformed(path)?;
        t.reject_malformed()?;
        Ok(t)
    }

    /// [`Table::read`], but rows whose cell count differs from the header's (or with a cell
    /// that is not UTF-8) are kept in `malformed` for [`Table::parse_rows`] to report in line order (after a bad cell on an
    /// earlier line). A file whose rows are all malformed is refused here.
    pub fn read_keeping_malformed(path: impl AsRef<Path>) -> Result<Table> {
        let path = path.as_ref();
        let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
        let t = Table::parse(&bytes, path, b',', false)?;
        t.require_rows()?;
        Ok(t)
    }

    /// Each row parsed by `parse` (given its index), in file order. The first bad line is
    /// the error, be it a cell `parse` refuses or a row of the wrong length ([`Table::malformed`]).
    pub fn parse_rows<T>(&self, mut parse: impl FnMut(usize) -> Result<T>) -> Result<Vec<T>> {
        let first_malformed = self.malformed.first().map_or(usize::MAX, |(line, _)| *line);
        let mut out = Vec::with_capacity(self.rows.len());
        for r in 0..self.rows.len() {
            if self.lines[r] > first_malformed {
                break;
            }
            out.push(parse(r)?);
        }
        self.reject_malformed()?;
        Ok(out)
    }

    /// A comma-separated table given as text (in code), with the rules of [`Table::read`];
    /// errors name it [`IN_MEMORY`].
    pub fn from_text(text: &str) -> Result<Table> {
        Table::checked(text.as_bytes(), Path::new(IN_MEMORY))
    }

    fn checked(bytes: &[u8], path: &Path) -> Result<Table> {
        let t = Table::parse(bytes, path, b',', false)?;
        t.reject_malformed()?;
        t.require_rows()?;
        Ok(t)
    }

    /// Refuses a table without data rows (naming its first malformed row, if it has one).
    fn require_rows(&self) -> Result<()> {
        if !self.rows.is_empty() {
            return Ok(());
        }
        self.reject_malformed()?;
        // A header alone is a file cut short or a template, never an empty batch to skip.
        Err(Error::input(
            Location::file(&self.path),
            "no data rows (only a header or nothing at all)",
        ))
    }

    /// The first malformed row as an error, if there is one.
    pub fn reject_malformed(&self) -> Result<()> {
        match self.malformed.first() {
            Some((line, msg)) => Err(Error::input(
                Location {
                    file: self.path.clone(),
                    line: Some(*line),
                    field: None,
                },
                msg.clone(),
            )),
            None => Ok(()),
        }
    }

    /// Reads a file with the given delimiter and decimal separator.
    pub fn read_with(path: impl AsRef<Path>, delimiter: u8, decimal_comma: bool) -> Result<Table> {
        let path = path.as_ref();
        let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
        Table::parse(&bytes, path, delimiter, decimal_comma)
    }

    /// Parses CSV bytes; `path` is used in messages.
    pub fn parse(bytes: &[u8], path: &Path, delimiter: u8, decimal_comma: bool) -> Result<Table> {
        // The csv crate reads the rest of the file, from a quote never closed, into one cell:
        // refused at once (also under --skip-bad-rows: it is not one bad row but all after).
        if let Some(at) = unclosed_quote(bytes, delimiter) {
            let line = 1 + line_ends(bytes).partition_point(|&p| p < at);
            return Err(Error::input(
                Location {
                    file: path.to_path_buf(),
                    line: Some(line),
                    field: None,
                },
                "malformed CSV: a quoted cell opened here is never closed (a missing '\"'?), \
                 which would take the rest of the file",
            ));
        }
        // Records as bytes: a cell that is not UTF-8 text is then one bad row, named by its
        // line and column (and dropped under --skip-bad-rows), not the whole file refused.
        // Cells are trimmed as text below (Unicode white space, as the crate's text records).
        let mut rdr = csv::ReaderBuilder::new()
            .delimiter(delimiter)
            .has_headers(true)
            .flexible(true)
            .from_reader(bytes);
        // The csv crate does not count the blank lines it skips, so lines come from offsets.
        // A record after blank lines is reported at the first blank line: skip them.
        let newlines = line_ends(bytes);
        let line_at = |byte: u64| {
            let mut end = (byte as usize).min(bytes.len());
            while end < bytes.len() && (bytes[end] == b'\n' || bytes[end] == b'\r') {
                end += 1;
            }
            newlines.partition_point(|&p| p < end) + 1
        };
        let csv_err = |e: csv::Error| {
            let line = e.position().map(|p| line_at(p.byte()));
            Error::input(
                Location {
                    file: path.to_path_buf(),
                    line,
                    field: None,
                },
                format!("malformed CSV: {e}"),
            )
        };
        let header = rdr.byte_headers().map_err(csv_err)?.clone();
        let mut headers = Vec::with_capacity(header.len());
        for (i, h) in header.iter().enumerate() {
            let Ok(h) = std::str::from_utf8(h) else {
                return Err(Error::input(
                    Location::at(path, 1, format!("#{}", i + 1)),
                    "a column name is not UTF-8 text: save the file as UTF-8 (or plain ASCII)",
                ));
            };
            headers.push(h.trim().trim_start_matches('\u{feff}').trim().to_string());
        }
        if headers.iter().all(|h| h.is_empty()) {
            return Err(Error::input(
                Location::file(path),
                "empty file: a header row is needed",
            ));
        }
        // A set, not a scan of the names before: `evaluate` on a header of 200,000 columns
        // took 42 s, now 0.11 s.
        let mut seen = std::collections::HashSet::with_capacity(headers.len());
        for (i, h) in headers.iter().enumerate() {
            if h.is_empty() {
                let last = i + 1 == headers.len();
                return Err(Error::input(
                    Location::at(path, 1, format!("#{}", i + 1)),
                    if last {
                        "empty column name in the header (a delimiter at the end of the line?)"
                    } else {
                        "empty column name in the header"
                    },
                ));
            }
            if !seen.insert(h.as_str()) {
                return Err(Error::input(
                    Location::at(path, 1, h.clone()),
                    "duplicate column name in the header",
                ));
            }
        }
        let mut rows = Vec::new();
        let mut lines = Vec::new();
        let mut malformed = Vec::new();
        for rec in rdr.byte_records() {
            let rec = rec.map_err(csv_err)?;
            let line = rec.position().map_or(0, |p| line_at(p.byte()));
            let cells: Vec<std::result::Result<&str, _>> = rec
                .iter()
                .map(|c| std::str::from_utf8(c).map(str::trim))
                .collect();
            // A row of delimiters alone (`;;;;`, which spreadsheets leave after the data)
            // holds no more than a blank line.
            if cells.iter().all(|c| matches!(c, Ok(""))) {
                continue;
            }
            if let Some(c) = cells.iter().position(|c| c.is_err()) {
                let column = headers
                    .get(c)
                    .map_or_else(|| format!("cell {}", c + 1), |h| format!("column `{h}`"));
                malformed.push((
                    line,
                    format!(
                        "{column}: the cell is not UTF-8 text (a file saved in another encoding, \
                         e.g. Windows-1252 or Latin-1?): save it as UTF-8"
                    ),
                ));
                continue;
            }
            if rec.len() != headers.len() {
                let msg = format!(
                    "{} cells, but the header has {} columns",
                    rec.len(),
                    headers.len()
                );
                malformed.push((line, msg));
                continue;
            }
            rows.push(cells.into_iter().flatten().map(str::to_string).collect());
            lines.push(line);
        }
        Ok(Table {
            path: path.to_path_buf(),
            headers,
            rows,
            lines,
            decimal_comma,
            malformed,
        })
    }

    /// Index of a column, if present.
    pub fn column(&self, name: &str) -> Option<usize> {
        self.headers.iter().position(|h| h == name)
    }

    /// Index of a column that must be present.
    pub fn require(&self, name: &str) -> Result<usize> {
        self.column(name).ok_or_else(|| {
            Error::input(
                Location::at(&self.path, 1, name),
                format!(
                    "missing column (the header has: {}){}{}",
                    self.header_list(),
                    self.delimiter_hint(),
                    self.case_hint(name)
                ),
            )
        })
    }

    /// The header's names as messages show them, comma-separated.
    pub fn header_list(&self) -> String {
        (self.headers.iter().map(|h| shown(h)))
            .collect::<Vec<_>>()
            .join(", ")
    }

    /// The header's name that differs from `name` in letter case only, if any (an export
    /// written in capitals).
    pub fn other_case(&self, name: &str) -> Option<&str> {
        (self.headers.iter())
            .find(|h| h.as_str() != name && h.eq_ignore_ascii_case(name))
            .map(String::as_str)
    }

    /// A hint for a column `name` the header holds in other letter case (an export written in
    /// capitals): "; `SHOULDER_PAN_JOINT` differs only in case (names are case-sensitive)",
    /// else empty.
    pub fn case_hint(&self, name: &str) -> String {
        self.other_case(name).map_or_else(String::new, |h| {
            format!(
                "; {} differs only in case (column names are case-sensitive)",
                shown(h)
            )
        })
    }

    /// A hint for a header read as one column that holds another delimiter (`;`, a tab, `|`):
    /// "; the header is one column holding `;`: set delimiter = ";" in a profile (...)", else
    /// empty.
    pub fn delimiter_hint(&self) -> String {
        match &self.headers[..] {
            [h] => [';', '\t', '|', ',']
                .into_iter()
                .find(|&c| h.contains(c))
                .map(|c| {
                    let shown = if c == '\t' {
                        "\\t".to_string()
                    } else {
                        c.to_string()
                    };
                    format!(
                        "; the header is one column holding `{shown}`: set delimiter = \"{shown}\" \
                         in a profile (--profile, where the command reads measurements), or \
                         write the file with commas"
                    )
                })
                .unwrap_or_default(),
            _ => String::new(),
        }
    }

    /// Location of a cell, for messages.
    pub fn location(&self, row: usize, col: usize) -> Location {
        Location::at(&self.path, self.lines[row], self.headers[col].clone())
    }

    /// A cell as a finite number (with a decimal comma when the table has one).
    pub fn number(&self, row: usize, col: usize) -> Result<f64> {
        let cell = &self.rows[row][col];
        let parsed = if self.decimal_comma {
            // A point in a file of decimal commas is a thousands separator (`1.234,5`) or a
            // file of other conventions: read as a decimal point, `1.234` would be 1.234,
            // not 1234.
            if cell.contains('.') {
                return Err(Error::input(
                    self.location(row, col),
                    format!(
                        "`{}` has a decimal point, but the profile says the file writes decimal \
                         commas (`decimal_comma = true`)",
                        shown(cell)
                    ),
                ));
            }
            cell.replace(',', ".").parse::<f64>()
        } else {
            cell.parse::<f64>()
        };
        match parsed {
            Ok(v) if v.is_finite() => Ok(v),
            Ok(_) => Err(Error::input(
                self.location(row, col),
                format!("`{}` is not finite", shown(cell)),
            )),
            Err(_) => Err(Error::input(
                self.location(row, col),
                format!("`{}` is not a number", shown(cell)),
            )),
        }
    }

    /// A cell that may be empty: None when empty, else a finite number.
    pub fn optional_number(&self, row: usize, col: usize) -> Result<Option<f64>> {
        if self.rows[row][col].is_empty() {
            Ok(None)
        } else {
            self.number(row, col).map(Some)
        }
    }

    /// Several cells of one row as finite numbers; where some are not, the error of the
    /// leftmost in the file (the columns may be asked in another order: orientation angles
    /// about x, y, z from columns rz, ry, rx).
    pub fn numbers(&self, row: usize, cols: &[usize]) -> Result<Vec<f64>> {
        let mut out = Vec::with_capacity(cols.len());
        let mut first: Option<(usize, Error)> = None;
        for &c in cols {
            match self.number(row, c) {
                Ok(v) => out.push(v),
                Err(e) if first.as_ref().is_none_or(|(k, _)| c < *k) => first = Some((c, e)),
                Err(_) => {}
            }
        }
        match first {
            Some((_, e)) => Err(e),
            None => Ok(out),
        }
    }
}

/// A cell as messages show it: at most 40 characters, then an ellipsis and the full length
/// (a 1 MB cell is not echoed whole).
pub fn shown(cell: &str) -> String {
    const MAX: usize = 40;
    let n = cell.chars().count();
    if n <= MAX {
        cell.to_string()
    } else {
        let head: String = cell.chars().take(MAX).collect();
        format!("{head}... ({n} characters)")
    }
}

/// Builds CSV output in memory; see [`crate::io::write_atomic`] to put it in a file.
pub struct CsvOut {
    w: csv::Writer<Vec<u8>>,
}

impl CsvOut {
    /// Starts the output with the header row `headers`.
    pub fn new(headers: &[String]) -> Result<Self> {
        let mut w = csv::Writer::from_writer(Vec::new());
        w.write_record(headers)
            .map_err(|e| Error::Invalid(format!("CSV output: {e}")))?;
        Ok(CsvOut { w })
    }

    /// Appends one row of cells.
    pub fn row(&mut self, cells: &[String]) -> Result<()> {
        self.w
            .write_record(cells)
            .map_err(|e| Error::Invalid(format!("CSV output: {e}")))
    }

    /// The CSV text written so far.
    pub fn into_bytes(self) -> Result<Vec<u8>> {
        self.w
            .into_inner()
            .map_err(|e| Error::Invalid(format!("CSV output: {e}")))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(s: &str) -> Result<Table> {
        Table::parse(s.as_bytes(), Path::new("d.csv"), b',', false)
    }

    #[test]
    fn decimal_commas_and_semicolons() {
        let t = Table::parse(
            "a;b\n1,5;-2,25E+1\n".as_bytes(),
            Path::new("e.csv"),
            b';',
            true,
        )
        .unwrap();
        assert_eq!(t.number(0, 0).unwrap(), 1.5);
        assert_eq!(t.number(0, 1).unwrap(), -22.5);
        // A point there is not a decimal point: refused where it stands.
        let t = Table::parse(
            "a;b
1,5;1.234
"
            .as_bytes(),
            Path::new("e.csv"),
            b';',
            true,
        )
        .unwrap();
        let e = t.number(0, 1).unwrap_err().to_string();
        assert!(e.contains("e.csv:2") && e.contains("decimal point"), "{e}");
    }

    #[test]
    fn a_quote_never_closed_is_refused_where_it_opens() {
        // As the csv crate reads quotes: the cells below are read alike by it and by the scan.
        for ok in [
            "id,q1\n\"a\",1\n",
            "id,q1\n\"a \"\"b\"\"\",1\n",
            "id,q1\nab\"c,1\n",
            "id,q1\n\"a,\nb\",1\n",
            "\u{feff}\"id\",q1\na,1\n",
        ] {
            assert!(parse(ok).is_ok(), "{ok:?}");
            assert_eq!(unclosed_quote(ok.as_bytes(), b','), None, "{ok:?}");
        }
        let e = parse("id,q1\na,1\n\"b,2\n").unwrap_err().to_string();
        assert!(e.contains("d.csv:3") && e.contains("never closed"), "{e}");
        // After a multi-line cell, its own line; a lone quote on the last line; the header.
        let e = parse("id,q1\n\"a\nb\",1\n\nc,\"2\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("d.csv:5") && e.contains("never closed"), "{e}");
        let e = parse("id,q1\na,1\n\"\n").unwrap_err().to_string();
        assert!(e.contains("d.csv:3") && e.contains("never closed"), "{e}");
        let e = parse("id,\"q1\na,1\n").unwrap_err().to_string();
        assert!(e.contains("d.csv:1") && e.contains("never closed"), "{e}");
        let semicolons = |s: &str| Table::parse(s.as_bytes(), Path::new("d.csv"), b';', false);
        let e = semicolons("id;q1\na;\"1\n").unwrap_err().to_string();
        assert!(e.contains("never closed"), "{e}");
        assert!(semicolons("id;q1\na;\"1\"\n").is_ok());
        // With commas between cells, that quote is inside the cell `a;"1`: a letter.
        assert!(parse("id;q1\na;\"1\n").is_ok());
    }

    #[test]
    fn a_bad_cell_before_a_malformed_row_is_the_error() {
        let t = parse("id,q1\na,x\nb,1,2\n").unwrap();
        let e = t.parse_rows(|r| t.number(r, 1)).unwrap_err().to_string();
        assert!(e.contains("d.csv:2") && e.contains("`x`"), "{e}");
        let t = parse("id,q1\na,1\nb,1,2\nc,x\n").unwrap();
        let e = t.parse_rows(|r| t.number(r, 1)).unwrap_err().to_string();
        assert!(e.contains("d.csv:3") && e.contains("3 cells"), "{e}");
        let t = parse("id,q1\na,1\nb,2\n").unwrap();
        assert_eq!(t.parse_rows(|r| t.number(r, 1)).unwrap(), vec![1.0, 2.0]);
    }

    #[test]
    fn rows_keep_their_file_lines() {
        let t = parse("id,q1\na,1\n\nb,2\n").unwrap();
        assert_eq!(t.rows.len(), 2);
        assert_eq!(t.lines, vec![2, 4]);
        assert_eq!(t.number(1, 1).unwrap(), 2.0);
    }

    #[test]
    fn rows_of_empty_cells_are_skipped_as_blank_lines() {
        // A spreadsheet's trailing rows of delimiters, with and without spaces, and one of
        // another length; a row with one cell filled is data (and its empty cells errors).
        let t = parse("id,q1,q2\na,1,2\n,,\n , ,\nb,3,4\n,\n,,,\n").unwrap();
        assert_eq!(t.lines, vec![2, 5]);
        assert!(t.malformed.is_empty());
        let t = parse("id,q1,q2\na,1,2\n,,5\n").unwrap();
        assert_eq!(t.lines, vec![2, 3]);
        let e = t.number(1, 1).unwrap_err().to_string();
        assert!(e.contains("d.csv:3"), "{e}");
    }

    #[test]
    fn lines_end_with_a_feed_a_return_and_feed_or_a_return_alone() {
        // The same table with the three line ends (and blank lines): the same lines.
        for end in ["\n", "\r\n", "\r"] {
            let text = ["id,q1", "a,1", "", "b,2", "c,x", ""].join(end);
            let t = parse(&text).unwrap();
            assert_eq!(t.lines, vec![2, 4, 5], "{end:?}");
            let e = t.number(2, 1).unwrap_err().to_string();
            assert!(e.contains("d.csv:5"), "{end:?}: {e}");
            let e = parse(&["id,q1", "a,1", "b,\"2"].join(end))
                .unwrap_err()
                .to_string();
            assert!(
                e.contains("d.csv:3") && e.contains("never closed"),
                "{end:?}: {e}"
            );
        }
    }

    #[test]
    fn a_cell_that_is_not_utf8_is_one_bad_row_named_by_line_and_column() {
        // 0xE9 is e-acute in Latin-1, no UTF-8 on its own.
        let bytes = b"id,q1,note\na,1,ok\nb,2,caf\xe9\nc,3,ok\n";
        let t = Table::parse(bytes, Path::new("d.csv"), b',', false).unwrap();
        assert_eq!(t.lines, vec![2, 4]);
        assert_eq!(t.rows[1], vec!["c", "3", "ok"]);
        let e = t.reject_malformed().unwrap_err().to_string();
        assert!(
            e.contains("d.csv:3") && e.contains("`note`") && e.contains("not UTF-8"),
            "{e}"
        );
        let e = Table::parse(b"id,q\xe91\na,1\n", Path::new("d.csv"), b',', false)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("d.csv:1") && e.contains("#2") && e.contains("UTF-8"),
            "{e}"
        );
        // Cells are trimmed of Unicode white space, as before (a no-break space here).
        let t = parse("id , q1\n a ,\u{a0}1\u{a0}\n").unwrap();
        assert_eq!((t.headers[1].as_str(), t.rows[0][1].as_str()), ("q1", "1"));
    }

    #[test]
    fn errors_name_file_line_and_column() {
        let t = parse("id,q1\na,1\nb,x\n").unwrap();
        let e = t.number(1, 1).unwrap_err().to_string();
        assert!(
            e.contains("d.csv:3") && e.contains("q1") && e.contains("`x`"),
            "{e}"
        );
        let e = parse("id,q1\na,1\nb,inf\n")
            .unwrap()
            .number(1, 1)
            .unwrap_err()
            .to_string();
        assert!(e.contains("not finite"), "{e}");
        let e = parse("id,q1\na,1,3\n")
            .unwrap()
            .reject_malformed()
            .unwrap_err()
            .to_string();
        assert!(e.contains("d.csv:2") && e.contains("3 cells"), "{e}");
        let e = parse("q1,q1\n1,2\n").unwrap_err().to_string();
        assert!(e.contains("duplicate") && e.contains("q1"), "{e}");
        let e = parse("id\n1\n")
            .unwrap()
            .require("q1")
            .unwrap_err()
            .to_string();
        assert!(e.contains("missing column") && e.contains("q1"), "{e}");
    }
}
