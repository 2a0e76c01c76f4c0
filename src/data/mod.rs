//! Measurement and batch data in CSV files.

pub mod configuration;
pub mod joints;
pub mod measurement;
pub mod pairs;
pub mod profile;
pub mod shared_readings;
pub mod table;
pub mod targets;

pub use joints::JointTable;
pub use measurement::{
    JointInfo, Measurement, MeasurementSet, ReadOptions, ReadReport, read_canonical,
    read_measurements, write_measurements,
};
pub use profile::{Orientation, Profile, SigmaAngles};
pub use table::Table;
pub use targets::{Target, TargetTable};

use crate::error::{Error, Location, Result};

/// The header of an output that carries table `t`'s columns (`carried`, renamed or not) and
/// adds `written`: a carried column whose name is written is kept as `input_<name>`
/// (`input_input_<name>` where the input has an `input_<name>` too, as `import` names an
/// export's own column, and so on); a name that would still appear twice is refused (the
/// CSV would be ambiguous and JSON would keep only one of them).
pub fn output_headers(t: &Table, carried: Vec<String>, written: &[String]) -> Result<Vec<String>> {
    let mut headers: Vec<String> = Vec::with_capacity(carried.len() + written.len());
    for h in &carried {
        let mut name = h.clone();
        if written.contains(&name) {
            name = format!("input_{name}");
            while carried.contains(&name) || written.contains(&name) || headers.contains(&name) {
                name = format!("input_{name}");
            }
        }
        headers.push(name);
    }
    headers.extend(written.iter().cloned());
    for (i, h) in headers.iter().enumerate() {
        if headers[..i].contains(h) {
            return Err(Error::input(
                Location::at(&t.path, 1, h.clone()),
                "this column would appear twice in the output (the input's own, renamed or \
                 not, and one the command writes); rename or drop it",
            ));
        }
    }
    Ok(headers)
}

/// Names of the joint columns `q1..qN` (deg, or mm for prismatic joints).
pub fn joint_columns(n: usize) -> Vec<String> {
    (1..=n).map(|i| format!("q{i}")).collect()
}

/// Refuses a table with a joint-like column (`q` and digits) other than `q1..qN` for the
/// robot's `n` joints: `q{n+1}` and beyond are another robot's rows, `q07` or `q0` a
/// misspelt joint, and carried along as labels they would be dropped from the joints
/// silently. Where `n` was counted from the header (`q1`, `q2`, ... without a robot), a
/// column past a gap (`q4` without `q3`) names the missing one.
pub fn no_extra_joint(t: &table::Table, n: usize) -> crate::error::Result<()> {
    for h in &t.headers {
        let Some(digits) = h.strip_prefix('q') else {
            continue;
        };
        if digits.is_empty() || !digits.bytes().all(|b| b.is_ascii_digit()) {
            continue;
        }
        let k: usize = digits.parse().unwrap_or(usize::MAX);
        let spelled = *h == format!("q{k}");
        if spelled && (1..=n).contains(&k) {
            continue;
        }
        let why = if !spelled || k == 0 {
            format!("joint columns are named q1..q{n} (no leading zero, from 1)")
        } else if t.column(&format!("q{}", n + 1)).is_none() {
            format!(
                "a joint column past q{n}, the last joint here (q{} is not in the file): \
                 another robot's joints, or a gap in the joint columns?",
                n + 1
            )
        } else {
            format!("a joint column beyond the robot's {n} joints: is this file for another robot?")
        };
        return Err(crate::error::Error::input(
            crate::error::Location::at(&t.path, 1, h.clone()),
            why,
        ));
    }
    Ok(())
}

/// Names of the pose columns: position (mm) and Z-Y-X Euler angles (deg, R = Rz Ry Rx).
pub const POSE_COLUMNS: [&str; 6] = ["x", "y", "z", "rz", "ry", "rx"];

#[cfg(test)]
mod tests {
    use super::no_extra_joint;
    use super::table::Table;
    use std::path::Path;

    #[test]
    fn joint_like_columns_other_than_the_robots_are_refused_by_name() {
        let check = |header: &str, n: usize| {
            let text = format!("{header}\n");
            let t = Table::parse(text.as_bytes(), Path::new("f.csv"), b',', false).unwrap();
            no_extra_joint(&t, n).map_err(|e| e.to_string())
        };
        assert!(check("id,q1,q2,q3,x,seed_q4,input_q9,qa,q", 3).is_ok());
        for (header, n, column, says) in [
            (
                "q1,q2,q3,q4,q5,q6,q7",
                6,
                "q7",
                "beyond the robot's 6 joints",
            ),
            ("q1,q2,q3,q4,q5,q6,q8", 6, "q8", "q7 is not in the file"),
            ("q1,q2,q4,x", 2, "q4", "q3 is not in the file"),
            ("q1,q2,q07", 6, "q07", "no leading zero"),
            ("q0,q1,q2", 2, "q0", "from 1"),
        ] {
            let e = check(header, n).unwrap_err();
            assert!(e.contains(&format!("f.csv:1: field `{column}`")), "{e}");
            assert!(e.contains(says), "{header}: {e}");
        }
    }
}
