//! Which parameters to identify, and in what priority when the data cannot tell some apart.
//!
//! A selection is a comma-separated list of groups and names:
//! - `offsets`: the joints' zero offsets (theta of revolute joints, d of prismatic ones),
//!   level-1 calibration (thesis Case D);
//! - `full`: every geometric parameter of base, joints and tool (reduced later to an
//!   identifiable set);
//! - `base`, `tool`: every parameter of that row; `joints`: every geometric joint parameter;
//! - `compliance`: the joint compliances c1..cN (a robot with mass properties), or without
//!   masses the mass-free coefficients k_jbi (see `model::compliance`);
//! - parameter names: `a2`, `alpha3`, `beta3`, `base.x`, `tool.rz`, `thetaR`, ...
//!
//! Priority (thesis 4.3.4: parameters the controller holds come first), highest first:
//! 1. 6-DOF base and tool transforms: the measurement system's frame and the tool frame,
//!    which controllers hold as user and tool frames (so a tracker's arbitrary placement is
//!    not pushed into the joint offsets);
//! 2. joint zero offsets (controller mastering data);
//! 3. the other joint parameters, in chain order;
//! 4. base and tool rows given in a DH-type convention (the thesis's frames R and T), so that
//!    theta_R and d_R regroup with theta_1 and d_1 as in thesis eq. 4.44;
//! 5. compliances: a deflection the geometry can express is left to the geometry.

use crate::error::{Error, Result};
use crate::model::{Convention, Field, JointType, ParamId, Robot, Slot};

/// True when `id` is a joint's zero offset.
pub fn is_offset(robot: &Robot, id: &ParamId) -> bool {
    match id.slot {
        Slot::Joint(i) => match robot.joints()[i].joint_type {
            JointType::Revolute => id.field == Field::Theta,
            JointType::Prismatic => id.field == Field::D,
        },
        _ => false,
    }
}

/// True when `id` is a compliance parameter: c_j, or a mass-free coefficient k_jbi.
pub fn is_compliance(id: &ParamId) -> bool {
    matches!(id.field, Field::C | Field::K { .. })
}

/// Priority class of a parameter (0 is kept first); see the module docs.
pub fn priority(robot: &Robot, id: &ParamId) -> u8 {
    match id.slot {
        Slot::Base if robot.base().convention() == Convention::Transform => 0,
        Slot::Tool if robot.tool().convention() == Convention::Transform => 0,
        Slot::Base | Slot::Tool => 3,
        Slot::Joint(_) if is_compliance(id) => 4,
        Slot::Joint(_) if is_offset(robot, id) => 1,
        Slot::Joint(_) => 2,
    }
}

/// Parses a selection into indices of [`Robot::parameters`], sorted by priority (stable in
/// chain order within a class). Unknown names are an error that lists the valid ones.
pub fn select(robot: &Robot, spec: &str) -> Result<Vec<usize>> {
    let params = robot.parameters();
    let mut chosen = vec![false; params.len()];
    if spec.trim().is_empty() {
        return Err(Error::Invalid(
            "an empty parameter selection: give one, e.g. `offsets` or `full`".into(),
        ));
    }
    for item in spec.split(',').map(str::trim) {
        if item.is_empty() {
            return Err(Error::Invalid(format!(
                "the parameter selection `{spec}` has an empty entry (two commas in a row, or \
                 one at an end)"
            )));
        }
        let pick = |f: &dyn Fn(&ParamId) -> bool, chosen: &mut Vec<bool>| {
            for (k, id) in params.iter().enumerate() {
                if f(id) {
                    chosen[k] = true;
                }
            }
        };
        match item {
            "offsets" => pick(&|id| is_offset(robot, id), &mut chosen),
            "full" => pick(&|id| !is_compliance(id), &mut chosen),
            "base" => pick(&|id| id.slot == Slot::Base, &mut chosen),
            "tool" => pick(&|id| id.slot == Slot::Tool, &mut chosen),
            "joints" => pick(
                &|id| matches!(id.slot, Slot::Joint(_)) && !is_compliance(id),
                &mut chosen,
            ),
            "compliance" => pick(&|id| is_compliance(id), &mut chosen),
            name => {
                let id = robot.find_param(name).ok_or_else(|| {
                    let mut names: Vec<String> = params
                        .iter()
                        .filter(|p| !matches!(p.field, Field::K { .. }))
                        .map(|p| p.name())
                        .collect();
                    for (what, row) in [("base", robot.base()), ("tool", robot.tool())] {
                        if row.convention() != Convention::Transform {
                            names.push(format!(
                                "{what}.x, .y, .z, .rz, .ry, .rx (the {what} row as a 6-DOF \
                                 transform)"
                            ));
                        }
                    }
                    if params.iter().any(|p| matches!(p.field, Field::K { .. })) {
                        names.push("k<joint>.<m|mx|my|mz><link|P> (e.g. k2.mx3)".into());
                    }
                    Error::Invalid(format!(
                        "unknown parameter or group `{name}`: use offsets, full, base, tool, joints, compliance or one of {}",
                        names.join(", ")
                    ))
                })?;
                let k = params.iter().position(|p| *p == id).unwrap_or(0);
                chosen[k] = true;
            }
        }
    }
    let mut out: Vec<usize> = (0..params.len()).filter(|&k| chosen[k]).collect();
    if out.is_empty() {
        return Err(Error::Invalid(format!("`{spec}` selects no parameter")));
    }
    out.sort_by_key(|&k| priority(robot, &params[k]));
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    use crate::model::test_fanuc as fanuc;

    #[test]
    fn empty_entries_are_refused() {
        let r = fanuc();
        for spec in ["full,,tool", "full,", ",offsets", " , ", ""] {
            let e = select(&r, spec).unwrap_err().to_string();
            assert!(e.contains("empty"), "{spec:?}: {e}");
        }
        assert_eq!(
            select(&r, " full , tool ").unwrap(),
            select(&r, "full,tool").unwrap()
        );
    }

    #[test]
    fn groups_names_and_priority() {
        let r = fanuc();
        let p = r.parameters();
        let names = |v: Vec<usize>| v.into_iter().map(|k| p[k].name()).collect::<Vec<_>>();
        assert_eq!(
            names(select(&r, "offsets").unwrap()),
            ["theta1", "theta2", "theta3", "theta4", "theta5", "theta6"]
        );
        let full = names(select(&r, "full").unwrap());
        assert_eq!(full.len(), 32);
        // Offsets first, then joint geometry, then the MDH base and tool rows.
        assert_eq!(full[0], "theta1");
        assert_eq!(full[6], "alpha1");
        assert!(
            full[26..]
                .iter()
                .all(|n| n.starts_with("base.") || n.starts_with("tool.")),
            "{full:?}"
        );
        assert_eq!(
            names(select(&r, "a2, thetaR").unwrap()),
            ["a2", "base.theta"]
        );
        let e = select(&r, "offsets,d3").unwrap_err().to_string();
        assert!(e.contains("`d3`") && e.contains("beta3"), "{e}");
        // A 6-DOF base comes before the offsets.
        let ur = crate::model::test_ur10();
        let up = ur.parameters();
        let s = select(&ur, "offsets,base").unwrap();
        assert_eq!(up[s[0]].name(), "base.x");
        assert_eq!(up[s[6]].name(), "theta1");
    }
}
