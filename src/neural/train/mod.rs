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

mod options;
mod phase2;

use super::batch::Batch;
use super::net::train_momentum;
use super::samples::{Samples, weight_norm2};
use super::weights::Weights;
use crate::error::{Error, Result};
use nalgebra::{DMatrix, DVector};
pub use options::{
    Epoch, LM_BUDGET, Phase2, Progress, RbfHyper, TrainOptions, TrainReport, TrainStop, auto_phase2,
};
use phase2::{phase2_lbfgs, phase2_lm};
use rand::seq::SliceRandom;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

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

/// Training rows (samples) a network needs at least.
pub const MIN_ROWS: usize = 4;

/// Refuses samples too few or of unequal shapes, and a network without hidden units.
fn check_samples(samples: &Samples, outputs: usize, opts: &TrainOptions) -> Result<()> {
    let n = samples.len();
    if samples.b.len() != n || n < MIN_ROWS {
        return Err(Error::Invalid(format!(
            "training a network needs at least {MIN_ROWS} rows (got {n})"
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
