//! Unmodelled error: what the weights of a fit become when the model misses the rows by far
//! more than their own sigmas say.
//!
//! A tracker reports the noise of each reading (`sx..srz`), and the weights of eq. 4.29-4.31
//! divide each residual component by it. That is right while the model can follow the robot.
//! On a real robot a geometric model leaves ten times more than the tracker's noise (the
//! UR10's Series B: 0.26 mm per coordinate against sigmas of 0.004-0.03 mm), and the sigmas'
//! ratios, up to 8 between the axes of one reading and more between readings, then decide
//! which rows and axes the model fits and which it gives up. Each component's variance is
//! then sigma_c^2 + tau_k^2: the reading's noise plus an unmodelled error common to every
//! component of its kind k (positions, orientations). tau_k^2 is the Paule-Mandel estimate
//! (Paule and Mandel 1982, as meta-analysis estimates between-study variance): the root of
//! sum_c r_c^2 / (sigma_c^2 + tau_k^2) = m_k (1 - n / m), the kind's share of the degrees of
//! freedom (m residual components, n parameters). The kind's total weight sum_c 1 / sigma_c^2
//! is kept: only its spread over the rows and axes changes, and the balance of positions
//! against orientations stays that of the sigmas. tau_k stays 0 unless the kind's chi-square
//! exceeds its degrees of freedom by 3 standard deviations (sqrt(2 dof)): where the sigmas
//! account for the residuals, the weights are theirs. Where every component of a kind has one
//! sigma, adding tau_k^2 changes nothing and is left out. The weights with tau enter the
//! solve and what follows it (the significance of each parameter, the covariance, the
//! outliers); the rank analysis and the screening of compliances before the solve keep the
//! sigmas' (their residuals are the start's, millimetres off before the fit).
//!
//! Measured on Series B (500 rows identify `full`, the other 995 validate, eight seeded
//! splits): weighting by the tracker's sigmas left 0.4582-0.5546 mm RMS on the held-out rows,
//! one common sigma per kind 0.4383-0.4599 mm, on every split lower.

use super::problem::{Observations, residuals};
use crate::identify::Measure;

/// The kinds of residual component: positions (mm), orientations (rad).
const KINDS: usize = 2;

/// Rounds of (estimate tau, solve again) at most (a warning when they do not settle).
pub const MAX_ROUNDS: usize = 8;

/// Relative change of every tau below which the rounds stop.
pub const SETTLED: f64 = 1e-3;

/// The unmodelled error added to each kind's sigmas (mm for positions, rad for
/// orientations); None where it was not added (not significant, or one sigma for the kind).
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Unmodelled {
    /// tau of the position components (mm).
    pub position_mm: Option<f64>,
    /// tau of the orientation components (rad).
    pub rotation_rad: Option<f64>,
}

impl Unmodelled {
    /// Whether any kind's weights were changed.
    pub fn any(&self) -> bool {
        self.position_mm.is_some() || self.rotation_rad.is_some()
    }

    fn get(&self, kind: usize) -> Option<f64> {
        if kind == 0 {
            self.position_mm
        } else {
            self.rotation_rad
        }
    }

    fn set(&mut self, kind: usize, tau: Option<f64>) {
        if kind == 0 {
            self.position_mm = tau;
        } else {
            self.rotation_rad = tau;
        }
    }

    /// The kinds' tau in file units, as `position 0.2545 mm, orientation 0.5223 mrad` (only
    /// the kinds that have one); None where no kind has one.
    pub fn describe(&self) -> Option<String> {
        let parts: Vec<String> = [
            self.position_mm.map(|t| format!("position {t:.4} mm")),
            self.rotation_rad
                .map(|t| format!("orientation {:.4} mrad", t * 1e3)),
        ]
        .into_iter()
        .flatten()
        .collect();
        (!parts.is_empty()).then(|| parts.join(", "))
    }

    /// What was done, for `identify` and a compensator's refinement alike: the model misses
    /// `rows` by far more than their sigmas, and the unmodelled error added; None where none
    /// was added.
    pub fn note(&self, rows: &str) -> Option<String> {
        self.describe().map(|tau| {
            format!(
                "the model misses {rows} by far more than their own sigmas; an unmodelled error \
                 ({tau}) was added to each sigma of that kind, the kind's total weight kept"
            )
        })
    }

    /// Whether every tau is within [`SETTLED`] of `other`'s (both None counts as settled).
    pub fn settled(&self, other: &Unmodelled) -> bool {
        (0..KINDS).all(|k| match (self.get(k), other.get(k)) {
            (None, None) => true,
            (Some(a), Some(b)) => (a - b).abs() <= SETTLED * a.abs().max(b.abs()),
            _ => false,
        })
    }
}

/// The kind of residual component `c` under `measure` (0 position, 1 orientation).
fn kind_of(measure: Measure, c: usize) -> usize {
    match measure {
        Measure::Pose if c >= 3 => 1,
        Measure::Orientation => 1,
        _ => 0,
    }
}

/// The unmodelled error of each kind at `robot`, the sigmas those of `sigma_inv` (1/sigma of
/// each component of each observation, as [`super::problem::Observation::inv_sigma`]), `n`
/// parameters solved for. A kind gets a tau where its sigmas differ and its chi-square is
/// significantly above its degrees of freedom.
pub fn estimate(
    robot: &crate::model::Robot,
    obs: &Observations,
    sigma_inv: &[[f64; 6]],
    n: usize,
) -> Unmodelled {
    let dim = obs.dim();
    let m = obs.len();
    // Kinds whose sigmas all agree take no tau: without such a kind, no residual pass.
    let mut varies = [false; KINDS];
    let mut seen: [Option<f64>; KINDS] = [None; KINDS];
    for inv in sigma_inv {
        for (c, &i) in inv.iter().enumerate().take(dim) {
            let k = kind_of(obs.measure, c);
            varies[k] |= *seen[k].get_or_insert(i) != i;
        }
    }
    if !varies.iter().any(|&v| v) || m <= n {
        return Unmodelled::default();
    }
    // (w r^2, sigma^2) of every component, by kind, w the observation's robust weight (1
    // without a robust loss): a row the loss has weighted down counts as little here as in
    // the fit, and its share of the degrees of freedom with it.
    let mut parts: [Vec<(f64, f64)>; KINDS] = Default::default();
    let mut weight = [0.0; KINDS];
    for ((o, inv), r) in obs.items.iter().zip(sigma_inv).zip(residuals(robot, obs)) {
        for c in 0..dim {
            let k = kind_of(obs.measure, c);
            parts[k].push((o.weight * r[c] * r[c], 1.0 / (inv[c] * inv[c])));
            weight[k] += o.weight;
        }
    }
    let mut out = Unmodelled::default();
    for (k, part) in parts.iter().enumerate() {
        if !varies[k] || part.is_empty() {
            continue;
        }
        let dof = weight[k] * (1.0 - n as f64 / m as f64);
        out.set(k, paule_mandel(part, dof));
    }
    out
}

/// tau (the sigmas' unit) of components given as (r^2, sigma^2) with `dof` degrees of
/// freedom: None unless their chi-square exceeds `dof` by 3 standard deviations
/// (sqrt(2 dof)), else the root of sum r^2 / (sigma^2 + tau^2) = dof.
pub fn paule_mandel(parts: &[(f64, f64)], dof: f64) -> Option<f64> {
    let chi2: f64 = parts.iter().map(|&(r2, s2)| r2 / s2).sum();
    let significant = chi2 > dof + 3.0 * (2.0 * dof).sqrt();
    if !chi2.is_finite() || !dof.is_finite() || dof <= 0.0 || !significant {
        return None;
    }
    // The sum falls from chi2 > dof at tau^2 = 0 to below dof at tau^2 = sum r^2 / dof:
    // bisection between them.
    let f = |t: f64| parts.iter().map(|&(r2, s2)| r2 / (s2 + t)).sum::<f64>() - dof;
    let (mut lo, mut hi) = (0.0, parts.iter().map(|&(r2, _)| r2).sum::<f64>() / dof);
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if mid <= lo || mid >= hi {
            break;
        }
        if f(mid) > 0.0 {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    Some((0.5 * (lo + hi)).sqrt())
}

/// Sets the weights of `obs` for `tau`: 1/sigma of each component of kind k becomes
/// lambda_k / sqrt(sigma^2 + tau_k^2), lambda_k keeping the kind's sum of 1/sigma^2; a kind
/// without a tau keeps `sigma_inv`'s.
pub fn apply(obs: &mut Observations, sigma_inv: &[[f64; 6]], tau: &Unmodelled) {
    let dim = obs.dim();
    let measure = obs.measure;
    let mut before = [0.0; KINDS];
    let mut after = [0.0; KINDS];
    for inv in sigma_inv {
        for (c, &i) in inv.iter().enumerate().take(dim) {
            let k = kind_of(measure, c);
            let s2 = 1.0 / (i * i);
            before[k] += 1.0 / s2;
            after[k] += 1.0 / (s2 + tau.get(k).map_or(0.0, |t| t * t));
        }
    }
    let lambda: Vec<f64> = (0..KINDS).map(|k| (before[k] / after[k]).sqrt()).collect();
    for (o, inv) in obs.items.iter_mut().zip(sigma_inv) {
        for (c, (out, &i)) in o.inv_sigma.iter_mut().zip(inv).enumerate().take(dim) {
            let k = kind_of(measure, c);
            *out = match tau.get(k) {
                Some(t) => lambda[k] / (1.0 / (i * i) + t * t).sqrt(),
                None => i,
            };
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_distr::{Distribution, Normal};

    #[test]
    fn describe_gives_file_units_and_only_the_kinds_that_have_a_tau() {
        let both = Unmodelled {
            position_mm: Some(0.25454),
            rotation_rad: Some(0.00052226),
        };
        assert_eq!(
            both.describe().as_deref(),
            Some("position 0.2545 mm, orientation 0.5223 mrad")
        );
        let turns = Unmodelled {
            position_mm: None,
            rotation_rad: Some(1e-4),
        };
        assert_eq!(turns.describe().as_deref(), Some("orientation 0.1000 mrad"));
        assert_eq!(Unmodelled::default().describe(), None);
    }

    /// Components whose sigmas spread over a factor 8, drawn with their sigma alone: no tau
    /// (on 20 seeds); drawn with an added error of 0.26: tau found within 5 %.
    #[test]
    fn the_estimate_finds_an_added_error_and_none_where_the_sigmas_hold() {
        let unit = Normal::new(0.0, 1.0).unwrap();
        for seed in 0..20 {
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
            let sigmas: Vec<f64> = (0..1500)
                .map(|i| 0.004 * (1.0 + 7.0 * ((i * 37 % 101) as f64 / 100.0)))
                .collect();
            let draw = |tau: f64, rng: &mut rand_chacha::ChaCha8Rng| -> Vec<(f64, f64)> {
                sigmas
                    .iter()
                    .map(|&s| {
                        let r = unit.sample(rng) * (s * s + tau * tau).sqrt();
                        (r * r, s * s)
                    })
                    .collect()
            };
            let dof = 1500.0 * (1.0 - 30.0 / 1500.0);
            assert_eq!(paule_mandel(&draw(0.0, &mut rng), dof), None, "seed {seed}");
            let tau = paule_mandel(&draw(0.26, &mut rng), dof).unwrap();
            assert!((tau / 0.26 - 1.0).abs() < 0.05, "seed {seed}: {tau}");
        }
        // The root solves its equation.
        let parts = [(4.0, 1.0), (9.0, 0.25), (1.0, 4.0), (16.0, 1.0)];
        let tau = paule_mandel(&parts, 2.0).unwrap();
        let sum: f64 = parts.iter().map(|&(r2, s2)| r2 / (s2 + tau * tau)).sum();
        assert!((sum - 2.0).abs() < 1e-9, "{sum}");
        // Not a number in, no tau out.
        assert_eq!(paule_mandel(&[(f64::NAN, 1.0), (4.0, 1.0)], 1.0), None);
        assert_eq!(paule_mandel(&[(4.0, 1.0)], 0.0), None);
    }
}
