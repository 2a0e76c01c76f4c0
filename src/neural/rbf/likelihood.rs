//! The Gaussian process's kernel matrix and its negative log marginal likelihood with the
//! gradient by the log hyperparameters (Rasmussen and Williams 2006, eqs. 2.30 and 5.9).

use super::{Covariance, Hyper};
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::llt::{factor, inverse, solve};
use faer::{Conj, Mat};
use nalgebra::DVector;

/// Standard deviation (ln units) of the prior on each log hyperparameter.
pub const PRIOR_SD: f64 = 3.0;

/// The prior's centre: widths 1 (the inputs are standardised), signal variance the targets'
/// mean square `var`, noise a tenth of it.
pub(super) fn prior_mean(d: usize, var: f64) -> Hyper {
    let mut m = Hyper::zeros(d + 2);
    m[d] = var.ln();
    m[d + 1] = (0.1 * var).ln();
    m
}

/// 1 / l_d^2 = e^(-2 ln l_d) of every input under `h` into `w` (cleared first).
fn inverse_squares(h: &Hyper, w: &mut Vec<f64>) {
    w.clear();
    w.extend(h.rows(0, h.len() - 2).iter().map(|v| (-2.0 * v).exp()));
}

/// The lower triangle of K = s^2 E + (sigma^2 + jitter) I at the inputs `x` under `h` (E
/// the unit responses of `cov`, [`Covariance::response`]); the upper triangle is left 0.
pub(super) fn kernel(x: &[Vec<f64>], h: &Hyper, cov: Covariance) -> Mat<f64> {
    let n = x.len();
    let d = h.len() - 2;
    let mut w = Vec::with_capacity(d);
    inverse_squares(h, &mut w);
    let (s2, noise) = (h[d].exp(), h[d + 1].exp());
    let all: Vec<usize> = (0..n).collect();
    let pairs = Pairs::new(x, &all);
    // The lower triangle only, column by column (contiguous, input after input as the
    // likelihood's sweep adds them): the factorisation reads no other.
    let mut k = Mat::<f64>::zeros(n, n);
    crate::neural::wide::dispatch(
        #[inline(always)]
        || {
            for j in 0..n {
                let column = k.col_as_slice_mut(j);
                column[j] = s2 + noise + 1e-8 * s2;
                let below = &mut column[j + 1..];
                pairs.column_squares(j, &w, below);
                cov.responses_in_place(below, s2);
            }
        },
    );
    k
}

/// The scratch of [`factor_lower`] and of a solve for `rhs` columns on `n` rows, and with
/// `inverse` of [`inverse_lower`] (an n x n matrix of its own, which a fit does not need).
pub(super) fn scratch(n: usize, rhs: usize, inverse: bool) -> MemBuffer {
    let par = faer::get_global_parallelism();
    let solve = factor::cholesky_in_place_scratch::<f64>(n, par, Default::default())
        .or(solve::solve_in_place_scratch::<f64>(n, rhs, par));
    MemBuffer::new(if inverse {
        solve.or(inverse::inverse_scratch::<f64>(n, par))
    } else {
        solve
    })
}

/// Factors in place the positive definite K whose lower triangle `k` holds: L with L L^T =
/// K, by faer's LLT as `Mat::llt` runs it (the same numbers, without its copy of the
/// matrix), the strict upper triangle then 0. False where K is not positive definite.
pub(super) fn factor_lower(k: &mut Mat<f64>, stack: &mut MemStack) -> bool {
    let par = faer::get_global_parallelism();
    let ok = factor::cholesky_in_place(
        k.as_mut(),
        Default::default(),
        par,
        stack,
        Default::default(),
    )
    .is_ok();
    for j in 1..k.ncols() {
        k.col_as_slice_mut(j)[..j].fill(0.0);
    }
    ok
}

/// K^-1 B in place of `rhs` = B, with `l` the factor of [`factor_lower`].
pub(super) fn solve_lower(l: &Mat<f64>, rhs: &mut Mat<f64>, stack: &mut MemStack) {
    let par = faer::get_global_parallelism();
    solve::solve_in_place_with_conj(l.as_ref(), Conj::No, rhs.as_mut(), par, stack);
}

/// The lower triangle of K^-1 into `out` (its upper triangle left as it was), with `l` the
/// factor of [`factor_lower`].
fn inverse_lower(l: &Mat<f64>, out: &mut Mat<f64>, stack: &mut MemStack) {
    let par = faer::get_global_parallelism();
    inverse::inverse(out.as_mut(), l.as_ref(), par, stack);
}

/// What [`neg_log_likelihood_in`] writes on each evaluation, kept between the evaluations
/// of one search (the n x n matrices and the pairs' arrays, allocated and zeroed on every
/// evaluation otherwise).
pub(super) struct Scratch {
    k: Mat<f64>,
    kinv: Mat<f64>,
    alpha: Mat<f64>,
    e: Vec<f64>,
    p: Vec<f64>,
    /// Per pair, -2 dk/dq ([`Covariance::response_and_width_factor`]), then P with it in
    /// place of E (unused for the squared exponential, whose factor is E itself).
    g: Vec<f64>,
    /// 1 / l_d^2 of each input, and the gradient's sums over the pairs of each input.
    w: Vec<f64>,
    total: Vec<f64>,
    mem: MemBuffer,
}

impl Scratch {
    /// Scratch for `n` rows and `o` targets.
    pub(super) fn new(n: usize, o: usize) -> Scratch {
        Scratch {
            k: Mat::zeros(n, n),
            kinv: Mat::zeros(n, n),
            alpha: Mat::zeros(n, o),
            e: Vec::new(),
            p: Vec::new(),
            g: Vec::new(),
            w: Vec::new(),
            total: Vec::new(),
            mem: scratch(n, o, true),
        }
    }
}

/// Values in one register-wide block of the pair sweeps (eight: one AVX-512 register, two
/// AVX2 ones).
const LANES: usize = 8;

/// The inputs of the rows a search sees (or a fit's kernel matrix), laid out for the
/// likelihood's two sweeps over the pairs of rows (i > j, column by column): by input
/// (`columns`, the kernel's sweep adds input after input over many pairs at once) and by row
/// (`rows`, each padded with zeros to a multiple of 8 (`LANES`) inputs: the gradient's sweep
/// adds one pair to every input's sum, a register of inputs at a time, the sums held in
/// registers over every pair: three times faster than through memory on 400 rows of 30
/// inputs). The squared differences are formed on the fly from these two copies of
/// the inputs (250 kB on 500 rows and 30 inputs, cache-resident) instead of being stored per
/// pair and input (30 MB, read twice per evaluation). The padding only widens the registers:
/// every pair's and every input's sum is added in the order of the sweeps written out
/// (`Pairs::column_squares`, `tests::pair_sweeps_match_the_pairs_written_out`), so the same
/// bits.
pub struct Pairs {
    columns: Vec<Vec<f64>>,
    /// Row after row, [`Pairs::stride`] values each.
    rows: Vec<f64>,
    stride: usize,
    n: usize,
}

impl Pairs {
    /// The pairs of the rows `rows` of the inputs `x` (normalised input units).
    pub fn new(x: &[Vec<f64>], rows: &[usize]) -> Pairs {
        let d = x.first().map_or(0, |r| r.len());
        let stride = d.div_ceil(LANES) * LANES;
        let mut flat = vec![0.0; rows.len() * stride];
        for (out, &r) in flat.chunks_exact_mut(stride.max(1)).zip(rows) {
            out[..d].copy_from_slice(&x[r]);
        }
        let columns = (0..d)
            .map(|c| rows.iter().map(|&r| x[r][c]).collect())
            .collect();
        Pairs {
            columns,
            rows: flat,
            stride,
            n: rows.len(),
        }
    }

    /// Rows.
    fn len(&self) -> usize {
        self.n
    }

    /// Inputs per row.
    pub(super) fn inputs(&self) -> usize {
        self.columns.len()
    }

    /// sum_c w_c (x_ic - x_jc)^2 of every pair into `q` (pair order: j, then i > j), each
    /// pair's terms added input after input.
    fn weighted_squares(&self, w: &[f64], q: &mut [f64]) {
        crate::neural::wide::dispatch(
            #[inline(always)]
            || self.weighted_squares_in(w, q),
        );
    }

    #[inline(always)]
    fn weighted_squares_in(&self, w: &[f64], q: &mut [f64]) {
        let n = self.len();
        let mut at = 0;
        for j in 0..n {
            self.column_squares(j, w, &mut q[at..at + (n - j - 1)]);
            at += n - j - 1;
        }
    }

    /// The pairs (i, j), i > j, of one row j into `part` (n - j - 1 of them), as
    /// [`Pairs::weighted_squares`] adds them.
    #[inline(always)]
    fn column_squares(&self, j: usize, w: &[f64], part: &mut [f64]) {
        part.fill(0.0);
        for (column, &wc) in self.columns.iter().zip(w) {
            let xj = column[j];
            part.iter_mut()
                .zip(&column[j + 1..])
                .for_each(|(q, &xi)| *q += (xi - xj) * (xi - xj) * wc);
        }
    }

    /// sum over the pairs of p_ij (x_ic - x_jc)^2 for every input c into `total`, the pairs
    /// added in pair order.
    fn weighted_sums(&self, p: &[f64], total: &mut [f64]) {
        // A register block per LANES inputs, the sums kept in registers over every pair
        // (the padded inputs' lanes sum zeros, dropped); no input, or more than the
        // registers hold, through memory.
        match self.stride / LANES {
            1 => self.weighted_sums_of::<1>(p, total),
            2 => self.weighted_sums_of::<2>(p, total),
            3 => self.weighted_sums_of::<3>(p, total),
            4 => self.weighted_sums_of::<4>(p, total),
            5 => self.weighted_sums_of::<5>(p, total),
            6 => self.weighted_sums_of::<6>(p, total),
            _ => crate::neural::wide::dispatch(
                #[inline(always)]
                || self.weighted_sums_in(p, total),
            ),
        }
    }

    /// [`Pairs::weighted_sums`] with the sums of `R` x [`LANES`] inputs held in registers
    /// (each input's sum added pair after pair, as [`Pairs::weighted_sums_in`] adds it).
    fn weighted_sums_of<const R: usize>(&self, p: &[f64], total: &mut [f64]) {
        crate::neural::wide::dispatch(
            #[inline(always)]
            || {
                let n = self.len();
                // The width known to the compiler: R registers.
                let stride = R * LANES;
                debug_assert_eq!(self.stride, stride);
                // -0.0: the start of an f64 sum, as an iterator's `sum` starts it.
                let mut acc = [[-0.0; LANES]; R];
                let mut at = 0;
                for j in 0..n {
                    let xj: &[f64] = &self.rows[j * stride..(j + 1) * stride];
                    for xi in self.rows[(j + 1) * stride..n * stride].chunks_exact(stride) {
                        let pij = p[at];
                        for (r, acc) in acc.iter_mut().enumerate() {
                            let a: &[f64; LANES] = xi[r * LANES..(r + 1) * LANES]
                                .try_into()
                                .expect("a block of LANES");
                            let b: &[f64; LANES] = xj[r * LANES..(r + 1) * LANES]
                                .try_into()
                                .expect("a block of LANES");
                            for ((t, a), b) in acc.iter_mut().zip(a).zip(b) {
                                *t += pij * ((a - b) * (a - b));
                            }
                        }
                        at += 1;
                    }
                }
                for (c, t) in total.iter_mut().enumerate() {
                    *t = acc[c / LANES][c % LANES];
                }
            },
        );
    }

    /// [`Pairs::weighted_sums`] through memory, for more inputs than registers hold (or none).
    #[inline(always)]
    fn weighted_sums_in(&self, p: &[f64], total: &mut [f64]) {
        let n = self.len();
        let (d, stride) = (total.len(), self.stride);
        // -0.0: the start of an f64 sum, as an iterator's `sum` starts it.
        total.fill(-0.0);
        let mut at = 0;
        for j in 0..n {
            let xj = &self.rows[j * stride..j * stride + d];
            for i in j + 1..n {
                let xi = &self.rows[i * stride..i * stride + d];
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
/// `h`, plus the prior's negative log density around `prior` if given (constants dropped;
/// a search on several blocks of rows counts it with one block only), and its
/// gradient by h into `grad`: with alpha = K^-1 Y and M = alpha alpha^T - o K^-1,
/// d/dh_j = -1/2 sum_ij M_ij dK_ij/dh_j (Rasmussen and Williams eq. 5.9), where
/// dK/d ln l_d = s^2 G o D_d / l_d^2 (D_d the squared differences of input d, G = -2 dE/dq,
/// E itself for the squared exponential), dK/d ln s^2 = s^2 E and dK/d ln sigma^2 = sigma^2
/// I, with E_ij = G_ij = 0 beyond the weighted squared distance [`Covariance::far`] (K is the
/// module's `kernel` under `cov`). Infinite where K is not positive definite.
pub fn neg_log_likelihood(
    pairs: &Pairs,
    y: &Mat<f64>,
    h: &Hyper,
    prior: Option<&Hyper>,
    cov: Covariance,
    grad: Option<&mut DVector<f64>>,
) -> f64 {
    let mut scratch = Scratch::new(pairs.len(), y.ncols());
    neg_log_likelihood_in(pairs, y, h, prior, cov, grad, &mut scratch)
}

/// [`neg_log_likelihood`] writing into `scratch` (made for the rows of `pairs` and the
/// columns of `y`: a search's evaluations allocate nothing of the rows' size, only the prior's
/// d + 2 differences).
pub(super) fn neg_log_likelihood_in(
    pairs: &Pairs,
    y: &Mat<f64>,
    h: &Hyper,
    prior: Option<&Hyper>,
    cov: Covariance,
    grad: Option<&mut DVector<f64>>,
    scratch: &mut Scratch,
) -> f64 {
    let n = pairs.len();
    let d = h.len() - 2;
    let o = y.ncols();
    if h.iter().any(|v| !v.is_finite() || v.abs() > 50.0) || pairs.inputs() != d {
        return f64::INFINITY;
    }
    let (s2, noise) = (h[d].exp(), h[d + 1].exp());
    // E over the pairs, then K.
    let count = n * n.saturating_sub(1) / 2;
    if scratch.k.nrows() != n || scratch.alpha.ncols() != o {
        *scratch = Scratch::new(n, o);
    }
    let Scratch {
        k,
        kinv,
        alpha,
        e,
        p,
        g: gf,
        w,
        total,
        mem,
    } = scratch;
    inverse_squares(h, w);
    let stack = MemStack::new(mem);
    e.resize(count, 0.0);
    pairs.weighted_squares(w, e);
    let squared_exponential = cov == Covariance::SquaredExponential;
    if !squared_exponential && grad.is_some() {
        gf.resize(count, 0.0);
        cov.responses_and_width_factors_in_place(e, gf);
    } else {
        cov.responses_in_place(e, 1.0);
    }
    // The factorisation reads the lower triangle only: the upper one is zero (a new
    // scratch's, or the last factorisation's).
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
    if !factor_lower(k, stack) {
        return f64::INFINITY;
    }
    alpha.copy_from(y);
    solve_lower(k, alpha, stack);
    let l = &*k;
    let log_det: f64 = 2.0 * (0..n).map(|i| l[(i, i)].ln()).sum::<f64>();
    let mut fit = 0.0;
    for j in 0..o {
        for i in 0..n {
            fit += y[(i, j)] * alpha[(i, j)];
        }
    }
    let dh = prior.map(|p| h - p);
    let sd2 = PRIOR_SD * PRIOR_SD;
    let mut f = 0.5 * fit + 0.5 * o as f64 * log_det;
    if let Some(dh) = &dh {
        f += 0.5 * dh.norm_squared() / sd2;
    }
    if let Some(g) = grad {
        inverse_lower(k, kinv, stack);
        // (alpha alpha^T)_ij, formed where it is used instead of as an n x n product.
        let aa = |i: usize, j: usize| (0..o).fold(0.0, |s, c| s + alpha[(i, c)] * alpha[(j, c)]);
        let of = o as f64;
        // M's diagonal (E_ii = 1) and P = M o (s^2 E) over the pairs.
        let trace_m: f64 = (0..n).map(|i| aa(i, i) - of * kinv[(i, i)]).sum();
        // Every pair's entry is written below.
        p.resize(count, 0.0);
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
                crate::neural::wide::dispatch(
                    #[inline(always)]
                    || {
                        for (pij, ((&kij, &eij), &a_i)) in
                            p_j.iter_mut().zip(kinv_j.iter().zip(e_j).zip(a_below))
                        {
                            *pij = (a_i * a_j - of * kij) * s2 * eij;
                        }
                    },
                );
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
        // sum_ij P_ij D_ij = 2 sum_{i>j} P_ij D_ij (D_ii = 0), with G in place of E in P.
        total.resize(d, 0.0);
        if squared_exponential {
            pairs.weighted_sums(p, total);
        } else {
            // P_ij / E_ij G_ij, written over G (E and G are 0 together, beyond the cut-off).
            gf.iter_mut()
                .zip(p.iter().zip(e.iter()))
                .for_each(|(gij, (&pij, &eij))| {
                    *gij = if eij == 0.0 { 0.0 } else { pij / eij * *gij }
                });
            pairs.weighted_sums(gf, total);
        }
        for c in 0..d {
            g[c] = -total[c] * w[c];
        }
        if let Some(dh) = &dh {
            *g += dh / sd2;
        }
    }
    f
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::neural::rbf::FAR;
    use crate::neural::rbf::tests::data;
    use faer::Side;
    use faer::linalg::solvers::{DenseSolveCore, Solve};

    /// The in-place factorisation, solve and inverse are faer's `Mat::llt`, `solve` and
    /// `inverse` bit for bit (on the lower triangle, which is all the likelihood reads).
    #[test]
    fn in_place_factors_are_those_of_faers_llt() {
        let (s, _) = data(120);
        let h = Hyper::from_vec(vec![0.3, -0.2, 0.9, 0.1, -3.0]);
        let mut k = kernel(&s.x, &h, Covariance::DEFAULT);
        let chol = k.llt(Side::Lower).unwrap();
        let mut mem = scratch(120, 2, true);
        let stack = MemStack::new(&mut mem);
        assert!(factor_lower(&mut k, stack));
        assert_eq!(k, chol.L().to_owned());
        let b = Mat::<f64>::from_fn(120, 2, |i, j| s.b[i][j]);
        let mut x = b.clone();
        solve_lower(&k, &mut x, stack);
        assert_eq!(x, chol.solve(&b));
        let mut inv = Mat::<f64>::zeros(120, 120);
        inverse_lower(&k, &mut inv, stack);
        let expected = chol.inverse();
        for j in 0..120 {
            for i in j..120 {
                assert_eq!(inv[(i, j)], expected[(i, j)], "{i} {j}");
            }
        }
        // Not positive definite: refused.
        let mut bad = Mat::<f64>::identity(3, 3);
        bad[(1, 0)] = 2.0;
        assert!(!factor_lower(&mut bad, stack));
    }

    /// A search's scratch, reused across evaluations (after one refused, and after a
    /// factorisation that failed; one of another size remade), gives the numbers of a fresh
    /// one.
    #[test]
    fn a_reused_scratch_gives_the_numbers_of_a_fresh_one() {
        let (s, _) = data(60);
        let rows: Vec<usize> = (0..60).collect();
        let pairs = Pairs::new(&s.x, &rows);
        let y = Mat::<f64>::from_fn(60, 1, |i, _| s.b[i][0]);
        let prior = prior_mean(3, 0.5);
        let mut reused = Scratch::new(60, 1);
        let hs = [
            vec![0.1, -0.4, 0.7, 0.2, -2.0],
            // A noise variance of e^-60: beyond the bounds, refused before any factorisation.
            vec![0.1, -0.4, 0.7, 0.2, -60.0],
            vec![-1.0, 0.5, 0.3, -0.5, -4.0],
            vec![0.1, -0.4, 0.7, 0.2, -2.0],
        ];
        for (t, h) in hs.iter().enumerate() {
            if t == 2 {
                // A factorisation that fails midway leaves its scratch as the next needs it.
                let mut mem = scratch(60, 1, false);
                let k = &mut reused.k;
                for j in 0..60 {
                    k.col_as_slice_mut(j)[j..].fill(if j == 30 { -1.0 } else { 0.5 });
                }
                assert!(!factor_lower(k, MemStack::new(&mut mem)));
            }
            let h = DVector::from_vec(h.clone());
            // Both covariance functions through one scratch, one after the other.
            for cov in [Covariance::Matern52, Covariance::SquaredExponential] {
                let (mut g1, mut g2) = (DVector::zeros(5), DVector::zeros(5));
                let fresh = neg_log_likelihood(&pairs, &y, &h, Some(&prior), cov, Some(&mut g1));
                let again = neg_log_likelihood_in(
                    &pairs,
                    &y,
                    &h,
                    Some(&prior),
                    cov,
                    Some(&mut g2),
                    &mut reused,
                );
                assert_eq!(fresh.to_bits(), again.to_bits(), "{h}");
                assert_eq!(g1, g2);
            }
        }
        // A scratch of another size is remade.
        let mut small = Scratch::new(5, 1);
        let h = DVector::from_vec(hs[0].clone());
        let cov = Covariance::DEFAULT;
        assert_eq!(
            neg_log_likelihood_in(&pairs, &y, &h, Some(&prior), cov, None, &mut small).to_bits(),
            neg_log_likelihood(&pairs, &y, &h, Some(&prior), cov, None).to_bits()
        );
    }

    #[test]
    fn likelihood_gradient_matches_central_differences() {
        let (s, _) = data(40);
        let rows: Vec<usize> = (0..40).collect();
        let pairs = Pairs::new(&s.x, &rows);
        // One target (as every search has: its own path) and two; widths near 1, and
        // narrow ones (0.02 on inputs spread over 3) where most pairs lie beyond FAR.
        let near = vec![0.1, -0.4, 0.7, 0.2, -2.0];
        let narrow = vec![0.02f64.ln(), 0.03f64.ln(), 0.7, 0.2, -2.0];
        let w: Vec<f64> = narrow[..3].iter().map(|h| (-2.0 * h).exp()).collect();
        let mut q = vec![0.0; 40 * 39 / 2];
        pairs.weighted_squares(&w, &mut q);
        let far = q.iter().filter(|&&q| q > FAR).count();
        assert!(far > q.len() / 2, "{far} of {} pairs beyond FAR", q.len());
        // Narrower still (0.005 and 0.008): pairs beyond Matern 5/2's cut-off too.
        let narrower = vec![0.005f64.ln(), 0.008f64.ln(), 0.7, 0.2, -2.0];
        let w: Vec<f64> = narrower[..3].iter().map(|h| (-2.0 * h).exp()).collect();
        pairs.weighted_squares(&w, &mut q);
        let beyond = q
            .iter()
            .filter(|&&q| q > Covariance::Matern52.far())
            .count();
        assert!(
            beyond > q.len() / 4 && beyond < q.len(),
            "{beyond} of {} pairs beyond Matern's cut-off",
            q.len()
        );
        let cases = [
            (1, &near),
            (2, &near),
            (1, &narrow),
            (2, &narrow),
            (1, &narrower),
            (2, &narrower),
        ];
        for (cov, (targets, h)) in [Covariance::SquaredExponential, Covariance::Matern52]
            .into_iter()
            .flat_map(|c| cases.into_iter().map(move |t| (c, t)))
        {
            let y = Mat::<f64>::from_fn(40, targets, |i, j| s.b[i][j]);
            let h = DVector::from_vec(h.clone());
            let prior = prior_mean(3, 0.5);
            let mut g = DVector::zeros(5);
            let f = neg_log_likelihood(&pairs, &y, &h, Some(&prior), cov, Some(&mut g));
            assert!(f.is_finite());
            for j in 0..5 {
                let step = 1e-5;
                let (mut a, mut b) = (h.clone(), h.clone());
                a[j] += step;
                b[j] -= step;
                let fd = (neg_log_likelihood(&pairs, &y, &a, Some(&prior), cov, None)
                    - neg_log_likelihood(&pairs, &y, &b, Some(&prior), cov, None))
                    / (2.0 * step);
                assert!(
                    (fd - g[j]).abs() <= 1e-6 * (1.0 + fd.abs()),
                    "{cov:?}, {targets} target(s), {h}, component {j}: analytic {} numeric {fd}",
                    g[j]
                );
            }
        }
    }

    /// The sweeps over the pairs against the squared differences written out pair by pair:
    /// few rows and inputs, and rows and inputs enough for every register block and tail
    /// (8 inputs a register and the padding, the sums held in registers for up to 48 inputs
    /// and the sweep through memory beyond).
    #[test]
    fn pair_sweeps_match_the_pairs_written_out() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        let (small, _) = data(13);
        // (inputs, rows, the input held constant if any)
        let mut cases = vec![(small.x, vec![0, 2, 3, 5, 7, 8, 12], None)];
        // Inputs for every count of registers (1 to 6, the memory sweep beyond 48, none) and
        // rows for the sweeps' edges (one row: no pair).
        let shapes = [
            (75, 30),
            (40, 8),
            (33, 1),
            (20, 20),
            (12, 40),
            (10, 48),
            (9, 49),
            (9, 50),
            (70, 12),
            (6, 0),
            (1, 5),
        ];
        for (n, d) in shapes {
            let x: Vec<Vec<f64>> = (0..2 * n + 3)
                .map(|_| (0..d).map(|_| rng.random_range(-2.0..2.0)).collect())
                .collect();
            let rows: Vec<usize> = (0..2 * n + 3).filter(|r| r % 7 != 3).take(n).collect();
            assert_eq!(rows.len(), n);
            cases.push((x, rows, None));
        }
        // A constant input: its sum over weights all below zero stays -0.0 (the sum's start).
        let mut x: Vec<Vec<f64>> = (0..12)
            .map(|_| (0..9).map(|_| rng.random_range(-2.0..2.0)).collect())
            .collect();
        x.iter_mut().for_each(|r| r[4] = 0.5);
        cases.push((x, (0..12).collect(), Some(4)));
        for (x, rows, constant) in cases {
            let d = x[0].len();
            let pairs = Pairs::new(&x, &rows);
            let w: Vec<f64> = (0..d).map(|c| 0.25 + c as f64 / 3.0).collect();
            let count = rows.len() * rows.len().saturating_sub(1) / 2;
            let mut q = vec![f64::NAN; count];
            pairs.weighted_squares(&w, &mut q);
            // Weights of both signs, and all below zero.
            for p in [
                (0..count)
                    .map(|k| 1.0 - k as f64 / 7.0)
                    .collect::<Vec<f64>>(),
                (0..count).map(|k| -1.0 - k as f64 / 7.0).collect(),
            ] {
                let mut total = vec![f64::NAN; d];
                pairs.weighted_sums(&p, &mut total);
                // Written out pair by pair as the old table did it (and as an f64 sum starts,
                // at -0.0): the same operations in the same order, so the same bits.
                let mut expected_total = vec![-0.0; d];
                let mut at = 0;
                for j in 0..rows.len() {
                    // The kernel's sweep of one row (the kernel matrix's column).
                    let mut column = vec![f64::NAN; rows.len() - j - 1];
                    pairs.column_squares(j, &w, &mut column);
                    for i in j + 1..rows.len() {
                        let (xi, xj) = (&x[rows[i]], &x[rows[j]]);
                        let d2: Vec<f64> = (0..d).map(|c| (xi[c] - xj[c]).powi(2)).collect();
                        let mut expected = 0.0;
                        for c in 0..d {
                            expected += d2[c] * w[c];
                            expected_total[c] += p[at] * d2[c];
                        }
                        assert_eq!(q[at].to_bits(), expected.to_bits(), "{d} inputs, pair {at}");
                        assert_eq!(column[i - j - 1].to_bits(), expected.to_bits(), "pair {at}");
                        at += 1;
                    }
                }
                for c in 0..d {
                    assert_eq!(
                        total[c].to_bits(),
                        expected_total[c].to_bits(),
                        "{d} inputs, input {c}"
                    );
                }
                if let Some(c) = constant.filter(|_| p[0] < 0.0) {
                    assert_eq!(
                        total[c].to_bits(),
                        (-0.0f64).to_bits(),
                        "the constant input"
                    );
                }
            }
        }
    }
}
