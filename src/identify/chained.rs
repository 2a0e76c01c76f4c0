//! The covariance of parameters identified from pairs of rows that share rows: relative
//! displacements or distances of consecutive rows (1, 2), (2, 3), ..., where row 2's
//! measurement error enters both pairs, with opposite signs.
//!
//! The solve weights each pair as if its error were its own (1/sigma^2 of the pair, the sum
//! of its two rows' variances), which leaves the estimates unbiased; but the usual
//! covariance s^2 (J_w^T J_w)^-1 then assumes independent residuals, and with the
//! neighbours' correlation of -1/2 (equal sigmas) it understated the spread of the estimates
//! of a chain by 15-25 % (a helper measured 1.25 for relative displacements and 1.15 for
//! distances, the ratio of the spread over 20 seeds to the reported standard deviation;
//! disjoint pairs 0.99). Here the covariance is the sandwich
//! s^2 A^-1 M A^-1, A = J_w^T J_w, M = J_w^T R J_w, R the correlation of the weighted
//! residuals: 1 on the diagonal and, for two pairs k, k' that share row i, the share of
//! row i's variance in each pair, sqrt(f_k f_k'), f_k = sigma_i^2 / (sigma_a^2 + sigma_b^2)
//! per coordinate (for distances |sigma_i|^2 over the sum, times u_k . u_k', the cosine of
//! the two displacements: a distance reads the error along its own direction), signed +
//! where the row enters both pairs alike (first row of both, or second of both), - else.
//! Rows' error beyond their sigmas (the unmodelled error, per pair) is taken to split
//! between a pair's rows as their sigmas do, and a distance's as if each row's sigma were
//! the same along every axis (as its weight takes it): approximations, exact for equal
//! isotropic sigmas. A distance from the `distance` column (an instrument's reading of the
//! pair) shares nothing. The variance factor then counts the degrees of freedom the
//! correlation takes ([`super::solve::covariance_of`]).

use super::problem::{IdentifyWorkspace, Measure, Observations, residual};
use crate::kinematics::tool_pose;
use crate::model::Robot;
use nalgebra::{DMatrix, Matrix6xX, Vector3};

/// M - A: the cross terms J_k^T R_kk' J_k' + J_k'^T R_k'k J_k of every two weighted pairs
/// k, k' that share a row (k x k, `cols` order); None where no two pairs share one (single
/// rows, disjoint pairs).
pub fn shared_row_terms(robot: &Robot, obs: &Observations, cols: &[usize]) -> Option<DMatrix<f64>> {
    if !matches!(obs.measure, Measure::Relative | Measure::Distance) {
        return None;
    }
    // Each row's pairs, with the row's sign in the pair's residual (a - b: + first, - second).
    let mut of_row: Vec<Vec<(usize, f64)>> = vec![Vec::new(); obs.set.rows.len()];
    for (k, o) in obs.items.iter().enumerate() {
        // A distance read off the `distance` column is the instrument's own reading (a
        // ball bar's): its error belongs to the pair, not to the rows' positions.
        if obs.measure == Measure::Distance && obs.set.rows[o.b.unwrap_or(o.a)].distance.is_some() {
            continue;
        }
        of_row[o.a].push((k, 1.0));
        if let Some(b) = o.b {
            of_row[b].push((k, -1.0));
        }
    }
    if of_row.iter().all(|p| p.len() < 2) {
        return None;
    }
    let dim = obs.dim();
    let n = cols.len();
    let mut ws = IdentifyWorkspace::new(robot);
    // The weighted Jacobian rows of every pair, and for distances the displacement's direction.
    let mut jw: Vec<DMatrix<f64>> = Vec::with_capacity(obs.items.len());
    let mut dir: Vec<Vector3<f64>> = Vec::with_capacity(obs.items.len());
    let mut jac = Matrix6xX::<f64>::zeros(n);
    let mut r = [0.0; 6];
    for o in &obs.items {
        residual(robot, obs, o, Some(cols), &mut ws, &mut r, &mut jac);
        let sw = o.weight.sqrt();
        jw.push(DMatrix::from_fn(dim, n, |c, j| {
            jac[(c, j)] * o.inv_sigma[c] * sw
        }));
        if obs.measure == Measure::Distance {
            let b = o.b.unwrap_or(o.a);
            let d = tool_pose(robot, &obs.set.rows[o.a].q).translation.vector
                - tool_pose(robot, &obs.set.rows[b].q).translation.vector;
            dir.push(d.try_normalize(0.0).unwrap_or_else(Vector3::zeros));
        }
    }
    let sigma = &obs.row_sigma_mm;
    // Row i's share of pair k's variance, per coordinate (for a distance, all three alike).
    let share = |k: usize, i: usize| -> Vector3<f64> {
        let o = &obs.items[k];
        let (a, b) = (sigma[o.a], sigma[o.b.unwrap_or(o.a)]);
        let own = sigma[i].component_mul(&sigma[i]);
        let sum = a.component_mul(&a) + b.component_mul(&b);
        if obs.measure == Measure::Distance {
            Vector3::repeat(own.sum() / sum.sum())
        } else {
            own.component_div(&sum)
        }
    };
    let mut cross = DMatrix::<f64>::zeros(n, n);
    for (i, pairs) in of_row.iter().enumerate() {
        for (x, &(k, sk)) in pairs.iter().enumerate() {
            for &(l, sl) in &pairs[x + 1..] {
                let (fk, fl) = (share(k, i), share(l, i));
                // R_kl (dim x dim, diagonal): the correlation of the two weighted residuals.
                let rho: Vec<f64> = match obs.measure {
                    Measure::Distance => vec![sk * sl * (fk.x * fl.x).sqrt() * dir[k].dot(&dir[l])],
                    _ => (0..dim).map(|c| sk * sl * (fk[c] * fl[c]).sqrt()).collect(),
                };
                for (c, rho) in rho.iter().enumerate() {
                    let (jk, jl) = (jw[k].row(c), jw[l].row(c));
                    // J_k^T rho J_l + J_l^T rho J_k.
                    cross.ger(*rho, &jk.transpose(), &jl.transpose(), 1.0);
                    cross.ger(*rho, &jl.transpose(), &jk.transpose(), 1.0);
                }
            }
        }
    }
    Some(cross)
}
