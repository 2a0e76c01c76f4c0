//! The neural compensator (thesis 3.2, 5.5, 6.4): a small MLP in series with a kinematic model.

pub mod compensator;
pub mod net;
pub mod train;
pub mod weights;
