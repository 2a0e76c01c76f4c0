//! A value as a cell of a canonical measurement file (mm, deg): a row read from a file is
//! written as the file gave it, to the bit where a canonical file can hold it, so that the
//! rows `split` and `import` write are rows of their source.

use crate::geometry::rotation::{rotation_to_zyx, zyx_to_rotation};
use nalgebra::Rotation3;

/// A number as a cell (mm, deg): shortest round-trip text, -0 (an angle of an exact rotation,
/// say) written 0.
pub(super) fn number_cell(v: f64) -> String {
    format!("{}", if v == 0.0 { 0.0 } else { v })
}

/// `v` (file units) with `d` decimals, trailing zeros dropped, -0 as 0.
fn fixed(v: f64, d: usize) -> String {
    let s = format!("{v:.d$}");
    let s = if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.')
    } else {
        &s
    };
    if s == "-0" { "0".into() } else { s.into() }
}

/// An internal value (rad) as a cell in degrees that reads back to the same bits. The
/// degrees whose radians are it form an interval of doubles near its own degrees (the trip
/// through radians moves a value by an ulp or two: -86.30847727262889 deg comes back as
/// -86.3084772726289, which reads back to other radians); the cell is the text of fewest
/// decimals in that interval (15 deg reads as 0.2617993877991494 rad, whose degrees are
/// 14.999999999999998: written 15), so a row read from a file is written as the file gave
/// it, and a subset `split` or `import` writes is rows of its source to the last bit. Where
/// no degree value within [`NEAR_ULPS`] reads back (9 % of radians read from a file in
/// radians; a value computed, not read), its degrees' shortest text, as [`number_cell`].
pub(super) fn degrees_cell(rad: f64) -> String {
    let deg = rad.to_degrees();
    let reads_back = |x: f64| x.to_radians().to_bits() == rad.to_bits();
    // -0 is written 0, as every cell.
    if !deg.is_finite() || deg == 0.0 {
        return number_cell(deg);
    }
    // The shortest text of the degrees, where it reads back and is no float dust (at most 15
    // significant digits), is the one a search would find: most rows' cells, for no search.
    let shortest = number_cell(deg);
    if significant_digits(&shortest) <= 15 && reads_back(deg) {
        return shortest;
    }
    // The degrees that read back form an interval of doubles [lo, hi] near `deg`; the text of
    // fewest decimals in it is found by arithmetic, formatted once and checked (formatting
    // every candidate cost import 3 times its time on Series A).
    let Some(x0) = std::iter::once(deg)
        .chain((1..=NEAR_ULPS).flat_map(|k| [ulps(deg, k), ulps(deg, -k)]))
        .find(|&x| reads_back(x))
    else {
        return shortest;
    };
    let (mut lo, mut hi) = (x0, x0);
    for _ in 0..2 * NEAR_ULPS {
        if reads_back(lo.next_down()) {
            lo = lo.next_down();
        }
        if reads_back(hi.next_up()) {
            hi = hi.next_up();
        }
    }
    // Decimals whose scaled value is an exact integer of a double (below 2^52): beyond, the
    // shortest text of a double in the interval, which has 17 digits at most.
    (0..=17)
        .map(|d| (d as usize, 10f64.powi(d)))
        .take_while(|(_, scale)| x0.abs() * scale < 2f64.powi(52))
        .flat_map(|(d, scale)| {
            // The decimals of d places either side of x0 (the product rounds, so both).
            let scaled = x0 * scale;
            [scaled.floor(), scaled.ceil()].map(|n| (d, n / scale))
        })
        // The arithmetic is off by an ulp or two at most: a candidate that near the interval
        // is formatted and its text checked.
        .filter(|&(_, c)| ulps(lo, -2) <= c && c <= ulps(hi, 2))
        .map(|(d, c)| fixed(c, d))
        .find(|t| t.parse::<f64>().is_ok_and(reads_back))
        .unwrap_or_else(|| {
            let mut x = lo;
            let mut best = number_cell(lo);
            while x < hi {
                x = x.next_up();
                let t = number_cell(x);
                if t.len() < best.len() {
                    best = t;
                }
            }
            best
        })
}

/// The significant digits of a plain decimal text (`-0.0012` has 2, `14.999999999999998`
/// has 17).
fn significant_digits(text: &str) -> usize {
    let digits: String = text.chars().filter(char::is_ascii_digit).collect();
    digits.trim_start_matches('0').len()
}

/// How many doubles either side of a value's degrees [`degrees_cell`] looks at.
const NEAR_ULPS: i64 = 8;

/// The double `k` steps (ulps) from the finite `x` (negative: down).
fn ulps(x: f64, k: i64) -> f64 {
    (0..k.unsigned_abs()).fold(x, |y, _| if k > 0 { y.next_up() } else { y.next_down() })
}

/// A rotation as its cells `rz, ry, rx` (deg, R = Rz Ry Rx) that read back to the same
/// matrix bits where some text does: of the angles (rad) within [`ANGLE_ULPS`] of those `r`
/// gives, among which the file's angles are after their trip through the matrix, those whose
/// texts ([`degrees_cell`]) are shortest (a row read from a file is so written as the file gave it:
/// 105.9 stays 105.9); else (computed, or read as other angles: X-Y-Z Euler angles, a
/// quaternion, angles beyond the canonical ranges) the angles' shortest texts.
pub(super) fn rotation_cells(r: &Rotation3<f64>) -> [String; 3] {
    let rad = rotation_to_zyx(r);
    let same = |b: Rotation3<f64>| {
        (b.matrix().iter().zip(r.matrix().iter())).all(|(x, y)| x.to_bits() == y.to_bits())
    };
    let read = |cells: &[String; 3]| -> Option<Rotation3<f64>> {
        let [z, y, x] = [&cells[0], &cells[1], &cells[2]].map(|c| c.parse::<f64>().ok());
        Some(zyx_to_rotation(
            z?.to_radians(),
            y?.to_radians(),
            x?.to_radians(),
        ))
    };
    if rad.iter().all(|a| a.is_finite()) {
        // Several triples can build the same matrix: the shortest texts win (the file's,
        // 52.682 where a triple a step nearer reads 52.681999999999995), the nearest among
        // equals. A triple counts only where its texts build the matrix again (an angle no
        // degree text reads back to is written otherwise).
        let mut best: Option<[String; 3]> = None;
        let length = |c: &[String; 3]| c.iter().map(String::len).sum::<usize>();
        for [i, j, k] in ANGLE_STEPS.iter() {
            let (z, y, x) = (ulps(rad[0], *i), ulps(rad[1], *j), ulps(rad[2], *k));
            if same(zyx_to_rotation(z, y, x)) {
                let cells = [z, y, x].map(degrees_cell);
                if read(&cells).is_some_and(same)
                    && best.as_ref().is_none_or(|b| length(&cells) < length(b))
                {
                    best = Some(cells);
                }
            }
        }
        if let Some(cells) = best {
            return cells;
        }
    }
    rad.map(|a| number_cell(a.to_degrees()))
}

/// The steps (ulps of each angle) [`rotation_cells`] tries, nearest first: every one whose
/// sizes sum to at most [`ANGLE_ULPS`] (63 triples).
static ANGLE_STEPS: std::sync::LazyLock<Vec<[i64; 3]>> = std::sync::LazyLock::new(|| {
    let mut steps = Vec::new();
    for i in -ANGLE_ULPS..=ANGLE_ULPS {
        for j in -ANGLE_ULPS..=ANGLE_ULPS {
            for k in -ANGLE_ULPS..=ANGLE_ULPS {
                steps.push([i, j, k]);
            }
        }
    }
    let size = |s: &[i64; 3]| s.iter().map(|v| v.abs()).sum::<i64>();
    steps.retain(|s| size(s) <= ANGLE_ULPS);
    steps.sort_by_key(size);
    steps
});

/// How far from the angles a matrix gives [`rotation_cells`] looks, in ulps summed over the
/// three: those it was built from lie within 2 on the 500 shipped Z-Y-X rows measured (375
/// at 0, 119 at 1, 6 at 2). A rotation built otherwise (X-Y-Z Euler angles, a quaternion)
/// is found by none, and the search costs each such row 63 matrices.
const ANGLE_ULPS: i64 = 3;

#[cfg(test)]
mod tests {
    use super::*;

    /// Angles read from a file are written as the file gave them, or as a text that reads
    /// back to the same bits (before, 15 deg was written 14.999999999999998, and
    /// -86.30847727262889 as -86.3084772726289, another angle: a subset of a file was not
    /// rows of it to the last bit).
    #[test]
    fn angles_read_from_a_file_are_written_back_to_the_bit() {
        for text in [
            "15",
            "6",
            "17.6",
            "-86.30847727262889",
            "3.9990329537813993",
            "0.1",
            "1e-7",
            "359.99999999999994",
            "-0.000001",
        ] {
            let rad = text.parse::<f64>().unwrap().to_radians();
            let cell = degrees_cell(rad);
            let back = cell.parse::<f64>().unwrap().to_radians();
            assert_eq!(back.to_bits(), rad.to_bits(), "{text} written {cell}");
            // A text of at most 15 significant digits comes back as it was.
            if text.trim_start_matches('-').len() <= 16 && !text.contains('e') {
                assert_eq!(cell, text);
            }
        }
        // Joints read in radians (a profile): where some degree value reads back to them,
        // the cell is one (of 17 significant digits at most); about 9 % have none.
        let mut seed = 0x9e37_79b9_7f4a_7c15_u64;
        let mut exact = 0;
        for _ in 0..5000 {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            let rad = ((seed >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0) * 6.0;
            let cell = degrees_cell(rad);
            let deg = rad.to_degrees();
            let some = (-8..=8).any(|k| ulps(deg, k).to_radians().to_bits() == rad.to_bits());
            let back = cell.parse::<f64>().unwrap().to_radians().to_bits() == rad.to_bits();
            assert_eq!(back, some, "{rad} written {cell}");
            assert!(significant_digits(&cell) <= 17, "{rad} written {cell}");
            exact += usize::from(back);
        }
        assert!((4300..4800).contains(&exact), "{exact} of 5000");
        // Three angles of a row, through the matrix and back.
        for [z, y, x] in [
            ["105.9", "17.6", "70.4"],
            [
                "95.23904333917534",
                "-9.116044244936985",
                "149.34282054108016",
            ],
            [
                "-12.164149475426916",
                "46.99282469856163",
                "-142.74172182340675",
            ],
            ["0", "0", "0"],
            // A triple 4 ulps away built the same matrix, and its -13.400000000000002 did
            // not (a reviewer's row): nearest first, and the texts checked.
            ["145.625", "-13.4", "-152.298431"],
            ["52.682", "-0.5", "3.25"],
        ] {
            let a = [z, y, x].map(|t| t.parse::<f64>().unwrap().to_radians());
            let r = zyx_to_rotation(a[0], a[1], a[2]);
            let cells = rotation_cells(&r);
            let b = cells
                .clone()
                .map(|c| c.parse::<f64>().unwrap().to_radians());
            assert_eq!(zyx_to_rotation(b[0], b[1], b[2]), r, "{cells:?}");
            if z.len() < 10 {
                assert_eq!(cells, [z, y, x], "short texts stay");
            }
        }
        // 3000 rows of short texts in the canonical ranges (a reviewer's emulation lost 13
        // matrices and changed 449 texts before the shortest texts won): every one kept.
        let mut seed = 0x2545_f491_4f6c_dd1d_u64;
        let mut draw = |range: f64, decimals: u32| {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            let unit = (seed >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0;
            let scale = 10f64.powi(decimals as i32);
            ((unit * range * 0.999 * scale).round() / scale).to_string()
        };
        for n in 0..3000 {
            let texts = [
                draw(180.0, 1 + n % 6),
                draw(90.0, 1 + (n / 6) % 6),
                draw(180.0, 1 + (n / 36) % 6),
            ];
            let a = texts
                .clone()
                .map(|t| t.parse::<f64>().unwrap().to_radians());
            let r = zyx_to_rotation(a[0], a[1], a[2]);
            assert_eq!(rotation_cells(&r), texts);
        }
        // A computed rotation no text reads back to exactly: its angles, within rounding.
        let r = Rotation3::from_axis_angle(&nalgebra::Vector3::y_axis(), 0.3)
            * Rotation3::from_axis_angle(&nalgebra::Vector3::x_axis(), 1.1);
        let cells = rotation_cells(&r);
        let b = cells
            .clone()
            .map(|c| c.parse::<f64>().unwrap().to_radians());
        assert!((zyx_to_rotation(b[0], b[1], b[2]).matrix() - r.matrix()).norm() < 1e-14);
    }
}
