//! Measurement planning: which configurations to measure so that the data identify the robot
//! best, and the accuracy they will give, before a tracker is set up.
//!
//! - [`pool`]: candidate configurations (given, or drawn in the limits or a region) and the
//!   cell's constraints (joint margins, a floor, a forbidden box).
//! - [`design`]: each candidate's noise-weighted, column-scaled Jacobian block over the
//!   parameters the pool identifies (the identification's own Jacobian and analysis).
//! - [`criterion`]: D, O1, O3 and A optimality of the information matrix.
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
pub use exchange::{Chosen, choose};
pub use pool::{Constraints, Pool};
pub use predict::{Prediction, predict};

use crate::error::{Error, Result};

/// The smallest plan whose predicted mean position error is at most `target_mm`, by
/// doubling from the fewest units that identify the parameters and then bisecting (the
/// predicted error of planned units falls with their number). Returns the plan and its
/// prediction; an error when even the whole pool misses the target.
pub fn smallest_meeting(
    design: &Design,
    criterion: Criterion,
    target_mm: f64,
    seed: u64,
) -> Result<(Chosen, Prediction)> {
    let units = design.units();
    let first = design.p() / design.dim + 1;
    if first > units {
        return Err(Error::Invalid(format!(
            "the pool's {units} units are too few for {} parameters",
            design.p()
        )));
    }
    let attempt = |n: usize| -> Result<(Chosen, Prediction)> {
        let chosen = choose(design, n, criterion, &[])?;
        let prediction = predict(design, &chosen.units, seed).ok_or_else(|| {
            Error::Invalid(format!("{n} planned units do not identify every parameter"))
        })?;
        Ok((chosen, prediction))
    };
    let meets = |p: &Prediction| p.position_mm.mean <= target_mm;
    // Doubling: lo misses (or is below the first), hi meets.
    let mut lo = first - 1;
    let mut hi = first;
    let mut best = loop {
        let r = attempt(hi)?;
        if meets(&r.1) {
            break r;
        }
        if hi == units {
            return Err(Error::Invalid(format!(
                "the whole pool ({units} units) predicts {:.4} mm mean position error, above \
                 the target {target_mm} mm: lower the noise, widen the region or change the \
                 measure",
                r.1.position_mm.mean
            )));
        }
        lo = hi;
        hi = (hi * 2).min(units);
    };
    while hi - lo > 1 {
        let mid = (lo + hi) / 2;
        let r = attempt(mid)?;
        if meets(&r.1) {
            hi = mid;
            best = r;
        } else {
            lo = mid;
        }
    }
    Ok(best)
}
