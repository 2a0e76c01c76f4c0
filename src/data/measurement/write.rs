//! Writing measurement files: canonical CSV, whole or streamed row by row.

use super::cells::{degrees_cell, number_cell, rotation_cells};
use super::{JointInfo, Measurement, MeasurementSet};
use crate::data::joint_columns;
use crate::data::table::CsvOut;
use crate::error::{Error, Result};
use crate::geometry::rotation::rotation_to_zyx;
use crate::model::JointType;
use std::path::Path;

/// The columns of a canonical measurement CSV: which optional groups it has, and the
/// carried-through columns.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Layout {
    /// Has an `id` column.
    pub id: bool,
    /// Has a `set` column.
    pub set: bool,
    /// Has a `pair` column.
    pub pair: bool,
    /// Has the position columns `x, y, z` (mm).
    pub position: bool,
    /// Has the orientation columns `rz, ry, rx` (deg, R = Rz Ry Rx).
    pub rotation: bool,
    /// Has a `distance` column (mm).
    pub distance: bool,
    /// Has the position sigma columns `sx, sy, sz` (mm).
    pub sigma_position: bool,
    /// Has the orientation sigma columns `srx, sry, srz` (deg).
    pub sigma_rotation: bool,
    /// Names of the carried-through columns, written last in this order.
    pub extra: Vec<String>,
}

impl Layout {
    /// The groups some row of `set` has.
    pub fn of(set: &MeasurementSet) -> Layout {
        let any = |f: &dyn Fn(&Measurement) -> bool| set.rows.iter().any(f);
        Layout {
            id: any(&|m| m.id.is_some()),
            set: any(&|m| m.set.is_some()),
            pair: any(&|m| m.pair.is_some()),
            position: any(&|m| m.position.is_some()),
            rotation: any(&|m| m.rotation.is_some()),
            distance: any(&|m| m.distance.is_some()),
            sigma_position: any(&|m| m.sigma_position.is_some()),
            sigma_rotation: any(&|m| m.sigma_rotation.is_some()),
            extra: set.extra_columns.clone(),
        }
    }

    /// The header row (joints in file units: deg, or mm for prismatic).
    pub fn headers(&self, joints: &[JointInfo]) -> Vec<String> {
        let mut headers: Vec<String> = Vec::new();
        let joints = joint_columns(joints.len());
        let joints: Vec<&str> = joints.iter().map(String::as_str).collect();
        let mut push = |on: bool, names: &[&str]| {
            if on {
                headers.extend(names.iter().map(|s| s.to_string()));
            }
        };
        push(self.id, &["id"]);
        push(self.set, &["set"]);
        push(self.pair, &["pair"]);
        push(true, &joints);
        push(self.position, &["x", "y", "z"]);
        push(self.rotation, &["rz", "ry", "rx"]);
        push(self.distance, &["distance"]);
        push(self.sigma_position, &["sx", "sy", "sz"]);
        push(self.sigma_rotation, &["srx", "sry", "srz"]);
        let carried = self.carried_names(joints.len());
        headers.extend(carried);
        headers
    }

    /// The carried columns' names as written: a name a canonical reader would take as a
    /// field (`x`, `rx`, `id`, a joint-like `q7`, ...: the export's own columns beside those
    /// its profile mapped), or refuse as one in other letter case (`X`, `SX`: a reader
    /// missing `x` names the `X` it found), becomes `input_<name>` (again, until it is
    /// unique), so that the file reads back with the fields it was written with.
    pub fn carried_names(&self, joints: usize) -> Vec<String> {
        const FIELDS: [&str; 16] = [
            "id", "set", "pair", "x", "y", "z", "rz", "ry", "rx", "distance", "sx", "sy", "sz",
            "srx", "sry", "srz",
        ];
        let joint_like = |h: &str| {
            (h.strip_prefix('q').or_else(|| h.strip_prefix('Q')))
                .is_some_and(|d| !d.is_empty() && d.bytes().all(|b| b.is_ascii_digit()))
        };
        let mut taken: Vec<String> = joint_columns(joints);
        taken.extend(FIELDS.iter().map(|f| f.to_string()));
        let mut names = Vec::with_capacity(self.extra.len());
        for e in &self.extra {
            let mut name = e.clone();
            while taken.iter().any(|t| t.eq_ignore_ascii_case(&name))
                || joint_like(&name)
                || names.contains(&name)
            {
                name = format!("input_{name}");
            }
            names.push(name);
        }
        // An original `input_x` after a renamed `x` is renamed in turn (the loop above), so
        // every name is unique.
        names
    }

    /// The cells of one row (mm, deg), blank where the row lacks a group the layout has.
    /// A row read from a file (`line` set) has its angles written as read, to the bit
    /// (`cells::degrees_cell`, `cells::rotation_cells`); a row built in code (`line` 0:
    /// simulated) as the shortest texts of its degrees, as it always was (the shipped
    /// simulated files).
    pub fn cells(&self, m: &Measurement, joints: &[JointInfo]) -> Vec<String> {
        let read = m.line > 0;
        let angle = |rad: f64| {
            if read {
                degrees_cell(rad)
            } else {
                number_cell(rad.to_degrees())
            }
        };
        // -0 (an angle of an exact rotation, say) is written 0.
        let num = number_cell;
        let mut c: Vec<String> = Vec::new();
        let text = |o: &Option<String>| o.clone().unwrap_or_default();
        if self.id {
            c.push(text(&m.id));
        }
        if self.set {
            c.push(text(&m.set));
        }
        if self.pair {
            c.push(text(&m.pair));
        }
        c.extend(m.q.iter().zip(joints).map(|(&v, j)| match j.joint_type {
            JointType::Revolute => angle(v),
            JointType::Prismatic => num(v),
        }));
        let opt3 = |c: &mut Vec<String>, on: bool, v: Option<[String; 3]>| {
            if on {
                c.extend(v.unwrap_or_default());
            }
        };
        opt3(
            &mut c,
            self.position,
            m.position.map(|p| [p.x, p.y, p.z].map(num)),
        );
        opt3(
            &mut c,
            self.rotation,
            m.rotation.map(|r| {
                if read {
                    rotation_cells(&r)
                } else {
                    rotation_to_zyx(&r).map(angle)
                }
            }),
        );
        if self.distance {
            c.push(m.distance.map(num).unwrap_or_default());
        }
        opt3(
            &mut c,
            self.sigma_position,
            m.sigma_position.map(|s| [s.x, s.y, s.z].map(num)),
        );
        opt3(
            &mut c,
            self.sigma_rotation,
            m.sigma_rotation.map(|s| [s.x, s.y, s.z].map(angle)),
        );
        c.extend(m.extra.iter().cloned());
        c
    }
}

/// A set as canonical CSV bytes.
pub fn measurements_to_csv(set: &MeasurementSet, joints: &[JointInfo]) -> Result<Vec<u8>> {
    let layout = Layout::of(set);
    let mut out = CsvOut::new(&layout.headers(joints))?;
    for m in &set.rows {
        out.row(&layout.cells(m, joints))?;
    }
    out.into_bytes()
}

/// Writes a set as canonical CSV, atomically.
pub fn write_measurements(set: &MeasurementSet, joints: &[JointInfo], path: &Path) -> Result<()> {
    crate::io::write_atomic(path, &measurements_to_csv(set, joints)?)
}

/// Canonical CSV streamed row by row to a file that appears whole on
/// [`MeasurementWriter::finish`] (a million simulated rows need no memory).
pub struct MeasurementWriter {
    w: csv::Writer<crate::io::AtomicWriter>,
    layout: Layout,
    joints: Vec<JointInfo>,
}

impl MeasurementWriter {
    /// Starts a file at `path` with `layout`'s columns and writes its header row; nothing
    /// appears at `path` until [`finish`](Self::finish).
    pub fn create(path: &Path, layout: Layout, joints: &[JointInfo]) -> Result<Self> {
        let mut w = csv::Writer::from_writer(crate::io::AtomicWriter::create(path)?);
        let csv_err = |e: csv::Error| Error::Invalid(format!("{}: {e}", path.display()));
        w.write_record(layout.headers(joints)).map_err(csv_err)?;
        Ok(MeasurementWriter {
            w,
            layout,
            joints: joints.to_vec(),
        })
    }

    /// Writes one row (in file units: deg, mm), blank where it lacks a group of the layout.
    pub fn write(&mut self, m: &Measurement) -> Result<()> {
        let cells = self.layout.cells(m, &self.joints);
        self.record(cells)
    }

    /// Writes one row's cells.
    fn record(&mut self, cells: Vec<String>) -> Result<()> {
        self.w
            .write_record(cells)
            .map_err(|e| Error::Invalid(format!("{}: {e}", self.w.get_ref().path().display())))
    }

    /// [`write`](Self::write), the joint columns holding `q` (file units: deg, mm) in place
    /// of the row's joints: values read from a file are written as read, without the float
    /// dust of a trip through radians (30 deg read back as 29.999999999999996).
    pub fn write_with_joints(&mut self, m: &Measurement, q: &[f64]) -> Result<()> {
        let mut cells = self.layout.cells(m, &self.joints);
        let first = [self.layout.id, self.layout.set, self.layout.pair]
            .iter()
            .filter(|on| **on)
            .count();
        for (cell, &v) in cells[first..first + self.joints.len()].iter_mut().zip(q) {
            *cell = number_cell(v);
        }
        self.record(cells)
    }

    /// Flushes the rows and moves the file into place (or stages it for the open transaction).
    pub fn finish(self) -> Result<()> {
        let path = self.w.get_ref().path().to_path_buf();
        self.w
            .into_inner()
            .map_err(|e| Error::Invalid(format!("{}: {}", path.display(), e.error())))?
            .finish()
    }
}
