//! A radial-basis-function network (Broomhead and Lowe, 1988) whose widths and output weights
//! are those of a Gaussian process's posterior mean (Rasmussen and Williams 2006, eqs. 2.25,
//! 5.8 and 5.9): one Gaussian unit per training row, centred on its normalised input,
//!
//!   y(x) = sum_i w_i exp(-1/2 sum_d ((x_d - c_id) / l_d)^2),
//!
//! W = s^2 (s^2 E + sigma^2 I)^-1 B, E_ij the units' responses at the training inputs, B the
//! unit-scale targets. The widths l_d (one per input: automatic relevance determination), the
//! signal variance s^2 and the noise variance sigma^2 maximise the marginal likelihood of the
//! targets (type-II maximum likelihood), each output an independent draw of one process:
//!
//!   -log p(B) = 1/2 tr(B^T K^-1 B) + o/2 log|K| + n o / 2 log(2 pi),  K = s^2 E + sigma^2 I,
//!
//! with a weak log-normal prior on each hyperparameter (standard deviation [`PRIOR_SD`] in ln
//! units) so that an input the data say nothing about keeps a finite width. Unlike an MLP's,
//! this network's capacity grows with the data: it learns errors that vary sharply with a few
//! joints (on real tracker data, repeated arm configurations reached with other wrist angles)
//! where a small MLP can only follow the smooth trend. Far from every centre its output falls
//! to zero: the compensator becomes the model. Its cost is cubic in the rows, so the
//! hyperparameters are fitted on at most [`HYPER_ROWS`] of them (a seeded choice) and only
//! the weights use every row. The likelihood has several modes on real data, so the search
//! runs from each of [`STARTS`]; the factorisations use `faer`.

use super::lbfgs::{Next, minimize};
use super::samples::Samples;
use crate::error::{Error, Result};
use faer::Mat;
use faer::Side;
use faer::linalg::solvers::{DenseSolveCore, Solve};
use nalgebra::{DMatrix, DVector};
use rand::SeedableRng;
use rand::seq::SliceRandom;
use rand_chacha::ChaCha8Rng;

/// Rows on which the hyperparameters are fitted at most (the rest only enter the weights).
pub const HYPER_ROWS: usize = 500;
/// Standard deviation (ln units) of the prior on each log hyperparameter.
pub const PRIOR_SD: f64 = 3.0;
/// Gain in log likelihood (nats) below which a search step counts as idle.
pub const STALL_NATS: f64 = 1e-3;
/// L-BFGS iterations of each hyperparameter search.
pub const HYPER_ITERATIONS: usize = 60;

/// A fitted RBF network (normalised inputs, unit-scale outputs).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Rbf {
    /// One centre per unit (normalised inputs).
    pub centres: Vec<Vec<f64>>,
    /// Width of each input, l_d (normalised input units).
    pub widths: Vec<f64>,
    /// Output weights, one row per unit (unit-scale outputs).
    pub weights: Vec<Vec<f64>>,
    /// Signal and noise variances, s^2 and sigma^2 (unit-scale outputs squared).
    pub signal_variance: f64,
    /// Noise variance sigma^2 (unit-scale outputs squared).
    pub noise_variance: f64,
}

/// Hyperparameters in the log domain: [ln l_1 .. ln l_d, ln s^2, ln sigma^2].
pub type Hyper = DVector<f64>;

impl Rbf {
    /// Number of hidden units (centres).
    pub fn units(&self) -> usize {
        self.centres.len()
    }

    /// y(x) into `y` (no allocation).
    pub fn forward_into(&self, x: &[f64], y: &mut [f64]) {
        y.fill(0.0);
        for (c, w) in self.centres.iter().zip(&self.weights) {
            let k = self.response(x, c);
            y.iter_mut().zip(w).for_each(|(yo, wo)| *yo += wo * k);
        }
    }

    /// y(x) into `y` and dy/dx (outputs x inputs) into `dy`: dy_o/dx_d = -sum_i w_io k_i
    /// (x_d - c_id) / l_d^2.
    pub fn input_jacobian_into(&self, x: &[f64], y: &mut [f64], dy: &mut DMatrix<f64>) {
        y.fill(0.0);
        dy.fill(0.0);
        for (c, w) in self.centres.iter().zip(&self.weights) {
            let k = self.response(x, c);
            if k == 0.0 {
                continue;
            }
            for (o, wo) in w.iter().enumerate() {
                y[o] += wo * k;
                for (d, l) in self.widths.iter().enumerate() {
                    dy[(o, d)] -= wo * k * (x[d] - c[d]) / (l * l);
                }
            }
        }
    }

    fn response(&self, x: &[f64], c: &[f64]) -> f64 {
        let mut s = 0.0;
        for ((xd, cd), l) in x.iter().zip(c).zip(&self.widths) {
            let t = (xd - cd) / l;
            s += t * t;
        }
        (-0.5 * s).exp()
    }

    /// Whether every number is finite and bounded (a finite 1e308 overflows in prediction)
    /// and the shapes agree with `inputs` and `outputs`.
    pub fn is_valid(&self, inputs: usize, outputs: usize) -> bool {
        let bound = super::weights::VALUE_BOUND;
        let small = |v: &f64| v.abs() <= bound;
        self.widths.len() == inputs
            && self
                .widths
                .iter()
                .all(|l| (1.0 / bound..=bound).contains(l))
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
            && self.signal_variance.is_finite()
            && self.noise_variance.is_finite()
    }

    /// Fits the network on `s` (targets without maps: the pose form): the hyperparameter
    /// search from [`STARTS`]`[start]`, or from every start keeping the highest likelihood
    /// when None ([`search`]), then the weights on every row ([`Rbf::with_hyper`]).
    pub fn fit(s: &Samples, start: Option<usize>, seed: u64) -> Result<(Rbf, Search)> {
        let found = match start {
            Some(k) => search(s, k, seed)?,
            None => search_best(s, seed)?,
        };
        Ok((Rbf::with_hyper(s, &found.hyper)?, found))
    }

    /// The network at fixed hyperparameters `h`: one unit per row of `s`, weights
    /// W = s^2 K^-1 B (the posterior mean's).
    pub fn with_hyper(s: &Samples, h: &Hyper) -> Result<Rbf> {
        let (n, d, o) = shape(s)?;
        if h.len() != d + 2 || h.iter().any(|v| !v.is_finite()) {
            return Err(Error::Invalid(format!(
                "RBF hyperparameters: {} finite numbers expected for {d} inputs",
                d + 2
            )));
        }
        let k = kernel(&s.x, h);
        let chol = k.llt(Side::Lower).map_err(|_| {
            Error::Invalid("the RBF network's kernel matrix is not positive definite".into())
        })?;
        let y = Mat::<f64>::from_fn(n, o, |i, j| s.b[i][j]);
        let s2 = h[d].exp();
        let alpha = chol.solve(&y);
        let rbf = Rbf {
            centres: s.x.clone(),
            widths: (0..d).map(|j| h[j].exp()).collect(),
            weights: (0..n)
                .map(|i| (0..o).map(|c| alpha[(i, c)] * s2).collect())
                .collect(),
            signal_variance: s2,
            noise_variance: h[d + 1].exp(),
        };
        if !rbf.is_valid(d, o) {
            return Err(Error::Invalid(
                "the RBF network's fit produced a non-finite number".into(),
            ));
        }
        Ok(rbf)
    }
}

/// Where the hyperparameter searches start: (width of every standardised input, noise
/// variance as a fraction of the targets' mean square). The likelihood has several modes on
/// real tracker data: a smooth one, and rough ones that interpolate between repeated arm
/// configurations with narrow widths on a few joints and almost no noise. Each start leads to
/// one of them; cross-validation or the likelihood chooses.
pub const STARTS: [(f64, f64); 3] = [(1.0, 0.5), (0.2, 0.05), (0.05, 0.01)];

/// The result of one hyperparameter search.
#[derive(Debug, Clone, PartialEq)]
pub struct Search {
    /// [ln l_1 .. ln l_d, ln s^2, ln sigma^2].
    pub hyper: Hyper,
    /// The minimised objective: negative log marginal likelihood plus the prior's term
    /// (constants dropped).
    pub objective: f64,
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
    if n < 2 || d == 0 || o == 0 {
        return Err(Error::Invalid(format!(
            "an RBF network needs at least 2 training rows (got {n})"
        )));
    }
    Ok((n, d, o))
}

/// Type-II maximum likelihood from [`STARTS`]`[start]` (L-BFGS on the log hyperparameters,
/// [`HYPER_ITERATIONS`] at most) on at most [`HYPER_ROWS`] rows of `s` (a choice seeded by
/// `seed` when there are more).
pub fn search(s: &Samples, start: usize, seed: u64) -> Result<Search> {
    let (n, d, o) = shape(s)?;
    let Some(&(width, noise)) = STARTS.get(start) else {
        return Err(Error::Invalid(format!(
            "RBF search start {start}: there are {} starts",
            STARTS.len()
        )));
    };
    let mut rows: Vec<usize> = (0..n).collect();
    if n > HYPER_ROWS {
        rows.shuffle(&mut ChaCha8Rng::seed_from_u64(seed ^ 0x7bf));
        rows.truncate(HYPER_ROWS);
        rows.sort_unstable();
    }
    let y = Mat::<f64>::from_fn(rows.len(), o, |i, j| s.b[rows[i]][j]);
    let mut square = 0.0;
    for j in 0..o {
        for i in 0..rows.len() {
            square += y[(i, j)] * y[(i, j)];
        }
    }
    let var = (square / (rows.len() * o) as f64).max(1e-12);
    let prior = prior_mean(d, var);
    let pairs = Pairs::new(&s.x, &rows);
    let mut h0 = Hyper::from_element(d + 2, width.ln());
    h0[d] = var.ln();
    h0[d + 1] = (noise * var).ln();
    let (mut last, mut idle) = (f64::INFINITY, 0);
    let (hyper, objective, _) = minimize(
        h0,
        8,
        HYPER_ITERATIONS,
        1e-6,
        |h, g| neg_log_likelihood(&pairs, &y, h, &prior, Some(g)),
        |_, value, _| {
            // Likelihood differences of a thousandth of a nat choose nothing: stop when
            // three steps in a row gain less.
            idle = if last - value < STALL_NATS {
                idle + 1
            } else {
                0
            };
            last = value;
            if idle >= 3 {
                Next::Stop
            } else {
                Next::Continue
            }
        },
    );
    if !objective.is_finite() {
        return Err(Error::Invalid(
            "the RBF network's hyperparameter search diverged".into(),
        ));
    }
    Ok(Search { hyper, objective })
}

/// The searches from every start (in parallel) and the one of highest likelihood.
pub fn search_best(s: &Samples, seed: u64) -> Result<Search> {
    let all = super::parallel::parallel_map(STARTS.len(), |k| search(s, k, seed));
    let mut best: Option<Search> = None;
    let mut last_error = None;
    for r in all {
        match r {
            Ok(f) if best.as_ref().is_none_or(|b| f.objective < b.objective) => best = Some(f),
            Ok(_) => {}
            Err(e) => last_error = Some(e),
        }
    }
    best.ok_or_else(|| last_error.unwrap_or_else(|| Error::Invalid("no RBF search".into())))
}

/// The prior's centre: widths 1 (the inputs are standardised), signal variance the targets'
/// mean square `var`, noise a tenth of it.
fn prior_mean(d: usize, var: f64) -> Hyper {
    let mut m = Hyper::zeros(d + 2);
    m[d] = var.ln();
    m[d + 1] = (0.1 * var).ln();
    m
}

/// K = s^2 E + (sigma^2 + jitter) I at the inputs `x` under `h` (E the unit responses).
fn kernel(x: &[Vec<f64>], h: &Hyper) -> Mat<f64> {
    let n = x.len();
    let d = h.len() - 2;
    let w: Vec<f64> = (0..d).map(|j| (-2.0 * h[j]).exp()).collect();
    let (s2, noise) = (h[d].exp(), h[d + 1].exp());
    let mut k = Mat::<f64>::zeros(n, n);
    for j in 0..n {
        let xj = &x[j];
        k[(j, j)] = s2 + noise + 1e-8 * s2;
        for i in j + 1..n {
            let xi = &x[i];
            let q: f64 = (0..d).map(|c| (xi[c] - xj[c]).powi(2) * w[c]).sum();
            let v = s2 * (-0.5 * q).exp();
            k[(i, j)] = v;
            k[(j, i)] = v;
        }
    }
    k
}

/// The squared input differences of every pair of rows (i > j, column by column), one
/// array per input: the likelihood's kernel and gradient sweep them as contiguous arrays.
pub struct Pairs {
    n: usize,
    squared: Vec<Vec<f64>>,
}

impl Pairs {
    /// The pairs of the rows `rows` of the inputs `x` (normalised input units).
    pub fn new(x: &[Vec<f64>], rows: &[usize]) -> Pairs {
        let n = rows.len();
        let d = x.first().map_or(0, |r| r.len());
        let mut squared = vec![Vec::with_capacity(n * n.saturating_sub(1) / 2); d];
        for j in 0..n {
            for i in j + 1..n {
                let (xi, xj) = (&x[rows[i]], &x[rows[j]]);
                for (c, list) in squared.iter_mut().enumerate() {
                    list.push((xi[c] - xj[c]).powi(2));
                }
            }
        }
        Pairs { n, squared }
    }
}

/// The negative log marginal likelihood of the targets `y` at the rows of `pairs` under
/// `h`, plus the prior's negative log density around `prior` (constants dropped), and its
/// gradient by h into `grad`: with alpha = K^-1 Y and M = alpha alpha^T - o K^-1,
/// d/dh_j = -1/2 sum_ij M_ij dK_ij/dh_j (Rasmussen and Williams eq. 5.9), where
/// dK/d ln l_d = s^2 E o D_d / l_d^2 (D_d the squared differences of input d),
/// dK/d ln s^2 = s^2 E and dK/d ln sigma^2 = sigma^2 I. Infinite where K is not positive
/// definite.
pub fn neg_log_likelihood(
    pairs: &Pairs,
    y: &Mat<f64>,
    h: &Hyper,
    prior: &Hyper,
    grad: Option<&mut DVector<f64>>,
) -> f64 {
    let n = pairs.n;
    let d = h.len() - 2;
    let o = y.ncols();
    if h.iter().any(|v| !v.is_finite() || v.abs() > 50.0) || pairs.squared.len() != d {
        return f64::INFINITY;
    }
    let w: Vec<f64> = (0..d).map(|j| (-2.0 * h[j]).exp()).collect();
    let (s2, noise) = (h[d].exp(), h[d + 1].exp());
    // E over the pairs, then K.
    let count = n * n.saturating_sub(1) / 2;
    let mut e = vec![0.0; count];
    for (c, list) in pairs.squared.iter().enumerate() {
        e.iter_mut().zip(list).for_each(|(q, v)| *q += v * w[c]);
    }
    e.iter_mut().for_each(|q| *q = (-0.5 * *q).exp());
    let mut k = Mat::<f64>::zeros(n, n);
    let mut at = 0;
    for j in 0..n {
        k[(j, j)] = s2 + noise + 1e-8 * s2;
        for i in j + 1..n {
            let v = s2 * e[at];
            k[(i, j)] = v;
            k[(j, i)] = v;
            at += 1;
        }
    }
    let Ok(chol) = k.llt(Side::Lower) else {
        return f64::INFINITY;
    };
    let alpha = chol.solve(y);
    let l = chol.L();
    let log_det: f64 = 2.0 * (0..n).map(|i| l[(i, i)].ln()).sum::<f64>();
    let mut fit = 0.0;
    for j in 0..o {
        for i in 0..n {
            fit += y[(i, j)] * alpha[(i, j)];
        }
    }
    let dh = h - prior;
    let sd2 = PRIOR_SD * PRIOR_SD;
    let f = 0.5 * fit + 0.5 * o as f64 * log_det + 0.5 * dh.norm_squared() / sd2;
    if let Some(g) = grad {
        let kinv = chol.inverse();
        let aa = &alpha * alpha.transpose();
        let of = o as f64;
        // M's diagonal (E_ii = 1) and P = M o (s^2 E) over the pairs.
        let trace_m: f64 = (0..n).map(|i| aa[(i, i)] - of * kinv[(i, i)]).sum();
        let mut p = vec![0.0; count];
        let mut at = 0;
        for j in 0..n {
            for i in j + 1..n {
                p[at] = (aa[(i, j)] - of * kinv[(i, j)]) * s2 * e[at];
                at += 1;
            }
        }
        g.fill(0.0);
        // sum_ij P_ij = trace(P) + 2 sum_{i>j} P_ij, trace(P) = s^2 trace(M).
        g[d] = -0.5 * (s2 * trace_m + 2.0 * p.iter().sum::<f64>());
        g[d + 1] = -0.5 * noise * trace_m;
        // sum_ij P_ij D_ij = 2 sum_{i>j} P_ij D_ij (D_ii = 0).
        for (c, list) in pairs.squared.iter().enumerate() {
            let total: f64 = p.iter().zip(list).map(|(a, b)| a * b).sum();
            g[c] = -total * w[c];
        }
        *g += dh / sd2;
    }
    f
}

#[cfg(test)]
mod tests {
    use super::*;

    fn data(n: usize) -> (Samples, impl Fn(&[f64]) -> [f64; 2]) {
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
    fn likelihood_gradient_matches_central_differences() {
        let (s, _) = data(40);
        let rows: Vec<usize> = (0..40).collect();
        let y = Mat::<f64>::from_fn(40, 2, |i, j| s.b[i][j]);
        let h = DVector::from_vec(vec![0.1, -0.4, 0.7, 0.2, -2.0]);
        let prior = prior_mean(3, 0.5);
        let mut g = DVector::zeros(5);
        let pairs = Pairs::new(&s.x, &rows);
        neg_log_likelihood(&pairs, &y, &h, &prior, Some(&mut g));
        for j in 0..5 {
            let step = 1e-5;
            let (mut a, mut b) = (h.clone(), h.clone());
            a[j] += step;
            b[j] -= step;
            let fd = (neg_log_likelihood(&pairs, &y, &a, &prior, None)
                - neg_log_likelihood(&pairs, &y, &b, &prior, None))
                / (2.0 * step);
            assert!(
                (fd - g[j]).abs() <= 1e-6 * (1.0 + fd.abs()),
                "component {j}: analytic {} numeric {fd}",
                g[j]
            );
        }
    }

    #[test]
    fn learns_a_smooth_function_and_ignores_an_idle_input() {
        let (s, truth) = data(150);
        let (rbf, _) = Rbf::fit(&s, None, 1).unwrap();
        assert!(
            rbf.widths[2] > 3.0 * rbf.widths[0].max(rbf.widths[1]),
            "idle input width {:?}",
            rbf.widths
        );
        let mut worst: f64 = 0.0;
        let mut y = [0.0; 2];
        for a in [-1.0, -0.3, 0.4, 1.1] {
            for b in [-0.8, 0.2, 0.9] {
                let x = [a, b, 0.5];
                rbf.forward_into(&x, &mut y);
                let t = truth(&x);
                worst = worst.max((y[0] - t[0]).abs()).max((y[1] - t[1]).abs());
            }
        }
        assert!(worst < 0.05, "largest error {worst}");
        // Far from every centre the output falls to zero.
        rbf.forward_into(&[40.0, -40.0, 0.0], &mut y);
        assert!(y.iter().all(|v| v.abs() < 1e-9), "{y:?}");
    }

    #[test]
    fn input_jacobian_matches_central_differences() {
        let (s, _) = data(60);
        let (rbf, _) = Rbf::fit(&s, None, 1).unwrap();
        let x = [0.3, -0.2, 0.8];
        let mut y = [0.0; 2];
        let mut dy = DMatrix::zeros(2, 3);
        rbf.input_jacobian_into(&x, &mut y, &mut dy);
        let mut y0 = [0.0; 2];
        rbf.forward_into(&x, &mut y0);
        assert_eq!(y, y0);
        for d in 0..3 {
            let (mut a, mut b) = (x, x);
            a[d] += 1e-6;
            b[d] -= 1e-6;
            let (mut ya, mut yb) = ([0.0; 2], [0.0; 2]);
            rbf.forward_into(&a, &mut ya);
            rbf.forward_into(&b, &mut yb);
            for o in 0..2 {
                let fd = (ya[o] - yb[o]) / 2e-6;
                assert!((fd - dy[(o, d)]).abs() < 1e-6 * (1.0 + fd.abs()), "{o} {d}");
            }
        }
    }

    #[test]
    fn the_best_search_has_the_lowest_objective_of_the_starts() {
        let (s, _) = data(80);
        let all: Vec<Search> = (0..STARTS.len())
            .map(|k| search(&s, k, 1).unwrap())
            .collect();
        let best = search_best(&s, 1).unwrap();
        let lowest = all
            .iter()
            .map(|f| f.objective)
            .fold(f64::INFINITY, f64::min);
        assert_eq!(best.objective, lowest);
        assert!(all.contains(&best));
        // The fit from a start is the network at that start's hyperparameters.
        let (rbf, found) = Rbf::fit(&s, Some(1), 1).unwrap();
        assert_eq!(found, all[1]);
        assert_eq!(rbf, Rbf::with_hyper(&s, &all[1].hyper).unwrap());
        assert!(search(&s, STARTS.len(), 1).is_err());
    }

    #[test]
    fn refuses_mapped_samples() {
        let (mut s, _) = data(10);
        s.maps = Some(vec![DMatrix::identity(2, 2); 10]);
        assert!(Rbf::fit(&s, None, 1).is_err());
    }
}
