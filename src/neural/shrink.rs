//! Shrinkage of the MLP ensemble's mean where its members disagree.
//!
//! Each member is a fit of the same residual from another start; where they disagree the
//! ensemble's mean is an uncertain estimate, typically an extrapolation. Treat the members'
//! mean ybar (normalised outputs) as a noisy reading of the true correction y, with noise
//! variance S(x) = sum_k s_k^2(x), the members' sample variance summed over the outputs, and
//! take for y the prior the training rows give: mean c (the mean output over them) and variance
//! T (the variance of the mean output over them, summed over the outputs: the signal the
//! networks learnt). The posterior mean (the empirical-Bayes, James-Stein-type estimate) is
//!
//!   y = c + f (ybar - c),   f = T / (T + S(x)),
//!
//! so where the members agree (S << T) nothing changes, and where they disagree as much as the
//! signal varies the correction is halved toward its training mean. With
//! S = (sum_m |y_m|^2 - M |ybar|^2) / (M - 1), the derivative by the inputs is
//! dS/dx = 2 (sum_m dy_m^T y_m - M dybar^T ybar) / (M - 1), df/dx = -(f^2 / T) dS/dx.
//! A single network has no spread and is never shrunk; the RBF network has its own shrinkage
//! (a Gaussian process's posterior mean) and is not part of S.

use super::weights::Weights;

/// The prior of the shrinkage: the MLP ensemble's mean output over its training rows and its
/// variance there (normalised output units).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Shrink {
    /// c: the mean over the training rows of the members' mean output (normalised units).
    pub centre: Vec<f64>,
    /// T: the variance over the training rows of the members' mean output, summed over the
    /// outputs (normalised units squared).
    pub signal: f64,
}

impl Shrink {
    /// The prior of `members` from their outputs at the training inputs `xs` (normalised);
    /// None for fewer than two members (no spread) or a constant mean output.
    pub fn fit(members: &[Weights], xs: &[Vec<f64>]) -> Option<Shrink> {
        let (first, count) = (members.first()?, members.len());
        if count < 2 || xs.is_empty() {
            return None;
        }
        let outputs = first.outputs();
        let mut hidden = vec![0.0; first.hidden()];
        let mut y = vec![0.0; outputs];
        let means: Vec<Vec<f64>> = xs
            .iter()
            .map(|x| {
                let mut sum = vec![0.0; outputs];
                for w in members {
                    w.forward_into(x, &mut hidden, &mut y);
                    sum.iter_mut()
                        .zip(&y)
                        .for_each(|(s, v)| *s += v / count as f64);
                }
                sum
            })
            .collect();
        let n = means.len() as f64;
        let centre: Vec<f64> = (0..outputs)
            .map(|k| means.iter().map(|m| m[k]).sum::<f64>() / n)
            .collect();
        let signal = means
            .iter()
            .map(|m| {
                m.iter()
                    .zip(&centre)
                    .map(|(a, c)| (a - c).powi(2))
                    .sum::<f64>()
            })
            .sum::<f64>()
            / n;
        (signal.is_finite() && signal > 0.0).then_some(Shrink { centre, signal })
    }

    /// f = T / (T + S) for the members' summed sample variance `spread` S.
    pub fn factor(&self, spread: f64) -> f64 {
        self.signal / (self.signal + spread.max(0.0))
    }

    /// Whether it fits `outputs` network outputs of `members` MLPs (two or more: one has no
    /// spread) with finite numbers and a positive signal.
    pub fn is_valid(&self, outputs: usize, members: usize) -> bool {
        members >= 2
            && self.centre.len() == outputs
            && self.centre.iter().all(|v| v.is_finite())
            && self.signal.is_finite()
            && self.signal > 0.0
    }
}
