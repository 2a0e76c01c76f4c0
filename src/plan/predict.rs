//! The accuracy a plan predicts before anything is measured.
//!
//! With C = M^-1 the parameters' covariance (parameter units; right when the sigmas are the
//! instrument's and the model is complete), the tool's error at a configuration is
//! e = J_pose dtheta, of covariance J C J^T (the pose Jacobian over the planned parameters,
//! thesis eq. 4.19-4.21). Its length |e| is not Gaussian: its distribution over a validation
//! cloud is sampled, each configuration with `SAMPLES` seeded standard normal draws of its
//! own, e = V sqrt(Lambda) z (V Lambda V^T = J C J^T): the statistics pool every
//! configuration's draws. The cloud's mean |e| is what an identification from the
//! planned measurements will leave against the truth, on average over the noise. Draws of
//! their own, not one set shared by every configuration: a shared set's sampling error is
//! every configuration's, and moved a plan's predicted RMS by up to 10 % from its exact
//! value (the I-criterion's) between seeds; its own draws average it out over the cloud.

use super::design::Design;
use crate::evaluate::Summary;
use crate::identify::Measure;
use crate::identify::parameter_jacobian;
use crate::kinematics::{Frames, frames};
use nalgebra::{Matrix3, Matrix6xX, Vector3};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

/// Normal draws per validation configuration.
const SAMPLES: usize = 64;

/// One parameter's predicted standard deviation.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ParamStd {
    /// Its name (`a2`, `theta3`, `base.x`, ...).
    pub name: String,
    /// Its file unit (`mm`, `deg`, ...).
    pub unit: String,
    /// Predicted standard deviation (file unit).
    pub std: f64,
}

/// What a set of units predicts.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Prediction {
    /// Units measured.
    pub units: usize,
    /// Each planned parameter's standard deviation.
    pub parameters: Vec<ParamStd>,
    /// Tool position error (mm): mean, RMS, p95 and max over the cloud and the draws; None
    /// where the measure sees no position (orientation): the base's and the tool's positions
    /// keep their nominal values, whose errors no prediction holds.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub position_mm: Option<Summary>,
    /// Tool orientation error (deg), the same; None where the measure sees no orientation
    /// (position, relative, distance: the tool's rotation keeps its nominal value; a review
    /// measured 0.005 deg predicted against 0.33 deg realised from a position plan).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub orientation_deg: Option<Summary>,
}

/// sqrt of the symmetric positive semi-definite `s` (V sqrt(Lambda), negative eigenvalues of
/// rounding taken as zero).
fn root(s: &Matrix3<f64>) -> Matrix3<f64> {
    let e = s.symmetric_eigen();
    let mut v = e.eigenvectors;
    for k in 0..3 {
        let l = e.eigenvalues[k].max(0.0).sqrt();
        v.column_mut(k).scale_mut(l);
    }
    v
}

/// The prediction for the units `chosen` of `design`, over its validation cloud; None when
/// the units do not identify every planned parameter. The draws are seeded by `seed`.
pub fn predict(design: &Design, chosen: &[usize], seed: u64) -> Option<Prediction> {
    let cov = design.covariance(chosen)?;
    if cov.iter().any(|v| !v.is_finite()) {
        return None;
    }
    let cloud = &design.cloud;
    let robot = &design.robot;
    let ids = robot.parameters();
    let parameters = design
        .params
        .iter()
        .enumerate()
        .map(|(k, &c)| ParamStd {
            name: ids[c].name(),
            unit: ids[c].field.file_unit().to_string(),
            std: ids[c].field.to_file(cov[(k, k)].max(0.0).sqrt()),
        })
        .collect();
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut draw = || -> Vector3<f64> {
        Vector3::new(
            StandardNormal.sample(&mut rng),
            StandardNormal.sample(&mut rng),
            StandardNormal.sample(&mut rng),
        )
    };
    let p = design.p();
    let mut ws = Frames::new(robot);
    let mut jac = Matrix6xX::zeros(p);
    let mut pos = Vec::with_capacity(cloud.len() * SAMPLES);
    let mut rot = Vec::with_capacity(cloud.len() * SAMPLES);
    for q in cloud {
        frames(robot, q, &mut ws);
        parameter_jacobian(robot, &ws, &design.params, &mut jac);
        let jc = &jac * &cov;
        let s = &jc * jac.transpose();
        let sp: Matrix3<f64> = s.fixed_view::<3, 3>(0, 0).into_owned();
        let sr: Matrix3<f64> = s.fixed_view::<3, 3>(3, 3).into_owned();
        let (rp, rr) = (root(&sp), root(&sr));
        for _ in 0..SAMPLES {
            let zk = draw();
            pos.push((rp * zk).norm());
            rot.push((rr * zk).norm().to_degrees());
        }
    }
    let (position, orientation) = (Summary::of(&pos)?, Summary::of(&rot)?);
    Some(Prediction {
        units: chosen.len(),
        parameters,
        position_mm: (design.measure != Measure::Orientation).then_some(position),
        orientation_deg: matches!(design.measure, Measure::Pose | Measure::Orientation)
            .then_some(orientation),
    })
}
