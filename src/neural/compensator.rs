//! A compensator: a kinematic model and an MLP in series (thesis 3.2, Fig. 3.6).
//!
//! Inputs: sin and cos of each revolute joint's angle (the value for prismatic joints),
//! min-max normalised to [-1, 1]. Two forms:
//! - pose-space (the thesis's): the network gives what the model misses at the tool,
//!   [dp (mm); dr (mrad, rotation vector)], composed as p = p_model + dp,
//!   R = exp(dr) R_model (position-only training data: dp only);
//! - joint-space: the network gives joint corrections dq (mrad, or um for prismatic joints)
//!   added before the model's FK. Compliance and gear errors live in the joints. Training
//!   targets are dq* = argmin |W^1/2 (J(q) dq - e)|^2 + lambda |dq|^2 per sample, from the
//!   model's geometric Jacobian J and the measured error e weighted by the tracker sigmas.

use super::net::{record_bytes, weights_from_record};
use super::train::{TrainOptions, TrainReport, train};
use super::weights::{MinMax, Weights};
use crate::data::MeasurementSet;
use crate::error::{Error, Location, Result};
use crate::identify::Sigmas;
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

/// Training targets of one measured row for a form (None when the row lacks what it needs).
fn target(
    robot: &Robot,
    form: Form,
    m: &crate::data::Measurement,
    sigmas: Sigmas,
    ws: &mut Frames,
    jac: &mut Matrix6xX<f64>,
) -> Option<Vec<f64>> {
    frames(robot, &m.q, ws);
    let t = &ws.tool;
    let dp = m.position? - t.translation.vector;
    let dr = m
        .rotation
        .map(|r| rotation_vector(&(r * t.rotation.inverse())));
    match form {
        Form::Pose => {
            let mut v = vec![dp.x, dp.y, dp.z];
            if let Some(r) = dr {
                v.extend((r * 1e3).iter());
            }
            Some(v)
        }
        Form::Joint => {
            joint_jacobian(robot, ws, jac);
            let n = robot.dof();
            let (wp, wr) = (1.0 / sigmas.position_mm, 1.0 / sigmas.rotation_rad);
            let rows = if dr.is_some() { 6 } else { 3 };
            let mut a = DMatrix::<f64>::zeros(rows, n);
            let mut e = DVector::<f64>::zeros(rows);
            for r in 0..rows {
                let w = if r < 3 { wp } else { wr };
                for c in 0..n {
                    a[(r, c)] = jac[(r, c)] * w;
                }
                e[r] = if r < 3 {
                    dp[r]
                } else {
                    dr.unwrap_or_default()[r - 3]
                } * w;
            }
            let mut ata = a.tr_mul(&a);
            let scale = (0..n).map(|i| ata[(i, i)]).fold(0.0, f64::max);
            for i in 0..n {
                ata[(i, i)] += 1e-9 * scale;
            }
            let dq = ata.cholesky()?.solve(&a.tr_mul(&e));
            Some(dq.iter().map(|v| v * 1e3).collect())
        }
    }
}

/// Scratch space for prediction.
#[derive(Debug, Clone, Default)]
pub struct PredictWorkspace {
    feat: Vec<f64>,
    x: Vec<f64>,
    h: Vec<f64>,
    y: Vec<f64>,
    out: Vec<f64>,
    q: Vec<f64>,
}

impl Compensator {
    /// Trains a compensator of `form` for `robot` on the measured rows of `set`.
    pub fn train(
        robot: &Robot,
        set: &MeasurementSet,
        form: Form,
        sigmas: Sigmas,
        opts: &TrainOptions,
    ) -> Result<(Compensator, TrainReport)> {
        let mut ws = Frames::new(robot);
        let mut jac = Matrix6xX::zeros(robot.dof());
        let mut xs = Vec::new();
        let mut ys = Vec::new();
        let mut feat = Vec::new();
        for m in &set.rows {
            let Some(t) = target(robot, form, m, sigmas, &mut ws, &mut jac) else {
                return Err(Error::input(
                    Location::at(&set.source, m.line, "x"),
                    "training needs a position (and for 6 outputs an orientation) in every row",
                ));
            };
            features(robot, &m.q, &mut feat);
            xs.push(feat.clone());
            ys.push(t);
        }
        if ys.iter().any(|t| t.len() != ys[0].len()) {
            return Err(Error::Invalid(format!(
                "{}: some rows have orientations and some not",
                set.source.display()
            )));
        }
        let input_norm = MinMax::fit(&xs);
        let output_norm = MinMax::fit(&ys);
        let norm = |n: &MinMax, v: &Vec<Vec<f64>>| -> Vec<Vec<f64>> {
            v.iter()
                .map(|r| {
                    let mut o = vec![0.0; r.len()];
                    n.apply(r, &mut o);
                    o
                })
                .collect()
        };
        let (weights, report) = train(&norm(&input_norm, &xs), &norm(&output_norm, &ys), opts)?;
        Ok((
            Compensator {
                form,
                robot: robot.clone(),
                weights,
                input_norm,
                output_norm,
            },
            report,
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
        Ok(Compensator {
            form: de(&v, "form", path)?,
            robot,
            weights,
            input_norm: de(&v, "input_norm", path)?,
            output_norm: de(&v, "output_norm", path)?,
        })
    }
}

const FORMAT: &str = "robocal-compensator";
const VERSION: u64 = 1;

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
