//! Optimality criteria of a plan's scaled information matrix M (p x p, see
//! [`super::design`]). Each is a number to maximise.
//!
//! - `d` (D-optimal): ln det M, the volume of the parameters' confidence ellipsoid shrunk.
//! - `o1` (Borm and Menq's observability index): (sigma_1 ... sigma_p)^(1/p) / sqrt(N), the
//!   geometric mean of the stacked scaled Jacobian's singular values over sqrt(units); for a
//!   fixed N a monotone function of ln det M, so it plans as `d`.
//! - `o3` (Nahvi and Hollerbach's minimum singular value): sigma_min = sqrt(lambda_min(M)), the
//!   worst-determined direction's information.
//! - `a` (A-optimal): -trace(M^-1), minus the sum of the scaled parameters' variances.
//! - `i` (I-optimal, or V-optimal): -trace(W M^-1), W = R^T R the mean of J_v^T J_v over a
//!   validation cloud (J_v the tool position's Jacobian over the scaled parameters): minus the
//!   predicted mean squared position error (mm^2) over the cloud, what a user is after.

use nalgebra::DMatrix;

/// Which criterion a plan maximises.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Criterion {
    /// D-optimal: ln det M.
    D,
    /// Borm and Menq's O1: det(M)^(1/2p) / sqrt(N).
    O1,
    /// Nahvi and Hollerbach's O3: the smallest singular value, sqrt(lambda_min(M)).
    O3,
    /// A-optimal: -trace(M^-1).
    A,
    /// I-optimal: -trace(R M^-1 R^T), the predicted mean squared position error (mm^2)
    /// over the validation cloud.
    I,
}

impl Criterion {
    /// Parses `d`, `o1`, `o3`, `a` or `i`.
    pub fn parse(s: &str) -> Option<Criterion> {
        match s {
            "d" => Some(Criterion::D),
            "o1" => Some(Criterion::O1),
            "o3" => Some(Criterion::O3),
            "a" => Some(Criterion::A),
            "i" => Some(Criterion::I),
            _ => None,
        }
    }

    /// Its name on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Criterion::D => "d",
            Criterion::O1 => "o1",
            Criterion::O3 => "o3",
            Criterion::A => "a",
            Criterion::I => "i",
        }
    }

    /// What [`Criterion::value`] reports, in words: the quantity, its unit and whether more
    /// is better, as `plan` prints it.
    pub fn value_words(self) -> &'static str {
        match self {
            Criterion::D => "ln det M, higher is better",
            Criterion::O1 => "det(M)^(1/2p) / sqrt(N), higher is better",
            Criterion::O3 => "the smallest singular value of M's root, higher is better",
            Criterion::A => {
                "-trace(M^-1), minus the scaled parameters' summed variances, higher is better"
            }
            Criterion::I => {
                "the predicted RMS position error over the validation cloud in mm, lower is better"
            }
        }
    }

    /// The quantity the exchange compares: ln det M for `d` and `o1` (the same ordering),
    /// lambda_min(M) for `o3`, -trace(M^-1) for `a`, -trace(R M^-1 R^T) for `i` (`r` the
    /// cloud's root R, p x p); -infinity when M is singular.
    pub fn objective(self, m: &DMatrix<f64>, r: &DMatrix<f64>) -> f64 {
        match self {
            Criterion::D | Criterion::O1 => match m.clone().cholesky() {
                Some(c) => 2.0 * c.l_dirty().diagonal().iter().map(|v| v.ln()).sum::<f64>(),
                None => f64::NEG_INFINITY,
            },
            Criterion::O3 => {
                let l = smallest_eigenvalue(m);
                if l > 0.0 { l } else { f64::NEG_INFINITY }
            }
            Criterion::A => match m.clone().cholesky() {
                Some(c) => -c.inverse().trace(),
                None => f64::NEG_INFINITY,
            },
            Criterion::I => match m.clone().cholesky() {
                Some(c) => -(r * c.inverse() * r.transpose()).trace(),
                None => f64::NEG_INFINITY,
            },
        }
    }

    /// The criterion's value as reported (see the module doc), for `units` units: for `i`
    /// the predicted RMS position error (mm).
    pub fn value(self, m: &DMatrix<f64>, r: &DMatrix<f64>, units: usize) -> f64 {
        let o = self.objective(m, r);
        match self {
            Criterion::D | Criterion::A => o,
            Criterion::O1 => (o / (2.0 * m.nrows() as f64)).exp() / (units as f64).sqrt(),
            Criterion::O3 => o.max(0.0).sqrt(),
            Criterion::I => (-o).sqrt(),
        }
    }
}

/// The smallest eigenvalue of the symmetric matrix `m`.
pub fn smallest_eigenvalue(m: &DMatrix<f64>) -> f64 {
    m.clone()
        .symmetric_eigenvalues()
        .iter()
        .copied()
        .fold(f64::INFINITY, f64::min)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn values_match_hand_computed_ones() {
        // diag(4, 1): ln det = ln 4; O1 = (2 * 1)^(1/2) / sqrt(2) = 1; O3 = 1; A = -(1/4 + 1).
        // R = [[2, 0], [0, 0]]: I = sqrt(4 / 4) = 1.
        let m = DMatrix::from_diagonal(&nalgebra::DVector::from_vec(vec![4.0, 1.0]));
        let r = DMatrix::from_row_slice(2, 2, &[2.0, 0.0, 0.0, 0.0]);
        assert!((Criterion::D.value(&m, &r, 2) - 4f64.ln()).abs() < 1e-12);
        assert!((Criterion::O1.value(&m, &r, 2) - 1.0).abs() < 1e-12);
        assert!((Criterion::O3.value(&m, &r, 2) - 1.0).abs() < 1e-12);
        assert!((Criterion::A.value(&m, &r, 2) + 1.25).abs() < 1e-12);
        assert!((Criterion::I.value(&m, &r, 2) - 1.0).abs() < 1e-12);
        let singular = DMatrix::from_row_slice(2, 2, &[1.0, 1.0, 1.0, 1.0]);
        for c in [Criterion::D, Criterion::O3, Criterion::A, Criterion::I] {
            assert_eq!(c.objective(&singular, &r), f64::NEG_INFINITY, "{c:?}");
        }
        for c in ["d", "o1", "o3", "a", "i"] {
            assert_eq!(Criterion::parse(c).unwrap().name(), c);
        }
        assert!(Criterion::parse("e").is_none());
    }
}
