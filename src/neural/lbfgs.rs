//! Limited-memory BFGS (Nocedal and Wright, Algorithm 7.4 and 7.5) with a backtracking
//! Armijo line search: the weight-refining phase where a dense Levenberg-Marquardt normal
//! matrix (residual rows x weights^2) would cost too much.
//!
//! Small and ours because the training needs a per-iteration callback (validation-failure
//! stopping, progress) that minimiser crates do not offer.

use super::vectors::{axpy, dot, norm};
use nalgebra::DVector;
use std::collections::VecDeque;

/// What the callback decides after an iteration.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Next {
    /// Run another iteration.
    Continue,
    /// Stop now and return the current point ([`LbfgsStop::Callback`]).
    Stop,
}

/// Why L-BFGS stopped.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LbfgsStop {
    /// The callback asked to stop.
    Callback,
    /// The largest gradient component fell below the tolerance.
    MinGradient,
    /// No step along the search direction lowers the objective.
    LineSearch,
    /// The iteration limit.
    MaxIterations,
}

/// Minimises `f` from `x` for at most `max_iter` iterations, keeping `memory` correction
/// pairs. `f(x, g)` returns the objective and writes its gradient into `g`; `after(iter,
/// value, x)` runs after each accepted step. Returns the last iterate, its value and the stop.
pub fn minimize(
    mut x: DVector<f64>,
    memory: usize,
    max_iter: usize,
    min_grad: f64,
    mut f: impl FnMut(&DVector<f64>, &mut DVector<f64>) -> f64,
    mut after: impl FnMut(usize, f64, &DVector<f64>) -> Next,
) -> (DVector<f64>, f64, LbfgsStop) {
    let n = x.len();
    let memory = memory.max(1);
    let mut g = DVector::zeros(n);
    let mut fx = f(&x, &mut g);
    let mut pairs: VecDeque<(DVector<f64>, DVector<f64>, f64)> = VecDeque::with_capacity(memory);
    let mut alpha = vec![0.0; memory];
    let (mut d, mut x_new, mut g_new) = (DVector::zeros(n), DVector::zeros(n), DVector::zeros(n));
    // The next pair's storage: the pair dropped from a full memory, or one not kept, is
    // written again (no allocation once the memory is full).
    let mut spare: Option<(DVector<f64>, DVector<f64>)> = None;
    for iter in 1..=max_iter {
        if g.amax() < min_grad {
            return (x, fx, LbfgsStop::MinGradient);
        }
        // Two-loop recursion: d = -H g.
        d.copy_from(&g);
        for (k, (s, y, rho)) in pairs.iter().enumerate().rev() {
            alpha[k] = rho * dot(s, &d);
            axpy(&mut d, -alpha[k], y);
        }
        let gamma = pairs
            .back()
            .map_or(1.0 / norm(&g).max(1e-300), |(s, y, _)| {
                dot(s, y) / dot(y, y)
            });
        d *= gamma;
        for (k, (s, y, rho)) in pairs.iter().enumerate() {
            let beta = rho * dot(y, &d);
            axpy(&mut d, alpha[k] - beta, s);
        }
        d.neg_mut();
        let mut slope = dot(&g, &d);
        if slope >= 0.0 {
            // Not a descent direction (curvature information gone stale): restart.
            pairs.clear();
            d.copy_from(&g);
            d.neg_mut();
            d /= norm(&g).max(1e-300);
            slope = dot(&g, &d);
        }
        // Backtracking line search on the Armijo condition.
        let mut step = 1.0;
        let mut accepted = None;
        for _ in 0..40 {
            x_new.copy_from(&x);
            axpy(&mut x_new, step, &d);
            let f_new = f(&x_new, &mut g_new);
            if f_new.is_finite() && f_new <= fx + 1e-4 * step * slope {
                accepted = Some(f_new);
                break;
            }
            step *= 0.5;
        }
        let Some(f_new) = accepted else {
            if pairs.is_empty() {
                return (x, fx, LbfgsStop::LineSearch);
            }
            // Stale curvature pairs can point nowhere useful: restart from steepest descent.
            pairs.clear();
            continue;
        };
        let (mut s, mut y) = spare
            .take()
            .unwrap_or_else(|| (DVector::zeros(n), DVector::zeros(n)));
        s.copy_from(&x_new);
        s -= &x;
        y.copy_from(&g_new);
        y -= &g;
        let sy = dot(&s, &y);
        if sy > 1e-12 * norm(&s) * norm(&y) {
            if pairs.len() == memory
                && let Some((old_s, old_y, _)) = pairs.pop_front()
            {
                spare = Some((old_s, old_y));
            }
            pairs.push_back((s, y, 1.0 / sy));
        } else {
            spare = Some((s, y));
        }
        std::mem::swap(&mut x, &mut x_new);
        std::mem::swap(&mut g, &mut g_new);
        fx = f_new;
        if after(iter, fx, &x) == Next::Stop {
            return (x, fx, LbfgsStop::Callback);
        }
    }
    (x, fx, LbfgsStop::MaxIterations)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn minimises_the_rosenbrock_function() {
        let rosen = |x: &DVector<f64>, g: &mut DVector<f64>| {
            let mut f = 0.0;
            g.fill(0.0);
            for i in 0..x.len() - 1 {
                let (a, b) = (x[i], x[i + 1]);
                f += 100.0 * (b - a * a).powi(2) + (1.0 - a).powi(2);
                g[i] += -400.0 * a * (b - a * a) - 2.0 * (1.0 - a);
                g[i + 1] += 200.0 * (b - a * a);
            }
            f
        };
        let x0 = DVector::from_vec(vec![-1.2, 1.0, -1.2, 1.0, 0.5]);
        let (x, fx, stop) = minimize(x0, 7, 500, 1e-9, rosen, |_, _, _| Next::Continue);
        assert!(fx < 1e-14, "{fx} {stop:?}");
        assert!((x.add_scalar(-1.0)).amax() < 1e-6, "{x}");
        assert_eq!(stop, LbfgsStop::MinGradient);
    }

    #[test]
    fn the_callback_stops_it() {
        let quad = |x: &DVector<f64>, g: &mut DVector<f64>| {
            g.copy_from(x);
            0.5 * x.norm_squared()
        };
        let mut seen = 0;
        let (_, _, stop) = minimize(
            DVector::from_vec(vec![3.0, -2.0, 1.0]),
            5,
            100,
            0.0,
            quad,
            |it, _, _| {
                seen = it;
                if it == 2 { Next::Stop } else { Next::Continue }
            },
        );
        assert_eq!((stop, seen), (LbfgsStop::Callback, 2));
    }
}
