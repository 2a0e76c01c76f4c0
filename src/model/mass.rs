//! Mass properties of a robot, for the gravity torques that bend compliant joints (issue 14):
//! per joint, the mass (kg) of the link it moves and that link's centre of mass (mm) in the
//! joint's frame (z on its axis, moved by it; `kinematics::Frames::joint`); the
//! payload's mass and centre of mass (mm) in the tool frame; gravity (m/s^2) in the robot's
//! base frame: the frame after the base row, so that a base row holding a tracker's
//! placement does not tilt gravity (-z for a floor mount; +z for a ceiling mount, a horizontal
//! vector for a wall mount).
//!
//! In a robot file:
//!
//! ```toml
//! [mass]
//! gravity = [0.0, 0.0, -9.81]                  # m/s^2, base frame (the default)
//! link_kg = [30.0, 25.0, 12.0, 3.0, 2.0, 0.5]  # one per joint
//! link_com_mm = [[0, 0, 0], [300, 0, 100], [250, 0, 0], [0, 0, 0], [0, 0, 0], [0, 0, 20]]
//! payload_kg = 10.0
//! payload_com_mm = [0.0, 0.0, 50.0]            # tool frame
//! ```

use nalgebra::Vector3;

/// Largest mass (kg) of a link or payload: heavier than any robot lifts.
pub const MAX_MASS_KG: f64 = 1e5;
/// Largest gravity component (m/s^2).
pub const MAX_GRAVITY: f64 = 100.0;

/// A rigid body's mass and centre of mass.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BodyMass {
    /// Mass (kg, 0 to [`MAX_MASS_KG`]).
    pub mass_kg: f64,
    /// Centre of mass (mm) in the body's frame.
    pub com_mm: Vector3<f64>,
}

/// A robot's mass properties.
#[derive(Debug, Clone, PartialEq)]
pub struct MassProperties {
    /// The link moved by each joint, in its joint's frame.
    pub links: Vec<BodyMass>,
    /// The payload, in the tool frame.
    pub payload: BodyMass,
    /// Gravity acceleration (m/s^2) in the robot's base frame (after the base row).
    pub gravity: Vector3<f64>,
}

impl MassProperties {
    /// Whether any link or the payload has mass (a table may give gravity alone).
    pub fn has_mass(&self) -> bool {
        self.links.iter().any(|b| b.mass_kg > 0.0) || self.payload.mass_kg > 0.0
    }

    /// What is wrong with these properties for a robot of `n` joints (a count that differs,
    /// a negative, huge or non-finite mass, a centre of mass beyond 100 m, gravity beyond
    /// 100 m/s^2), or None.
    pub fn fault(&self, n: usize) -> Option<String> {
        if self.links.len() != n {
            return Some(format!(
                "{} link masses for a robot with {n} joints",
                self.links.len()
            ));
        }
        let body = |b: &BodyMass, what: &str| -> Option<String> {
            if !(b.mass_kg.is_finite() && (0.0..=MAX_MASS_KG).contains(&b.mass_kg)) {
                return Some(format!(
                    "{what}: mass {} kg outside [0, {MAX_MASS_KG}]",
                    b.mass_kg
                ));
            }
            let far = b
                .com_mm
                .iter()
                .any(|v| !v.is_finite() || v.abs() > super::MAX_LENGTH_MM);
            far.then(|| format!("{what}: centre of mass beyond {} mm", super::MAX_LENGTH_MM))
        };
        for (k, b) in self.links.iter().enumerate() {
            if let Some(f) = body(b, &format!("link {}", k + 1)) {
                return Some(f);
            }
        }
        if let Some(f) = body(&self.payload, "payload") {
            return Some(f);
        }
        if self
            .gravity
            .iter()
            .any(|v| !v.is_finite() || v.abs() > MAX_GRAVITY)
        {
            return Some(format!("gravity components beyond {MAX_GRAVITY} m/s^2"));
        }
        None
    }
}
