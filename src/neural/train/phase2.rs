//! Phase 2, refining the weights phase 1 left: Levenberg-Marquardt as MATLAB's trainlm (mu
//! 1e-3, x10 on failure, x0.1 on success, up to 1e10; the dense normal matrix solved with
//! nalgebra's Cholesky), or L-BFGS on the same penalised objective where that matrix would
//! cost too much (with variable projection of the output layer where the outputs are linear
//! in it).

use super::options::{TrainOptions, TrainStop};
use crate::neural::batch::Batch;
use crate::neural::lbfgs::{self, LbfgsStop, Next};
use crate::neural::samples::{Samples, penalty_mask, weight_norm2};
use crate::neural::weights::Weights;
use nalgebra::{DMatrix, DVector};

/// The penalised objective times M: sum |r|^2 + lambda |W|^2.
fn penalised_sum(w: &Weights, s: &Samples, lambda: f64) -> f64 {
    s.mse(w) * s.components() as f64 + lambda * weight_norm2(w)
}

/// One LM (trainlm) step loop from `w`, whose sum |r|^2 + lambda |W|^2 is `perf`: the
/// Jacobian of A_k y by every weight, steps (J^T J + lambda D + mu I) dw = J^T e - lambda D w
/// solved by Cholesky (D: 1 on weights, 0 on biases), mu x0.1 on success, x10 on failure.
fn lm_step(
    w: &Weights,
    perf: f64,
    s: &Samples,
    mu: &mut f64,
    min_grad: f64,
    lambda: f64,
) -> LmOutcome {
    let (a, g) = lm_system(w, s, lambda);
    if g.amax() < min_grad {
        return LmOutcome::MinGradient;
    }
    let (p, v, mask) = (w.len(), w.to_vector(), penalty_mask(w));
    while *mu <= 1e10 {
        let mut mat = a.clone();
        for i in 0..p {
            mat[(i, i)] += *mu + lambda * mask[i];
        }
        if let Some(ch) = mat.cholesky() {
            let cand = w.from_vector(&(&v + ch.solve(&g)));
            let c = penalised_sum(&cand, s, lambda);
            if c.is_finite() && c < perf {
                *mu *= 0.1;
                return LmOutcome::Step(cand, c);
            }
        }
        *mu *= 10.0;
    }
    LmOutcome::MuMax
}

/// LM's normal matrix J^T J and right-hand side J^T e - lambda D w at `w`, J the Jacobian of
/// every sample's mapped outputs A_k y by every weight, e the residuals: the right-hand side
/// is minus half the gradient of [`penalised_sum`].
fn lm_system(w: &Weights, s: &Samples, lambda: f64) -> (DMatrix<f64>, DVector<f64>) {
    let (no, p, nr) = (w.outputs(), w.len(), s.rows());
    let rows = s.len() * nr;
    let mut jac = DMatrix::<f64>::zeros(rows, p);
    let mut blk = DMatrix::<f64>::zeros(no, p);
    let mut e = DVector::<f64>::zeros(rows);
    let mut h = vec![0.0; w.hidden()];
    let mut out = vec![0.0; no];
    let mut r = vec![0.0; nr];
    for k in 0..s.len() {
        w.jacobian_into(&s.x[k], &mut h, &mut out, &mut blk, 0);
        let mut rows_k = jac.view_mut((k * nr, 0), (nr, p));
        match &s.maps {
            None => rows_k.copy_from(&blk),
            Some(a) => rows_k.gemm(1.0, &a[k], &blk, 0.0),
        }
        s.residual(k, &out, &mut r);
        e.rows_mut(k * nr, nr).copy_from_slice(&r);
    }
    let g = jac.tr_mul(&e) - penalty_mask(w).component_mul(&w.to_vector()) * lambda;
    (jac.tr_mul(&jac), g)
}

/// Relative held-out gain below which an L-BFGS iteration counts as a failure: its iterations
/// are many and small, and an ever slower creep would otherwise run to the iteration limit.
const LBFGS_MIN_GAIN: f64 = 1e-4;

enum LmOutcome {
    /// The accepted weights and their sum |r|^2 + lambda |W|^2.
    Step(Weights, f64),
    MinGradient,
    MuMax,
}

/// What phase 2 reports after each epoch: (epoch, weights, penalised objective, patience,
/// least relative gain that counts as progress) -> a reason to stop, if any.
pub(super) type Record<'a> = dyn FnMut(usize, &Weights, f64, usize, f64) -> Option<TrainStop> + 'a;

/// Phase 2 by Levenberg-Marquardt (MATLAB trainlm) from `w`; the epochs taken in `epochs`.
pub(super) fn phase2_lm(
    mut w: Weights,
    st: &Samples,
    lambda: f64,
    opts: &TrainOptions,
    epochs: &mut usize,
    record: &mut Record,
) -> TrainStop {
    let components = st.components() as f64;
    let mut perf = penalised_sum(&w, st, lambda);
    let mut mu = 1e-3;
    loop {
        if *epochs >= opts.max_epochs {
            return TrainStop::MaxEpochs;
        }
        match lm_step(&w, perf, st, &mut mu, opts.min_grad, lambda) {
            LmOutcome::MinGradient => return TrainStop::MinGradient,
            LmOutcome::MuMax => return TrainStop::MuMax,
            LmOutcome::Step(next, sum) => {
                *epochs += 1;
                (w, perf) = (next, sum);
                if let Some(stop) = record(*epochs, &w, sum / components, opts.max_fail, 0.0) {
                    return stop;
                }
            }
        }
    }
}

/// Phase 2 by L-BFGS from `w`. Without maps the outputs are linear in the output layer:
/// L-BFGS moves the hidden layer only and the output layer is solved exactly every time
/// (variable projection). The iterations taken in `epochs`.
pub(super) fn phase2_lbfgs(
    w: Weights,
    st: &Samples,
    lambda: f64,
    opts: &TrainOptions,
    epochs: &mut usize,
    record: &mut Record,
) -> TrainStop {
    let components = st.components() as f64;
    let shape = w.clone();
    let mut batch = Batch::new(st, &w);
    let project = st.maps.is_none();
    let hidden_len = w.hidden() * (w.inputs() + 1);
    let x0 = if project {
        w.to_vector().rows(0, hidden_len).into_owned()
    } else {
        w.to_vector()
    };
    let full = std::cell::RefCell::new(w.to_vector());
    let mut grad_full = DVector::zeros(w.len());
    // The weights at the point L-BFGS asks for, rewritten in place at every evaluation.
    let scratch = std::cell::RefCell::new(shape);
    let load = |v: &DVector<f64>| {
        let mut f = full.borrow_mut();
        f.rows_mut(0, v.len()).copy_from(v);
        scratch.borrow_mut().read_vector(&f);
    };
    let mut stop = None;
    let (_, _, why) = lbfgs::minimize(
        x0,
        10,
        opts.max_epochs * 10,
        // The objective is a mean: its gradient is 2 / M times LM's J^T e.
        opts.min_grad * 2.0 / components,
        |v, g| {
            load(v);
            let mut w = scratch.borrow_mut();
            if project {
                let f = batch.objective_projected(&mut w, lambda, &mut grad_full);
                w.write_vector(&mut full.borrow_mut());
                g.copy_from(&grad_full.rows(0, hidden_len));
                f
            } else {
                batch.objective(&w, lambda, g)
            }
        },
        |it, f, v| {
            *epochs = it;
            load(v);
            let w = scratch.borrow();
            stop = record(it, &w, f, opts.max_fail * 10, LBFGS_MIN_GAIN);
            if stop.is_some() {
                Next::Stop
            } else {
                Next::Continue
            }
        },
    );
    stop.unwrap_or(match why {
        LbfgsStop::MinGradient => TrainStop::MinGradient,
        LbfgsStop::LineSearch => TrainStop::MuMax,
        LbfgsStop::MaxIterations | LbfgsStop::Callback => TrainStop::MaxEpochs,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::neural::samples::objective;

    /// LM's right-hand side is minus half the gradient of the penalised sum, which the
    /// objective's own gradient (checked against central differences in `batch`) gives:
    /// with and without maps, the penalty on the weights alone. And J^T J is the
    /// Gauss-Newton matrix: along a direction d, d^T J^T J d is |J d|^2, |J d| the residuals'
    /// change per unit step by central differences.
    #[test]
    fn lm_system_is_the_penalised_sums_gradient_and_gauss_newton_matrix() {
        for with_maps in [false, true] {
            let (w, s) = crate::neural::samples::test_fixture(with_maps, 6);
            let lambda = 0.7;
            let (a, g) = lm_system(&w, &s, lambda);
            let mut grad = DVector::zeros(w.len());
            objective(&s, &w, lambda, &mut grad);
            // The objective is the penalised sum over M components.
            let half = grad * (s.components() as f64 / 2.0);
            assert!(
                (&g + &half).amax() < 1e-10 * (1.0 + half.amax()),
                "maps {with_maps}"
            );
            // d^T A d against |J d|^2 from the residuals' central differences.
            let d = DVector::from_fn(w.len(), |i, _| ((i * 3) as f64 * 0.41).cos());
            let residuals = |v: &DVector<f64>| {
                let wv = w.from_vector(v);
                let mut r = vec![0.0; s.rows()];
                let mut out = vec![0.0; wv.outputs()];
                let mut h = vec![0.0; wv.hidden()];
                let mut blk = DMatrix::zeros(wv.outputs(), wv.len());
                (0..s.len())
                    .flat_map(|k| {
                        wv.jacobian_into(&s.x[k], &mut h, &mut out, &mut blk, 0);
                        s.residual(k, &out, &mut r);
                        r.clone()
                    })
                    .collect::<Vec<f64>>()
            };
            let (v, e) = (w.to_vector(), 1e-6);
            let (rp, rm) = (residuals(&(&v + &d * e)), residuals(&(&v - &d * e)));
            let jd2: f64 = (rp.iter().zip(&rm))
                .map(|(p, m)| ((p - m) / (2.0 * e)).powi(2))
                .sum();
            let dad = d.dot(&(&a * &d));
            assert!(
                (dad - jd2).abs() < 1e-6 * jd2,
                "maps {with_maps}: {dad} vs {jd2}"
            );
        }
    }
}
