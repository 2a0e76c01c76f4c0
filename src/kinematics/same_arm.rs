//! Whether two models are one arm: a calibration moves the distances between the flange's
//! positions at the same joints by millimetres, another robot's model by tens of percent.
//! `compensate` holds a calibrated model to its nominal with it, and `evaluate` and
//! `compensate` a compensator's embedded model to the robot given.

use super::spread::spread;
use super::{Frames, frames};
use crate::model::Robot;

/// The largest difference of arm distances ([`arm_distance_gap`]) two models of one arm may
/// have, as a fraction of the arm's size: a calibration (or a compensator's refinement)
/// changes them by millimetres, another robot's model by tens of percent.
pub const GEOMETRY_GAP: f64 = 0.1;

/// The configurations compared: sixteen spread over the reference's joint ranges.
const CONFIGURATIONS: usize = 16;

/// For the flange (the chain's last frame: after the last joint's row, before the tool) and
/// for the tool, at [`CONFIGURATIONS`] configurations spread over `reference`'s joint ranges:
/// the largest difference between the two models' distances from one configuration's point
/// to another's (mm), and the largest of `reference`'s distances (the arm's size, mm).
fn point_gaps(reference: &Robot, other: &Robot) -> [(f64, f64); 2] {
    let (mut a, mut b) = (Frames::new(reference), Frames::new(other));
    let n = reference.dof();
    let mut points = Vec::with_capacity(CONFIGURATIONS);
    for k in 0..CONFIGURATIONS {
        let q: Vec<f64> = (reference.joints().iter().enumerate())
            .map(|(j, joint)| {
                let [lo, hi] = joint.limits_internal();
                lo + (hi - lo) * spread(k, n, j)
            })
            .collect();
        frames(reference, &q, &mut a);
        frames(other, &q, &mut b);
        let point = |f: &Frames| [f.link[n - 1].translation.vector, f.tool.translation.vector];
        points.push((point(&a), point(&b)));
    }
    [0, 1].map(|p| {
        let (mut gap, mut scale) = (0.0_f64, 0.0_f64);
        for (i, (pa, pb)) in points.iter().enumerate() {
            for (qa, qb) in &points[i + 1..] {
                let (da, db) = ((pa[p] - qa[p]).norm(), (pb[p] - qb[p]).norm());
                gap = gap.max((da - db).abs());
                scale = scale.max(da);
            }
        }
        (gap, scale.max(1.0))
    })
}

/// How far `other`'s arm is from `reference`'s, whatever their base frames: the distances
/// between the points of two configurations do not depend on the base frame (the
/// measurement frame, once calibrated). Of the flange's and the tool's distances
/// (`point_gaps`), the pair (largest difference, arm's size, both mm) whose difference is
/// the smaller part of the arm: the flange's where the tools differ (a controller's flange
/// against a calibrated measurement tool), the tool's where the files split the chain
/// elsewhere (the last joint's offset in its row or in the tool). How each row's convention
/// places its frames along the joint axes drops out of both (the UR10 in DH and in MDH with
/// Hayati rows agree to 5e-13 mm).
pub fn arm_distance_gap(reference: &Robot, other: &Robot) -> (f64, f64) {
    let [flange, tool] = point_gaps(reference, other);
    if flange.0 / flange.1 <= tool.0 / tool.1 {
        flange
    } else {
        tool
    }
}

/// How far `other`'s tool is from `reference`'s on one arm: the largest difference between
/// the two models' distances from one configuration's tool position to another's (mm), where
/// it exceeds `tolerance` (mm) and the flanges' distances differ by `tolerance` or less (else
/// the files split the chain elsewhere, or the arms differ beyond a tool); None otherwise. A
/// calibration moves it by millimetres; a measurement tool the other model lacks, or a TCP
/// updated in one file only, by up to twice the tools' distance.
pub fn tool_gap(reference: &Robot, other: &Robot, tolerance: f64) -> Option<f64> {
    let [flange, tool] = point_gaps(reference, other);
    (tool.0 > tolerance && flange.0 <= tolerance).then_some(tool.0)
}

/// `None` when `other` is an arm of `reference`'s (its [`arm_distance_gap`] within
/// [`GEOMETRY_GAP`] of the arm's size, for the flange or the tool); else what differs, for a
/// message.
pub fn another_arm(reference: &Robot, other: &Robot) -> Option<String> {
    let [flange, tool] = point_gaps(reference, other);
    let far = |(gap, scale): (f64, f64)| gap > GEOMETRY_GAP * scale;
    let part = |(gap, scale): (f64, f64)| {
        format!(
            "up to {gap:.0} mm ({:.1} % of the arm's {scale:.0} mm)",
            100.0 * gap / scale
        )
    };
    (far(flange) && far(tool)).then(|| {
        format!(
            "the distances between the flange positions at the same joints differ by {}, and \
             those between the tool positions by {}, where a calibration moves them by \
             millimetres",
            part(flange),
            part(tool)
        )
    })
}
