//! Whether two models are one arm: a calibration moves the distances between the flange's
//! positions at the same joints by millimetres, another robot's model by tens of percent.
//! `compensate` holds a calibrated model to its nominal with it, and `predict`, `evaluate`
//! and `compensate` a compensator's embedded model to the robot given.

use super::{Frames, frames};
use crate::model::Robot;

/// The largest difference of arm distances ([`arm_distance_gap`]) a calibrated model may
/// have from its nominal, as a fraction of the arm's size: calibrations change them by
/// millimetres, another robot's model by tens of percent.
pub const GEOMETRY_GAP: f64 = 0.1;

/// How far `calibrated`'s arm is from `nominal`'s, whatever the base and tool frames: at
/// sixteen configurations spread over the nominal's joint ranges, the position of the chain's
/// last frame (the flange: after the last joint's row, before the tool) in each model, and
/// every distance between two of them (mm); returns the largest difference between the
/// models' distances and the largest of the nominal's (the arm's size, mm). The base frame
/// (the measurement frame once calibrated) and the tool (which the controller may take as
/// the flange) drop out, and so does how each row's convention places its frames along the
/// joint axes (the UR10 in DH and in MDH with Hayati rows agree to 5e-13 mm).
pub fn arm_distance_gap(nominal: &Robot, calibrated: &Robot) -> (f64, f64) {
    const CONFIGURATIONS: usize = 16;
    let (mut a, mut b) = (Frames::new(nominal), Frames::new(calibrated));
    let n = nominal.dof();
    let mut ends = Vec::with_capacity(CONFIGURATIONS);
    for k in 0..CONFIGURATIONS {
        let q: Vec<f64> = (nominal.joints().iter().enumerate())
            .map(|(j, joint)| {
                let [lo, hi] = joint.limits_internal();
                // A fixed low-discrepancy spread: the golden ratio's multiples mod 1.
                let t = ((k * n + j) as f64 * 0.618_033_988_749_895 + 0.25).fract();
                lo + (hi - lo) * t
            })
            .collect();
        frames(nominal, &q, &mut a);
        frames(calibrated, &q, &mut b);
        ends.push((
            a.link[n - 1].translation.vector,
            b.link[n - 1].translation.vector,
        ));
    }
    let (mut gap, mut scale) = (0.0_f64, 0.0_f64);
    for (i, (pa, pb)) in ends.iter().enumerate() {
        for (qa, qb) in &ends[i + 1..] {
            let (da, db) = ((pa - qa).norm(), (pb - qb).norm());
            gap = gap.max((da - db).abs());
            scale = scale.max(da);
        }
    }
    (gap, scale.max(1.0))
}

/// `None` when `other` is an arm of `reference`'s (its [`arm_distance_gap`] within
/// [`GEOMETRY_GAP`] of the arm's size); else what differs, for a message: "the distances
/// between the flange positions at the same joints differ by up to G mm (P % of the arm's S
/// mm), where a calibration moves them by millimetres".
pub fn another_arm(reference: &Robot, other: &Robot) -> Option<String> {
    let (gap, scale) = arm_distance_gap(reference, other);
    (gap > GEOMETRY_GAP * scale).then(|| {
        format!(
            "the distances between the flange positions at the same joints differ by up to \
             {gap:.0} mm ({:.0} % of the arm's {scale:.0} mm), where a calibration moves them \
             by millimetres",
            100.0 * gap / scale
        )
    })
}
