//! Shared output of the fitting commands: the before/after statistics table and JSON reports.

use anyhow::Result;
use robocal::evaluate::ErrorStats;
use serde_json::Value;
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

/// Prints a before/after table of error statistics.
pub fn print_stats(rows: &[(&str, &str, &ErrorStats)]) {
    println!(
        "{:<12} {:<7} {:>39}   {:>26}",
        "set", "model", "position mm: mean rms p95 max", "orientation deg: mean rms max"
    );
    for (set, model, s) in rows {
        let (p, r) = fmt_stats(s);
        println!("{set:<12} {model:<7} {p:>39}   {r:>26}");
    }
}

pub fn stats_json(s: &ErrorStats) -> Value {
    serde_json::to_value(s).unwrap_or(Value::Null)
}

pub fn write_json(path: &Path, v: &Value) -> Result<()> {
    let mut b = serde_json::to_vec_pretty(v)?;
    b.push(b'\n');
    super::output::writing(robocal::io::write_atomic(path, &b), path)
}
