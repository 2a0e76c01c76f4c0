//! Training (thesis 3.2, 5.5): phase 1, gradient descent with momentum 0.9 and learning rate
//! 0.01 (burn); phase 2, Levenberg-Marquardt weight refinement as MATLAB's trainlm
//! (mu 1e-3, x10 on failure, x0.1 on success, up to 1e10), solved with nalgebra, or L-BFGS
//! where LM's dense normal matrix would cost too much. Both phases minimise the penalised
//! objective of [`super::samples`] (residuals r_k = b_k - A_k y(x_k), L2 weight penalty).
//!
//! Stopping rules (the thesis's Neural Networks tab, MATLAB's defaults): the performance
//! (mean squared error of the normalised outputs) reaches `goal`; the gradient falls below
//! `min_grad`; the validation error (on a held-out part of the training data) has not improved
//! for `max_fail` epochs in a row (the weights of its best epoch are kept); `max_epochs`.

use super::batch::Batch;
use super::lbfgs::{self, LbfgsStop, Next};
use super::net::train_momentum;
use super::samples::{Samples, penalty_mask, weight_norm2};
use super::weights::Weights;
use crate::error::{Error, Result};
use nalgebra::{DMatrix, DVector};
use rand::seq::SliceRandom;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// The weight-refining phase.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Phase2 {
    /// Levenberg-Marquardt while its dense normal matrix is cheap to form and factorise
    /// (residual components x weights^2 + weights^3 / 3 <= [`LM_BUDGET`]), L-BFGS beyond.
    #[default]
    Auto,
    /// Levenberg-Marquardt (MATLAB trainlm), the thesis's.
    Lm,
    /// L-BFGS on the same penalised objective.
    Lbfgs,
}

/// Largest work of one LM epoch, residual components x weights^2 (the normal matrix) plus
/// weights^3 / 3 (its factorisation), for which `Phase2::Auto` uses Levenberg-Marquardt (a
/// few milliseconds per epoch on one core); beyond it an LM epoch costs more than a whole
/// L-BFGS run. Without the factorisation's part, a few rows chose LM for hundreds of
/// weights: 18 s to train on 7 rows against 1.3 s on 150.
pub const LM_BUDGET: f64 = 3e7;

/// What [`Phase2::Auto`] runs for `components` residual components and `weights` weights.
pub fn auto_phase2(components: usize, weights: usize) -> Phase2 {
    let (m, w) = (components as f64, weights as f64);
    if m * w * w + w * w * w / 3.0 <= LM_BUDGET {
        Phase2::Lm
    } else {
        Phase2::Lbfgs
    }
}

/// Where training stands, told after every epoch (and once more, `finished`, at the end).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Epoch {
    /// Epochs done of both phases, out of at most `total`.
    pub done: usize,
    /// Most epochs of both phases: phase-1 epochs plus the phase-2 limit.
    pub total: usize,
    /// Mean squared normalised residual of the training and the held-out rows.
    pub train_mse: f64,
    /// Held-out MSE (normalised outputs); without a held-out part, the penalised training
    /// objective per residual component.
    pub validation_mse: f64,
    /// True on the last report, after training ended.
    pub finished: bool,
}

/// A callback told each [`Epoch`] (a progress bar, a log): the library draws nothing itself.
#[derive(Clone)]
pub struct Progress(pub std::sync::Arc<dyn Fn(&Epoch) + Send + Sync>);

impl std::fmt::Debug for Progress {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("Progress(callback)")
    }
}

/// Where an RBF network's hyperparameters ([`super::rbf::Hyper`]: log widths, signal and
/// noise variances, output after output) come from.
#[derive(Debug, Clone, Default, PartialEq)]
pub enum RbfHyper {
    /// Searched: from the settings' start, or from every start when the settings name none
    /// ([`super::rbf::search_without`], [`super::rbf::search_best_without`]).
    #[default]
    Search,
    /// Given: found before on the same rows, not searched.
    Given(nalgebra::DVector<f64>),
    /// Searched beginning at these: those of a search on nearly the same rows
    /// ([`super::rbf::search_from`]).
    From(nalgebra::DVector<f64>),
}

/// Training settings.
#[derive(Debug, Clone)]
pub struct TrainOptions {
    /// Hidden units of the MLP.
    pub hidden: usize,
    /// Seed of the initial weights and of the held-out draw.
    pub seed: u64,
    /// Phase-1 epochs (full batch).
    pub momentum_epochs: usize,
    /// Phase-2 epoch limit (L-BFGS: ten iterations an epoch).
    pub max_epochs: usize,
    /// Performance goal (MSE of normalised outputs).
    pub goal: f64,
    /// Smallest gradient before stopping: the largest |J^T e| component.
    pub min_grad: f64,
    /// Validation failures in a row before stopping.
    pub max_fail: usize,
    /// Part of the training rows held out for the validation-failure rule (whole groups);
    /// 0 (the default): none, every row trains and the L2 penalty regularises (early stopping
    /// on a held-out part stopped networks well short of the penalised optimum and raised the
    /// real UR10 held-out RMS by 12 %).
    pub validation_fraction: f64,
    /// L2 weight penalty lambda (see [`super::samples`]); 0: none.
    pub penalty: f64,
    /// The weight-refining method of phase 2.
    pub phase2: Phase2,
    /// Told every epoch; None: nothing is told.
    pub progress: Option<Progress>,
    /// Weights to start from instead of the seeded initial ones (a warm start: the same
    /// network trained with another penalty); ignored when their shape does not fit.
    pub start: Option<Weights>,
    /// Where an RBF network's hyperparameters come from.
    pub rbf_hyper: RbfHyper,
    /// Rows of a larger set this one was taken from without (indices in that set): an RBF
    /// search runs on the rows the larger set's search draws, but these
    /// ([`super::rbf::search_without`]); empty: the set is whole.
    /// [`Compensator::train`](super::compensator::Compensator::train) sets it (and
    /// `rbf_hyper`, `rbf_whole_groups`) for its final fit, whatever the caller gave.
    pub rbf_left_out: Vec<usize>,
    /// The larger set's configuration group of each of its rows (its
    /// [`Samples::groups`](super::samples::Samples::groups)), so that the search draws that
    /// set's one row per configuration ([`super::rbf::LeftOut`]); empty: this set's groups,
    /// each row of `rbf_left_out` a configuration of its own.
    pub rbf_whole_groups: Vec<usize>,
    /// Rows an RBF network's hyperparameter search sees at most (one per arm configuration, a
    /// seeded choice of them on larger sets, the same in cross-validation and in the final
    /// fit; at least 2): default
    /// [`super::rbf::HYPER_ROWS`]. The search's cost is cubic in them.
    pub rbf_search_rows: usize,
    /// Disjoint blocks of `rbf_search_rows` an RBF network's hyperparameter search sees at
    /// most on larger sets, their likelihoods added (at least 1): default
    /// [`super::rbf::HYPER_BLOCKS`]. The search's cost is linear in them.
    pub rbf_search_blocks: usize,
    /// The RBF network's covariance function: default [`super::rbf::Covariance::DEFAULT`]
    /// (Matern 5/2).
    pub rbf_covariance: super::rbf::Covariance,
}

impl TrainOptions {
    /// The rows an RBF network's hyperparameter search sees (up to `rbf_search_blocks`
    /// blocks of `rbf_search_rows` of the set, drawn by `seed`) and its covariance function.
    pub fn rbf_draw(&self) -> super::rbf::Draw {
        super::rbf::Draw {
            seed: self.seed,
            rows: self.rbf_search_rows,
            covariance: self.rbf_covariance,
            blocks: self.rbf_search_blocks,
        }
    }
}

impl Default for TrainOptions {
    fn default() -> Self {
        TrainOptions {
            hidden: 20,
            seed: 1,
            momentum_epochs: 50,
            max_epochs: 60,
            goal: 0.0,
            min_grad: 1e-7,
            max_fail: 6,
            validation_fraction: 0.0,
            penalty: 0.0,
            phase2: Phase2::Auto,
            progress: None,
            start: None,
            rbf_hyper: RbfHyper::Search,
            rbf_left_out: Vec::new(),
            rbf_whole_groups: Vec::new(),
            rbf_search_rows: super::rbf::HYPER_ROWS,
            rbf_search_blocks: super::rbf::HYPER_BLOCKS,
            rbf_covariance: super::rbf::Covariance::DEFAULT,
        }
    }
}

/// Why training stopped.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum TrainStop {
    /// The training MSE reached `goal`.
    Goal,
    /// The gradient fell below `min_grad`.
    MinGradient,
    /// The held-out error did not improve for `max_fail` epochs in a row (best epoch kept).
    ValidationFailures,
    /// The phase-2 epoch limit `max_epochs` was reached.
    MaxEpochs,
    /// mu exceeded 1e10 (LM), or no step lowers the error (L-BFGS line search).
    MuMax,
}

impl TrainStop {
    /// A short phrase for reports: why training stopped.
    pub fn describe(self) -> &'static str {
        match self {
            TrainStop::Goal => "performance goal reached",
            TrainStop::MinGradient => "minimum gradient reached",
            TrainStop::ValidationFailures => "held-out error stopped improving (best epoch kept)",
            TrainStop::MaxEpochs => "epoch limit",
            TrainStop::MuMax => "no step lowers the error any more",
        }
    }
}

/// What training did.
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
pub struct TrainReport {
    /// Why training stopped.
    pub stop: TrainStop,
    /// Phase-1 (momentum) epochs run.
    pub momentum_epochs: usize,
    /// Phase-2 epochs (L-BFGS: iterations).
    pub lm_epochs: usize,
    /// The phase-2 method used.
    pub phase2: Phase2,
    /// Final MSE (normalised outputs, no penalty) on the training part, and on the held-out
    /// part when there is one.
    pub train_mse: f64,
    /// Final MSE on the held-out part (normalised outputs); None when nothing was held out.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub validation_mse: Option<f64>,
    /// (epoch, training MSE, validation MSE) over both phases.
    pub curve: Vec<(usize, f64, f64)>,
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
    let v = w.to_vector();
    let mask = penalty_mask(w);
    let a = jac.tr_mul(&jac);
    let g = jac.tr_mul(&e) - mask.component_mul(&v) * lambda;
    if g.amax() < min_grad {
        return LmOutcome::MinGradient;
    }
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

/// The best weights by validation error, and how many epochs in a row failed to beat them.
struct Best {
    mse: f64,
    /// The error an epoch must beat to count as progress.
    mark: f64,
    weights: Weights,
    fails: usize,
}

impl Best {
    fn new(mse: f64, weights: Weights) -> Self {
        Best {
            mse,
            mark: mse,
            weights,
            fails: 0,
        }
    }

    /// Records an epoch's validation error; returns the failures in a row. The best weights
    /// are kept whatever the gain; an epoch counts as progress only when it lowers the error
    /// by more than the fraction `min_gain` of the last progress mark.
    fn record(&mut self, mse: f64, w: &Weights, min_gain: f64) -> usize {
        if mse < self.mse {
            self.mse = mse;
            self.weights.clone_from(w);
        }
        if mse < self.mark * (1.0 - min_gain) {
            self.mark = mse;
            self.fails = 0;
        } else {
            self.fails += 1;
        }
        self.fails
    }
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

/// Splits samples into training and held-out parts by a seeded draw of whole groups;
/// about `fraction` of the samples are held out, and at least 2 stay for training.
pub fn holdout(s: &Samples, fraction: f64, seed: u64) -> (Vec<usize>, Vec<usize>) {
    let n = s.len();
    let mut groups: Vec<usize> = (0..n).map(|k| s.group(k)).collect();
    groups.sort_unstable();
    groups.dedup();
    groups.shuffle(&mut ChaCha8Rng::seed_from_u64(seed ^ 0x5eed));
    let want = ((n as f64) * fraction).round() as usize;
    let mut size = std::collections::HashMap::new();
    for k in 0..n {
        *size.entry(s.group(k)).or_insert(0usize) += 1;
    }
    let mut held = std::collections::HashSet::new();
    let mut count = 0;
    for g in groups {
        if count >= want {
            break;
        }
        let c = size[&g];
        if count + c > n.saturating_sub(2) {
            continue;
        }
        held.insert(g);
        count += c;
    }
    (0..n).partition(|&k| !held.contains(&s.group(k)))
}

/// Refuses samples too few or of unequal shapes, and a network without hidden units.
fn check_samples(samples: &Samples, outputs: usize, opts: &TrainOptions) -> Result<()> {
    let n = samples.len();
    if samples.b.len() != n || n < 4 {
        return Err(Error::Invalid(format!(
            "training needs at least 4 samples (got {n})"
        )));
    }
    let rows = samples.rows();
    let shapes_ok = samples.b.iter().all(|b| b.len() == rows)
        && match &samples.maps {
            None => rows == outputs,
            Some(a) => a.len() == n && a.iter().all(|a| a.shape() == (rows, outputs)),
        };
    if !shapes_ok {
        return Err(Error::Invalid("training samples of unequal shapes".into()));
    }
    if opts.hidden == 0 {
        return Err(Error::Invalid(
            "the hidden layer needs at least one unit".into(),
        ));
    }
    Ok(())
}

/// What phase 2 reports after each epoch: (epoch, weights, penalised objective, patience,
/// least relative gain that counts as progress) -> a reason to stop, if any.
type Record<'a> = dyn FnMut(usize, &Weights, f64, usize, f64) -> Option<TrainStop> + 'a;

/// Phase 2 by Levenberg-Marquardt (MATLAB trainlm) from `w`; the epochs taken in `epochs`.
fn phase2_lm(
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
fn phase2_lbfgs(
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

/// Trains a network with `hidden` sigmoid units on `samples` (normalised inputs, targets of
/// unit scale): phase 1 momentum, phase 2 LM or L-BFGS, both on the penalised objective,
/// stopping on the thesis's rules; the weights of the best held-out epoch are returned.
pub fn train(
    samples: &Samples,
    outputs: usize,
    opts: &TrainOptions,
) -> Result<(Weights, TrainReport)> {
    check_samples(samples, outputs, opts)?;
    let lambda = opts.penalty;
    let (ti, vi) = holdout(samples, opts.validation_fraction, opts.seed);
    // Nothing held out (the default): train on the samples themselves, not on a copy.
    let st = if vi.is_empty() {
        std::borrow::Cow::Borrowed(samples)
    } else {
        std::borrow::Cow::Owned(samples.pick(&ti))
    };
    let sv = samples.pick(&vi);
    let inputs = samples.x[0].len();
    let start = match &opts.start {
        Some(w) if (w.inputs(), w.hidden(), w.outputs()) == (inputs, opts.hidden, outputs) => {
            w.clone()
        }
        _ => initial_weights(inputs, opts.hidden, outputs, opts.seed),
    };
    let held = std::cell::RefCell::new(Batch::new(if sv.is_empty() { &st } else { &sv }, &start));
    // Without a held-out part the best weights are those of the lowest penalised training
    // objective (what both phases minimise), not of the lowest plain MSE: near the penalised
    // optimum the plain MSE rises as the weights shrink.
    let per_component = lambda / st.components().max(1) as f64;
    let val = |w: &Weights| {
        let mse = held.borrow_mut().mse(w);
        if sv.is_empty() {
            mse + per_component * weight_norm2(w)
        } else {
            mse
        }
    };

    let total = opts.momentum_epochs + opts.max_epochs;
    let tell = |done: usize, train_mse: f64, validation_mse: f64, finished: bool| {
        if let Some(p) = &opts.progress {
            (p.0)(&Epoch {
                done,
                total,
                train_mse,
                validation_mse,
                finished,
            });
        }
    };
    let mut curve = Vec::new();
    let mut best = Best::new(val(&start), start.clone());
    let mut stop = None;
    let mut momentum_epochs = 0;
    // Phase 1 ends on the goal (training is done) or on its own validation failures (phase 2
    // then refines the best weights so far).
    let mut phase1_done = false;
    let after_momentum = train_momentum(
        &start,
        &st,
        lambda,
        opts.momentum_epochs,
        |epoch, train_mse, w| {
            momentum_epochs = epoch;
            let v = val(w);
            curve.push((epoch, train_mse, v));
            tell(epoch, train_mse, v, false);
            let fails = best.record(v, w, 0.0);
            if train_mse <= opts.goal {
                stop = Some(TrainStop::Goal);
            } else if fails >= opts.max_fail * 10 {
                // Gradient descent is noisy: allow it ten times the patience of the LM phase.
                phase1_done = true;
            }
            stop.is_none() && !phase1_done
        },
    )?;
    let after = val(&after_momentum);
    let (w, v) = if best.mse < after {
        (best.weights, best.mse)
    } else {
        (after_momentum, after)
    };
    best = Best::new(v, w.clone());
    let phase2 = match opts.phase2 {
        Phase2::Auto => auto_phase2(st.components(), w.len()),
        p => p,
    };
    let mut epochs = 0;
    // `objective`: the penalised training objective F of `w`, which both phase-2 methods have
    // already computed; without a held-out part it is also the value tracked.
    let mut record = |epoch: usize, w: &Weights, objective: f64, patience: usize, gain: f64| {
        let train_mse = objective - per_component * weight_norm2(w);
        let v = if sv.is_empty() { objective } else { val(w) };
        curve.push((momentum_epochs + epoch, train_mse, v));
        tell(opts.momentum_epochs + epoch, train_mse, v, false);
        let fails = best.record(v, w, gain);
        if train_mse <= opts.goal {
            Some(TrainStop::Goal)
        } else if !sv.is_empty() && fails >= patience {
            Some(TrainStop::ValidationFailures)
        } else {
            None
        }
    };
    if stop.is_none() {
        stop = Some(match phase2 {
            Phase2::Lm | Phase2::Auto => phase2_lm(w, &st, lambda, opts, &mut epochs, &mut record),
            Phase2::Lbfgs => phase2_lbfgs(w, &st, lambda, opts, &mut epochs, &mut record),
        });
    }
    tell(total, f64::NAN, f64::NAN, true);
    let w = best.weights;
    if w.to_vector().iter().any(|v| !v.is_finite()) {
        return Err(Error::NotConverged(
            "network training diverged: a weight is not finite".into(),
        ));
    }
    let report = TrainReport {
        stop: stop.unwrap_or(TrainStop::MaxEpochs),
        momentum_epochs,
        lm_epochs: epochs,
        phase2,
        train_mse: st.mse(&w),
        validation_mse: (!sv.is_empty()).then(|| sv.mse(&w)),
        curve,
    };
    Ok((w, report))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn smooth(n: usize, seed: u64) -> Samples {
        // y = sin(2 x1) cos(x2) on [-1, 1]^2: a few hidden units represent it well.
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let x: Vec<Vec<f64>> = (0..n)
            .map(|_| vec![rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0)])
            .collect();
        let b = x
            .iter()
            .map(|v| vec![(2.0 * v[0]).sin() * v[1].cos()])
            .collect();
        Samples {
            x,
            b,
            ..Default::default()
        }
    }

    #[test]
    fn training_reaches_the_goal_on_a_smooth_function() {
        let s = smooth(200, 3);
        for phase2 in [Phase2::Lm, Phase2::Lbfgs] {
            let opts = TrainOptions {
                hidden: 10,
                goal: 1e-5,
                momentum_epochs: 100,
                max_epochs: 500,
                phase2,
                ..Default::default()
            };
            let (w, report) = train(&s, 1, &opts).unwrap();
            assert!(report.lm_epochs > 0);
            assert_eq!(report.phase2, phase2);
            assert_eq!(
                report.stop,
                TrainStop::Goal,
                "{phase2:?}: {:?}",
                report.stop
            );
            assert!(s.mse(&w) < 2e-5);
            // Fresh points: the function is learnt, not the samples.
            let fresh = smooth(50, 4);
            assert!(fresh.mse(&w) < 1e-4, "{phase2:?}: {}", fresh.mse(&w));
            // Same seed, same network.
            let (w2, _) = train(&s, 1, &opts).unwrap();
            assert_eq!(w, w2);
        }
    }

    #[test]
    fn the_penalty_shrinks_the_weights_and_auto_picks_by_size() {
        let s = smooth(120, 5);
        let opts = |penalty| TrainOptions {
            hidden: 8,
            penalty,
            max_epochs: 100,
            ..Default::default()
        };
        let (free, r) = train(&s, 1, &opts(0.0)).unwrap();
        assert_eq!(r.phase2, Phase2::Lm, "small problems use LM");
        let (held, _) = train(&s, 1, &opts(10.0)).unwrap();
        assert!(
            weight_norm2(&held) < 0.5 * weight_norm2(&free),
            "{} vs {}",
            weight_norm2(&held),
            weight_norm2(&free)
        );
        let big = smooth(40_000, 6);
        let (_, r) = train(
            &big,
            1,
            &TrainOptions {
                hidden: 30,
                momentum_epochs: 1,
                max_epochs: 1,
                ..Default::default()
            },
        )
        .unwrap();
        assert_eq!(r.phase2, Phase2::Lbfgs, "large problems use L-BFGS");
    }

    #[test]
    fn mapped_outputs_are_learnt_through_their_maps() {
        // b_k = A_k f(x_k), f(x) = (sin 2x, x^2 - 0.3), random maps: the network learns f only
        // through A_k.
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        let mut s = Samples {
            maps: Some(Vec::new()),
            ..Default::default()
        };
        for _ in 0..300 {
            let x: f64 = rng.random_range(-1.0..1.0);
            let a = DMatrix::from_fn(3, 2, |_, _| rng.random_range(-1.0..1.0));
            let f = DVector::from_vec(vec![(2.0 * x).sin(), x * x - 0.3]);
            let b = &a * f;
            s.x.push(vec![x]);
            s.b.push(b.iter().copied().collect());
            s.maps.as_mut().unwrap().push(a);
        }
        let opts = TrainOptions {
            hidden: 6,
            goal: 1e-8,
            max_epochs: 500,
            ..Default::default()
        };
        let (w, report) = train(&s, 2, &opts).unwrap();
        assert!(s.mse(&w) < 1e-6, "{report:?}");
        for x in [-0.8, -0.2, 0.5] {
            let y = w.forward(&[x]);
            assert!((y[0] - (2.0 * x).sin()).abs() < 1e-2, "{x}: {y:?}");
            assert!((y[1] - (x * x - 0.3)).abs() < 1e-2, "{x}: {y:?}");
        }
    }

    #[test]
    fn held_out_rows_keep_their_groups_together() {
        let mut s = smooth(60, 7);
        s.groups = (0..60).map(|k| k / 3).collect();
        let (t, v) = holdout(&s, 0.2, 9);
        assert_eq!(t.len() + v.len(), 60);
        assert_eq!(v.len(), 12);
        for k in &v {
            assert!(!t.iter().any(|j| s.group(*j) == s.group(*k)));
        }
    }

    #[test]
    fn auto_phase2_counts_the_factorisation() {
        // 150 rows x 6 outputs and a 30-4-6 network: LM, as in the thesis.
        assert_eq!(auto_phase2(900, 30 * 4 + 4 + 4 * 6 + 6), Phase2::Lm);
        // 7 rows and 598 weights (30-16-6): forming J^T J is cheap (1.5e7) but factorising
        // it is not (7.1e7): L-BFGS.
        assert_eq!(auto_phase2(42, 598), Phase2::Lbfgs);
        assert_eq!(auto_phase2(900, 598), Phase2::Lbfgs);
    }
}
