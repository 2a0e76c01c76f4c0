//! The least-squares problem: residuals of measurements against a model, weighted by
//! W = diag(1/sigma^2) (thesis eq. 4.29-4.31), and their Jacobian (eq. 4.22-4.23, 4.37).
//!
//! One *observation* is one measured row (pose, position, orientation) or one pair of rows
//! (relative position: 3 components; distance: 1). Its residual is y - f(q, p):
//! - pose: [p_meas - p_model (mm); rotvec(R_meas R_model^T) (rad)];
//! - relative (thesis eq. 4.38): (p_a - p_b)_meas - (p_a - p_b)_model, Jacobian J_a - J_b;
//! - distance: |p_a - p_b|_meas - |p_a - p_b|_model, Jacobian u^T (J_a - J_b).
//!
//! Each component is divided by its sigma (a robust weight w scales it by sqrt(w) more), so the
//! problem is min sum r_w^2. Rows are processed in blocks: the normal equations (or the R of a
//! QR factorisation) are accumulated, so memory grows with the parameter count, not the rows.

use super::jacobian::parameter_jacobian;
use crate::data::MeasurementSet;
use crate::data::pairs::{Pair, pairs};
use crate::error::{Error, Result};
use crate::geometry::rotation::rotation_vector;
use crate::kinematics::{Frames, Pose, frames, tool_pose};
use crate::model::Robot;
use nalgebra::{DMatrix, DVector, DVectorView, Matrix6xX, Vector3};

/// How measurements are compared with the model.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Measure {
    /// Position and orientation of each row.
    Pose,
    /// Position of each row.
    Position,
    /// Orientation of each row.
    Orientation,
    /// Displacement p(a) - p(b) of each pair of rows.
    Relative,
    /// Length of that displacement (a ball-bar's distance).
    Distance,
}

impl Measure {
    /// The richest measure the set supports: pose, else position, else orientation, else
    /// distance.
    pub fn default_for(set: &MeasurementSet) -> Measure {
        match (set.has_position(), set.has_rotation()) {
            (true, true) => Measure::Pose,
            (true, false) => Measure::Position,
            (false, true) => Measure::Orientation,
            (false, false) => Measure::Distance,
        }
    }

    /// Lower-case name, as in files and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Measure::Pose => "pose",
            Measure::Position => "position",
            Measure::Orientation => "orientation",
            Measure::Relative => "relative",
            Measure::Distance => "distance",
        }
    }
}

/// Set-level noise, used where rows carry no sigma of their own.
#[derive(Debug, Clone, Copy)]
pub struct Sigmas {
    /// Per position coordinate (mm).
    pub position_mm: f64,
    /// Per orientation component (rad).
    pub rotation_rad: f64,
}

impl Default for Sigmas {
    /// The thesis's Leica LTD500 + T-Mac: 0.033 mm, 0.174 mrad.
    fn default() -> Self {
        Sigmas {
            position_mm: 0.033,
            rotation_rad: 0.174e-3,
        }
    }
}

/// One observation: its row(s) and the inverse sigma of each residual component.
#[derive(Debug, Clone)]
pub struct Observation {
    /// Index of the measured row (the pair's first row for relative and distance).
    pub a: usize,
    /// Index of the pair's second row; None for single-row measures.
    pub b: Option<usize>,
    /// 1/sigma of each residual component, in the order of the residual (1/mm for position
    /// components, 1/rad for orientation ones); unused components are 1.
    pub inv_sigma: [f64; 6],
    /// Robust weight (IRLS), 1 by default.
    pub weight: f64,
}

/// The observations of a measurement set under one measure.
#[derive(Debug, Clone)]
pub struct Observations<'a> {
    /// The measurement set the observations index into.
    pub set: &'a MeasurementSet,
    /// How the rows are compared with the model.
    pub measure: Measure,
    /// One observation per row, or per pair for relative and distance.
    pub items: Vec<Observation>,
    /// For relative and distance: each row's position sigma (mm per coordinate, its own or
    /// the set-level one), which the pairs that share the row share
    /// ([`super::chained`]); empty for the other measures.
    pub row_sigma_mm: Vec<Vector3<f64>>,
}

impl<'a> Observations<'a> {
    /// Builds the observations; an error when the set lacks what the measure needs.
    pub fn new(set: &'a MeasurementSet, measure: Measure, sigmas: Sigmas) -> Result<Self> {
        let need = |ok: bool, what: &str| {
            if ok {
                Ok(())
            } else {
                Err(Error::Invalid(format!(
                    "{}: measuring by {} needs {what} in every row",
                    set.source.display(),
                    measure.name()
                )))
            }
        };
        for s in [sigmas.position_mm, sigmas.rotation_rad] {
            if !(s.is_finite() && s > 0.0) {
                return Err(Error::Invalid(format!("sigma {s} must be positive")));
            }
        }
        let sp = |i: usize| {
            set.rows[i]
                .sigma_position
                .unwrap_or(Vector3::repeat(sigmas.position_mm))
        };
        let sr = |i: usize| {
            set.rows[i]
                .sigma_rotation
                .unwrap_or(Vector3::repeat(sigmas.rotation_rad))
        };
        let mut items = Vec::new();
        match measure {
            Measure::Pose | Measure::Position | Measure::Orientation => {
                match measure {
                    Measure::Pose => need(
                        set.has_position() && set.has_rotation(),
                        "position and orientation",
                    )?,
                    Measure::Position => need(set.has_position(), "a position")?,
                    _ => need(set.has_rotation(), "an orientation")?,
                }
                for i in 0..set.rows.len() {
                    let (p, r) = (sp(i), sr(i));
                    let inv = match measure {
                        Measure::Pose => [p.x, p.y, p.z, r.x, r.y, r.z],
                        Measure::Position => [p.x, p.y, p.z, 1.0, 1.0, 1.0],
                        _ => [r.x, r.y, r.z, 1.0, 1.0, 1.0],
                    }
                    .map(|s| 1.0 / s);
                    items.push(Observation {
                        a: i,
                        b: None,
                        inv_sigma: inv,
                        weight: 1.0,
                    });
                }
            }
            Measure::Relative | Measure::Distance => {
                // Read as absent, such a column would leave pairs chained in file order, or
                // distances found from the positions, without a word. Relative reads no
                // distance.
                let [pair, distance] = &set.other_case_pair_columns;
                let read = [
                    (
                        pair,
                        "the label of each row's pair",
                        "the pairs chained in file order",
                    ),
                    (
                        distance,
                        "each pair's distance",
                        "the distances found from the positions",
                    ),
                ];
                let reads_distance = measure == Measure::Distance;
                if let Some((Some((name, header)), what, then)) = (read.into_iter())
                    .enumerate()
                    .find(|(k, (found, ..))| found.is_some() && (reads_distance || *k == 0))
                    .map(|(_, r)| r)
                {
                    return Err(Error::Invalid(format!(
                        "{}: measuring by {} reads {what} from a `{name}` column, but the header \
                         has `{}`: column names are case-sensitive, so it would be read as \
                         absent, and {then}; rename it `{name}`, or name it in a profile",
                        set.source.display(),
                        measure.name(),
                        crate::data::table::shown(header),
                    )));
                }
                if measure == Measure::Relative {
                    need(set.has_position(), "a position")?;
                }
                // Consecutive rows pair up (1, 2), (2, 3), ...: the first row's distance is
                // of no pair, and would be dropped unread (a 0 there is taken as a blank).
                if measure == Measure::Distance
                    && set.rows.iter().all(|m| m.pair.is_none())
                    && let Some(first) = set.rows.first()
                    && first.distance.is_some_and(|d| d != 0.0)
                {
                    return Err(Error::Invalid(format!(
                        "{}: line {}: a distance on the first row: consecutive rows pair up \
                         (1, 2), (2, 3), ..., each distance on the pair's second row, so the \
                         first row's is of no pair (give a pair column, or leave it empty)",
                        set.source.display(),
                        first.line
                    )));
                }
                for Pair { a, b } in pairs(set)? {
                    let s =
                        (sp(a).component_mul(&sp(a)) + sp(b).component_mul(&sp(b))).map(f64::sqrt);
                    let inv = if measure == Measure::Relative {
                        [1.0 / s.x, 1.0 / s.y, 1.0 / s.z, 1.0, 1.0, 1.0]
                    } else {
                        // A labelled pair's distance is read from its second row: one on its
                        // first row would be dropped unread.
                        if set.rows[a].pair.is_some() && set.rows[a].distance.is_some() {
                            return Err(Error::Invalid(format!(
                                "{}: line {}: a distance on the first row of pair `{}`: a \
                                 pair's distance is read from its second row (line {})",
                                set.source.display(),
                                set.rows[a].line,
                                set.rows[a].pair.as_deref().unwrap_or(""),
                                set.rows[b].line
                            )));
                        }
                        if crate::data::pairs::distance(set, Pair { a, b }).is_none() {
                            return Err(Error::Invalid(format!(
                                "{}: line {}: pair has no distance (a `distance` column on its second row, or positions)",
                                set.source.display(),
                                set.rows[b].line
                            )));
                        }
                        [
                            1.0 / (s.norm_squared() / 3.0).sqrt(),
                            1.0,
                            1.0,
                            1.0,
                            1.0,
                            1.0,
                        ]
                    };
                    items.push(Observation {
                        a,
                        b: Some(b),
                        inv_sigma: inv,
                        weight: 1.0,
                    });
                }
            }
        }
        let row_sigma_mm = match measure {
            Measure::Relative | Measure::Distance => (0..set.rows.len()).map(sp).collect(),
            _ => Vec::new(),
        };
        Ok(Observations {
            set,
            measure,
            items,
            row_sigma_mm,
        })
    }

    /// Number of residual components of one observation.
    pub fn dim(&self) -> usize {
        match self.measure {
            Measure::Pose => 6,
            Measure::Position | Measure::Orientation | Measure::Relative => 3,
            Measure::Distance => 1,
        }
    }

    /// Total number of residual components.
    pub fn len(&self) -> usize {
        self.items.len() * self.dim()
    }

    /// Whether there are no observations.
    pub fn is_empty(&self) -> bool {
        self.items.is_empty()
    }
}

/// Scratch space for evaluating observations.
#[derive(Debug, Clone)]
pub struct IdentifyWorkspace {
    fa: Frames,
    fb: Frames,
    ja: Matrix6xX<f64>,
    jb: Matrix6xX<f64>,
}

impl IdentifyWorkspace {
    /// A workspace sized for `robot`.
    pub fn new(robot: &Robot) -> Self {
        IdentifyWorkspace {
            fa: Frames::new(robot),
            fb: Frames::new(robot),
            ja: Matrix6xX::zeros(0),
            jb: Matrix6xX::zeros(0),
        }
    }
}

/// The tool pose at commanded joints `q`; with `cols`, also its parameter Jacobian into `jac`
/// (through the frames in `ws`). Without, [`tool_pose`] alone: the same bits without the
/// frames, the gravity load's derivatives or a compliant robot's second walk's stores.
fn tool_of(
    robot: &Robot,
    q: &[f64],
    cols: Option<&[usize]>,
    ws: &mut Frames,
    jac: &mut Matrix6xX<f64>,
) -> Pose {
    match cols {
        Some(c) => {
            frames(robot, q, ws);
            parameter_jacobian(robot, ws, c, jac);
            ws.tool
        }
        None => tool_pose(robot, q),
    }
}

/// The unweighted residual (mm, rad) of every observation of `obs` at `robot`, in order: the
/// first `obs.dim()` components of each, as [`residual`] gives them.
pub fn residuals(robot: &Robot, obs: &Observations) -> Vec<[f64; 6]> {
    let mut ws = IdentifyWorkspace::new(robot);
    let mut jac = Matrix6xX::zeros(0);
    (obs.items.iter())
        .map(|o| {
            let mut r = [0.0; 6];
            residual(robot, obs, o, None, &mut ws, &mut r, &mut jac);
            r
        })
        .collect()
}

/// Unweighted residual (y - f) of observation `o` into `r[..dim]`; with `cols`, also the
/// model Jacobian of the same components (dim x cols.len()) into `jac`'s first rows.
///
/// Position, displacement and distance rows are exact derivatives of f. A rotation residual
/// is log(M R^-1) (rad) and its rows are the tool's angular velocity per parameter, the
/// derivative of the log at a zero residual only (the inverse Jacobian of SO(3), I + \[r\]x/2 +
/// ..., left out): Gauss-Newton's approximation, off by O(|r|) row by row. The gradient it
/// gives is exact where a row's three rotation sigmas are equal (J^-1(r)^T r = r), so the
/// solve stops at the exact minimum; only the step's curvature is approximate.
pub fn residual(
    robot: &Robot,
    obs: &Observations,
    o: &Observation,
    cols: Option<&[usize]>,
    ws: &mut IdentifyWorkspace,
    r: &mut [f64; 6],
    jac: &mut Matrix6xX<f64>,
) {
    let set = obs.set;
    let ma = &set.rows[o.a];
    let ta = tool_of(robot, &ma.q, cols, &mut ws.fa, &mut ws.ja);
    let pa = ta.translation.vector;
    match obs.measure {
        Measure::Pose | Measure::Position | Measure::Orientation => {
            let dp = ma.position.map(|p| p - pa).unwrap_or_default();
            let dr = ma
                .rotation
                .map(|m| rotation_vector(&(m * ta.rotation.inverse())))
                .unwrap_or_default();
            let (first, second) = match obs.measure {
                Measure::Pose => (dp, Some(dr)),
                Measure::Position => (dp, None),
                _ => (dr, None),
            };
            r[..3].copy_from_slice(first.as_slice());
            if let Some(s) = second {
                r[3..6].copy_from_slice(s.as_slice());
            }
            if cols.is_some() {
                if obs.measure == Measure::Orientation {
                    let rot = ws.ja.fixed_rows::<3>(3).clone_owned();
                    jac.copy_from(&ws.ja);
                    jac.fixed_rows_mut::<3>(0).copy_from(&rot);
                } else {
                    jac.copy_from(&ws.ja);
                }
            }
        }
        Measure::Relative | Measure::Distance => {
            let b = o.b.unwrap_or(o.a);
            let mb = &set.rows[b];
            let tb = tool_of(robot, &mb.q, cols, &mut ws.fb, &mut ws.jb);
            let d_model = pa - tb.translation.vector;
            if obs.measure == Measure::Relative {
                let d_meas = ma.position.unwrap_or_default() - mb.position.unwrap_or_default();
                r[..3].copy_from_slice((d_meas - d_model).as_slice());
                if cols.is_some() {
                    jac.copy_from(&ws.ja);
                    *jac -= &ws.jb;
                }
            } else {
                let len = d_model.norm();
                let meas = crate::data::pairs::distance(set, Pair { a: o.a, b }).unwrap_or(0.0);
                r[0] = meas - len;
                if cols.is_some() {
                    let u = if len > 0.0 {
                        d_model / len
                    } else {
                        Vector3::zeros()
                    };
                    let diff = ws.ja.fixed_rows::<3>(0) - ws.jb.fixed_rows::<3>(0);
                    let row = u.transpose() * diff;
                    jac.row_mut(0).copy_from(&row);
                }
            }
        }
    }
}

/// Rows per block when accumulating.
const BLOCK: usize = 240;

/// Runs over all observations, handing weighted blocks `(J_w, r_w, rows)` to `sink`.
/// With `cols = None` only residuals are computed (the Jacobian block is empty).
pub fn for_each_block(
    robot: &Robot,
    obs: &Observations,
    cols: Option<&[usize]>,
    ws: &mut IdentifyWorkspace,
    mut sink: impl FnMut(&DMatrix<f64>, &DVector<f64>, usize),
) {
    let k = cols.map_or(0, |c| c.len());
    let dim = obs.dim();
    let mut jb = DMatrix::<f64>::zeros(BLOCK, k);
    let mut rb = DVector::<f64>::zeros(BLOCK);
    let mut jac = Matrix6xX::<f64>::zeros(k);
    let mut r = [0.0; 6];
    let mut fill = 0;
    for o in &obs.items {
        residual(robot, obs, o, cols, ws, &mut r, &mut jac);
        let sw = o.weight.sqrt();
        for c in 0..dim {
            let w = o.inv_sigma[c] * sw;
            rb[fill] = r[c] * w;
            if k > 0 {
                for j in 0..k {
                    jb[(fill, j)] = jac[(c, j)] * w;
                }
            }
            fill += 1;
        }
        if fill + dim > BLOCK {
            sink(&jb, &rb, fill);
            fill = 0;
        }
    }
    if fill > 0 {
        sink(&jb, &rb, fill);
    }
}

/// Weighted sum of squares sum r_w^2 (chi-square when the sigmas are right).
pub fn cost(robot: &Robot, obs: &Observations, ws: &mut IdentifyWorkspace) -> f64 {
    let mut total = 0.0;
    for_each_block(robot, obs, None, ws, |_, r, rows| {
        total += r.rows(0, rows).norm_squared();
    });
    total
}

/// Normal equations of the weighted problem: A = J_w^T J_w, g = J_w^T r_w, and the cost.
#[derive(Debug, Clone)]
pub struct Normal {
    /// A = J_w^T J_w (k x k, k = `cols.len()`; entry (i, j) per unit of parameter i times
    /// unit of parameter j, mm or rad).
    pub a: DMatrix<f64>,
    /// g = J_w^T r_w (k entries, each per unit of its parameter).
    pub g: DVector<f64>,
    /// Weighted sum of squares sum r_w^2 (dimensionless).
    pub cost: f64,
}

/// Accumulates the normal equations for the parameters `cols`.
pub fn normal_equations(
    robot: &Robot,
    obs: &Observations,
    cols: &[usize],
    ws: &mut IdentifyWorkspace,
) -> Normal {
    let k = cols.len();
    let mut out = Normal {
        a: DMatrix::zeros(k, k),
        g: DVector::zeros(k),
        cost: 0.0,
    };
    normal_equations_into(robot, obs, cols, ws, &mut out);
    out
}

/// [`normal_equations`] into `out`, reusing its matrix and vector (resized if `cols` has
/// another length).
pub fn normal_equations_into(
    robot: &Robot,
    obs: &Observations,
    cols: &[usize],
    ws: &mut IdentifyWorkspace,
    out: &mut Normal,
) {
    let k = cols.len();
    if out.a.nrows() != k || out.a.ncols() != k {
        out.a = DMatrix::zeros(k, k);
        out.g = DVector::zeros(k);
    }
    out.a.fill(0.0);
    out.g.fill(0.0);
    let mut total = 0.0;
    let (a, g) = (&mut out.a, &mut out.g);
    for_each_block(robot, obs, Some(cols), ws, |jb, rb, rows| {
        add_gram_upper(a, jb, rows);
        let j = jb.rows(0, rows);
        let r = rb.rows(0, rows);
        g.gemv_tr(1.0, &j, &r, 1.0);
        total += r.norm_squared();
    });
    a.fill_lower_triangle_with_upper_triangle();
    out.cost = total;
}

/// a += J^T J over J's first `rows` rows, upper triangle only (J^T J is symmetric: half the
/// work of a general product; the caller mirrors it). Each entry takes the bits of
/// nalgebra's `gemm_tr`, which the identification used before: a_ij + J_i . J_j with
/// nalgebra's own `dot`.
fn add_gram_upper(a: &mut DMatrix<f64>, j: &DMatrix<f64>, rows: usize) {
    let (stride, k) = (j.nrows(), j.ncols());
    let data = j.as_slice();
    let column = |c: usize| &data[c * stride..c * stride + rows];
    for c in 0..k {
        let jc = column(c);
        let out = &mut a.as_mut_slice()[c * k..c * k + c + 1];
        for (i, v) in out.iter_mut().enumerate() {
            *v += dot(column(i), jc);
        }
    }
}

/// x . y by nalgebra's `dot` (the order of additions `gemm_tr` and `gemv_tr` use), on slices.
fn dot(x: &[f64], y: &[f64]) -> f64 {
    DVectorView::from_slice(x, x.len()).dot(&DVectorView::from_slice(y, y.len()))
}

/// The k x k triangular factor R of the weighted observation matrix (Phi_w = Q R), built
/// block by block; its singular values are those of Phi_w, without squaring them. With
/// fewer rows than k, R keeps all k rows, the extra ones zero: where a column is zero its
/// reflection is skipped, and what the rows hold lands in a later row of R.
pub fn observation_r(
    robot: &Robot,
    obs: &Observations,
    cols: &[usize],
    ws: &mut IdentifyWorkspace,
) -> DMatrix<f64> {
    let k = cols.len();
    let mut r = DMatrix::<f64>::zeros(k, k);
    let mut block: Vec<f64> = Vec::with_capacity(BLOCK * k);
    for_each_block(robot, obs, Some(cols), ws, |jb, _, rows| {
        block.clear();
        for c in 0..k {
            block.extend_from_slice(&jb.column(c).as_slice()[..rows]);
        }
        absorb_rows(&mut r, &mut block, rows);
    });
    r
}

/// Folds the rows of `block` (`rows` x k, by columns) into the upper triangular `r` (k x k):
/// afterwards r^T r gains block^T block. One Householder reflection per column j, acting on
/// r's row j and the block's rows only (the rows of r below j are zero in columns up to j):
/// 2 rows k^2 flops, where a QR of r stacked on the block would also work through r's k
/// rows. The block is left overwritten.
fn absorb_rows(r: &mut DMatrix<f64>, block: &mut [f64], rows: usize) {
    let k = r.ncols();
    let rs = r.as_mut_slice();
    for j in 0..k {
        let (head, tail) = block.split_at_mut((j + 1) * rows);
        let v = &mut head[j * rows..];
        let below = v.iter().map(|x| x * x).sum::<f64>().sqrt();
        if below == 0.0 {
            continue;
        }
        // The reflection maps (x0, v) to (beta, 0): beta of x0's opposite sign, so that
        // x0 - beta never cancels; v is scaled to the reflector's tail (its head is 1).
        let x0 = rs[j * k + j];
        let beta = -x0.signum() * x0.hypot(below);
        let tau = (beta - x0) / beta;
        let scale = 1.0 / (x0 - beta);
        for x in v.iter_mut() {
            *x *= scale;
        }
        rs[j * k + j] = beta;
        for (c, bc) in tail.chunks_exact_mut(rows).enumerate() {
            let at = (j + 1 + c) * k + j;
            let f = tau * (rs[at] + dot(v, bc));
            rs[at] -= f;
            for (y, x) in bc.iter_mut().zip(v.iter()) {
                *y -= f * x;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Uniform in [-1, 1) (xorshift).
    fn random(seed: &mut u64) -> f64 {
        *seed ^= *seed << 13;
        *seed ^= *seed >> 7;
        *seed ^= *seed << 17;
        (*seed >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
    }

    /// Rows `start..start + rows` of `all`, by columns (the layout `absorb_rows` takes).
    fn block_of(all: &DMatrix<f64>, start: usize, rows: usize) -> Vec<f64> {
        let mut block = Vec::with_capacity(rows * all.ncols());
        for c in all.column_iter() {
            block.extend(c.rows(start, rows).iter());
        }
        block
    }

    /// Block after block, r stays upper triangular with r^T r = J^T J, and its singular
    /// values are those of nalgebra's QR of all rows at once (columns of very different
    /// scales and one repeated column, as in an identification; a zero column too).
    #[test]
    fn absorbed_rows_give_the_triangular_factor() {
        let (k, n) = (9, 3 * 7 + 5);
        let mut seed = 0x9e37_79b9_7f4a_7c15_u64;
        let scales = [1e3, 1.0, 1e-3, 5.0, 0.0, 2.0, 1e2, 1.0, 1.0];
        let mut all = DMatrix::from_fn(n, k, |_, c| random(&mut seed) * scales[c]);
        let col7 = all.column(7).into_owned();
        all.column_mut(8).copy_from(&col7);
        let mut r = DMatrix::<f64>::zeros(k, k);
        let mut done = 0;
        for rows in [7, 3, 7, 1, 7, 1] {
            absorb_rows(&mut r, &mut block_of(&all, done, rows), rows);
            done += rows;
        }
        assert_eq!(done, n);
        for c in 0..k {
            for i in c + 1..k {
                assert_eq!(r[(i, c)], 0.0);
            }
        }
        let gram = all.transpose() * &all;
        let ours = r.transpose() * &r;
        assert!((ours - &gram).norm() <= 1e-12 * gram.norm());
        let mut a: Vec<f64> = r.singular_values().iter().copied().collect();
        let mut b: Vec<f64> = all
            .clone()
            .qr()
            .r()
            .singular_values()
            .iter()
            .copied()
            .collect();
        a.sort_by(f64::total_cmp);
        b.sort_by(f64::total_cmp);
        let top = b[k - 1];
        for (x, y) in a.iter().zip(&b) {
            assert!((x - y).abs() <= 1e-12 * top, "{x} vs {y}");
        }
        // Two exact zeros: the zero column and the repeated one, to rounding.
        assert!(
            a[0] <= 1e-12 * top && a[1] <= 1e-12 * top && a[2] > 1e-9 * top,
            "{a:?}"
        );
    }

    /// Fewer rows than columns, the first column zero: nothing the rows hold is lost (its
    /// skipped reflection leaves the first row of r zero and fills the next).
    #[test]
    fn absorbed_rows_keep_everything_with_fewer_rows_than_columns() {
        let k = 5;
        let mut seed = 0x1234_5678_9abc_def1_u64;
        let all = DMatrix::from_fn(3, k, |_, c| if c == 0 { 0.0 } else { random(&mut seed) });
        let mut r = DMatrix::<f64>::zeros(k, k);
        for (start, rows) in [(0, 1), (1, 2)] {
            absorb_rows(&mut r, &mut block_of(&all, start, rows), rows);
        }
        assert!(r.row(0).iter().all(|&x| x == 0.0) && r.row(1).norm() > 0.0);
        let gram = all.transpose() * &all;
        assert!((r.transpose() * &r - &gram).norm() <= 1e-14 * gram.norm());
        for c in 1..k {
            assert!((r.column(c).norm() - all.column(c).norm()).abs() <= 1e-14);
        }
    }

    /// The symmetric accumulation gives nalgebra's `gemm_tr` bits, block after block, for
    /// every row count around the chunk of eight (and a full block).
    #[test]
    fn gram_matches_gemm_tr_to_the_bit() {
        let k = 13;
        let mut seed = 0x2545_f491_4f6c_dd1d_u64;
        let mut ours = DMatrix::<f64>::zeros(k, k);
        let mut theirs = DMatrix::<f64>::zeros(k, k);
        for rows in (0..=25).chain([BLOCK]) {
            let j = DMatrix::from_fn(BLOCK, k, |_, _| random(&mut seed) * 1e3);
            add_gram_upper(&mut ours, &j, rows);
            let jr = j.rows(0, rows);
            theirs.gemm_tr(1.0, &jr, &jr, 1.0);
        }
        ours.fill_lower_triangle_with_upper_triangle();
        assert!(theirs.norm() > 1e6);
        for (a, b) in ours.iter().zip(theirs.iter()) {
            assert_eq!(a.to_bits(), b.to_bits(), "{a} vs {b}");
        }
    }
}
