//! The robot model: a base frame, N joints and a tool frame, in chain order
//! (thesis eq. 3.12: T = T_R T_1 ... T_N T_T), with its named parameters.
//!
//! A [`Robot`] never changes during a solve. It keeps the rows as written (file units) and a
//! compiled chain of constant transforms that forward kinematics runs through.

use super::chain::{Chain, compile};
use super::compliance::Compliance;
pub use super::joint::{Joint, JointType, LIMIT_TOL};
use super::mass::MassProperties;
use super::row::{Convention, Field, PAYLOAD, Row};
use crate::error::{Error, Result};

/// Largest length (mm) a robot may hold: 100 m, far beyond any robot or cell, small enough
/// that poses stay exact in f64.
pub const MAX_LENGTH_MM: f64 = 1e5;
/// Largest angle (deg) of a row's field.
pub const MAX_ANGLE_DEG: f64 = 720.0;
/// Largest joint limit (deg) of a revolute joint: four turns either way.
pub const MAX_JOINT_DEG: f64 = 1440.0;

/// Where a parameter sits in the chain.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Slot {
    /// The base row (T_R).
    Base,
    /// Joint index, 0-based (joint 1 is `Joint(0)`).
    Joint(usize),
    /// The tool row (T_T).
    Tool,
}

/// A named model parameter: a field of a row.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct ParamId {
    /// The row the parameter belongs to.
    pub slot: Slot,
    /// The parameter's field in that row.
    pub field: Field,
}

/// The parts of a mass-free coefficient's name (`k2.mx3`), by [`Field::K`]'s `part`: the
/// mass, then its moment along x, y, z.
const K_PARTS: [&str; 4] = ["m", "mx", "my", "mz"];

/// Why joint compliances c_j cannot go without a link or payload mass: the deflection is
/// c_j tau_j, and without mass the gravity torque tau_j is zero (a `[mass]` table may give
/// gravity alone, for the mass-free `moments`).
const NO_MASS_FOR_COMPLIANCE: &str = "joint compliances need mass properties (a [mass] table \
     with link masses or a payload: without mass there is no gravity torque to deflect the \
     joints, and the compliances would do nothing)";

impl ParamId {
    /// The parameter's name: `a3`, `alpha2`, `theta1`, `beta3`, `base.x`, `tool.rz`, `c2`
    /// (a compliance), `k2.mx3` (a mass-free compliance coefficient: joint 2, link 3's moment
    /// along x; `k2.mP` the payload's mass), ...
    pub fn name(&self) -> String {
        if let (Field::K { body, part }, Slot::Joint(j)) = (self.field, self.slot) {
            let body = if body == PAYLOAD {
                "P".to_string()
            } else {
                (body + 1).to_string()
            };
            let part = K_PARTS[usize::from(part.min(3))];
            return format!("k{}.{part}{body}", j + 1);
        }
        match self.slot {
            Slot::Base => format!("base.{}", self.field.name()),
            Slot::Tool => format!("tool.{}", self.field.name()),
            Slot::Joint(i) => format!("{}{}", self.field.name(), i + 1),
        }
    }
}

/// A robot: base row, joints and tool row. Immutable during a solve; see [`Robot::with_param`]
/// for changing one parameter.
#[derive(Debug, Clone)]
pub struct Robot {
    name: String,
    base: Row,
    joints: Vec<Joint>,
    tool: Row,
    /// Mass properties, for gravity torques (none: a rigid, massless model).
    masses: Option<MassProperties>,
    /// Joint compliances (none: rigid joints); only with mass properties.
    compliance: Option<Compliance>,
    /// Parameters a calibration's measurements did not observe (no effect on them), in
    /// [`Robot::parameters`] order: they keep the values the calibration started from.
    unobserved: Vec<ParamId>,
    chain: Chain,
}

impl PartialEq for Robot {
    fn eq(&self, other: &Self) -> bool {
        self.name == other.name
            && self.base == other.base
            && self.joints == other.joints
            && self.tool == other.tool
            && self.masses == other.masses
            && self.compliance == other.compliance
            && self.unobserved == other.unobserved
    }
}

impl Robot {
    /// Builds a robot and checks it: at least one joint, finite values, limits in order,
    /// no 6-DOF transform as a joint row, no prismatic Hayati row (it has no d).
    pub fn new(name: impl Into<String>, base: Row, joints: Vec<Joint>, tool: Row) -> Result<Self> {
        if joints.is_empty() {
            return Err(Error::Model("a robot needs at least one joint".into()));
        }
        for (i, j) in joints.iter().enumerate() {
            let n = i + 1;
            match (j.row.convention(), j.joint_type) {
                (Convention::Transform, _) => {
                    return Err(Error::Model(format!(
                        "joint {n}: a 6-DOF transform cannot carry a joint variable; use mdh, hayati or dh"
                    )));
                }
                (Convention::Hayati, JointType::Prismatic) => {
                    return Err(Error::Model(format!(
                        "joint {n}: a Hayati row has no d, so it cannot be prismatic"
                    )));
                }
                _ => {}
            }
            let [lo, hi] = j.limits;
            if !(lo.is_finite() && hi.is_finite()) || lo > hi {
                return Err(Error::Model(format!(
                    "joint {n}: limits [{lo}, {hi}] must be finite with min <= max"
                )));
            }
        }
        let robot_rows = std::iter::once(("base".to_string(), &base))
            .chain(
                joints
                    .iter()
                    .enumerate()
                    .map(|(i, j)| (format!("joint {}", i + 1), &j.row)),
            )
            .chain(std::iter::once(("tool".to_string(), &tool)));
        // The file's bounds hold for robots made in code too (a deviation, an identification
        // step), so that no robot poses beyond what f64 keeps exact.
        for (label, row) in robot_rows {
            for &f in row.convention().fields() {
                let v = row.file_value(f).unwrap_or(0.0);
                let bound = if f.is_angle() {
                    MAX_ANGLE_DEG
                } else {
                    MAX_LENGTH_MM
                };
                if v.is_nan() || v.abs() > bound {
                    return Err(Error::Model(format!(
                        "{label}: {} = {v} {} is not finite or beyond the bound of {bound}",
                        f.name(),
                        f.file_unit()
                    )));
                }
            }
        }
        let chain = compile(&base, &joints, &tool);
        Ok(Robot {
            name: name.into(),
            base,
            joints,
            tool,
            masses: None,
            compliance: None,
            unobserved: Vec::new(),
            chain,
        })
    }

    /// A copy with these mass properties (none: massless); properties for another joint
    /// count, or out of their bounds, are an error, and so is removing the masses of a robot
    /// with compliances (they would have no torque to act on). A table whose masses are all
    /// zero is not refused here: a cell without payload holds a payload-only compliant model
    /// undeflected ([`Robot::with_compliance`], which a robot file goes through, refuses
    /// compliances without any mass).
    pub fn with_masses(&self, masses: Option<MassProperties>) -> Result<Robot> {
        if let Some(f) = masses.as_ref().and_then(|m| m.fault(self.dof())) {
            return Err(Error::Model(format!("mass properties: {f}")));
        }
        if masses.is_none()
            && self
                .compliance
                .as_ref()
                .is_some_and(|c| !c.joints.is_empty())
        {
            return Err(Error::Model(NO_MASS_FOR_COMPLIANCE.into()));
        }
        Ok(Robot {
            masses,
            ..self.clone()
        }
        .keeping_unobserved(&self.unobserved))
    }

    /// The mass properties, if the robot has them.
    #[inline]
    pub fn masses(&self) -> Option<&MassProperties> {
        self.masses.as_ref()
    }

    /// A copy with these joint compliances (none: rigid joints). Joint compliances need mass
    /// properties with a link or payload mass; compliances for another joint count, or out of
    /// their bounds, are an error.
    pub fn with_compliance(&self, compliance: Option<Compliance>) -> Result<Robot> {
        if let Some(c) = &compliance {
            if !self.masses.as_ref().is_some_and(MassProperties::has_mass)
                && c.joints.iter().any(|&v| v != 0.0)
            {
                return Err(Error::Model(NO_MASS_FOR_COMPLIANCE.into()));
            }
            if let Some(f) = c.fault(self.dof()) {
                return Err(Error::Model(format!("compliance: {f}")));
            }
        }
        Ok(Robot {
            compliance,
            ..self.clone()
        })
    }

    /// The joint compliances, if the robot has them.
    #[inline]
    pub fn compliance(&self) -> Option<&Compliance> {
        self.compliance.as_ref()
    }

    /// The parameters its calibration did not observe (no effect on the measurements), in
    /// [`Robot::parameters`] order; they keep the values the calibration started from, and
    /// what depends on them is unchecked (`kinematics::unobserved`, which reads it). Empty for a
    /// model no calibration marked.
    pub fn unobserved(&self) -> &[ParamId] {
        &self.unobserved
    }

    /// A copy that marks `ids` as unobserved (replacing any marks); a parameter the robot
    /// does not have is an error.
    pub fn with_unobserved(&self, ids: &[ParamId]) -> Result<Robot> {
        let params = self.parameters();
        if let Some(id) = ids.iter().find(|id| !params.contains(id)) {
            return Err(Error::Invalid(format!(
                "unobserved parameter {}: the model has no such parameter",
                id.name()
            )));
        }
        Ok(self.clone().keeping_unobserved(ids))
    }

    /// This robot marking those of `ids` it has, in parameter order.
    fn keeping_unobserved(mut self, ids: &[ParamId]) -> Robot {
        if ids.is_empty() && self.unobserved.is_empty() {
            return self;
        }
        let params = self.parameters();
        self.unobserved = params.into_iter().filter(|p| ids.contains(p)).collect();
        self
    }

    /// The same robot with rigid joints (its compliances removed, its masses kept).
    pub fn rigid(&self) -> Robot {
        Robot {
            compliance: None,
            ..self.clone()
        }
    }

    /// Whether the robot's joints bend under gravity: a non-zero compliance (joint
    /// compliances with masses, or mass-free coefficients). Forward kinematics then runs
    /// q' = q + delta(q) ([`super::compliance`]).
    #[inline]
    pub fn is_compliant(&self) -> bool {
        self.compliance.as_ref().is_some_and(|c| {
            c.has_moments() || (self.masses.is_some() && c.joints.iter().any(|&v| v != 0.0))
        })
    }

    /// The robot's name (from its file, or given in code).
    pub fn name(&self) -> &str {
        &self.name
    }

    /// The base row (T_R: world to the frame before joint 1).
    pub fn base(&self) -> &Row {
        &self.base
    }

    /// The tool row (T_T: last joint's frame to the tool frame).
    pub fn tool(&self) -> &Row {
        &self.tool
    }

    /// The joints in chain order (joint 1 first).
    pub fn joints(&self) -> &[Joint] {
        &self.joints
    }

    /// Number of joints N.
    pub fn dof(&self) -> usize {
        self.joints.len()
    }

    #[inline]
    pub(crate) fn chain(&self) -> &Chain {
        &self.chain
    }

    fn row(&self, slot: Slot) -> Option<&Row> {
        match slot {
            Slot::Base => Some(&self.base),
            Slot::Tool => Some(&self.tool),
            Slot::Joint(i) => self.joints.get(i).map(|j| &j.row),
        }
    }

    /// Every parameter of the model, in chain order (base, joints 1..N, tool) and, within a
    /// row, in the order of its transform product; then, for a robot with mass properties,
    /// the joint compliances c1..cN, or for one without, the mass-free coefficients k_jbi
    /// ([`super::compliance`]).
    pub fn parameters(&self) -> Vec<ParamId> {
        let mut out = Vec::new();
        let mut push = |slot: Slot, row: &Row| {
            for &field in row.convention().fields() {
                out.push(ParamId { slot, field });
            }
        };
        push(Slot::Base, &self.base);
        for (i, j) in self.joints.iter().enumerate() {
            push(Slot::Joint(i), &j.row);
        }
        push(Slot::Tool, &self.tool);
        // A robot with masses has a compliance per joint (zero until identified); one
        // without has the mass-free coefficients of every body each joint carries.
        let n = self.dof();
        if self.masses.as_ref().is_some_and(|m| m.has_mass()) {
            out.extend((0..n).map(|i| ParamId {
                slot: Slot::Joint(i),
                field: Field::C,
            }));
        } else {
            for j in 0..n {
                for b in j..=n {
                    for part in 0..4u8 {
                        out.push(ParamId {
                            slot: Slot::Joint(j),
                            field: Field::K {
                                body: body_code(b, n),
                                part,
                            },
                        });
                    }
                }
            }
        }
        out
    }

    /// Finds a parameter by name: `a3`, `base.x`, `tool.rz`; the thesis's `dR`, `thetaR`
    /// (base) and `aT`, `alphaT` (tool) are accepted too.
    pub fn find_param(&self, name: &str) -> Option<ParamId> {
        if let Some(rest) = name.strip_prefix('k')
            && let Some((joint, body)) = rest.split_once('.')
        {
            // Parsed, not matched against every parameter's formatted name: identification
            // maps a hundred such names at a time.
            let j: usize = joint.parse().ok().filter(|&j| j >= 1)?;
            // The longest part first ("m" begins them all).
            let (part, link) = (0..K_PARTS.len())
                .rev()
                .find_map(|p| body.strip_prefix(K_PARTS[p]).map(|l| (p as u8, l)))?;
            let code = if link == "P" {
                PAYLOAD
            } else {
                let b: usize = link.parse().ok().filter(|&b| b >= 1 && b <= self.dof())?;
                body_code(b - 1, self.dof())
            };
            let id = ParamId {
                slot: Slot::Joint(j - 1),
                field: Field::K { body: code, part },
            };
            // Its name must read back as given ("k2.mx03" is no parameter).
            return (self.parameters().contains(&id) && id.name() == name).then_some(id);
        }
        let (slot, field) = if let Some(f) = name.strip_prefix("base.") {
            (Slot::Base, f)
        } else if let Some(f) = name.strip_prefix("tool.") {
            (Slot::Tool, f)
        } else if let Some(f) = name
            .strip_suffix('R')
            .filter(|f| Field::from_name(f).is_some())
        {
            (Slot::Base, f)
        } else if let Some(f) = name
            .strip_suffix('T')
            .filter(|f| Field::from_name(f).is_some())
        {
            (Slot::Tool, f)
        } else {
            let split = name.find(|c: char| c.is_ascii_digit())?;
            let (f, num) = name.split_at(split);
            let n: usize = num.parse().ok()?;
            if n == 0 {
                return None;
            }
            (Slot::Joint(n - 1), f)
        };
        let field = Field::from_name(field)?;
        let id = ParamId { slot, field };
        if field == Field::C {
            return self.parameters().contains(&id).then_some(id);
        }
        self.row(slot)?.file_value(field).map(|_| id)
    }

    /// A parameter's value in internal units (mm, rad; a compliance in rad per N m).
    pub fn param(&self, id: ParamId) -> f64 {
        match (id.field, id.slot) {
            (Field::C, Slot::Joint(i)) => self.compliance.as_ref().map_or(0.0, |c| c.joint(i)),
            (Field::K { body, part }, Slot::Joint(j)) => {
                self.compliance.as_ref().map_or(0.0, |c| {
                    c.moment(
                        self.dof(),
                        j,
                        body_index(body, self.dof()),
                        usize::from(part),
                    )
                })
            }
            _ => self.row(id.slot).map_or(0.0, |r| r.value(id.field)),
        }
    }

    /// A copy with one parameter set, in internal units (mm or rad).
    pub fn with_param(&self, id: ParamId, value: f64) -> Result<Robot> {
        self.with_params(&[(id, value)])
    }

    /// A copy with several parameters set, in internal units (mm, rad; a compliance in rad
    /// per N m).
    pub fn with_params(&self, values: &[(ParamId, f64)]) -> Result<Robot> {
        let mut base = self.base.clone();
        let mut joints = self.joints.clone();
        let mut tool = self.tool.clone();
        let mut compliance = self.compliance.clone();
        for &(id, v) in values {
            let n = self.dof();
            match (id.field, id.slot) {
                (Field::C, Slot::Joint(i))
                    if i < n && self.masses.as_ref().is_some_and(|m| m.has_mass()) =>
                {
                    let c = compliance.get_or_insert_with(Compliance::default);
                    c.joints.resize(n, 0.0);
                    c.joints[i] = Field::C.to_file(v);
                    continue;
                }
                (Field::K { body, part }, Slot::Joint(j))
                    if j < n
                        && body_index(body, n) <= n
                        && body_index(body, n) >= j
                        && part < 4 =>
                {
                    let c = compliance.get_or_insert_with(Compliance::default);
                    c.moments.resize(n * (n + 1) * 4, 0.0);
                    let at = super::compliance::moment_index(
                        n,
                        j,
                        body_index(body, n),
                        usize::from(part),
                    );
                    c.moments[at] = id.field.to_file(v);
                    continue;
                }
                (Field::C | Field::K { .. }, _) => {
                    return Err(Error::Invalid(format!("no parameter {}", id.name())));
                }
                _ => {}
            }
            let row = match id.slot {
                Slot::Base => &mut base,
                Slot::Tool => &mut tool,
                Slot::Joint(i) => match joints.get_mut(i) {
                    Some(j) => &mut j.row,
                    None => return Err(Error::Invalid(format!("no parameter {}", id.name()))),
                },
            };
            if !row.set_value(id.field, v) {
                return Err(Error::Invalid(format!("no parameter {}", id.name())));
            }
        }
        Ok(Robot::new(self.name.clone(), base, joints, tool)?
            .with_masses(self.masses.clone())?
            .with_compliance(compliance)?
            .keeping_unobserved(&self.unobserved))
    }

    /// A copy whose base or tool row is replaced by the 6-DOF transform with the same pose.
    pub fn with_frame_as_transform(&self, slot: Slot) -> Result<Robot> {
        let (row, is_base) = match slot {
            Slot::Base => (&self.base, true),
            Slot::Tool => (&self.tool, false),
            Slot::Joint(_) => {
                return Err(Error::Invalid("only base and tool rows are frames".into()));
            }
        };
        let t = row.transform();
        let [rz, ry, rx] = crate::geometry::rotation::rotation_to_zyx(&t.rotation);
        let v = t.translation.vector;
        let mut new = Row::zero(Convention::Transform);
        for (f, val) in [
            (Field::X, v.x),
            (Field::Y, v.y),
            (Field::Z, v.z),
            (Field::Rz, rz),
            (Field::Ry, ry),
            (Field::Rx, rx),
        ] {
            new.set_value(f, val);
        }
        let (base, tool) = if is_base {
            (new, self.tool.clone())
        } else {
            (self.base.clone(), new)
        };
        // A re-expressed frame has other parameters: marks on the old ones have no meaning.
        self.with_rows(base, tool)
    }

    /// A copy whose 6-DOF base or tool rows in `slots` are [`Row::rebased`]: the same
    /// frames, their angles turns about the frames' own axes from here on (for a solve that
    /// starts here, where a frame sits at the gimbal lock of its Z-Y-X angles).
    pub(crate) fn with_frames_rebased(&self, slots: &[Slot]) -> Result<Robot> {
        let row = |slot: Slot, r: &Row| {
            if slots.contains(&slot) {
                r.rebased()
            } else {
                r.clone()
            }
        };
        self.with_rows(row(Slot::Base, &self.base), row(Slot::Tool, &self.tool))
    }

    /// The robot with every reference rotation folded into its rows' angles (a copy; the
    /// same robot where there is none): the frames as a file writes them.
    pub fn plain(&self) -> Result<Robot> {
        if !self.base.is_rebased() && !self.tool.is_rebased() {
            return Ok(self.clone());
        }
        self.with_rows(self.base.plain(), self.tool.plain())
    }

    /// A copy with the base and tool rows given (joints, masses, compliance and the marks
    /// kept where they still name parameters).
    fn with_rows(&self, base: Row, tool: Row) -> Result<Robot> {
        Ok(
            Robot::new(self.name.clone(), base, self.joints.clone(), tool)?
                .with_masses(self.masses.clone())?
                .with_compliance(self.compliance.clone())?
                .keeping_unobserved(&self.unobserved),
        )
    }

    /// This robot with `other`'s tool row and payload (mass, mm centre of mass; where both
    /// have mass properties): what a cell changes (another gripper, another load) while the
    /// arm's calibration stays, so that a model embedded elsewhere (a compensator's) takes
    /// those of the file given with it. Also says whether the tool and the payload changed.
    pub fn with_tool_and_payload_of(&self, other: &Robot) -> Result<(Robot, bool, bool)> {
        let tool = self.tool != other.tool;
        let mut robot = if tool {
            self.with_rows(self.base.clone(), other.tool.clone())?
        } else {
            self.clone()
        };
        let payload = match (&self.masses, &other.masses) {
            (Some(a), Some(b)) if a.payload != b.payload => {
                let mut m = a.clone();
                m.payload = b.payload;
                robot = robot.with_masses(Some(m))?;
                true
            }
            _ => false,
        };
        Ok((robot, tool, payload))
    }

    /// Whether `other` has the same number and types of joints (so joint vectors fit both).
    pub fn same_joints(&self, other: &Robot) -> bool {
        self.dof() == other.dof()
            && self
                .joints()
                .iter()
                .zip(other.joints())
                .all(|(a, b)| a.joint_type == b.joint_type)
    }

    /// This robot with `other`'s joint limits (deg, mm), and the 1-based numbers of the joints
    /// whose limits that changes: the limits are the cell's (a robot file's), not a
    /// calibration's, so a model embedded elsewhere (a compensator's) takes those of the file
    /// given with it. An error when the joints differ in number or type.
    pub fn with_limits_of(&self, other: &Robot) -> Result<(Robot, Vec<usize>)> {
        if !self.same_joints(other) {
            return Err(Error::Model(format!(
                "joint limits of a robot with other joints ({} and {})",
                self.dof(),
                other.dof()
            )));
        }
        let mut robot = self.clone();
        let mut changed = Vec::new();
        for (i, (j, o)) in robot.joints.iter_mut().zip(other.joints()).enumerate() {
            if j.limits != o.limits {
                j.limits = o.limits;
                changed.push(i + 1);
            }
        }
        Ok((robot, changed))
    }

    /// The middle of every joint's range (rad or mm): the reference for choosing among IK
    /// solutions when no seed is given.
    pub fn mid_joints(&self) -> Vec<f64> {
        self.joints()
            .iter()
            .map(|j| {
                let [lo, hi] = j.limits_internal();
                0.5 * (lo + hi)
            })
            .collect()
    }

    /// Checks a joint vector (internal units) against the limits; returns the 0-based indices
    /// of the joints outside, with a tolerance of [`LIMIT_TOL`] (rad or mm).
    pub fn joints_outside_limits(&self, q: &[f64]) -> Vec<usize> {
        self.joints
            .iter()
            .zip(q)
            .enumerate()
            .filter(|(_, (j, v))| {
                let [lo, hi] = j.limits_internal();
                **v < lo - LIMIT_TOL || **v > hi + LIMIT_TOL
            })
            .map(|(i, _)| i)
            .collect()
    }

    /// `q` (rad, mm) with each revolute joint moved by whole turns to its copy nearest
    /// `reference` within the limits ([`Joint::nearest_turn`]): the same pose, as a
    /// controller choosing near the reference takes it. None where a joint has no copy within
    /// them.
    pub fn turns_near(&self, q: &[f64], reference: &[f64]) -> Option<Vec<f64>> {
        (self.joints.iter().zip(q).zip(reference))
            .map(|((joint, &v), &r)| joint.nearest_turn(v, r))
            .collect()
    }

    /// `q` (rad, mm) with each joint outside its limits moved inside: a revolute joint to its
    /// whole-turn copy nearest the range's middle, and then (any joint) held at least
    /// `inset` times its range inside the limits (`inset` clamped to [0, 0.5]); a joint
    /// within the limits is kept as it is. A start for a solve that should end within the
    /// limits, made from a solution that leaves them.
    pub fn moved_within_limits(&self, q: &[f64], inset: f64) -> Vec<f64> {
        (self.joints.iter().zip(q))
            .map(|(j, &v)| {
                let [lo, hi] = j.limits_internal();
                if (lo - LIMIT_TOL..=hi + LIMIT_TOL).contains(&v) {
                    return v;
                }
                let tau = std::f64::consts::TAU;
                let v = match j.joint_type {
                    JointType::Revolute => v + tau * ((0.5 * (lo + hi) - v) / tau).round(),
                    JointType::Prismatic => v,
                };
                let m = inset.clamp(0.0, 0.5) * (hi - lo);
                v.clamp(lo + m, hi - m)
            })
            .collect()
    }

    /// Converts a joint vector from file units (deg/mm) to internal units (rad/mm).
    pub fn joints_to_internal(&self, q: &[f64]) -> Vec<f64> {
        self.joints
            .iter()
            .zip(q)
            .map(|(j, &v)| j.joint_type.to_internal(v))
            .collect()
    }

    /// Converts a joint vector from internal units (rad/mm) to file units (deg/mm).
    pub fn joints_to_file(&self, q: &[f64]) -> Vec<f64> {
        self.joints
            .iter()
            .zip(q)
            .map(|(j, &v)| j.joint_type.to_file(v))
            .collect()
    }
}

/// [`Field::K`]'s body code of body `b` (0-based link, or `n` for the payload).
fn body_code(b: usize, n: usize) -> u8 {
    if b == n {
        PAYLOAD
    } else {
        u8::try_from(b).unwrap_or(PAYLOAD - 1)
    }
}

/// The body index (0-based link, or `n` for the payload) of a [`Field::K`] body code.
fn body_index(code: u8, n: usize) -> usize {
    if code == PAYLOAD {
        n
    } else {
        usize::from(code)
    }
}

/// Euclidean distance between two joint vectors (rad and mm, as they are): the distance the
/// IK strategy uses to choose among solutions and starts. Whole turns count: a solution
/// 360 deg away is a different motion of the robot.
pub fn joint_distance(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).powi(2))
        .sum::<f64>()
        .sqrt()
}

#[cfg(test)]
mod tests {
    use crate::model::test_fanuc;

    #[test]
    fn turns_are_taken_nearest_the_seed_within_the_limits() {
        // FANUC limits (deg): J1 +-150, J4 +-180, J6 +-180.
        let r = test_fanuc();
        let rad = |v: [f64; 6]| v.map(f64::to_radians);
        let deg = |v: Vec<f64>| v.into_iter().map(f64::to_degrees).collect::<Vec<_>>();
        let seed = rad([0.0, 0.0, 0.0, 170.0, 0.0, -170.0]);
        let q = rad([360.0, 10.0, -20.0, -185.0, 30.0, 185.0]);
        let got = deg(r.turns_near(&q, &seed).unwrap());
        let want = [0.0, 10.0, -20.0, 175.0, 30.0, -175.0];
        for (g, w) in got.iter().zip(want) {
            assert!((g - w).abs() < 1e-9, "{got:?}");
        }
        // Joint 1 at 200 deg has no copy within +-150.
        assert!(
            r.turns_near(&rad([200.0, 0.0, 0.0, 0.0, 0.0, 0.0]), &seed)
                .is_none()
        );
    }

    #[test]
    fn limits_come_from_another_file_and_nothing_else_does() {
        let r = test_fanuc();
        let mut narrow = r.clone();
        narrow.joints[0].limits = [-100.0, 100.0];
        narrow.joints[4].limits = [-10.0, 10.0];
        let moved = r.with_param(r.parameters()[3], 0.25).unwrap();
        let (got, changed) = moved.with_limits_of(&narrow).unwrap();
        assert_eq!(changed, vec![1, 5]);
        assert_eq!(got.joints()[0].limits, [-100.0, 100.0]);
        assert_eq!(got.joints()[4].limits, [-10.0, 10.0]);
        assert_eq!(got.joints()[1].limits, r.joints()[1].limits);
        // The geometry is the robot's own.
        assert_eq!(got.param(r.parameters()[3]), 0.25);
        assert_eq!(got.joints()[0].row, moved.joints()[0].row);
        assert!(moved.with_limits_of(&moved).unwrap().1.is_empty());
    }

    #[test]
    fn tool_and_payload_come_from_another_file_and_nothing_else_does() {
        let path = concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/datasets/nongeometric_robot/nominal_masses.toml"
        );
        let r = crate::model::read_robot(path).unwrap();
        let moved = r.with_param(r.parameters()[3], 0.25).unwrap();
        let tool = r
            .parameters()
            .into_iter()
            .find(|p| matches!(p.slot, crate::model::Slot::Tool) && r.param(*p) != 0.0);
        let tool = tool.unwrap();
        let cell = r.with_param(tool, 0.5 * r.param(tool)).unwrap();
        let mut masses = cell.masses().unwrap().clone();
        masses.payload.mass_kg = 50.0;
        masses.payload.com_mm.x += 30.0;
        masses.links[2].mass_kg += 1.0;
        let cell = cell.with_masses(Some(masses.clone())).unwrap();
        let (got, tool_changed, payload_changed) = moved.with_tool_and_payload_of(&cell).unwrap();
        assert!(tool_changed && payload_changed);
        assert_eq!(got.tool(), cell.tool());
        assert_eq!(got.masses().unwrap().payload, masses.payload);
        // The arm is the robot's own: its geometry and its links' masses.
        assert_eq!(got.param(r.parameters()[3]), 0.25);
        assert_eq!(got.masses().unwrap().links, r.masses().unwrap().links);
        assert_eq!(got.base(), moved.base());
        let (same, t, p) = moved.with_tool_and_payload_of(&moved).unwrap();
        assert!(!t && !p && same == moved);
    }

    #[test]
    fn joints_outside_the_limits_are_moved_inside_them() {
        // FANUC limits (deg): J1 +-150, J2 [-50, 70], J3 +-60, J4 +-180. Joint 1 at 200 deg
        // has no copy within its limits: its copy nearest the range's middle (-160) goes 1 %
        // of the range (3 deg) inside the limit it passed; joint 2 at 80 likewise (1.2 deg
        // inside 70); joint 3 on its limit and the others within theirs are kept; joint 4 at
        // 190 deg is its copy -170 within the limits.
        let r = test_fanuc();
        let rad = |v: [f64; 6]| v.map(f64::to_radians);
        let q = rad([200.0, 80.0, -60.0, 190.0, 0.5, 0.0]);
        let got: Vec<f64> = (r.moved_within_limits(&q, 0.01).into_iter())
            .map(f64::to_degrees)
            .collect();
        let want = [-147.0, 68.8, -60.0, -170.0, 0.5, 0.0];
        for (g, w) in got.iter().zip(want) {
            assert!((g - w).abs() < 1e-9, "{got:?}");
        }
        assert!(
            r.joints_outside_limits(&got.iter().map(|d| d.to_radians()).collect::<Vec<_>>())
                .is_empty()
        );
    }
}
