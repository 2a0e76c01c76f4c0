//! Non-geometric errors of a virtual robot: what real robots have and parametric models miss.
//! Each term is a joint deflection added to the commanded joints before the true model's FK.
//!
//! ```toml
//! [compliance]                 # joint deflection = compliance * gravity torque
//! payload_kg = 210.0           # at the tool origin
//! link_masses_kg = [400.0, 200.0, 250.0, 30.0, 20.0, 5.0]
//! mrad_per_knm = [0.0, 0.05, 0.08, 0.0, 0.0, 0.0]
//! gravity = [0.0, 0.0, -9.81]  # m/s^2 in the base frame, after the base row (default: -z)
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
//! tau_j = z_j . sum_{k >= j} (c_k - o_j) x (m_k g)  [N m, lengths in m] (for a prismatic
//! joint the force along its axis, N; the direct point-mass sum of `kinematics::gravity`, which
//! the model's suffix sums equal, a test checks)
//! and the joint deflects by compliance_j * tau_j in the direction of the torque.
//! Gear error: dq = A1 sin(q + phi1) + A2 sin(2 q + phi2).
//! Backlash: dq = +-play/2, the sign of the joint's last motion (from q = 0 for the first row).

use crate::error::{Error, Location, Result};
use crate::kinematics::gravity::PointMass;
use crate::kinematics::{Frames, frames};
use crate::model::{BodyMass, MassProperties, Robot};
use nalgebra::Vector3;
use serde::Deserialize;
use std::path::Path;

pub use crate::model::mass::{MAX_GRAVITY, MAX_MASS_KG};
/// Largest joint error term (mrad: compliance per kN m, gear amplitude, backlash): a radian,
/// far beyond any real joint.
pub const MAX_MRAD: f64 = 1e3;

/// Gravity compliance: deflection proportional to a static gravity torque.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Compliance {
    /// Payload mass at the tool origin (kg).
    pub payload_kg: f64,
    /// Mass of each link (kg), placed midway between its joint origin and the next.
    pub link_masses_kg: Vec<f64>,
    /// Compliance of each joint, mrad per kN m.
    pub mrad_per_knm: Vec<f64>,
    /// Gravity acceleration in the base frame (m/s^2); default [0, 0, -9.81].
    #[serde(default = "default_gravity")]
    pub gravity: [f64; 3],
}

impl Compliance {
    /// This compliance model as the model's own ([`crate::model::compliance`]): the robot
    /// with mass properties where the simulator puts its masses (link k's midway between
    /// joint origins k and k + 1, written in joint frame k at q = 0, which is exact at every
    /// configuration when joint k + 1 is revolute, its origin being fixed in frame k; the
    /// payload at the tool origin) and the same compliances. Its `tool_pose` is then the
    /// simulator's pose with this compliance alone.
    pub fn on_robot(&self, robot: &Robot) -> Result<Robot> {
        let n = robot.dof();
        let mut f = Frames::new(robot);
        frames(&robot.rigid(), &vec![0.0; n], &mut f);
        let origin = |k: usize| {
            if k < n {
                f.joint[k].translation.vector
            } else {
                f.tool.translation.vector
            }
        };
        let links = (0..n)
            .map(|k| {
                let mid = (origin(k) + origin(k + 1)) * 0.5;
                BodyMass {
                    mass_kg: self.link_masses_kg.get(k).copied().unwrap_or(0.0),
                    com_mm: f.joint[k].inverse_transform_point(&mid.into()).coords,
                }
            })
            .collect();
        let masses = MassProperties {
            links,
            payload: BodyMass {
                mass_kg: self.payload_kg,
                com_mm: Vector3::zeros(),
            },
            gravity: Vector3::from(self.gravity),
        };
        robot
            .with_compliance(None)?
            .with_masses(Some(masses))?
            .with_compliance(Some(crate::model::Compliance::from_file_units(
                &self.mrad_per_knm,
            )))
    }
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
    /// Amplitude A1 of the once-per-revolution term (mrad).
    #[serde(default)]
    pub amplitude1_mrad: f64,
    /// Phase phi1 of the once-per-revolution term (deg).
    #[serde(default)]
    pub phase1_deg: f64,
    /// Amplitude A2 of the twice-per-revolution term (mrad).
    #[serde(default)]
    pub amplitude2_mrad: f64,
    /// Phase phi2 of the twice-per-revolution term (deg).
    #[serde(default)]
    pub phase2_deg: f64,
}

/// Backlash: each joint is off by half its play, with the sign of its last motion.
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
    /// Gravity compliance of the joints, if any.
    pub compliance: Option<Compliance>,
    /// Transmission errors, at most one per joint.
    #[serde(default)]
    pub gear: Vec<Gear>,
    /// Joint backlash, if any.
    pub backlash: Option<Backlash>,
}

impl NonGeometric {
    /// Reads a non-geometric error file and checks it against the robot; a fault names the
    /// line and key of the value at fault.
    pub fn read(path: impl AsRef<Path>, robot: &Robot) -> Result<Self> {
        let path = path.as_ref();
        let text = crate::io::read_text(path)?;
        let ng: NonGeometric = crate::io::parse_toml(&text, path)?;
        ng.check(robot).map_err(|f| {
            Error::input(
                Location {
                    file: path.to_path_buf(),
                    line: f.line_in(&text),
                    field: Some(f.key.to_string()),
                },
                f.to_string(),
            )
        })?;
        Ok(ng)
    }

    /// Checks list lengths, joint numbers and bounds against the robot.
    pub fn check(&self, robot: &Robot) -> std::result::Result<(), Fault> {
        let n = robot.dof();
        if let Some(c) = &self.compliance {
            for (key, values) in [
                ("link_masses_kg", &c.link_masses_kg),
                ("mrad_per_knm", &c.mrad_per_knm),
            ] {
                if values.len() != n {
                    return Err(Fault::new(
                        Table::Compliance,
                        key,
                        format!(
                            "link_masses_kg and mrad_per_knm need {n} values each (one per joint)"
                        ),
                    ));
                }
            }
            // 1e308 kg passed and gave NaN poses: keep to what a robot can carry and bend
            // (a NaN lies in no range).
            let payload = [c.payload_kg];
            let ranges: [(&str, &[f64], f64, f64); 4] = [
                ("link_masses_kg", &c.link_masses_kg, 0.0, MAX_MASS_KG),
                ("payload_kg", &payload, 0.0, MAX_MASS_KG),
                ("mrad_per_knm", &c.mrad_per_knm, -MAX_MRAD, MAX_MRAD),
                ("gravity", &c.gravity, -MAX_GRAVITY, MAX_GRAVITY),
            ];
            for (key, values, lo, hi) in ranges {
                if values.iter().any(|v| !(lo..=hi).contains(v)) {
                    return Err(Fault::new(
                        Table::Compliance,
                        key,
                        format!(
                            "masses must lie in [0, {MAX_MASS_KG}] kg, compliances within \
                             +-{MAX_MRAD} mrad per kN m and gravity within +-{MAX_GRAVITY} m/s^2"
                        ),
                    ));
                }
            }
        }
        for (k, g) in self.gear.iter().enumerate() {
            let table = Table::Gear(k);
            if self.gear[..k].iter().any(|h| h.joint == g.joint) {
                return Err(Fault::new(
                    table,
                    "joint",
                    format!(
                        "joint {} is given twice (one [[gear]] table per joint)",
                        g.joint
                    ),
                ));
            }
            if g.joint == 0 || g.joint > n {
                return Err(Fault::new(
                    table,
                    "joint",
                    format!("joint {} does not exist (1..{n})", g.joint),
                ));
            }
            let values = [
                ("amplitude1_mrad", g.amplitude1_mrad, MAX_MRAD),
                ("phase1_deg", g.phase1_deg, 720.0),
                ("amplitude2_mrad", g.amplitude2_mrad, MAX_MRAD),
                ("phase2_deg", g.phase2_deg, 720.0),
            ];
            if let Some((key, ..)) = values
                .iter()
                .find(|(_, v, max)| v.is_nan() || v.abs() > *max)
            {
                return Err(Fault::new(
                    table,
                    key,
                    format!(
                        "joint {}: amplitudes must be finite and within +-{MAX_MRAD} mrad, \
                         phases within +-720 deg",
                        g.joint
                    ),
                ));
            }
        }
        if let Some(b) = &self.backlash
            && (b.mrad.len() != n || b.mrad.iter().any(|v| !(0.0..=MAX_MRAD).contains(v)))
        {
            return Err(Fault::new(
                Table::Backlash,
                "mrad",
                format!("mrad needs {n} values in [0, {MAX_MRAD}]"),
            ));
        }
        Ok(())
    }

    /// Whether there is no term at all (the true robot is then purely geometric).
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

/// Gravity torque about every joint axis (N m; N along a prismatic one) at joints `q` (rad),
/// from the masses of the module docs, by the direct point-mass sum
/// ([`crate::kinematics::gravity::gravity_torques`]; the model's suffix sums in
/// `kinematics::load` give the same torques to 1e-9, `tests/gravity.rs`).
pub fn gravity_torques(robot: &Robot, c: &Compliance, q: &[f64], ws: &mut Frames) -> Vec<f64> {
    frames(robot, q, ws);
    let n = robot.dof();
    let origin = |k: usize| {
        if k < n {
            ws.joint[k].translation.vector
        } else {
            ws.tool.translation.vector
        }
    };
    // Link k's mass midway between joint origins k and k + 1 (carried by joints 0..=k),
    // then the payload at the tool origin (carried by all).
    let mut points: Vec<PointMass> = (0..n)
        .map(|k| PointMass {
            mass_kg: c.link_masses_kg[k],
            position_mm: (origin(k) + origin(k + 1)) * 0.5,
            frame: k,
        })
        .collect();
    points.push(PointMass {
        mass_kg: c.payload_kg,
        position_mm: origin(n),
        frame: n,
    });
    let mut tau = vec![0.0; n];
    // Gravity is given in the robot's base frame (after the base row), as in robot files.
    let g = robot.base().transform().rotation * Vector3::from(c.gravity);
    crate::kinematics::gravity::gravity_torques(robot, &ws.joint, &g, &points, &mut tau);
    tau
}

/// The table of a non-geometric file a [`Fault`] lies in.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Table {
    /// The `[compliance]` table.
    Compliance,
    /// The k-th `[[gear]]` table (0-based).
    Gear(usize),
    /// The `[backlash]` table.
    Backlash,
}

/// What [`NonGeometric::check`] found wrong: the table, the key and why.
#[derive(Debug, Clone, PartialEq)]
pub struct Fault {
    /// The table the faulty value lies in.
    pub table: Table,
    /// The key at fault, e.g. `mrad_per_knm`.
    pub key: &'static str,
    /// Why the value is refused.
    pub message: String,
}

impl Fault {
    fn new(table: Table, key: &'static str, message: String) -> Self {
        Fault {
            table,
            key,
            message,
        }
    }

    /// The 1-based line of the key in the file's `text`: the first line starting with the
    /// key after its table's header (the header's own line when the key is absent).
    pub fn line_in(&self, text: &str) -> Option<usize> {
        let lines: Vec<&str> = text.lines().collect();
        let headers = lines
            .iter()
            .enumerate()
            .filter(|(_, l)| l.trim_start().starts_with('['));
        let start = match self.table {
            Table::Compliance => headers.clone().find(|(_, l)| l.trim() == "[compliance]"),
            Table::Backlash => headers.clone().find(|(_, l)| l.trim() == "[backlash]"),
            Table::Gear(k) => headers
                .clone()
                .filter(|(_, l)| l.trim() == "[[gear]]")
                .nth(k),
        }?
        .0;
        let end = headers
            .map(|(i, _)| i)
            .find(|&i| i > start)
            .unwrap_or(lines.len());
        let at = (start + 1..end).find(|&i| {
            let l = lines[i].trim_start();
            l.strip_prefix(self.key)
                .is_some_and(|r| r.trim_start().starts_with('='))
        });
        Some(at.unwrap_or(start) + 1)
    }
}

impl std::fmt::Display for Fault {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let table = match self.table {
            Table::Compliance => "compliance".to_string(),
            Table::Gear(_) => "gear".to_string(),
            Table::Backlash => "backlash".to_string(),
        };
        write!(f, "{table}: {}", self.message)
    }
}
