//! e^x as straight-line arithmetic, for loops the compiler vectorises: the logistic
//! activation over a batch ([`super::logistic::logistic_in_place`]) and the RBF network's
//! unit responses over a kernel matrix's column or a prediction's units
//! ([`super::rbf::Covariance::responses_in_place`]).
//!
//! Why ours: the C library's `exp` is an opaque call per value; it was a sixth of the default
//! `train`'s instructions on 150 poses (the activation) and, before the RBF network's
//! responses used this one, 12 % of the samples of the default `train` on 2000 Series A poses
//! (the kernel matrices and the held-out predictions of cross-validation). A loop over this
//! one runs two values at once (SSE2, the default target): 3.6 ns per value against 5.1 ns
//! for the library's, four where the processor has AVX2 and eight where it has AVX-512 (the
//! callers dispatch through [`super::wide`]; the same operations, so the same bits). One
//! value at a time the library's table-driven `exp` is faster (16 against 22 ns on a
//! dependent chain), so the MLP's prediction keeps it; the RBF network's one-value response
//! ([`super::rbf::Covariance::response`], in its input Jacobian) takes this one, so that the
//! Jacobian's outputs are prediction's bit for bit.
//!
//! Method (Cody and Waite, as fdlibm's `exp`): x = k ln2 + r with k = round(x / ln2) and
//! |r| <= ln2 / 2, ln2 split in a high part with trailing zeros (k ln2_hi is exact) and a low
//! part; e^r by its Taylor polynomial to r^13 (truncation below 6e-18 relative; the terms
//! beyond r by Estrin's scheme), e^x = 2^k e^r with 2^k built from its bits. Accuracy: within
//! 2 units in the last place of the C library's `exp` (a test checks 2^20 arguments), itself
//! within about half a unit of the exact value. The argument is clamped to [-700, 700], so
//! 2^k stays a normal number: below e^-700 (about 1e-304) the result is e^-700, above e^700
//! it is e^700; NaN gives NaN.

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
pub fn exp_clamped(x: f64) -> f64 {
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
}
