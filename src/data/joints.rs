//! Tables of joint vectors (`fk`, `predict`): columns q1..qN (deg; mm for prismatic joints),
//! every other column carried into the output.

use super::measurement::JointInfo;
use super::table::Table;
use super::{joint_columns, output_headers};
use crate::error::{Error, Result};
use crate::model::{JointType, MAX_JOINT_DEG, MAX_LENGTH_MM, Robot};
use std::path::Path;

/// The bound of a joint value in file units: 4 turns (deg) for a revolute joint, 100 m (mm)
/// for a prismatic one, as in measurement files.
pub fn joint_bound(joint_type: JointType) -> f64 {
    match joint_type {
        JointType::Revolute => MAX_JOINT_DEG,
        JointType::Prismatic => MAX_LENGTH_MM,
    }
}

/// [`joint_bound`] as messages give it, with its unit: "1440 deg (4 turns)" or "100000 mm
/// (100 m)".
pub fn joint_bound_text(joint_type: JointType) -> String {
    match joint_type {
        JointType::Revolute => format!("{MAX_JOINT_DEG} deg (4 turns)"),
        JointType::Prismatic => format!("{MAX_LENGTH_MM} mm (100 m)"),
    }
}

/// Row `r`'s values of columns `cols` as joints of `robot` (file units), each within
/// [`joint_bound`].
pub(super) fn row_joints(t: &Table, r: usize, cols: &[usize], robot: &Robot) -> Result<Vec<f64>> {
    let q = t.numbers(r, cols)?;
    for ((v, &c), j) in q.iter().zip(cols).zip(robot.joints()) {
        let max = joint_bound(j.joint_type);
        if v.abs() > max {
            return Err(Error::input(
                t.location(r, c),
                format!(
                    "{v:e} is beyond the bound of {}",
                    joint_bound_text(j.joint_type)
                ),
            ));
        }
    }
    Ok(q)
}

/// A CSV of joint vectors.
#[derive(Debug, Clone)]
pub struct JointTable {
    /// The file as read; its cells are carried into outputs.
    pub table: Table,
    /// Each row's joints (file units: deg, mm).
    pub joints: Vec<Vec<f64>>,
}

impl JointTable {
    /// Reads `path`: columns q1..qN of `robot` required, each value within [`joint_bound`].
    pub fn read(path: impl AsRef<Path>, robot: &Robot) -> Result<JointTable> {
        JointTable::from_table(Table::read_keeping_malformed(path)?, robot)
    }

    /// The joint table of an already parsed table (for example from [`Table::parse`]).
    pub fn from_table(table: Table, robot: &Robot) -> Result<JointTable> {
        super::no_extra_joint(&table, robot.dof())?;
        let idx: Vec<usize> = joint_columns(robot.dof())
            .iter()
            .map(|c| table.require(c))
            .collect::<Result<_>>()?;
        let joints = table.parse_rows(|r| row_joints(&table, r, &idx, robot))?;
        Ok(JointTable { table, joints })
    }

    /// Row `r`'s joints in internal units (rad, mm).
    pub fn internal(&self, r: usize, robot: &Robot) -> Vec<f64> {
        robot.joints_to_internal(&self.joints[r])
    }

    /// The output's header: the carried columns, then `written` (see [`output_headers`]).
    pub fn output_headers(&self, written: &[String]) -> Result<Vec<String>> {
        output_headers(&self.table, self.table.headers.clone(), written)
    }

    /// Whether the degree columns probably hold radians ([`look_like_radians`]).
    pub fn looks_like_radians(&self, robot: &Robot) -> bool {
        look_like_radians(robot, self.joints.iter().map(Vec::as_slice))
    }
}

/// Whether the orientation values of a file read as degrees (angles or a rotation vector's
/// components, every value of `rows` rows) probably hold radians: three rows or more, and
/// every value within +-6.3 (a turn in radians) but not all 0. Measurement and target files
/// are read by this rule.
pub fn orientations_look_like_radians(rows: usize, values: impl Iterator<Item = f64>) -> bool {
    let max = values.fold(0.0_f64, |m, v| m.max(v.abs()));
    rows >= 3 && max > 0.0 && max <= 6.3
}

/// Whether joint vectors read as degrees (`rows`, file units: deg, mm) probably hold radians:
/// every revolute angle lies within one turn in radians (|q| <= 2 pi), or within its joint's
/// range in radians where that is wider (a joint of +-400 deg), and some exceed 1 (the joint
/// unit of most controllers' logs; read as degrees they give plausible but wrong poses).
pub fn look_like_radians<'a>(robot: &Robot, rows: impl Iterator<Item = &'a [f64]>) -> bool {
    let revolute: Vec<(usize, f64)> = (JointInfo::of(robot).iter().enumerate())
        .filter(|(_, j)| j.joint_type == JointType::Revolute)
        .map(|(i, j)| (i, j.span().max(std::f64::consts::TAU)))
        .collect();
    let mut max: Option<f64> = None;
    let mut within = true;
    for q in rows {
        for &(j, bound) in &revolute {
            max = Some(max.unwrap_or(0.0).max(q[j].abs()));
            within &= q[j].abs() <= bound;
        }
    }
    within && max.is_some_and(|m| m > 1.0)
}
