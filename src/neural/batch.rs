//! The training samples as matrices (one row per sample) for fast batched passes of an MLP:
//! the penalised objective of [`super::samples`] and its gradient by matrix products, and the
//! variable projection of phase 2 (the output layer solved for the hidden layer given).
//! The products run on [`super::products`]'s kernel where it gives the bits of nalgebra's
//! (AVX2 and FMA, every dimension above nalgebra's small ones), on nalgebra elsewhere.

use super::products::{Isa, NALGEBRA_SMALL, abt, fast};
use super::samples::{Samples, weight_norm2};
use super::vectors::{add_products, sub_products};
use super::weights::Weights;
use nalgebra::{DMatrix, DMatrixViewMut, DVector};

/// The samples as matrices (one row per sample) for fast batched passes: the objective and
/// its gradient by matrix products, the numbers of [`super::samples::objective`] and
/// [`Samples::mse`] (to about 1e-16: the batch's activation runs on [`super::logistic`]'s
/// exponential).
pub struct Batch<'a> {
    s: &'a Samples,
    x: DMatrix<f64>,
    b: DMatrix<f64>,
    z: DMatrix<f64>,
    y: DMatrix<f64>,
    r: DMatrix<f64>,
    gy: DMatrix<f64>,
    gh: DMatrix<f64>,
    gw1: DMatrix<f64>,
    gw2: DMatrix<f64>,
    /// The projection's column sums of the activations (the gradients' go straight into
    /// the gradient).
    sums: Vec<f64>,
    /// The column sums of the targets `b` (constant: formed once).
    b_sums: Vec<f64>,
    /// The projection's normal matrix H~^T H~ + lambda D, (nh + 1) x (nh + 1), factored in
    /// place and kept for the next evaluation.
    normal: DMatrix<f64>,
    /// The projection's right-hand side H~^T B, (nh + 1) x the target columns, solved in place.
    rhs: DMatrix<f64>,
    /// The samples' maps (rows x outputs each) packed for passes over the samples: entry
    /// (row, c) of sample k at (row outputs + c) n + k, every sample's side by side.
    maps: Vec<f64>,
    /// W1^T and W2^T, copied in at every pass (an owned transpose per pass would allocate;
    /// [`super::products`] reads W1 in place, W1^T is then empty, and needs W2^T only).
    w1t: DMatrix<f64>,
    w2t: DMatrix<f64>,
    /// AVX2 and FMA where the samples, inputs and hidden units take `dgemm`'s fused kernel:
    /// the hidden layer's products (X W1^T, Z^T Z) then run on [`super::products::abt`].
    simd: Option<Isa>,
    /// The same where the outputs do too: the products with the output layer (Z W2^T, Gy W2)
    /// and the hidden layer's gradient (Gh^T X) run on it.
    simd_out: Option<Isa>,
    /// The same where the target columns do too: the projection's Z^T B runs on it.
    simd_rhs: Option<Isa>,
    /// X^T (inputs x samples), formed once, for Gh^T X (empty where nalgebra multiplies).
    xt: DMatrix<f64>,
    /// Z^T (hidden units x samples): the activations as the kernel computes them (Z is their
    /// transpose; empty where nalgebra multiplies).
    zt: DMatrix<f64>,
    /// Gh^T (hidden units x samples): the hidden layer's gradients as the kernel computes them
    /// (empty where nalgebra multiplies, which fills `gh` instead).
    ght: DMatrix<f64>,
    /// B^T (target columns x samples), formed once, for Z^T B (empty where nalgebra
    /// multiplies).
    bt: DMatrix<f64>,
}

impl<'a> Batch<'a> {
    /// The matrices of `s` and workspaces sized for networks shaped as `w`.
    pub fn new(s: &'a Samples, w: &Weights) -> Self {
        Self::with_kernels(s, w, true)
    }

    /// [`Batch::new`], running nalgebra's products throughout unless `kernels` (the products
    /// of [`super::products`] where they give nalgebra's bits).
    fn with_kernels(s: &'a Samples, w: &Weights, kernels: bool) -> Self {
        let (n, rows) = (s.len(), s.rows());
        let (nh, ni, no) = (w.hidden(), w.inputs(), w.outputs());
        let x = DMatrix::from_fn(n, ni, |k, i| s.x[k][i]);
        let b = DMatrix::from_fn(n, rows, |k, r| s.b[k][r]);
        let mut b_sums = vec![0.0; rows];
        column_sums(&b, &mut b_sums);
        let maps = s.maps.as_ref().map_or_else(Vec::new, |list| {
            debug_assert!(
                list.len() == n && list.iter().all(|a| a.shape() == (rows, no)),
                "Batch::new: one rows x outputs map per sample"
            );
            let mut packing = vec![0.0; rows * no * n];
            for (k, a) in list.iter().enumerate() {
                for row in 0..rows {
                    for c in 0..no {
                        packing[(row * no + c) * n + k] = a[(row, c)];
                    }
                }
            }
            packing
        });
        // Each product on the kernel where nalgebra called `dgemm` for it (every dimension
        // above its small ones), the transposed copies only where they are read.
        let simd = fast(&[n, ni, nh]).filter(|_| kernels);
        let simd_out = simd.filter(|_| no > NALGEBRA_SMALL);
        let simd_rhs = simd.filter(|_| rows > NALGEBRA_SMALL && s.maps.is_none());
        let t = |on: bool, r: usize| DMatrix::zeros(if on { r } else { 0 }, n);
        let (mut xt, mut bt) = (t(simd_out.is_some(), ni), t(simd_rhs.is_some(), rows));
        if simd_out.is_some() {
            x.transpose_to(&mut xt);
        }
        if simd_rhs.is_some() {
            b.transpose_to(&mut bt);
        }
        let (zt, ght) = (t(simd.is_some(), nh), t(simd_out.is_some(), nh));
        let gh = DMatrix::zeros(n, if simd_out.is_some() { 0 } else { nh });
        Batch {
            s,
            x,
            b,
            z: DMatrix::zeros(n, nh),
            y: DMatrix::zeros(n, no),
            r: DMatrix::zeros(n, rows),
            gy: DMatrix::zeros(n, no),
            gh,
            gw1: DMatrix::zeros(nh, ni),
            gw2: DMatrix::zeros(no, nh),
            sums: vec![0.0; nh],
            b_sums,
            normal: DMatrix::zeros(nh + 1, nh + 1),
            rhs: DMatrix::zeros(nh + 1, rows),
            maps,
            // Read where nalgebra computes the hidden layer only.
            w1t: DMatrix::zeros(ni, if simd.is_some() { 0 } else { nh }),
            w2t: DMatrix::zeros(nh, no),
            simd,
            simd_out,
            simd_rhs,
            xt,
            zt,
            ght,
            bt,
        }
    }

    /// Hidden activations of every sample into `z`.
    fn hidden(&mut self, w: &Weights) {
        if let Some(simd) = self.simd {
            // Z^T = W1 X^T, a sample per column, its activations, and Z.
            let nh = self.zt.nrows();
            debug_assert_eq!(w.hidden(), nh, "hidden: the batch's shape");
            abt(simd, &w.w1, &self.x, false, self.zt.as_mut_slice(), nh);
            super::logistic::logistic_columns_in_place(self.zt.as_mut_slice(), w.b1.as_slice());
            transpose_into(&self.zt, &mut self.z);
            return;
        }
        self.w1t.tr_copy_from(&w.w1);
        self.x.mul_to(&self.w1t, &mut self.z);
        let n = self.z.nrows();
        for (j, col) in self.z.as_mut_slice().chunks_exact_mut(n.max(1)).enumerate() {
            super::logistic::logistic_in_place(col, w.b1[j]);
        }
    }

    /// Forward pass: hidden activations into `z`, outputs into `y`, residuals into `r`;
    /// returns the sum of squared residuals.
    fn forward(&mut self, w: &Weights) -> f64 {
        self.hidden(w);
        self.outputs(w)
    }

    /// Outputs and residuals from the activations in `z`; the sum of squared residuals.
    fn outputs(&mut self, w: &Weights) -> f64 {
        if let Some(simd) = self.simd_out {
            let n = self.y.nrows();
            abt(simd, &self.z, &w.w2, false, self.y.as_mut_slice(), n);
        } else {
            self.w2t.tr_copy_from(&w.w2);
            self.z.mul_to(&self.w2t, &mut self.y);
        }
        for (o, mut col) in self.y.column_iter_mut().enumerate() {
            col.add_scalar_mut(w.b2[o]);
        }
        match &self.s.maps {
            None => {
                self.r.copy_from(&self.b);
                self.r -= &self.y;
            }
            Some(_) => {
                // Column-major slices: sample k's entry of column c is at c n + k. Each
                // residual is b - a_0 y_0 - a_1 y_1 - ..., in that order, every sample side
                // by side.
                let n = self.y.nrows();
                let no = self.y.ncols();
                let (b, y, r) = (self.b.as_slice(), self.y.as_slice(), self.r.as_mut_slice());
                r.copy_from_slice(b);
                // (chunks of at least 1: none without samples)
                for (row, r) in r.chunks_exact_mut(n.max(1)).enumerate() {
                    for (c, y) in y.chunks_exact(n.max(1)).enumerate() {
                        sub_products(r, packed(&self.maps, row, c, no, n), y);
                    }
                }
            }
        }
        self.r.norm_squared()
    }

    /// Mean squared residual (no penalty).
    pub fn mse(&mut self, w: &Weights) -> f64 {
        if self.s.is_empty() {
            return 0.0;
        }
        self.forward(w) / self.s.components() as f64
    }

    /// The penalised objective F and its gradient, as [`super::samples::objective`].
    pub fn objective(&mut self, w: &Weights, lambda: f64, grad: &mut DVector<f64>) -> f64 {
        let sum = self.forward(w);
        self.backward(w, sum, lambda, grad)
    }

    /// Variable projection (samples without maps: the outputs are linear in the output layer):
    /// for the hidden layer of `w`, sets the output layer to its exact minimiser
    /// (W2 b2)^T = (H~^T H~ + lambda D)^-1 H~^T B, H~ = [H 1], D = diag(1, .., 1, 0), and
    /// returns F there with its gradient (by the envelope theorem, the full gradient at that
    /// point; its output-layer part is zero).
    pub fn objective_projected(
        &mut self,
        w: &mut Weights,
        lambda: f64,
        grad: &mut DVector<f64>,
    ) -> f64 {
        self.hidden(w);
        let (n, nh) = (self.z.nrows(), self.z.ncols());
        let targets = self.b.ncols();
        // The normal matrix is taken out of the batch for the factorisation, which consumes
        // it, and put back after: no allocation per evaluation (a failed factorisation drops
        // it; the next evaluation makes a new one).
        let mut a = std::mem::replace(&mut self.normal, DMatrix::zeros(0, 0));
        if a.shape() != (nh + 1, nh + 1) {
            a = DMatrix::zeros(nh + 1, nh + 1);
        }
        a.fill(0.0);
        if let Some(simd) = self.simd {
            abt(simd, &self.zt, &self.zt, true, a.as_mut_slice(), nh + 1);
            row_sums(&self.zt, &mut self.sums);
        } else {
            gemm_tn(&self.z, &self.z, a.view_mut((0, 0), (nh, nh)));
            column_sums(&self.z, &mut self.sums);
        }
        for (j, &s) in self.sums.iter().enumerate() {
            a[(j, nh)] = s;
            a[(nh, j)] = s;
            a[(j, j)] += lambda;
        }
        a[(nh, nh)] = n as f64;
        let rhs = &mut self.rhs;
        debug_assert_eq!(
            rhs.shape(),
            (nh + 1, targets),
            "projection: rhs sized in new"
        );
        match self.simd_rhs {
            Some(simd) => abt(simd, &self.zt, &self.bt, false, rhs.as_mut_slice(), nh + 1),
            None => gemm_tn(&self.z, &self.b, rhs.view_mut((0, 0), (nh, targets))),
        }
        for (c, &s) in self.b_sums.iter().enumerate() {
            rhs[(nh, c)] = s;
        }
        // A tiny ridge keeps a saturated (constant) unit from making A singular.
        for j in 0..=nh {
            a[(j, j)] += 1e-12 * (1.0 + a[(j, j)]);
        }
        if let Some(ch) = a.cholesky() {
            ch.solve_mut(rhs);
            for o in 0..w.outputs() {
                for j in 0..nh {
                    w.w2[(o, j)] = rhs[(j, o)];
                }
                w.b2[o] = rhs[(nh, o)];
            }
            self.normal = ch.unpack_dirty();
        }
        let sum = self.outputs(w);
        self.backward(w, sum, lambda, grad)
    }

    /// The gradient from the residuals of the last forward pass into `grad`; returns F.
    fn backward(&mut self, w: &Weights, sum: f64, lambda: f64, grad: &mut DVector<f64>) -> f64 {
        let (nh, ni, no) = (w.hidden(), w.inputs(), w.outputs());
        let m = self.s.components().max(1) as f64;
        match &self.s.maps {
            None => {
                self.gy.copy_from(&self.r);
                self.gy *= -2.0 / m;
            }
            Some(_) => {
                // Column-major slices: sample k's entry of column c is at c n + k. Each
                // gradient is -2 / M (0 + a_0 r_0 + a_1 r_1 + ...), in that order, every
                // sample side by side.
                let n = self.r.nrows();
                let (r, gy) = (self.r.as_slice(), self.gy.as_mut_slice());
                gy.fill(0.0);
                for (c, gy) in gy.chunks_exact_mut(n.max(1)).enumerate() {
                    for (row, r) in r.chunks_exact(n.max(1)).enumerate() {
                        add_products(gy, packed(&self.maps, row, c, no, n), r);
                    }
                    for t in gy.iter_mut() {
                        *t *= -2.0 / m;
                    }
                }
            }
        }
        // dF/dW2 = Gy^T H, dF/dH = Gy W2, dF/dZ = dF/dH . H (1 - H), dF/dW1 = Gz^T X.
        super::vectors::tr_mul_to(&self.gy, &self.z, &mut self.gw2);
        let (gh, z) = if let Some(simd) = self.simd_out {
            // Gh^T = W2^T Gy^T, a sample per column, as Z^T.
            self.w2t.tr_copy_from(&w.w2);
            abt(
                simd,
                &self.w2t,
                &self.gy,
                false,
                self.ght.as_mut_slice(),
                nh,
            );
            (self.ght.as_mut_slice(), self.zt.as_slice())
        } else {
            self.gy.mul_to(&w.w2, &mut self.gh);
            (self.gh.as_mut_slice(), self.z.as_slice())
        };
        // As wide as the processor allows (AVX-512, AVX2 or the baseline's two values), the
        // same operations: a pass over every sample and hidden unit per evaluation.
        crate::neural::wide::dispatch(
            #[inline(always)]
            || {
                for (g, h) in gh.iter_mut().zip(z) {
                    *g *= h * (1.0 - h);
                }
            },
        );
        match self.simd_out {
            // Gh^T X = Gh^T (X^T)^T.
            Some(simd) => abt(
                simd,
                &self.ght,
                &self.xt,
                false,
                self.gw1.as_mut_slice(),
                nh,
            ),
            None => gemm_tn(&self.gh, &self.x, self.gw1.view_mut((0, 0), (nh, ni))),
        }
        let (off_b1, off_w2, off_b2) = (nh * ni, nh * ni + nh, nh * ni + nh + no * nh);
        // The weights and the gradient's blocks by slices (row-major in the gradient,
        // column-major in the matrices); sums from 0 in row order, as nalgebra's `sum`.
        let decay = 2.0 * lambda / m;
        let g = grad.as_mut_slice();
        let (gw1, w1) = (self.gw1.as_slice(), w.w1.as_slice());
        if self.simd_out.is_some() {
            row_sums(&self.ght, &mut g[off_b1..off_b1 + nh]);
        } else {
            column_sums(&self.gh, &mut g[off_b1..off_b1 + nh]);
        }
        for j in 0..nh {
            for i in 0..ni {
                g[j * ni + i] = gw1[i * nh + j] + decay * w1[i * nh + j];
            }
        }
        let (gw2, w2) = (self.gw2.as_slice(), w.w2.as_slice());
        column_sums(&self.gy, &mut g[off_b2..off_b2 + no]);
        for o in 0..no {
            for j in 0..nh {
                g[off_w2 + o * nh + j] = gw2[j * no + o] + decay * w2[j * no + o];
            }
        }
        (sum + lambda * weight_norm2(w)) / m
    }
}

/// Entry (`row`, `c`) of every sample's map, side by side, from [`Batch`]'s packing of
/// maps with `no` columns over `n` samples.
fn packed(maps: &[f64], row: usize, c: usize, no: usize, n: usize) -> &[f64] {
    &maps[(row * no + c) * n..][..n]
}

/// The sum of every column of `m` into `out` (one per column), each added in row order from
/// 0 (the bits of nalgebra's `sum`), the columns side by side: one chain of additions per
/// column running at once instead of each addition waiting on the one before.
fn column_sums(m: &DMatrix<f64>, out: &mut [f64]) {
    let n = m.nrows();
    debug_assert_eq!(out.len(), m.ncols(), "column_sums: one sum per column");
    out.fill(0.0);
    for k in 0..n {
        for (t, column) in out.iter_mut().zip(m.as_slice().chunks_exact(n)) {
            *t += column[k];
        }
    }
}

/// The sum of every row of `m` into `out` (one per row), each added in column order from 0:
/// [`column_sums`] of m^T, the rows side by side.
fn row_sums(m: &DMatrix<f64>, out: &mut [f64]) {
    debug_assert_eq!(out.len(), m.nrows(), "row_sums: one sum per row");
    out.fill(0.0);
    for column in m.as_slice().chunks_exact(m.nrows().max(1)) {
        for (t, v) in out.iter_mut().zip(column) {
            *t += v;
        }
    }
}

/// `out` = A^T B (A: rows x m, B: rows x n, out: m x n), the numbers of nalgebra's `gemm` on a
/// transposed copy of A, without the copy (written one cache line per number, it cost more
/// than the product on the batch's long, thin matrices). Where every dimension exceeds
/// [`NALGEBRA_SMALL`], `matrixmultiply`'s blocked `dgemm`, which nalgebra calls there, reading A
/// with its row and column strides swapped; below, nalgebra's loop (each entry
/// a_0i b_0j + a_1i b_1j + ..., added in row order). Not nalgebra's `gemm` on a view with
/// A's strides swapped: its small-matrix path (`axcpy_uninit`) loops over a strided view's
/// whole span and writes out of bounds (dimforge/nalgebra#1616, open).
fn gemm_tn(a: &DMatrix<f64>, b: &DMatrix<f64>, mut out: DMatrixViewMut<'_, f64>) {
    let (rows, m) = a.shape();
    let n = b.ncols();
    assert!(
        b.nrows() == rows && out.shape() == (m, n),
        "gemm_tn: shapes {:?}^T {:?} into {:?}",
        a.shape(),
        b.shape(),
        out.shape()
    );
    if m <= NALGEBRA_SMALL || n <= NALGEBRA_SMALL || rows <= NALGEBRA_SMALL {
        for j in 0..n {
            let bj = b.column(j);
            for i in 0..m {
                let ai = a.column(i);
                out[(i, j)] = if rows == 0 {
                    0.0
                } else {
                    (1..rows).fold(ai[0] * bj[0], |t, p| ai[p] * bj[p] + t)
                };
            }
        }
        return;
    }
    let (rsc, csc) = out.strides();
    // Strides in elements: A^T's (i, p) is a's (p, i), at i rows + p; B's (p, j) at
    // j rows + p; out's (i, j) at i rsc + j csc, distinct for distinct (i, j) (a view of a
    // matrix, rsc >= 1 and csc >= the view's rows).
    let (rows_stride, rsc, csc) = (rows as isize, rsc as isize, csc as isize);
    // SAFETY: every index dgemm forms (i < m, p < rows, j < n) lies within the storage of
    // `a`, `b` and `out` by the strides above and the shapes checked; `out` is borrowed
    // mutably, so it aliases neither input, and it is initialised (a view of a matrix),
    // which beta 0 overwrites.
    unsafe {
        matrixmultiply::dgemm(
            m,
            rows,
            n,
            1.0,
            a.as_ptr(),
            rows_stride,
            1,
            b.as_ptr(),
            1,
            rows_stride,
            0.0,
            out.as_mut_ptr(),
            rsc,
            csc,
        );
    }
}

/// `dst <- src^T` (shapes r x c and c x r), eight of `src`'s columns at a time: each pass
/// reads eight whole columns and writes eight consecutive values of each of `dst`'s columns,
/// where nalgebra's `transpose_to` walks `src` along its rows (a stride of r values per read).
fn transpose_into(src: &DMatrix<f64>, dst: &mut DMatrix<f64>) {
    let (r, c) = src.shape();
    assert_eq!(dst.shape(), (c, r), "transpose_into: shapes");
    let (s, d) = (src.as_slice(), dst.as_mut_slice());
    for j0 in (0..c).step_by(8) {
        let j1 = (j0 + 8).min(c);
        for i in 0..r {
            let row = &mut d[i * c + j0..i * c + j1];
            for (v, j) in row.iter_mut().zip(j0..j1) {
                *v = s[j * r + i];
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::neural::samples::objective;

    #[test]
    fn the_blocked_transpose_is_nalgebras() {
        for (r, c) in [(32, 150), (7, 13), (1, 9), (9, 1), (16, 16), (0, 5)] {
            let src = DMatrix::from_fn(r, c, |i, j| (i * 1000 + j) as f64 + 0.5);
            let mut got = DMatrix::from_element(c, r, f64::NAN);
            transpose_into(&src, &mut got);
            assert_eq!(got, src.transpose(), "{r} x {c}");
        }
    }

    /// The batch's shortcuts give the bits of what they replace: A^T B without the copy those
    /// of nalgebra's `gemm` on a transposed copy, into a view of a larger matrix as the
    /// projection writes it (300 rows: more than `dgemm`'s blocks of 256 along them), and in
    /// every shape where one dimension is at most nalgebra's small-matrix threshold (its own
    /// loops there; position-only samples have 3 outputs); the side-by-side column sums those
    /// of nalgebra's `sum` of each column (numbers of spread magnitudes, whose sum depends on
    /// the order of the additions).
    #[test]
    fn products_without_copies_and_column_sums_give_nalgebras_bits() {
        let m = DMatrix::from_fn(300, 33, |i, j| {
            ((i * 31 + j * 17) as f64 * 0.713).sin() * 10f64.powi(((i * 7 + j) % 13) as i32 - 6)
        });
        let b = DMatrix::from_fn(300, 7, |i, j| ((i * 3 + j * 11) as f64 * 0.291).cos());
        let bits = |x: &DMatrix<f64>| x.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
        for (rows, cols, outs) in [
            (300, 33, 7),
            (300, 33, 3),
            (300, 4, 7),
            (5, 33, 7),
            (0, 8, 7),
        ] {
            let (a, c) = (
                m.view((0, 0), (rows, cols)).into_owned(),
                b.view((0, 0), (rows, outs)).into_owned(),
            );
            let mut ours = DMatrix::from_element(cols + 2, outs + 2, 5.0);
            gemm_tn(&a, &c, ours.view_mut((0, 0), (cols, outs)));
            let mut copied = DMatrix::from_element(cols, outs, f64::NAN);
            copied.gemm(1.0, &a.transpose(), &c, 0.0);
            let got = ours.view((0, 0), (cols, outs)).into_owned();
            assert_eq!(bits(&got), bits(&copied), "{rows} x {cols}, {outs}");
            // Nothing outside the view written.
            let untouched = ours.iter().filter(|&&v| v == 5.0).count();
            assert_eq!(untouched, (cols + 2) * (outs + 2) - cols * outs);
        }
        let mut sums = vec![f64::NAN; 33];
        column_sums(&m, &mut sums);
        let mut rows = vec![f64::NAN; 33];
        row_sums(&m.transpose(), &mut rows);
        for (j, s) in sums.iter().enumerate() {
            assert_eq!(s.to_bits(), m.column(j).sum().to_bits(), "column {j}");
            assert_eq!(rows[j].to_bits(), s.to_bits(), "row {j}");
        }
        // In another order the sums differ: the comparison above can tell.
        let reversed: f64 = m.column(0).iter().rev().sum();
        assert_ne!(reversed.to_bits(), sums[0].to_bits());
    }

    /// The per-sample objective's gradient against central differences, and the batched
    /// passes (plain and projected) against the per-sample objective.
    #[test]
    fn gradient_matches_central_differences_with_maps_and_penalty() {
        for with_maps in [false, true] {
            let (w, s) = crate::neural::samples::test_fixture(with_maps, 5);
            let lambda = 0.7;
            let mut g = DVector::zeros(w.len());
            let f = objective(&s, &w, lambda, &mut g);
            // The batched pass gives the same numbers.
            let mut batch = Batch::new(&s, &w);
            let mut gb = DVector::zeros(w.len());
            let fb = batch.objective(&w, lambda, &mut gb);
            assert!(
                (f - fb).abs() < 1e-12 && (&g - &gb).amax() < 1e-12,
                "{f} vs {fb}"
            );
            assert!((batch.mse(&w) - s.mse(&w)).abs() < 1e-12);
            if !with_maps {
                // Projection: the output layer it sets is optimal (zero output-layer gradient,
                // checked by the per-sample objective) and its value is the objective there.
                let mut wp = w.clone();
                let mut gp = DVector::zeros(w.len());
                let fp = batch.objective_projected(&mut wp, lambda, &mut gp);
                let mut gd = DVector::zeros(w.len());
                let fd = objective(&s, &wp, lambda, &mut gd);
                assert!((fp - fd).abs() < 1e-12 && (&gp - &gd).amax() < 1e-10);
                let off = w.hidden() * w.inputs() + w.hidden();
                assert!(gd.rows(off, gd.len() - off).amax() < 1e-10, "{gd}");
                assert!(fp < f);
                // The batch keeps its normal matrix and right-hand side between evaluations:
                // other hidden weights, then one whose factorisation fails (a negative
                // penalty: A is not positive definite, the output layer is left as it was),
                // then the first again give the bits of a fresh batch each time.
                let mut other = w.clone();
                other.w1 *= 1.7;
                for (weights, lam) in [(&other, lambda), (&w, -1e3), (&w, lambda)] {
                    let (mut kept, mut fresh) = (weights.clone(), weights.clone());
                    let (mut gk, mut gf) = (DVector::zeros(w.len()), DVector::zeros(w.len()));
                    let fk = batch.objective_projected(&mut kept, lam, &mut gk);
                    let ff = Batch::new(&s, &w).objective_projected(&mut fresh, lam, &mut gf);
                    assert_eq!(fk.to_bits(), ff.to_bits(), "penalty {lam}");
                    assert_eq!(gk, gf);
                    assert_eq!(kept.to_vector(), fresh.to_vector());
                    if lam < 0.0 {
                        assert_eq!(kept.to_vector(), weights.to_vector(), "failed: unchanged");
                    }
                }
            }
            let direct = (s.mse(&w) * s.components() as f64 + lambda * weight_norm2(&w))
                / s.components() as f64;
            assert!((f - direct).abs() < 1e-12, "{f} vs {direct}");
            let v = w.to_vector();
            let mut scratch = DVector::zeros(w.len());
            for c in 0..v.len() {
                let e = 1e-6;
                let (mut vp, mut vm) = (v.clone(), v.clone());
                vp[c] += e;
                vm[c] -= e;
                let fp = objective(&s, &w.from_vector(&vp), lambda, &mut scratch);
                let fm = objective(&s, &w.from_vector(&vm), lambda, &mut scratch);
                let fd = (fp - fm) / (2.0 * e);
                assert!(
                    (fd - g[c]).abs() < 1e-8 * (1.0 + fd.abs()),
                    "maps {with_maps}, entry {c}: {fd} vs {}",
                    g[c]
                );
            }
        }
    }

    /// On shapes where products take `dgemm`'s kernel (more than five samples, inputs and
    /// hidden units; more than five outputs and target columns, or three of either, where
    /// those products run on nalgebra's loops), the batch's passes on
    /// [`super::super::products`] give the bits of its passes on nalgebra's products: the
    /// objective and gradient with and without maps, and the projection's output layer, value
    /// and gradient; and both agree with the per-sample objective.
    #[test]
    fn the_kernels_give_the_bits_of_nalgebras_products() {
        let (ni, nh, n) = (7, 9, 37);
        let bits = |v: &DVector<f64>| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        // (outputs, target columns, maps)
        for (no, rows, with_maps) in [(6, 6, false), (6, 6, true), (3, 3, false), (6, 3, true)] {
            let w = Weights {
                w1: DMatrix::from_fn(nh, ni, |i, j| ((i * 7 + j * 3) as f64 * 0.37).sin()),
                b1: DVector::from_fn(nh, |i, _| (i as f64 * 0.9).cos()),
                w2: DMatrix::from_fn(no, nh, |i, j| ((i * 5 + j) as f64 * 0.53).sin()),
                b2: DVector::from_fn(no, |i, _| i as f64 * 0.1 - 0.2),
            };
            let mut s = Samples::default();
            let mut maps = Vec::new();
            for k in 0..n {
                let t = k as f64;
                s.x.push((0..ni).map(|i| (t * 0.7 + i as f64).sin() * 1.3).collect());
                s.b.push(
                    (0..rows)
                        .map(|o| (t * 0.3 - o as f64).cos() * 0.4)
                        .collect(),
                );
                maps.push(DMatrix::from_fn(rows, no, |i, j| {
                    ((k + i * 2 + j) as f64).cos()
                }));
            }
            s.maps = with_maps.then_some(maps);
            let case = format!("{no} outputs, {rows} target columns, maps {with_maps}");
            let mut kernel = Batch::new(&s, &w);
            #[cfg(target_arch = "x86_64")]
            {
                let v3 = pulp::x86::V3::try_new().is_some();
                assert_eq!(kernel.simd.is_some(), v3, "{case}");
                assert_eq!(kernel.simd_out.is_some(), v3 && no == 6, "{case}");
                assert_eq!(kernel.simd_rhs.is_some(), v3 && !with_maps && rows == 6);
            }
            let mut plain = Batch::with_kernels(&s, &w, false);
            let (mut gk, mut gp) = (DVector::zeros(w.len()), DVector::zeros(w.len()));
            let fk = kernel.objective(&w, 0.3, &mut gk);
            let fp = plain.objective(&w, 0.3, &mut gp);
            assert_eq!(fk.to_bits(), fp.to_bits(), "{case}");
            assert_eq!(bits(&gk), bits(&gp), "{case}");
            let mut gd = DVector::zeros(w.len());
            let fd = objective(&s, &w, 0.3, &mut gd);
            assert!(
                (fk - fd).abs() < 1e-12 && (&gk - &gd).amax() < 1e-12,
                "{case}"
            );
            if !with_maps {
                let (mut wk, mut wp) = (w.clone(), w.clone());
                let fk = kernel.objective_projected(&mut wk, 0.3, &mut gk);
                let fp = plain.objective_projected(&mut wp, 0.3, &mut gp);
                assert_eq!(fk.to_bits(), fp.to_bits(), "{case}");
                assert_eq!(bits(&gk), bits(&gp), "{case}");
                assert_eq!(bits(&wk.to_vector()), bits(&wp.to_vector()), "{case}");
            }
        }
    }
}
