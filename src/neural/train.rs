//! Training (thesis 3.2, 5.5): phase 1, gradient descent with momentum 0.9 and learning rate
//! 0.01 (burn); phase 2, Levenberg-Marquardt weight refinement as MATLAB's trainlm
//! (mu 1e-3, x10 on failure, x0.1 on success, up to 1e10), solved with nalgebra.
//!
//! Stopping rules (the thesis's Neural Networks tab, MATLAB's defaults): the performance
//! (mean squared error of the normalised outputs) reaches `goal`; the gradient falls below
//! `min_grad`; the validation error (on a held-out part of the training data) has not improved
//! for `max_fail` epochs in a row (the weights of its best epoch are kept); `max_epochs`.

use super::net::train_momentum;
use super::weights::Weights;
use crate::error::{Error, Result};
use nalgebra::{DMatrix, DVector};
use rand::seq::SliceRandom;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Training settings.
#[derive(Debug, Clone)]
pub struct TrainOptions {
    pub hidden: usize,
    pub seed: u64,
    /// Phase-1 epochs (full batch).
    pub momentum_epochs: usize,
    /// Phase-2 epoch limit.
    pub max_epochs: usize,
    /// Performance goal (MSE of normalised outputs).
    pub goal: f64,
    /// Smallest gradient norm (max |J^T e|) before stopping.
    pub min_grad: f64,
    /// Validation failures in a row before stopping.
    pub max_fail: usize,
    /// Part of the training rows held out for validation.
    pub validation_fraction: f64,
    /// Show a progress bar (on a terminal).
    pub progress: bool,
}

impl Default for TrainOptions {
    fn default() -> Self {
        TrainOptions {
            hidden: 20,
            seed: 1,
            momentum_epochs: 200,
            max_epochs: 200,
            goal: 0.0,
            min_grad: 1e-7,
            max_fail: 6,
            validation_fraction: 0.15,
            progress: false,
        }
    }
}

/// Why training stopped.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum TrainStop {
    Goal,
    MinGradient,
    ValidationFailures,
    MaxEpochs,
    /// mu exceeded 1e10: no step lowers the error.
    MuMax,
}

/// What training did.
#[derive(Debug, Clone, serde::Serialize)]
pub struct TrainReport {
    pub stop: TrainStop,
    pub momentum_epochs: usize,
    pub lm_epochs: usize,
    /// Final MSE (normalised outputs) on the training and validation parts.
    pub train_mse: f64,
    pub validation_mse: f64,
    /// (epoch, training MSE, validation MSE) over both phases.
    pub curve: Vec<(usize, f64, f64)>,
}

fn mse(w: &Weights, x: &[Vec<f64>], y: &[Vec<f64>]) -> f64 {
    if x.is_empty() {
        return 0.0;
    }
    let mut h = vec![0.0; w.hidden()];
    let mut out = vec![0.0; w.outputs()];
    let mut s = 0.0;
    for (xi, yi) in x.iter().zip(y) {
        w.forward_into(xi, &mut h, &mut out);
        s += out
            .iter()
            .zip(yi)
            .map(|(a, b)| (a - b).powi(2))
            .sum::<f64>();
    }
    s / (x.len() * w.outputs()) as f64
}

/// Seeded initial weights, U(-k, k) with k = sqrt(1 / fan-in) (burn's default for Linear).
pub fn initial_weights(inputs: usize, hidden: usize, outputs: usize, seed: u64) -> Weights {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut u = |fan_in: usize| {
        let k = (1.0 / fan_in as f64).sqrt();
        rng.random_range(-k..k)
    };
    let w1 = DMatrix::from_fn(hidden, inputs, |_, _| u(inputs));
    let b1 = DVector::from_fn(hidden, |_, _| u(inputs));
    let w2 = DMatrix::from_fn(outputs, hidden, |_, _| u(hidden));
    let b2 = DVector::from_fn(outputs, |_, _| u(hidden));
    Weights { w1, b1, w2, b2 }
}

/// One LM (trainlm) step loop from `w`; returns the accepted weights and their training MSE,
/// or None when mu passed 1e10.
fn lm_step(
    w: &Weights,
    x: &[Vec<f64>],
    y: &[Vec<f64>],
    mu: &mut f64,
    min_grad: f64,
) -> Result<LmOutcome> {
    let (no, p) = (w.outputs(), w.len());
    let rows = x.len() * no;
    let mut jac = DMatrix::<f64>::zeros(rows, p);
    let mut e = DVector::<f64>::zeros(rows);
    let mut h = vec![0.0; w.hidden()];
    let mut out = vec![0.0; no];
    for (k, (xi, yi)) in x.iter().zip(y).enumerate() {
        w.jacobian_into(xi, &mut h, &mut jac, k * no);
        w.forward_into(xi, &mut h, &mut out);
        for c in 0..no {
            e[k * no + c] = yi[c] - out[c];
        }
    }
    let a = jac.tr_mul(&jac);
    let g = jac.tr_mul(&e);
    if g.amax() < min_grad {
        return Ok(LmOutcome::MinGradient);
    }
    let perf = e.norm_squared() / rows as f64;
    let v = w.to_vector();
    while *mu <= 1e10 {
        let mut m = a.clone();
        for i in 0..p {
            m[(i, i)] += *mu;
        }
        if let Some(ch) = m.cholesky() {
            let cand = w.from_vector(&(&v + ch.solve(&g)));
            let c = mse(&cand, x, y);
            if c.is_finite() && c < perf {
                *mu *= 0.1;
                return Ok(LmOutcome::Step(cand, c));
            }
        }
        *mu *= 10.0;
    }
    Ok(LmOutcome::MuMax)
}

/// The best weights by validation error, and how many epochs in a row failed to beat them.
struct Best {
    mse: f64,
    weights: Weights,
    fails: usize,
}

impl Best {
    fn new(mse: f64, weights: Weights) -> Self {
        Best {
            mse,
            weights,
            fails: 0,
        }
    }

    /// Records an epoch's validation error; returns the failures in a row.
    fn record(&mut self, mse: f64, w: &Weights) -> usize {
        if mse < self.mse {
            self.mse = mse;
            self.weights = w.clone();
            self.fails = 0;
        } else {
            self.fails += 1;
        }
        self.fails
    }
}

enum LmOutcome {
    Step(Weights, f64),
    MinGradient,
    MuMax,
}

/// Trains a network on normalised inputs `x` and targets `y`.
pub fn train(
    x: &[Vec<f64>],
    y: &[Vec<f64>],
    opts: &TrainOptions,
) -> Result<(Weights, TrainReport)> {
    if x.len() != y.len() || x.len() < 4 {
        return Err(Error::Invalid(format!(
            "training needs at least 4 samples (got {})",
            x.len()
        )));
    }
    if opts.hidden == 0 {
        return Err(Error::Invalid(
            "the hidden layer needs at least one unit".into(),
        ));
    }
    // Held-out validation rows, by a seeded draw.
    let mut idx: Vec<usize> = (0..x.len()).collect();
    idx.shuffle(&mut ChaCha8Rng::seed_from_u64(opts.seed ^ 0x5eed));
    let n_val = ((x.len() as f64) * opts.validation_fraction).round() as usize;
    let (vi, ti) = idx.split_at(n_val.min(x.len() - 2));
    let pick = |ix: &[usize], v: &[Vec<f64>]| ix.iter().map(|&i| v[i].clone()).collect::<Vec<_>>();
    let (xt, yt, xv, yv) = (pick(ti, x), pick(ti, y), pick(vi, x), pick(vi, y));
    let val = |w: &Weights| {
        if xv.is_empty() {
            mse(w, &xt, &yt)
        } else {
            mse(w, &xv, &yv)
        }
    };

    let bar = if opts.progress {
        let b = indicatif::ProgressBar::new((opts.momentum_epochs + opts.max_epochs) as u64);
        b.set_style(
            indicatif::ProgressStyle::with_template("{bar:30} epoch {pos}/{len} {msg}")
                .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
        );
        b
    } else {
        indicatif::ProgressBar::hidden()
    };
    let mut curve = Vec::new();
    let start = initial_weights(x[0].len(), opts.hidden, y[0].len(), opts.seed);
    let mut best = Best::new(val(&start), start.clone());
    let mut stop = None;
    let mut momentum_epochs = 0;
    // Phase 1 ends on the goal (training is done) or on its own validation failures (phase 2
    // then refines the best weights so far).
    let mut phase1_done = false;
    let after_momentum = train_momentum(
        &start,
        &xt,
        &yt,
        opts.momentum_epochs,
        |epoch, train_mse, w| {
            momentum_epochs = epoch;
            let v = val(w);
            curve.push((epoch, train_mse, v));
            bar.set_position(epoch as u64);
            bar.set_message(format!("train {train_mse:.3e} validation {v:.3e}"));
            let fails = best.record(v, w);
            if train_mse <= opts.goal {
                stop = Some(TrainStop::Goal);
            } else if fails >= opts.max_fail * 10 {
                // Gradient descent is noisy: allow it ten times the patience of the LM phase.
                phase1_done = true;
            }
            stop.is_none() && !phase1_done
        },
    )?;
    let mut w = if best.mse < val(&after_momentum) {
        best.weights.clone()
    } else {
        after_momentum
    };
    best = Best::new(val(&w), w.clone());
    let mut mu = 1e-3;
    let mut lm_epochs = 0;
    while stop.is_none() {
        if lm_epochs >= opts.max_epochs {
            stop = Some(TrainStop::MaxEpochs);
            break;
        }
        match lm_step(&w, &xt, &yt, &mut mu, opts.min_grad)? {
            LmOutcome::MinGradient => stop = Some(TrainStop::MinGradient),
            LmOutcome::MuMax => stop = Some(TrainStop::MuMax),
            LmOutcome::Step(next, train_mse) => {
                lm_epochs += 1;
                w = next;
                let v = val(&w);
                curve.push((momentum_epochs + lm_epochs, train_mse, v));
                bar.set_position((opts.momentum_epochs + lm_epochs) as u64);
                bar.set_message(format!("train {train_mse:.3e} validation {v:.3e} (LM)"));
                let fails = best.record(v, &w);
                if train_mse <= opts.goal {
                    stop = Some(TrainStop::Goal);
                } else if !xv.is_empty() && fails >= opts.max_fail {
                    stop = Some(TrainStop::ValidationFailures);
                }
            }
        }
    }
    bar.finish_and_clear();
    let w = best.weights;
    let report = TrainReport {
        stop: stop.unwrap_or(TrainStop::MaxEpochs),
        momentum_epochs,
        lm_epochs,
        train_mse: mse(&w, &xt, &yt),
        validation_mse: val(&w),
        curve,
    };
    Ok((w, report))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn training_reaches_the_goal_on_a_smooth_function() {
        // y = sin(2 x1) cos(x2) on [-1, 1]^2: a few hidden units represent it well.
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let x: Vec<Vec<f64>> = (0..200)
            .map(|_| vec![rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0)])
            .collect();
        let y: Vec<Vec<f64>> = x
            .iter()
            .map(|v| vec![(2.0 * v[0]).sin() * v[1].cos()])
            .collect();
        let opts = TrainOptions {
            hidden: 10,
            goal: 1e-5,
            momentum_epochs: 100,
            max_epochs: 500,
            ..Default::default()
        };
        let (w, report) = train(&x, &y, &opts).unwrap();
        assert!(report.lm_epochs > 0);
        assert_eq!(report.stop, TrainStop::Goal, "{:?}", report.stop);
        assert!(mse(&w, &x, &y) < 2e-5);
        // Fresh points: the function is learnt, not the samples.
        let xs: Vec<Vec<f64>> = (0..50).map(|k| vec![k as f64 / 25.0 - 1.0, 0.3]).collect();
        let ys: Vec<Vec<f64>> = xs
            .iter()
            .map(|v| vec![(2.0 * v[0]).sin() * v[1].cos()])
            .collect();
        assert!(mse(&w, &xs, &ys) < 1e-4);
        // Same seed, same network.
        let (w2, _) = train(&x, &y, &opts).unwrap();
        assert_eq!(w, w2);
    }
}
