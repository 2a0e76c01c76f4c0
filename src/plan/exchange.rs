//! Choosing N units from the pool: a greedy start, then exchanges until none improves the
//! criterion: Fedorov's exchange, the best swap of a chosen unit for one of a shortlist of
//! 64 candidates, scored exactly, while it improves (the plan is a local optimum against
//! every single swap when the pool has at most 64 units besides it).
//!
//! Every candidate is scored against the current M^-1 through its own dim x dim matrix (the
//! matrix determinant lemma and the Woodbury identity), never by refactorising M:
//! - D: adding B (dim x p) multiplies det M by det(I + B M^-1 B^T); dropping it by
//!   det(I - B M^-1 B^T);
//! - A and I: adding lowers trace(W M^-1) by trace((I + B M^-1 B^T)^-1 B M^-1 W M^-1 B^T);
//!   dropping raises it by the same with I - B M^-1 B^T (W = I for A, R^T R for I);
//! - O3 (no such lemma): candidates are ranked by the first-order change of the smallest
//!   eigenvalues, lambda_k + |B v_k|^2 over the three smallest, and the shortlist is scored
//!   exactly (an eigenvalue problem per swap: O3 plans take longer).
//!
//! The greedy start is D's for every criterion (M is singular for the first p / dim units,
//! where M + eps I stands in); M^-1 is recomputed from M after each accepted change (p x p,
//! once per step, not per candidate).

use super::criterion::Criterion;
use super::design::Design;
use crate::error::{Error, Result};
use nalgebra::{DMatrix, Matrix6, SMatrix};

/// Regularisation of the scaled information (whose per-unit diagonal averages 1) while it
/// is singular.
const EPS: f64 = 1e-9;

/// A chosen set of units.
#[derive(Debug, Clone, PartialEq)]
pub struct Chosen {
    /// Unit indices into the design's pool: the fixed ones first, then in the order the
    /// greedy start chose them, an exchange replacing a unit in its place.
    pub units: Vec<usize>,
    /// The criterion's value ([`Criterion::value`]).
    pub value: f64,
    /// The criterion's value after the greedy start, before any exchange.
    pub greedy_value: f64,
    /// Exchanges accepted.
    pub exchanges: usize,
}

/// Scratch for scoring every unit against M^-1.
struct Scorer<'a> {
    design: &'a Design,
    /// B^T of every unit, stacked (p x units dim): unit u's columns are contiguous.
    bt: DMatrix<f64>,
    /// M^-1 B^T (p x units dim).
    et: DMatrix<f64>,
    /// For `i`, R M^-1 B^T (p x units dim); unused otherwise.
    rt: DMatrix<f64>,
    criterion: Criterion,
}

impl<'a> Scorer<'a> {
    fn new(design: &'a Design, criterion: Criterion) -> Self {
        let bt = design.stacked.transpose();
        let et = DMatrix::zeros(bt.nrows(), bt.ncols());
        let rt = if criterion == Criterion::I {
            et.clone()
        } else {
            DMatrix::zeros(0, 0)
        };
        Scorer {
            design,
            bt,
            et,
            rt,
            criterion,
        }
    }

    /// E^T = M^-1 B^T for every unit, one product (and R E^T for `i`).
    fn update(&mut self, m_inv: &DMatrix<f64>) {
        self.et.gemm(1.0, m_inv, &self.bt, 0.0);
        if self.criterion == Criterion::I {
            self.rt.gemm(1.0, &self.design.cloud_root, &self.et, 0.0);
        }
    }

    /// The stacked columns whose products give B M^-1 W M^-1 B^T: M^-1 B^T for `a` (W = I),
    /// R M^-1 B^T for `i` (W = R^T R); None for the other criteria.
    fn weighted(&self, criterion: Criterion) -> Option<&DMatrix<f64>> {
        match criterion {
            Criterion::A => Some(&self.et),
            Criterion::I => Some(&self.rt),
            _ => None,
        }
    }

    /// (I + sign B M^-1 B^T, and for `a` and `i` B M^-1 W M^-1 B^T) of unit u, padded with
    /// the identity (zeros) to 6 x 6.
    fn blocks(&self, u: usize, sign: f64, criterion: Criterion) -> (Matrix6<f64>, Matrix6<f64>) {
        let d = self.design.dim;
        let mut h = Matrix6::identity();
        let mut g = Matrix6::zeros();
        let second = self.weighted(criterion);
        for i in 0..d {
            let ei = self.et.column(u * d + i);
            for j in 0..d {
                h[(i, j)] += sign * ei.dot(&self.bt.column(u * d + j));
                if let Some(s) = second
                    && j >= i
                {
                    g[(i, j)] = s.column(u * d + i).dot(&s.column(u * d + j));
                    g[(j, i)] = g[(i, j)];
                }
            }
        }
        (h, g)
    }

    /// The change of the objective when unit u is added (sign +1) or dropped (-1), exact for
    /// D, A and I; -infinity when dropping it leaves M singular.
    fn change(&self, u: usize, sign: f64, criterion: Criterion) -> f64 {
        let (h, g) = self.blocks(u, sign, criterion);
        let Some(c) = h.cholesky() else {
            return f64::NEG_INFINITY;
        };
        match criterion {
            // trace(W M^-1) falls by t when adding, rises by t when dropping.
            Criterion::A | Criterion::I => sign * (c.inverse() * g).trace(),
            // ln det M changes by ln det(I +- B M^-1 B^T).
            _ => 2.0 * c.l_dirty().diagonal().iter().map(|v| v.ln()).sum::<f64>(),
        }
    }

    /// x_a . y_b summed into the d x d block at (r0, c0) of `k`, times `sign`, for units
    /// a (rows) and b (columns) of the stacked columns `x` and `y`.
    #[allow(clippy::too_many_arguments)]
    fn cross(
        &self,
        k: &mut SMatrix<f64, 12, 12>,
        (r0, c0): (usize, usize),
        x: &DMatrix<f64>,
        a: usize,
        y: &DMatrix<f64>,
        b: usize,
        sign: f64,
    ) {
        let d = self.design.dim;
        for i in 0..d {
            for j in 0..d {
                k[(r0 + i, c0 + j)] += sign * x.column(a * d + i).dot(&y.column(b * d + j));
            }
        }
    }

    /// The change of the objective when unit `out` leaves and unit `inn` joins, exact for
    /// D, A and I: with M' = M + U V^T, U = [B_in^T, B_out^T], V = [B_in^T, -B_out^T],
    /// det M' = det M det K and trace(W M'^-1) = trace(W M^-1) - trace(K^-1 G), where
    /// K = I + V^T M^-1 U and G = V^T M^-1 W M^-1 U (2 dim x 2 dim, padded to 12 x 12);
    /// -infinity when M' is singular.
    fn swap_change(&self, out: usize, inn: usize, criterion: Criterion) -> f64 {
        let mut k = SMatrix::<f64, 12, 12>::identity();
        let (bt, et) = (&self.bt, &self.et);
        self.cross(&mut k, (0, 0), bt, inn, et, inn, 1.0);
        self.cross(&mut k, (0, 6), bt, inn, et, out, 1.0);
        self.cross(&mut k, (6, 0), bt, out, et, inn, -1.0);
        self.cross(&mut k, (6, 6), bt, out, et, out, -1.0);
        let lu = k.lu();
        let det = lu.determinant();
        if det.is_nan() || det <= 0.0 {
            return f64::NEG_INFINITY;
        }
        match self.weighted(criterion) {
            Some(f) => {
                let mut g = SMatrix::<f64, 12, 12>::zeros();
                self.cross(&mut g, (0, 0), f, inn, f, inn, 1.0);
                self.cross(&mut g, (0, 6), f, inn, f, out, 1.0);
                self.cross(&mut g, (6, 0), f, out, f, inn, -1.0);
                self.cross(&mut g, (6, 6), f, out, f, out, -1.0);
                lu.solve(&g).map_or(f64::NEG_INFINITY, |x| x.trace())
            }
            None => det.ln(),
        }
    }
}

/// Candidates scored exactly against every chosen unit in one exchange step: the best by
/// their gain when added.
const SHORTLIST: usize = 64;

fn inverse(m: &DMatrix<f64>) -> DMatrix<f64> {
    let p = m.nrows();
    let reg = m + DMatrix::identity(p, p) * EPS;
    match reg.cholesky() {
        Some(c) => c.inverse(),
        None => DMatrix::identity(p, p) / EPS,
    }
}

/// The candidates to try in an exchange: for D, A and I the [`SHORTLIST`] whose addition
/// gains most (exact); for O3, the [`SHORTLIST`] best by the first-order change of the
/// three smallest eigenvalues, min_k (lambda_k + |B v_k|^2).
fn shortlist(
    scorer: &Scorer,
    m: &DMatrix<f64>,
    candidates: impl Iterator<Item = usize>,
    criterion: Criterion,
) -> Vec<usize> {
    let mut ranked: Vec<(usize, f64)> = if criterion == Criterion::O3 {
        let eig = m.clone().symmetric_eigen();
        let mut order: Vec<usize> = (0..eig.eigenvalues.len()).collect();
        order.sort_by(|&a, &b| eig.eigenvalues[a].total_cmp(&eig.eigenvalues[b]));
        let weakest: Vec<(f64, nalgebra::DVector<f64>)> = order
            .iter()
            .take(3)
            .map(|&k| (eig.eigenvalues[k], eig.eigenvectors.column(k).into_owned()))
            .collect();
        let d = scorer.design.dim;
        candidates
            .map(|u| {
                let score = weakest
                    .iter()
                    .map(|(l, v)| {
                        l + (0..d)
                            .map(|i| scorer.bt.column(u * d + i).dot(v).powi(2))
                            .sum::<f64>()
                    })
                    .fold(f64::INFINITY, f64::min);
                (u, score)
            })
            .collect()
    } else {
        candidates
            .map(|u| (u, scorer.change(u, 1.0, criterion)))
            .collect()
    };
    ranked.sort_by(|a, b| b.1.total_cmp(&a.1));
    ranked.into_iter().take(SHORTLIST).map(|(u, _)| u).collect()
}

/// An error unless `n` units of `design` give more equations than it has identifiable
/// parameters, as identification asks: as many leave no residual to judge the fit by (and
/// fewer do not determine it).
pub fn enough_equations(design: &Design, n: usize) -> Result<()> {
    let p = design.p();
    if n * design.dim <= p {
        return Err(Error::Invalid(format!(
            "{n} unit{} give{} {} equations for {p} identifiable parameters: at least {} units \
             ({} equations) are needed",
            if n == 1 { "" } else { "s" },
            if n == 1 { "s" } else { "" },
            n * design.dim,
            p / design.dim + 1,
            (p / design.dim + 1) * design.dim
        )));
    }
    Ok(())
}

/// Chooses `n` distinct units of `design`'s pool maximising `criterion`. `fixed` units (a
/// plan to extend) are kept and count towards n. An error when n exceeds the pool or gives
/// no more equations than parameters.
pub fn choose(design: &Design, n: usize, criterion: Criterion, fixed: &[usize]) -> Result<Chosen> {
    let units = design.units();
    if n > units {
        return Err(Error::Invalid(format!(
            "{n} units asked for from a pool of {units}"
        )));
    }
    enough_equations(design, n)?;
    let mut fixed = fixed.to_vec();
    fixed.sort_unstable();
    fixed.dedup();
    if fixed.len() > n || fixed.iter().any(|&u| u >= units) {
        return Err(Error::Invalid(
            "fixed units beyond the plan or the pool".into(),
        ));
    }
    let mut scorer = Scorer::new(design, criterion);
    let mut inside = vec![false; units];
    for &u in &fixed {
        inside[u] = true;
    }
    let mut chosen = fixed;
    // The fixed units stay where they are, first.
    let free = chosen.len();
    let mut m = design.information(&chosen);
    // Greedy start (D).
    while chosen.len() < n {
        scorer.update(&inverse(&m));
        let Some(u) = (0..units)
            .filter(|&u| !inside[u])
            .map(|u| (u, scorer.change(u, 1.0, Criterion::D)))
            .max_by(|a, b| a.1.total_cmp(&b.1))
            .map(|(u, _)| u)
        else {
            break;
        };
        inside[u] = true;
        chosen.push(u);
        let b = design.block(u);
        m.gemm_tr(1.0, &b, &b, 1.0);
    }
    let r = &design.cloud_root;
    let greedy_value = criterion.value(&m, r, n);
    // The exchange compares M + eps I, as its scores do: a greedy start that left M singular
    // (-infinity) can still be improved, swap by swap.
    let regular = |m: &DMatrix<f64>| {
        criterion.objective(&(m + DMatrix::identity(m.nrows(), m.ncols()) * EPS), r)
    };
    let mut objective = regular(&m);
    let mut exchanges = 0;
    let better = |v: f64, than: f64| v > than + 1e-10 * than.abs().max(1.0);
    for _ in 0..10 * n.max(1) {
        scorer.update(&inverse(&m));
        // The best single swap of a chosen unit for a shortlisted candidate (Fedorov's
        // exchange on the shortlist), exact.
        let shortlist = shortlist(&scorer, &m, (0..units).filter(|&u| !inside[u]), criterion);
        let mut best: Option<(usize, usize, f64)> = None;
        for (k, &out) in chosen.iter().enumerate().skip(free) {
            for &u in &shortlist {
                let c = if criterion == Criterion::O3 {
                    let (bo, bi) = (design.block(out), design.block(u));
                    let mut next = m.clone();
                    next.gemm_tr(-1.0, &bo, &bo, 1.0);
                    next.gemm_tr(1.0, &bi, &bi, 1.0);
                    regular(&next) - objective
                } else {
                    scorer.swap_change(out, u, criterion)
                };
                if !c.is_nan() && best.is_none_or(|b| c > b.2) {
                    best = Some((k, u, c));
                }
            }
        }
        let Some((k, u, c)) = best else { break };
        if !better(objective + c, objective) {
            break;
        }
        inside[chosen[k]] = false;
        inside[u] = true;
        chosen[k] = u;
        m = design.information(&chosen);
        objective = regular(&m);
        exchanges += 1;
    }
    // m is the information of `chosen`: summed unit by unit in their order, as
    // `Design::information` sums it.
    Ok(Chosen {
        value: criterion.value(&m, r, n),
        units: chosen,
        greedy_value,
        exchanges,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::identify::problem::{Measure, Sigmas};
    use crate::plan::pool::{Constraints, draw};
    use crate::sim::Region;

    fn design(units: usize, measure: Measure) -> Design {
        let robot = crate::model::test_fanuc();
        let region = Region::limits(&robot);
        let per = crate::plan::design::per_unit(measure);
        let pool = draw(&robot, &region, &Constraints::default(), units, per, 7).unwrap();
        let cloud = draw(&robot, &region, &Constraints::default(), 50, 1, 8)
            .unwrap()
            .into_configurations();
        Design::new(
            &robot,
            "full",
            measure,
            Sigmas::default(),
            &pool,
            cloud,
            1e-7,
        )
        .unwrap()
    }

    #[test]
    fn lemma_scores_equal_refactorised_criteria() {
        let d = design(40, Measure::Pose);
        let r = &d.cloud_root;
        let base: Vec<usize> = (0..12).collect();
        let m = d.information(&base);
        for criterion in [Criterion::D, Criterion::A, Criterion::I] {
            let mut s = Scorer::new(&d, criterion);
            s.update(&m.clone().cholesky().unwrap().inverse());
            let now = criterion.objective(&m, r);
            for u in [20, 33] {
                let b = d.block(u);
                let mut grown = m.clone();
                grown.gemm_tr(1.0, &b, &b, 1.0);
                let want = criterion.objective(&grown, r) - now;
                let got = s.change(u, 1.0, criterion);
                assert!(
                    (got - want).abs() < 1e-8 * want.abs().max(1.0),
                    "{criterion:?} add {got} vs {want}"
                );
            }
            for u in [3, 9] {
                let b = d.block(u);
                let mut less = m.clone();
                less.gemm_tr(-1.0, &b, &b, 1.0);
                let want = criterion.objective(&less, r) - now;
                let got = s.change(u, -1.0, criterion);
                assert!(
                    (got - want).abs() < 1e-8 * want.abs().max(1.0),
                    "{criterion:?} drop {got} vs {want}"
                );
            }
        }
    }

    #[test]
    fn no_single_swap_improves_the_exchanged_plan() {
        for (measure, criterion) in [
            (Measure::Pose, Criterion::D),
            (Measure::Position, Criterion::A),
            (Measure::Pose, Criterion::I),
            (Measure::Pose, Criterion::O3),
            (Measure::Distance, Criterion::D),
        ] {
            let d = design(60, measure);
            let n = d.p() / d.dim + 2;
            let c = choose(&d, n, criterion, &[]).unwrap();
            let r = &d.cloud_root;
            assert_eq!(c.units.len(), n);
            let mut sorted = c.units.clone();
            sorted.sort_unstable();
            sorted.dedup();
            assert_eq!(sorted.len(), n, "repeated units");
            // I's value is the predicted RMS error: lower is better.
            let kept = if criterion == Criterion::I {
                c.value <= c.greedy_value + 1e-12
            } else {
                c.value >= c.greedy_value - 1e-12
            };
            assert!(kept, "{criterion:?}: {} after {}", c.value, c.greedy_value);
            let best = criterion.objective(&d.information(&c.units), r);
            assert!(best.is_finite());
            let slack = 1e-9 * best.abs().max(1.0);
            for k in 0..n {
                for u in (0..d.units()).filter(|u| !c.units.contains(u)) {
                    let mut other = c.units.clone();
                    other[k] = u;
                    let v = criterion.objective(&d.information(&other), r);
                    assert!(
                        v <= best + slack,
                        "{measure:?} {criterion:?}: swapping {k} for {u} gives {v} > {best}"
                    );
                }
            }
        }
    }

    #[test]
    fn too_few_units_and_fixed_units_are_handled() {
        let d = design(30, Measure::Pose);
        let few = d.p() / d.dim;
        let e = choose(&d, few, Criterion::D, &[]).unwrap_err();
        assert!(e.to_string().contains("equations"), "{e}");
        assert!(choose(&d, 31, Criterion::D, &[]).is_err());
        // Two units leave M singular: no covariance, no prediction, rather than 1e12 mm.
        assert!(d.covariance(&[0, 1]).is_none());
        assert!(crate::plan::predict(&d, &[0, 1], 0).is_none());
        let fixed = [4, 5, 6];
        let c = choose(&d, few + 2, Criterion::D, &fixed).unwrap();
        assert!(fixed.iter().all(|u| c.units.contains(u)));
    }
}
