//! A radial-basis-function network (Broomhead and Lowe, 1988) whose widths and output weights
//! are those of Gaussian processes' posterior means (Rasmussen and Williams 2006, eqs. 2.25,
//! 5.8 and 5.9): one unit per training row (at most [`MAX_UNITS`] by default, on a choice of
//! the rows beyond: [`unit_rows`]), centred on its normalised input, and for each output o its
//! own kernel,
//!
//!   y_o(x) = sum_i w_io k(sum_d ((x_d - c_id) / l_od)^2),
//!
//! k the unit response of the kernel's covariance function ([`Covariance`]: Matern 5/2 by
//! default, the squared exponential exp(-q / 2) of networks before file version 7),
//! w_o = s_o^2 (s_o^2 E_o + sigma_o^2 I)^-1 b_o, E_o the units' responses at the training
//! inputs under output o's widths, b_o the unit-scale targets of output o. The widths l_od (one
//! per input and output: automatic relevance determination), the signal variance s_o^2 and
//! the noise variance sigma_o^2 maximise output o's marginal likelihood (type-II maximum
//! likelihood), each output an independent process:
//!
//!   -log p(b_o) = 1/2 b_o^T K_o^-1 b_o + 1/2 log|K_o| + n / 2 log(2 pi),
//!   K_o = s_o^2 E_o + sigma_o^2 I,
//!
//! with a weak log-normal prior on each hyperparameter (standard deviation [`PRIOR_SD`] in ln
//! units) so that an input the data say nothing about keeps a finite width. One kernel per
//! output, not one shared by all: the components of a pose error depend on different joints
//! (and a tracker measures along its beam and across it with different noise), and on real UR10
//! data (Series B, pools of 500 and 1000, three seeds each) per-output kernels lowered the
//! held-out position RMS by 16-38 % against one shared kernel, and the orientation RMS by
//! 30-44 %;
//! per-output variances with shared widths gained nothing.
//!
//! Unlike an MLP's, this network's capacity grows with the data: it learns errors that vary
//! sharply with a few joints (on real tracker data, repeated arm configurations reached with
//! other wrist angles) where a small MLP can only follow the smooth trend. Far from every
//! centre its output falls to zero: the compensator becomes the model. Its cost is cubic in
//! the rows, so the hyperparameters are fitted on at most [`HYPER_BLOCKS`] blocks of
//! [`HYPER_ROWS`] of them (one per arm configuration, a seeded choice; the blocks'
//! likelihoods added) and only the weights use every row that carries a unit. The likelihood
//! has several modes
//! on real data, so the search can run from each of [`STARTS`]; the factorisations use
//! `faer`.

mod covariance;
mod draw;
mod likelihood;
mod prediction;
mod search;

use super::samples::Samples;
use crate::error::{Error, Result};
/// Training rows an RBF network needs at least.
pub const MIN_ROWS: usize = 2;

pub use covariance::Covariance;
pub use draw::{Draw, HYPER_BLOCKS, HYPER_ROWS, LeftOut, MAX_UNITS, drawn_rows, unit_rows};
use faer::Mat;
use faer::dyn_stack::MemStack;
use likelihood::kernel;
pub use likelihood::{PRIOR_SD, Pairs, neg_log_likelihood};
use nalgebra::DVector;
pub use search::{
    HYPER_ITERATIONS, STALL_NATS, STARTS, Search, WIDTH_FLOOR_SD, search, search_best,
    search_best_without, search_from, search_start_without, search_without,
};

/// One output's Gaussian process (or, in files of version 3 and 4, every output's).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Kernel {
    /// Consecutive outputs this kernel serves: 1 in networks fitted now; every output in a
    /// version 3-4 file, whose outputs shared one kernel.
    pub outputs: usize,
    /// Width of each input, l_d (normalised input units).
    pub widths: Vec<f64>,
    /// Signal variance s^2 (unit-scale outputs squared).
    pub signal_variance: f64,
    /// Noise variance sigma^2 (unit-scale outputs squared).
    pub noise_variance: f64,
    /// The form of the unit response (files before version 7: the squared exponential).
    #[serde(default = "Covariance::before_version_7")]
    pub covariance: Covariance,
}

impl Kernel {
    /// 1 / l_d^2 of each input, appended to `inv`.
    fn inverse_squares_into(&self, inv: &mut Vec<f64>) {
        inv.extend(self.widths.iter().map(|l| 1.0 / (l * l)));
    }
}

/// Weighted squared distance sum_d (x_d - c_d)^2 / l_d^2 beyond which a squared-exponential
/// unit's response counts as 0 ([`Covariance::far`]; Matern 5/2 reaches the same response
/// farther), in the fit, the likelihood and prediction alike: e^-345, about 1e-150, below
/// anything a sum of order-one terms can notice. Beyond a distance of about 1416 the
/// responses (with the C library's `exp`; ours stops at e^-700, about 1e-304), and before
/// that their products in the factorisation, were subnormal numbers, which the processor
/// handles about 15 times slower: a search whose widths had grown narrow
/// took 5.4 s instead of 0.33 s for one output, with the same result to 10 digits; with the
/// weights' kernel matrices (then filled in their lower triangle only) and prediction cut
/// as well, the default `train` on Series A's pool of 2000 took 5.60 s instead of 7.32 s,
/// the same compensator bit for bit.
pub(super) const FAR: f64 = 690.0;

/// A fitted RBF network (normalised inputs, unit-scale outputs).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Rbf {
    /// One centre per unit (normalised inputs).
    pub centres: Vec<Vec<f64>>,
    /// The kernels, in the order of the outputs they serve.
    pub kernels: Vec<Kernel>,
    /// Output weights, one row per unit (unit-scale outputs).
    pub weights: Vec<Vec<f64>>,
}

/// An RBF network as files of version 3 and 4 hold it: one kernel for every output.
#[derive(Debug, Clone, PartialEq, serde::Deserialize)]
pub struct SharedKernelRbf {
    /// One centre per unit (normalised inputs).
    pub centres: Vec<Vec<f64>>,
    /// Width of each input (normalised input units).
    pub widths: Vec<f64>,
    /// Output weights, one row per unit (unit-scale outputs).
    pub weights: Vec<Vec<f64>>,
    /// Signal variance (unit-scale outputs squared).
    pub signal_variance: f64,
    /// Noise variance (unit-scale outputs squared).
    pub noise_variance: f64,
}

impl From<SharedKernelRbf> for Rbf {
    fn from(r: SharedKernelRbf) -> Rbf {
        Rbf {
            kernels: vec![Kernel {
                outputs: r.weights.first().map_or(0, |w| w.len()),
                widths: r.widths,
                signal_variance: r.signal_variance,
                noise_variance: r.noise_variance,
                covariance: Covariance::before_version_7(),
            }],
            centres: r.centres,
            weights: r.weights,
        }
    }
}

/// Hyperparameters in the log domain, output after output: [ln l_o1 .. ln l_od, ln s_o^2,
/// ln sigma_o^2] for o = 1..outputs (d + 2 numbers each).
pub type Hyper = DVector<f64>;

impl Rbf {
    /// Number of hidden units (centres).
    pub fn units(&self) -> usize {
        self.centres.len()
    }

    /// Each kernel with the range of outputs it serves.
    pub fn kernel_outputs(&self) -> impl Iterator<Item = (&Kernel, std::ops::Range<usize>)> {
        self.kernels.iter().scan(0, |first, k| {
            let outs = *first..*first + k.outputs;
            *first = outs.end;
            Some((k, outs))
        })
    }

    /// Whether every number is finite and bounded (a finite 1e308 overflows in prediction)
    /// and the shapes agree with `inputs` and `outputs`.
    pub fn is_valid(&self, inputs: usize, outputs: usize) -> bool {
        let bound = super::weights::VALUE_BOUND;
        let small = |v: &f64| v.abs() <= bound;
        !self.kernels.is_empty()
            && self.kernels.iter().all(|k| {
                // Bounded first: a huge count would wrap the sum below.
                (1..=outputs).contains(&k.outputs)
                    && k.widths.len() == inputs
                    && k.widths.iter().all(|l| (1.0 / bound..=bound).contains(l))
                    && k.signal_variance.is_finite()
                    && k.noise_variance.is_finite()
            })
            && self.kernels.iter().map(|k| k.outputs).sum::<usize>() == outputs
            && self.centres.iter().flatten().all(small)
            && self.weights.iter().flatten().all(small)
            && self.centres.len() == self.weights.len()
            && !self.centres.is_empty()
            && self
                .centres
                .iter()
                .all(|c| c.len() == inputs && c.iter().all(|v| v.is_finite()))
            && self
                .weights
                .iter()
                .all(|w| w.len() == outputs && w.iter().all(|v| v.is_finite()))
    }

    /// Fits the network on `s` (targets without maps: the pose form): the hyperparameter
    /// search from [`STARTS`]`[start]` ([`search()`]), or when None from every start keeping,
    /// output by output, the highest likelihood ([`search_best`]), on the default draw of
    /// `seed` ([`Draw::seeded`], the default covariance function), then the weights on every
    /// row ([`Rbf::with_hyper`]).
    pub fn fit(s: &Samples, start: Option<usize>, seed: u64) -> Result<(Rbf, Search)> {
        let draw = Draw::seeded(seed);
        let found = search_start_without(s, start, draw, LeftOut::NONE)?;
        Ok((Rbf::with_hyper(s, &found.hyper, draw.covariance)?, found))
    }

    /// The network at fixed hyperparameters `h` (every output's, see [`Hyper`]) and
    /// covariance function `cov`: one unit per row of `s`, output o's weights w_o = s_o^2
    /// K_o^-1 b_o (the posterior mean's).
    pub fn with_hyper(s: &Samples, h: &Hyper, cov: Covariance) -> Result<Rbf> {
        Rbf::with_hyper_on(s, h, cov, true)
    }

    /// [`Rbf::with_hyper`], the outputs on several threads when `parallel` (callers that
    /// already run fits side by side pass false: each thread holds an n x n kernel).
    pub fn with_hyper_on(s: &Samples, h: &Hyper, cov: Covariance, parallel: bool) -> Result<Rbf> {
        let (n, d, o) = shape(s)?;
        check_hyper(h, d, o)?;
        let fit = |j: usize| -> Result<(Kernel, Vec<f64>)> {
            let hj = h.rows(j * (d + 2), d + 2).into_owned();
            let mut k = kernel(&s.x, &hj, cov);
            let mut mem = likelihood::scratch(n, 1, false);
            let stack = MemStack::new(&mut mem);
            if !likelihood::factor_lower(&mut k, stack) {
                return Err(Error::Invalid(format!(
                    "the RBF network's kernel matrix of output {} is not positive definite",
                    j + 1
                )));
            }
            let mut alpha = Mat::<f64>::from_fn(n, 1, |i, _| s.b[i][j]);
            likelihood::solve_lower(&k, &mut alpha, stack);
            let s2 = hj[d].exp();
            let kernel = Kernel {
                outputs: 1,
                widths: (0..d).map(|c| hj[c].exp()).collect(),
                signal_variance: s2,
                noise_variance: hj[d + 1].exp(),
                covariance: cov,
            };
            Ok((
                kernel,
                (0..n).map(|i| alpha[(i, 0)] * s2).collect::<Vec<f64>>(),
            ))
        };
        let fits: Vec<Result<(Kernel, Vec<f64>)>> = if parallel {
            super::parallel::parallel_map(o, fit)
        } else {
            (0..o).map(fit).collect()
        };
        let mut kernels = Vec::with_capacity(o);
        let mut columns = Vec::with_capacity(o);
        for f in fits {
            let (k, w) = f?;
            kernels.push(k);
            columns.push(w);
        }
        let rbf = Rbf {
            centres: s.x.clone(),
            kernels,
            weights: (0..n)
                .map(|i| columns.iter().map(|w| w[i]).collect())
                .collect(),
        };
        if !rbf.is_valid(d, o) {
            return Err(Error::Invalid(
                "the RBF network's fit produced a non-finite number".into(),
            ));
        }
        Ok(rbf)
    }
}

/// Numbers of rows, inputs and outputs of `s`, refused when it cannot carry an RBF network.
fn shape(s: &Samples) -> Result<(usize, usize, usize)> {
    if s.maps.is_some() {
        return Err(Error::Invalid(
            "the RBF network acts on the pose residual only (pose form)".into(),
        ));
    }
    let n = s.len();
    let (d, o) = (s.x.first().map_or(0, |x| x.len()), s.rows());
    if n < MIN_ROWS || d == 0 || o == 0 {
        return Err(Error::Invalid(format!(
            "an RBF network needs at least {MIN_ROWS} training rows (got {n})"
        )));
    }
    Ok((n, d, o))
}

/// Refuses hyperparameters that are not o (d + 2) finite numbers (see [`Hyper`]).
fn check_hyper(h: &Hyper, d: usize, o: usize) -> Result<()> {
    if h.len() != o * (d + 2) || h.iter().any(|v| !v.is_finite()) {
        return Err(Error::Invalid(format!(
            "RBF hyperparameters: {} finite numbers expected for {d} inputs and {o} outputs, \
             got {}",
            o * (d + 2),
            h.len()
        )));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::DMatrix;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;

    /// Samples of a smooth function of two inputs (a third carries nothing) with noise, and
    /// the function.
    pub(super) fn data(n: usize) -> (Samples, impl Fn(&[f64]) -> [f64; 2]) {
        let truth = |x: &[f64]| [(2.0 * x[0]).sin() + 0.3 * x[1], (x[0] * x[1]).cos() - 0.5];
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        use rand::Rng;
        let mut s = Samples::default();
        for _ in 0..n {
            // Input 3 carries nothing: its width must grow.
            let x: Vec<f64> = (0..3).map(|_| rng.random_range(-1.5..1.5)).collect();
            let t = truth(&x);
            s.b.push(vec![
                t[0] + 0.01 * rng.random_range(-1.0..1.0),
                t[1] + 0.01 * rng.random_range(-1.0..1.0),
            ]);
            s.x.push(x);
        }
        (s, truth)
    }

    #[test]
    fn learns_a_smooth_function_and_ignores_an_idle_input() {
        let (s, truth) = data(150);
        let (rbf, _) = Rbf::fit(&s, None, 1).unwrap();
        assert_eq!(rbf.kernels.len(), 2);
        for k in &rbf.kernels {
            assert!(
                k.widths[2] > 3.0 * k.widths[0],
                "idle input width {:?}",
                k.widths
            );
        }
        let mut worst: f64 = 0.0;
        let mut y = [0.0; 2];
        let mut inv = Vec::new();
        for a in [-1.0, -0.3, 0.4, 1.1] {
            for b in [-0.8, 0.2, 0.9] {
                let x = [a, b, 0.5];
                rbf.forward_into(&x, &mut y, &mut inv);
                let t = truth(&x);
                worst = worst.max((y[0] - t[0]).abs()).max((y[1] - t[1]).abs());
            }
        }
        assert!(worst < 0.05, "largest error {worst}");
        // Far from every centre the output falls to zero (as e^-t, t = sqrt(5 q), under the
        // default Matern 5/2: farther than a squared exponential's e^-q/2 needs).
        rbf.forward_into(&[400.0, -400.0, 0.0], &mut y, &mut inv);
        assert!(y.iter().all(|v| v.abs() < 1e-9), "{y:?}");
    }

    /// Beyond FAR a unit's response is exactly 0 in the weights' kernel matrix (as in the
    /// likelihood's) and in prediction, well short of the exponential's floor (e^-700 at a
    /// weighted squared distance of 1400 for the squared exponential): no subnormal numbers
    /// reach the factorisation. Within it, the response of the kernel's covariance function.
    #[test]
    fn responses_beyond_far_are_zero_in_the_fit_and_in_prediction() {
        let (s, _) = data(40);
        // Narrow widths (0.02, 0.03 and 2 on inputs spread over 3): most pairs lie beyond FAR;
        // narrower for Matern 5/2 (0.005, 0.008), whose cut-off lies farther.
        for (cov, l) in [
            (Covariance::SquaredExponential, [0.02f64, 0.03]),
            (Covariance::Matern52, [0.005, 0.008]),
        ] {
            let h = Hyper::from_vec(vec![l[0].ln(), l[1].ln(), 0.7, 0.2, -2.0]);
            let w: Vec<f64> = (0..3).map(|c| (-2.0 * h[c]).exp()).collect();
            let s2 = h[3].exp();
            let k = likelihood::kernel(&s.x, &h, cov);
            let (mut cut, mut kept) = (0, 0);
            for j in 0..s.x.len() {
                for i in j + 1..s.x.len() {
                    let q: f64 = (0..3).map(|c| (s.x[i][c] - s.x[j][c]).powi(2) * w[c]).sum();
                    // The upper triangle is never written (the factorisation reads the lower).
                    assert_eq!(k[(j, i)], 0.0);
                    if q > cov.far() {
                        assert_eq!(k[(i, j)], 0.0, "pair {i} {j}: {q}");
                        cut += usize::from(
                            q < 1400.0 || (cov == Covariance::Matern52 && q < 98_000.0),
                        );
                    } else {
                        assert_eq!(k[(i, j)], s2 * cov.response(q));
                        kept += 1;
                    }
                }
            }
            // Pairs cut where the response alone would still be above the exponential's
            // floor e^-700 (q below 1400 for the squared exponential, 98,000 for Matern 5/2),
            // and pairs kept.
            assert!(
                cut > 0 && kept > 0,
                "{cov:?}: {cut} cut short of underflow, {kept} kept"
            );
            if cov == Covariance::SquaredExponential {
                assert_eq!(cov.far(), FAR);
            }
        }
        // Prediction: one unit of width 1 at 0, seen at distances 1 and 30 (q = 900), and
        // for Matern 5/2 at 160 (q = 25,600).
        let unit = |covariance| Rbf {
            centres: vec![vec![0.0]],
            kernels: vec![Kernel {
                outputs: 1,
                widths: vec![1.0],
                signal_variance: 1.0,
                noise_variance: 0.1,
                covariance,
            }],
            weights: vec![vec![2.0]],
        };
        let (mut y, mut inv) = ([0.0], Vec::new());
        let rbf = unit(Covariance::SquaredExponential);
        rbf.forward_into(&[1.0], &mut y, &mut inv);
        assert_eq!(y[0], 2.0 * Covariance::SquaredExponential.response(1.0));
        assert!((y[0] - 2.0 * (-0.5f64).exp()).abs() < 1e-15);
        assert!((-450.0f64).exp() > 0.0);
        rbf.forward_into(&[30.0], &mut y, &mut inv);
        assert_eq!(y[0], 0.0);
        let rbf = unit(Covariance::Matern52);
        rbf.forward_into(&[1.0], &mut y, &mut inv);
        let t = 5.0f64.sqrt();
        assert!((y[0] - 2.0 * (1.0 + t + 5.0 / 3.0) * (-t).exp()).abs() < 1e-15);
        rbf.forward_into(&[30.0], &mut y, &mut inv);
        assert!(y[0] > 0.0);
        rbf.forward_into(&[160.0], &mut y, &mut inv);
        assert_eq!(y[0], 0.0);
    }

    #[test]
    fn each_output_has_its_own_kernel() {
        // Output 0 varies with input 0 only, output 1 with input 1 only, at other noise
        // levels: each kernel widens the input its output ignores and keeps its own noise.
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        use rand::Rng;
        let mut s = Samples::default();
        for _ in 0..120 {
            let x: Vec<f64> = (0..2).map(|_| rng.random_range(-1.5..1.5)).collect();
            s.b.push(vec![
                (2.0 * x[0]).sin() + 0.01 * rng.random_range(-1.0..1.0),
                (1.5 * x[1]).cos() + 0.2 * rng.random_range(-1.0..1.0),
            ]);
            s.x.push(x);
        }
        let (rbf, found) = Rbf::fit(&s, Some(0), 1).unwrap();
        let (k0, k1) = (&rbf.kernels[0], &rbf.kernels[1]);
        assert!(k0.widths[1] > 5.0 * k0.widths[0], "{:?}", k0.widths);
        assert!(k1.widths[0] > 5.0 * k1.widths[1], "{:?}", k1.widths);
        assert!(
            k1.noise_variance > 20.0 * k0.noise_variance,
            "{} {}",
            k0.noise_variance,
            k1.noise_variance
        );
        // The joint search is the outputs' own searches side by side.
        assert_eq!(found.hyper.len(), 2 * 4);
        for j in 0..2 {
            let mut one = s.clone();
            one.b = s.b.iter().map(|b| vec![b[j]]).collect();
            let own = search(&one, 0, Draw::seeded(1)).unwrap();
            assert_eq!(own.hyper, found.hyper.rows(4 * j, 4).into_owned());
            let alone = Rbf::with_hyper(&one, &own.hyper, Covariance::DEFAULT).unwrap();
            assert_eq!(alone.kernels[0], rbf.kernels[j]);
        }
    }

    #[test]
    fn input_jacobian_matches_central_differences() {
        let (s, _) = data(60);
        for covariance in [Covariance::SquaredExponential, Covariance::Matern52] {
            let draw = Draw {
                covariance,
                ..Draw::seeded(1)
            };
            let found = search_start_without(&s, None, draw, LeftOut::NONE).unwrap();
            let rbf = Rbf::with_hyper(&s, &found.hyper, covariance).unwrap();
            assert!(rbf.kernels.iter().all(|k| k.covariance == covariance));
            jacobian_matches_central_differences(&rbf);
        }
    }

    fn jacobian_matches_central_differences(rbf: &Rbf) {
        let x = [0.3, -0.2, 0.8];
        let mut y = [0.0; 2];
        let mut dy = DMatrix::zeros(2, 3);
        let mut inv = Vec::new();
        rbf.input_jacobian_into(&x, &mut y, &mut dy, &mut inv);
        let mut y0 = [0.0; 2];
        rbf.forward_into(&x, &mut y0, &mut inv);
        assert_eq!(y, y0);
        // The weights of a nearly noise-free fit reach hundreds and cancel: a step of 1e-4
        // keeps the differences' rounding (1e-13 / 1e-4) below the tolerance, and their
        // truncation (step^2 times the third derivative) too.
        let step = 1e-4;
        for d in 0..3 {
            let (mut a, mut b) = (x, x);
            a[d] += step;
            b[d] -= step;
            let (mut ya, mut yb) = ([0.0; 2], [0.0; 2]);
            rbf.forward_into(&a, &mut ya, &mut inv);
            rbf.forward_into(&b, &mut yb, &mut inv);
            for o in 0..2 {
                let fd = (ya[o] - yb[o]) / (2.0 * step);
                assert!(
                    (fd - dy[(o, d)]).abs() < 1e-6 * (1.0 + fd.abs()),
                    "{o} {d}: {fd} {}",
                    dy[(o, d)]
                );
            }
        }
    }

    #[test]
    fn refuses_mapped_samples() {
        let (mut s, _) = data(10);
        s.maps = Some(vec![DMatrix::identity(2, 2); 10]);
        assert!(Rbf::fit(&s, None, 1).is_err());
    }
}
