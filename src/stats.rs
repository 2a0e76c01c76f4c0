//! Order statistics shared by identification and the compensator's training.

/// The median of `v` (the mean of the middle two for an even count; 0 for none). NaN sorts
/// last (`total_cmp`).
pub fn median(v: &[f64]) -> f64 {
    let mut s = v.to_vec();
    s.sort_by(|a, b| a.total_cmp(b));
    let n = s.len();
    if n == 0 {
        0.0
    } else if n % 2 == 1 {
        s[n / 2]
    } else {
        0.5 * (s[n / 2 - 1] + s[n / 2])
    }
}

/// The `p`-th percentile of `v` by nearest rank: the smallest value that at least `p` % of
/// the values do not exceed (0 for none). NaN sorts last.
pub fn percentile(v: &[f64], p: f64) -> f64 {
    let mut s = v.to_vec();
    s.sort_by(|a, b| a.total_cmp(b));
    if s.is_empty() {
        return 0.0;
    }
    let rank = ((p / 100.0 * s.len() as f64).ceil() as usize).clamp(1, s.len());
    s[rank - 1]
}

/// The least robust sigma [`robust_sigma`] gives (the unit of its values: measurement
/// sigmas, mm or deg): values of rounding alone (noise-free simulated data, near 1e-12) have
/// no outlier, and 3 robust sigmas of rounding would name one.
pub const ROBUST_SIGMA_FLOOR: f64 = 1e-6;

/// The robust sigma of non-negative errors `v`: 1.4826 x their median, at least
/// [`ROBUST_SIGMA_FLOOR`]; the scale of the outlier tests of identification and of the
/// compensator's training. For the absolute values of normal errors it is their standard
/// deviation s; for the RMS over d coordinates of normal errors (sqrt(chi2_d / d) s) it is
/// 1.317 s (d = 3) or 1.400 s (d = 6), so that 3 such sigmas lie at 3.95 s (4.20 s) of each
/// coordinate: the cut of a position or pose row is wider than that of a single number.
pub fn robust_sigma(v: &[f64]) -> f64 {
    (1.4826 * median(v)).max(ROBUST_SIGMA_FLOOR)
}

#[cfg(test)]
mod tests {
    use super::{ROBUST_SIGMA_FLOOR, median, percentile, robust_sigma};

    #[test]
    fn percentiles_by_nearest_rank() {
        let v = [5.0, 1.0, 4.0, 2.0, 3.0, 10.0, 9.0, 8.0, 7.0, 6.0];
        assert_eq!(percentile(&v, 90.0), 9.0);
        assert_eq!(percentile(&v, 91.0), 10.0);
        assert_eq!(percentile(&v, 10.0), 1.0);
        assert_eq!(percentile(&v, 0.0), 1.0);
        assert_eq!(percentile(&[], 50.0), 0.0);
    }

    #[test]
    fn robust_sigma_is_floored() {
        assert!((robust_sigma(&[1.0, 2.0, 3.0]) - 2.9652).abs() < 1e-12);
        assert_eq!(robust_sigma(&[1e-12, 2e-12, 5e-12]), ROBUST_SIGMA_FLOOR);
    }

    #[test]
    fn robust_sigma_of_normal_errors_and_of_their_rms_over_coordinates() {
        use rand::SeedableRng;
        use rand_distr::{Distribution, StandardNormal};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        for (d, want) in [(1, 1.0), (3, 1.317), (6, 1.400)] {
            let e: Vec<f64> = (0..200_000)
                .map(|_| {
                    let sum: f64 = (0..d)
                        .map(|_| {
                            let x: f64 = StandardNormal.sample(&mut rng);
                            x * x
                        })
                        .sum();
                    (sum / d as f64).sqrt()
                })
                .collect();
            let got = robust_sigma(&e);
            assert!((got - want).abs() < 0.01, "{d} coordinates: {got}");
        }
    }

    #[test]
    fn median_of_odd_even_and_empty_sets() {
        assert_eq!(median(&[3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median(&[4.0, 1.0, 3.0, 2.0]), 2.5);
        assert_eq!(median(&[]), 0.0);
    }
}
