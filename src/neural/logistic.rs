//! The hidden units' activation, the logistic sigmoid s(z) = 1 / (1 + e^-z) (thesis 3.2):
//! one value at a time on the C library's `exp` (prediction, [`logistic`] in
//! [`super::weights::Weights::forward_into`]: one value at a time the library's is the faster),
//! over a batch on [`super::exponential::exp_clamped`], which the compiler vectorises
//! (training: every sample, hidden unit and objective evaluation). The two agree to about
//! 1e-16; the clamp of the argument to [-700, 700] makes s(z) differ from the exact value
//! only where that is below 1e-304 (s returns about 1e-304) or within 1e-304 of one, far
//! below anything a network computes with.

use super::exponential::exp_clamped;

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
/// the compiler vectorises, on our exponential, as wide as the processor allows:
/// [`super::wide`] compiles it for AVX-512 and AVX2 too and picks at run time; the same
/// operations in the same order, so the same bits as the baseline build's two values at a
/// time).
pub fn logistic_in_place(values: &mut [f64], bias: f64) {
    crate::neural::wide::dispatch(
        #[inline(always)]
        || {
            for v in values.iter_mut() {
                *v = logistic_vectorised(*v + bias);
            }
        },
    );
}

/// `values[i] <- logistic(values[i] + biases[i mod b])` for every i, b = `biases.len()`: the
/// hidden units of a batch stored a sample per column (`biases` one per unit), the bits of
/// [`logistic_in_place`] on each unit.
pub fn logistic_columns_in_place(values: &mut [f64], biases: &[f64]) {
    crate::neural::wide::dispatch(
        #[inline(always)]
        || {
            for column in values.chunks_exact_mut(biases.len().max(1)) {
                for (v, b) in column.iter_mut().zip(biases) {
                    *v = logistic_vectorised(*v + b);
                }
            }
        },
    );
}

#[cfg(test)]
mod tests {
    use super::*;

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
        // A batch stored a sample per column: the bits of each unit over the batch.
        let biases = [0.5, -1.25, 3.0];
        let mut columns = z[..51].to_vec();
        logistic_columns_in_place(&mut columns, &biases);
        for (unit, &b) in biases.iter().enumerate() {
            let mut one: Vec<f64> = z[..51].iter().skip(unit).step_by(3).copied().collect();
            logistic_in_place(&mut one, b);
            let got: Vec<f64> = columns.iter().skip(unit).step_by(3).copied().collect();
            assert_eq!(got, one, "unit {unit}");
        }
    }
}
