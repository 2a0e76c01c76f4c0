//! Why an inverse-kinematics target has no solution.

use crate::kinematics::ik_closed::MAX_SOLUTIONS;

/// Why a target has no solution.
#[derive(Debug, Clone, PartialEq)]
pub enum IkFailure {
    /// Numerical IK needs seed joints and none were given.
    NoSeed,
    /// Seed joints that do not fit the robot.
    BadSeed(String),
    /// The closed form has no solution: the pose is out of the arm's reach (or of its wrist's).
    Unreachable(String),
    /// The target lies beyond the arm's reach ([`Reach`](crate::kinematics::Reach), with [`REACH_MARGIN`](super::REACH_MARGIN)): how far.
    OutOfReach(String),
    /// More than [`MAX_SOLUTIONS`] solutions within the limits (ranges of many turns).
    TooMany,
    /// No numerical solve converged; the last one's report.
    NotConverged(String),
    /// Every solution found leaves the limits; the nearest the seed (or the middle of the
    /// ranges) leaves those of these 0-based joints.
    OutsideLimits(Vec<usize>),
}

impl IkFailure {
    /// A short code for a status column: `no-seed`, `bad-seed`, `unreachable`, `too-many`,
    /// `not-converged` or `outside-limits`.
    pub fn code(&self) -> &'static str {
        match self {
            IkFailure::NoSeed => "no-seed",
            IkFailure::BadSeed(_) => "bad-seed",
            IkFailure::Unreachable(_) | IkFailure::OutOfReach(_) => "unreachable",
            IkFailure::TooMany => "too-many",
            IkFailure::NotConverged(_) => "not-converged",
            IkFailure::OutsideLimits(_) => "outside-limits",
        }
    }
}

impl std::fmt::Display for IkFailure {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            IkFailure::NoSeed => write!(f, "no seed joints to start the numerical solve"),
            IkFailure::BadSeed(m) => write!(f, "bad seed: {m}"),
            IkFailure::Unreachable(m) | IkFailure::OutOfReach(m) => write!(f, "unreachable: {m}"),
            IkFailure::TooMany => write!(
                f,
                "more than {MAX_SOLUTIONS} solutions within the joint limits (ranges of many \
                 turns)"
            ),
            IkFailure::NotConverged(m) => write!(f, "{m}"),
            IkFailure::OutsideLimits(j) => write!(
                f,
                "every solution found leaves the limits; the one nearest the seed (or, without one, \
                 the middle of the ranges) leaves those of joint{} {}",
                if j.len() == 1 { "" } else { "s" },
                j.iter()
                    .map(|j| (j + 1).to_string())
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
        }
    }
}

/// An exact closed form without a solution: no branch reaches the pose.
pub(super) fn out_of_reach() -> IkFailure {
    IkFailure::Unreachable(
        "the pose is out of the arm's reach (the closed form has no solution)".into(),
    )
}
