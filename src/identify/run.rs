//! One identification, end to end: select the parameters, register an unknown measurement
//! frame, reduce to an identifiable subset, solve (optionally robustly), and report standard
//! deviations, correlations and outliers.

use super::candidates::candidates;
use super::identifiability::{CONDITION_WARNING, DropReason, Dropped, Identifiability, analyse};
use super::nelder_mead::solve_nelder_mead;
use super::outliers::{Outlier, dragged_fit_warning, normalized_residuals, outliers};
use super::problem::{IdentifyWorkspace, Measure, Normal, Observations, Sigmas, normal_equations};
use super::register::{Registration, check_position_scale, register};
use super::select::is_compliance;
use super::solve::{Method, Solution, SolveOptions, StopReason, covariance_of, solve_gradient};
use super::unmodelled::Unmodelled;
use crate::data::MeasurementSet;
use crate::error::{Error, Result};
use crate::model::{Convention, Field, JointType, ParamId, Robot, Slot};
use crate::stats::median;
use nalgebra::{DMatrix, DVector};

/// Robust loss for iteratively reweighted least squares.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum RobustLoss {
    /// Quadratic within k robust sigmas, linear beyond (k = 1.345).
    Huber,
    /// Logarithmic: w = 1 / (1 + (u/k)^2) (k = 2.385).
    Cauchy,
}

impl RobustLoss {
    /// Weight of a residual of `u` robust sigmas (95% efficiency constants).
    fn weight(self, u: f64) -> f64 {
        match self {
            RobustLoss::Huber => {
                let k = 1.345;
                if u <= k { 1.0 } else { k / u }
            }
            RobustLoss::Cauchy => {
                let k = 2.385;
                1.0 / (1.0 + (u / k).powi(2))
            }
        }
    }
}

/// Everything an identification needs besides the model and the data.
#[derive(Debug, Clone)]
pub struct Options {
    /// Parameter selection (see `select`): `offsets`, `full`, names, ...
    pub params: String,
    /// How to compare measurements; None: the richest the data supports.
    pub measure: Option<Measure>,
    /// Set-level sigmas (mm, rad) for rows without their own.
    pub sigmas: Sigmas,
    /// Solver, tolerances and iteration limit.
    pub solve: SolveOptions,
    /// Robust loss for iteratively reweighted least squares; None: plain least squares.
    pub robust: Option<RobustLoss>,
    /// Register a 6-DOF transform base (and tool) to the measured positions first.
    pub register: bool,
    /// Rows whose residual exceeds this many robust sigmas are reported as outliers.
    pub outlier_k: f64,
    /// Smallest sine of the angle between a parameter's scaled column and the span of the
    /// parameters kept before it (see [`super::identifiability::analyse`]).
    pub rank_tolerance: f64,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            params: "full".into(),
            measure: None,
            sigmas: Sigmas::default(),
            solve: SolveOptions::default(),
            robust: None,
            register: true,
            outlier_k: 3.0,
            rank_tolerance: super::identifiability::RANK_TOL,
        }
    }
}

/// One identified parameter, in file units (mm or deg).
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
pub struct ParamReport {
    /// Parameter name: `a3`, `theta1`, `base.x`, ...
    pub name: String,
    /// Its file unit: `mm`, `deg`, or a compliance's (`mrad/kNm`, and `mrad/kNm*kg`,
    /// `mrad/kNm*kg*m` for mass-free coefficients; [`crate::model::Field::file_unit`]).
    pub unit: String,
    /// Value in the nominal (start) model (mm or deg).
    pub nominal: f64,
    /// Identified value (mm or deg).
    pub estimate: f64,
    /// One standard deviation, s^2 (J^T W J)^-1.
    pub std: f64,
}

/// The outcome of an identification.
#[derive(Debug, Clone)]
pub struct Identified {
    /// The identified model (base or tool rows possibly re-expressed as 6-DOF transforms).
    pub robot: Robot,
    /// How measurements were compared with the model.
    pub measure: Measure,
    /// What the data could identify, and the subset that was solved for.
    pub identifiability: Identifiability,
    /// The final solve (after the last robust reweighting round).
    pub solution: Solution,
    /// a-posteriori variance factor s^2 = cost / (m - n); near 1 when the sigmas are right.
    pub variance_factor: f64,
    /// The warning where s^2 lies far above 1 and nothing else says so
    /// ([`super::plausibility::variance_factor_warning`]); `identify` gives it with
    /// [`Identified::warnings`].
    pub variance_warning: Option<String>,
    /// The solved parameters, in the order of the identifiable subset.
    pub parameters: Vec<ParamReport>,
    /// Pairs of parameters with |correlation| > 0.9.
    pub correlations: Vec<(String, String, f64)>,
    /// Rows (or pairs) beyond `outlier_k` robust sigmas, without robust weights.
    pub outliers: Vec<Outlier>,
    /// The registered base (and tool), when registration ran.
    pub registration: Option<Registration>,
    /// The solves' work, all of them counted ([`Effort`]; `solution` is the last solve).
    pub effort: Effort,
    /// The unmodelled error added to the rows' own sigmas, by kind (see
    /// [`super::unmodelled`]); none where the sigmas account for the residuals, or where
    /// every component of a kind has the same sigma (however far the residuals exceed it).
    pub unmodelled: Unmodelled,
    /// What was done that the user should know (frames re-expressed, ...).
    pub notes: Vec<String>,
    /// What may make the result unreliable (ill-conditioning, iteration limit).
    pub warnings: Vec<String>,
}

pub(crate) fn file_value(id: &ParamId, v: f64) -> f64 {
    id.field.to_file(v)
}

/// Refuses data with no more independent residual components than `k` identifiable
/// parameters. Rows that repeat one configuration add no independent equation: 20
/// measurements of one pose give 6 equations, whatever their number.
fn enough_equations(set: &MeasurementSet, obs: &Observations, k: usize) -> Result<()> {
    let distinct = {
        let mut keys: Vec<Vec<i64>> = set
            .rows
            .iter()
            .map(|m| m.q.iter().map(|v| (v * 1e9).round() as i64).collect())
            .collect();
        keys.sort_unstable();
        keys.dedup();
        keys.len()
    };
    let per_row = obs.len().div_ceil(set.rows.len().max(1));
    if distinct * per_row <= k {
        return Err(Error::Invalid(format!(
            "{}: {} rows hold {distinct} distinct configuration(s), at most {} independent \
             residual components for {k} identifiable parameters: more measurements of distinct \
             configurations are needed",
            set.source.display(),
            set.rows.len(),
            distinct * per_row,
        )));
    }
    if obs.len() <= k {
        return Err(Error::Invalid(format!(
            "{}: {} residual components for {k} identifiable parameters: more measurements are needed",
            set.source.display(),
            obs.len(),
        )));
    }
    Ok(())
}

/// The solve from `start` (Nelder-Mead or a gradient method), and with a robust loss its
/// iteratively reweighted rounds (weights from the residuals in robust sigmas, 1.4826 x the
/// median; at most 30 rounds, until no weight moves by 1e-6), each solve and round counted
/// in `effort`. `normal`: the normal equations at `start` over `cols` when the caller has
/// them (the first solve then saves a pass over the data).
fn solve_robust(
    start: &Robot,
    obs: &mut Observations,
    cols: &[usize],
    opts: &Options,
    normal: Option<Normal>,
    effort: &mut Effort,
) -> Result<Solution> {
    let mut run = |start: &Robot, obs: &Observations, normal| -> Result<Solution> {
        let s = match opts.solve.method {
            Method::Nm => solve_nelder_mead(start, obs, cols, &opts.solve),
            _ => solve_gradient(start, obs, cols, &opts.solve, normal),
        }?;
        effort.solves += 1;
        effort.iterations += s.iterations;
        Ok(s)
    };
    let mut solution = run(start, obs, normal)?;
    if let Some(loss) = opts.robust {
        for _ in 0..30 {
            let e = normalized_residuals(&solution.robot, obs);
            let scale = (1.4826 * median(&e)).max(1e-12);
            let mut change: f64 = 0.0;
            for (o, ei) in obs.items.iter_mut().zip(&e) {
                let w = loss.weight(ei / scale);
                change = change.max((w - o.weight).abs());
                o.weight = w;
            }
            solution = run(&solution.robot, obs, None)?;
            effort.robust_rounds += 1;
            if change < 1e-6 {
                break;
            }
        }
    }
    Ok(solution)
}

/// The work of an identification's solves, counted over all of them: the first, robust
/// reweighting rounds, the solves again with the unmodelled error in the sigmas and those
/// after an insignificant parameter leaves.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Effort {
    /// Nonlinear solves run.
    pub solves: usize,
    /// Their iterations, summed (Nelder-Mead: its iterations).
    pub iterations: usize,
    /// Robust reweighting rounds (0 without a robust loss).
    pub robust_rounds: usize,
}

/// Each identified parameter's nominal value, estimate and standard deviation (file units,
/// from the covariance `cov`), and the pairs correlated beyond |r| > 0.9.
fn parameter_reports(
    nominal: &Robot,
    estimate: &Robot,
    ids: &[ParamId],
    cov: &nalgebra::DMatrix<f64>,
) -> (Vec<ParamReport>, Vec<(String, String, f64)>) {
    let parameters = ids
        .iter()
        .enumerate()
        .map(|(i, id)| ParamReport {
            name: id.name(),
            unit: id.field.file_unit().to_string(),
            nominal: file_value(id, nominal.param(*id)),
            estimate: file_value(id, estimate.param(*id)),
            std: file_value(id, cov[(i, i)].sqrt()),
        })
        .collect();
    let mut correlations = Vec::new();
    for i in 0..ids.len() {
        for j in i + 1..ids.len() {
            let rho = cov[(i, j)] / (cov[(i, i)] * cov[(j, j)]).sqrt();
            if rho.abs() > 0.9 {
                correlations.push((ids[i].name(), ids[j].name(), rho));
            }
        }
    }
    (parameters, correlations)
}

/// |Correlation| from which two identified parameters are nearly aliases of each other: the
/// data determine one combination of the two, and each alone only through the last digits of
/// the residuals (a condition number below [`CONDITION_WARNING`] can hide such a pair when
/// the rest is well determined).
pub const ALIASED_CORRELATION: f64 = 0.999;

/// The warning for `correlations` (name, name, r) at or beyond [`ALIASED_CORRELATION`]; None
/// where there is none.
fn aliased_warning(correlations: &[(String, String, f64)]) -> Option<String> {
    let pairs: Vec<String> = correlations
        .iter()
        .filter(|(_, _, r)| r.abs() >= ALIASED_CORRELATION)
        .map(|(a, b, r)| format!("{a}/{b} {r:+.4}"))
        .collect();
    (!pairs.is_empty()).then(|| {
        format!(
            "nearly aliased parameters (|correlation| >= {ALIASED_CORRELATION}): {}: the data \
             determine a combination of each pair, not each one, so their estimates can lie far \
             from the robot's own values (in opposite directions) while the model fits; read \
             their standard deviations. Causes: a measure that cannot see them (positions of a \
             point on the last joint's axis hide the wrist's orientation: measure poses, or a \
             point off that axis), or a 6-DOF frame at the gimbal lock of its angles",
            pairs.join(", ")
        )
    })
}

/// A compliance is kept only when its estimate is at least this many standard deviations
/// from zero: a joint whose gravity torque is too small for the data (a light wrist) would
/// otherwise fit noise, and run to its bound. On the shipped non-geometric robot (20 seeds of
/// 30 poses, without masses) 3 gave a median validation error of 0.098 mm and a worst of
/// 0.114; 2 gave 0.095 and 0.137; 1 gave 0.097 and 0.142: the worst case decides.
pub const SIGNIFICANCE: f64 = 3.0;

/// The least significant compliance among `cols` (`t(position in cols, parameter)` its
/// estimate over its standard deviation), when |t| < [`SIGNIFICANCE`] (or t is NaN): it
/// leaves `cols` and the identifiable set, recorded as not significant. Returns its position
/// in `cols` and its parameter.
fn drop_weakest(
    params: &[ParamId],
    cols: &mut Vec<usize>,
    ident: &mut Identifiability,
    t: impl Fn(usize, usize) -> f64,
) -> Option<(usize, usize)> {
    let (k, tk) = cols
        .iter()
        .enumerate()
        .filter(|(_, c)| is_compliance(&params[**c]))
        .map(|(k, &c)| (k, t(k, c)))
        .filter(|(_, t)| t.is_nan() || t.abs() < SIGNIFICANCE)
        .min_by(|a, b| a.1.abs().total_cmp(&b.1.abs()))?;
    let c = cols.remove(k);
    ident.selected.retain(|&p| p != c);
    ident.dropped.push(Dropped {
        param: c,
        reason: DropReason::NotSignificant(tk),
    });
    Some((k, c))
}

/// Backward elimination of compliances: while one has |estimate - its value in `start`| <
/// [`SIGNIFICANCE`] std, the least significant goes back to its value in `start` (the
/// nominal's: zero unless the file gave one) and out of the set, and the rest is solved again
/// from there. Returns the final solution, set, covariance and s^2.
fn drop_insignificant(
    start: &Robot,
    mut solution: Solution,
    obs: &mut Observations,
    mut cols: Vec<usize>,
    opts: &Options,
    ident: &mut Identifiability,
    effort: &mut Effort,
) -> Result<(Solution, Vec<usize>, nalgebra::DMatrix<f64>, f64)> {
    let params = start.parameters();
    loop {
        // The solve's own normal equations at its solution, when it has them.
        let (cov, s2) = covariance_of(&solution.robot, obs, &cols, solution.normal.as_ref())?;
        let robot = &solution.robot;
        let dropped = drop_weakest(&params, &mut cols, ident, |k, c| {
            let id = params[c];
            (robot.param(id) - start.param(id)) / cov[(k, k)].max(0.0).sqrt()
        });
        let Some((_, c)) = dropped else {
            return Ok((solution, cols, cov, s2));
        };
        let id = params[c];
        let reset = solution.robot.with_param(id, start.param(id))?;
        if cols.is_empty() {
            let (cov, s2) = covariance_of(&reset, obs, &cols, None)?;
            solution.robot = reset;
            return Ok((solution, cols, cov, s2));
        }
        solution = solve_robust(&reset, obs, &cols, opts, None, effort)?;
    }
}

/// The compliances' screening before their nonlinear solve: at `start`, one Gauss-Newton
/// step of the linearised problem over `cols` (geometry and compliances together) gives every
/// estimate and its standard deviation at once; the least significant compliance (|estimate|
/// < [`SIGNIFICANCE`] std) leaves, the step is solved again without it, and so on. Only the
/// small normal matrix is solved again, not the problem: a weak compliance never enters the
/// nonlinear solve, where it would crawl towards its bound (a single joint solve from the
/// UR10's nominal ran its wrist's c5 to the bound). Returns the columns kept and the normal
/// equations at `start` over them, the joint solve's first iteration.
fn screen_compliances(
    start: &Robot,
    obs: &Observations,
    mut cols: Vec<usize>,
    ident: &mut Identifiability,
) -> (Vec<usize>, Normal) {
    let params = start.parameters();
    let mut ws = IdentifyWorkspace::new(start);
    let ne = normal_equations(start, obs, &cols, &mut ws);
    // Positions in `ne` of the columns still in.
    let mut live: Vec<usize> = (0..cols.len()).collect();
    let m = obs.len();
    let kept = |cols: Vec<usize>, live: &[usize]| {
        let k = live.len();
        let normal = Normal {
            a: DMatrix::from_fn(k, k, |i, j| ne.a[(live[i], live[j])]),
            g: DVector::from_fn(k, |i, _| ne.g[live[i]]),
            cost: ne.cost,
        };
        (cols, normal)
    };
    loop {
        let n = live.len();
        if n == 0 || m <= n {
            return kept(cols, &live);
        }
        // Unit diagonal before factorising: mm, rad and rad per N m columns differ by orders.
        let d: Vec<f64> = live.iter().map(|&i| ne.a[(i, i)].sqrt()).collect();
        if d.iter().any(|v| !(v.is_finite() && *v > 0.0)) {
            return kept(cols, &live);
        }
        let a = DMatrix::from_fn(n, n, |i, j| ne.a[(live[i], live[j])] / (d[i] * d[j]));
        let g = DVector::from_fn(n, |i, _| ne.g[live[i]] / d[i]);
        let Some(chol) = a.cholesky() else {
            return kept(cols, &live);
        };
        let y = chol.solve(&g);
        let inv = inverse_diagonal(chol.l_dirty());
        // The linearised cost after the step, and the variance factor it gives.
        let s2 = ((ne.cost - g.dot(&y)) / (m - n) as f64).max(0.0);
        let Some((i, _)) = drop_weakest(&params, &mut cols, ident, |i, _| {
            let x = y[i] / d[i];
            let std = (inv[i] * s2).sqrt() / d[i];
            x / std
        }) else {
            return kept(cols, &live);
        };
        live.remove(i);
    }
}

/// The diagonal of A^-1 from the Cholesky factor L of A = L L^T (its lower triangle; the
/// upper is ignored): (A^-1)_ii = |L^-1 e_i|^2, one forward substitution from row i each,
/// a sixth of the work of the whole inverse.
fn inverse_diagonal(l: &DMatrix<f64>) -> Vec<f64> {
    let n = l.nrows();
    let mut y = vec![0.0; n];
    // Column by column (L is stored by columns: column c below the diagonal is the
    // contiguous slice after l[(c, c)]).
    let data = l.as_slice();
    (0..n)
        .map(|i| {
            y[i..].fill(0.0);
            y[i] = 1.0;
            for c in i..n {
                y[c] /= l[(c, c)];
                let yc = y[c];
                let below = &data[c * n + c + 1..(c + 1) * n];
                for (yr, lr) in y[c + 1..].iter_mut().zip(below) {
                    *yr -= lr * yc;
                }
            }
            y[i..].iter().map(|v| v * v).sum()
        })
        .collect()
}

/// The names of `slot`'s parameters not among `candidates`, joined by commas (None when
/// all are).
fn held_fields(robot: &Robot, candidates: &[usize], slot: Slot) -> Option<String> {
    let held: Vec<String> = (robot.parameters().iter().enumerate())
        .filter(|(k, p)| p.slot == slot && !candidates.contains(k))
        .map(|(_, p)| p.name())
        .collect();
    (!held.is_empty()).then(|| held.join(", "))
}

/// The parameters left unobserved after an identification of `candidates` (indices into
/// `params`, the start model's) analysed as `ident`: the geometric ones the data found
/// without effect, and
/// those the start model marked that were not candidates (a candidate with an effect is
/// observed, solved for or regrouped with one that is).
fn unobserved(
    start: &Robot,
    params: &[ParamId],
    candidates: &[usize],
    ident: &Identifiability,
) -> Vec<ParamId> {
    let mut out: Vec<ParamId> = (start.unobserved().iter())
        .filter(|p| !candidates.iter().any(|&c| params[c] == **p))
        .copied()
        .collect();
    // A compliance without effect is one gravity cannot load (joint 1 of an upright arm):
    // it is zero for every pose, so nothing depends on it.
    out.extend(
        (ident.dropped.iter())
            .filter(|d| d.reason == DropReason::NoEffect && !is_compliance(&params[d.param]))
            .map(|d| params[d.param]),
    );
    out
}

/// The joint compliances identified below zero by more than [`SIGNIFICANCE`] std, as a
/// warning: a joint does not turn against the torque it holds, so such a compliance stands
/// in for an error the model leaves out (a reviewer's compliances identified alone on data
/// with geometric errors came out at c3 = -0.93 +- 0.098 mrad/kNm on 20 seeds of 20).
/// `ids` are the solved parameters, `reports` their values in the same order.
fn negative_compliance_warning(
    ids: &[ParamId],
    reports: &[ParamReport],
    geometry: bool,
) -> Option<String> {
    let negative: Vec<String> = (ids.iter().zip(reports))
        .filter(|(id, p)| id.field == Field::C && p.estimate < -SIGNIFICANCE * p.std)
        .map(|(_, p)| format!("{} = {:.4} +- {:.4} {}", p.name, p.estimate, p.std, p.unit))
        .collect();
    (!negative.is_empty()).then(|| {
        let causes = if geometry {
            "mass properties that are not the arm's (a centre of mass, the payload), or an \
             error of another kind (a gear's, a compliance of another joint)"
        } else {
            "the joints' geometry, which was not selected (identify it with the compliances: \
             --params full,compliance), or mass properties that are not the arm's"
        };
        // A compliance at zero passes the 3-std screen below zero by chance once in about
        // 700 (a helper's Monte Carlo: a wrist's c5 at zero, 4 of 400 seeds, accuracy
        // unharmed).
        format!(
            "negative compliance: {}: a joint does not turn against the torque it holds, so \
             the compliance stands in for an error the model leaves out: {causes}; or, a few \
             standard deviations below zero, noise (once in about 700 compliances at zero)",
            negative.join(", ")
        )
    })
}

/// Where mass-free compliance coefficients were solved, the note that they carry the
/// calibration's payload: the rows give no payload, so its moments are the same on every
/// row and regroup with the last link's, and the model holds for that payload alone.
fn mass_free_note(ids: &[ParamId]) -> Option<String> {
    ids.iter()
        .any(|id| matches!(id.field, Field::K { .. }))
        .then(|| {
            "mass-free compliance: the coefficients carry the payload the robot held while these \
         rows were measured (nothing in the rows tells it from the last link): the model holds for \
         that payload only; to move to another payload, give the robot file's [mass] table \
         (link_kg, link_com_mm, payload_kg, payload_com_mm) and identify c1..cN"
                .to_string()
        })
}

/// Where a revolute joint's `d` regroups with another revolute joint's `d` alone, their
/// axes are parallel (each `d` runs along its joint's axis in MDH and DH alike), and an MDH
/// or DH description cannot express the small tilt out of parallel a real arm has: the note
/// names each run of parallel axes and the joints an MDH description needs Hayati rows for
/// (thesis eq. 3.11: each after the run's first; a Hayati row has no `d`, so it regroups with
/// nothing). Two joints whose `d` each regroup with the base's (or each with the tool's)
/// translation along z alone are parallel too: a SCARA's axes 1, 2 and 4 all run along the
/// base's z. A reviewer's ABB arm with axis 3 tilted by 0.55 mrad fitted with s^2 = 38 and
/// nothing said why; a reviewer's SCARA with axis 2 tilted by 0.05 deg, s^2 = 43.
/// `consequence` says what the missing tilt does to the caller's figures.
pub(crate) fn parallel_axes_note(
    robot: &Robot,
    params: &[ParamId],
    ident: &Identifiability,
    consequence: &str,
) -> Option<String> {
    let revolute = |k: usize| robot.joints()[k].joint_type == JointType::Revolute;
    // Nodes: joints by index; the base's and the tool's z translation beyond them.
    let n = robot.dof();
    let (base_z, tool_z) = (n, n + 1);
    let pairs: Vec<(usize, usize)> = (ident.dropped.iter())
        .filter_map(|d| {
            let DropReason::Regroups(g) = &d.reason else {
                return None;
            };
            let (p, [(other, c)]) = (params[d.param], &g[..]) else {
                return None;
            };
            let o = params[*other];
            let (Slot::Joint(k), Field::D) = (p.slot, p.field) else {
                return None;
            };
            if !revolute(k) || (c.abs() - 1.0).abs() >= 1e-3 {
                return None;
            }
            match (o.slot, o.field) {
                (Slot::Joint(j), Field::D) if j != k && revolute(j) => Some((k, j)),
                (Slot::Base, Field::Z | Field::D) => Some((k, base_z)),
                (Slot::Tool, Field::Z | Field::D) => Some((k, tool_z)),
                _ => None,
            }
        })
        .collect();
    // Runs of parallel axes: joints linked through pairs (or through the base's or the
    // tool's z) are one run (the UR10's d3 and d4 both regroup with d2); a joint whose d
    // alone regroups with the base's z (every arm's first) is no run.
    let mut root: Vec<usize> = (0..n + 2).collect();
    fn find(root: &[usize], mut x: usize) -> usize {
        while root[x] != x {
            x = root[x];
        }
        x
    }
    for (a, b) in pairs {
        let (ra, rb) = (find(&root, a), find(&root, b));
        root[ra.max(rb)] = ra.min(rb);
    }
    let mut runs: Vec<Vec<usize>> = Vec::new();
    for k in 0..n {
        let r = find(&root, k);
        match runs.iter_mut().find(|run| find(&root, run[0]) == r) {
            Some(run) => run.push(k),
            None => runs.push(vec![k]),
        }
    }
    runs.retain(|r| r.len() >= 2);
    let list = |v: &[usize]| -> String {
        let names: Vec<String> = v.iter().map(|k| (k + 1).to_string()).collect();
        match names.split_last() {
            Some((last, [])) => last.clone(),
            Some((last, rest)) => format!("{} and {last}", rest.join(", ")),
            None => String::new(),
        }
    };
    let (mut axes, mut hayati) = (Vec::new(), Vec::new());
    for run in &mut runs {
        run.sort_unstable();
        run.dedup();
        axes.push(list(run));
        hayati.extend_from_slice(&run[1..]);
    }
    (!axes.is_empty()).then(|| {
        format!(
            "parallel axes: joints {}: an MDH or DH description cannot express the small tilt \
             out of parallel a real arm has, and {consequence}; describe the arm in MDH with \
             Hayati rows (convention = \"hayati\", thesis eq. 3.11) for joint(s) {} to identify \
             it (datasets/robots/ur10_mdh_hayati.toml is the UR10 so)",
            axes.join("; joints "),
            list(&hayati)
        )
    })
}

/// Within this many degrees of ry = +-90 deg a 6-DOF frame's rotation is solved for as turns
/// about its own axes (`Robot::with_frames_rebased`): there the Z-Y-X angles'
/// map to rotations loses rank (exactly at the lock, one axis of turn is lost; 10 deg from
/// it, the angles' columns are 6 times longer than the turn they make).
pub const REBASE_WITHIN_DEG: f64 = 10.0;

/// The base and tool slots of `robot` whose rows are 6-DOF transforms with all three
/// rotation angles among the `candidates` (indices into `params`) and ry within
/// [`REBASE_WITHIN_DEG`] of +-90 deg. (Where only some angles are selected, each keeps its
/// own meaning: a turn about the frame's own z is not the file's rz, and solving for it
/// would move the angles held.)
pub(crate) fn frames_near_lock(
    robot: &Robot,
    params: &[ParamId],
    candidates: &[usize],
) -> Vec<Slot> {
    [(Slot::Base, robot.base()), (Slot::Tool, robot.tool())]
        .into_iter()
        .filter(|(slot, row)| {
            row.convention() == Convention::Transform
                && [Field::Rz, Field::Ry, Field::Rx].iter().all(|f| {
                    (candidates.iter()).any(|&c| params[c].slot == *slot && params[c].field == *f)
                })
                && row
                    .file_value(Field::Ry)
                    .is_some_and(|ry| (90.0 - ry.abs()).abs() < REBASE_WITHIN_DEG)
        })
        .map(|(slot, _)| slot)
        .collect()
}

/// Identifies `nominal`'s selected parameters from `set`.
pub fn identify(nominal: &Robot, set: &MeasurementSet, opts: &Options) -> Result<Identified> {
    if set.rows.is_empty() {
        return Err(Error::Invalid(format!(
            "{}: no rows to identify from",
            set.source.display()
        )));
    }
    set.check_rows(nominal)?;
    let measure = opts.measure.unwrap_or_else(|| Measure::default_for(set));
    let mut obs = Observations::new(set, measure, opts.sigmas)?;
    let (completed, candidates, mut notes) = candidates(nominal, &opts.params)?;
    let mut warnings = Vec::new();
    let nominal = &completed;
    let params = nominal.parameters();

    // An unknown measurement frame: register it (and the tool) first.
    let base_free = candidates.iter().any(|&c| params[c].slot == Slot::Base);
    let tool_free = candidates.iter().any(|&c| params[c].slot == Slot::Tool);
    let tool_held = held_fields(nominal, &candidates, Slot::Tool);
    let uses_positions = matches!(measure, Measure::Pose | Measure::Position);
    if uses_positions {
        check_position_scale(nominal, set)?;
    }
    let mut start = nominal.clone();
    let mut registration = None;
    if opts.register
        && base_free
        && uses_positions
        && nominal.base().convention() == Convention::Transform
    {
        // A registration writes every field of the base (and of the tool): where some are
        // held, it would change parameters the user did not select.
        match held_fields(nominal, &candidates, Slot::Base) {
            Some(held) => notes.push(format!(
                "no registration of the measurement frame: it sets every base parameter and {held} are not selected; the solve starts from the model's base"
            )),
            None => {
                if let (true, Some(held)) = (tool_free, &tool_held) {
                    notes.push(format!(
                        "the tool is not registered with the base: a registration sets every tool parameter and {held} are not selected"
                    ));
                }
                // A frame the registration puts beyond a robot file's bounds is said as the
                // registration's, with the rows' file (`--no-register` starts from the file).
                let tool = tool_free && tool_held.is_none();
                let (r, reg) = register(nominal, set, tool, measure == Measure::Pose)
                    .map_err(|e| match e {
                        Error::Model(m) => Error::Invalid(format!(
                            "{}: the registration of the base (and tool) to the measured \
                             positions gives a frame beyond a robot file's bounds ({m}); \
                             --no-register starts the solve from the robot file's frame",
                            set.source.display()
                        )),
                        e => e,
                    })?;
                start = r;
                registration = Some(reg);
            }
        }
    }

    // A 6-DOF frame near the gimbal lock of its Z-Y-X angles is solved for as turns about
    // its own axes: at the lock its rz and rx turn it about one axis and no angle about the
    // third, which the data would then never correct (a tool along the flange's x, its
    // orientation left 0.17 deg off). The file gets the same frame in its own angles.
    let rebased = frames_near_lock(&start, &params, &candidates);
    if !rebased.is_empty() {
        start = start.with_frames_rebased(&rebased)?;
    }
    // Compliances are analysed with the rest at the (registered) nominal; they come last in
    // priority, so the geometric subset is what it would be without them.
    let mut ident = analyse(&start, &obs, &candidates, opts.rank_tolerance);
    if registration.is_some() && rebased.is_empty() {
        start = frames_left_as_given(nominal, start, &ident, &obs);
    }
    let mut cols = ident.selected.clone();
    // A compliance the data cannot tell from zero (a light wrist's) would stand in for a
    // geometric error and run to its bound in the nonlinear solve: screen them first.
    let mut first_normal = None;
    if cols.iter().any(|&c| is_compliance(&params[c])) {
        let (kept, normal) = screen_compliances(&start, &obs, cols, &mut ident);
        cols = kept;
        first_normal = Some(normal);
    }
    if cols.is_empty() {
        return Err(Error::Invalid(format!(
            "{}: the data identify none of the selected parameters (`{}`, measure {}): select \
             parameters this measure can tell apart, or measure more distinct configurations",
            set.source.display(),
            opts.params,
            measure.name()
        )));
    }
    enough_equations(set, &obs, cols.len())?;
    if ident.selected_condition_number > CONDITION_WARNING {
        warnings.push(format!(
            "the identifiable set is ill-conditioned (condition number {:.3e} > {CONDITION_WARNING:.0e} \
             on column-scaled data): estimates are sensitive to noise; add measurements spread over \
             the workspace",
            ident.selected_condition_number
        ));
    }

    let mut effort = Effort::default();
    let mut solution = solve_robust(&start, &mut obs, &cols, opts, first_normal, &mut effort)?;
    // Where the model misses by far more than the rows' own sigmas, they no longer decide
    // which rows and axes it fits: each kind's sigmas take its unmodelled error, and the
    // problem is solved again until that settles.
    let sigma_inv: Vec<[f64; 6]> = obs.items.iter().map(|o| o.inv_sigma).collect();
    let mut unmodelled = Unmodelled::default();
    for round in 0..=super::unmodelled::MAX_ROUNDS {
        let tau = super::unmodelled::estimate(&solution.robot, &obs, &sigma_inv, cols.len());
        if tau.settled(&unmodelled) {
            break;
        }
        if round == super::unmodelled::MAX_ROUNDS {
            warnings.push(format!(
                "the unmodelled error added to the sigmas did not settle in {round} rounds \
                 (last {}, then {}): the weights are those of the last round",
                unmodelled.describe().unwrap_or_else(|| "none".into()),
                tau.describe().unwrap_or_else(|| "none".into())
            ));
            break;
        }
        unmodelled = tau;
        super::unmodelled::apply(&mut obs, &sigma_inv, &unmodelled);
        solution = solve_robust(&solution.robot, &mut obs, &cols, opts, None, &mut effort)?;
    }
    if solution.stop == StopReason::MaxIterations {
        warnings.push(format!(
            "stopped at the iteration limit ({}) before any tolerance: the result may be unconverged",
            solution.iterations
        ));
    }

    let (mut solution, cols, cov, s2) = drop_insignificant(
        nominal,
        solution,
        &mut obs,
        cols,
        opts,
        &mut ident,
        &mut effort,
    )?;
    solution.robot = solution.robot.plain()?;
    let misfit = super::plausibility::warning(
        &solution.robot,
        &obs,
        registration.is_some(),
        tool_held.is_none(),
        opts.robust.is_some(),
    );
    let misfit_far = misfit.is_some();
    // A model that does not describe its data says so already; one that does, but as
    // another arm, was started from another robot's file.
    let another = misfit
        .is_none()
        .then(|| super::plausibility::another_arm_warning(nominal, &solution.robot))
        .flatten();
    warnings.extend(misfit);
    // A model far off its rows says so already (the misfit warning), and an unmodelled
    // error added to the sigmas has its note. Apart from the warnings: a refinement in
    // `train` (which learns what the model leaves) does not pass it on.
    let variance_warning = (unmodelled.describe().is_none() && !misfit_far)
        .then(|| {
            let dof = obs.len().saturating_sub(cols.len());
            let compliance = cols.iter().any(|&c| is_compliance(&params[c]));
            super::plausibility::variance_factor_warning(s2, dof, compliance)
        })
        .flatten();
    warnings.extend(super::plausibility::copied_warning(set));
    let candidate_ids: Vec<ParamId> = candidates.iter().map(|&c| params[c]).collect();
    warnings.extend(super::plausibility::held_joints_warning(
        nominal,
        set,
        &candidate_ids,
    ));
    warnings.extend(another);
    let ids: Vec<ParamId> = cols.iter().map(|&c| params[c]).collect();
    notes.extend(super::plausibility::gimbal_notes(
        &solution.robot,
        &ids,
        &rebased,
    ));
    let (parameters, correlations) = parameter_reports(nominal, &solution.robot, &ids, &cov);
    warnings.extend(aliased_warning(&correlations));
    // The joints' geometry: base and tool alone leave the arm's errors to the compliances.
    let geometry = (candidates.iter())
        .any(|&c| matches!(params[c].slot, Slot::Joint(_)) && !is_compliance(&params[c]));
    warnings.extend(negative_compliance_warning(&ids, &parameters, geometry));
    notes.extend(mass_free_note(&ids));
    notes.extend(parallel_axes_note(
        nominal,
        &params,
        &ident,
        "what it leaves stays in the residuals (see s^2)",
    ));
    let outliers = outliers(set, &obs, &solution.robot, opts.outlier_k);
    if misfit_far && outliers.is_empty() {
        warnings.extend(dragged_fit_warning(
            set,
            &obs,
            &start,
            opts.outlier_k,
            opts.robust.is_some(),
        ));
    }
    let robot =
        solution
            .robot
            .with_unobserved(&unobserved(nominal, &params, &candidates, &ident))?;
    if !robot.unobserved().is_empty() {
        let names: Vec<String> = robot.unobserved().iter().map(|p| p.name()).collect();
        notes.push(format!(
            "unobserved: {} (no effect on these measurements): they keep the start model's \
             values, the model file marks them ([calibration] unobserved), and fk, ik, predict and \
             compensate warn where a result depends on them",
            names.join(", ")
        ));
    }
    Ok(Identified {
        robot,
        measure,
        identifiability: ident,
        solution,
        variance_factor: s2,
        variance_warning,
        parameters,
        correlations,
        outliers,
        registration,
        effort,
        unmodelled,
        notes,
        warnings,
    })
}

/// The relative rise of the start's cost within which [`frames_left_as_given`] hands a
/// registered frame parameter's change to the parameters it regroups with.
const START_COST_SLACK: f64 = 1e-3;

/// `start` (registered) with the base and tool parameters the data leave out back at the
/// values of `nominal` (the file's), the change the registration made to each carried by the
/// kept parameters it regroups with (a change dp of it acts as c dp of each, c its
/// coefficient; one without effect carries none): the registration sets every base and tool
/// field, and where the data cannot tell one from its partners (a SCARA's tool.z from its
/// base.z) it would keep an arbitrary share (tool.z 90.8 mm for the file's 100, base.z -8.5 mm
/// for the truth's 0 with d3 +0.7), which a user would copy into a controller's frame.
/// Kept only where the model's cost on the rows stays within [`START_COST_SLACK`] of
/// `start`'s: a regrouping holds to first order (the SCARA's tool.z and base.z are parallel
/// but for the registered base's tilt: 6.5e-7 of the cost), a large rotation moved so might
/// not; the solve then fits the kept parameters as from any start.
fn frames_left_as_given(
    nominal: &Robot,
    start: Robot,
    ident: &Identifiability,
    obs: &Observations,
) -> Robot {
    use std::f64::consts::PI;
    let params = nominal.parameters();
    let mut moves: Vec<(ParamId, f64)> = Vec::new();
    for d in &ident.dropped {
        let id = params[d.param];
        if !matches!(id.slot, Slot::Base | Slot::Tool) {
            continue;
        }
        let mut back = nominal.param(id) - start.param(id);
        // An angle's change the short way round (a registered 179 deg for the file's -179 is
        // 2 deg, not 358).
        if id.field.is_angle() {
            back = (back + PI).rem_euclid(2.0 * PI) - PI;
        }
        if back == 0.0 {
            continue;
        }
        moves.push((id, nominal.param(id)));
        if let DropReason::Regroups(with) = &d.reason {
            for &(k, c) in with {
                let kid = params[k];
                let at = moves
                    .iter()
                    .position(|(m, _)| *m == kid)
                    .unwrap_or_else(|| {
                        moves.push((kid, start.param(kid)));
                        moves.len() - 1
                    });
                moves[at].1 -= c * back;
            }
        }
    }
    if moves.is_empty() {
        return start;
    }
    let Ok(moved) = start.with_params(&moves) else {
        return start;
    };
    let mut ws = IdentifyWorkspace::new(&start);
    let before = super::problem::cost(&start, obs, &mut ws);
    let after = super::problem::cost(&moved, obs, &mut ws);
    if after.is_finite() && after <= before * (1.0 + START_COST_SLACK) {
        moved
    } else {
        start
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_nearly_aliased_pairs_are_warned_of() {
        let pair = |r: f64| ("theta5".to_string(), "a5".to_string(), r);
        assert_eq!(aliased_warning(&[pair(0.95), pair(-0.9989)]), None);
        let w = aliased_warning(&[pair(0.95), pair(0.99961), pair(-0.9991)]).unwrap();
        assert!(
            w.contains("theta5/a5 +0.9996, theta5/a5 -0.9991:") && !w.contains("+0.9500"),
            "{w}"
        );
    }

    #[test]
    fn inverse_diagonal_is_the_inverses() {
        let b = DMatrix::from_fn(7, 7, |i, j| ((i * 7 + j) as f64 * 0.37).sin());
        let a = &b * b.transpose() + DMatrix::identity(7, 7) * 0.1;
        let chol = a.clone().cholesky().unwrap();
        let diag = inverse_diagonal(chol.l_dirty());
        let inv = a.try_inverse().unwrap();
        for (i, d) in diag.iter().enumerate() {
            assert!(
                (d - inv[(i, i)]).abs() < 1e-9 * inv[(i, i)].abs(),
                "{i}: {d} {}",
                inv[(i, i)]
            );
        }
    }
}
