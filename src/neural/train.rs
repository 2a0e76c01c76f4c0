//! Training (thesis 3.2, 5.5): phase 1, gradient descent with momentum 0.9 and learning rate
//! 0.01 (burn); phase 2, Levenberg-Marquardt weight refinement as MATLAB's trainlm
//! (mu 1e-3, x10 on failure, x0.1 on success, up to 1e10), solved with nalgebra.
//!
//! Targets may be observed through a per-sample linear map of the network's output: the
//! residual of sample k is r_k = b_k - A_k y(x_k) ([`Samples`]); the thesis's pose network has
//! A_k = I, the joint-space network has A_k = (weighted) J(q_k), the model's joint Jacobian.
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

impl TrainStop {
    pub fn describe(self) -> &'static str {
        match self {
            TrainStop::Goal => "performance goal reached",
            TrainStop::MinGradient => "minimum gradient reached",
            TrainStop::ValidationFailures => "held-out error stopped improving (best epoch kept)",
            TrainStop::MaxEpochs => "epoch limit",
            TrainStop::MuMax => "mu above 1e10 (no step lowers the error)",
        }
    }
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

/// Training samples: normalised inputs `x[k]`, targets `b[k]` and optional maps `maps[k]`
/// (rows of b x network outputs); the residual is r_k = b_k - A_k y(x_k), A_k = I without maps.
#[derive(Debug, Clone, Default)]
pub struct Samples {
    pub x: Vec<Vec<f64>>,
    pub b: Vec<Vec<f64>>,
    pub maps: Option<Vec<DMatrix<f64>>>,
    /// Optional maps `lin[k]` (rows of b x m) of m parameters theta estimated together with
    /// the weights: r_k = b_k - A_k y(x_k) - L_k theta.
    pub lin: Option<Vec<DMatrix<f64>>>,
}

impl Samples {
    pub fn len(&self) -> usize {
        self.x.len()
    }

    pub fn is_empty(&self) -> bool {
        self.x.is_empty()
    }

    /// The samples at `idx`.
    pub fn pick(&self, idx: &[usize]) -> Samples {
        Samples {
            x: idx.iter().map(|&i| self.x[i].clone()).collect(),
            b: idx.iter().map(|&i| self.b[i].clone()).collect(),
            maps: self
                .maps
                .as_ref()
                .map(|m| idx.iter().map(|&i| m[i].clone()).collect()),
            lin: self
                .lin
                .as_ref()
                .map(|m| idx.iter().map(|&i| m[i].clone()).collect()),
        }
    }

    /// Number of linear parameters.
    pub fn linear_len(&self) -> usize {
        self.lin
            .as_ref()
            .and_then(|l| l.first())
            .map_or(0, |a| a.ncols())
    }

    /// The samples with targets b_k - L_k theta and no linear part.
    fn without_linear(&self, theta: &DVector<f64>) -> Samples {
        let mut out = self.clone();
        if let Some(l) = out.lin.take() {
            for (b, a) in out.b.iter_mut().zip(&l) {
                let lt = a * theta;
                b.iter_mut().zip(lt.iter()).for_each(|(v, d)| *v -= d);
            }
        }
        out
    }

    /// Least-squares theta with the network's output at zero.
    fn linear_start(&self) -> Option<DVector<f64>> {
        let l = self.lin.as_ref()?;
        let m = self.linear_len();
        let mut ata = DMatrix::<f64>::zeros(m, m);
        let mut atb = DVector::<f64>::zeros(m);
        for (a, b) in l.iter().zip(&self.b) {
            ata += a.tr_mul(a);
            atb += a.tr_mul(&DVector::from_column_slice(b));
        }
        ata.cholesky().map(|c| c.solve(&atb))
    }

    /// Rows of each target (all equal, checked by [`train`]).
    pub fn rows(&self) -> usize {
        self.b.first().map_or(0, |b| b.len())
    }

    /// Writes r_k = b_k - A_k y - L_k theta into `r`.
    fn residual(&self, k: usize, y: &[f64], theta: &DVector<f64>, r: &mut [f64]) {
        self.residual_net(k, y, r);
        if let Some(l) = &self.lin {
            let a = &l[k];
            for (row, rr) in r.iter_mut().enumerate() {
                for (c, t) in theta.iter().enumerate() {
                    *rr -= a[(row, c)] * t;
                }
            }
        }
    }

    /// Writes b_k - A_k y into `r`.
    fn residual_net(&self, k: usize, y: &[f64], r: &mut [f64]) {
        match &self.maps {
            None => {
                for (c, rc) in r.iter_mut().enumerate() {
                    *rc = self.b[k][c] - y[c];
                }
            }
            Some(m) => {
                let a = &m[k];
                for (row, rr) in r.iter_mut().enumerate() {
                    let mut s = self.b[k][row];
                    for (c, yc) in y.iter().enumerate() {
                        s -= a[(row, c)] * yc;
                    }
                    *rr = s;
                }
            }
        }
    }
}

/// Mean squared residual over all samples and rows.
fn mse(w: &Weights, theta: &DVector<f64>, s: &Samples) -> f64 {
    if s.is_empty() {
        return 0.0;
    }
    let mut h = vec![0.0; w.hidden()];
    let mut out = vec![0.0; w.outputs()];
    let mut r = vec![0.0; s.rows()];
    let mut sum = 0.0;
    for k in 0..s.len() {
        w.forward_into(&s.x[k], &mut h, &mut out);
        s.residual(k, &out, theta, &mut r);
        sum += r.iter().map(|v| v * v).sum::<f64>();
    }
    sum / (s.len() * s.rows()) as f64
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

/// Network weights and the linear parameters estimated with them.
#[derive(Debug, Clone, PartialEq)]
pub struct Fit {
    pub weights: Weights,
    pub theta: DVector<f64>,
}

impl Fit {
    fn to_vector(&self) -> DVector<f64> {
        let w = self.weights.to_vector();
        let mut v = DVector::zeros(w.len() + self.theta.len());
        v.rows_mut(0, w.len()).copy_from(&w);
        v.rows_mut(w.len(), self.theta.len()).copy_from(&self.theta);
        v
    }

    fn with_vector(&self, v: &DVector<f64>) -> Fit {
        let p = self.weights.len();
        Fit {
            weights: self.weights.from_vector(&v.rows(0, p).into_owned()),
            theta: v.rows(p, self.theta.len()).into_owned(),
        }
    }

    fn mse(&self, s: &Samples) -> f64 {
        mse(&self.weights, &self.theta, s)
    }
}

/// One LM (trainlm) step loop from `fit`: the Jacobian of A_k y + L_k theta with respect to
/// weights and theta, steps solved by Cholesky with mu on the diagonal (x0.1 on success, x10
/// on failure).
fn lm_step(fit: &Fit, s: &Samples, mu: &mut f64, min_grad: f64) -> Result<LmOutcome> {
    let w = &fit.weights;
    let (no, pw, nr, m) = (w.outputs(), w.len(), s.rows(), fit.theta.len());
    let p = pw + m;
    let rows = s.len() * nr;
    let mut jac = DMatrix::<f64>::zeros(rows, p);
    let mut blk = DMatrix::<f64>::zeros(no, pw);
    let mut e = DVector::<f64>::zeros(rows);
    let mut h = vec![0.0; w.hidden()];
    let mut out = vec![0.0; no];
    let mut r = vec![0.0; nr];
    for k in 0..s.len() {
        // The residual's Jacobian is -[A_k dy/dw, L_k]; the step below uses its negative.
        w.jacobian_into(&s.x[k], &mut h, &mut out, &mut blk, 0);
        let mut rows_k = jac.view_mut((k * nr, 0), (nr, pw));
        match &s.maps {
            None => rows_k.copy_from(&blk),
            Some(a) => rows_k.gemm(1.0, &a[k], &blk, 0.0),
        }
        if let Some(l) = &s.lin {
            jac.view_mut((k * nr, pw), (nr, m)).copy_from(&l[k]);
        }
        s.residual(k, &out, &fit.theta, &mut r);
        e.rows_mut(k * nr, nr).copy_from_slice(&r);
    }
    let a = jac.tr_mul(&jac);
    let g = jac.tr_mul(&e);
    if g.amax() < min_grad {
        return Ok(LmOutcome::MinGradient);
    }
    let perf = e.norm_squared() / rows as f64;
    let v = fit.to_vector();
    while *mu <= 1e10 {
        let mut mat = a.clone();
        for i in 0..p {
            mat[(i, i)] += *mu;
        }
        if let Some(ch) = mat.cholesky() {
            let cand = fit.with_vector(&(&v + ch.solve(&g)));
            let c = cand.mse(s);
            if c.is_finite() && c < perf {
                *mu *= 0.1;
                return Ok(LmOutcome::Step(cand, c));
            }
        }
        *mu *= 10.0;
    }
    Ok(LmOutcome::MuMax)
}

/// The best fit by validation error, and how many epochs in a row failed to beat it.
struct Best {
    mse: f64,
    fit: Fit,
    fails: usize,
}

impl Best {
    fn new(mse: f64, fit: Fit) -> Self {
        Best { mse, fit, fails: 0 }
    }

    /// Records an epoch's validation error; returns the failures in a row.
    fn record(&mut self, mse: f64, fit: &Fit) -> usize {
        if mse < self.mse {
            self.mse = mse;
            self.fit = fit.clone();
            self.fails = 0;
        } else {
            self.fails += 1;
        }
        self.fails
    }
}

enum LmOutcome {
    Step(Fit, f64),
    MinGradient,
    MuMax,
}

/// Trains a network with `hidden` sigmoid units on `samples` (normalised inputs, targets of
/// unit scale), with the linear parameters of `samples.lin` if any (started at their
/// least-squares values, held there in phase 1, refined with the weights in phase 2).
pub fn train(samples: &Samples, outputs: usize, opts: &TrainOptions) -> Result<(Fit, TrainReport)> {
    let n = samples.len();
    if samples.b.len() != n || n < 4 {
        return Err(Error::Invalid(format!(
            "training needs at least 4 samples (got {n})"
        )));
    }
    let rows = samples.rows();
    let m = samples.linear_len();
    let shapes_ok = samples.b.iter().all(|b| b.len() == rows)
        && match &samples.maps {
            None => rows == outputs,
            Some(a) => a.len() == n && a.iter().all(|a| a.shape() == (rows, outputs)),
        }
        && samples
            .lin
            .as_ref()
            .is_none_or(|l| l.len() == n && l.iter().all(|a| a.shape() == (rows, m)));
    if !shapes_ok {
        return Err(Error::Invalid("training samples of unequal shapes".into()));
    }
    if opts.hidden == 0 {
        return Err(Error::Invalid(
            "the hidden layer needs at least one unit".into(),
        ));
    }
    // Held-out validation rows, by a seeded draw.
    let mut idx: Vec<usize> = (0..n).collect();
    idx.shuffle(&mut ChaCha8Rng::seed_from_u64(opts.seed ^ 0x5eed));
    let n_val = ((n as f64) * opts.validation_fraction).round() as usize;
    let (vi, ti) = idx.split_at(n_val.min(n - 2));
    let (st, sv) = (samples.pick(ti), samples.pick(vi));
    let val = |f: &Fit| {
        if sv.is_empty() {
            f.mse(&st)
        } else {
            f.mse(&sv)
        }
    };
    let theta0 = match m {
        0 => DVector::zeros(0),
        _ => st.linear_start().ok_or_else(|| {
            Error::Invalid(
                "the linear parameters are not identifiable from the training rows".into(),
            )
        })?,
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
    let start = Fit {
        weights: initial_weights(samples.x[0].len(), opts.hidden, outputs, opts.seed),
        theta: theta0.clone(),
    };
    let mut best = Best::new(val(&start), start.clone());
    let mut stop = None;
    let mut momentum_epochs = 0;
    // Phase 1 ends on the goal (training is done) or on its own validation failures (phase 2
    // then refines the best weights so far).
    let mut phase1_done = false;
    let with_theta = |w: &Weights| Fit {
        weights: w.clone(),
        theta: theta0.clone(),
    };
    let after_momentum = train_momentum(
        &start.weights,
        &st.without_linear(&theta0),
        opts.momentum_epochs,
        |epoch, train_mse, w| {
            momentum_epochs = epoch;
            let f = with_theta(w);
            let v = val(&f);
            curve.push((epoch, train_mse, v));
            bar.set_position(epoch as u64);
            bar.set_message(format!("train {train_mse:.3e} validation {v:.3e}"));
            let fails = best.record(v, &f);
            if train_mse <= opts.goal {
                stop = Some(TrainStop::Goal);
            } else if fails >= opts.max_fail * 10 {
                // Gradient descent is noisy: allow it ten times the patience of the LM phase.
                phase1_done = true;
            }
            stop.is_none() && !phase1_done
        },
    )?;
    let after_momentum = with_theta(&after_momentum);
    let mut fit = if best.mse < val(&after_momentum) {
        best.fit.clone()
    } else {
        after_momentum
    };
    best = Best::new(val(&fit), fit.clone());
    let mut mu = 1e-3;
    let mut lm_epochs = 0;
    while stop.is_none() {
        if lm_epochs >= opts.max_epochs {
            stop = Some(TrainStop::MaxEpochs);
            break;
        }
        match lm_step(&fit, &st, &mut mu, opts.min_grad)? {
            LmOutcome::MinGradient => stop = Some(TrainStop::MinGradient),
            LmOutcome::MuMax => stop = Some(TrainStop::MuMax),
            LmOutcome::Step(next, train_mse) => {
                lm_epochs += 1;
                fit = next;
                let v = val(&fit);
                curve.push((momentum_epochs + lm_epochs, train_mse, v));
                bar.set_position((opts.momentum_epochs + lm_epochs) as u64);
                bar.set_message(format!("train {train_mse:.3e} validation {v:.3e} (LM)"));
                let fails = best.record(v, &fit);
                if train_mse <= opts.goal {
                    stop = Some(TrainStop::Goal);
                } else if !sv.is_empty() && fails >= opts.max_fail {
                    stop = Some(TrainStop::ValidationFailures);
                }
            }
        }
    }
    bar.finish_and_clear();
    let fit = best.fit;
    let report = TrainReport {
        stop: stop.unwrap_or(TrainStop::MaxEpochs),
        momentum_epochs,
        lm_epochs,
        train_mse: fit.mse(&st),
        validation_mse: val(&fit),
        curve,
    };
    Ok((fit, report))
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
        let s = Samples {
            x: x.clone(),
            b: y.clone(),
            maps: None,
            lin: None,
        };
        let (f, report) = train(&s, 1, &opts).unwrap();
        assert!(report.lm_epochs > 0);
        assert_eq!(report.stop, TrainStop::Goal, "{:?}", report.stop);
        assert!(f.mse(&s) < 2e-5);
        // Fresh points: the function is learnt, not the samples.
        let xs: Vec<Vec<f64>> = (0..50).map(|k| vec![k as f64 / 25.0 - 1.0, 0.3]).collect();
        let ys: Vec<Vec<f64>> = xs
            .iter()
            .map(|v| vec![(2.0 * v[0]).sin() * v[1].cos()])
            .collect();
        let fresh = Samples {
            x: xs,
            b: ys,
            maps: None,
            lin: None,
        };
        assert!(f.mse(&fresh) < 1e-4);
        // Same seed, same network.
        let (f2, _) = train(&s, 1, &opts).unwrap();
        assert_eq!(f, f2);
    }

    #[test]
    fn mapped_outputs_and_linear_parameters_are_learnt_together() {
        // b_k = A_k f(x_k) + L_k theta*, with f(x) = (sin 2x, x^2 - 0.3) and random maps: the
        // network learns f only through A_k, and theta* is recovered.
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        let theta_true = DVector::from_vec(vec![0.7, -0.4]);
        let mut s = Samples {
            maps: Some(Vec::new()),
            lin: Some(Vec::new()),
            ..Default::default()
        };
        for _ in 0..300 {
            let x: f64 = rng.random_range(-1.0..1.0);
            let a = DMatrix::from_fn(3, 2, |_, _| rng.random_range(-1.0..1.0));
            let l = DMatrix::from_fn(3, 2, |_, _| rng.random_range(-1.0..1.0));
            let f = DVector::from_vec(vec![(2.0 * x).sin(), x * x - 0.3]);
            let b = &a * f + &l * &theta_true;
            s.x.push(vec![x]);
            s.b.push(b.iter().copied().collect());
            s.maps.as_mut().unwrap().push(a);
            s.lin.as_mut().unwrap().push(l);
        }
        let opts = TrainOptions {
            hidden: 6,
            goal: 1e-8,
            max_epochs: 500,
            ..Default::default()
        };
        let (fit, report) = train(&s, 2, &opts).unwrap();
        assert!(fit.mse(&s) < 1e-6, "{report:?}");
        assert!(
            (&fit.theta - &theta_true).amax() < 1e-3,
            "theta {} vs {theta_true}",
            fit.theta
        );
        // The network itself is f, seen through no map at all.
        for x in [-0.8, -0.2, 0.5] {
            let y = fit.weights.forward(&[x]);
            assert!((y[0] - (2.0 * x).sin()).abs() < 1e-2, "{x}: {y:?}");
            assert!((y[1] - (x * x - 0.3)).abs() < 1e-2, "{x}: {y:?}");
        }
    }
}
