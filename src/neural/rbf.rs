//! A radial-basis-function network (Broomhead and Lowe, 1988) whose widths and output weights
//! are those of Gaussian processes' posterior means (Rasmussen and Williams 2006, eqs. 2.25,
//! 5.8 and 5.9): one Gaussian unit per training row, centred on its normalised input, and for
//! each output o its own kernel,
//!
//!   y_o(x) = sum_i w_io exp(-1/2 sum_d ((x_d - c_id) / l_od)^2),
//!
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
//! the rows, so the hyperparameters are fitted on at most [`HYPER_ROWS`] of them (a seeded
//! choice) and only the weights use every row. The likelihood has several modes on real data,
//! so the search can run from each of [`STARTS`]; the factorisations use `faer`.

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
}

impl Kernel {
    /// 1 / l_d^2 of each input, appended to `inv`.
    fn inverse_squares_into(&self, inv: &mut Vec<f64>) {
        inv.extend(self.widths.iter().map(|l| 1.0 / (l * l)));
    }
}

/// The unit response exp(-1/2 sum_d (x_d - c_d)^2 / l_d^2) at `x` of the unit at `c`, with
/// `inv` the kernel's 1 / l_d^2 (multiplications: per input and unit a division cost four
/// times as much, most of a prediction).
fn response(x: &[f64], c: &[f64], inv: &[f64]) -> f64 {
    let mut s = 0.0;
    for ((xd, cd), i) in x.iter().zip(c).zip(inv) {
        let t = xd - cd;
        s += t * t * i;
    }
    (-0.5 * s).exp()
}

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

    /// Calls `f(outputs, inv, centre, weights, k)` for every kernel (the outputs it serves,
    /// its 1 / l_d^2) and unit, k the unit's response at `x`: kernel by kernel, the units in
    /// order. `inv` is scratch for the kernels' 1 / l_d^2 (no allocation once it has held
    /// them).
    fn responses(
        &self,
        x: &[f64],
        inv: &mut Vec<f64>,
        mut f: impl FnMut(std::ops::Range<usize>, &[f64], &[f64], &[f64], f64),
    ) {
        inv.clear();
        for k in &self.kernels {
            k.inverse_squares_into(inv);
        }
        let mut at = 0;
        for (kernel, outs) in self.kernel_outputs() {
            let own = &inv[at..at + kernel.widths.len()];
            at += kernel.widths.len();
            for (c, w) in self.centres.iter().zip(&self.weights) {
                f(outs.clone(), own, c, w, response(x, c, own));
            }
        }
    }

    /// y(x) into `y`; `inv` is scratch (no allocation once it has been used).
    pub fn forward_into(&self, x: &[f64], y: &mut [f64], inv: &mut Vec<f64>) {
        y.fill(0.0);
        self.responses(x, inv, |outs, _, _, w, k| {
            y[outs.clone()]
                .iter_mut()
                .zip(&w[outs])
                .for_each(|(yo, wo)| *yo += wo * k);
        });
    }

    /// y(x) into `y` and dy/dx (outputs x inputs) into `dy`: dy_o/dx_d = -sum_i w_io k_io
    /// (x_d - c_id) / l_od^2; `inv` is scratch as in [`Rbf::forward_into`].
    pub fn input_jacobian_into(
        &self,
        x: &[f64],
        y: &mut [f64],
        dy: &mut DMatrix<f64>,
        inv: &mut Vec<f64>,
    ) {
        y.fill(0.0);
        dy.fill(0.0);
        self.responses(x, inv, |outs, own, c, w, k| {
            if k == 0.0 {
                return;
            }
            for o in outs {
                let wk = w[o] * k;
                y[o] += wk;
                for (d, i) in own.iter().enumerate() {
                    dy[(o, d)] -= wk * (x[d] - c[d]) * i;
                }
            }
        });
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
    /// search from [`STARTS`]`[start]` ([`search`]), or when None from every start keeping,
    /// output by output, the highest likelihood ([`search_best`]), then the weights on every
    /// row ([`Rbf::with_hyper`]).
    pub fn fit(s: &Samples, start: Option<usize>, seed: u64) -> Result<(Rbf, Search)> {
        let found = match start {
            Some(k) => search(s, k, seed)?,
            None => search_best(s, seed)?,
        };
        Ok((Rbf::with_hyper(s, &found.hyper)?, found))
    }

    /// The network at fixed hyperparameters `h` (every output's, see [`Hyper`]): one unit
    /// per row of `s`, output o's weights w_o = s_o^2 K_o^-1 b_o (the posterior mean's).
    pub fn with_hyper(s: &Samples, h: &Hyper) -> Result<Rbf> {
        Rbf::with_hyper_on(s, h, true)
    }

    /// [`Rbf::with_hyper`], the outputs on several threads when `parallel` (callers that
    /// already run fits side by side pass false: each thread holds an n x n kernel).
    pub fn with_hyper_on(s: &Samples, h: &Hyper, parallel: bool) -> Result<Rbf> {
        let (n, d, o) = shape(s)?;
        if h.len() != o * (d + 2) || h.iter().any(|v| !v.is_finite()) {
            return Err(Error::Invalid(format!(
                "RBF hyperparameters: {} finite numbers expected for {d} inputs and {o} outputs",
                o * (d + 2)
            )));
        }
        let fit = |j: usize| -> Result<(Kernel, Vec<f64>)> {
            let hj = h.rows(j * (d + 2), d + 2).into_owned();
            let chol = kernel(&s.x, &hj).llt(Side::Lower).map_err(|_| {
                Error::Invalid(format!(
                    "the RBF network's kernel matrix of output {} is not positive definite",
                    j + 1
                ))
            })?;
            let alpha = chol.solve(Mat::<f64>::from_fn(n, 1, |i, _| s.b[i][j]));
            let s2 = hj[d].exp();
            let kernel = Kernel {
                outputs: 1,
                widths: (0..d).map(|c| hj[c].exp()).collect(),
                signal_variance: s2,
                noise_variance: hj[d + 1].exp(),
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

/// Where the hyperparameter searches start: (width of every standardised input, noise
/// variance as a fraction of the targets' mean square). The likelihood has several modes on
/// real tracker data: a smooth one, and rough ones that interpolate between repeated arm
/// configurations with narrow widths on a few joints and almost no noise. Each start leads to
/// one of them. Cross-validation tries the first (smooth) one unless told another; a fit
/// without a start takes, output by output, the start of highest likelihood.
pub const STARTS: [(f64, f64); 3] = [(1.0, 0.5), (0.2, 0.05), (0.05, 0.01)];

/// The result of one hyperparameter search.
#[derive(Debug, Clone, PartialEq)]
pub struct Search {
    /// Every output's [ln l_1 .. ln l_d, ln s^2, ln sigma^2], output after output ([`Hyper`]).
    pub hyper: Hyper,
    /// The minimised objective summed over the outputs: negative log marginal likelihood
    /// plus the prior's term (constants dropped).
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

/// Type-II maximum likelihood from [`STARTS`]`[start]`, output by output (L-BFGS on the log
/// hyperparameters, [`HYPER_ITERATIONS`] at most) on at most [`HYPER_ROWS`] rows of `s` (a
/// choice seeded by `seed` when there are more). The objective is the sum of the outputs'.
pub fn search(s: &Samples, start: usize, seed: u64) -> Result<Search> {
    let one = Searches::new(s, seed)?;
    let found = super::parallel::parallel_map(one.outputs, |j| one.output(j, start));
    Ok(join(found.into_iter().collect::<Result<Vec<_>>>()?))
}

/// The searches from every start (in parallel), keeping for each output the one of highest
/// likelihood.
pub fn search_best(s: &Samples, seed: u64) -> Result<Search> {
    let one = Searches::new(s, seed)?;
    let (o, starts) = (one.outputs, STARTS.len());
    let all = super::parallel::parallel_map(o * starts, |i| one.output(i / starts, i % starts));
    let mut best = Vec::with_capacity(o);
    let mut all = all.into_iter();
    for _ in 0..o {
        let mut pick: Option<Search> = None;
        let mut last_error = None;
        for r in all.by_ref().take(starts) {
            match r {
                Ok(f) if pick.as_ref().is_none_or(|b| f.objective < b.objective) => pick = Some(f),
                Ok(_) => {}
                Err(e) => last_error = Some(e),
            }
        }
        best.push(
            pick.ok_or_else(|| {
                last_error.unwrap_or_else(|| Error::Invalid("no RBF search".into()))
            })?,
        );
    }
    Ok(join(best))
}

/// The outputs' searches as one: their hyperparameters in output order, objectives summed.
fn join(per_output: Vec<Search>) -> Search {
    let hyper = Hyper::from_iterator(
        per_output.iter().map(|f| f.hyper.len()).sum(),
        per_output.iter().flat_map(|f| f.hyper.iter().copied()),
    );
    Search {
        hyper,
        objective: per_output.iter().map(|f| f.objective).sum(),
    }
}

/// What every output's search shares: the rows searched on and their pairs.
struct Searches<'a> {
    s: &'a Samples,
    /// Outputs of `s` (one search each).
    outputs: usize,
    rows: Vec<usize>,
    pairs: Pairs,
}

impl<'a> Searches<'a> {
    fn new(s: &'a Samples, seed: u64) -> Result<Searches<'a>> {
        let (n, _, outputs) = shape(s)?;
        let mut rows: Vec<usize> = (0..n).collect();
        if n > HYPER_ROWS {
            rows.shuffle(&mut ChaCha8Rng::seed_from_u64(seed ^ 0x7bf));
            rows.truncate(HYPER_ROWS);
            rows.sort_unstable();
        }
        let pairs = Pairs::new(&s.x, &rows);
        Ok(Searches {
            s,
            outputs,
            rows,
            pairs,
        })
    }

    /// Output `j`'s search from [`STARTS`]`[start]`: its d + 2 hyperparameters.
    fn output(&self, j: usize, start: usize) -> Result<Search> {
        let Some(&(width, noise)) = STARTS.get(start) else {
            return Err(Error::Invalid(format!(
                "RBF search start {start}: there are {} starts",
                STARTS.len()
            )));
        };
        let d = self.pairs.inputs();
        let y = Mat::<f64>::from_fn(self.rows.len(), 1, |i, _| self.s.b[self.rows[i]][j]);
        let square: f64 = (0..self.rows.len()).map(|i| y[(i, 0)] * y[(i, 0)]).sum();
        let var = (square / self.rows.len() as f64).max(1e-12);
        let prior = prior_mean(d, var);
        let mut h0 = Hyper::from_element(d + 2, width.ln());
        h0[d] = var.ln();
        h0[d + 1] = (noise * var).ln();
        let (mut last, mut idle) = (f64::INFINITY, 0);
        let (hyper, objective, _) = minimize(
            h0,
            8,
            HYPER_ITERATIONS,
            1e-6,
            |h, g| neg_log_likelihood(&self.pairs, &y, h, &prior, Some(g)),
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

/// The inputs of the rows a search sees, laid out for the likelihood's two sweeps over the
/// pairs of rows (i > j, column by column): by input (`columns`, the kernel's sweep adds
/// input after input over many pairs at once) and by row (`rows`, the gradient's sweep adds
/// one pair to every input's sum). The squared differences are formed on the fly from these
/// two copies of the inputs (240 kB on 500 rows and 30 inputs, cache-resident) instead of
/// being stored per pair and input (30 MB, read twice per evaluation).
pub struct Pairs {
    columns: Vec<Vec<f64>>,
    rows: Vec<Vec<f64>>,
}

impl Pairs {
    /// The pairs of the rows `rows` of the inputs `x` (normalised input units).
    pub fn new(x: &[Vec<f64>], rows: &[usize]) -> Pairs {
        let d = x.first().map_or(0, |r| r.len());
        let rows: Vec<Vec<f64>> = rows.iter().map(|&r| x[r].clone()).collect();
        let columns = (0..d)
            .map(|c| rows.iter().map(|r| r[c]).collect())
            .collect();
        Pairs { columns, rows }
    }

    /// Rows.
    fn len(&self) -> usize {
        self.rows.len()
    }

    /// Inputs per row.
    fn inputs(&self) -> usize {
        self.columns.len()
    }

    /// sum_c w_c (x_ic - x_jc)^2 of every pair into `q` (pair order: j, then i > j), each
    /// pair's terms added input after input.
    fn weighted_squares(&self, w: &[f64], q: &mut [f64]) {
        pulp::Arch::new().dispatch(|| self.weighted_squares_in(w, q));
    }

    #[inline(always)]
    fn weighted_squares_in(&self, w: &[f64], q: &mut [f64]) {
        let n = self.len();
        let mut at = 0;
        for j in 0..n {
            let part = &mut q[at..at + (n - j - 1)];
            part.fill(0.0);
            for (column, &wc) in self.columns.iter().zip(w) {
                let xj = column[j];
                part.iter_mut()
                    .zip(&column[j + 1..])
                    .for_each(|(q, &xi)| *q += (xi - xj) * (xi - xj) * wc);
            }
            at += n - j - 1;
        }
    }

    /// sum over the pairs of p_ij (x_ic - x_jc)^2 for every input c into `total`, the pairs
    /// added in pair order.
    fn weighted_sums(&self, p: &[f64], total: &mut [f64]) {
        pulp::Arch::new().dispatch(|| self.weighted_sums_in(p, total));
    }

    #[inline(always)]
    fn weighted_sums_in(&self, p: &[f64], total: &mut [f64]) {
        let n = self.len();
        // -0.0: the start of an f64 sum, as an iterator's `sum` starts it.
        total.fill(-0.0);
        let mut at = 0;
        for j in 0..n {
            let xj = &self.rows[j];
            for xi in &self.rows[j + 1..] {
                let pij = p[at];
                total
                    .iter_mut()
                    .zip(xi.iter().zip(xj))
                    .for_each(|(t, (a, b))| *t += pij * ((a - b) * (a - b)));
                at += 1;
            }
        }
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
    let n = pairs.len();
    let d = h.len() - 2;
    let o = y.ncols();
    if h.iter().any(|v| !v.is_finite() || v.abs() > 50.0) || pairs.inputs() != d {
        return f64::INFINITY;
    }
    let w: Vec<f64> = (0..d).map(|j| (-2.0 * h[j]).exp()).collect();
    let (s2, noise) = (h[d].exp(), h[d + 1].exp());
    // E over the pairs, then K.
    let count = n * n.saturating_sub(1) / 2;
    let mut e = vec![0.0; count];
    pairs.weighted_squares(&w, &mut e);
    e.iter_mut().for_each(|q| *q = (-0.5 * *q).exp());
    // The factorisation reads the lower triangle only: the upper one stays zero.
    let mut k = Mat::<f64>::zeros(n, n);
    let mut at = 0;
    for j in 0..n {
        let column = k.col_as_slice_mut(j);
        column[j] = s2 + noise + 1e-8 * s2;
        let below = n - j - 1;
        column[j + 1..]
            .iter_mut()
            .zip(&e[at..at + below])
            .for_each(|(kij, &eij)| *kij = s2 * eij);
        at += below;
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
        // (alpha alpha^T)_ij, formed where it is used instead of as an n x n product.
        let aa = |i: usize, j: usize| (0..o).fold(0.0, |s, c| s + alpha[(i, c)] * alpha[(j, c)]);
        let of = o as f64;
        // M's diagonal (E_ii = 1) and P = M o (s^2 E) over the pairs.
        let trace_m: f64 = (0..n).map(|i| aa(i, i) - of * kinv[(i, i)]).sum();
        let mut p = vec![0.0; count];
        let mut at = 0;
        for j in 0..n {
            let below = n - j - 1;
            let kinv_j = &kinv.col_as_slice(j)[j + 1..];
            let (p_j, e_j) = (&mut p[at..at + below], &e[at..at + below]);
            if o == 1 {
                // One target (every search): alpha_i alpha_j from the column's slice, a loop
                // that vectorises (10 % of a search against the general form below; the same
                // product bit for bit).
                let a = alpha.col_as_slice(0);
                let (a_j, a_below) = (a[j], &a[j + 1..]);
                pulp::Arch::new().dispatch(|| {
                    for (pij, ((&kij, &eij), &a_i)) in
                        p_j.iter_mut().zip(kinv_j.iter().zip(e_j).zip(a_below))
                    {
                        *pij = (a_i * a_j - of * kij) * s2 * eij;
                    }
                });
            } else {
                for (t, (pij, (&kij, &eij))) in
                    p_j.iter_mut().zip(kinv_j.iter().zip(e_j)).enumerate()
                {
                    *pij = (aa(j + 1 + t, j) - of * kij) * s2 * eij;
                }
            }
            at += below;
        }
        g.fill(0.0);
        // sum_ij P_ij = trace(P) + 2 sum_{i>j} P_ij, trace(P) = s^2 trace(M).
        g[d] = -0.5 * (s2 * trace_m + 2.0 * p.iter().sum::<f64>());
        g[d + 1] = -0.5 * noise * trace_m;
        // sum_ij P_ij D_ij = 2 sum_{i>j} P_ij D_ij (D_ii = 0).
        let mut total = vec![0.0; d];
        pairs.weighted_sums(&p, &mut total);
        for c in 0..d {
            g[c] = -total[c] * w[c];
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
        let pairs = Pairs::new(&s.x, &rows);
        // One target (as every search has: its own path) and two.
        for targets in [1, 2] {
            let y = Mat::<f64>::from_fn(40, targets, |i, j| s.b[i][j]);
            let h = DVector::from_vec(vec![0.1, -0.4, 0.7, 0.2, -2.0]);
            let prior = prior_mean(3, 0.5);
            let mut g = DVector::zeros(5);
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
                    "{targets} target(s), component {j}: analytic {} numeric {fd}",
                    g[j]
                );
            }
        }
    }

    /// The sweeps over the pairs against the squared differences written out pair by pair.
    #[test]
    fn pair_sweeps_match_the_pairs_written_out() {
        let (s, _) = data(13);
        let rows: Vec<usize> = vec![0, 2, 3, 5, 7, 8, 12];
        let pairs = Pairs::new(&s.x, &rows);
        let w = [0.5, 2.0, 0.25];
        let count = rows.len() * (rows.len() - 1) / 2;
        let mut q = vec![f64::NAN; count];
        pairs.weighted_squares(&w, &mut q);
        let p: Vec<f64> = (0..count).map(|k| 1.0 + k as f64 / 7.0).collect();
        let mut total = vec![f64::NAN; 3];
        pairs.weighted_sums(&p, &mut total);
        // Written out pair by pair as the old table did it (and as an f64 sum starts, at
        // -0.0): the same operations in the same order, so the same bits.
        let mut expected_total = [-0.0; 3];
        let mut at = 0;
        for j in 0..rows.len() {
            for i in j + 1..rows.len() {
                let (xi, xj) = (&s.x[rows[i]], &s.x[rows[j]]);
                let d2: Vec<f64> = (0..3).map(|c| (xi[c] - xj[c]).powi(2)).collect();
                let mut expected = 0.0;
                for c in 0..3 {
                    expected += d2[c] * w[c];
                    expected_total[c] += p[at] * d2[c];
                }
                assert_eq!(q[at].to_bits(), expected.to_bits(), "pair {at}");
                at += 1;
            }
        }
        for c in 0..3 {
            assert_eq!(total[c].to_bits(), expected_total[c].to_bits(), "input {c}");
        }
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
        // Far from every centre the output falls to zero.
        rbf.forward_into(&[40.0, -40.0, 0.0], &mut y, &mut inv);
        assert!(y.iter().all(|v| v.abs() < 1e-9), "{y:?}");
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
            let own = search(&one, 0, 1).unwrap();
            assert_eq!(own.hyper, found.hyper.rows(4 * j, 4).into_owned());
            let alone = Rbf::with_hyper(&one, &own.hyper).unwrap();
            assert_eq!(alone.kernels[0], rbf.kernels[j]);
        }
    }

    #[test]
    fn input_jacobian_matches_central_differences() {
        let (s, _) = data(60);
        let (rbf, _) = Rbf::fit(&s, None, 1).unwrap();
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
    fn the_best_search_takes_each_outputs_lowest_objective_of_the_starts() {
        let (s, _) = data(80);
        let all: Vec<Search> = (0..STARTS.len())
            .map(|k| search(&s, k, 1).unwrap())
            .collect();
        let best = search_best(&s, 1).unwrap();
        let lowest = all
            .iter()
            .map(|f| f.objective)
            .fold(f64::INFINITY, f64::min);
        assert!(best.objective <= lowest, "{} {lowest}", best.objective);
        // Output by output, the start of lowest objective on that output's own column.
        let block = s.x[0].len() + 2;
        let mut total = 0.0;
        for j in 0..s.rows() {
            let mut one = s.clone();
            one.b = s.b.iter().map(|b| vec![b[j]]).collect();
            let own = (0..STARTS.len())
                .map(|k| search(&one, k, 1).unwrap())
                .min_by(|a, b| a.objective.total_cmp(&b.objective))
                .unwrap();
            assert_eq!(
                best.hyper.rows(j * block, block),
                own.hyper.rows(0, block),
                "{j}"
            );
            total += own.objective;
        }
        assert_eq!(best.objective, total);
        // The fit from a start is the network at that start's hyperparameters.
        let (rbf, found) = Rbf::fit(&s, Some(1), 1).unwrap();
        assert_eq!(found, all[1]);
        assert_eq!(rbf, Rbf::with_hyper(&s, &all[1].hyper).unwrap());
        assert!(search(&s, STARTS.len(), 1).is_err());
        assert!(Rbf::with_hyper(&s, &all[1].hyper.rows(0, block).into_owned()).is_err());
    }

    #[test]
    fn refuses_mapped_samples() {
        let (mut s, _) = data(10);
        s.maps = Some(vec![DMatrix::identity(2, 2); 10]);
        assert!(Rbf::fit(&s, None, 1).is_err());
    }
}
