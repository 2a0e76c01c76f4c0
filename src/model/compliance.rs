//! Joint compliance (issue 14): under gravity a joint turns (or slides) a little beyond its
//! commanded value, in proportion to the gravity torque it holds. The joint the robot reaches
//! is
//!
//! q'_j = q_j + c_j tau_j(q),
//!
//! tau_j the gravity torque at joint j (N m; N along a prismatic joint) of the robot's mass
//! properties ([`super::mass`]) at the commanded joints q, c_j the joint's compliance. Inside,
//! c_j is in rad per N m (mm per N for a prismatic joint); in files and reports in mrad per
//! kN m (um per kN), a factor [`FILE_PER_INTERNAL`] larger.
//!
//! The torque is taken at the commanded joints, not at the deflected ones: the difference is
//! of second order in the compliance (a deflection of 1 mrad changes the lever arms by 0.1%),
//! and it keeps the model explicit (no fixed-point iteration per pose).
//!
//! In a robot file (the robot needs a `[mass]` table):
//!
//! ```toml
//! [compliance]
//! joints = [0.0, 0.05, 0.08, 0.3, 0.5, 0.0]   # mrad per kN m (um per kN if prismatic)
//! ```

/// File units (mrad per kN m, um per kN) per internal unit (rad per N m, mm per N).
pub const FILE_PER_INTERNAL: f64 = 1e6;
/// Largest compliance in files (mrad per kN m): a joint that turns a radian under a kN m,
/// far beyond any real joint.
pub const MAX_COMPLIANCE_FILE: f64 = 1e3;

/// The compliance of every joint, kept in file units so that a robot file written and read
/// again gives the same model to the last bit (as rows keep theirs).
#[derive(Debug, Clone, PartialEq)]
pub struct Compliance {
    /// c_j of each joint in file units (mrad per kN m; um per kN for a prismatic joint).
    pub file: Vec<f64>,
}

impl Compliance {
    /// Compliances given in file units (mrad per kN m; um per kN for a prismatic joint).
    pub fn from_file_units(values: &[f64]) -> Self {
        Compliance {
            file: values.to_vec(),
        }
    }

    /// Joint j's compliance (0-based) in internal units (rad per N m; mm per N if prismatic).
    pub fn joint(&self, j: usize) -> f64 {
        self.file[j] / FILE_PER_INTERNAL
    }

    /// Sets joint j's compliance (0-based) from internal units.
    pub fn set_joint(&mut self, j: usize, v: f64) {
        self.file[j] = v * FILE_PER_INTERNAL;
    }

    /// Whether every compliance is zero (the robot is then rigid).
    pub fn is_zero(&self) -> bool {
        self.file.iter().all(|&c| c == 0.0)
    }

    /// What is wrong with these compliances for a robot of `n` joints (a count that differs,
    /// a value that is not finite or beyond +-[`MAX_COMPLIANCE_FILE`]), or None.
    pub fn fault(&self, n: usize) -> Option<String> {
        if self.file.len() != n {
            return Some(format!(
                "{} compliances for a robot with {n} joints",
                self.file.len()
            ));
        }
        let bad = self
            .file
            .iter()
            .enumerate()
            .find(|(_, v)| !(v.is_finite() && v.abs() <= MAX_COMPLIANCE_FILE));
        bad.map(|(j, v)| {
            format!(
                "joint {}: compliance {v} mrad per kN m is not finite or beyond +-{MAX_COMPLIANCE_FILE}",
                j + 1
            )
        })
    }
}
