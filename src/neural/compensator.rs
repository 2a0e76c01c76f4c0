//! A compensator: a kinematic model and an MLP in series (thesis 3.2, Fig. 3.6).
//!
//! Inputs: sin and cos of each revolute joint's angle (the value for prismatic joints),
//! min-max normalised to [-1, 1]. Two forms:
//! - pose-space (the thesis's): the network gives what the model misses at the tool,
//!   [dp (mm); dr (mrad, rotation vector)], composed as p = p_model + dp,
//!   R = exp(dr) R_model (position-only training data: dp only);
//! - joint-space: the network gives joint corrections dq (mrad, or um for prismatic joints)
//!   added before the model's FK. Compliance and gear errors live in the joints. The training
//!   residual maps the corrections through the model's joint Jacobian,
//!   r = W (e - J(q) dq(q)), with e the measured error and W the tracker's 1 / sigma.

use super::net::{record_bytes, weights_from_record};
use super::train::{Samples, TrainOptions, TrainReport, train};
use super::weights::{MinMax, Weights};
use crate::data::MeasurementSet;
use crate::error::{Error, Location, Result};
use crate::identify::identifiability::analyse;
use crate::identify::problem::Observations;
use crate::identify::run::file_value;
use crate::identify::select::select;
use crate::identify::solve::{free_values, with_values};
use crate::identify::{Measure, Sigmas, parameter_jacobian};
use crate::kinematics::{Frames, Pose, frames, joint_jacobian, tool_pose};
use crate::model::{JointType, Robot, robot_to_toml};
use crate::rotation::{from_rotation_vector, rotation_vector};
use nalgebra::{DMatrix, DVector, Matrix6xX, Translation3, Vector3};
use std::path::Path;

/// Where the network's output acts.
#[derive(
    Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum, serde::Serialize, serde::Deserialize,
)]
#[serde(rename_all = "lowercase")]
pub enum Form {
    /// Pose residual at the tool.
    Pose,
    /// Joint corrections before FK.
    Joint,
}

/// A trained compensator.
#[derive(Debug, Clone)]
pub struct Compensator {
    pub form: Form,
    pub robot: Robot,
    pub weights: Weights,
    pub input_norm: MinMax,
    pub output_norm: MinMax,
}

/// Network inputs of a configuration: sin, cos of revolute joints, value of prismatic ones.
pub fn features(robot: &Robot, q: &[f64], out: &mut Vec<f64>) {
    out.clear();
    for (j, v) in robot.joints().iter().zip(q) {
        match j.joint_type {
            JointType::Revolute => {
                let (s, c) = libm::sincos(*v);
                out.push(s);
                out.push(c);
            }
            JointType::Prismatic => out.push(*v),
        }
    }
}

/// What the model misses in one measured row: the position error (mm) and, when the row has
/// an orientation, the rotation vector of R_measured R_model^T (rad). None without a position.
fn model_error(
    robot: &Robot,
    m: &crate::data::Measurement,
    ws: &mut Frames,
) -> Option<(Vector3<f64>, Option<Vector3<f64>>)> {
    frames(robot, &m.q, ws);
    let t = &ws.tool;
    let dp = m.position? - t.translation.vector;
    let dr = m
        .rotation
        .map(|r| rotation_vector(&(r * t.rotation.inverse())));
    Some((dp, dr))
}

/// Pose-form samples (thesis): targets [dp (mm); dr (mrad)] min-max normalised.
fn pose_samples(robot: &Robot, set: &MeasurementSet, xs: Vec<Vec<f64>>) -> Result<Prepared> {
    let mut ws = Frames::new(robot);
    let mut ys = Vec::with_capacity(set.rows.len());
    for m in &set.rows {
        let (dp, dr) = model_error(robot, m, &mut ws).ok_or_else(|| no_position(set, m))?;
        let mut v = vec![dp.x, dp.y, dp.z];
        if let Some(r) = dr {
            v.extend((r * 1e3).iter());
        }
        ys.push(v);
    }
    let norm = MinMax::fit(&ys);
    let b = ys
        .iter()
        .map(|r| {
            let mut o = vec![0.0; r.len()];
            norm.apply(r, &mut o);
            o
        })
        .collect();
    // Target units per pose-error unit: mm -> normalised, rad -> mrad -> normalised.
    let half: Vec<f64> = (0..norm.min.len())
        .map(|r| {
            let h = 0.5 * (norm.max[r] - norm.min[r]);
            let unit = if r < 3 { 1.0 } else { 1e3 };
            if h > 0.0 { unit / h } else { unit }
        })
        .collect();
    Ok(Prepared {
        samples: Samples {
            x: xs,
            b,
            maps: None,
            lin: None,
        },
        input_norm: MinMax::default(),
        output_norm: norm,
        row_scales: vec![half; set.rows.len()],
        refine_cols: Vec::new(),
        refine_scale: Vec::new(),
    })
}

/// Samples of a form, their input and output normalisations, for each sample and target row
/// the factor from a pose-error component (mm, rad) to the target's unit, and the refined
/// parameters (indices into `Robot::parameters`) with their scales (mm or rad per unit).
pub struct Prepared {
    pub samples: Samples,
    pub input_norm: MinMax,
    pub output_norm: MinMax,
    pub row_scales: Vec<Vec<f64>>,
    pub refine_cols: Vec<usize>,
    pub refine_scale: Vec<f64>,
}

/// Joint-form samples: the network's joint corrections dq are seen through the model's joint
/// Jacobian, r_k = W (e_k - J(q_k) dq(q_k)), W = diag(1 / sigma) (tracker sigmas of the row,
/// else `sigmas`). dq_j = s_j y_j with s_j = sqrt(sum_k |W e_k|^2 / sum_k |W J_k e_j|^2), the
/// correction joint j alone would need; residuals are divided by the RMS of W e so that the
/// training works at unit scale like the pose form.
fn joint_samples(
    robot: &Robot,
    set: &MeasurementSet,
    xs: Vec<Vec<f64>>,
    sigmas: Sigmas,
) -> Result<Prepared> {
    let n = robot.dof();
    let mut ws = Frames::new(robot);
    let mut jac = Matrix6xX::zeros(n);
    let mut bs: Vec<Vec<f64>> = Vec::with_capacity(set.rows.len());
    let mut maps: Vec<DMatrix<f64>> = Vec::with_capacity(set.rows.len());
    let mut row_scales: Vec<Vec<f64>> = Vec::with_capacity(set.rows.len());
    for m in &set.rows {
        let (dp, dr) = model_error(robot, m, &mut ws).ok_or_else(|| no_position(set, m))?;
        joint_jacobian(robot, &ws, &mut jac);
        let rows = if dr.is_some() { 6 } else { 3 };
        let (sp, sr) = (
            m.sigma_position
                .unwrap_or(Vector3::repeat(sigmas.position_mm)),
            m.sigma_rotation
                .unwrap_or(Vector3::repeat(sigmas.rotation_rad)),
        );
        let w = |r: usize| if r < 3 { 1.0 / sp[r] } else { 1.0 / sr[r - 3] };
        let e = |r: usize| {
            if r < 3 {
                dp[r]
            } else {
                dr.unwrap_or_default()[r - 3]
            }
        };
        bs.push((0..rows).map(|r| w(r) * e(r)).collect());
        row_scales.push((0..rows).map(w).collect());
        maps.push(DMatrix::from_fn(rows, n, |r, c| w(r) * jac[(r, c)]));
    }
    let total: f64 = bs.iter().flatten().map(|v| v * v).sum();
    let count = bs.iter().map(|b| b.len()).sum::<usize>().max(1);
    let rms = (total / count as f64).sqrt();
    if rms == 0.0 || !rms.is_finite() {
        return Err(Error::Invalid(format!(
            "{}: the model already fits every row exactly; there is nothing to train on",
            set.source.display()
        )));
    }
    let scale: Vec<f64> = (0..n)
        .map(|j| {
            let col: f64 = maps.iter().map(|a| a.column(j).norm_squared()).sum();
            if col > 0.0 { (total / col).sqrt() } else { 0.0 }
        })
        .collect();
    for (a, b) in maps.iter_mut().zip(bs.iter_mut()) {
        for (j, s) in scale.iter().enumerate() {
            a.column_mut(j).scale_mut(s / rms);
        }
        b.iter_mut().for_each(|v| *v /= rms);
    }
    row_scales.iter_mut().flatten().for_each(|v| *v /= rms);
    // Output normalisation in the file's unit, mrad (um for prismatic joints).
    let norm = MinMax {
        min: scale.iter().map(|s| -s * 1e3).collect(),
        max: scale.iter().map(|s| s * 1e3).collect(),
    };
    Ok(Prepared {
        samples: Samples {
            x: xs,
            b: bs,
            maps: Some(maps),
            lin: None,
        },
        input_norm: MinMax::default(),
        output_norm: norm,
        row_scales,
        refine_cols: Vec::new(),
        refine_scale: Vec::new(),
    })
}

/// The training problem of a compensator: normalised inputs, targets and maps of the form,
/// and the linear columns of the refined parameters.
pub fn prepare(robot: &Robot, set: &MeasurementSet, opts: &CompensatorOptions) -> Result<Prepared> {
    let mut feat = Vec::new();
    let mut xs = Vec::with_capacity(set.rows.len());
    for m in &set.rows {
        features(robot, &m.q, &mut feat);
        xs.push(feat.clone());
    }
    let kinds = set.rows.iter().map(|m| m.rotation.is_some());
    if kinds.clone().any(|k| k) && kinds.clone().any(|k| !k) {
        return Err(Error::Invalid(format!(
            "{}: some rows have orientations and some not",
            set.source.display()
        )));
    }
    let input_norm = MinMax::fit(&xs);
    for x in xs.iter_mut() {
        let raw = x.clone();
        input_norm.apply(&raw, x);
    }
    let mut prepared = match opts.form {
        Form::Pose => pose_samples(robot, set, xs)?,
        Form::Joint => joint_samples(robot, set, xs, opts.sigmas)?,
    };
    let cols = match &opts.refine {
        None => Vec::new(),
        Some(spec) => {
            let measure = Measure::default_for(set);
            let obs = Observations::new(set, measure, opts.sigmas)?;
            analyse(robot, &obs, &select(robot, spec)?).selected
        }
    };
    let scale = if cols.is_empty() {
        Vec::new()
    } else {
        add_linear(robot, set, &cols, &mut prepared)
    };
    prepared.input_norm = input_norm;
    prepared.refine_cols = cols;
    prepared.refine_scale = scale;
    Ok(prepared)
}

/// Adds the model parameters `cols` (indices into `Robot::parameters`) as linear terms of
/// the training: L_k = D_k J_p(q_k) S, D_k the row scales, J_p the parameter Jacobian and
/// S = diag(s_j), s_j the change of parameter j alone that would explain the errors (mm or
/// rad per unit of theta). Returns the s_j.
fn add_linear(robot: &Robot, set: &MeasurementSet, cols: &[usize], p: &mut Prepared) -> Vec<f64> {
    let mut ws = Frames::new(robot);
    let mut jp = Matrix6xX::zeros(cols.len());
    let mut lin: Vec<DMatrix<f64>> = Vec::with_capacity(set.rows.len());
    for (m, d) in set.rows.iter().zip(&p.row_scales) {
        frames(robot, &m.q, &mut ws);
        parameter_jacobian(robot, &ws, cols, &mut jp);
        lin.push(DMatrix::from_fn(d.len(), cols.len(), |r, c| {
            d[r] * jp[(r, c)]
        }));
    }
    let total: f64 = p.samples.b.iter().flatten().map(|v| v * v).sum();
    let scale: Vec<f64> = (0..cols.len())
        .map(|j| {
            let col: f64 = lin.iter().map(|a| a.column(j).norm_squared()).sum();
            if col > 0.0 { (total / col).sqrt() } else { 0.0 }
        })
        .collect();
    for a in lin.iter_mut() {
        for (j, s) in scale.iter().enumerate() {
            a.column_mut(j).scale_mut(*s);
        }
    }
    p.samples.lin = Some(lin);
    scale
}

fn no_position(set: &MeasurementSet, m: &crate::data::Measurement) -> Error {
    Error::input(
        Location::at(&set.source, m.line, "x"),
        "training needs a measured position in every row",
    )
}

/// How to build a compensator.
#[derive(Debug, Clone)]
pub struct CompensatorOptions {
    pub form: Form,
    /// Tracker sigmas for rows that carry none (joint form weighting and refinement).
    pub sigmas: Sigmas,
    /// Model parameters re-estimated with the network (a selection as for `identify`,
    /// e.g. "full"); None keeps the model as given.
    pub refine: Option<String>,
    pub train: TrainOptions,
}

impl Default for CompensatorOptions {
    fn default() -> Self {
        CompensatorOptions {
            form: Form::Joint,
            sigmas: Sigmas::default(),
            refine: None,
            train: TrainOptions::default(),
        }
    }
}

/// A model parameter re-estimated with the network (file units: mm or deg).
#[derive(Debug, Clone, serde::Serialize)]
pub struct RefinedParam {
    pub name: String,
    pub unit: &'static str,
    pub before: f64,
    pub after: f64,
}

/// What training did.
#[derive(Debug, Clone, serde::Serialize)]
pub struct CompensatorReport {
    pub network: TrainReport,
    pub refined: Vec<RefinedParam>,
}

/// Scratch space for prediction.
#[derive(Debug, Clone)]
pub struct PredictWorkspace {
    feat: Vec<f64>,
    x: Vec<f64>,
    h: Vec<f64>,
    y: Vec<f64>,
    out: Vec<f64>,
    q: Vec<f64>,
    row: Vec<f64>,
    dy: DMatrix<f64>,
    dout: DMatrix<f64>,
}

impl Default for PredictWorkspace {
    fn default() -> Self {
        PredictWorkspace {
            feat: Vec::new(),
            x: Vec::new(),
            h: Vec::new(),
            y: Vec::new(),
            out: Vec::new(),
            q: Vec::new(),
            row: Vec::new(),
            dy: DMatrix::zeros(0, 0),
            dout: DMatrix::zeros(0, 0),
        }
    }
}

impl Compensator {
    /// Trains a compensator for `robot` on the measured rows of `set`; with `opts.refine`,
    /// the identifiable ones of those model parameters are re-estimated with the network
    /// (linearised at `robot`) and the compensator runs in series with the refined model.
    pub fn train(
        robot: &Robot,
        set: &MeasurementSet,
        opts: &CompensatorOptions,
    ) -> Result<(Compensator, CompensatorReport)> {
        let prepared = prepare(robot, set, opts)?;
        let (cols, scale) = (&prepared.refine_cols, &prepared.refine_scale);
        let outputs = prepared.output_norm.min.len();
        let (fit, network) = train(&prepared.samples, outputs, &opts.train)?;
        let (ids, x0) = free_values(robot, cols);
        let x = DVector::from_iterator(
            ids.len(),
            (0..ids.len()).map(|j| x0[j] + fit.theta[j] * scale[j]),
        );
        let refined_robot = with_values(robot, &ids, &x)?;
        let refined = ids
            .iter()
            .enumerate()
            .map(|(j, id)| RefinedParam {
                name: id.name(),
                unit: id.field.file_unit(),
                before: file_value(id, x0[j]),
                after: file_value(id, x[j]),
            })
            .collect();
        Ok((
            Compensator {
                form: opts.form,
                robot: refined_robot,
                weights: fit.weights,
                input_norm: prepared.input_norm,
                output_norm: prepared.output_norm,
            },
            CompensatorReport { network, refined },
        ))
    }

    /// The network's raw outputs for `q` into `ws.out`.
    fn outputs(&self, q: &[f64], ws: &mut PredictWorkspace) {
        features(&self.robot, q, &mut ws.feat);
        ws.x.resize(ws.feat.len(), 0.0);
        ws.h.resize(self.weights.hidden(), 0.0);
        ws.y.resize(self.weights.outputs(), 0.0);
        ws.out.resize(self.weights.outputs(), 0.0);
        self.input_norm.apply(&ws.feat, &mut ws.x);
        self.weights.forward_into(&ws.x, &mut ws.h, &mut ws.y);
        self.output_norm.invert(&ws.y, &mut ws.out);
    }

    /// The network's raw outputs for `q` into `ws.out` and their derivatives by the joints
    /// (outputs x joints; output units per rad or per mm) into `ws.dout`.
    fn output_derivatives(&self, q: &[f64], ws: &mut PredictWorkspace) {
        features(&self.robot, q, &mut ws.feat);
        let (i, o, n) = (ws.feat.len(), self.weights.outputs(), q.len());
        ws.x.resize(i, 0.0);
        ws.h.resize(self.weights.hidden(), 0.0);
        ws.y.resize(o, 0.0);
        ws.out.resize(o, 0.0);
        if ws.dy.shape() != (o, i) {
            ws.dy = DMatrix::zeros(o, i);
        }
        if ws.dout.shape() != (o, n) {
            ws.dout = DMatrix::zeros(o, n);
        }
        self.input_norm.apply(&ws.feat, &mut ws.x);
        self.weights
            .input_jacobian_into(&ws.x, &mut ws.h, &mut ws.y, &mut ws.dy);
        self.output_norm.invert(&ws.y, &mut ws.out);
        // Chain rule through out = y h_out + mid_out, x = (f - mid_in) / h_in and the
        // features (sin q, cos q) or q.
        ws.dout.fill(0.0);
        let mut col = 0;
        for (j, joint) in self.robot.joints().iter().enumerate() {
            let dfeat: &[(usize, f64)] = &match joint.joint_type {
                JointType::Revolute => {
                    let (s, c) = libm::sincos(q[j]);
                    [(col, c), (col + 1, -s)]
                }
                JointType::Prismatic => [(col, 1.0), (col, 0.0)],
            };
            for &(f, d) in dfeat {
                let dx = d / self.input_norm.half_range(f);
                for k in 0..o {
                    ws.dout[(k, j)] += ws.dy[(k, f)] * dx * self.output_norm.half_range(k);
                }
            }
            col += match joint.joint_type {
                JointType::Revolute => 2,
                JointType::Prismatic => 1,
            };
        }
    }

    /// The geometric Jacobian of the compensated pose at `q` into `jac` (6 x N; rows 0-2 mm
    /// per rad or per mm, rows 3-5 rad per rad or per mm, world); `frames` is a workspace of
    /// `self.robot`. Joint form: J = J_model(q + dq(q)) (I + d dq/dq). Pose form:
    /// [J_p + d dp/dq; exp(dr) J_w + J_l(dr) d dr/dq], J_l the left Jacobian of SO(3).
    pub fn jacobian(
        &self,
        q: &[f64],
        ws: &mut PredictWorkspace,
        frames_ws: &mut Frames,
        jac: &mut Matrix6xX<f64>,
    ) {
        self.output_derivatives(q, ws);
        let n = q.len();
        match self.form {
            Form::Joint => {
                ws.q.clear();
                ws.q.extend(q.iter().zip(&ws.out).map(|(a, d)| a + d * 1e-3));
                frames(&self.robot, &ws.q, frames_ws);
                joint_jacobian(&self.robot, frames_ws, jac);
                // jac <- jac (I + 1e-3 dout), column by column without a temporary.
                for r in 0..6 {
                    ws.row.clear();
                    ws.row.extend((0..n).map(|c| jac[(r, c)]));
                    for c in 0..n {
                        let extra: f64 = (0..n).map(|k| ws.row[k] * ws.dout[(k, c)] * 1e-3).sum();
                        jac[(r, c)] = ws.row[c] + extra;
                    }
                }
            }
            Form::Pose => {
                frames(&self.robot, q, frames_ws);
                joint_jacobian(&self.robot, frames_ws, jac);
                let with_rotation = ws.out.len() >= 6;
                let dr = if with_rotation {
                    Vector3::new(ws.out[3], ws.out[4], ws.out[5]) * 1e-3
                } else {
                    Vector3::zeros()
                };
                let (turn, left) = (from_rotation_vector(&dr), left_jacobian(&dr));
                for c in 0..n {
                    let mut w = turn * Vector3::new(jac[(3, c)], jac[(4, c)], jac[(5, c)]);
                    if with_rotation {
                        let ddr = Vector3::new(ws.dout[(3, c)], ws.dout[(4, c)], ws.dout[(5, c)]);
                        w += left * ddr * 1e-3;
                    }
                    for r in 0..3 {
                        jac[(r, c)] += ws.dout[(r, c)];
                        jac[(3 + r, c)] = w[r];
                    }
                }
            }
        }
    }

    /// The compensated tool pose for joints `q` (rad, mm). Allocation-free once `ws` has been
    /// used for this compensator.
    pub fn predict(&self, q: &[f64], ws: &mut PredictWorkspace) -> Pose {
        self.outputs(q, ws);
        match self.form {
            Form::Pose => {
                let model = tool_pose(&self.robot, q);
                let dp = Vector3::new(ws.out[0], ws.out[1], ws.out[2]);
                let rot = if ws.out.len() >= 6 {
                    from_rotation_vector(&(Vector3::new(ws.out[3], ws.out[4], ws.out[5]) * 1e-3))
                        * model.rotation
                } else {
                    model.rotation
                };
                Pose::from_parts(Translation3::from(model.translation.vector + dp), rot)
            }
            Form::Joint => {
                ws.q.clear();
                ws.q.extend(q.iter().zip(&ws.out).map(|(a, d)| a + d * 1e-3));
                tool_pose(&self.robot, &ws.q)
            }
        }
    }

    /// The compensator file's text (JSON): format and version, form, shapes, normalisation,
    /// the robot file it runs in series with (embedded, with its hash), the burn record
    /// (burnpack, hex) and a checksum of all of it.
    pub fn to_file_text(&self) -> Result<String> {
        let robot_toml = robot_to_toml(&self.robot);
        let record = record_bytes(&self.weights)?;
        let mut body = serde_json::json!({
            "format": FORMAT,
            "version": VERSION,
            "form": self.form,
            "inputs": self.weights.inputs(),
            "hidden": self.weights.hidden(),
            "outputs": self.weights.outputs(),
            "input_norm": self.input_norm,
            "output_norm": self.output_norm,
            "robot_toml": robot_toml,
            "robot_hash": format!("{:016x}", fnv1a(robot_toml.as_bytes())),
            "network_record_burnpack_hex": hex(&record),
        });
        let sum = fnv1a(
            serde_json::to_string(&body)
                .map_err(|e| Error::Invalid(e.to_string()))?
                .as_bytes(),
        );
        body["checksum"] = serde_json::json!(format!("{sum:016x}"));
        serde_json::to_string_pretty(&body).map_err(|e| Error::Invalid(e.to_string()))
    }

    /// Writes the compensator file atomically.
    pub fn save(&self, path: &Path) -> Result<()> {
        crate::io::write_atomic(path, self.to_file_text()?.as_bytes())
    }

    /// Reads a compensator file; a wrong format, version, checksum, robot hash or record is an
    /// error naming the file.
    pub fn load(path: &Path) -> Result<Compensator> {
        let text = crate::io::read_text(path)?;
        let bad = |m: String| Error::input(Location::file(path), m);
        let mut v: serde_json::Value =
            serde_json::from_str(&text).map_err(|e| bad(format!("not a compensator file: {e}")))?;
        if v["format"] != FORMAT {
            return Err(bad("not a robocal compensator file".into()));
        }
        if v["version"] != VERSION {
            return Err(bad(format!(
                "compensator file version {} (this robocal reads version {VERSION})",
                v["version"]
            )));
        }
        let sum = v["checksum"].as_str().unwrap_or_default().to_string();
        if let Some(o) = v.as_object_mut() {
            o.remove("checksum");
        }
        let body = serde_json::to_string(&v).map_err(|e| bad(e.to_string()))?;
        if format!("{:016x}", fnv1a(body.as_bytes())) != sum {
            return Err(bad(
                "checksum mismatch: the file is corrupt or was edited".into()
            ));
        }
        let robot_toml = v["robot_toml"]
            .as_str()
            .ok_or_else(|| bad("no embedded robot".into()))?;
        if format!("{:016x}", fnv1a(robot_toml.as_bytes()))
            != v["robot_hash"].as_str().unwrap_or_default()
        {
            return Err(bad("the embedded robot does not match its hash".into()));
        }
        let robot =
            crate::model::file::parse_robot(robot_toml, &path.with_extension("embedded.toml"))?;
        let get = |k: &str| {
            v[k].as_u64()
                .map(|x| x as usize)
                .ok_or_else(|| bad(format!("missing `{k}`")))
        };
        let (ni, nh, no) = (get("inputs")?, get("hidden")?, get("outputs")?);
        let record = unhex(
            v["network_record_burnpack_hex"]
                .as_str()
                .unwrap_or_default(),
        )
        .ok_or_else(|| bad("the network record is not hex".into()))?;
        let weights = weights_from_record(&record, ni, nh, no).map_err(|e| bad(e.to_string()))?;
        fn de<T: serde::de::DeserializeOwned>(
            v: &serde_json::Value,
            k: &str,
            path: &Path,
        ) -> Result<T> {
            serde_json::from_value(v[k].clone())
                .map_err(|e| Error::input(Location::file(path), format!("`{k}`: {e}")))
        }
        let c = Compensator {
            form: de(&v, "form", path)?,
            robot,
            weights,
            input_norm: de(&v, "input_norm", path)?,
            output_norm: de(&v, "output_norm", path)?,
        };
        // A consistent checksum does not prove consistent shapes: prediction indexes by them.
        let mut feat = Vec::new();
        features(&c.robot, &vec![0.0; c.robot.dof()], &mut feat);
        let outputs_ok = match c.form {
            Form::Joint => no == c.robot.dof(),
            Form::Pose => no == 3 || no == 6,
        };
        let norms_ok = [&c.input_norm, &c.output_norm]
            .iter()
            .zip([ni, no])
            .all(|(n, len)| n.min.len() == len && n.max.len() == len);
        if ni != feat.len() || !outputs_ok || !norms_ok {
            return Err(bad(format!(
                "a {ni}-{nh}-{no} {:?}-form network with normalisations of {}/{} inputs and \
                 {}/{} outputs does not fit its {}-joint robot",
                c.form,
                c.input_norm.min.len(),
                c.input_norm.max.len(),
                c.output_norm.min.len(),
                c.output_norm.max.len(),
                c.robot.dof()
            )));
        }
        Ok(c)
    }
}

const FORMAT: &str = "robocal-compensator";
const VERSION: u64 = 1;

/// The left Jacobian of SO(3) at rotation vector `phi` (rad): the angular velocity of
/// exp(phi) is J_l(phi) dphi/dt. J_l = I + (1 - cos t)/t^2 [phi]x + (t - sin t)/t^3 [phi]x^2.
fn left_jacobian(phi: &Vector3<f64>) -> nalgebra::Matrix3<f64> {
    let t = phi.norm();
    let k = phi.cross_matrix();
    let (a, b) = if t < 1e-6 {
        (0.5 - t * t / 24.0, 1.0 / 6.0 - t * t / 120.0)
    } else {
        ((1.0 - t.cos()) / (t * t), (t - t.sin()) / (t * t * t))
    };
    nalgebra::Matrix3::identity() + k * a + k * k * b
}

/// FNV-1a, 64 bits: a checksum against corruption, not a cryptographic hash.
fn fnv1a(b: &[u8]) -> u64 {
    b.iter().fold(0xcbf29ce484222325u64, |h, &x| {
        (h ^ x as u64).wrapping_mul(0x100000001b3)
    })
}

fn hex(b: &[u8]) -> String {
    b.iter().map(|x| format!("{x:02x}")).collect()
}

fn unhex(s: &str) -> Option<Vec<u8>> {
    if !s.len().is_multiple_of(2) {
        return None;
    }
    (0..s.len())
        .step_by(2)
        .map(|i| u8::from_str_radix(s.get(i..i + 2)?, 16).ok())
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn left_jacobian_matches_differences_of_exp() {
        let phi = Vector3::new(0.3, -0.35, 0.2);
        let jl = left_jacobian(&phi);
        for k in 0..3 {
            let h = 1e-6;
            let mut d = Vector3::zeros();
            d[k] = h;
            let (rp, rm) = (
                from_rotation_vector(&(phi + d)),
                from_rotation_vector(&(phi - d)),
            );
            // Angular velocity (world) of exp(phi) as phi moves along e_k.
            let w = rotation_vector(&(rp * rm.inverse())) / (2.0 * h);
            for r in 0..3 {
                assert!(
                    (w[r] - jl[(r, k)]).abs() < 1e-8,
                    "{k} {r}: {} vs {}",
                    w[r],
                    jl[(r, k)]
                );
            }
        }
        assert_eq!(
            left_jacobian(&Vector3::zeros()),
            nalgebra::Matrix3::identity()
        );
    }
}
