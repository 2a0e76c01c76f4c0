//! One joint of a robot: its row, whether it rotates or slides, its limits, and its
//! whole-turn copies within them.

use super::row::Row;

/// Revolute joints add their variable to theta; prismatic joints add it to d.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum JointType {
    /// Rotates: the variable (rad inside, deg in files) adds to theta.
    Revolute,
    /// Slides: the variable (mm) adds to d.
    Prismatic,
}

impl JointType {
    /// Lower-case name, as in robot files: `revolute` or `prismatic`.
    pub fn name(self) -> &'static str {
        match self {
            JointType::Revolute => "revolute",
            JointType::Prismatic => "prismatic",
        }
    }

    /// The unit of the joint variable in files and on the command line.
    pub fn file_unit(self) -> &'static str {
        match self {
            JointType::Revolute => "deg",
            JointType::Prismatic => "mm",
        }
    }

    /// Converts a joint value from file units (deg or mm) to internal units (rad or mm).
    pub fn to_internal(self, v: f64) -> f64 {
        match self {
            JointType::Revolute => v.to_radians(),
            JointType::Prismatic => v,
        }
    }

    /// Converts a joint value from internal units (rad or mm) to file units (deg or mm).
    pub fn to_file(self, v: f64) -> f64 {
        match self {
            JointType::Revolute => v.to_degrees(),
            JointType::Prismatic => v,
        }
    }
}

/// One joint: its row, its type and its limits.
#[derive(Debug, Clone, PartialEq)]
pub struct Joint {
    /// The joint's row: its convention and constant field values (mm, deg).
    pub row: Row,
    /// Whether the joint variable is an angle or a length.
    pub joint_type: JointType,
    /// Lower and upper limit of the joint variable, in file units (deg or mm).
    pub limits: [f64; 2],
}

/// Rounding allowance (rad or mm) of the joint limits: a joint value this little past a
/// limit counts as within it (a solve that ends on a limit can end a rounding beyond it).
pub const LIMIT_TOL: f64 = 1e-9;

impl Joint {
    /// Limits in internal units (rad or mm).
    pub fn limits_internal(&self) -> [f64; 2] {
        self.limits.map(|v| self.joint_type.to_internal(v))
    }

    /// The value `v` (rad, mm) takes nearest `reference` within the limits (widened by
    /// [`LIMIT_TOL`]): for a revolute joint the whole-turn copy v + 2 pi k, for a prismatic
    /// one `v` itself; None where no copy lies within them.
    pub fn nearest_turn(&self, v: f64, reference: f64) -> Option<f64> {
        let (kmin, kmax) = self.turns(v)?;
        let tau = std::f64::consts::TAU;
        Some(
            v + tau
                * ((reference - v) / tau)
                    .round()
                    .clamp(kmin as f64, kmax as f64),
        )
    }

    /// The whole turns k (lowest, highest) for which `v + 2 pi k` (rad) lies within the
    /// limits widened by [`LIMIT_TOL`]; for a prismatic joint (0, 0) where `v` (mm) lies
    /// within them; None where no copy does.
    pub fn turns(&self, v: f64) -> Option<(i64, i64)> {
        const TOL: f64 = LIMIT_TOL;
        let [lo, hi] = self.limits_internal();
        if self.joint_type == JointType::Prismatic {
            return (lo - TOL..=hi + TOL).contains(&v).then_some((0, 0));
        }
        let tau = std::f64::consts::TAU;
        let (kmin, kmax) = (
            ((lo - TOL - v) / tau).ceil() as i64,
            ((hi + TOL - v) / tau).floor() as i64,
        );
        (kmin <= kmax).then_some((kmin, kmax))
    }
}
