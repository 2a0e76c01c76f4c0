//! The batch's matrix products (samples x units: long and thin) with the bits of what nalgebra
//! calls for them: `matrixmultiply`'s `dgemm` where every dimension exceeds
//! [`NALGEBRA_SMALL`] (nalgebra's own loops below, which the batch runs itself).
//!
//! `dgemm`'s AVX2 kernel (chosen where the processor has FMA and AVX2 but not AVX-512)
//! computes each entry as one chain of fused multiply-adds over the inner index in order from
//! +0, restarted every 256 indices (`KC`), each chain added to the entry (`C = ab + 0` for the
//! first, `C = ab + C` after). [`abt`] computes the same chains on operands laid out so that
//! both are read in place, C = A B^T with A and B column-major and the chains running over
//! their columns (the batch keeps a transposed copy of the samples and of the hidden
//! activations for the products over the samples), where `dgemm` first copies both into
//! packed panels. Its tiles are 8 x 6 entries, twelve chains in flight, where `dgemm`'s AVX2
//! tiles of 8 x 4 keep eight. A symmetric A A^T computes its lower triangle and mirrors it: a
//! fused multiply-add does not depend on the order of its two factors. On Case D's 150
//! samples and a 30-32-6 network, one projected objective with its gradient took 90 / 102 /
//! 93 us on `dgemm` and 78 / 74 / 68 us here (criterion, alternated the same hour; the
//! packing was a quarter of `dgemm`'s time, 8 x 4 tiles here 8 % slower than 8 x 6).
//!
//! Where the processor has AVX-512, `dgemm` runs its AVX-512 kernel: the same chains, the
//! first block stored as `ab` rather than `ab + 0`, which differ only for a chain whose
//! products all underflow to -0 (-0 there, +0 here). Where pulp's V3 (x86-64-v3: AVX2, FMA
//! and the rest) is not there, `dgemm` does not run a fused kernel: the batch runs nalgebra's
//! products ([`fast`] says which).
//!
//! Where the processor has AVX-512, [`abt`] runs the same chains eight entries to a register
//! (`avx512`: tiles of 16 x 6, the rows past the last masked), so the same bits. With it
//! (and the loops of [`super::wide`]) criterion's default `train` on Case D's 150 poses took
//! 423 and 449 ms in two runs against 455 ms before, run between them; the CLI there
//! 0.73-0.78 s of processor time against 0.83-0.98 s (eight runs each, two rounds; the same
//! files written).

use nalgebra::DMatrix;

/// Dimensions up to which nalgebra's `gemm` runs its own loops instead of `matrixmultiply`'s
/// `dgemm` (nalgebra 0.34's `SMALL_DIM`).
pub const NALGEBRA_SMALL: usize = 5;

/// `matrixmultiply`'s `D_KC`: the inner indices one chain of its kernel runs over (a build of
/// `matrixmultiply` with `MATMUL_DGEMM_KC` set to another value would give other bits; the
/// tests would say so).
const KC: usize = 256;

/// The instruction sets the kernels run on (none off x86-64): AVX2 with FMA, and AVX-512 F
/// where the processor has it too (the wider kernel then, the same bits).
#[cfg(target_arch = "x86_64")]
#[derive(Clone, Copy, Debug)]
pub struct Isa {
    v3: pulp::x86::V3,
    avx512: bool,
}
/// The instruction set the kernel runs on (none off x86-64).
#[cfg(not(target_arch = "x86_64"))]
#[derive(Clone, Copy, Debug)]
pub enum Isa {}

/// AVX2 with FMA, where products whose dimensions all exceed [`NALGEBRA_SMALL`] (every one of
/// `dims`) run through `dgemm`'s fused kernel: [`abt`] then gives their bits. None where the
/// caller must run nalgebra's products.
pub fn fast(dims: &[usize]) -> Option<Isa> {
    if dims.iter().any(|&d| d <= NALGEBRA_SMALL) {
        return None;
    }
    #[cfg(target_arch = "x86_64")]
    return pulp::x86::V3::try_new().map(|v3| Isa {
        v3,
        avx512: super::wide::avx512(),
    });
    #[cfg(not(target_arch = "x86_64"))]
    None
}

/// `C = A B^T` (A: m x k, B: n x k, both column-major) into `out`, entry (r, c) at
/// `out[c ldo + r]` (a column-major matrix with `ldo` rows, or its top-left block): each
/// entry the chain sum_p A(r, p) B(c, p) of `dgemm`'s fused kernel, so the bits of nalgebra's
/// product of A by a transposed copy of B (and of B A^T transposed). With `symmetric` (B is A,
/// the same matrix) the lower triangle is computed and mirrored. Without chains (k = 0) C is
/// zero.
pub fn abt(
    simd: Isa,
    a: &DMatrix<f64>,
    b: &DMatrix<f64>,
    symmetric: bool,
    out: &mut [f64],
    ldo: usize,
) {
    let (m, k) = a.shape();
    let n = b.nrows();
    assert!(
        b.ncols() == k && (!symmetric || std::ptr::eq(a, b)),
        "abt: shapes {:?} {:?}^T",
        a.shape(),
        b.shape(),
    );
    assert!(
        m == 0 || n == 0 || (ldo >= m && (n - 1) * ldo + m <= out.len()),
        "abt: {m} x {n} entries with {ldo} rows beyond {} values",
        out.len()
    );
    if m == 0 || n == 0 {
        return;
    }
    if k == 0 {
        for column in out.chunks_mut(ldo).take(n) {
            column[..m].fill(0.0);
        }
        return;
    }
    #[cfg(target_arch = "x86_64")]
    {
        let (a, b) = (a.as_slice(), b.as_slice());
        if simd.avx512 {
            // SAFETY: the processor has AVX-512 F (`fast` checked it); the slices hold A, B
            // and C's entries (asserted above).
            unsafe { avx512::abt(a, b, m, n, k, out, ldo, symmetric) };
        } else {
            let simd = simd.v3;
            simd.vectorize(Abt {
                simd,
                a,
                b,
                m,
                n,
                k,
                out,
                ldo,
                symmetric,
            });
        }
        if symmetric {
            mirror(out, n, ldo);
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        let _ = (out, ldo, symmetric);
        match simd {}
    }
}

#[cfg(target_arch = "x86_64")]
mod avx512;

#[cfg(target_arch = "x86_64")]
use super::vectors::{load4, store4};
#[cfg(target_arch = "x86_64")]
use pulp::{Simd as _, f64x4};

/// The first four values of `c`, or those there are with zeros after them.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn load_part(c: &[f64]) -> f64x4 {
    let at = |i: usize| c.get(i).copied().unwrap_or(0.0);
    f64x4(at(0), at(1), at(2), at(3))
}

/// `v` into the first four values of `c`, or as many as there are.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn store_part(c: &mut [f64], v: f64x4) {
    let v = [v.0, v.1, v.2, v.3];
    let n = c.len().min(4);
    c[..n].copy_from_slice(&v[..n]);
}

/// The columns of C one tile computes: 2 x 6 accumulators in AVX2 (or AVX-512) registers,
/// twelve registers of chains in flight (with four columns, eight, the projected objective
/// took 8 % longer on AVX2: each chain waits on its last multiply-add). The dispatch in
/// [`Abt`] (and in `avx512`) instantiates tiles of 1 to 6 columns.
#[cfg(target_arch = "x86_64")]
const COLUMNS: usize = 6;

/// [`abt`] as the operation `vectorize` compiles with AVX2 (a closure there is compiled
/// apart from the AVX2 code: see [`super::vectors`]).
#[cfg(target_arch = "x86_64")]
struct Abt<'s> {
    simd: pulp::x86::V3,
    a: &'s [f64],
    b: &'s [f64],
    m: usize,
    n: usize,
    k: usize,
    out: &'s mut [f64],
    ldo: usize,
    symmetric: bool,
}

#[cfg(target_arch = "x86_64")]
impl pulp::NullaryFnOnce for Abt<'_> {
    type Output = ();

    #[inline(always)]
    fn call(self) {
        let Abt {
            simd,
            a,
            b,
            m,
            n,
            k,
            out,
            ldo,
            symmetric,
        } = self;
        tiles(
            a,
            b,
            [m, n, k, ldo],
            symmetric,
            #[inline(always)]
            |left| if left >= 8 { 8 } else { left.min(4) },
            #[inline(always)]
            |t, r, width, c, columns| match (width, columns) {
                (8, 6) => t.tile::<2, 6>(simd, r, width, c, out),
                (8, 5) => t.tile::<2, 5>(simd, r, width, c, out),
                (8, 4) => t.tile::<2, 4>(simd, r, width, c, out),
                (8, 3) => t.tile::<2, 3>(simd, r, width, c, out),
                (8, 2) => t.tile::<2, 2>(simd, r, width, c, out),
                (8, _) => t.tile::<2, 1>(simd, r, width, c, out),
                (_, 6) => t.tile::<1, 6>(simd, r, width, c, out),
                (_, 5) => t.tile::<1, 5>(simd, r, width, c, out),
                (_, 4) => t.tile::<1, 4>(simd, r, width, c, out),
                (_, 3) => t.tile::<1, 3>(simd, r, width, c, out),
                (_, 2) => t.tile::<1, 2>(simd, r, width, c, out),
                _ => t.tile::<1, 1>(simd, r, width, c, out),
            },
        );
    }
}

/// Every tile of C = A B^T (A: m x k, B: n x k, C with `ldo` rows: `dims` [m, n, k, ldo]),
/// for both kernels: over the chains' blocks of [`KC`] indices, the rows in tiles of
/// `width(rows left)`, the columns in tiles of up to [`COLUMNS`] (a symmetric product's up to
/// the tile's last row: its lower triangle and some entries above it on the diagonal),
/// `tile(block, r, width, c, columns)` for each.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn tiles<'s>(
    a: &'s [f64],
    b: &'s [f64],
    [m, n, k, ldo]: [usize; 4],
    symmetric: bool,
    width: impl Fn(usize) -> usize,
    mut tile: impl FnMut(&Block<'s>, usize, usize, usize, usize),
) {
    for p0 in (0..k).step_by(KC) {
        let t = Block {
            a,
            b,
            m,
            n,
            p: p0..(p0 + KC).min(k),
            first: p0 == 0,
            ldo,
        };
        let mut r = 0;
        while r < m {
            let width = width(m - r);
            let end = if symmetric { (r + width).min(n) } else { n };
            for c in (0..end).step_by(COLUMNS) {
                tile(&t, r, width, c, (end - c).min(COLUMNS));
            }
            r += width;
        }
    }
}

/// A symmetric n x n product's upper triangle from its lower one (entry (r, c) at
/// `out[c ldo + r]`).
#[cfg(target_arch = "x86_64")]
fn mirror(out: &mut [f64], n: usize, ldo: usize) {
    for c in 0..n {
        for r in 0..c {
            out[c * ldo + r] = out[r * ldo + c];
        }
    }
}

/// [`abt`]'s product over one block of [`KC`] of the chains' indices (or fewer, the last).
#[cfg(target_arch = "x86_64")]
struct Block<'s> {
    a: &'s [f64],
    b: &'s [f64],
    m: usize,
    n: usize,
    p: std::ops::Range<usize>,
    first: bool,
    ldo: usize,
}

#[cfg(target_arch = "x86_64")]
impl Block<'_> {
    /// Entries r..r + `width` (4 RV, or fewer than 4 with RV 1) by c..c + NC: one chain of
    /// fused multiply-adds per entry over the block's indices.
    #[inline(always)]
    fn tile<const RV: usize, const NC: usize>(
        &self,
        simd: pulp::x86::V3,
        r: usize,
        width: usize,
        c: usize,
        out: &mut [f64],
    ) {
        let zero = simd.splat_f64s(0.0);
        // The chains of column c + cc, rows r + 4 v.. r + 4 v + 3, in acc[cc][v].
        let mut acc = [[zero; RV]; NC];
        let mut av = [zero; RV];
        let full = width == 4 * RV;
        let (m, n) = (self.m, self.n);
        let Some(last) = self.p.clone().last() else {
            return;
        };
        // Every row the chains read, p in the block: A's column p from row r (`width`
        // values), B's from row c (NC values).
        assert!(
            last * m + r + width <= self.a.len() && last * n + c + NC <= self.b.len(),
            "abt: a tile beyond its operands"
        );
        if full {
            let mut ap = self.a[self.p.start * m + r..].as_ptr();
            let mut bp = self.b[self.p.start * n + c..].as_ptr();
            for _ in self.p.clone() {
                for (v, x) in av.iter_mut().enumerate() {
                    // SAFETY: ap is A's column p from row r, whose 4 RV values lie within A
                    // (asserted for every p of the block).
                    let q = unsafe { ap.add(4 * v).cast::<[f64; 4]>().read_unaligned() };
                    *x = load4(&q);
                }
                for (cc, chains) in acc.iter_mut().enumerate() {
                    // SAFETY: bp is B's column p from row c, whose NC values lie within B.
                    let y = simd.splat_f64s(unsafe { *bp.add(cc) });
                    for (chain, &x) in chains.iter_mut().zip(&av) {
                        *chain = simd.mul_add_f64s(x, y, *chain);
                    }
                }
                // Past the last column the pointers are not read (wrapping: no claim on
                // where they point).
                ap = ap.wrapping_add(m);
                bp = bp.wrapping_add(n);
            }
        } else {
            for p in self.p.clone() {
                let (ac, bc) = (&self.a[p * m + r..][..width], &self.b[p * n + c..][..NC]);
                av[0] = load_part(ac);
                for (chains, &y) in acc.iter_mut().zip(bc) {
                    chains[0] = simd.mul_add_f64s(av[0], simd.splat_f64s(y), chains[0]);
                }
            }
        }
        for (cc, chains) in acc.iter().enumerate() {
            let column = &mut out[(c + cc) * self.ldo + r..][..width];
            for (v, &chain) in chains.iter().enumerate() {
                let dst = &mut column[4 * v..(4 * v + 4).min(width)];
                if full {
                    let sum = if self.first { zero } else { load4(dst) };
                    store4(dst, simd.add_f64s(chain, sum));
                } else {
                    let sum = if self.first { zero } else { load_part(dst) };
                    store_part(dst, simd.add_f64s(chain, sum));
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Values of spread magnitudes and both signs (sums of them depend on the order of the
    /// additions, and fused multiply-adds round otherwise than a product and a sum).
    fn spread(r: usize, c: usize, seed: usize) -> DMatrix<f64> {
        DMatrix::from_fn(r, c, |i, j| {
            ((i * 31 + j * 17 + seed * 7) as f64 * 0.713).sin()
                * 10f64.powi(((i * 7 + j + seed) % 13) as i32 - 6)
        })
    }

    /// The AVX2 kernel on any processor that has it.
    #[cfg(target_arch = "x86_64")]
    fn avx2_only(simd: Isa) -> Isa {
        Isa {
            avx512: false,
            ..simd
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    fn avx2_only(simd: Isa) -> Isa {
        match simd {}
    }

    /// Whether `simd` runs the AVX-512 kernel.
    #[cfg(target_arch = "x86_64")]
    fn has_avx512(simd: Isa) -> bool {
        simd.avx512
    }
    #[cfg(not(target_arch = "x86_64"))]
    fn has_avx512(simd: Isa) -> bool {
        match simd {}
    }

    fn bits(x: &DMatrix<f64>) -> Vec<u64> {
        x.iter().map(|v| v.to_bits()).collect()
    }

    /// Both kernels (AVX2, and AVX-512 where the processor has it) against nalgebra's product
    /// of A by a transposed copy of B, bit for bit, into the top-left block of a larger
    /// matrix: tiles of 16, 8, 4 and fewer rows and of 1 to 6 columns, chains longer than
    /// `dgemm`'s blocks of 256, and symmetric products.
    #[test]
    fn the_kernels_give_nalgebras_bits() {
        let shapes = [
            (32, 120, 32),
            (24, 121, 32),
            (121, 32, 6),
            (13, 7, 9),
            (33, 300, 11),
            (9, 520, 6),
            (6, 6, 7),
            (7, 300, 10),
            (12, 260, 6),
            (17, 40, 13),
            (150, 9, 32),
            // AVX-512 tiles of 16 rows and 2, 5, 10, 11, 14 and 15; chains of exactly one and
            // two blocks of 256.
            (18, 256, 7),
            (21, 512, 9),
            (11, 40, 6),
            (14, 30, 8),
            (15, 257, 12),
            (10, 255, 6),
        ];
        let mut checked = 0;
        if !super::super::wide::avx512() {
            eprintln!("the AVX-512 kernel is not tested: this processor lacks AVX-512 F");
        }
        for wide in [false, true] {
            for (m, k, n) in shapes {
                let Some(simd) = fast(&[m, k, n]) else {
                    continue;
                };
                let simd = match (wide, has_avx512(simd)) {
                    (false, _) => avx2_only(simd),
                    (true, true) => simd,
                    (true, false) => continue,
                };
                checked += 1;
                let case = format!("{m} x {k} x {n}, AVX-512 {wide}");
                let (a, b) = (spread(m, k, 1), spread(n, k, 2));
                let mut want = DMatrix::from_element(m, n, f64::NAN);
                a.mul_to(&b.transpose(), &mut want);
                let mut big = DMatrix::from_element(m + 2, n + 1, 5.0);
                abt(simd, &a, &b, false, big.as_mut_slice(), m + 2);
                let got = big.view((0, 0), (m, n)).into_owned();
                assert_eq!(bits(&got), bits(&want), "{case}");
                // Nothing outside the block written.
                assert_eq!(
                    big.iter().filter(|&&v| v == 5.0).count(),
                    2 * (n + 1) + m,
                    "{case}"
                );
                // A A^T from its lower triangle, into the top-left block of a larger matrix.
                let mut want = DMatrix::from_element(m, m, f64::NAN);
                a.mul_to(&a.transpose(), &mut want);
                let mut big = DMatrix::from_element(m + 3, m, 5.0);
                abt(simd, &a, &a, true, big.as_mut_slice(), m + 3);
                let got = big.view((0, 0), (m, m)).into_owned();
                assert_eq!(bits(&got), bits(&want), "symmetric, {case}");
                assert_eq!(
                    big.iter().filter(|&&v| v == 5.0).count(),
                    3 * m,
                    "symmetric, {case}"
                );
                // Without chains, zero.
                let empty = DMatrix::<f64>::zeros(m, 0);
                let mut zero = DMatrix::from_element(m, m, f64::NAN);
                abt(simd, &empty, &empty, true, zero.as_mut_slice(), m);
                assert!(zero.iter().all(|&v| v == 0.0), "{case}");
            }
        }
        #[cfg(target_arch = "x86_64")]
        if pulp::x86::V3::try_new().is_some() {
            let kernels = if super::super::wide::avx512() { 2 } else { 1 };
            assert_eq!(checked, kernels * shapes.len());
        }
        // Where a dimension is nalgebra's small one, the batch runs nalgebra's loops.
        assert!(fast(&[5, 100, 100]).is_none() && fast(&[100, 100, 5]).is_none());
        // Where the kernel runs, a sum of the same products rounded one by one differs from
        // nalgebra's somewhere: the comparisons above can tell a multiply-add that is not
        // fused.
        let (a, b) = (spread(40, 30, 5), spread(8, 30, 6));
        if fast(&[40, 30, 8]).is_some() {
            let product = &a * b.transpose();
            let unfused = DMatrix::from_fn(40, 8, |r, c| {
                (0..30).fold(0.0, |t, p| t + a[(r, p)] * b[(c, p)])
            });
            assert_ne!(bits(&unfused), bits(&product));
        }
    }
}
