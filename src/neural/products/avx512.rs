//! [`super::abt`]'s kernel in AVX-512 registers (eight values each) where the processor has
//! them: the same chains, one per entry, so the same bits as the AVX2 kernel and as
//! nalgebra's product. Tiles of up to 16 rows (two registers) by [`super::COLUMNS`] columns,
//! twelve registers of chains in flight as in the AVX2 kernel, walked as the AVX2 kernel's
//! ([`super::tiles`]); the rows of a tile past the matrix's last are masked out of every load
//! and store, so one kernel serves every remainder.

use super::Block;
use core::arch::x86_64::{
    __m512d, __mmask8, _mm512_add_pd, _mm512_fmadd_pd, _mm512_mask_storeu_pd,
    _mm512_maskz_loadu_pd, _mm512_set1_pd, _mm512_setzero_pd,
};

/// C = A B^T into `out` as [`super::abt`] (A: m x k, B: n x k, column-major; without the
/// mirror of a symmetric product's upper triangle, which the caller does), for k > 0.
///
/// # Safety
/// The processor must have AVX-512 F; the slices must hold A and B and the entries of C
/// (`super::abt` asserts it).
#[target_feature(enable = "avx512f,avx2,fma")]
#[allow(clippy::too_many_arguments)]
pub(super) unsafe fn abt(
    a: &[f64],
    b: &[f64],
    m: usize,
    n: usize,
    k: usize,
    out: &mut [f64],
    ldo: usize,
    symmetric: bool,
) {
    super::tiles(
        a,
        b,
        [m, n, k, ldo],
        symmetric,
        #[inline(always)]
        |left| left.min(16),
        #[inline(always)]
        |t, r, width, c, columns| {
            // SAFETY: AVX-512 F (this function's contract); the tile's reads and writes are
            // asserted within the slices in `tile16`.
            unsafe {
                match (width > 8, columns) {
                    (true, 6) => t.tile16::<2, 6>(r, width, c, out),
                    (true, 5) => t.tile16::<2, 5>(r, width, c, out),
                    (true, 4) => t.tile16::<2, 4>(r, width, c, out),
                    (true, 3) => t.tile16::<2, 3>(r, width, c, out),
                    (true, 2) => t.tile16::<2, 2>(r, width, c, out),
                    (true, _) => t.tile16::<2, 1>(r, width, c, out),
                    (false, 6) => t.tile16::<1, 6>(r, width, c, out),
                    (false, 5) => t.tile16::<1, 5>(r, width, c, out),
                    (false, 4) => t.tile16::<1, 4>(r, width, c, out),
                    (false, 3) => t.tile16::<1, 3>(r, width, c, out),
                    (false, 2) => t.tile16::<1, 2>(r, width, c, out),
                    (false, _) => t.tile16::<1, 1>(r, width, c, out),
                }
            }
        },
    );
}

/// The lanes of the rows v 8..v 8 + 7 of a tile of `width` rows that lie in it.
#[inline(always)]
fn mask(width: usize, v: usize) -> __mmask8 {
    let rows = width.saturating_sub(8 * v).min(8);
    ((1u16 << rows) - 1) as __mmask8
}

impl Block<'_> {
    /// Entries r..r + `width` (8 (RV - 1) < width <= 8 RV) by c..c + NC: one chain of fused
    /// multiply-adds per entry over the block's indices, added to the entry after the first
    /// block.
    ///
    /// # Safety
    /// The processor must have AVX-512 F.
    #[target_feature(enable = "avx512f,avx2,fma")]
    #[inline]
    unsafe fn tile16<const RV: usize, const NC: usize>(
        &self,
        r: usize,
        width: usize,
        c: usize,
        out: &mut [f64],
    ) {
        let (m, n) = (self.m, self.n);
        let Some(last) = self.p.clone().last() else {
            return;
        };
        assert!(
            width > 8 * (RV - 1) && width <= 8 * RV,
            "abt: {width} rows in a tile of {RV} registers"
        );
        assert!(
            last * m + r + width <= self.a.len() && last * n + c + NC <= self.b.len(),
            "abt: a tile beyond its operands"
        );
        assert!(
            (c + NC - 1) * self.ldo + r + width <= out.len(),
            "abt: a tile beyond its product"
        );
        let masks: [__mmask8; RV] = std::array::from_fn(|v| mask(width, v));
        let zero = _mm512_setzero_pd();
        // The chains of column c + cc, rows r + 8 v.. r + 8 v + 7, in acc[cc][v].
        let mut acc: [[__m512d; RV]; NC] = [[zero; RV]; NC];
        let mut av: [__m512d; RV] = [zero; RV];
        for p in self.p.clone() {
            let (ap, bp) = (
                self.a.as_ptr().wrapping_add(p * m + r),
                &self.b[p * n + c..],
            );
            for (v, x) in av.iter_mut().enumerate() {
                // SAFETY: the lanes the mask keeps are A's rows r + 8 v.. of column p, within
                // A (asserted for every p of the block); the others are not read.
                *x = unsafe { _mm512_maskz_loadu_pd(masks[v], ap.wrapping_add(8 * v)) };
            }
            for (chains, &y) in acc.iter_mut().zip(&bp[..NC]) {
                let y = _mm512_set1_pd(y);
                for (chain, &x) in chains.iter_mut().zip(&av) {
                    *chain = _mm512_fmadd_pd(x, y, *chain);
                }
            }
        }
        for (cc, chains) in acc.iter().enumerate() {
            let column = out.as_mut_ptr().wrapping_add((c + cc) * self.ldo + r);
            for (v, &chain) in chains.iter().enumerate() {
                let dst = column.wrapping_add(8 * v);
                // SAFETY: the lanes the mask keeps are entries of C within `out` (asserted);
                // the others are neither read nor written.
                unsafe {
                    let sum = if self.first {
                        zero
                    } else {
                        _mm512_maskz_loadu_pd(masks[v], dst)
                    };
                    _mm512_mask_storeu_pd(dst, masks[v], _mm512_add_pd(chain, sum));
                }
            }
        }
    }
}
