//! What each candidate unit tells about the parameters: its noise-weighted, column-scaled
//! Jacobian block, from which a plan's information matrix is summed.
//!
//! For unit u with weighted Jacobian J_u (dim x p: rows divided by their sigma, thesis
//! eq. 4.41), the information of a set of units U is M = sum_{u in U} J_u^T J_u, and the
//! covariance of the least-squares estimate from their measurements is M^-1 (parameter
//! units) when the sigmas are right. Columns are scaled to unit RMS over the pool (mm and rad
//! columns comparable, Hollerbach and Wampler's scaling); the blocks kept are the scaled ones,
//! B_u = J_u S^-1, so the criteria of [`super::criterion`] are unit-free.

use super::pool::Pool;
use crate::data::{Measurement, MeasurementSet};
use crate::error::{Error, Result};
use crate::identify::identifiability::{Identifiability, analyse};
use crate::identify::parameter_jacobian;
use crate::identify::problem::{IdentifyWorkspace, Measure, Observations, Sigmas, residual};
use crate::kinematics::{Frames, frames, tool_pose};
use crate::model::Robot;
use nalgebra::{DMatrix, Matrix6xX};

/// The candidate pool's information, ready for planning.
#[derive(Debug, Clone)]
pub struct Design {
    /// The model linearised (a fully selected DH-type base or tool row as a 6-DOF transform,
    /// as identification solves it).
    pub robot: Robot,
    /// How the units are measured.
    pub measure: Measure,
    /// Rows per unit (6 pose, 3 position, orientation or relative, 1 distance).
    pub dim: usize,
    /// What the whole pool can identify: `selected` are the planned parameters.
    pub identifiability: Identifiability,
    /// The planned parameters (indices into `robot.parameters()`), `identifiability.selected`.
    pub params: Vec<usize>,
    /// Column scale s_j (the scaled parameter is s_j times the parameter, mm or rad): the
    /// RMS of column j over the pool's units.
    pub scale: Vec<f64>,
    /// The scaled, weighted blocks B_u (dim x p) stacked: unit u's rows are u dim ..
    /// (u + 1) dim.
    pub stacked: DMatrix<f64>,
    /// The validation cloud (rad, mm) that predictions and the `i` criterion average over.
    pub cloud: Vec<Vec<f64>>,
    /// R (p x p) with R^T R the cloud's mean J_v^T J_v, J_v the tool position's Jacobian
    /// over the scaled parameters (mm per scaled unit).
    pub cloud_root: DMatrix<f64>,
    /// Notes from preparing the model (frames re-expressed).
    pub notes: Vec<String>,
}

/// The pool's units as measurement rows of the nominal model (its own poses and distances,
/// so that every measure finds what it needs); pairs labelled by unit.
pub fn as_measurements(robot: &Robot, pool: &Pool) -> MeasurementSet {
    let mut rows = Vec::new();
    for (u, unit) in pool.units.iter().enumerate() {
        for (k, q) in unit.iter().enumerate() {
            let pose = tool_pose(robot, q);
            let mut m = Measurement::new(q.clone());
            m.id = Some(format!("{}", u + 1));
            m.position = Some(pose.translation.vector);
            m.rotation = Some(pose.rotation);
            if unit.len() == 2 {
                m.pair = Some(format!("{}", u + 1));
                if k == 1 {
                    let a = tool_pose(robot, &unit[0]).translation.vector;
                    m.distance = Some((pose.translation.vector - a).norm());
                }
            }
            rows.push(m);
        }
    }
    MeasurementSet::from_rows(rows)
}

/// Rows per unit of `measure`.
pub fn per_unit(measure: Measure) -> usize {
    match measure {
        Measure::Relative | Measure::Distance => 2,
        _ => 1,
    }
}

impl Design {
    /// The design of `pool` for identifying `params` (a selection, see
    /// [`crate::identify::select`]) of `nominal` by `measure` with noise `sigmas`; the
    /// planned parameters are those the whole pool identifies (rank tolerance `rank_tol`).
    /// `cloud`: the validation configurations (rad, mm).
    pub fn new(
        nominal: &Robot,
        params: &str,
        measure: Measure,
        sigmas: Sigmas,
        pool: &Pool,
        cloud: Vec<Vec<f64>>,
        rank_tol: f64,
    ) -> Result<Design> {
        if pool.units.is_empty() {
            return Err(Error::Invalid("the candidate pool is empty".into()));
        }
        if cloud.is_empty() {
            return Err(Error::Invalid("the validation cloud is empty".into()));
        }
        let per = per_unit(measure);
        if let Some(u) = pool.units.iter().position(|u| u.len() != per) {
            return Err(Error::Invalid(format!(
                "candidate unit {} has {} configuration(s); measuring by {} takes {per}",
                u + 1,
                pool.units[u].len(),
                measure.name()
            )));
        }
        let (robot, candidates, mut notes) = crate::identify::candidates(nominal, params)?;
        // As `identify` solves for it: a frame at the gimbal lock of its angles by turns
        // about its own axes (else a tool along the flange's x plans one rotation short).
        let near = crate::identify::run::frames_near_lock(&robot, &robot.parameters(), &candidates);
        let robot = if near.is_empty() {
            robot
        } else {
            robot.with_frames_rebased(&near)?
        };
        let set = as_measurements(&robot, pool);
        let obs = Observations::new(&set, measure, sigmas)?;
        let identifiability = analyse(&robot, &obs, &candidates, rank_tol);
        // As `identify` says it: a reviewer's UR10 planned in DH predicted 0.0308 mm where
        // axes 3 and 4 tilted by a milliradian gave 0.4383 mm.
        notes.extend(crate::identify::run::parallel_axes_note(
            &robot,
            &robot.parameters(),
            &identifiability,
            "the prediction takes those axes as exactly parallel: a real arm's tilt adds to the \
             error it predicts",
        ));
        let cols = identifiability.selected.clone();
        if cols.is_empty() {
            return Err(Error::Invalid(
                "the candidate pool identifies none of the selected parameters".into(),
            ));
        }
        let dim = obs.dim();
        let p = cols.len();
        let mut ws = IdentifyWorkspace::new(&robot);
        let mut r = [0.0; 6];
        let mut jac = Matrix6xX::zeros(p);
        let units = obs.items.len();
        let mut stacked = DMatrix::zeros(units * dim, p);
        for (u, o) in obs.items.iter().enumerate() {
            residual(&robot, &obs, o, Some(&cols), &mut ws, &mut r, &mut jac);
            for i in 0..dim {
                for j in 0..p {
                    stacked[(u * dim + i, j)] = jac[(i, j)] * o.inv_sigma[i];
                }
            }
        }
        // Unit RMS per unit of measurement.
        let scale: Vec<f64> = (0..p)
            .map(|j| (stacked.column(j).norm_squared() / units as f64).sqrt())
            .collect();
        for (j, s) in scale.iter().enumerate() {
            stacked.column_mut(j).unscale_mut(*s);
        }
        // The cloud's position rows over the scaled parameters, reduced to R by QR.
        let mut rows = DMatrix::zeros(3 * cloud.len().max(p), p);
        let mut f = Frames::new(&robot);
        let w = (cloud.len() as f64).sqrt();
        for (k, q) in cloud.iter().enumerate() {
            frames(&robot, q, &mut f);
            parameter_jacobian(&robot, &f, &cols, &mut jac);
            for i in 0..3 {
                for j in 0..p {
                    rows[(3 * k + i, j)] = jac[(i, j)] / (scale[j] * w);
                }
            }
        }
        let cloud_root = rows.qr().r();
        Ok(Design {
            robot,
            measure,
            dim,
            identifiability,
            params: cols,
            scale,
            stacked,
            cloud,
            cloud_root,
            notes,
        })
    }

    /// Number of planned parameters.
    pub fn p(&self) -> usize {
        self.params.len()
    }

    /// Number of candidate units.
    pub fn units(&self) -> usize {
        self.stacked.nrows() / self.dim
    }

    /// Unit u's scaled block B_u (dim x p).
    pub fn block(&self, u: usize) -> nalgebra::DMatrixView<'_, f64> {
        self.stacked.rows(u * self.dim, self.dim)
    }

    /// The scaled information matrix sum B_u^T B_u of the units `chosen`.
    pub fn information(&self, chosen: &[usize]) -> DMatrix<f64> {
        let p = self.p();
        let mut m = DMatrix::zeros(p, p);
        for &u in chosen {
            let b = self.block(u);
            m.gemm_tr(1.0, &b, &b, 1.0);
        }
        m
    }

    /// The covariance (parameter units: mm, rad) of the parameters identified from the
    /// units `chosen`, S^-1 M^-1 S^-1; None when M is singular up to rounding (the units do not identify
    /// every planned parameter).
    pub fn covariance(&self, chosen: &[usize]) -> Option<DMatrix<f64>> {
        let m = self.information(chosen);
        // Singular up to rounding: the scaled information's eigenvalues (squared singular
        // values) span more than the rank tolerance squared.
        let eig = m.clone().symmetric_eigenvalues();
        let (lo, hi) = eig
            .iter()
            .fold((f64::INFINITY, 0.0f64), |(a, b), v| (a.min(*v), b.max(*v)));
        let tol = crate::identify::identifiability::RANK_TOL;
        if lo.is_nan() || lo <= tol * tol * hi {
            return None;
        }
        let inv = m.cholesky()?.inverse();
        let p = self.p();
        Some(DMatrix::from_fn(p, p, |i, j| {
            inv[(i, j)] / (self.scale[i] * self.scale[j])
        }))
    }
}
