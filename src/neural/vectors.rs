//! Dense vector kernels with nalgebra's bits: the same operations in the same order as
//! nalgebra's `dot`, `axpy` and `tr_mul_to` (so the same results to the bit), four values at a
//! time in AVX2 registers (`pulp`'s V3, chosen at run time) where the processor has them, one
//! at a time elsewhere. nalgebra's `axpy` walks its vectors by run-time strides, one value at
//! a time, and the release build's baseline keeps its `dot` two values wide. L-BFGS's vector
//! operations were a sixth of the instructions of a default `train` on 150 poses.

use nalgebra::{DMatrix, DVector};

/// a . b of equal-length slices in nalgebra's order: eight partial sums over blocks of eight,
/// added pairwise (0 + 4, 1 + 5, ...), then the tail one by one.
#[inline(always)]
pub(super) fn dot_in(a: &[f64], b: &[f64]) -> f64 {
    #[cfg(target_arch = "x86_64")]
    if let Some(simd) = pulp::x86::V3::try_new() {
        return simd.vectorize(DotV3 { simd, a, b });
    }
    dot_plain(a, b)
}

/// [`dot_v3`] as the operation `vectorize` compiles with AVX2: a closure there was compiled
/// apart from the AVX2 code, two values wide and called each time (it raised a 150-pose
/// `train` from 7.9 to 12.1 G instructions); a method marked `inline(always)` is not.
#[cfg(target_arch = "x86_64")]
struct DotV3<'s> {
    simd: pulp::x86::V3,
    a: &'s [f64],
    b: &'s [f64],
}

#[cfg(target_arch = "x86_64")]
impl pulp::NullaryFnOnce for DotV3<'_> {
    type Output = f64;

    #[inline(always)]
    fn call(self) -> f64 {
        dot_v3(self.simd, self.a, self.b)
    }
}

/// [`dot_in`] one value at a time (where AVX2 is not there).
fn dot_plain(a: &[f64], b: &[f64]) -> f64 {
    let (mut lo, mut hi) = ([0.0f64; 4], [0.0f64; 4]);
    for (ca, cb) in a.chunks_exact(8).zip(b.chunks_exact(8)) {
        for k in 0..4 {
            lo[k] += ca[k] * cb[k];
            hi[k] += ca[k + 4] * cb[k + 4];
        }
    }
    finish(a, b, lo, hi)
}

/// [`dot_in`] with partial sums 0-3 and 4-7 in two AVX2 registers (the compiler, left to
/// itself, keeps them two values wide).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn dot_v3(simd: pulp::x86::V3, a: &[f64], b: &[f64]) -> f64 {
    use pulp::Simd;
    let (mut lo, mut hi) = (simd.splat_f64s(0.0), simd.splat_f64s(0.0));
    for (ca, cb) in a.chunks_exact(8).zip(b.chunks_exact(8)) {
        lo = simd.add_f64s(lo, simd.mul_f64s(load4(&ca[..4]), load4(&cb[..4])));
        hi = simd.add_f64s(hi, simd.mul_f64s(load4(&ca[4..]), load4(&cb[4..])));
    }
    finish(a, b, lanes(lo), lanes(hi))
}

/// The end of [`dot_in`]: the partial sums added in nalgebra's order, then the tail.
#[inline(always)]
pub(super) fn finish(a: &[f64], b: &[f64], lo: [f64; 4], hi: [f64; 4]) -> f64 {
    let mut res = 0.0;
    for k in 0..4 {
        res += lo[k] + hi[k];
    }
    for k in a.len() / 8 * 8..a.len() {
        res += a[k] * b[k];
    }
    res
}

/// The first four values of `c` in an AVX2 register.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
pub(super) fn load4(c: &[f64]) -> pulp::f64x4 {
    pulp::f64x4(c[0], c[1], c[2], c[3])
}

/// The four lanes of an AVX2 register.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
pub(super) fn lanes(v: pulp::f64x4) -> [f64; 4] {
    [v.0, v.1, v.2, v.3]
}

/// `v` into the first four values of `c`.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
pub(super) fn store4(c: &mut [f64], v: pulp::f64x4) {
    c[..4].copy_from_slice(&[v.0, v.1, v.2, v.3]);
}

/// a . b: nalgebra's `a.dot(&b)`.
pub fn dot(a: &DVector<f64>, b: &DVector<f64>) -> f64 {
    let (a, b) = (a.as_slice(), b.as_slice());
    assert_eq!(a.len(), b.len(), "dot: vectors of unequal lengths");
    dot_in(a, b)
}

/// |a|: nalgebra's `a.norm()` (the square root of 0 + a . a).
pub fn norm(a: &DVector<f64>) -> f64 {
    dot(a, a).sqrt()
}

/// max_i |a_i|: nalgebra's `a.amax()` (0 for an empty vector). Without NaN a maximum is
/// exact, so the order of the comparisons does not change it: eight running maxima, a loop
/// the compiler vectorises, where nalgebra's one chain of compare-and-selects was most of
/// L-BFGS's own time outside its vector passes (its stopping test, once per iteration). With a
/// NaN, nalgebra's order decides (its `a >= b` select keeps a NaN only from the last value
/// and forgets what came before one): nalgebra's `amax` then.
pub fn amax(a: &DVector<f64>) -> f64 {
    let values = a.as_slice();
    if values.is_empty() {
        return 0.0;
    }
    let (top, nan) = crate::neural::wide::dispatch(
        #[inline(always)]
        || {
            // Running maxima and NaN flags, a lane per value of a block of eight (the
            // remainder into the first lanes).
            let (mut top, mut nan) = ([0.0f64; 8], [false; 8]);
            let blocks = values.chunks_exact(8);
            let remainder = blocks.remainder();
            for block in blocks.chain([remainder]) {
                for ((m, n), v) in top.iter_mut().zip(nan.iter_mut()).zip(block) {
                    *m = if v.abs() > *m { v.abs() } else { *m };
                    *n |= v.is_nan();
                }
            }
            (top.into_iter().fold(0.0, f64::max), nan.contains(&true))
        },
    );
    if nan { a.amax() } else { top }
}

/// y <- y + a x: nalgebra's `y.axpy(a, x, 1.0)` (whose a x 1 + 1 y has these bits).
pub fn axpy(y: &mut DVector<f64>, a: f64, x: &DVector<f64>) {
    let (y, x) = (y.as_mut_slice(), x.as_slice());
    assert_eq!(y.len(), x.len(), "axpy: vectors of unequal lengths");
    crate::neural::wide::dispatch(
        #[inline(always)]
        || {
            for (y, x) in y.iter_mut().zip(x) {
                *y += a * x;
            }
        },
    );
}

/// y <- y - a x, element by element (each y - (a x), the bits of `*y -= a * x`).
pub fn sub_products(y: &mut [f64], a: &[f64], x: &[f64]) {
    elementwise::<true>(y, a, x, true);
}

/// y <- y + a x, element by element (each y + (a x), the bits of `*y += a * x`).
pub fn add_products(y: &mut [f64], a: &[f64], x: &[f64]) {
    elementwise::<false>(y, a, x, true);
}

/// y <- y - a x (`SUB`) or y + a x element by element: four at a time with AVX2 where the
/// processor has it and `wide` allows (the product and the sum as separate instructions, no
/// fused multiply-add: one value at a time's bits), one at a time on the rest.
#[inline(always)]
fn elementwise<const SUB: bool>(y: &mut [f64], a: &[f64], x: &[f64], wide: bool) {
    assert!(
        a.len() == y.len() && x.len() == y.len(),
        "elementwise: slices of unequal lengths"
    );
    #[cfg_attr(not(target_arch = "x86_64"), allow(unused_mut))]
    let mut done = 0;
    #[cfg(target_arch = "x86_64")]
    if wide && let Some(simd) = pulp::x86::V3::try_new() {
        simd.vectorize(ElementwiseV3::<SUB> {
            simd,
            y: &mut *y,
            a,
            x,
        });
        done = y.len() / 4 * 4;
    }
    for ((y, a), x) in y[done..].iter_mut().zip(&a[done..]).zip(&x[done..]) {
        *y = if SUB { *y - a * x } else { *y + a * x };
    }
}

/// [`elementwise`]'s blocks of four as the operation `vectorize` compiles with AVX2 (see
/// [`DotV3`]).
#[cfg(target_arch = "x86_64")]
struct ElementwiseV3<'s, const SUB: bool> {
    simd: pulp::x86::V3,
    y: &'s mut [f64],
    a: &'s [f64],
    x: &'s [f64],
}

#[cfg(target_arch = "x86_64")]
impl<const SUB: bool> pulp::NullaryFnOnce for ElementwiseV3<'_, SUB> {
    type Output = ();

    #[inline(always)]
    fn call(self) {
        use pulp::Simd;
        let simd = self.simd;
        for ((yc, ac), xc) in self
            .y
            .chunks_exact_mut(4)
            .zip(self.a.chunks_exact(4))
            .zip(self.x.chunks_exact(4))
        {
            let p = simd.mul_f64s(load4(ac), load4(xc));
            let v = if SUB {
                simd.sub_f64s(load4(yc), p)
            } else {
                simd.add_f64s(load4(yc), p)
            };
            store4(yc, v);
        }
    }
}

/// out = A^T B, each entry the dot product of a column of A and one of B: nalgebra's
/// `a.tr_mul_to(&b, out)`.
pub fn tr_mul_to(a: &DMatrix<f64>, b: &DMatrix<f64>, out: &mut DMatrix<f64>) {
    let rows = a.nrows();
    assert!(
        b.nrows() == rows && out.shape() == (a.ncols(), b.ncols()),
        "tr_mul_to: shapes {:?}^T {:?} into {:?}",
        a.shape(),
        b.shape(),
        out.shape()
    );
    if rows == 0 {
        out.fill(0.0);
        return;
    }
    let m = a.ncols();
    let (a, b, out) = (a.as_slice(), b.as_slice(), out.as_mut_slice());
    // Each entry dispatches on its own: a dispatch around the loops, with the dot product
    // passed in as a closure, was compiled apart from its AVX2 code (+25 % instructions).
    for (j, bj) in b.chunks_exact(rows).enumerate() {
        for (i, ai) in a.chunks_exact(rows).enumerate() {
            out[j * m + i] = dot_in(ai, bj);
        }
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// Values of many magnitudes (1e-6 to 1e6) and both signs, from a xorshift seeded by
    /// `seed`: sums of them in another order round otherwise.
    pub(crate) fn values(mut seed: u64) -> impl FnMut() -> f64 {
        move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            let m = (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5;
            m * 10f64.powi((seed % 13) as i32 - 6)
        }
    }

    /// The largest magnitude against nalgebra's `amax`, bit for bit: lengths around the
    /// blocks of eight, the largest, a NaN and -inf at every place, signed zeros, and every
    /// value NaN.
    #[test]
    fn the_largest_magnitude_is_nalgebras() {
        let mut next = values(0x9e37_79b9_7f4a_7c15);
        let same = |v: &DVector<f64>| {
            let (got, want) = (amax(v), v.amax());
            assert!(
                got.to_bits() == want.to_bits() || got.is_nan() && want.is_nan(),
                "{v}: {got} against {want}"
            );
        };
        for n in 0..27 {
            let v = DVector::from_fn(n, |_, _| next());
            same(&v);
            for at in 0..n {
                let mut w = v.clone();
                w[at] = -1e3;
                same(&w);
                w[at] = f64::NAN;
                same(&w);
                w[at] = f64::NEG_INFINITY;
                same(&w);
            }
        }
        same(&DVector::from_element(11, f64::NAN));
        same(&DVector::from_vec(vec![-0.0, 0.0, -0.0]));
        assert_eq!(amax(&DVector::from_vec(vec![-0.0; 9])).to_bits(), 0);
        assert_eq!(amax(&DVector::zeros(0)), 0.0);
    }

    #[test]
    fn vector_operations_give_nalgebras_bits() {
        // Lengths around the blocks of eight.
        let mut next = values(0x9e37_79b9_7f4a_7c15_u64);
        for n in [0, 1, 7, 8, 9, 15, 16, 17, 63, 992, 1190, 1999] {
            let a = DVector::from_fn(n, |_, _| next());
            let b = DVector::from_fn(n, |_, _| next());
            assert_eq!(dot(&a, &b).to_bits(), a.dot(&b).to_bits(), "dot, n = {n}");
            let plain = dot_plain(a.as_slice(), b.as_slice());
            assert_eq!(
                plain.to_bits(),
                a.dot(&b).to_bits(),
                "dot one at a time, n = {n}"
            );
            assert_eq!(norm(&a).to_bits(), a.norm().to_bits(), "norm, n = {n}");
            let alpha = next();
            let (mut y, mut z) = (b.clone(), b.clone());
            axpy(&mut y, alpha, &a);
            z.axpy(alpha, &a, 1.0);
            assert!(
                y.iter()
                    .zip(z.iter())
                    .all(|(p, q)| p.to_bits() == q.to_bits()),
                "axpy, n = {n}"
            );
        }
    }

    #[test]
    fn elementwise_products_give_one_value_at_a_times_bits() {
        let mut next = values(0x853c_49e6_748f_ea9b_u64);
        for n in [0, 1, 3, 4, 5, 8, 120, 123] {
            let mut v = || (0..n).map(|_| next()).collect::<Vec<f64>>();
            let (y, a, x) = (v(), v(), v());
            for wide in [true, false] {
                let (mut sub, mut add) = (y.clone(), y.clone());
                elementwise::<true>(&mut sub, &a, &x, wide);
                elementwise::<false>(&mut add, &a, &x, wide);
                for k in 0..n {
                    let (s, t) = (y[k] - a[k] * x[k], y[k] + a[k] * x[k]);
                    assert_eq!(sub[k].to_bits(), s.to_bits(), "n = {n}, {wide}");
                    assert_eq!(add[k].to_bits(), t.to_bits(), "n = {n}, {wide}");
                }
            }
        }
    }

    #[test]
    fn transposed_products_give_nalgebras_bits() {
        let mut next = values(0x2545_f491_4f6c_dd1d_u64);
        for (rows, m, n) in [(0, 3, 2), (1, 1, 1), (7, 6, 32), (120, 6, 64), (121, 5, 3)] {
            let a = DMatrix::from_fn(rows, m, |_, _| next());
            let b = DMatrix::from_fn(rows, n, |_, _| next());
            // NaN at the start: every entry must be written (zeros with no rows too).
            let mut ours = DMatrix::from_element(m, n, f64::NAN);
            let mut theirs = DMatrix::zeros(m, n);
            tr_mul_to(&a, &b, &mut ours);
            a.tr_mul_to(&b, &mut theirs);
            assert!(
                ours.iter()
                    .zip(theirs.iter())
                    .all(|(p, q)| p.to_bits() == q.to_bits()),
                "{rows} x {m}, {n}"
            );
        }
    }
}
