//! What the search tells besides its table: the refinements' notes, and why nothing could
//! be scored.

use super::COMPLIANCE_MARGIN;
use crate::error::Error;
use crate::neural::selection::Candidate;

/// What to tell about the refinements asked for, `tried` (besides none; `added`, if any, is
/// the one with the compliances cross-validation added on its own): which changed the model
/// on some fold (`kept`: the others were left out), whether any refined candidate could be
/// scored (`scored`: where each failed, the table says why) and what was chosen (`winner`).
pub(super) fn refinement_notes(
    tried: &[String],
    kept: &[Option<String>],
    added: Option<&str>,
    scored: bool,
    winner: Option<&str>,
) -> Vec<String> {
    let changes = |r: &str| kept.iter().any(|k| k.as_deref() == Some(r));
    let Some(first) = tried.first() else {
        return Vec::new();
    };
    let mut notes = Vec::new();
    if !tried.iter().any(|t| changes(t)) {
        notes.push(format!(
            "refining `{first}` changes nothing on these rows: the model is kept as given"
        ));
        return notes;
    }
    // "Did not lower the error" would claim a comparison that never took place.
    if !scored {
        notes.push(format!(
            "refining `{first}` could not be cross-validated on these rows (the table says \
             why): the model is kept as given"
        ));
        return notes;
    }
    let added_changes = added.is_some_and(changes);
    if added.is_some() && !changes(first) {
        notes.push(format!(
            "refining `{first}` alone changes nothing on these rows"
        ));
    }
    let margin = COMPLIANCE_MARGIN * 100.0;
    match winner {
        None if added_changes => notes.push(format!(
            "refining `{first}` did not lower the cross-validated error (with the joints' \
             gravity compliances, not by {margin:.0} % or more): the model is kept as given"
        )),
        None => notes.push(format!(
            "refining `{first}` did not lower the cross-validated error: the model is kept as \
             given"
        )),
        Some(w) if Some(w) == added => notes.push(format!(
            "cross-validation added the joints' gravity compliances to the refinement of \
             `{first}`: they lowered its cross-validated error by {margin:.0} % or more"
        )),
        Some(_) => {}
    }
    notes
}

/// The error of a search in which no candidate could be scored: every candidate's own.
pub(super) fn failed(candidates: &[Candidate]) -> Error {
    let why: Vec<String> = candidates
        .iter()
        .filter_map(|c| {
            c.error
                .as_ref()
                .map(|e| format!("{}: {e}", c.settings.describe()))
        })
        .collect();
    Error::Invalid(format!(
        "no candidate could be cross-validated: {}",
        why.join("; ")
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn refinement_notes_say_what_changed_and_what_was_kept() {
        let t = |v: &[&str]| v.iter().map(|x| x.to_string()).collect::<Vec<_>>();
        let k = |v: &[&str]| -> Vec<Option<String>> {
            std::iter::once(None)
                .chain(v.iter().map(|x| Some(x.to_string())))
                .collect()
        };
        let both = t(&["full", "full,compliance"]);
        let added = Some("full,compliance");
        let one = |n: Vec<String>| {
            assert_eq!(n.len(), 1, "{n:?}");
            n[0].clone()
        };
        // Nothing changed the model.
        let n = one(refinement_notes(&both, &k(&[]), added, true, None));
        assert!(n.contains("`full` changes nothing"), "{n}");
        // The geometry alone changed nothing; the compliances did, and lost by the margin.
        let n = refinement_notes(&both, &k(&["full,compliance"]), added, true, None);
        assert_eq!(n.len(), 2, "{n:?}");
        assert!(n[0].contains("`full` alone changes nothing"), "{n:?}");
        assert!(n[1].contains("not by 2 % or more"), "{n:?}");
        // ... or won.
        let n = refinement_notes(&both, &k(&["full,compliance"]), added, true, added);
        assert_eq!(n.len(), 2, "{n:?}");
        assert!(
            n[1].contains("added the joints' gravity compliances"),
            "{n:?}"
        );
        // Both changed it; the geometry was kept: nothing to tell.
        let n = refinement_notes(
            &both,
            &k(&["full", "full,compliance"]),
            added,
            true,
            Some("full"),
        );
        assert!(n.is_empty(), "{n:?}");
        // A fixed selection that did not lower the error.
        let n = one(refinement_notes(
            &t(&["offsets"]),
            &k(&["offsets"]),
            None,
            true,
            None,
        ));
        assert!(
            n.contains("`offsets` did not lower") && !n.contains("2 %"),
            "{n}"
        );
        let n = one(refinement_notes(
            &t(&["offsets"]),
            &k(&[]),
            None,
            true,
            None,
        ));
        assert!(n.contains("`offsets` changes nothing"), "{n}");
        // Every refined candidate failed (too few rows on each fold): nothing was compared.
        let n = one(refinement_notes(
            &both,
            &k(&["full", "full,compliance"]),
            added,
            false,
            None,
        ));
        assert!(
            n.contains("`full` could not be cross-validated") && !n.contains("did not lower"),
            "{n}"
        );
    }
}
