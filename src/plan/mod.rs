//! Measurement planning: which configurations to measure so that the data identify the robot
//! best, and the accuracy they will give, before a tracker is set up.
//!
//! - [`pool`]: candidate configurations (given, or drawn in the limits or a region) and the
//!   cell's constraints (joint margins, a floor, a forbidden box).
//! - [`design`]: each candidate's noise-weighted, column-scaled Jacobian block over the
//!   parameters the pool identifies (the identification's own Jacobian and analysis).
//! - [`criterion`]: D, O1, O3, A and I optimality of the information matrix.
//! - [`exchange`]: greedy start, then exchanges until none improves.
//! - [`mod@predict`]: each parameter's standard deviation and the tool's error over a
//!   validation cloud, by propagating the covariance through the pose Jacobian.

pub mod criterion;
pub mod design;
pub mod exchange;
pub mod pool;
pub mod predict;

pub use criterion::Criterion;
pub use design::Design;
pub use exchange::{Chosen, choose, enough_equations};
pub use pool::{Constraints, Pool};
pub use predict::{Prediction, predict};

use crate::error::{Error, Result};

/// A prediction's mean position error (mm); infinite where it predicts none (an orientation
/// measure), which meets no target.
fn position_mean(p: &Prediction) -> f64 {
    p.position_mm.map_or(f64::INFINITY, |s| s.mean)
}

/// The smallest plan whose predicted mean position error is at most `target_mm`, by
/// doubling from the fewest units that give more equations than parameters and then
/// bisecting (the predicted error of planned units falls with their number); a plan that
/// does not identify every parameter counts as missing the target. Returns the plan and its
/// prediction; an error, before any plan, when even the whole pool misses the target.
/// `progress` is told each number of units tried (a plan of thousands takes minutes).
pub fn smallest_meeting(
    design: &Design,
    criterion: Criterion,
    target_mm: f64,
    seed: u64,
    progress: &mut dyn FnMut(usize),
) -> Result<(Chosen, Prediction)> {
    let units = design.units();
    let first = design.p() / design.dim + 1;
    if first > units {
        return Err(Error::Invalid(format!(
            "the pool's {units} units are too few for {} parameters",
            design.p()
        )));
    }
    let all: Vec<usize> = (0..units).collect();
    match predict(design, &all, seed) {
        Some(p) if position_mean(&p) <= target_mm => {}
        p => {
            return Err(Error::Invalid(format!(
                "the whole pool ({units} units) predicts {} mean position error, above the \
                 target {target_mm} mm: give more units to choose from (a larger --pool, or \
                 more --candidates; the whole pool measured is the best a plan from it gives), \
                 lower the noise, widen the region or change the measure",
                p.map_or("no bounded".to_string(), |p| format!(
                    "{:.4} mm",
                    position_mean(&p)
                ))
            )));
        }
    }
    // A plan and its prediction, or None when it misses.
    let mut attempt = |n: usize| -> Result<Option<(Chosen, Prediction)>> {
        progress(n);
        let chosen = choose(design, n, criterion, &[])?;
        Ok(predict(design, &chosen.units, seed)
            .filter(|p| position_mean(p) <= target_mm)
            .map(|p| (chosen, p)))
    };
    // Doubling: lo misses (or is below the first), hi meets.
    let mut lo = first - 1;
    let mut hi = first;
    let mut best = loop {
        if let Some(r) = attempt(hi)? {
            break r;
        }
        if hi == units {
            // The whole pool met the target above: only rounding brings this here.
            return Err(Error::Invalid(format!(
                "no plan from the pool's {units} units meets the target {target_mm} mm"
            )));
        }
        lo = hi;
        hi = (hi * 2).min(units);
    };
    while hi - lo > 1 {
        let mid = (lo + hi) / 2;
        if let Some(r) = attempt(mid)? {
            hi = mid;
            best = r;
        } else {
            lo = mid;
        }
    }
    Ok(best)
}
