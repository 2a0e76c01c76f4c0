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
//! Without mass properties, the deflection can still be modelled: tau_j is linear in the
//! first mass moments of the bodies joint j carries (link b's mass m_b and moment m_b c_b in
//! its joint frame, the payload's in the tool frame), so
//!
//! delta_j = sum_b k_jb0 g . (z_j x (o_b - o_j)) + sum_{b, i} k_jbi g . (z_j x R_b e_i)
//!
//! (revolute j; a prismatic joint's is sum_b k_jb0 g . z_j), with k_jb0 = c_j m_b and
//! (k_jb1, k_jb2, k_jb3) = c_j m_b c_b the products to identify, reduced to an identifiable set
//! by the rank analysis. Bodies b = j..N (N: the payload, on the tool frame); o_b, R_b the
//! origin (m in the formula) and rotation of body b's frame. In files: mrad per kN m times kg
//! (k_jb0) and times kg m (k_jb1..3); inside, a factor [`FILE_PER_INTERNAL`] smaller.
//!
//! In a robot file (joint compliances need a `[mass]` table; moments do not):
//!
//! ```toml
//! [compliance]
//! joints = [0.0, 0.05, 0.08, 0.3, 0.5, 0.0]   # mrad per kN m (um per kN if prismatic)
//! # or, without masses: per joint, per body 1..N and payload, [k0, k1, k2, k3]
//! moments = [[[0, 0, 0, 0], ...], ...]
//! ```

/// File units (mrad per kN m, um per kN; times kg or kg m for moments) per internal unit
/// (rad per N m, mm per N).
pub const FILE_PER_INTERNAL: f64 = 1e6;
/// Largest compliance in files (mrad per kN m): a joint that turns a radian under a kN m,
/// far beyond any real joint.
pub const MAX_COMPLIANCE_FILE: f64 = 1e3;
/// Largest moment coefficient in files (mrad per kN m times kg or kg m): the largest
/// compliance times a 1e5 kg mass 10 m out.
pub const MAX_MOMENT_FILE: f64 = 1e9;

/// The compliance of the joints, kept in file units so that a robot file written and read
/// again gives the same model to the last bit (as rows keep theirs).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Compliance {
    /// c_j of each joint in file units (mrad per kN m; um per kN for a prismatic joint);
    /// empty for none.
    pub joints: Vec<f64>,
    /// The mass-free coefficients k_jbi in file units, joint j (0..N), body b (0..=N, N the
    /// payload), part i (0: mass, 1-3: moment x, y, z), at [`moment_index`]; empty for none.
    /// Entries of bodies before their joint (b < j) are zero.
    pub moments: Vec<f64>,
}

/// Where k_jbi sits in [`Compliance::moments`] for a robot of `n` joints.
pub fn moment_index(n: usize, j: usize, b: usize, i: usize) -> usize {
    (j * (n + 1) + b) * 4 + i
}

impl Compliance {
    /// Joint compliances given in file units (mrad per kN m; um per kN if prismatic).
    pub fn from_file_units(values: &[f64]) -> Self {
        Compliance {
            joints: values.to_vec(),
            moments: Vec::new(),
        }
    }

    /// Joint j's compliance (0-based) in internal units (rad per N m; mm per N if
    /// prismatic); 0 without joint compliances.
    pub fn joint(&self, j: usize) -> f64 {
        self.joints.get(j).map_or(0.0, |v| v / FILE_PER_INTERNAL)
    }

    /// k_jbi in internal units (rad per N m times kg or kg m); 0 without moments.
    pub fn moment(&self, n: usize, j: usize, b: usize, i: usize) -> f64 {
        self.moments
            .get(moment_index(n, j, b, i))
            .map_or(0.0, |v| v / FILE_PER_INTERNAL)
    }

    /// Whether every coefficient is zero (the robot is then rigid).
    pub fn is_zero(&self) -> bool {
        self.joints.iter().chain(&self.moments).all(|&c| c == 0.0)
    }

    /// Whether there are mass-free coefficients with a non-zero value.
    pub fn has_moments(&self) -> bool {
        self.moments.iter().any(|&c| c != 0.0)
    }

    /// What is wrong with these compliances for a robot of `n` joints (a count that differs,
    /// a value that is not finite or beyond its bound, a moment of a body its joint does not
    /// carry), or None.
    pub fn fault(&self, n: usize) -> Option<String> {
        if !self.joints.is_empty() && self.joints.len() != n {
            return Some(format!(
                "{} compliances for a robot with {n} joints",
                self.joints.len()
            ));
        }
        if let Some((j, v)) = self
            .joints
            .iter()
            .enumerate()
            .find(|(_, v)| !(v.is_finite() && v.abs() <= MAX_COMPLIANCE_FILE))
        {
            return Some(format!(
                "joint {}: compliance {v} mrad per kN m is not finite or beyond +-{MAX_COMPLIANCE_FILE}",
                j + 1
            ));
        }
        if self.moments.is_empty() {
            return None;
        }
        if self.moments.len() != n * (n + 1) * 4 {
            return Some(format!(
                "moments need {n} joints x {} bodies x 4 values",
                n + 1
            ));
        }
        for j in 0..n {
            for b in 0..=n {
                for i in 0..4 {
                    let v = self.moments[moment_index(n, j, b, i)];
                    if !(v.is_finite() && v.abs() <= MAX_MOMENT_FILE) {
                        return Some(format!(
                            "joint {}: moment coefficient {v} is not finite or beyond +-{MAX_MOMENT_FILE}",
                            j + 1
                        ));
                    }
                    if b < j && v != 0.0 {
                        return Some(format!(
                            "joint {}: a moment coefficient of body {} which the joint does not carry",
                            j + 1,
                            b + 1
                        ));
                    }
                }
            }
        }
        None
    }
}
