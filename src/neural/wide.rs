//! Loops compiled for AVX-512 where the processor has it (eight values per register), else
//! for AVX2 through `pulp`'s dispatch (four), else the baseline build's (two).
//!
//! Why not `pulp`'s own AVX-512 level: it is behind a `pulp` feature, and features are shared
//! with `faer`, whose own dispatch (the RBF network's factorisations) would then see that
//! level too and could take other kernels, so other bits. Here only our loops widen.
//!
//! Bits: the compiler never reorders floating-point operations (no fast-math in Rust) and
//! never fuses a product and a sum unless the source says `mul_add`, so a loop's values are
//! those of its scalar source at every width. The loops whose lanes are explicit keep their
//! AVX2 registers: [`super::vectors`]' dot products in nalgebra's order (eight partial sums,
//! a chain of additions no wider register shortens) and its element-wise blocks of four, and
//! [`super::fused`]'s passes that end in such a dot product; [`super::products`] has an
//! AVX-512 kernel of its own.

/// Whether the processor (and the operating system) has AVX-512 F with AVX2 and FMA: checked
/// once by the standard library, which caches it.
#[inline]
pub fn avx512() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::arch::is_x86_feature_detected!("avx512f")
            && std::arch::is_x86_feature_detected!("avx2")
            && std::arch::is_x86_feature_detected!("fma")
    }
    #[cfg(not(target_arch = "x86_64"))]
    false
}

/// Runs `f` compiled for AVX-512 where the processor has it ([`avx512`]), else through
/// `pulp`'s dispatch (AVX2 where there, else the baseline). `f` must be marked
/// `#[inline(always)]`: a closure that is not is compiled apart, for the baseline.
#[inline(always)]
pub fn dispatch<R>(f: impl FnOnce() -> R) -> R {
    #[cfg(target_arch = "x86_64")]
    if avx512() {
        // SAFETY: the processor has every feature the function is compiled for (checked).
        return unsafe { with_avx512(f) };
    }
    pulp::Arch::new().dispatch(f)
}

/// `f()` compiled with AVX-512 F (and what it implies: AVX2, FMA).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx2,fma")]
unsafe fn with_avx512<R>(f: impl FnOnce() -> R) -> R {
    f()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::neural::exponential::exp_clamped;

    /// The logistic activation over a batch (division, the exponential's integer bit
    /// tricks, a clamp) through AVX-512, through `pulp`'s dispatch and one value at a time
    /// without either: the same bits.
    #[test]
    fn every_width_gives_the_scalar_bits() {
        let z: Vec<f64> = (0..203).map(|i| -750.0 + 7.41 * i as f64).collect();
        #[inline(always)]
        fn activate(v: &mut [f64]) {
            for x in v.iter_mut() {
                *x = 1.0 / (1.0 + exp_clamped(-*x)) + 0.25 * *x;
            }
        }
        let mut scalar = z.clone();
        for x in scalar.iter_mut() {
            *x = std::hint::black_box(1.0 / (1.0 + exp_clamped(-*x)) + 0.25 * *x);
        }
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        let mut pulp_run = z.clone();
        pulp::Arch::new().dispatch(
            #[inline(always)]
            || activate(&mut pulp_run),
        );
        assert_eq!(bits(&pulp_run), bits(&scalar));
        let mut ours = z.clone();
        dispatch(
            #[inline(always)]
            || activate(&mut ours),
        );
        assert_eq!(bits(&ours), bits(&scalar));
        #[cfg(target_arch = "x86_64")]
        if avx512() {
            let mut wide = z.clone();
            // SAFETY: the processor has the features (checked).
            unsafe {
                with_avx512(
                    #[inline(always)]
                    || activate(&mut wide),
                )
            };
            assert_eq!(bits(&wide), bits(&scalar));
        }
    }
}
