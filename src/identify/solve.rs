//! Levenberg-Marquardt (default) and Gauss-Newton on the normal equations (thesis eq. 4.16-4.18,
//! weighted as eq. 4.29): (J^T W J + lambda diag(J^T W J)) dp = J^T W r.
//!
//! Stopping, reported as [`StopReason`]: the gradient test (largest cosine between the
//! residual and a Jacobian column, as MINPACK), the relative decrease of the cost, the size of
//! the step against the parameters (mm, rad), or the iteration limit. A NaN, a factorisation
//! that fails even with heavy damping (rank loss) and a Gauss-Newton step that no halving can
//! make descend (divergence) are errors, never results.

use super::problem::{
    IdentifyWorkspace, Normal, Observations, cost, normal_equations, normal_equations_into,
};
use crate::error::{Error, Result};
use crate::model::{ParamId, Robot};
use nalgebra::{DMatrix, DVector};

/// Identification method.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Method {
    /// Levenberg-Marquardt.
    Lm,
    /// Gauss-Newton with step halving.
    Gn,
    /// Nelder-Mead simplex (derivative free, thesis 4.1).
    Nm,
}

/// Why a solve stopped.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum StopReason {
    /// The residual is orthogonal to every Jacobian column (gradient tolerance).
    Gradient,
    /// The cost stopped decreasing (function tolerance).
    Function,
    /// The step became negligible against the parameters (parameter tolerance).
    Parameter,
    /// No step lowers the cost any more: converged to machine precision.
    Precision,
    /// The simplex collapsed (Nelder-Mead).
    Simplex,
    /// The iteration limit was reached before any tolerance: the result may be unconverged.
    MaxIterations,
}

impl StopReason {
    /// A short sentence for reports: which test stopped the solve.
    pub fn describe(self) -> &'static str {
        match self {
            StopReason::Gradient => "gradient tolerance reached",
            StopReason::Function => "function tolerance reached (cost no longer decreases)",
            StopReason::Parameter => "parameter tolerance reached (step negligible)",
            StopReason::Precision => "converged to machine precision",
            StopReason::Simplex => "simplex collapsed to the tolerance",
            StopReason::MaxIterations => "maximum iterations reached (may be unconverged)",
        }
    }
}

/// Tolerances and limits.
#[derive(Debug, Clone, Copy)]
pub struct SolveOptions {
    /// Which solver runs.
    pub method: Method,
    /// Iteration limit (Nelder-Mead: simplex iterations).
    pub max_iterations: usize,
    /// Relative decrease of the cost below which the solve stops.
    pub ftol: f64,
    /// Step (mm or rad) below xtol * (1 + |p|) for every parameter stops the solve.
    pub xtol: f64,
    /// Largest cosine between residual and a Jacobian column below which the solve stops.
    pub gtol: f64,
}

impl Default for SolveOptions {
    fn default() -> Self {
        SolveOptions {
            method: Method::Lm,
            max_iterations: 200,
            ftol: 1e-12,
            xtol: 1e-12,
            gtol: 1e-12,
        }
    }
}

/// A finished solve.
#[derive(Debug, Clone)]
pub struct Solution {
    /// The robot with the free parameters at their solved values.
    pub robot: Robot,
    /// Iterations run.
    pub iterations: usize,
    /// Which test stopped the solve.
    pub stop: StopReason,
    /// Final weighted sum of squares.
    pub cost: f64,
    /// Passes over the data (a cost, or a cost with the normal equations; for Nelder-Mead:
    /// function evaluations).
    pub evaluations: usize,
    /// The normal equations at `robot` over the solved parameters (gradient methods; None
    /// for Nelder-Mead): the covariance needs them, and they cost a pass over the data.
    pub normal: Option<Normal>,
}

/// The robot with the free parameters `ids` set to `x` (mm, rad).
pub fn with_values(robot: &Robot, ids: &[ParamId], x: &DVector<f64>) -> Result<Robot> {
    let values: Vec<(ParamId, f64)> = ids.iter().copied().zip(x.iter().copied()).collect();
    robot.with_params(&values)
}

/// The free parameters `cols` (indices into `Robot::parameters`) and their values (mm, rad).
pub fn free_values(robot: &Robot, cols: &[usize]) -> (Vec<ParamId>, DVector<f64>) {
    let params = robot.parameters();
    let ids: Vec<ParamId> = cols.iter().map(|&c| params[c]).collect();
    let x = DVector::from_iterator(ids.len(), ids.iter().map(|&id| robot.param(id)));
    (ids, x)
}

fn finished(
    robot: Robot,
    iterations: usize,
    stop: StopReason,
    normal: Normal,
    evaluations: usize,
) -> Solution {
    Solution {
        robot,
        iterations,
        stop,
        cost: normal.cost,
        evaluations,
        normal: Some(normal),
    }
}

fn names(ids: &[ParamId]) -> String {
    ids.iter().map(|i| i.name()).collect::<Vec<_>>().join(", ")
}

/// Runs LM or GN from `robot` on the parameters `cols` (indices into `Robot::parameters`);
/// `normal`: the normal equations at `robot` over `cols` when the caller has them already
/// (they cost a pass over the data).
pub fn solve_gradient(
    robot: &Robot,
    obs: &Observations,
    cols: &[usize],
    opts: &SolveOptions,
    normal: Option<Normal>,
) -> Result<Solution> {
    let (ids, mut x) = free_values(robot, cols);
    let mut ws = IdentifyWorkspace::new(robot);
    let mut current = robot.clone();
    let mut ne = match normal {
        Some(ne) => {
            debug_assert!(ne.a.nrows() == cols.len() && ne.g.len() == cols.len());
            ne
        }
        None => normal_equations(&current, obs, cols, &mut ws),
    };
    let mut evaluations = 1;
    if !ne.cost.is_finite() {
        return Err(Error::NotConverged(format!(
            "the cost at the starting model is {}: check the measurements and the model",
            ne.cost
        )));
    }
    let k = ids.len();
    let mut step = StepBuffers::new(k);
    let mut lambda = 1e-3;
    // The normal equations of an LM trial evaluated with its Jacobian (see `lm_step`).
    let mut spare = Normal {
        a: DMatrix::zeros(k, k),
        g: DVector::zeros(k),
        cost: 0.0,
    };
    // Optimistic from the start: LM's first step is nearly always accepted.
    let mut accepted_first = true;
    let problem = Problem {
        robot,
        obs,
        cols,
        ids: &ids,
    };
    for iter in 0..opts.max_iterations {
        if ne.cost == 0.0 {
            return Ok(finished(
                current,
                iter,
                StopReason::Gradient,
                ne,
                evaluations,
            ));
        }
        let rnorm = ne.cost.sqrt();
        let gmax = (0..k)
            .map(|i| {
                let d = ne.a[(i, i)].sqrt();
                if d > 0.0 {
                    ne.g[i].abs() / (d * rnorm)
                } else {
                    0.0
                }
            })
            .fold(0.0, f64::max);
        if gmax <= opts.gtol {
            return Ok(finished(
                current,
                iter,
                StopReason::Gradient,
                ne,
                evaluations,
            ));
        }
        let (outcome, with_normal) = if opts.method == Method::Gn {
            let o = gn_step(
                &problem,
                &ne,
                &x,
                iter,
                opts,
                &mut step,
                &mut ws,
                &mut evaluations,
            )?;
            (o, false)
        } else {
            let trial = LmTrial {
                lambda: &mut lambda,
                normal: accepted_first.then_some(&mut spare),
            };
            let (o, first, filled) = lm_step(
                &problem,
                &ne,
                &x,
                trial,
                &mut step,
                &mut ws,
                &mut evaluations,
            );
            accepted_first = first;
            (o, filled)
        };
        let Some((new_robot, new_cost)) = outcome else {
            return Ok(finished(
                current,
                iter,
                StopReason::Precision,
                ne,
                evaluations,
            ));
        };
        let decrease = ne.cost - new_cost;
        let small_step = step
            .step
            .iter()
            .zip(x.iter())
            .all(|(d, v)| d.abs() <= opts.xtol * (1.0 + v.abs()));
        x += &step.step;
        current = new_robot;
        let old_cost = ne.cost;
        if with_normal {
            // The accepted trial's pass gave them already.
            std::mem::swap(&mut ne, &mut spare);
        } else {
            normal_equations_into(&current, obs, cols, &mut ws, &mut ne);
            evaluations += 1;
        }
        if !ne.cost.is_finite() {
            return Err(Error::NotConverged(format!(
                "the cost became {} at iteration {}",
                ne.cost,
                iter + 1
            )));
        }
        if decrease <= opts.ftol * old_cost {
            return Ok(finished(
                current,
                iter + 1,
                StopReason::Function,
                ne,
                evaluations,
            ));
        }
        if small_step {
            return Ok(finished(
                current,
                iter + 1,
                StopReason::Parameter,
                ne,
                evaluations,
            ));
        }
    }
    Ok(finished(
        current,
        opts.max_iterations,
        StopReason::MaxIterations,
        ne,
        evaluations,
    ))
}

/// What a step is taken on: the model, the observations and the free parameters.
struct Problem<'a> {
    robot: &'a Robot,
    obs: &'a Observations<'a>,
    /// The free parameters (indices into `Robot::parameters`) and their ids.
    cols: &'a [usize],
    ids: &'a [ParamId],
}

/// The step's matrices and vectors, reused across iterations: the damped normal matrix
/// (then its Cholesky factor), the step and the trial parameters (mm, rad).
struct StepBuffers {
    m: DMatrix<f64>,
    step: DVector<f64>,
    trial: DVector<f64>,
}

impl StepBuffers {
    fn new(k: usize) -> Self {
        StepBuffers {
            m: DMatrix::zeros(k, k),
            step: DVector::zeros(k),
            trial: DVector::zeros(k),
        }
    }

    /// Solves `m` step = g into `step`, factorising `m` in place; false when `m` is not
    /// positive definite.
    fn solve(&mut self, g: &DVector<f64>) -> bool {
        let k = g.len();
        let m = std::mem::replace(&mut self.m, DMatrix::zeros(0, 0));
        match m.cholesky() {
            Some(chol) => {
                self.step.copy_from(g);
                chol.solve_mut(&mut self.step);
                self.m = chol.unpack_dirty();
                true
            }
            None => {
                self.m = DMatrix::zeros(k, k);
                false
            }
        }
    }

    /// The model at x + t step and its cost, or None when that model leaves the robot's
    /// bounds (100 m, 2 turns: a failed step). With `normal`, the cost comes from a pass
    /// that fills the normal equations too: the same bits as the cost-only pass (the same
    /// residuals, summed block by block alike).
    fn trial(
        &mut self,
        p: &Problem,
        x: &DVector<f64>,
        t: f64,
        normal: Option<&mut Normal>,
        ws: &mut IdentifyWorkspace,
    ) -> Option<(Robot, f64)> {
        self.trial.copy_from(x);
        self.trial.axpy(t, &self.step, 1.0);
        let cand = with_values(p.robot, p.ids, &self.trial).ok()?;
        let c = match normal {
            Some(out) => {
                normal_equations_into(&cand, p.obs, p.cols, ws, out);
                out.cost
            }
            None => cost(&cand, p.obs, ws),
        };
        Some((cand, c))
    }
}

/// One Gauss-Newton step with step halving: the model and cost of the first fraction of the
/// full step that does not raise the cost (`step` holds that fraction), None when no
/// fraction does and the step is already negligible; an error when J^T W J is singular or
/// no fraction helps.
#[allow(clippy::too_many_arguments)]
fn gn_step(
    p: &Problem,
    ne: &Normal,
    x: &DVector<f64>,
    iter: usize,
    opts: &SolveOptions,
    b: &mut StepBuffers,
    ws: &mut IdentifyWorkspace,
    evaluations: &mut usize,
) -> Result<Option<(Robot, f64)>> {
    b.m.copy_from(&ne.a);
    if !b.solve(&ne.g) {
        return Err(Error::NotConverged(format!(
            "Gauss-Newton: J^T W J is singular at iteration {iter} (rank loss among {}); Levenberg-Marquardt (method lm) damps it",
            names(p.ids)
        )));
    }
    let mut t = 1.0;
    for _ in 0..30 {
        if let Some((cand, c)) = b.trial(p, x, t, None, ws) {
            *evaluations += 1;
            if c.is_finite() && c <= ne.cost {
                b.step.scale_mut(t);
                return Ok(Some((cand, c)));
            }
        }
        t *= 0.5;
    }
    if b.step
        .iter()
        .zip(x.iter())
        .all(|(d, v)| d.abs() <= 1e3 * opts.xtol * (1.0 + v.abs()))
    {
        return Ok(None);
    }
    Err(Error::NotConverged(format!(
        "Gauss-Newton diverged at iteration {iter}: no fraction of its step lowers the cost \
         ({:.6e}); Levenberg-Marquardt (method lm) damps the step",
        ne.cost
    )))
}

/// Predicted decrease (relative to the cost) below which an LM trial is evaluated for its
/// cost alone: near convergence, where a trial's change is at the level of the cost's
/// rounding and may be refused, a pass with the Jacobian would be wasted.
const DECISIVE: f64 = 1e-10;

/// How an LM step evaluates its trials: the damping, raised and lowered in place, and where
/// the first trial's normal equations go when it is evaluated with its Jacobian.
struct LmTrial<'a> {
    lambda: &'a mut f64,
    /// Some at the first step and after a step whose first trial was accepted: the first
    /// trial is then evaluated by a pass with the Jacobian (into here), which
    /// the next iteration needs if the trial is accepted; the cost-only pass it replaces
    /// would be followed by that same pass. A refused trial wastes it, so after a refusal,
    /// and where the predicted decrease is not [`DECISIVE`], trials are cost-only.
    normal: Option<&'a mut Normal>,
}

/// One Levenberg-Marquardt step (thesis 4.1; damping lambda diag(J^T W J), raised tenfold
/// until the cost falls, lowered tenfold after a success): the new model and cost (`step`
/// holds the step), None when no damping lowers the cost; whether the first trial was
/// accepted; and whether the accepted trial's normal equations are in `trial.normal`.
fn lm_step(
    p: &Problem,
    ne: &Normal,
    x: &DVector<f64>,
    mut trial: LmTrial,
    b: &mut StepBuffers,
    ws: &mut IdentifyWorkspace,
    evaluations: &mut usize,
) -> (Option<(Robot, f64)>, bool, bool) {
    let lambda = trial.lambda;
    let mut first = true;
    while *lambda < 1e16 {
        b.m.copy_from(&ne.a);
        for i in 0..ne.g.len() {
            b.m[(i, i)] += *lambda * ne.a[(i, i)].max(1e-300);
        }
        if !b.solve(&ne.g) {
            *lambda *= 10.0;
            first = false;
            continue;
        }
        // The linear model predicts the decrease 2 s.g - s^T A s = s.g + lambda s^T D s
        // (cost sum r_w^2, (A + lambda D) s = g): at least s.g. Where that is near the
        // cost's rounding, acceptance is a coin toss: cost-only then.
        let decisive = b.step.dot(&ne.g) > DECISIVE * ne.cost;
        let normal = if first && decisive {
            trial.normal.take()
        } else {
            None
        };
        let filled = normal.is_some();
        let Some((cand, c)) = b.trial(p, x, 1.0, normal, ws) else {
            *lambda *= 10.0;
            first = false;
            continue;
        };
        *evaluations += 1;
        if c.is_finite() && c < ne.cost {
            *lambda = (*lambda / 10.0).max(1e-15);
            return (Some((cand, c)), first, filled);
        }
        *lambda *= 10.0;
        first = false;
    }
    (None, false, false)
}

/// The covariance of the free parameters at `robot` over `cols` (s^2 (J^T W J)^-1, from
/// the normal equations `ne` where the caller has them), and where pairs of rows share rows
/// (chained relative or distance measures) the sandwich s^2 A^-1 (A + C) A^-1 with C their
/// cross terms ([`super::chained`]) and the variance factor s^2 = cost / (m - n -
/// tr(A^-1 C)): the covariance and variance factor the identification reports.
pub fn covariance_of(
    robot: &Robot,
    obs: &Observations,
    cols: &[usize],
    ne: Option<&Normal>,
) -> Result<(DMatrix<f64>, f64)> {
    let computed;
    let ne = match ne {
        Some(ne) => ne,
        None => {
            computed = normal_equations(robot, obs, cols, &mut IdentifyWorkspace::new(robot));
            &computed
        }
    };
    let (cov, s2) = covariance_from(robot, ne, obs.len(), cols)?;
    let Some(cross) = super::chained::shared_row_terms(robot, obs, cols) else {
        return Ok((cov, s2));
    };
    // cov = s^2 A^-1 (factor 1 without redundancy): s^2 A^-1 C A^-1 = cov C cov / s^2.
    let factor = if s2.is_finite() { s2 } else { 1.0 };
    let cov_cross = &cov * &cross;
    let sandwich = &cov + &cov_cross * &cov / factor;
    if !s2.is_finite() {
        return Ok((sandwich, s2));
    }
    // Correlated residuals leave E[cost] = s^2 (m - n - tr(A^-1 C)), not s^2 (m - n): the
    // variance factor takes those degrees of freedom (on a chain of 16 rows the plain one
    // came out 0.6-0.7 with the sigmas right, a reviewer's simulation).
    let (m, n) = (obs.len() as f64, cols.len() as f64);
    let shared = cov_cross.trace() / s2;
    let dof = m - n - shared;
    if dof <= 0.0 {
        return Ok((sandwich, s2));
    }
    let corrected = s2 * (m - n) / dof;
    Ok((sandwich * (corrected / s2), corrected))
}

/// Covariance of the free parameters from the normal equations `ne` at `robot` over `cols`
/// (`m` residual components), the residuals taken as independent: s^2 (J^T W J)^-1 with the
/// a-posteriori variance factor s^2 = cost / (m - n) (1 when the sigmas are right). Returns
/// the matrix (internal units) and s^2; an error when J^T W J is singular (rank loss at the
/// solution).
fn covariance_from(
    robot: &Robot,
    ne: &Normal,
    m: usize,
    cols: &[usize],
) -> Result<(DMatrix<f64>, f64)> {
    let n = cols.len();
    let s2 = if m > n {
        ne.cost / (m - n) as f64
    } else {
        f64::NAN
    };
    // Scale to unit diagonal before inverting: mm and rad columns differ by orders.
    let d: Vec<f64> = (0..n).map(|i| ne.a[(i, i)].sqrt()).collect();
    let params = robot.parameters();
    let without_effect: Vec<String> = (cols.iter().zip(&d))
        .filter(|(_, v)| **v == 0.0 || !v.is_finite())
        .map(|(&c, _)| params[c].name())
        .collect();
    if !without_effect.is_empty() {
        return Err(Error::NotConverged(format!(
            "rank loss at the solution: no effect of {}",
            without_effect.join(", ")
        )));
    }
    let scaled = DMatrix::from_fn(n, n, |i, j| ne.a[(i, j)] / (d[i] * d[j]));
    let inv = scaled.cholesky().ok_or_else(|| {
        Error::NotConverged(format!(
            "rank loss at the solution: J^T W J is singular for {}",
            cols.iter()
                .map(|&c| params[c].name())
                .collect::<Vec<_>>()
                .join(", ")
        ))
    })?;
    let inv = inv.inverse();
    let cov = DMatrix::from_fn(n, n, |i, j| {
        inv[(i, j)] / (d[i] * d[j]) * if s2.is_finite() { s2 } else { 1.0 }
    });
    Ok((cov, s2))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::test_ur10 as ur10;
    use nalgebra::{DMatrix, DVector};

    /// The covariance's refusal names the parameters the rows do not move (a zero column of
    /// J), or all of them when the columns are dependent.
    #[test]
    fn rank_loss_at_the_solution_names_the_parameters() {
        let robot = ur10();
        let names: Vec<String> = robot.parameters().iter().map(|p| p.name()).collect();
        let normal = |a: DMatrix<f64>| Normal {
            g: DVector::zeros(a.nrows()),
            a,
            cost: 1.0,
        };
        let err = covariance_from(
            &robot,
            &normal(DMatrix::from_diagonal(&DVector::from_vec(vec![
                1.0, 0.0, 2.0,
            ]))),
            20,
            &[0, 1, 2],
        )
        .unwrap_err()
        .to_string();
        assert!(err.contains(&format!("no effect of {}", names[1])), "{err}");
        assert!(
            !err.contains(&names[0]) && !err.contains(&names[2]),
            "{err}"
        );
        let dependent = DMatrix::from_row_slice(2, 2, &[1.0, 1.0, 1.0, 1.0]);
        let err = covariance_from(&robot, &normal(dependent), 20, &[3, 4])
            .unwrap_err()
            .to_string();
        assert!(
            err.contains(&format!("singular for {}, {}", names[3], names[4])),
            "{err}"
        );
        let (cov, s2) =
            covariance_from(&robot, &normal(DMatrix::identity(2, 2)), 12, &[0, 1]).unwrap();
        assert!((s2 - 0.1).abs() < 1e-15 && (cov[(0, 0)] - 0.1).abs() < 1e-15);
    }
}
