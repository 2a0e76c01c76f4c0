//! The rows behind a set's largest errors, and those a compensator makes worse: what a mean
//! or an RMS does not name.

use super::RowError;
use crate::error::Result;
use serde::{Deserialize, Serialize};

/// Rows named by [`worst_rows`] (each list at most this long).
pub const WORST_ROWS: usize = 3;

/// Least rise of a row's error (mm) that [`worst_rows`] counts as raised by a compensator:
/// a tenth of a micrometre, below any tracker's resolution, so that rounding in the last
/// bits of a model the compensator reproduces is not counted as its doing.
pub const RAISED_MM: f64 = 1e-4;

/// One row's error under the model and with a compensator (mm): the position error, or for
/// a pair (relative and distance measures) the error of the displacement's length.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct RowComparison {
    /// Line of the row (of row b for a pair).
    pub line: usize,
    /// The model's error (mm).
    #[serde(with = "crate::io::json_number")]
    pub model_mm: f64,
    /// The error with the compensator (mm); None when none was evaluated.
    #[serde(
        default,
        with = "crate::io::json_number::option",
        skip_serializing_if = "Option::is_none"
    )]
    pub compensated_mm: Option<f64>,
}

/// Where a set's largest errors lie, and where a compensator adds error: the rows behind a
/// max, which a mean or an RMS does not name. Errors as [`RowComparison`]'s (mm).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct WorstRows {
    /// The rows of largest error (the compensator's where one was evaluated, else the
    /// model's), largest first.
    pub largest: Vec<RowComparison>,
    /// With a compensator: the rows whose error it raises most over the model's (by
    /// [`RAISED_MM`] or more), largest rise first; empty when it raises none.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub raised: Vec<RowComparison>,
    /// With a compensator: how many rows' error it raises by [`RAISED_MM`] or more (0
    /// without one).
    #[serde(default)]
    pub rows_raised: usize,
    /// Rows (or pairs) compared: those with a position or length error.
    pub rows: usize,
}

/// The [`WORST_ROWS`] rows of largest error and, given the compensator's errors
/// `compensated` (row for row with `model`: the same set and measure), the rows whose error it
/// raises most; None when no row has a position or length error (measure orientation), there
/// being nothing to name. Rows without one are skipped; ties go to the earlier line. Errors
/// are finite where the files are (both are checked on reading); a not-a-number error would
/// rank first, as the worst a row can have.
pub fn worst_rows(
    model: &[RowError],
    compensated: Option<&[RowError]>,
) -> Result<Option<WorstRows>> {
    if let Some(c) = compensated
        && c.len() != model.len()
    {
        return Err(crate::error::Error::Invalid(format!(
            "worst rows: {} compensated row errors for {} model row errors",
            c.len(),
            model.len()
        )));
    }
    let rows: Vec<RowComparison> = model
        .iter()
        .enumerate()
        .filter_map(|(i, m)| {
            Some(RowComparison {
                line: m.line,
                model_mm: m.position_mm?,
                compensated_mm: match compensated {
                    Some(c) => Some(c[i].position_mm?),
                    None => None,
                },
            })
        })
        .collect();
    if rows.is_empty() {
        return Ok(None);
    }
    let worst_first = |v: f64| if v.is_nan() { f64::INFINITY } else { v };
    let error = |r: &RowComparison| worst_first(r.compensated_mm.unwrap_or(r.model_mm));
    let rise = |r: &RowComparison| worst_first(r.compensated_mm.map_or(0.0, |c| c - r.model_mm));
    // Without a compensator every rise is 0: nothing is raised.
    let raised = |r: &RowComparison| rise(r) >= RAISED_MM;
    let top = |key: &dyn Fn(&RowComparison) -> f64, keep: &dyn Fn(&RowComparison) -> bool| {
        let mut v: Vec<RowComparison> = rows.iter().copied().filter(|r| keep(r)).collect();
        v.sort_by(|a, b| key(b).total_cmp(&key(a)).then(a.line.cmp(&b.line)));
        v.truncate(WORST_ROWS);
        v
    };
    Ok(Some(WorstRows {
        largest: top(&error, &|_| true),
        raised: top(&rise, &raised),
        rows_raised: rows.iter().filter(|r| raised(r)).count(),
        rows: rows.len(),
    }))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(line: usize, mm: Option<f64>) -> RowError {
        RowError {
            line,
            position_mm: mm,
            abs_xyz_mm: None,
            orientation_deg: None,
        }
    }

    #[test]
    fn worst_rows_rank_by_the_compensated_error_and_by_its_rise() {
        // Lines 2..7: model and compensated errors (mm, exact in binary so that ties are
        // ties); line 4 has no position.
        let table = [
            (2, Some(1.0), Some(0.125)),
            (3, Some(0.25), Some(0.625)),
            (4, None, None),
            (5, Some(0.75), Some(1.25)),
            (6, Some(0.5), Some(0.625)),
            (7, Some(0.25), Some(0.625)),
        ];
        let model: Vec<RowError> = table.iter().map(|&(l, m, _)| row(l, m)).collect();
        let net: Vec<RowError> = table.iter().map(|&(l, _, n)| row(l, n)).collect();
        let worst = |c: Option<&[RowError]>| worst_rows(&model, c).unwrap().unwrap();
        let w = worst(Some(&net));
        let lines = |v: &[RowComparison]| v.iter().map(|r| r.line).collect::<Vec<_>>();
        // 1.25 (5), then 0.625 three times: ties to the earlier line (3, 6; 7 is fourth).
        assert_eq!(lines(&w.largest), vec![5, 3, 6]);
        assert_eq!(w.largest[0].model_mm, 0.75);
        assert_eq!(w.largest[0].compensated_mm, Some(1.25));
        // Rises: 5 +0.5, 3 and 7 +0.375 (the earlier first), 6 +0.125; line 2 falls.
        assert_eq!(lines(&w.raised), vec![5, 3, 7]);
        assert_eq!((w.rows_raised, w.rows), (4, 5));
        // The model alone: its own largest, nothing raised.
        let alone = worst(None);
        assert_eq!(lines(&alone.largest), vec![2, 5, 6]);
        assert!(alone.largest.iter().all(|r| r.compensated_mm.is_none()));
        assert!(alone.raised.is_empty());
        assert_eq!((alone.rows_raised, alone.rows), (0, 5));
        // A compensator that lowers every error raises none.
        let lower: Vec<RowError> = model
            .iter()
            .map(|r| row(r.line, r.position_mm.map(|e| e / 2.0)))
            .collect();
        let w = worst(Some(&lower));
        assert!(w.raised.is_empty());
        assert_eq!(w.rows_raised, 0);
        assert_eq!(lines(&w.largest), vec![2, 5, 6]);
        // A rise below RAISED_MM (the last bits of a model reproduced) is not counted.
        let same: Vec<RowError> = model
            .iter()
            .map(|r| row(r.line, r.position_mm.map(|e| e + RAISED_MM / 2.0)))
            .collect();
        let w = worst(Some(&same));
        assert_eq!((w.rows_raised, w.raised.len()), (0, 0));
        // A not-a-number error is the worst.
        let mut broken = net.clone();
        broken[5].position_mm = Some(f64::NAN);
        let w = worst(Some(&broken));
        assert_eq!((w.largest[0].line, w.raised[0].line), (7, 7));
        // Row errors of different sets are refused.
        assert!(worst_rows(&model, Some(&net[..3])).is_err());
        // No position at all: nothing to name.
        assert_eq!(worst_rows(&[row(2, None)], None).unwrap(), None);
    }
}
