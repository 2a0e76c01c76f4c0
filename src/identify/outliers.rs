//! Rows far out: each row's weighted residual in robust sigmas, and the rows that stood out
//! against the start where the fit is dragged by them.

use super::problem::{Observations, residuals};
use crate::data::MeasurementSet;
use crate::model::Robot;

/// A row whose residual is far out.
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
pub struct Outlier {
    /// 1-based line of the row in the measurement file (of row b for a pair).
    pub line: usize,
    /// Its weighted residual in robust sigmas.
    pub robust_sigmas: f64,
}

/// Weighted residual norm of every observation, divided by sqrt(dim).
pub(super) fn normalized_residuals(robot: &Robot, obs: &Observations) -> Vec<f64> {
    let dim = obs.dim();
    (residuals(robot, obs).iter().zip(&obs.items))
        .map(|(r, o)| {
            ((0..dim)
                .map(|c| (r[c] * o.inv_sigma[c]).powi(2))
                .sum::<f64>()
                / dim as f64)
                .sqrt()
        })
        .collect()
}

/// Rows whose residual lies beyond `k` robust sigmas ([`crate::stats::robust_sigma`], in
/// the measurements' own sigmas), on the residuals unweighted by a robust loss.
pub(super) fn outliers(
    set: &MeasurementSet,
    obs: &Observations,
    robot: &Robot,
    k: f64,
) -> Vec<Outlier> {
    let mut plain = obs.clone();
    for o in plain.items.iter_mut() {
        o.weight = 1.0;
    }
    let e = normalized_residuals(robot, &plain);
    let scale = crate::stats::robust_sigma(&e);
    plain
        .items
        .iter()
        .zip(&e)
        .filter(|(_, ei)| **ei > k * scale)
        .map(|(o, ei)| Outlier {
            line: set.rows[o.b.unwrap_or(o.a)].line,
            robust_sigmas: ei / scale,
        })
        .collect()
}

/// Where the identified model misses every row by far and no row stands out from the rest
/// (the outlier check void: one row far off can drag the fit, and with it every residual), the
/// rows that stood out against the start model (registered where the frame was): a warning
/// naming them, None where none did. A reviewer's file with one joint mistyped by 100 deg
/// (3648 mm off) was fitted to 576 mm RMS with "outliers: none". `outlier_k`: the bound in
/// robust sigmas; `robust`: whether a robust loss weighted the rows already.
pub(super) fn dragged_fit_warning(
    set: &MeasurementSet,
    obs: &Observations,
    start: &Robot,
    outlier_k: f64,
    robust: bool,
) -> Option<String> {
    let mut before = outliers(set, obs, start, outlier_k);
    if before.is_empty() {
        return None;
    }
    before.sort_by(|a, b| b.robust_sigmas.total_cmp(&a.robust_sigmas));
    let shown: Vec<String> = (before.iter().take(5))
        .map(|o| format!("line {} ({:.0} robust sigmas)", o.line, o.robust_sigmas))
        .collect();
    let robust = if robust {
        ""
    } else {
        ", or use a robust loss (--robust huber) that weights them down"
    };
    Some(format!(
        "{}: no row stands out from the identified model's residuals, all of them large, but \
         {} row(s) stood out against the start model: {}{}: a row far off drags the whole fit \
         with it; check them (a mistyped joint, a reading paired with another configuration) \
         and fix or remove them{robust}",
        set.source.display(),
        before.len(),
        shown.join(", "),
        if before.len() > 5 { ", ..." } else { "" }
    ))
}
