//! The neural compensator (thesis 3.2, 5.5, 6.4): small MLPs in series with a kinematic model.

pub mod batch;
pub mod compensator;
pub mod domain;
pub mod encoding;
pub mod exponential;
pub mod file;
pub mod fit;
pub mod lbfgs;
pub mod logistic;
pub mod net;
pub mod parallel;
pub mod predict;
pub mod products;
pub mod rbf;
pub mod refine;
pub mod repeats;
pub mod samples;
pub mod selection;
pub mod settings;
pub mod shrink;
pub mod targets;
pub mod train;
pub mod training;
pub mod tuning;
pub mod vectors;
pub mod weights;
