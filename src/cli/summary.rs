//! Shared output of the fitting commands: the accuracy table and the typed JSON reports.

use anyhow::Result;
use robocal::evaluate::ErrorStats;
use robocal::neural::repeats::Repeats;
use robocal::reports::{Accuracy, Report};
use std::path::Path;

fn fmt_stats(s: &ErrorStats) -> (String, String) {
    let p = s.position_mm.map_or("-".into(), |p| {
        format!(
            "{:>9.4} {:>9.4} {:>9.4} {:>9.4}",
            p.mean, p.rms, p.p95, p.max
        )
    });
    let r = s.orientation_deg.map_or("-".into(), |r| {
        format!("{:>8.4} {:>8.4} {:>8.4}", r.mean, r.rms, r.max)
    });
    (p, r)
}

/// Prints a report's accuracy table (before/after pairs of error statistics).
pub fn print_stats(rows: &[Accuracy]) {
    println!(
        "{:<12} {:<7} {:>39}   {:>26}",
        "set", "model", "position mm: mean rms p95 max", "orientation deg: mean rms max"
    );
    for r in rows {
        let (p, o) = fmt_stats(&r.stats);
        println!("{:<12} {:<7} {p:>39}   {o:>26}", r.data, r.model);
    }
}

/// Prints the line on the data's repeated configurations (`train` and `evaluate` alike):
/// how far the model's residuals of one configuration differ, and the pure error no
/// compensator can remove.
pub fn print_repeats(r: &Repeats) {
    println!(
        "repeats: {} configurations measured more than once ({} rows); the model's position \
         residuals of one configuration differ by {:.4} mm (median), at most {:.4} mm (lines \
         {} and {}); pure error {:.4} mm RMS, which no compensator can remove",
        r.configurations,
        r.rows,
        r.median_spread_mm,
        r.max_spread_mm,
        r.max_spread_lines[0],
        r.max_spread_lines[1],
        r.pure_error_rms_mm
    );
}

/// Writes a typed report (JSON).
pub fn write_report(path: &Path, r: &Report) -> Result<()> {
    super::output::writing(r.save(path), path)
}

/// Width of a printed unit column: the widest unit, at least 4 (`unit`); compliance units
/// (`mrad/kNm`) are wider than mm and deg.
pub fn unit_width<'a>(units: impl IntoIterator<Item = &'a str>) -> usize {
    units.into_iter().map(str::len).fold(4, usize::max)
}
