//! Tables of desired tool poses (`ik`, `compensate`): x, y, z (mm) and rz, ry, rx (deg,
//! R = Rz Ry Rx), or x, y, z alone where position targets are allowed. Optional seed joints
//! q1..qN (deg; mm for prismatic joints): all present or all absent; a row whose seed cells
//! are all empty has no seed. Other columns are carried into the output, the seed columns
//! renamed seed_q1..seed_qN.

use super::joints::row_joints;
use super::table::Table;
use super::{POSE_COLUMNS, joint_columns, output_headers};
use crate::error::{Error, Location, Result};
use crate::geometry::{Pose, pose_from_file};
use crate::model::{MAX_ANGLE_DEG, MAX_LENGTH_MM, Robot};
use nalgebra::Vector3;
use std::path::Path;

/// The bound of pose value `k` of x, y, z (mm), rz, ry, rx (deg): 100 m, 2 turns, as in
/// measurement files.
pub fn pose_bound(k: usize) -> f64 {
    if k < 3 { MAX_LENGTH_MM } else { MAX_ANGLE_DEG }
}

/// [`pose_bound`] of value `k` as messages give it, with its unit: "100000 mm (100 m)" or
/// "720 deg (2 turns)".
pub fn pose_bound_text(k: usize) -> String {
    if k < 3 {
        format!("{MAX_LENGTH_MM} mm (100 m)")
    } else {
        format!("{MAX_ANGLE_DEG} deg (2 turns)")
    }
}

/// What a row asks the tool to reach.
#[derive(Debug, Clone, Copy)]
pub enum Target {
    /// Position (mm) and orientation.
    Pose(Pose),
    /// Position only (mm).
    Position(Vector3<f64>),
}

/// A CSV of targets.
#[derive(Debug, Clone)]
pub struct TargetTable {
    /// The file as read; its cells are carried into outputs.
    pub table: Table,
    /// Each row's target.
    pub targets: Vec<Target>,
    /// Each row's seed joints (internal units: rad, mm), if it has them.
    pub seeds: Vec<Option<Vec<f64>>>,
    /// The table has the orientation columns (else every target is a position).
    pub with_orientation: bool,
    /// The table has the seed columns.
    pub with_seeds: bool,
    /// The robot's joint count.
    dof: usize,
}

impl TargetTable {
    /// Reads `path` for `robot`; `positions` allows tables without orientation columns.
    pub fn read(path: impl AsRef<Path>, robot: &Robot, positions: bool) -> Result<TargetTable> {
        TargetTable::from_table(Table::read_keeping_malformed(path)?, robot, positions)
    }

    /// The target table of an already parsed table (for example from [`Table::parse`]).
    pub fn from_table(table: Table, robot: &Robot, positions: bool) -> Result<TargetTable> {
        let n = robot.dof();
        let pos_idx: Vec<usize> = POSE_COLUMNS[..3]
            .iter()
            .map(|c| table.require(c))
            .collect::<Result<_>>()?;
        let present = POSE_COLUMNS[3..]
            .iter()
            .filter(|c| table.column(c).is_some())
            .count();
        let with_orientation = present == 3 || !positions;
        let rot_idx: Vec<usize> = if with_orientation || present > 0 {
            // Names the first missing orientation column.
            POSE_COLUMNS[3..]
                .iter()
                .map(|c| table.require(c))
                .collect::<Result<_>>()?
        } else {
            Vec::new()
        };
        super::no_extra_joint(&table, n)?;
        let qcols = joint_columns(n);
        let seed_idx: Vec<Option<usize>> = qcols.iter().map(|c| table.column(c)).collect();
        let with_seeds = match seed_idx.iter().flatten().count() {
            0 => false,
            k if k == n => true,
            _ => {
                let missing = qcols
                    .iter()
                    .find(|c| table.column(c).is_none())
                    .expect("some seed column is missing");
                return Err(Error::input(
                    Location::at(&table.path, 1, missing.as_str()),
                    format!(
                        "missing column: seed columns q1..q{n} must be all present or all absent"
                    ),
                ));
            }
        };
        let seed_idx: Vec<usize> = seed_idx.into_iter().flatten().collect();
        let cols: Vec<usize> = pos_idx.iter().chain(&rot_idx).copied().collect();
        let parsed = table.parse_rows(|r| {
            let v = table.numbers(r, &cols)?;
            for (k, (x, &c)) in v.iter().zip(&cols).enumerate() {
                let max = pose_bound(k);
                if x.abs() > max {
                    return Err(Error::input(
                        table.location(r, c),
                        format!("{x:e} is beyond the bound of {}", pose_bound_text(k)),
                    ));
                }
            }
            let target = if with_orientation {
                Target::Pose(pose_from_file([v[0], v[1], v[2], v[3], v[4], v[5]]))
            } else {
                Target::Position(Vector3::new(v[0], v[1], v[2]))
            };
            let empty = seed_idx.iter().all(|&c| table.rows[r][c].trim().is_empty());
            let seed = if with_seeds && !empty {
                Some(robot.joints_to_internal(&row_joints(&table, r, &seed_idx, robot)?))
            } else {
                None
            };
            Ok((target, seed))
        })?;
        let (targets, seeds) = parsed.into_iter().unzip();
        Ok(TargetTable {
            table,
            targets,
            seeds,
            with_orientation,
            with_seeds,
            dof: n,
        })
    }

    /// Whether the seed columns (read as degrees) probably hold radians
    /// ([`super::joints::look_like_radians`]); false without seeds.
    pub fn seeds_look_like_radians(&self, robot: &Robot) -> bool {
        let file: Vec<Vec<f64>> = (self.seeds.iter().flatten())
            .map(|s| robot.joints_to_file(s))
            .collect();
        super::joints::look_like_radians(robot, file.iter().map(Vec::as_slice))
    }

    /// Whether the orientation columns (read as degrees) probably hold radians
    /// ([`super::joints::orientations_look_like_radians`], the rule measurement files are
    /// read by); false without orientation columns.
    pub fn orientations_look_like_radians(&self) -> bool {
        if !self.with_orientation {
            return false;
        }
        let cols: Vec<usize> = (POSE_COLUMNS[3..].iter())
            .filter_map(|c| self.table.column(c))
            .collect();
        let values = (0..self.table.rows.len())
            .filter_map(|r| self.table.numbers(r, &cols).ok())
            .flatten();
        super::joints::orientations_look_like_radians(self.targets.len(), values)
    }

    /// The output's header: the carried columns (seed columns renamed seed_q1..seed_qN),
    /// then `written` (see [`output_headers`]).
    /// A previous output fed back in carries seed_q1.. of its own beside the q1.. it solved,
    /// which are now the seeds: its own are kept as `input_seed_q1`.. (as a carried column
    /// whose name is written is).
    pub fn output_headers(&self, written: &[String]) -> Result<Vec<String>> {
        let qcols = joint_columns(self.dof);
        let headers = &self.table.headers;
        let seed = |h: &String| (self.with_seeds && qcols.contains(h)).then(|| format!("seed_{h}"));
        let seeds: Vec<String> = headers.iter().filter_map(seed).collect();
        let taken = |n: &String| headers.contains(n) || seeds.contains(n) || written.contains(n);
        let carried = (headers.iter())
            .map(|h| match seed(h) {
                Some(s) => s,
                None if seeds.contains(h) => {
                    let mut name = format!("input_{h}");
                    while taken(&name) {
                        name = format!("input_{name}");
                    }
                    name
                }
                None => h.clone(),
            })
            .collect();
        output_headers(&self.table, carried, written)
    }
}
