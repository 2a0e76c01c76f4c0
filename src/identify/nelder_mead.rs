//! Nelder-Mead simplex search (thesis 4.1, after Lagarias et al. 1998), derivative free.
//! Coefficients: reflection 1, expansion 2, contraction 0.5, shrink 0.5 (eq. 4.5).
//!
//! Parameters are searched in scaled coordinates, one unit being 1 mm for lengths, 1 mrad
//! for angles, 0.1 mrad per kN m for joint compliances and 10 mrad per kN m times kg (or
//! kg m) for their mass-free coefficients (the size of typical deviations): the starting
//! simplex is the start plus one unit along each axis. The search stops when the simplex has collapsed (every vertex within
//! `xtol` units of the best and the costs within `ftol` relative) or after the iteration limit;
//! it restarts once from the best vertex, as is customary, to guard against a degenerate
//! simplex.

use super::problem::{IdentifyWorkspace, Observations, cost};
use super::solve::{Solution, SolveOptions, StopReason, free_values, with_values};
use crate::error::{Error, Result};
use crate::model::{Field, Robot};
use nalgebra::DVector;

const REFLECT: f64 = 1.0;
const EXPAND: f64 = 2.0;
const CONTRACT: f64 = 0.5;
const SHRINK: f64 = 0.5;

/// Runs Nelder-Mead on the parameters `cols` (indices into `Robot::parameters`).
pub fn solve_nelder_mead(
    robot: &Robot,
    obs: &Observations,
    cols: &[usize],
    opts: &SolveOptions,
) -> Result<Solution> {
    let (ids, x0) = free_values(robot, cols);
    let scale = DVector::from_iterator(
        ids.len(),
        ids.iter().map(|id| match id.field {
            // 0.1 mrad per kN m: a typical joint compliance (rad per N m).
            Field::C => 1e-7,
            // 10 mrad per kN m times kg (or kg m): a typical mass-free compliance coefficient
            // (its 1.0 was a million file units, and the search crept down to it).
            Field::K { .. } => 1e-5,
            f if f.is_angle() => 1e-3,
            _ => 1.0,
        }),
    );
    let mut ws = IdentifyWorkspace::new(robot);
    let mut evaluations = 0usize;
    let mut f = |y: &DVector<f64>| -> Result<f64> {
        evaluations += 1;
        let x = &x0 + y.component_mul(&scale);
        // A vertex beyond the robot's bounds (100 m, 2 turns) is infinitely bad.
        Ok(match with_values(robot, &ids, &x) {
            Ok(r) => cost(&r, obs, &mut ws),
            Err(_) => f64::INFINITY,
        })
    };
    let n = ids.len();
    let mut best = DVector::zeros(n);
    let mut iterations = 0;
    let mut stop = StopReason::MaxIterations;
    // Cost-spread and size tolerances in scaled units.
    let ftol = opts.ftol.max(1e-15);
    let xtol = opts.xtol.max(1e-12) * 1e3;
    for _restart in 0..2 {
        let mut simplex: Vec<DVector<f64>> = vec![best.clone()];
        for i in 0..n {
            let mut v = best.clone();
            v[i] += 1.0;
            simplex.push(v);
        }
        let mut fv: Vec<f64> = simplex.iter().map(&mut f).collect::<Result<_>>()?;
        stop = StopReason::MaxIterations;
        while iterations < opts.max_iterations {
            iterations += 1;
            // 1. Sort.
            let mut order: Vec<usize> = (0..=n).collect();
            order.sort_by(|&a, &b| fv[a].total_cmp(&fv[b]));
            simplex = order.iter().map(|&i| simplex[i].clone()).collect();
            fv = order.iter().map(|&i| fv[i]).collect();
            if !fv[0].is_finite() {
                return Err(Error::NotConverged(format!(
                    "Nelder-Mead: the cost became {}",
                    fv[0]
                )));
            }
            let size = simplex[1..]
                .iter()
                .map(|v| (v - &simplex[0]).amax())
                .fold(0.0, f64::max);
            if size <= xtol && (fv[n] - fv[0]) <= ftol * fv[0].abs().max(1e-300) {
                stop = StopReason::Simplex;
                break;
            }
            // Centroid of the best n vertices (eq. 4.6).
            let centroid = simplex[..n]
                .iter()
                .fold(DVector::zeros(n), |acc, v| acc + v)
                / n as f64;
            // 2. Reflection (eq. 4.8).
            let xr = &centroid + (&centroid - &simplex[n]) * REFLECT;
            let fr = f(&xr)?;
            if fv[0] <= fr && fr < fv[n - 1] {
                simplex[n] = xr;
                fv[n] = fr;
                continue;
            }
            // 3. Expansion (eq. 4.9).
            if fr < fv[0] {
                let xe = &centroid + (&xr - &centroid) * EXPAND;
                let fe = f(&xe)?;
                if fe < fr {
                    simplex[n] = xe;
                    fv[n] = fe;
                } else {
                    simplex[n] = xr;
                    fv[n] = fr;
                }
                continue;
            }
            // 4. Outside contraction (eq. 4.10) or 5. inside contraction (eq. 4.11).
            let (xc, fc, accept) = if fr < fv[n] {
                let xc = &centroid + (&xr - &centroid) * CONTRACT;
                let fc = f(&xc)?;
                (xc, fc, fc <= fr)
            } else {
                let xc = &centroid - (&xr - &centroid) * CONTRACT;
                let fc = f(&xc)?;
                (xc, fc, fc < fv[n])
            };
            if accept {
                simplex[n] = xc;
                fv[n] = fc;
                continue;
            }
            // 6. Shrink towards the best vertex (eq. 4.12).
            for i in 1..=n {
                simplex[i] = &simplex[0] + (&simplex[i] - &simplex[0]) * SHRINK;
                fv[i] = f(&simplex[i])?;
            }
        }
        let b = (0..=n)
            .min_by(|&a, &c| fv[a].total_cmp(&fv[c]))
            .unwrap_or(0);
        best = simplex[b].clone();
        if stop == StopReason::MaxIterations {
            break;
        }
    }
    let x = &x0 + best.component_mul(&scale);
    let robot_out = with_values(robot, &ids, &x)?;
    let final_cost = cost(&robot_out, obs, &mut IdentifyWorkspace::new(robot));
    Ok(Solution {
        robot: robot_out,
        iterations,
        stop,
        cost: final_cost,
        evaluations,
        normal: None,
    })
}
