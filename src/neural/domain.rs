//! A compensator's training domain: where its network has seen data. A network extrapolates
//! badly, so configurations outside the domain are flagged wherever a compensator is used.
//!
//! A configuration is inside when every joint lies within the range the training rows
//! covered and its distance to the nearest training configuration, measured in the network's
//! normalised input space, is at most the domain's radius: the largest distance of a
//! training configuration to its own nearest (distinct) neighbour.

use super::encoding::Encoding;
use super::weights::Affine;
use crate::model::Robot;

/// The training domain (joints in rad or mm; distances in normalised input units).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Domain {
    pub joint_min: Vec<f64>,
    pub joint_max: Vec<f64>,
    /// The distinct training configurations as normalised network inputs.
    pub inputs: Vec<Vec<f64>>,
    pub radius: f64,
}

/// Where one configuration stands against a domain.
#[derive(Debug, Clone, PartialEq)]
pub struct DomainCheck {
    /// Joints (0-based) outside the training range.
    pub joints_outside: Vec<usize>,
    /// Distance to the nearest training configuration (normalised input units).
    pub nearest: f64,
    pub radius: f64,
}

impl DomainCheck {
    pub fn inside(&self) -> bool {
        self.joints_outside.is_empty() && self.nearest <= self.radius
    }

    /// A short text for output files and warnings: `inside`, or what is outside.
    pub fn describe(&self) -> String {
        if self.inside() {
            return "inside".into();
        }
        let mut parts: Vec<String> = self
            .joints_outside
            .iter()
            .map(|j| format!("q{} outside the training range", j + 1))
            .collect();
        if self.nearest > self.radius {
            parts.push(format!(
                "{:.2} from the nearest training configuration (radius {:.2})",
                self.nearest, self.radius
            ));
        }
        parts.join("; ")
    }
}

fn distance2(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum()
}

impl Domain {
    /// The domain of training configurations `qs` (rad, mm) under an encoding and its
    /// input normalisation.
    pub fn fit(robot: &Robot, encoding: Encoding, norm: &Affine, qs: &[&[f64]]) -> Domain {
        let n = robot.dof();
        let mut joint_min = vec![f64::INFINITY; n];
        let mut joint_max = vec![f64::NEG_INFINITY; n];
        let mut inputs: Vec<Vec<f64>> = Vec::with_capacity(qs.len());
        let mut feat = Vec::new();
        let mut ws = crate::kinematics::Frames::new(robot);
        for q in qs {
            for j in 0..n {
                joint_min[j] = joint_min[j].min(q[j]);
                joint_max[j] = joint_max[j].max(q[j]);
            }
            encoding.features(robot, q, &mut ws, &mut feat);
            let mut x = vec![0.0; feat.len()];
            norm.apply(&feat, &mut x);
            inputs.push(x);
        }
        inputs.sort_by(|a, b| {
            a.iter()
                .zip(b)
                .fold(std::cmp::Ordering::Equal, |o, (x, y)| {
                    o.then(x.total_cmp(y))
                })
        });
        inputs.dedup();
        let mut radius2: f64 = 0.0;
        for (i, a) in inputs.iter().enumerate() {
            let nearest = inputs
                .iter()
                .enumerate()
                .filter(|(k, _)| *k != i)
                .map(|(_, b)| distance2(a, b))
                .fold(f64::INFINITY, f64::min);
            if nearest.is_finite() {
                radius2 = radius2.max(nearest);
            }
        }
        Domain {
            joint_min,
            joint_max,
            inputs,
            radius: radius2.sqrt(),
        }
    }

    /// Where `q` (rad, mm) stands; `x` is its normalised network input.
    pub fn check(&self, q: &[f64], x: &[f64]) -> DomainCheck {
        let joints_outside = (0..q.len())
            .filter(|&j| q[j] < self.joint_min[j] || q[j] > self.joint_max[j])
            .collect();
        let nearest = self
            .inputs
            .iter()
            .map(|b| distance2(x, b))
            .fold(f64::INFINITY, f64::min)
            .sqrt();
        DomainCheck {
            joints_outside,
            nearest,
            radius: self.radius,
        }
    }

    /// True when the sizes fit `dof` joints and `inputs` features and every number is finite.
    pub fn is_valid(&self, dof: usize, inputs: usize) -> bool {
        self.joint_min.len() == dof
            && self.joint_max.len() == dof
            && self
                .joint_min
                .iter()
                .zip(&self.joint_max)
                .all(|(a, b)| a.is_finite() && b.is_finite() && a <= b)
            && self.radius.is_finite()
            && self.radius >= 0.0
            && !self.inputs.is_empty()
            && self
                .inputs
                .iter()
                .all(|x| x.len() == inputs && x.iter().all(|v| v.is_finite()))
    }
}
