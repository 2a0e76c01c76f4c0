//! Non-geometric errors of a virtual robot: what real robots have and parametric models miss.
//! Each term is a joint deflection added to the commanded joints before the true model's FK.
//!
//! ```toml
//! [compliance]                 # joint deflection = compliance * gravity torque
//! payload_kg = 210.0           # at the tool origin
//! link_masses_kg = [400.0, 200.0, 250.0, 30.0, 20.0, 5.0]
//! mrad_per_knm = [0.0, 0.05, 0.08, 0.0, 0.0, 0.0]
//! gravity = [0.0, 0.0, -9.81]  # m/s^2 in the base frame (default: -z)
//!
//! [[gear]]                     # transmission error of one joint (rad = mrad * 1e-3)
//! joint = 1                    # 1-based
//! amplitude1_mrad = 0.05       # once per joint revolution
//! phase1_deg = 30.0
//! amplitude2_mrad = 0.02       # twice per joint revolution
//! phase2_deg = 0.0
//!
//! [backlash]
//! mrad = [0.02, 0.02, 0.02, 0.0, 0.0, 0.0]   # total play per joint
//! ```
//!
//! Torque model (documented assumption, not a dynamic model): link k's mass sits at the midpoint
//! between the origins of joint frames k and k+1 (the tool origin after the last joint), the
//! payload at the tool origin; the gravity torque about joint j's axis z_j through o_j is
//! tau_j = z_j . sum_{k >= j} (c_k - o_j) x (m_k g)  [N m, lengths in m]
//! and the joint deflects by compliance_j * tau_j in the direction of the torque.
//! Gear error: dq = A1 sin(q + phi1) + A2 sin(2 q + phi2).
//! Backlash: dq = +-play/2, the sign of the joint's last motion (from q = 0 for the first row).

use crate::error::{Error, Location, Result};
use crate::kinematics::{Frames, frames};
use crate::model::Robot;
use nalgebra::Vector3;
use serde::Deserialize;
use std::path::Path;

/// Largest mass (kg) of a link or payload: heavier than any robot lifts.
pub const MAX_MASS_KG: f64 = 1e5;
/// Largest joint error term (mrad: compliance per kN m, gear amplitude, backlash): a radian,
/// far beyond any real joint.
pub const MAX_MRAD: f64 = 1e3;
/// Largest gravity component (m/s^2).
pub const MAX_GRAVITY: f64 = 100.0;

/// Gravity compliance: deflection proportional to a static gravity torque.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Compliance {
    pub payload_kg: f64,
    pub link_masses_kg: Vec<f64>,
    /// Compliance of each joint, mrad per kN m.
    pub mrad_per_knm: Vec<f64>,
    #[serde(default = "default_gravity")]
    pub gravity: [f64; 3],
}

fn default_gravity() -> [f64; 3] {
    [0.0, 0.0, -9.81]
}

/// Periodic transmission error of one joint.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Gear {
    /// 1-based joint number.
    pub joint: usize,
    #[serde(default)]
    pub amplitude1_mrad: f64,
    #[serde(default)]
    pub phase1_deg: f64,
    #[serde(default)]
    pub amplitude2_mrad: f64,
    #[serde(default)]
    pub phase2_deg: f64,
}

#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Backlash {
    /// Total play of each joint (mrad).
    pub mrad: Vec<f64>,
}

/// All non-geometric terms of a virtual robot; the default has none.
#[derive(Debug, Clone, Default, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NonGeometric {
    pub compliance: Option<Compliance>,
    #[serde(default)]
    pub gear: Vec<Gear>,
    pub backlash: Option<Backlash>,
}

impl NonGeometric {
    /// Reads a non-geometric error file and checks it against the robot.
    pub fn read(path: impl AsRef<Path>, robot: &Robot) -> Result<Self> {
        let path = path.as_ref();
        let text = crate::io::read_text(path)?;
        let ng: NonGeometric = crate::io::parse_toml(&text, path)?;
        ng.check(robot).map_err(|m| {
            let (line, field) = locate(&text, &m);
            Error::input(
                Location {
                    file: path.to_path_buf(),
                    line,
                    field,
                },
                m,
            )
        })?;
        Ok(ng)
    }

    /// Checks list lengths, joint numbers and bounds against the robot; the message starts
    /// with the table (`compliance`, `gear of joint N`, `backlash`) and names the key at
    /// fault after "key " where one is.
    pub fn check(&self, robot: &Robot) -> std::result::Result<(), String> {
        let n = robot.dof();
        if let Some(c) = &self.compliance {
            if c.link_masses_kg.len() != n || c.mrad_per_knm.len() != n {
                let key = if c.link_masses_kg.len() != n {
                    "link_masses_kg"
                } else {
                    "mrad_per_knm"
                };
                return Err(format!(
                    "compliance: key {key}: link_masses_kg and mrad_per_knm need {n} values each \
                     (one per joint)"
                ));
            }
            let all = c
                .link_masses_kg
                .iter()
                .chain(&c.mrad_per_knm)
                .chain(&c.gravity);
            if !c.payload_kg.is_finite()
                || c.payload_kg < 0.0
                || all.clone().any(|v| !v.is_finite())
            {
                let key = if !c.payload_kg.is_finite() || c.payload_kg < 0.0 {
                    "payload_kg"
                } else if c.link_masses_kg.iter().any(|v| !v.is_finite()) {
                    "link_masses_kg"
                } else if c.mrad_per_knm.iter().any(|v| !v.is_finite()) {
                    "mrad_per_knm"
                } else {
                    "gravity"
                };
                return Err(format!(
                    "compliance: key {key}: values must be finite and the payload non-negative"
                ));
            }
            // 1e308 kg passed and gave NaN poses: keep to what a robot can carry and bend.
            let key = if c
                .link_masses_kg
                .iter()
                .any(|m| !(0.0..=MAX_MASS_KG).contains(m))
            {
                Some("link_masses_kg")
            } else if !(0.0..=MAX_MASS_KG).contains(&c.payload_kg) {
                Some("payload_kg")
            } else if c.mrad_per_knm.iter().any(|v| v.abs() > MAX_MRAD) {
                Some("mrad_per_knm")
            } else if c.gravity.iter().any(|v| v.abs() > MAX_GRAVITY) {
                Some("gravity")
            } else {
                None
            };
            if let Some(key) = key {
                return Err(format!(
                    "compliance: key {key}: masses must lie in [0, {MAX_MASS_KG}] kg, \
                     compliances within +-{MAX_MRAD} mrad per kN m and gravity within \
                     +-{MAX_GRAVITY} m/s^2"
                ));
            }
        }
        for (k, g) in self.gear.iter().enumerate() {
            if self.gear[..k].iter().any(|h| h.joint == g.joint) {
                return Err(format!(
                    "gear: joint {} is given twice (one [[gear]] table per joint)",
                    g.joint
                ));
            }
        }
        for g in &self.gear {
            if g.joint == 0 || g.joint > n {
                return Err(format!("gear: joint {} does not exist (1..{n})", g.joint));
            }
            let values = [
                g.amplitude1_mrad,
                g.phase1_deg,
                g.amplitude2_mrad,
                g.phase2_deg,
            ];
            let keys = [
                "amplitude1_mrad",
                "phase1_deg",
                "amplitude2_mrad",
                "phase2_deg",
            ];
            let max = [MAX_MRAD, 720.0, MAX_MRAD, 720.0];
            if let Some(k) = (0..4).find(|&k| values[k].is_nan() || values[k].abs() > max[k]) {
                return Err(format!(
                    "gear of joint {}: key {}: amplitudes must be finite and within \
                     +-{MAX_MRAD} mrad, phases within +-720 deg",
                    g.joint, keys[k]
                ));
            }
        }
        if let Some(b) = &self.backlash
            && (b.mrad.len() != n
                || b.mrad
                    .iter()
                    .any(|v| !v.is_finite() || *v < 0.0 || *v > MAX_MRAD))
        {
            return Err(format!(
                "backlash: key mrad: mrad needs {n} values in [0, {MAX_MRAD}]"
            ));
        }
        Ok(())
    }

    pub fn is_empty(&self) -> bool {
        self.compliance.is_none() && self.gear.is_empty() && self.backlash.is_none()
    }

    /// Joint deflections (rad) at commanded joints `q` (rad), approached from `previous`.
    /// `ws` is a frames workspace of the robot whose geometry sets the torque lever arms.
    pub fn deflection(
        &self,
        robot: &Robot,
        q: &[f64],
        previous: &[f64],
        ws: &mut Frames,
        out: &mut [f64],
    ) {
        out.fill(0.0);
        if let Some(c) = &self.compliance {
            let tau = gravity_torques(robot, c, q, ws);
            for j in 0..out.len() {
                out[j] += c.mrad_per_knm[j] * 1e-3 * tau[j] * 1e-3;
            }
        }
        for g in &self.gear {
            let j = g.joint - 1;
            out[j] += 1e-3
                * (g.amplitude1_mrad * (q[j] + g.phase1_deg.to_radians()).sin()
                    + g.amplitude2_mrad * (2.0 * q[j] + g.phase2_deg.to_radians()).sin());
        }
        if let Some(b) = &self.backlash {
            for j in 0..out.len() {
                let dir = (q[j] - previous[j]).signum();
                out[j] += 0.5 * b.mrad[j] * 1e-3 * dir;
            }
        }
    }
}

/// Gravity torque about every joint axis (N m) at joints `q` (rad); see the module docs.
pub fn gravity_torques(robot: &Robot, c: &Compliance, q: &[f64], ws: &mut Frames) -> Vec<f64> {
    frames(robot, q, ws);
    let n = robot.dof();
    let g = Vector3::from(c.gravity);
    let origin = |k: usize| {
        if k < n {
            ws.joint[k].translation.vector
        } else {
            ws.tool.translation.vector
        }
    };
    // Mass points (mm) and masses (kg): links, then the payload.
    let mut points: Vec<(usize, Vector3<f64>, f64)> = (0..n)
        .map(|k| (k, (origin(k) + origin(k + 1)) * 0.5, c.link_masses_kg[k]))
        .collect();
    points.push((n, origin(n), c.payload_kg));
    (0..n)
        .map(|j| {
            let z: Vector3<f64> = ws.joint[j].rotation.matrix().column(2).into();
            let o = origin(j);
            points
                .iter()
                .filter(|(k, _, _)| *k >= j)
                .map(|(_, p, m)| z.dot(&((p - o) * 1e-3).cross(&(g * *m))))
                .sum()
        })
        .collect()
}

/// The line and key of a [`NonGeometric::check`] message in the file's text: the key's line
/// within its table (`[compliance]`, the `[[gear]]` of that joint, `[backlash]`).
fn locate(text: &str, message: &str) -> (Option<usize>, Option<String>) {
    let key = message
        .split("key ")
        .nth(1)
        .and_then(|r| r.split(':').next())
        .map(|k| k.trim().to_string());
    let lines: Vec<&str> = text.lines().collect();
    // Where the table starts.
    let start = if let Some(rest) = message.strip_prefix("gear of joint ") {
        let joint: String = rest.chars().take_while(char::is_ascii_digit).collect();
        let mut in_gear = None;
        let mut found = None;
        for (i, l) in lines.iter().enumerate() {
            let t = l.trim();
            if t.starts_with("[[gear]]") {
                in_gear = Some(i);
            } else if t.starts_with('[') {
                in_gear = None;
            } else if let Some(g) = in_gear
                && t.starts_with("joint")
                && t.split('=').nth(1).map(|v| v.trim()) == Some(joint.as_str())
            {
                found = Some(g);
                break;
            }
        }
        found
    } else {
        let table = message.split(':').next().unwrap_or("");
        lines.iter().position(|l| l.trim() == format!("[{table}]"))
    };
    let line = match (&key, start) {
        (Some(k), Some(s)) => lines[s..]
            .iter()
            .position(|l| l.trim_start().starts_with(k.as_str()))
            .map(|i| s + i + 1)
            .or(Some(s + 1)),
        (None, Some(s)) => Some(s + 1),
        _ => None,
    };
    (line, key)
}
