//! The hidden units' activation, the logistic sigmoid s(z) = 1 / (1 + e^-z) (thesis 3.2):
//! one value at a time on the C library's `exp`, over a batch on an exponential of our own
//! that the compiler vectorises.
//!
//! Why ours: training evaluates the activation for every sample, hidden unit and objective
//! evaluation (tens of millions of values for 150 poses), and the C library's `exp` is an
//! opaque call per value, a sixth of the default `train`'s instructions. This one is
//! straight-line arithmetic, so a loop over a slice runs two values at once (SSE2, the
//! default target): 3.6 ns per value against 5.1 ns for the library's on this machine, and
//! four where the processor has AVX2 (`pulp` picks at run time; the same operations). One
//! value at a time the library's table-driven `exp` is faster (16 against 22 ns on a
//! dependent chain), so prediction, which takes one configuration at a time, keeps it
//! ([`logistic`], in [`super::weights::Weights::forward_into`]); the two agree to about
//! 1e-16.
//!
//! Method (Cody and Waite, as fdlibm's `exp`): x = k ln2 + r with k = round(x / ln2) and
//! |r| <= ln2 / 2, ln2 split in a high part with trailing zeros (k ln2_hi is exact) and a low
//! part; e^r by its Taylor polynomial to r^13 (truncation below 6e-18 relative; the terms
//! beyond r by Estrin's scheme), e^x = 2^k e^r with 2^k built from its bits. Accuracy: within
//! 2 units in the last place of the C library's `exp` (a test checks 2^20 arguments), itself
//! within about half a unit of the exact value. The argument is clamped to [-700, 700], so
//! 2^k stays a normal number: s(z) differs from the exact value only where that is below
//! 1e-304 (s returns about 1e-304) or within 1e-304 of one, far below anything a network
//! computes with.

/// ln 2, high part (fdlibm's ln2_hi, by its bits): its trailing 21 bits are zero, so k ln2_hi is exact for |k|
/// below 2^20.
const LN2_HI: f64 = f64::from_bits(0x3fe6_2e42_fee0_0000);
/// ln 2 - LN2_HI (fdlibm's ln2_lo).
const LN2_LO: f64 = f64::from_bits(0x3dea_39ef_3579_3c76);
const INV_LN2: f64 = std::f64::consts::LOG2_E;
/// 1.5 2^52: adding it rounds a float of magnitude below 2^51 to an integer, which then sits
/// in the low bits of the sum.
const ROUND: f64 = 6_755_399_441_055_744.0;
/// 1 / n! for n = 2..=13: the Taylor coefficients beyond r.
const INV_FACT: [f64; 12] = [
    1.0 / 2.0,
    1.0 / 6.0,
    1.0 / 24.0,
    1.0 / 120.0,
    1.0 / 720.0,
    1.0 / 5_040.0,
    1.0 / 40_320.0,
    1.0 / 362_880.0,
    1.0 / 3_628_800.0,
    1.0 / 39_916_800.0,
    1.0 / 479_001_600.0,
    1.0 / 6_227_020_800.0,
];

/// e^x for x clamped to [-700, 700] (see the module doc); NaN gives NaN.
#[inline(always)]
fn exp_clamped(x: f64) -> f64 {
    let x = x.clamp(-700.0, 700.0);
    let shifted = x * INV_LN2 + ROUND;
    let k = shifted - ROUND;
    let r = (x - k * LN2_HI) - k * LN2_LO;
    // e^r = 1 + (r + r^2 q(r)), q(r) = sum r^n / (n + 2)! to n = 11 by Estrin's scheme:
    // a chain of 5 multiply-adds instead of Horner's 11, so that consecutive values overlap
    // in the processor instead of each waiting on its own long chain.
    let c = &INV_FACT;
    let r2 = r * r;
    let r4 = r2 * r2;
    let r8 = r4 * r4;
    let b0 = (c[0] + r * c[1]) + r2 * (c[2] + r * c[3]);
    let b1 = (c[4] + r * c[5]) + r2 * (c[6] + r * c[7]);
    let b2 = (c[8] + r * c[9]) + r2 * (c[10] + r * c[11]);
    let q = (b0 + r4 * b1) + r8 * b2;
    let er = 1.0 + (r + r2 * q);
    // The low 12 bits of `shifted`'s bits plus 1023 are k + 1023: 2^k's exponent field
    // (k + 1023 lies in 13..=2033 after the clamp).
    let scale = f64::from_bits(shifted.to_bits().wrapping_add(1023) << 52);
    er * scale
}

/// The logistic sigmoid 1 / (1 + e^-z), in (0, 1), one value at a time: with the C
/// library's `exp`, the faster one there (prediction).
pub fn logistic(z: f64) -> f64 {
    1.0 / (1.0 + (-z).exp())
}

/// [`logistic`] on our exponential, for loops the compiler vectorises.
#[inline(always)]
fn logistic_vectorised(z: f64) -> f64 {
    1.0 / (1.0 + exp_clamped(-z))
}

/// `values[i] <- logistic(values[i] + bias)` for every i: one hidden unit over a batch (a loop
/// the compiler vectorises, on our exponential, as wide as the processor allows: `pulp`
/// compiles it for AVX2 too and picks at run time; the same operations in the same order,
/// so the same bits as the baseline build's two values at a time).
pub fn logistic_in_place(values: &mut [f64], bias: f64) {
    pulp::Arch::new().dispatch(
        #[inline(always)]
        || {
            for v in values.iter_mut() {
                *v = logistic_vectorised(*v + bias);
            }
        },
    );
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Distance in units in the last place between two finite positive floats.
    fn ulps(a: f64, b: f64) -> u64 {
        a.to_bits().abs_diff(b.to_bits())
    }

    #[test]
    fn exp_is_within_two_ulps_of_the_c_library() {
        // 2^20 arguments spread over the whole clamped range, and a dense run where the
        // network's pre-activations live.
        let n = 1 << 19;
        let mut worst = (0, 0.0);
        for i in 0..n {
            for x in [
                -700.0 + 1400.0 * (i as f64 + 0.37) / n as f64,
                -40.0 + 80.0 * (i as f64 + 0.61) / n as f64,
            ] {
                let d = ulps(exp_clamped(x), x.exp());
                if d > worst.0 {
                    worst = (d, x);
                }
            }
        }
        assert!(worst.0 <= 2, "{} ulps at {}", worst.0, worst.1);
        // Exact where the reduction is exact.
        assert_eq!(exp_clamped(0.0), 1.0);
        assert!(ulps(exp_clamped(1.0), std::f64::consts::E) <= 1);
    }

    #[test]
    fn logistic_limits_symmetry_and_nan() {
        assert_eq!(logistic_vectorised(0.0), 0.5);
        assert_eq!(logistic_vectorised(800.0), 1.0);
        assert_eq!(logistic_vectorised(f64::INFINITY), 1.0);
        assert!(logistic_vectorised(-800.0) > 0.0 && logistic_vectorised(-800.0) < 1e-300);
        assert!(logistic_vectorised(f64::NEG_INFINITY) < 1e-300);
        assert!(logistic_vectorised(f64::NAN).is_nan());
        // s(z) + s(-z) = 1 and the value of the definition with the C library's exp.
        for i in 0..2000 {
            let z = -30.0 + 0.03 * i as f64;
            let s = logistic_vectorised(z);
            assert!((s + logistic_vectorised(-z) - 1.0).abs() < 4e-16, "{z}");
            let reference = logistic(z);
            assert!(
                (s - reference).abs() <= 4e-16 * reference,
                "{z}: {s} {reference}"
            );
        }
        // Over a batch (long enough for the vector loop's body, with a remainder), the bits
        // of one value at a time.
        let z: Vec<f64> = (0..53).map(|i| -40.0 + 1.537 * i as f64).collect();
        let mut v = z.clone();
        logistic_in_place(&mut v, 0.5);
        for (got, z) in v.iter().zip(&z) {
            assert_eq!(got.to_bits(), logistic_vectorised(z + 0.5).to_bits(), "{z}");
        }
    }
}
