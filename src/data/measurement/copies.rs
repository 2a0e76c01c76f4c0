//! Rows that are copies of an earlier row: the same joints and the same measurement to every
//! bit. A laser tracker never reads a point twice to the last digit, so such a row is a line
//! pasted twice (two exports concatenated), not a repeat measurement: it weighs its pose twice
//! in identification and, counted as a repeat, halves the pure error a repeat states.

use super::Measurement;
use std::collections::HashMap;

/// The bits a copy shares with its original: joints, position, orientation and distance
/// (rad or mm; the orientation's matrix entries). None for a row that measures nothing.
fn key(m: &Measurement) -> Option<Vec<u64>> {
    if m.position.is_none() && m.rotation.is_none() && m.distance.is_none() {
        return None;
    }
    let mut k: Vec<u64> = m.q.iter().map(|v| v.to_bits()).collect();
    // A marker per part, so that a missing part never matches a present one.
    if let Some(p) = m.position {
        k.push(1);
        k.extend(p.iter().map(|v| v.to_bits()));
    }
    if let Some(r) = m.rotation {
        k.push(2);
        k.extend(r.matrix().iter().map(|v| v.to_bits()));
    }
    if let Some(d) = m.distance {
        k.push(3);
        k.push(d.to_bits());
    }
    Some(k)
}

/// For each row that copies an earlier one ([`key`] equal), the index of that earlier (first)
/// row and its own, in file order.
pub fn copied_rows(rows: &[Measurement]) -> Vec<(usize, usize)> {
    let mut first: HashMap<Vec<u64>, usize> = HashMap::with_capacity(rows.len());
    let mut copies = Vec::new();
    for (i, m) in rows.iter().enumerate() {
        let Some(k) = key(m) else { continue };
        match first.get(&k) {
            Some(&o) => copies.push((o, i)),
            None => {
                first.insert(k, i);
            }
        }
    }
    copies
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Vector3;

    fn row(q: f64, x: f64) -> Measurement {
        let mut m = Measurement::new(vec![q, 0.2]);
        m.position = Some(Vector3::new(x, 1.0, 2.0));
        m
    }

    #[test]
    fn only_bit_equal_measured_rows_are_copies() {
        let mut rows = vec![
            row(0.1, 5.0),
            row(0.1, 5.0 + 1e-12),
            row(0.1, 5.0),
            row(0.3, 5.0),
        ];
        // A re-measurement (last digit differs) and another configuration are not copies.
        assert_eq!(copied_rows(&rows), vec![(0, 2)]);
        // Rows measuring nothing (joints alone) are never copies.
        rows.push(Measurement::new(vec![0.5, 0.5]));
        rows.push(Measurement::new(vec![0.5, 0.5]));
        assert_eq!(copied_rows(&rows), vec![(0, 2)]);
        // Three copies: each later one names the first.
        rows.push(row(0.1, 5.0));
        assert_eq!(copied_rows(&rows), vec![(0, 2), (0, 6)]);
    }
}
