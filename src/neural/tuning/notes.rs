//! What the search tells besides its table: the refinements' notes and tests, the network's
//! test, the outliers, and why nothing could be scored.

use super::{COMPLIANCE_MARGIN, NETWORK_MARGIN, NETWORK_Z, REFINEMENT_MARGIN, REFINEMENT_Z};
use crate::data::measurement::row_name;
use crate::error::Error;
use crate::neural::selection::{Candidate, NetworkTest, Outlier, Unseen};
use crate::neural::settings::Settings;

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

/// A ratio of cross-validated errors as the notes give it: `12.5 % below` or `3.0 % above`.
pub(super) fn below_or_above(ratio: f64) -> String {
    let below = (1.0 - ratio) * 100.0;
    if below >= 0.0 {
        format!("{below:.1} % below")
    } else {
        format!("{:.1} % above", -below)
    }
}

/// The model of a model alone's settings as the notes name it: `refine full` or `as given`.
pub(super) fn alone_model(alone: &Settings) -> String {
    alone
        .refine
        .as_ref()
        .map_or("as given".to_string(), |r| format!("refine {r}"))
}

/// "12 held-out rows", or "12 held-out rows of 9 configurations (each weighed once)" where
/// configurations repeat (0 configurations: a report written before they were counted).
pub(super) fn rows_of(rows: usize, configurations: usize) -> String {
    match repeated(rows, configurations) {
        Some(c) => format!("{rows} held-out rows of {c} configurations (each weighed once)"),
        None => format!("{rows} held-out rows"),
    }
}

/// The count of `configurations` among `rows` where some repeat (None where none does, or
/// where a report written before they were counted holds 0).
pub(super) fn repeated(rows: usize, configurations: usize) -> Option<usize> {
    (configurations > 0 && configurations < rows).then_some(configurations)
}

/// A paired z as the notes give it, to one decimal, or more where one would put it on the
/// other side of the test's level, -`level` (a network or refinement kept) or +`level` (a
/// fixed network warned of): z = -2.454 against 2.5 read "-2.5", a pass, in a test it failed
/// (a helper's).
pub(super) fn z_shown(z: f64, level: f64) -> String {
    let side = |v: f64| (v <= -level, v >= level);
    (1..=6)
        .map(|d| format!("{z:.d$}"))
        .find(|s| s.parse::<f64>().is_ok_and(|v| side(v) == side(z)))
        .unwrap_or_else(|| z.to_string())
}

/// A test's row-by-row figures as the notes give them, its z against `level`.
pub(super) fn paired_rows(t: &NetworkTest, level: f64) -> String {
    if t.rows > 0 {
        format!(
            "paired z {} over {}",
            z_shown(t.z, level),
            rows_of(t.rows, t.configurations)
        )
    } else {
        "no row-by-row test (the held-out rows could not be recomputed as scored)".into()
    }
}

/// The note of a refinement's test ([`REFINEMENT_MARGIN`], [`REFINEMENT_Z`]): the refined
/// candidate and what it was held against (each as [`Settings::describe`] says it), the
/// figures as judged and the verdict.
pub(super) fn refinement_test_note(t: &NetworkTest, candidates: &[Candidate]) -> String {
    let (refined, base) = (
        &candidates[t.network].settings,
        &candidates[t.alone].settings,
    );
    let by = below_or_above(t.ratio);
    let rows = paired_rows(t, REFINEMENT_Z);
    let verdict = if t.kept {
        "the refinement is kept".to_string()
    } else {
        format!(
            "not {:.0} % below with a paired z of -{REFINEMENT_Z} or lower: the refinement is \
             not kept",
            REFINEMENT_MARGIN * 100.0
        )
    };
    format!(
        "refined, {}: cross-validated error {by} {}'s ({rows}, as judged): {verdict}",
        refined.describe(),
        base.describe()
    )
}

/// The errors' own ratio of test `t` (network over model alone) and a function that gives a
/// ratio as judged (each candidate's RMS times its refinement's margin, [`COMPLIANCE_MARGIN`])
/// as "X % below as judged", None where the margins leave it the same: the errors' own ratio
/// comes first, so that it and the paired z (of the errors) speak of the
/// same figures.
pub(super) fn raw_ratio(
    t: &NetworkTest,
    candidates: &[Candidate],
) -> (f64, impl Fn(f64) -> Option<String>) {
    let raw = super::rank::cv_rms(candidates, t.network) / super::rank::cv_rms(candidates, t.alone);
    let differs = (raw - t.ratio).abs() > 1e-12 * raw;
    (raw, move |judged: f64| {
        differs.then(|| format!("{} as judged", below_or_above(judged)))
    })
}

/// `judged` (from [`raw_ratio`]) as the clause after a model alone's name.
pub(super) fn with_margin(judged: Option<String>) -> String {
    judged.map_or(String::new(), |j| {
        format!(
            "; {j}, with the compliance refinement's {:.0} % margin",
            COMPLIANCE_MARGIN * 100.0
        )
    })
}

/// The note on stage 5's test `t` of a network against the best model alone (`candidates`:
/// the search's, which `t` indexes): `network` names the network, `then` what follows where
/// it is not kept.
pub(super) fn network_note(
    t: &NetworkTest,
    candidates: &[Candidate],
    network: &str,
    then: &str,
) -> String {
    let by = below_or_above;
    let model = alone_model(&candidates[t.alone].settings);
    let rows = paired_rows(t, NETWORK_Z);
    let (raw, judged) = raw_ratio(t, candidates);
    let mut test = format!(
        "{network}'s cross-validated error is {} the best model alone's ({model}{}), {rows}",
        by(raw),
        with_margin(judged(t.ratio))
    );
    // The figures that decide: those on rows no hyperparameter search saw, where they ran.
    if let Some(u) = &t.unseen {
        test.push_str(", with its RBF hyperparameters searched on all training rows; ");
        test.push_str(&if u.by == Unseen::Folds {
            format!(
                "searched on each fold's training rows alone (no search seeing the rows it is \
                 judged on), {}{}, paired z {} over {}",
                by(u.ratio * raw / t.ratio),
                judged(u.ratio).map_or(String::new(), |j| format!(" ({j})")),
                z_shown(u.z, NETWORK_Z),
                rows_of(u.rows, u.configurations)
            )
        } else {
            format!(
                "on the {} held-out rows of configurations that search did not draw, {}{}, \
                 paired z {}{}",
                u.rows,
                by(u.ratio * raw / t.ratio),
                judged(u.ratio).map_or(String::new(), |j| format!(" ({j})")),
                z_shown(u.z, NETWORK_Z),
                repeated(u.rows, u.configurations).map_or(String::new(), |c| {
                    format!(" over their {c} configurations (each weighed once)")
                })
            )
        });
    }
    if t.kept {
        // The choice is made on position: say where the orientation pays for it.
        let rot = |i: usize| {
            candidates[i]
                .score
                .as_ref()
                .and_then(|s| s.orientation_rms_deg)
        };
        return match (rot(t.network), rot(t.alone)) {
            (Some(n), Some(a)) if n > a => format!(
                "{test}: the network is kept (chosen on position; its cross-validated \
                 orientation error is {:.1} % above the model alone's, {n:.4} against {a:.4} \
                 deg RMS)",
                (n / a - 1.0) * 100.0
            ),
            _ => format!("{test}: the network is kept"),
        };
    }
    let ratio = t.unseen.as_ref().map_or(t.ratio, |u| u.ratio);
    let why = if ratio * (1.0 + NETWORK_MARGIN) > 1.0 {
        format!("not {:.0} % or more below", NETWORK_MARGIN * 100.0)
    } else {
        format!("not significant row by row (a paired z of -{NETWORK_Z} or lower is needed)")
    };
    format!("{test}, {why}: {then}")
}

/// The note on training rows beyond `k` robust sigmas of the cross-validated error, named in
/// the rows given to training; `dropped`: left out of the final fit.
pub fn outlier_note(outliers: &[Outlier], k: f64, dropped: bool) -> String {
    let rows: Vec<String> = outliers.iter().map(|o| row_name(o.line, o.row)).collect();
    format!(
        "{} training row(s) beyond {k} robust sigmas of the cross-validated error ({}): {}",
        outliers.len(),
        rows.join(", "),
        if dropped {
            "left out of the final fit (a mis-measured row, or a sharp feature of the robot \
             one sample cannot tell; check them, or ask for them to be kept)"
        } else {
            "kept (a mis-measured row, or a sharp feature of the robot; check them, or \
             ask for them to be dropped from the final fit)"
        }
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::neural::compensator::Form;
    use crate::neural::encoding::Encoding;
    use crate::neural::selection::Score;
    use crate::neural::settings::Network;

    #[test]
    fn a_z_is_shown_on_its_side_of_the_level() {
        // One decimal where it keeps the verdict; more where rounding would cross the level.
        assert_eq!(z_shown(-8.93, 2.5), "-8.9");
        assert_eq!(z_shown(-1.36, 2.5), "-1.4");
        assert_eq!(z_shown(-2.454, 2.5), "-2.45");
        assert_eq!(z_shown(-2.4999, 2.5), "-2.4999");
        assert_eq!(z_shown(-2.5, 2.5), "-2.5");
        assert_eq!(z_shown(-2.46, 2.0), "-2.5");
        assert_eq!(z_shown(-1.96, 2.0), "-1.96");
        assert_eq!(z_shown(2.46, 2.5), "2.46");
        assert_eq!(z_shown(2.56, 2.5), "2.6");
    }

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

    #[test]
    fn held_out_rows_name_their_configurations_where_some_repeat() {
        assert_eq!(
            rows_of(12, 9),
            "12 held-out rows of 9 configurations (each weighed once)"
        );
        assert_eq!(rows_of(12, 12), "12 held-out rows");
        // A report written before the configurations were counted.
        assert_eq!(rows_of(12, 0), "12 held-out rows");
    }

    /// The network test's note gives the errors' own ratio, whose sign the paired z shares,
    /// and the ratio as judged beside it where a compliance refinement's margin moved it (a
    /// reviewer's note read "0.7 % below ..., paired z 0.4": the network was 1.3 % above).
    #[test]
    fn the_network_note_gives_the_errors_own_ratio_first() {
        let candidate = |network: Network, members: usize, refine: &str, rms: f64| Candidate {
            stage: 5,
            label: String::new(),
            settings: Settings {
                network,
                rbf_start: Some(0),
                form: Form::Pose,
                encoding: Encoding::Gravity,
                hidden: 0,
                penalty: 0.0,
                members,
                refine: Some(refine.to_string()),
                mlp_share: None,
            },
            score: Some(Score {
                position_rms_mm: rms,
                orientation_rms_deg: None,
            }),
            error: None,
            pruned: None,
            proxy: false,
            race: None,
        };
        let candidates = [
            candidate(Network::Rbf, 1, "full", 0.1053),
            candidate(Network::Mlp, 0, "full,compliance", 0.1039),
        ];
        let t = NetworkTest {
            network: 0,
            alone: 1,
            ratio: 0.1053 / (0.1039 * (1.0 + COMPLIANCE_MARGIN)),
            z: 0.4,
            rows: 150,
            configurations: 150,
            kept: false,
            unseen: None,
        };
        let note = network_note(
            &t,
            &candidates,
            "the network",
            "the compensator is the model alone",
        );
        assert!(
            note.starts_with(
                "the network's cross-validated error is 1.3 % above the best model alone's \
                 (refine full,compliance; 0.6 % below as judged, with the compliance \
                 refinement's 2 % margin), paired z 0.4 over 150 held-out rows"
            ),
            "{note}"
        );
        // Without a margin between them, the one ratio.
        let t = NetworkTest {
            ratio: 0.1053 / 0.1039,
            ..t
        };
        let mut plain = candidates.clone();
        plain[1].settings.refine = Some("full".into());
        let note = network_note(&t, &plain, "the network", "the model alone");
        assert!(
            note.starts_with(
                "the network's cross-validated error is 1.3 % above the best model alone's \
                 (refine full), paired z"
            ),
            "{note}"
        );
    }
}
