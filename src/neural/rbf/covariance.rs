//! The covariance function of the RBF network's Gaussian processes: the unit response k(q) at
//! the weighted squared distance q = sum_d (x_d - c_d)^2 / l_d^2 (k(0) = 1; output o's kernel
//! is s_o^2 k), its slope dk/dq (the input Jacobian and the likelihood's gradient by the
//! widths: dk/d ln l_d = -2 dk/dq (x_d - c_d)^2 / l_d^2), and the distance beyond which a
//! response counts as 0.
//!
//! The squared exponential exp(-q / 2) (Rasmussen and Williams 2006, eq. 4.9) draws
//! infinitely differentiable functions; the Matern class with nu = 5/2 (eq. 4.17),
//! (1 + t + t^2 / 3) e^-t with t = sqrt(5 q), twice differentiable ones, and is the usual
//! choice for physical processes: "such strong smoothness assumptions are unrealistic for
//! modelling many physical processes" (Stein 1999, quoted in R&W 4.2.1). A robot's residual
//! is smooth in the joints (gravity, gear errors) with sharper features (a cable, a gear
//! tooth, repeated configurations). On the shipped UR10 data, the default `train` with the
//! Matern 5/2 function against the squared exponential lowered the held-out position RMS on
//! every Series A split (pools of 500, four seeds: 2.8-6.4 %; pools of 2000, three seeds:
//! 3.3-8.5 %) and by 1.2 % on the mean of 28 Series B runs (seven splits, training seeds 1-4;
//! lower in 20 of them).
//!
//! Both run on [`exp_clamped`] (within 2 ulps of the C library's `exp`) with the cut-off as a
//! select, straight-line code: over a slice ([`Covariance::responses_in_place`]: a kernel
//! matrix's column, a prediction's units) the loop runs 4 wide where the processor has AVX2,
//! 8 where it has AVX-512 ([`crate::neural::wide`]).
//! On the default `train` of 2000 Series A poses, the C library's `exp` there took 12 % of
//! the samples; criterion measured 10.2 -> 9.3-9.4 s (two runs each, alternated), every
//! figure of the README's Series B table the same to 4 decimals.

use crate::neural::exponential::exp_clamped;
use serde::{Deserialize, Serialize};

/// Weighted squared distance beyond which a Matern 5/2 response counts as 0: where
/// (1 + t + t^2 / 3) e^-t = e^-345 as at the squared exponential's [`super::FAR`] (t = 355.66,
/// q = t^2 / 5).
const FAR_MATERN52: f64 = 25_300.0;

/// The form of the unit response (every output of a network fitted now has the same; files
/// written before version 7 hold squared-exponential kernels).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Covariance {
    /// exp(-q / 2).
    SquaredExponential,
    /// Matern nu = 5/2: (1 + t + t^2 / 3) e^-t, t = sqrt(5 q); the default.
    Matern52,
}

impl Covariance {
    /// The covariance function a network is fitted with unless told otherwise.
    pub const DEFAULT: Covariance = Covariance::Matern52;

    /// Its name in files and on the command line (`squared_exponential`, `matern52`).
    pub fn name(self) -> &'static str {
        match self {
            Covariance::SquaredExponential => "squared_exponential",
            Covariance::Matern52 => "matern52",
        }
    }

    /// The covariance of kernels read from files written before version 7.
    pub(crate) fn before_version_7() -> Covariance {
        Covariance::SquaredExponential
    }

    /// Weighted squared distance beyond which a response counts as 0, in the fit, the
    /// likelihood and prediction alike (no subnormal number reaches a factorisation).
    pub fn far(self) -> f64 {
        match self {
            Covariance::SquaredExponential => super::FAR,
            Covariance::Matern52 => FAR_MATERN52,
        }
    }

    /// The unit response k(q) (0 beyond [`Covariance::far`]).
    #[inline(always)]
    pub fn response(self, q: f64) -> f64 {
        self.response_and_width_factor(q).0
    }

    /// [`Covariance::response`] and -2 dk/dq at `q` (both 0 beyond [`Covariance::far`]) from
    /// one exponential (and for Matern 5/2 one square root). -2 dk/dq is the factor of
    /// dk/d ln l_d = -2 dk/dq D_d / l_d^2, D_d the squared difference of input d: for the
    /// squared exponential the response itself, for Matern 5/2 5/3 (1 + t) e^-t.
    #[inline(always)]
    pub fn response_and_width_factor(self, q: f64) -> (f64, f64) {
        match self {
            Covariance::SquaredExponential => squared_exponential(q),
            Covariance::Matern52 => matern52(q),
        }
    }

    /// `q[i] <- scale k(q[i])` for every i: [`Covariance::response`] over a slice, in a loop
    /// the compiler vectorises (compiled for AVX2 and AVX-512 too, picked at run time; the
    /// same operations, so the same bits as one value at a time).
    pub fn responses_in_place(self, q: &mut [f64], scale: f64) {
        fn run(q: &mut [f64], scale: f64, f: impl Fn(f64) -> (f64, f64)) {
            crate::neural::wide::dispatch(
                #[inline(always)]
                || q.iter_mut().for_each(|v| *v = scale * f(*v).0),
            );
        }
        match self {
            Covariance::SquaredExponential => run(q, scale, squared_exponential),
            Covariance::Matern52 => run(q, scale, matern52),
        }
    }

    /// `(q[i], g[i]) <- (k, -2 dk/dq)` at `q[i]` for every i: [`Covariance::response_and_width_factor`]
    /// over a slice, vectorised as [`Covariance::responses_in_place`].
    pub fn responses_and_width_factors_in_place(self, q: &mut [f64], g: &mut [f64]) {
        fn run(q: &mut [f64], g: &mut [f64], f: impl Fn(f64) -> (f64, f64)) {
            crate::neural::wide::dispatch(
                #[inline(always)]
                || {
                    q.iter_mut()
                        .zip(g.iter_mut())
                        .for_each(|(v, gv)| (*v, *gv) = f(*v))
                },
            );
        }
        match self {
            Covariance::SquaredExponential => run(q, g, squared_exponential),
            Covariance::Matern52 => run(q, g, matern52),
        }
    }
}

/// The squared exponential's (k, -2 dk/dq) = (e^(-q/2), e^(-q/2)), 0 beyond [`super::FAR`]:
/// straight-line code (our exponential, a select for the cut) so that loops over it vectorise.
#[inline(always)]
fn squared_exponential(q: f64) -> (f64, f64) {
    let k = exp_clamped(-0.5 * q);
    if q > super::FAR { (0.0, 0.0) } else { (k, k) }
}

/// Matern 5/2's (k, -2 dk/dq) = ((1 + t + t^2 / 3) e^-t, 5/3 (1 + t) e^-t), t = sqrt(5 q), 0
/// beyond [`FAR_MATERN52`]: straight-line code as [`squared_exponential`].
#[inline(always)]
fn matern52(q: f64) -> (f64, f64) {
    let t = (5.0 * q).sqrt();
    let e = exp_clamped(-t);
    let (k, g) = ((1.0 + t + t * t / 3.0) * e, 5.0 / 3.0 * (1.0 + t) * e);
    if q > FAR_MATERN52 { (0.0, 0.0) } else { (k, g) }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn responses_and_slopes_match_their_formulas_and_central_differences() {
        for c in [Covariance::SquaredExponential, Covariance::Matern52] {
            assert_eq!(c.response(0.0), 1.0);
            let mut last = 1.0;
            for q in [1e-3, 0.01, 0.3, 1.0, 4.0, 30.0, 300.0] {
                let k = c.response(q);
                assert!(k > 0.0 && k < last, "{c:?} {q}: {k}");
                last = k;
                // -2 dk/dq against central differences (relative step).
                let h = 1e-5 * q;
                let fd = -2.0 * (c.response(q + h) - c.response(q - h)) / (2.0 * h);
                let w = c.response_and_width_factor(q).1;
                assert!(
                    (fd - w).abs() <= 1e-6 * w.abs() + 1e-300,
                    "{c:?} {q}: {fd} {w}"
                );
            }
            assert_eq!(c.response(c.far() * 1.001), 0.0);
            assert_eq!(c.response_and_width_factor(c.far() * 1.001), (0.0, 0.0));
            // Just inside: a normal number near e^-345, no subnormal.
            let inside = c.response(c.far() * 0.999);
            assert!(inside > 1e-160 && inside < 1e-140, "{c:?}: {inside}");
        }
        // Matern 5/2 at t = sqrt(5 q) = 1: (1 + 1 + 1/3) / e.
        let m = Covariance::Matern52.response(0.2);
        assert!((m - 7.0 / 3.0 / std::f64::consts::E).abs() < 1e-15);
        assert!((Covariance::SquaredExponential.response(2.0) - (-1.0f64).exp()).abs() < 1e-16);
    }

    #[test]
    fn responses_over_a_slice_are_those_of_one_value_at_a_time() {
        // An odd length (the vector loop's body and a remainder); values at 0, at each
        // cut-off (kept), beyond it (0), and not a number.
        let mut q: Vec<f64> = (0..66).map(|i| 0.37 * (i as f64).powi(3)).collect();
        q.extend([0.0, 690.0, 690.5, 25_300.0, 25_300.5, 1e6, f64::NAN]);
        assert_eq!(q.len() % 2, 1);
        for c in [Covariance::SquaredExponential, Covariance::Matern52] {
            let mut k = q.clone();
            c.responses_in_place(&mut k, 1.7);
            let (mut kg, mut g) = (q.clone(), vec![0.0; q.len()]);
            c.responses_and_width_factors_in_place(&mut kg, &mut g);
            for (i, &v) in q.iter().enumerate() {
                let (k1, g1) = c.response_and_width_factor(v);
                if v.is_nan() {
                    // A NaN's sign is not specified: any NaN will do.
                    assert!(k[i].is_nan() && kg[i].is_nan() && g[i].is_nan(), "{c:?}");
                    continue;
                }
                assert_eq!(k[i].to_bits(), (1.7 * k1).to_bits(), "{c:?} {v}");
                assert_eq!(
                    (kg[i].to_bits(), g[i].to_bits()),
                    (k1.to_bits(), g1.to_bits())
                );
                if v > c.far() {
                    assert_eq!((k1, g1), (0.0, 0.0), "{c:?} {v}");
                } else {
                    assert!(k1 > 0.0 && g1 > 0.0, "{c:?} {v}: {k1} {g1}");
                }
            }
        }
    }
}
