//! Value parsers for bounded command-line options: every size, count and sigma has a range,
//! named in `--help` and in the usage error, so that no option can exhaust memory, run away
//! or put a non-finite number into a computation.

/// Most decimals a number is printed with: an f64 holds about 17 significant digits.
pub const MAX_DECIMALS: usize = 17;
/// Most configurations one `simulate` run draws: every row is held in memory until the
/// output is written (about 1 kB each).
pub const MAX_COUNT: usize = 1_000_000;
/// Largest tracker or noise sigma accepted (mm, mrad): far beyond any real instrument.
pub const MAX_SIGMA: f64 = 1000.0;
/// Smallest non-zero tracker or noise sigma (mm, mrad): 1 nm and 1 nrad, the bounds a
/// measurement file's sigma columns are read within (a simulated file's sigmas must read
/// back), and a weight of 1e12 per mm^-2 already beyond any instrument.
pub const MIN_SIGMA: f64 = 1e-6;

fn whole(s: &str, what: &str, lo: usize, hi: usize) -> Result<usize, String> {
    let n: usize = s
        .parse()
        .map_err(|_| format!("`{s}` is not a whole number of {what}"))?;
    if !(lo..=hi).contains(&n) {
        return Err(format!("give {lo} to {hi} {what} (got {n})"));
    }
    Ok(n)
}

/// `--decimals`: 0 to [`MAX_DECIMALS`].
pub fn decimals(s: &str) -> Result<usize, String> {
    whole(s, "decimals", 0, MAX_DECIMALS)
}

/// `simulate --count`: 1 to [`MAX_COUNT`].
pub fn count(s: &str) -> Result<usize, String> {
    whole(s, "configurations", 1, MAX_COUNT)
}

/// `plan --count`: 1 to [`MAX_COUNT`] units, configurations or (relative, distance) pairs.
pub fn units(s: &str) -> Result<usize, String> {
    whole(
        s,
        "units (configurations, or pairs for --measure relative|distance)",
        1,
        MAX_COUNT,
    )
}

/// `identify --max-iterations`: 1 to 100000 (each solves the normal equations once).
pub fn iterations(s: &str) -> Result<usize, String> {
    whole(s, "iterations", 1, 100_000)
}

fn real(s: &str, what: &str, zero_ok: bool) -> Result<f64, String> {
    let v: f64 = s
        .parse()
        .map_err(|_| format!("`{s}` is not a number ({what})"))?;
    let low_ok = (zero_ok && v == 0.0) || v >= MIN_SIGMA;
    if !(v.is_finite() && low_ok && v <= MAX_SIGMA) {
        let low = if zero_ok {
            format!("of 0 or from {MIN_SIGMA:e}")
        } else {
            format!("from {MIN_SIGMA:e}")
        };
        return Err(format!("give a {what} {low} up to {MAX_SIGMA} (got {s})"));
    }
    Ok(v)
}

/// Largest finite `identify --outlier-k` (robust sigmas): beyond it no row of a real file is
/// an outlier; `inf` says so directly.
pub const MAX_OUTLIER_K: f64 = 1e6;

/// `identify --outlier-k`: 1 to [`MAX_OUTLIER_K`] robust sigmas, or `inf` (none reported).
pub fn outlier_k(s: &str) -> Result<f64, String> {
    let v: f64 = s
        .parse()
        .map_err(|_| format!("`{s}` is not a number (robust sigmas)"))?;
    if v == f64::INFINITY || (1.0..=MAX_OUTLIER_K).contains(&v) {
        return Ok(v);
    }
    Err(format!(
        "give a cut of 1 to {MAX_OUTLIER_K:e} robust sigmas, or inf to report none (got {s})"
    ))
}

/// A tracker sigma that weights rows (identify, train): [`MIN_SIGMA`] to [`MAX_SIGMA`].
pub fn sigma(s: &str) -> Result<f64, String> {
    real(s, "sigma", false)
}

/// `plan --target-mm`: a mean position error of [`MIN_SIGMA`] to [`MAX_SIGMA`] (mm).
pub fn target_mm(s: &str) -> Result<f64, String> {
    real(s, "target mean position error (mm)", false)
}

/// A simulated noise sigma: 0 (no noise), or [`MIN_SIGMA`] to [`MAX_SIGMA`].
pub fn noise(s: &str) -> Result<f64, String> {
    real(s, "noise sigma", true)
}
