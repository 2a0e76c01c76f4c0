//! When two rows are one arm configuration.
//!
//! Two measurements of one commanded pose do not log the same joint values. On the shipped
//! UR10 Series B the 293 repeated pairs differ by the encoders' noise, up to 3e-4 rad in some
//! joint; on Series A 461 goal poses were commanded twice (the same rotation written as two
//! roll-pitch-yaw triples at pitch 90 deg) and reached with joints up to 6.7e-3 rad apart. No
//! two rows of different commanded poses come within 3e-2 rad on either series.

/// Largest difference in every joint (rad, 1e-2 rad = 0.57 deg; mm for a prismatic joint,
/// 10 um) at which two rows are the same configuration: above the 6.7e-3 rad of the shipped
/// repeats, below the 3e-2 rad between their distinct configurations.
pub const SAME_CONFIGURATION: f64 = 1e-2;

/// Whether joint vectors `a` and `b` (rad or mm) are one configuration: as many joints, each
/// closer than [`SAME_CONFIGURATION`].
pub fn same_configuration(a: &[f64], b: &[f64]) -> bool {
    a.len() == b.len()
        && a.iter()
            .zip(b)
            .all(|(x, y)| (x - y).abs() < SAME_CONFIGURATION)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_configuration_within_the_tolerance_in_every_joint() {
        let a = [0.1, -1.2, 0.8];
        assert!(same_configuration(&a, &[0.1 + 9e-3, -1.2 - 9e-3, 0.8]));
        assert!(!same_configuration(&a, &[0.1 + 1.1e-2, -1.2, 0.8]));
        assert!(!same_configuration(&a, &[0.1, -1.2, 0.8 - 2e-2]));
        // Another robot's joint count is never the same configuration.
        assert!(!same_configuration(&a, &[0.1, -1.2]));
    }
}
