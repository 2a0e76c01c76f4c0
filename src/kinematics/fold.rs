//! Starts across a fold of the map from joints to tool poses, for the numerical IK's search
//! of every solution.
//!
//! Next to a fold (a straight elbow, the wrist centre on the shoulder's cylinder) a pose has
//! two solutions close together on either side of the singular set, where the Jacobian J
//! loses rank. A calibrated arm's fold lies a little off the nominal's, so the nominal's
//! closed form can start both of its branches on one side, and the solve from each then finds
//! the same solution. Across the fold, det J changes sign, to first order linearly along the
//! direction v in which J is nearest singular (the eigenvector of J^T J of smallest
//! eigenvalue): det J(q + t v) = d0 + t d', so the fold lies at t* = -d0 / d', and the other
//! solution near q + 2 t* v, the reflection of q across it.

use super::ik_numeric::ToolModel;
use nalgebra::{Matrix6, Matrix6xX, Vector6};

/// Largest distance (rad, along the unit direction v) from a solution to the fold for its
/// reflection to be tried: 0.2 rad (11 deg). On 3000 poses of a calibrated UR10 with its elbow
/// within 3 deg of straight, `--all` left out 87 poses' own configuration without the
/// reflections, 7 with them within 0.05 rad, 6 within 0.2 (at four times the calibration's
/// deviations 334, 40 and 16).
pub const FOLD_NEAR_RAD: f64 = 0.2;

/// Step (rad) of the difference that estimates d' = d det J / dt.
const STEP_RAD: f64 = 1e-4;

/// The scaled Jacobian of `model` at `q` (rad, mm): rows 0-2 mm per rad, rows 3-5 the angular
/// rows times `length_scale_mm`, as the numerical solve weighs them; None for a robot of
/// other than six joints (a redundant arm's J^T J is always singular).
fn square_jacobian<M: ToolModel>(
    model: &mut M,
    q: &[f64],
    length_scale_mm: f64,
    jac: &mut Matrix6xX<f64>,
) -> Option<Matrix6<f64>> {
    if q.len() != 6 || jac.ncols() != 6 {
        return None;
    }
    model.jacobian(q, jac);
    let mut j = Matrix6::zeros();
    j.copy_from(jac);
    j.fixed_rows_mut::<3>(3).scale_mut(length_scale_mm);
    Some(j)
}

/// Inverse iterations on J^T J of [`nearest_singular`]: each shrinks the other directions'
/// share by (sigma_min / sigma_k)^2, so next to a fold, where sigma_min is far below the other
/// singular values, three leave v exact to rounding; far from one v is rough, and so is the
/// fold's distance estimated along it, which then exceeds [`FOLD_NEAR_RAD`] or starts a solve
/// that finds nothing new.
const INVERSE_ITERATIONS: usize = 3;

/// The unit direction v in which `j` is nearest singular: the eigenvector of J^T J of smallest
/// eigenvalue, by inverse iteration from a fixed start (cheaper than the eigen-decomposition,
/// which was 7 % of `ik`'s time on random poses); None where J^T J is singular to rounding
/// (no Cholesky factor): on the fold itself there is nothing to reflect across.
fn nearest_singular(j: &Matrix6<f64>) -> Option<Vector6<f64>> {
    let chol = (j.transpose() * j).cholesky()?;
    let mut v = Vector6::new(1.0, 0.9, 0.8, 0.7, 0.6, 0.5).normalize();
    for _ in 0..INVERSE_ITERATIONS {
        chol.solve_mut(&mut v);
        let norm = v.norm();
        if !norm.is_finite() || norm == 0.0 {
            return None;
        }
        v /= norm;
    }
    Some(v)
}

/// The reflection q + 2 t* v (rad, mm) of solution `q` of `model` across the nearest fold
/// (module doc), where the fold lies within [`FOLD_NEAR_RAD`]; None elsewhere, for a robot
/// of other than six joints, and where det J does not change along v. `jac` (6 x 6) is
/// scratch.
pub fn across_fold<M: ToolModel>(
    model: &mut M,
    q: &[f64],
    length_scale_mm: f64,
    jac: &mut Matrix6xX<f64>,
) -> Option<Vec<f64>> {
    let j0 = square_jacobian(model, q, length_scale_mm, jac)?;
    let v = nearest_singular(&j0)?;
    let mut stepped = [0.0; 6];
    for ((s, a), b) in stepped.iter_mut().zip(q).zip(v.iter()) {
        *s = a + STEP_RAD * b;
    }
    let d0 = j0.determinant();
    let d1 = square_jacobian(model, &stepped, length_scale_mm, jac)?.determinant();
    let slope = (d1 - d0) / STEP_RAD;
    let t = -d0 / slope;
    (t.is_finite() && t.abs() <= FOLD_NEAR_RAD).then(|| {
        (q.iter().zip(v.iter()))
            .map(|(a, b)| a + 2.0 * t * b)
            .collect()
    })
}
