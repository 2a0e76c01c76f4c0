//! A compensator: a kinematic model and an ensemble of MLPs in series (thesis 3.2, Fig. 3.6).
//!
//! Two forms (see [`super::targets`] for what each is trained on):
//! - joint: the networks give joint corrections dq(q) (mrad, or um for prismatic joints) added
//!   before the model's FK; compliance and gear errors live in the joints;
//! - pose (the thesis's): the networks give what the model misses at the tool, [dp (mm);
//!   dr (mrad, rotation vector)] in the robot's base frame, composed as p = p_model + R_b dp,
//!   R = exp(R_b dr) R_model (position-only data: dp only).
//!
//! Training a compensator ([`Compensator::train`], in [`super::training`]) fixes what the options fix and chooses the
//! rest by cross-validation ([`super::tuning`]); with refinement the model's parameters are
//! first re-estimated on the training rows through the exact model ([`super::refine`]).
//! Prediction is in [`super::predict`], the file in [`super::file`], the training domain in
//! [`super::domain`].

use super::domain::Domain;
pub use super::encoding::Encoding;
use super::rbf::Rbf;
pub use super::settings::{CompensatorOptions, Form, Network, Refine, Settings};
use super::shrink::Shrink;
use super::weights::{Affine, Weights};
use crate::model::Robot;

/// A trained compensator.
#[derive(Debug, Clone)]
pub struct Compensator {
    /// What the networks correct: joints or the tool pose.
    pub form: Form,
    /// How joints become network inputs.
    pub encoding: Encoding,
    /// The model the networks run in series with (refined in training when asked).
    pub robot: Robot,
    /// The ensemble's MLPs; the prediction uses their mean output, blended with `rbf`'s
    /// where both are present (none of either: no correction).
    pub members: Vec<Weights>,
    /// An RBF network, alone or with the MLPs.
    pub rbf: Option<Rbf>,
    /// The MLPs' share s of the correction where both they and `rbf` are present (0 < s < 1):
    /// y = s mean_m y_m + (1 - s) y_rbf. Unused otherwise.
    pub mlp_share: f64,
    /// The MLPs' mean shrinks toward its training mean where they disagree (two members or
    /// more; see [`super::shrink`]).
    pub shrink: Option<Shrink>,
    /// Standardisation of the input features (encoded joints) fitted on the training rows.
    pub input_norm: Affine,
    /// Map from the networks' unit-scale outputs to raw outputs: pose form dp (mm) and dr
    /// (mrad); joint form dq (mrad, or um for prismatic joints).
    pub output_norm: Affine,
    /// Where the networks have seen data; beyond it their correction fades out.
    pub domain: Domain,
    /// Whether training refined `robot` on the training rows (then fitted on those rows
    /// alone, so that a compensator without a network still has a domain: its joint ranges);
    /// None for a file written before it was recorded (version 7 and older), which is taken
    /// as not refined where that is the safe reading (the domain) and as unknown where it is
    /// not (a robot file's tool taken over only where the model is known unrefined).
    pub model_refined: Option<bool>,
}

impl Compensator {
    /// Number of network inputs (encoded features).
    pub fn inputs(&self) -> usize {
        self.input_norm.len()
    }

    /// Hidden units of each MLP (0 without MLPs).
    pub fn hidden(&self) -> usize {
        self.members.first().map_or(0, |w| w.hidden())
    }

    /// Number of network outputs (pose form: 3 or 6; joint form: the joints).
    pub fn outputs(&self) -> usize {
        self.output_norm.len()
    }
}
