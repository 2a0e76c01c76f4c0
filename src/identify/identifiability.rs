//! What the data can identify (thesis 4.3.4): zero columns, rank, an identifiable subset
//! chosen by priority, and what each left-out parameter regroups with.
//!
//! Method. The weighted observation matrix Phi_w (eq. 4.41, rows divided by their sigma) is
//! reduced to its triangular factor R (Phi_w = Q R) block by block. Columns are then scaled to
//! unit length, which makes mm and rad columns comparable (Hollerbach and Wampler's column
//! scaling): the numbers below are properties of the scaled matrix.
//! - A column shorter than `ZERO_TOL` times the longest is a zero column: no effect.
//! - Singular values of the scaled matrix (SVD) give the condition number; the rank counts
//!   singular values above `RANK_TOL` times the largest. QR with column pivoting gives the
//!   same count as a cross-check.
//! - The subset: columns in priority order (see `select`), each kept when the part of it
//!   outside the span of the kept ones is longer than `RANK_TOL` (it is a unit vector, so this
//!   is the sine of its angle to that span).
//! - A dropped column's regrouping: the least-squares combination of kept columns that
//!   reproduces it, in parameter units (`theta_R = 1.000 theta1`).

use super::problem::{IdentifyWorkspace, Observations, for_each_block, observation_r};
use crate::model::Robot;
use nalgebra::{DMatrix, DVector};

/// Columns shorter than this, relative to the longest, have no effect on the measurements.
pub const ZERO_TOL: f64 = 1e-10;
/// Relative singular value (and sine of angle to the kept span) under which a direction is
/// taken as unidentifiable.
pub const RANK_TOL: f64 = 1e-7;
/// Condition number of the selected, column-scaled set above which identification warns.
pub const CONDITION_WARNING: f64 = 1e4;

/// Why a parameter is left out.
#[derive(Debug, Clone, PartialEq)]
pub enum DropReason {
    /// Its column is zero: it does not change what is measured.
    NoEffect,
    /// Its column is a combination of kept ones: `(parameter index, coefficient)`, with
    /// coefficient in internal units of the kept parameter per internal unit of the dropped
    /// one (mm per rad for a length regrouped with an angle; the report gives file units).
    Regroups(Vec<(usize, f64)>),
    /// A compliance the data do not distinguish from zero: its estimate over its standard
    /// deviation when dropped (below [`super::run::SIGNIFICANCE`] in magnitude).
    NotSignificant(f64),
}

/// A parameter that the data cannot identify.
#[derive(Debug, Clone, PartialEq)]
pub struct Dropped {
    /// Index into `Robot::parameters`.
    pub param: usize,
    /// Why it is left out: no effect, or what it regroups with.
    pub reason: DropReason,
}

/// Result of the analysis.
#[derive(Debug, Clone)]
pub struct Identifiability {
    /// Parameters analysed, in priority order (indices into `Robot::parameters`).
    pub candidates: Vec<usize>,
    /// Singular values of the column-scaled matrix of the non-zero candidate columns.
    pub singular_values: Vec<f64>,
    /// Condition number of that matrix (infinite when rank deficient).
    pub condition_number: f64,
    /// Its rank (SVD, `RANK_TOL`).
    pub rank: usize,
    /// Its rank by QR with column pivoting (cross-check).
    pub rank_pivoted_qr: usize,
    /// The identifiable subset, in priority order.
    pub selected: Vec<usize>,
    /// Condition number of the selected columns (scaled).
    pub selected_condition_number: f64,
    /// The candidates left out of `selected`, in priority order, with the reason.
    pub dropped: Vec<Dropped>,
}

fn condition(m: &DMatrix<f64>) -> (Vec<f64>, f64) {
    if m.ncols() == 0 {
        return (Vec::new(), 1.0);
    }
    condition_of(m.ncols(), &m.clone().singular_values())
}

/// The sorted singular values `sv` of a matrix with `ncols` columns, padded with zeros, and
/// its condition number.
fn condition_of(ncols: usize, sv: &DVector<f64>) -> (Vec<f64>, f64) {
    let mut s: Vec<f64> = sv.iter().copied().collect();
    s.sort_by(|a, b| b.total_cmp(a));
    // Fewer rows than columns: the missing singular values are zero.
    s.resize(ncols, 0.0);
    let cond = if s[s.len() - 1] > 0.0 {
        s[0] / s[s.len() - 1]
    } else {
        f64::INFINITY
    };
    (s, cond)
}

/// The longest column of the weighted observation matrix Phi_w (eq. 4.41) over every
/// parameter of `robot`: the scale against which a candidate's column is zero ([`ZERO_TOL`]).
fn longest_column(robot: &Robot, obs: &Observations, ws: &mut IdentifyWorkspace) -> f64 {
    let all: Vec<usize> = (0..robot.parameters().len()).collect();
    let mut squares = vec![0.0; all.len()];
    for_each_block(robot, obs, Some(&all), ws, |jb, _, rows| {
        for (j, s) in squares.iter_mut().enumerate() {
            *s += jb.column(j).rows(0, rows).norm_squared();
        }
    });
    squares.into_iter().fold(0.0, f64::max).sqrt()
}

/// Analyses the candidate parameters (indices into `Robot::parameters`, in priority order).
/// A candidate joins the identifiable subset when the sine of the angle between its scaled
/// column and the span of those kept before it exceeds `tolerance` ([`RANK_TOL`] for plain
/// identification; larger keeps only well-determined parameters).
pub fn analyse(
    robot: &Robot,
    obs: &Observations,
    candidates: &[usize],
    tolerance: f64,
) -> Identifiability {
    analyse_with(robot, obs, candidates, &|_| tolerance)
}

/// [`analyse`] with a tolerance per parameter (`tolerance(index into Robot::parameters)`).
pub fn analyse_with(
    robot: &Robot,
    obs: &Observations,
    candidates: &[usize],
    tolerance: &dyn Fn(usize) -> f64,
) -> Identifiability {
    let mut ws = IdentifyWorkspace::new(robot);
    let r = observation_r(robot, obs, candidates, &mut ws);
    let k = candidates.len();
    let norms: Vec<f64> = (0..k).map(|j| r.column(j).norm()).collect();
    // Zero against the longest column of every parameter of the model, not of the candidates
    // alone: where none of them has an effect (the base under the distance measure), their
    // columns are rounding noise, and against each other that noise looked identifiable (a
    // reviewer's plan predicted 1e14 mm, identify moved the base by degrees at 1e15 deg std).
    let max_norm = norms
        .iter()
        .cloned()
        .fold(longest_column(robot, obs, &mut ws), f64::max);
    let nonzero: Vec<usize> = (0..k)
        .filter(|&j| norms[j] > ZERO_TOL * max_norm && max_norm > 0.0)
        .collect();
    let mut dropped: Vec<Dropped> = (0..k)
        .filter(|j| !nonzero.contains(j))
        .map(|j| Dropped {
            param: candidates[j],
            reason: DropReason::NoEffect,
        })
        .collect();

    // Unit columns (in the coordinates of R, which preserve lengths and angles).
    let mut scaled = DMatrix::<f64>::zeros(r.nrows().max(1), nonzero.len());
    for (c, &j) in nonzero.iter().enumerate() {
        if r.nrows() > 0 {
            scaled.column_mut(c).copy_from(&(r.column(j) / norms[j]));
        }
    }
    let (singular_values, condition_number) = condition(&scaled);
    let smax = singular_values.first().copied().unwrap_or(0.0);
    let rank = singular_values
        .iter()
        .filter(|&&s| s > RANK_TOL * smax)
        .count();
    let rank_pivoted_qr = if nonzero.is_empty() {
        0
    } else {
        let qr = scaled.clone().col_piv_qr();
        let rr = qr.r();
        let d0 = rr[(0, 0)].abs();
        (0..rr.nrows().min(rr.ncols()))
            .filter(|&i| rr[(i, i)].abs() > RANK_TOL * d0)
            .count()
    };

    // Greedy selection in priority order against an orthonormal basis of the kept columns.
    let mut basis: Vec<DVector<f64>> = Vec::new();
    let mut kept: Vec<usize> = Vec::new(); // positions in `nonzero`
    for (c, _) in nonzero.iter().enumerate() {
        let mut v = scaled.column(c).into_owned();
        for _ in 0..2 {
            for b in &basis {
                let proj = b.dot(&v);
                v.axpy(-proj, b, 1.0);
            }
        }
        let rest = v.norm();
        if rest > tolerance(candidates[nonzero[c]]).max(RANK_TOL) {
            basis.push(v / rest);
            kept.push(c);
        }
    }
    let kept_matrix = DMatrix::from_fn(scaled.nrows(), kept.len(), |i, c| scaled[(i, kept[c])]);
    // Column c = sum x_i column_i in scaled units; in parameter units a change dp_c acts as
    // x_i norm_c / norm_i of parameter i.
    let regrouping = |svd: &nalgebra::SVD<f64, nalgebra::Dyn, nalgebra::Dyn>, c: usize| {
        let j = nonzero[c];
        let coeffs = svd
            .solve(&scaled.column(c), 1e-12)
            .unwrap_or_else(|_| DVector::zeros(kept.len()));
        let max_c = coeffs.iter().map(|x| x.abs()).fold(0.0, f64::max);
        kept.iter()
            .zip(coeffs.iter())
            .filter(|&(_, x)| x.abs() > 1e-3 * max_c && x.abs() > 1e-9)
            .map(|(&ci, x)| (candidates[nonzero[ci]], x * norms[j] / norms[nonzero[ci]]))
            .collect::<Vec<_>>()
    };
    // One factorisation for every regrouping and the selection's condition number; its
    // singular values alone when nothing regroups.
    let regrouped: Vec<usize> = (0..nonzero.len()).filter(|c| !kept.contains(c)).collect();
    let selected_condition_number = if regrouped.is_empty() || kept.is_empty() {
        condition(&kept_matrix).1
    } else {
        let svd = kept_matrix.svd(true, true);
        for c in regrouped {
            dropped.push(Dropped {
                param: candidates[nonzero[c]],
                reason: DropReason::Regroups(regrouping(&svd, c)),
            });
        }
        condition_of(kept.len(), &svd.singular_values).1
    };
    let selected = kept.iter().map(|&c| candidates[nonzero[c]]).collect();
    Identifiability {
        candidates: candidates.to_vec(),
        singular_values,
        condition_number,
        rank,
        rank_pivoted_qr,
        selected,
        selected_condition_number,
        dropped,
    }
}
