//! Refinement: the model's parameters re-estimated on the compensator's training rows before
//! the network is trained on what the refined model still misses.
//!
//! The re-estimation is an identification ([`crate::identify::identify`], started at the
//! given model, no re-registration unless the model misses the rows by more than
//! [`crate::evaluate::MISPLACED_MEDIAN_MM`]) and so runs the exact model with its exact Jacobian in
//! every iteration; its identifiable subset comes from the rank analysis of the training rows.
//! It keeps the model's unobserved marks ([`crate::model::Robot::unobserved`]) but those of
//! parameters the rows observe, and adds none.
//! Parameters and network are never estimated together: a network's constant output can
//! mimic a joint offset or a base rotation, and a joint estimate would let them trade along
//! that direction by any amount. Whether the refined model is kept is decided on held-out
//! rows by the exact compensated prediction ([`super::tuning`]).

use crate::data::MeasurementSet;
use crate::error::{Error, Result};
use crate::identify::identifiability::DropReason;
use crate::identify::{Options, Sigmas, identify};
use crate::model::Robot;

/// Refinement keeps a parameter only when its column's angle to the span of those kept before
/// it has a sine of at least this (its standard deviation at most 100 times what an
/// orthogonal column would give): a model that was identified already has parameters whose
/// columns nearly coincide (the d of parallel axes), and re-estimating those would move them
/// by metres for nothing.
pub const RANK_TOLERANCE: f64 = 1e-2;

/// A model parameter re-estimated for the network (file units: mm or deg).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct RefinedParam {
    /// Parameter name: `a3`, `theta1`, `base.x`, ...
    pub name: String,
    /// Its file unit: `mm`, `deg`, or a compliance's (`mrad/kNm`, and `mrad/kNm*kg`,
    /// `mrad/kNm*kg*m` for mass-free coefficients; [`crate::model::Field::file_unit`]).
    pub unit: String,
    /// Value in the given model (mm or deg).
    pub before: f64,
    /// Re-estimated value (mm or deg).
    pub after: f64,
    /// One standard deviation of the re-estimate (file units).
    pub std: f64,
}

/// Re-estimates the parameters `spec` (a selection as for `identify`) of `model` on `set`:
/// the refined model, what moved, and notes: the identification's warnings and the unmodelled
/// error it added to the rows' sigmas ([`crate::identify::unmodelled`]), if any.
pub fn refine(
    model: &Robot,
    set: &MeasurementSet,
    spec: &str,
    sigmas: Sigmas,
) -> Result<(Robot, Vec<RefinedParam>, Vec<String>)> {
    // A model far off the rows (a nominal file, not registered to the tracker's frame:
    // `train` warns of it) is registered first, as `identify` does, where the selection holds
    // the whole base: started metres away, `full,compliance` on Series B ran its
    // compliances to 30 mm of validation error and the compensator to 54 mm.
    let misplaced = crate::evaluate::misplaced_median(model, set);
    let id = identify(
        model,
        set,
        &Options {
            params: spec.into(),
            sigmas,
            register: misplaced.is_some(),
            rank_tolerance: RANK_TOLERANCE,
            ..Default::default()
        },
    )
    .map_err(|e| Error::Invalid(format!("refining `{spec}` on the training rows: {e}")))?;
    let moved = id
        .parameters
        .iter()
        .map(|p| RefinedParam {
            name: p.name.clone(),
            unit: p.unit.clone(),
            before: p.nominal,
            after: p.estimate,
            std: p.std,
        })
        .collect();
    let mut notes: Vec<String> = id
        .warnings
        .iter()
        .map(|w| format!("refinement: {w}"))
        .collect();
    if let (Some((median, _)), Some(r)) = (misplaced, &id.registration) {
        notes.push(format!(
            "refinement: the model misses the training rows' positions by {median:.1} mm \
             (median): their frame was registered first (RMS {:.4} mm), as `identify` does",
            r.rms_mm
        ));
    }
    // A compliance the rows cannot tell from the model's value keeps it: where that is not
    // zero (a compliant model's), the user is told, as `identify` tells it.
    let params = id.robot.parameters();
    let held: Vec<String> = (id.identifiability.dropped.iter())
        .filter(|d| matches!(d.reason, DropReason::NotSignificant(_)))
        .map(|d| params[d.param])
        .filter(|p| id.robot.param(*p) != 0.0)
        .map(|p| {
            format!(
                "{} {} {}",
                p.name(),
                p.field.to_file(id.robot.param(p)),
                p.field.file_unit()
            )
        })
        .collect();
    if !held.is_empty() {
        notes.push(format!(
            "refinement: not significant on the training rows, held at the model's values: {}",
            held.join(", ")
        ));
    }
    // The weights the refined values and their sigmas come from, as `identify` reports them.
    if let Some(note) = id.unmodelled.note("the training rows") {
        notes.push(format!("refinement: {note}"));
    }
    // A refinement re-estimates a model identified already: what the training rows cannot see
    // was observed then, or is marked already, so it adds no marks (it only lifts those of
    // parameters the rows observe).
    let kept: Vec<_> = (id.robot.unobserved().iter())
        .filter(|p| model.unobserved().contains(p))
        .copied()
        .collect();
    Ok((id.robot.with_unobserved(&kept)?, moved, notes))
}
