//! Limited-memory BFGS (Nocedal and Wright, Algorithm 7.4 and 7.5) with a backtracking
//! Armijo line search: the weight-refining phase where a dense Levenberg-Marquardt normal
//! matrix (residual rows x weights^2) would cost too much.
//!
//! Small and ours because the training needs a per-iteration callback (validation-failure
//! stopping, progress) that minimiser crates do not offer.

use super::fused::{Then, differences, step_to, update_dot};
use super::vectors::{amax, dot, dot_in, norm};
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
    let mut pairs: VecDeque<Pair> = VecDeque::with_capacity(memory);
    let mut alpha = vec![0.0; memory];
    let (mut d, mut x_new, mut g_new) = (DVector::zeros(n), DVector::zeros(n), DVector::zeros(n));
    // The next pair's storage: the pair dropped from a full memory, or one not kept, is
    // written again (no allocation once the memory is full).
    let mut spare: Option<(DVector<f64>, DVector<f64>)> = None;
    for iter in 1..=max_iter {
        if amax(&g) < min_grad {
            return (x, fx, LbfgsStop::MinGradient);
        }
        let mut slope = direction(&pairs, &g, &mut d, &mut alpha);
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
            step_to(x_new.as_mut_slice(), x.as_slice(), step, d.as_slice());
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
        let (ss, yy, sy) = differences(&mut s, &x_new, &x, &mut y, &g_new, &g);
        if sy > 1e-12 * ss.sqrt() * yy.sqrt() {
            if pairs.len() == memory
                && let Some(old) = pairs.pop_front()
            {
                spare = Some((old.s, old.y));
            }
            pairs.push_back(Pair {
                s,
                y,
                rho: 1.0 / sy,
                sy,
                yy,
            });
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

/// A correction pair of the memory: s = x_{k+1} - x_k, y = g_{k+1} - g_k, rho = 1 / (s . y),
/// and the dot products s . y and y . y (the scaling of the initial Hessian, Nocedal and
/// Wright eq. 7.20, when the pair is the newest), taken when the pair was formed.
struct Pair {
    s: DVector<f64>,
    y: DVector<f64>,
    rho: f64,
    sy: f64,
    yy: f64,
}

/// The search direction d = -H g of the two-loop recursion (Nocedal and Wright, Algorithm
/// 7.4) into `d`, H0 = gamma I with gamma = s.y / y.y of the newest pair (1 / |g| without
/// pairs); returns the slope g . d. Each update of d and the dot product the next step takes
/// of it are one pass ([`update_dot`]), with the bits of the separate operations:
/// alpha_k = rho_k s_k . d, d <- d - alpha_k y_k (newest pair first), d <- gamma d,
/// beta_k = rho_k y_k . d, d <- d + (alpha_k - beta_k) s_k (oldest first), d <- -d.
fn direction(
    pairs: &VecDeque<Pair>,
    g: &DVector<f64>,
    d: &mut DVector<f64>,
    alpha: &mut [f64],
) -> f64 {
    d.copy_from(g);
    let (Some(newest), Some(oldest)) = (pairs.back(), pairs.front()) else {
        *d *= 1.0 / norm(g).max(1e-300);
        d.neg_mut();
        return dot(g, d);
    };
    let gamma = newest.sy / newest.yy;
    let m = pairs.len();
    let d = d.as_mut_slice();
    // The dot product the next step needs, of the d the last update left.
    let mut next = dot_in(newest.s.as_slice(), d);
    for k in (0..m).rev() {
        let p = &pairs[k];
        alpha[k] = p.rho * next;
        // After the last pair of the first loop, d is scaled and the second loop begins.
        let (then, of) = match k {
            0 => (Then::Scale(gamma), &oldest.y),
            _ => (Then::Keep, &pairs[k - 1].s),
        };
        next = update_dot(d, -alpha[k], p.y.as_slice(), then, of.as_slice());
    }
    for k in 0..m {
        let p = &pairs[k];
        let beta = p.rho * next;
        // After the last pair, d is negated and the slope is its dot product with g.
        let (then, of) = match pairs.get(k + 1) {
            Some(after) => (Then::Keep, &after.y),
            None => (Then::Negate, g),
        };
        next = update_dot(d, alpha[k] - beta, p.s.as_slice(), then, of.as_slice());
    }
    next
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The two-loop recursion as separate operations (nalgebra's `dot`, `axpy`, `*=` and
    /// `neg_mut`, with [`crate::neural::vectors`]' bits), one after the other.
    fn direction_separately(pairs: &VecDeque<Pair>, g: &DVector<f64>) -> (DVector<f64>, f64) {
        use crate::neural::vectors::axpy;
        let mut d = g.clone();
        let mut alpha = vec![0.0; pairs.len()];
        for (k, p) in pairs.iter().enumerate().rev() {
            alpha[k] = p.rho * dot(&p.s, &d);
            axpy(&mut d, -alpha[k], &p.y);
        }
        let gamma = pairs.back().map_or(1.0 / norm(g).max(1e-300), |p| {
            dot(&p.s, &p.y) / dot(&p.y, &p.y)
        });
        d *= gamma;
        for (k, p) in pairs.iter().enumerate() {
            let beta = p.rho * dot(&p.y, &d);
            axpy(&mut d, alpha[k] - beta, &p.s);
        }
        d.neg_mut();
        let slope = dot(g, &d);
        (d, slope)
    }

    #[test]
    fn the_fused_direction_has_the_separate_operations_bits() {
        let mut next = crate::neural::vectors::tests::values(0x2545_f491_4f6c_dd1d_u64);
        for (n, m) in [(1, 1), (9, 3), (992, 10), (1190, 7), (37, 0)] {
            let mut v = || DVector::from_fn(n, |_, _| next());
            let g = v();
            let mut pairs = VecDeque::new();
            for _ in 0..m {
                let (s, y) = (v(), v());
                let (sy, yy) = (dot(&s, &y), dot(&y, &y));
                pairs.push_back(Pair {
                    rho: 1.0 / sy,
                    s,
                    y,
                    sy,
                    yy,
                });
            }
            let (want, want_slope) = direction_separately(&pairs, &g);
            let mut d = DVector::from_element(n, f64::NAN);
            let mut alpha = vec![0.0; m];
            let slope = direction(&pairs, &g, &mut d, &mut alpha);
            assert_eq!(slope.to_bits(), want_slope.to_bits(), "slope, {n} x {m}");
            assert!(
                d.iter()
                    .zip(want.iter())
                    .all(|(a, b)| a.to_bits() == b.to_bits()),
                "direction, {n} x {m}"
            );
        }
    }

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
