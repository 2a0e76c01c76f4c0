//! Pairs of rows for relative-position and distance measurements (thesis 4.3.3).
//!
//! Without a `pair` column, consecutive rows pair up: (1, 2), (2, 3), ... so that n
//! configurations give n - 1 relative measurements, as in the thesis's Case C. With a `pair`
//! column, the two rows that share a label form a pair (the first in the file is a).

use super::measurement::MeasurementSet;
use crate::error::{Error, Location, Result};
use nalgebra::Vector3;
use std::path::Path;

/// One pair: row indices a and b.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Pair {
    /// Index in the set's rows of the pair's first row.
    pub a: usize,
    /// Index in the set's rows of the pair's second row (the one that carries a distance).
    pub b: usize,
}

/// The pairs of a set; consecutive pairing skips the set's chain breaks (a pair across a
/// dropped row was never measured as one step).
pub fn pairs(set: &MeasurementSet) -> Result<Vec<Pair>> {
    let labels: Vec<Option<&str>> = set.rows.iter().map(|m| m.pair.as_deref()).collect();
    let lines: Vec<usize> = set.rows.iter().map(|m| m.line).collect();
    let pairs = pairs_of(&labels, &lines, &set.source)?;
    if labels.iter().any(Option::is_some) || set.chain_breaks.is_empty() {
        return Ok(pairs);
    }
    let kept: Vec<Pair> = (pairs.into_iter())
        .filter(|p| set.chain_breaks.binary_search(&p.b).is_err())
        .collect();
    if kept.is_empty() {
        return Err(Error::input(
            Location::file(&set.source),
            format!(
                "no two consecutive rows are left to pair: rows dropped between all {} \
                 (bad rows skipped, or a subset) break every relative measurement",
                set.rows.len()
            ),
        ));
    }
    Ok(kept)
}

/// The warning for a relative or distance measure on `set` whose consecutive pairing lost
/// pairs across dropped rows (bad rows skipped); None where no pair was lost or a `pair`
/// column labels the pairs.
pub fn broken_pairs_warning(set: &MeasurementSet) -> Option<String> {
    (!set.chain_breaks.is_empty() && set.rows.iter().all(|m| m.pair.is_none())).then(|| {
        format!(
            "{}: the relative and distance measures, which pair consecutive rows in a file \
             without a pair column, leave out the {} pair(s) across the dropped row(s)",
            set.source.display(),
            set.chain_breaks.len()
        )
    })
}

/// The pairs of rows with `pair` labels `labels` (None: no label) on file lines `lines` of
/// `source` (for messages), by the rule of [`pairs`]: consecutive rows where no row has a
/// label, else the two rows of each label.
pub fn pairs_of(labels: &[Option<&str>], lines: &[usize], source: &Path) -> Result<Vec<Pair>> {
    let labelled = labels.iter().flatten().count();
    if labelled == 0 {
        if labels.len() < 2 {
            return Err(Error::input(
                Location::file(source),
                "relative measurements need at least two rows",
            ));
        }
        return Ok((0..labels.len() - 1)
            .map(|k| Pair { a: k, b: k + 1 })
            .collect());
    }
    if let Some(i) = labels.iter().position(Option::is_none) {
        return Err(Error::input(
            Location::at(source, lines[i], "pair"),
            "some rows have a pair label and this one has none",
        ));
    }
    let mut order: Vec<&str> = Vec::new();
    let mut members: Vec<Vec<usize>> = Vec::new();
    for (i, label) in labels.iter().enumerate() {
        let label = label.unwrap_or_default();
        match order.iter().position(|l| *l == label) {
            Some(k) => members[k].push(i),
            None => {
                order.push(label);
                members.push(vec![i]);
            }
        }
    }
    members
        .iter()
        .zip(&order)
        .map(|(rows, label)| match rows.as_slice() {
            [a, b] => Ok(Pair { a: *a, b: *b }),
            _ => Err(Error::input(
                Location::at(source, lines[rows[0]], "pair"),
                format!(
                    "pair `{label}` has {} rows; a pair needs exactly 2",
                    rows.len()
                ),
            )),
        })
        .collect()
}

/// Measured displacement p(a) - p(b) (mm) of a pair, when both rows have positions.
pub fn displacement(set: &MeasurementSet, p: Pair) -> Option<Vector3<f64>> {
    Some(set.rows[p.a].position? - set.rows[p.b].position?)
}

/// Measured distance |p(a) - p(b)| (mm): the ball-bar value on row b, else from positions.
pub fn distance(set: &MeasurementSet, p: Pair) -> Option<f64> {
    set.rows[p.b]
        .distance
        .or_else(|| displacement(set, p).map(|d| d.norm()))
}
