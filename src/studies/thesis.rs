//! What the thesis's protocols share: the shipped files (paths under `datasets/`), the
//! tracker noise, and the thesis's published figures (thesis notes, "The thesis's results").

use crate::error::Result;
use crate::identify::Sigmas;
use crate::model::{Robot, read_robot};
use std::path::Path;

/// The FANUC R-2000iB/210F's nominal model (thesis Table 4.1).
pub const FANUC: &str = "robots/fanuc_r2000ib_210f.toml";
/// The deviations of thesis Table 6.1.
pub const TABLE_6_1: &str = "deviations/table_6_1.toml";
/// Case D's focused region of the joint space.
pub const CASE_D_REGION: &str = "regions/case_d_focused.toml";

/// The FANUC's nominal model with the shipped non-geometric robot's masses (the simulator's,
/// for identifying its compliances with known masses).
pub const NONGEOMETRIC_MASSES: &str = "nongeometric_robot/nominal_masses.toml";

/// The FANUC's nominal model from `datasets` (the repository's `datasets/` folder).
pub fn fanuc(datasets: &Path) -> Result<Robot> {
    read_robot(datasets.join(FANUC))
}

/// The thesis's tracker noise (Leica LTD500 + T-Mac): 0.033 mm per coordinate, 0.174 mrad
/// per orientation component; identification's default weighting.
pub fn tracker_noise() -> Sigmas {
    Sigmas::default()
}

/// Thesis Table 6.6 (Case D), the nominal model: mean position error (mm) and orientation
/// error (deg) of the test poses, which match per-coordinate means against the measurements.
pub const TABLE_6_6_NOMINAL: (f64, f64) = (6.7929, 0.8386);
/// Thesis Table 6.6, joint offsets identified (mm, deg).
pub const TABLE_6_6_OFFSETS: (f64, f64) = (0.2183, 0.2585);
/// Thesis Table 6.6, joint offsets and the neural network (mm, deg).
pub const TABLE_6_6_OFFSETS_NETWORK: (f64, f64) = (0.0336, 0.0160);
