//! The parameters an identification solves for and the model it solves them in: a selection
//! (see [`super::select`]) where a DH-type base or tool row, fully selected or named by its
//! 6-DOF fields, becomes the equivalent 6-DOF transform.

use super::select::select;
use crate::error::{Error, Result};
use crate::model::{Convention, Robot, Slot};

/// A base or tool row in a DH-type convention, fully selected, becomes the equivalent 6-DOF
/// transform: an MDH base row followed by joint 1's MDH row is singular at the usual nominal
/// (alpha1 = a1 = 0: every base column repeats a joint-1 column), so no subset of them can
/// express a base frame tilted about y; likewise an MDH tool row with alpha_T = pi. A 6-DOF
/// transform can express any frame, so the identified family contains the true robot.
fn complete_frames(robot: &Robot, chosen: &[usize]) -> Result<(Robot, Vec<String>)> {
    let params = robot.parameters();
    let mut out = robot.clone();
    let mut notes = Vec::new();
    for (slot, row, what) in [
        (Slot::Base, robot.base(), "base"),
        (Slot::Tool, robot.tool(), "tool"),
    ] {
        let all = params
            .iter()
            .enumerate()
            .filter(|(_, p)| p.slot == slot)
            .all(|(k, _)| chosen.contains(&k));
        if row.convention() != Convention::Transform && all {
            out = out.with_frame_as_transform(slot)?;
            notes.push(format!(
                "the {what} row ({}) is identified as the equivalent 6-DOF transform, which can express any {what} frame",
                row.convention().name()
            ));
        }
    }
    Ok((out, notes))
}

/// The selection `chosen` (indices into `nominal`'s parameters) in the `completed` model:
/// a base or tool row converted to a transform contributes all its fields; the other slot's
/// chosen parameters stay as chosen.
fn selection_in(nominal: &Robot, completed: &Robot, chosen: Vec<usize>) -> Result<Vec<usize>> {
    if completed.parameters() == nominal.parameters() {
        return Ok(chosen);
    }
    let old = nominal.parameters();
    let mut spec: Vec<String> = (chosen.iter())
        .filter(|&&c| !matches!(old[c].slot, Slot::Base | Slot::Tool))
        .map(|&c| old[c].name())
        .collect();
    for (slot, word) in [(Slot::Base, "base"), (Slot::Tool, "tool")] {
        let names = |r: &Robot| -> Vec<String> {
            (r.parameters().iter())
                .filter(|p| p.slot == slot)
                .map(|p| p.name())
                .collect()
        };
        let in_slot = chosen.iter().filter(|&&c| old[c].slot == slot);
        if names(nominal) == names(completed) {
            spec.extend(in_slot.map(|&c| old[c].name()));
        } else if in_slot.count() > 0 {
            spec.push(word.into());
        }
    }
    select(completed, &spec.join(","))
}

/// The model an identification of `params` (a selection, see `select`) solves and its
/// candidate parameters (indices into that model's parameters, in priority order): a fully
/// selected DH-type base or tool row becomes the equivalent 6-DOF transform. With notes
/// saying so.
///
/// A DH-type base or tool row whose 6-DOF fields the selection names (`tool.x`, `base.rz`:
/// the names `identify` prints for such a row once it is a transform) becomes the
/// equivalent 6-DOF transform first, and those fields are selected in it.
pub fn candidates(nominal: &Robot, params: &str) -> Result<(Robot, Vec<usize>, Vec<String>)> {
    let (named, converted) = frames_named_as_transforms(nominal, params)?;
    let chosen = select(&named, params)?;
    let mut notes = Vec::new();
    let all = named.parameters();
    for (slot, what, convention, fields) in converted {
        let whole = (all.iter().enumerate())
            .filter(|(_, p)| p.slot == slot)
            .all(|(k, _)| chosen.contains(&k));
        notes.push(if whole {
            format!(
                "the {what} row ({convention}) is identified as the equivalent 6-DOF transform, \
                 which can express any {what} frame"
            )
        } else {
            format!(
                "the {what} row ({convention}) is identified as the equivalent 6-DOF transform, \
                 whose fields {} the selection names; its other fields keep the row's pose",
                fields.join(", ")
            )
        });
    }
    let (completed, more) = complete_frames(&named, &chosen)?;
    notes.extend(more);
    let candidates = selection_in(&named, &completed, chosen)?;
    Ok((completed, candidates, notes))
}

/// A base or tool row made a 6-DOF transform for the fields a selection names: its slot, its
/// word, its convention's name and the names given.
type Converted = (Slot, &'static str, &'static str, Vec<String>);

/// `robot` with each DH-type base or tool row whose 6-DOF fields (x, y, z, rz, ry, rx) the
/// selection `params` names as the equivalent 6-DOF transform, and those rows. A selection
/// that also names a field of such a row in its own convention (`tool.a` beside `tool.x`)
/// is refused: the row is one or the other.
fn frames_named_as_transforms(robot: &Robot, params: &str) -> Result<(Robot, Vec<Converted>)> {
    const FIELDS: [&str; 6] = ["x", "y", "z", "rz", "ry", "rx"];
    let mut out = robot.clone();
    let mut converted = Vec::new();
    let items: Vec<&str> = params.split(',').map(str::trim).collect();
    for (slot, what) in [(Slot::Base, "base"), (Slot::Tool, "tool")] {
        let row = match slot {
            Slot::Base => robot.base(),
            _ => robot.tool(),
        };
        fn field<'a>(item: &'a str, what: &str) -> Option<&'a str> {
            item.strip_prefix(what).and_then(|r| r.strip_prefix('.'))
        }
        let named: Vec<String> = (items.iter())
            .filter(|item| field(item, what).is_some_and(|f| FIELDS.contains(&f)))
            .map(|item| item.to_string())
            .collect();
        if row.convention() == Convention::Transform || named.is_empty() {
            continue;
        }
        let own: Vec<&str> = (items.iter().copied())
            .filter(|item| field(item, what).is_some() && robot.find_param(item).is_some())
            .collect();
        if !own.is_empty() {
            return Err(Error::Invalid(format!(
                "the selection names {} of the {what} row as a 6-DOF transform and {} of the \
                 row in its own convention ({}): name the fields of one or the other",
                named.join(", "),
                own.join(", "),
                row.convention().name()
            )));
        }
        out = out.with_frame_as_transform(slot)?;
        converted.push((slot, what, row.convention().name(), named));
    }
    Ok((out, converted))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn transform_fields_named_for_a_dh_row_select_them_in_its_equivalent_transform() {
        // identify prints an MDH tool row, made a transform, as tool.x ... tool.rx: those
        // names select its fields (they were refused as unknown), the pose kept.
        let fanuc = crate::model::read_robot(
            std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("datasets/robots/fanuc_r2000ib_210f.toml"),
        )
        .unwrap();
        let (completed, chosen, notes) = candidates(&fanuc, "offsets,tool.x,base.rz").unwrap();
        let all = completed.parameters();
        let mut names: Vec<String> = chosen.iter().map(|&c| all[c].name()).collect();
        names.sort();
        let mut want: Vec<String> = ["base.rz", "tool.x"]
            .into_iter()
            .chain(["theta1", "theta2", "theta3", "theta4", "theta5", "theta6"])
            .map(String::from)
            .collect();
        want.sort();
        assert_eq!(names, want);
        assert_eq!(completed.tool().convention(), Convention::Transform);
        assert_eq!(completed.base().convention(), Convention::Transform);
        assert_eq!(notes.len(), 2, "{notes:?}");
        for q in [[0.1, -0.3, 0.4, 1.0, -0.7, 2.0], [0.0; 6]] {
            let (a, b) = (
                crate::kinematics::tool_pose(&fanuc, &q),
                crate::kinematics::tool_pose(&completed, &q),
            );
            assert!((a.to_homogeneous() - b.to_homogeneous()).abs().max() < 1e-9);
        }
        assert!(
            notes.iter().all(|n| n.contains("its other fields keep")),
            "{notes:?}"
        );
        // The whole row selected anyway: the note says so, not that fields are kept.
        let (_, _, notes) = candidates(&fanuc, "full,tool.x").unwrap();
        assert!(
            notes.iter().all(|n| !n.contains("its other fields keep"))
                && notes
                    .iter()
                    .any(|n| n.contains("can express any tool frame")),
            "{notes:?}"
        );
        // A field a transform does not have is still unknown; the row's own field beside a
        // transform field is refused as a mix.
        assert!(candidates(&fanuc, "tool.q").is_err());
        let e = candidates(&fanuc, "tool.a,tool.x").unwrap_err().to_string();
        assert!(
            e.contains("tool.x") && e.contains("tool.a") && e.contains("one or the other"),
            "{e}"
        );
    }

    #[test]
    fn a_row_made_a_transform_leaves_the_other_rows_selection_as_chosen() {
        let fanuc = crate::model::read_robot(
            std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("datasets/robots/fanuc_r2000ib_210f.toml"),
        )
        .unwrap();
        let names = |params: &str| -> Vec<String> {
            let (completed, chosen, _) = candidates(&fanuc, params).unwrap();
            let all = completed.parameters();
            chosen.iter().map(|&c| all[c].name()).collect()
        };
        let tool = [
            "tool.x", "tool.y", "tool.z", "tool.rz", "tool.ry", "tool.rx",
        ];
        // The tool row (mdh) fully selected becomes a transform; the base keeps theta alone.
        let got = names("base.theta,tool");
        let mut want: Vec<String> = tool.iter().map(|s| s.to_string()).collect();
        want.push("base.theta".into());
        let (mut got_sorted, mut want_sorted) = (got.clone(), want);
        got_sorted.sort();
        want_sorted.sort();
        assert_eq!(got_sorted, want_sorted, "{got:?}");
        // And the other way round, with a joint's parameter beside them.
        let got = names("base,tool.d,theta2");
        assert_eq!(
            got.iter().filter(|n| n.starts_with("tool.")).count(),
            1,
            "{got:?}"
        );
        assert!(got.contains(&"tool.d".to_string()) && got.contains(&"theta2".to_string()));
        assert_eq!(
            got.iter().filter(|n| n.starts_with("base.")).count(),
            6,
            "{got:?}"
        );
    }
}
