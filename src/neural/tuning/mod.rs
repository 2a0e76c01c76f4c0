//! The self-tuning default: k-fold cross-validation on the training rows chooses what the
//! options leave open (network, form, encoding, hidden units, penalty, refinement, ensemble
//! size).
//!
//! Folds are drawn by a seeded shuffle of whole configurations (rows that repeat a joint
//! configuration, within [`super::repeats::SAME_CONFIGURATION`], stay in one fold). Every
//! candidate is fitted on k - 1 folds (refinement included, so a refined model is judged on
//! rows it never saw) and scored on the held-out fold through the exact compensated prediction ([`Compensator::predict`], the code path
//! of `predict` and `evaluate`, except the training-domain fade: candidates carry no domain,
//! whose nearest-neighbour search would cost more than the fit, so their correction is never
//! faded); the score is the RMS position error over all held-out rows (mm), orientation RMS
//! reported beside it.
//!
//! [`Compensator::predict`]: crate::neural::compensator::Compensator::predict
//!
//! The search is staged to stay cheap, each step starting from the best so far: (1) the forms
//! with gravity inputs at the middle size and penalty, then the penalty decade and the other
//! encodings; (2) hidden units, then a finer penalty step; (3) the ensemble, kept where it
//! lowers the cross-validated error, then the RBF network from its search start, alone and
//! blended with the best pose-form MLPs at the MLPs' share of lowest cross-validated error
//! among [`SHARES`] (its hyperparameters searched once on the training rows, at most
//! [`super::rbf::HYPER_ROWS`] of them, beside stages 2 and 3; the folds fit only its
//! weights); (4) refinement (for a blend, judged first with the RBF network alone on the race
//! folds, and the best refinement then tried with the blend); (5) no network at all. Candidates are fitted
//! with a phase 2 of fixed work ([`CV_WORK`]) and without phase 1, and raced: each is scored
//! on [`RACE_FOLDS`] folds first and dropped there when it is more than [`RACE_MARGIN`] worse
//! than the best so far on the same folds. The chosen settings are then fitted in full.

mod cv;
mod rows;

use super::encoding::Encoding;
use super::parallel::parallel_map;
use super::selection::Sums;
pub use super::selection::{Candidate, Outlier, Score, Selection};
pub use super::settings::OUTLIER_K;
use super::settings::{CompensatorOptions, Form, Network, Refine, Settings, check_share};
use crate::data::MeasurementSet;
use crate::error::{Error, Result};
use crate::model::Robot;
use cv::{Cv, searches};
pub use rows::{folds, outliers_of, subset};
use rows::{held_errors, sums};
use std::collections::HashMap;
use std::sync::Mutex;
use std::sync::atomic::{AtomicUsize, Ordering};

/// Hidden units tried when not fixed (the middle one first).
pub const HIDDEN: [usize; 3] = [16, 32, 64];
/// Penalties tried first when not fixed, a decade apart: how much regularisation a set needs
/// depends on its size and noise far more than on anything else.
pub const PENALTIES: [f64; 3] = [0.1, 1.0, 10.0];
/// The finer step tried around the best of [`PENALTIES`] (factor).
pub const PENALTY_STEP: f64 = 3.0;
/// Work of one candidate's phase 2 (rows x L-BFGS iterations, 10 an epoch), within 10 and 25
/// epochs: every candidate costs about the same whatever the set's size (about 110 iterations
/// on 1333 rows, 250 on up to 600). A flat 100 iterations halved the time on small sets but
/// chose a worse encoding on a real 500-pose pool (+6 % RMS).
pub const CV_WORK: usize = 150_000;
/// Work of each network of the final fit (rows x L-BFGS iterations, 10 an epoch), within 50
/// and 60 epochs: 500 iterations on 2000 rows, 600 on up to 1333.
pub const FIT_WORK: usize = 800_000;

/// The phase-2 epoch limit that spends `work` on `rows` rows, within [`lo`, `hi`] epochs.
pub fn budget_epochs(work: usize, rows: usize, lo: usize, hi: usize) -> usize {
    (work / rows.max(1) / 10).clamp(lo, hi)
}

/// Folds on which every candidate is scored first (racing).
pub const RACE_FOLDS: usize = 2;
/// A candidate whose RMS on the race folds exceeds the best's there by more than this
/// fraction is dropped without fitting the other folds: on 2 of 5 folds a 10 % gap is rarely
/// closed by the other 3.
pub const RACE_MARGIN: f64 = 0.10;

/// Distinct configurations from which cross-validation uses 4 folds instead of 5.
pub const MANY: usize = 1500;

/// Relative cross-validated error within which an ensemble counts as no worse than one network.
pub const ENSEMBLE_TIE: f64 = 0.005;

/// Networks of the ensemble probe in cross-validation: if two networks beat one, the mean of
/// [`ENSEMBLE`] beats both.
pub const ENSEMBLE_PROBE: usize = 2;

/// The MLPs' shares at which a mixed network's candidate is scored when not fixed; it takes
/// the share of lowest cross-validated error (one number chosen on every held-out residual,
/// hardly an optimistic choice), and the networks run once per row for all of them
/// ([`crate::neural::compensator::Compensator::predict_shares`]). The equal say of earlier
/// versions (1/2) was too much on real tracker data: on five Series B splits the held-out
/// error of the blend fell from the RBF network alone to a minimum at shares 0.1-0.3 and rose
/// steeply beyond, and cross-validation chose shares of 0.05-0.4 there (20 fits).
/// Written out, so that each reads back and prints as typed (0.15, not 0.15000000000000002).
pub const SHARES: [f64; 19] = [
    0.05, 0.1, 0.15, 0.2, 0.25, 0.3, 0.35, 0.4, 0.45, 0.5, 0.55, 0.6, 0.65, 0.7, 0.75, 0.8, 0.85,
    0.9, 0.95,
];

/// Rows up to which cross-validation tries an RBF network when the network is not fixed: its
/// weights solve with the kernel matrix of every row (n^2 numbers, a factorisation cubic in
/// n), which MLPs do not need. The hyperparameter search itself sees at most
/// [`super::rbf::HYPER_ROWS`] rows.
pub const RBF_MAX_ROWS: usize = 3000;

/// Ensemble size tried against a single network when not fixed.
pub const ENSEMBLE: usize = 4;
/// The selection refined when refinement is left to cross-validation ([`Refine::Auto`]):
/// the full identifiable geometry, tried against none and, unless
/// [`CompensatorOptions::compliance`] says otherwise, with the joints' gravity compliances
/// (mass-free coefficients where the file has no masses).
pub const AUTO_REFINE: &str = "full";

/// Relative cross-validated error by which a refinement with the joints' gravity compliances
/// that cross-validation adds on its own ([`CompensatorOptions::compliance`] None) must beat
/// the best candidate without it to be chosen: it adds up to a hundred mass-free
/// coefficients, and a choice among more candidates is more optimistic. Where gravity
/// bends the joints it wins by far more (by 23 to 62 % on the simulated compliant robots
/// tried); on a real UR10 pool of 2000 rows it won by 0.3 %, which is no evidence.
pub const COMPLIANCE_MARGIN: f64 = 0.02;

/// Whether selection `spec` names compliance parameters of `robot`; an error where it does
/// not parse.
pub fn names_compliance(robot: &Robot, spec: &str) -> Result<bool> {
    let (completed, chosen, _) = crate::identify::candidates(robot, spec)?;
    let params = completed.parameters();
    Ok(chosen
        .iter()
        .any(|&i| crate::identify::select::is_compliance(&params[i])))
}

/// The refinements tried for selection `spec` (besides none), and the one cross-validation
/// added the joints' gravity compliances to on its own (judged by [`COMPLIANCE_MARGIN`]):
/// `spec` alone where it `names` compliances (they are refined as named) or `compliance` is
/// `Some(false)`; `spec` with them where `Some(true)`; both where None.
fn refinements(
    spec: &str,
    names: bool,
    compliance: Option<bool>,
) -> (Vec<Option<String>>, Option<String>) {
    let with = format!("{spec},compliance");
    match (names, compliance) {
        (true, _) | (_, Some(false)) => (vec![None, Some(spec.into())], None),
        (false, Some(true)) => (vec![None, Some(with)], None),
        (false, None) => (
            vec![None, Some(spec.into()), Some(with.clone())],
            Some(with),
        ),
    }
}

/// What to tell about the refinements asked for, `tried` (besides none; `added`, if any, is
/// the one with the compliances cross-validation added on its own): which changed the model
/// on some fold (`kept`: the others were left out) and what was chosen (`winner`).
fn refinement_notes(
    tried: &[String],
    kept: &[Option<String>],
    added: Option<&str>,
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

/// The settings to fit: `opts`'s fixed choices, the rest chosen by cross-validation on `set`
/// (None when nothing was left to choose).
pub fn select_settings(
    robot: &Robot,
    set: &MeasurementSet,
    opts: &CompensatorOptions,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<(Settings, Option<Selection>)> {
    let Space {
        refines,
        auto_compliance,
        rbf_only,
        mix_only,
        forms,
        encodings,
        hiddens,
        penalties,
        base,
        rbf_start,
        try_rbf,
        open,
    } = Space::of(robot, opts, set)?;
    if !open {
        // Nothing to choose (a fixed mix, its share given, keeps, output by output, the start
        // of highest likelihood).
        let network = opts.network.unwrap_or(Network::Mlp);
        let mlp_share = opts.mlp_share.filter(|_| network == Network::Mix);
        return Ok((
            Settings {
                network,
                mlp_share,
                ..base
            },
            None,
        ));
    }
    // Fewer folds train candidates on a smaller part of the set; where the held-out error
    // still falls steeply with more rows (real tracker data), 3 folds chose penalties ten
    // times too large. From MANY configurations on, candidate fits sit at their iteration
    // floor and the cost grows with the folds: 4 there.
    let groups = super::repeats::configuration_groups(set);
    let distinct = super::repeats::group_count(&groups);
    let want = opts.folds.unwrap_or(if distinct >= MANY { 4 } else { 5 });
    let fold_of = folds(&groups, want.max(2), opts.train.seed);
    let k = fold_of.iter().max().map_or(0, |m| m + 1);
    if k < 2 || want < 2 {
        return Err(Error::Invalid(format!(
            "choosing the settings by cross-validation needs at least 2 folds of distinct \
             configurations (got {k}); fix form, encoding, hidden units, penalty, ensemble \
             size and refinement instead"
        )));
    }
    let cv = Cv {
        robot,
        train: (0..k).map(|f| subset(set, |i| fold_of[i] != f)).collect(),
        held: (0..k).map(|f| subset(set, |i| fold_of[i] == f)).collect(),
        opts,
        nets: Mutex::new(HashMap::new()),
        warm: Mutex::new(HashMap::new()),
        fitted: Mutex::new(HashMap::new()),
        set,
        hypers: Mutex::new(HashMap::new()),
        rbf_fits: Mutex::new(HashMap::new()),
    };
    let rounds = AtomicUsize::new(0);
    let mut model = Sums::default();
    for f in 0..k {
        model.add(sums(&cv.held[f], |q| {
            crate::kinematics::tool_pose(robot, q)
        })?);
    }
    // Refined models per fold and refinement, computed once. A refinement whose models are
    // an earlier one's on every fold (the compliances all screened out) is the same
    // candidate: left out before anything is fitted with it.
    let mut refined: Vec<Vec<Result<Robot>>> = Vec::new();
    let mut refines = refines;
    let tried: Vec<String> = refines.iter().flatten().cloned().collect();
    refines.retain(|spec| {
        let models = parallel_map(k, |f| cv.model(f, spec));
        let repeated = refined
            .iter()
            .any(|earlier| earlier.iter().zip(&models).all(|(a, b)| same_model(a, b)));
        if !repeated {
            refined.push(models);
        }
        !repeated
    });
    let mut candidates: Vec<Candidate> = Vec::new();
    // Each candidate is first scored on the race folds; one that is already clearly worse
    // there than the best so far on the same folds is dropped before the other folds.
    let racer = Race {
        cv: &cv,
        refines: &refines,
        refined: &refined,
        k,
        race: if k > RACE_FOLDS { RACE_FOLDS } else { k },
        done: AtomicUsize::new(0),
        rounds: &rounds,
        progress,
    };
    let evaluate = |stage: usize, list: Vec<Settings>, candidates: &mut Vec<Candidate>| {
        racer.evaluate(stage, list, candidates)
    };
    if rbf_only {
        // A fixed RBF network: its encoding is open (its search start is the smooth one
        // unless given).
        let mut list = Vec::new();
        for &e in &encodings {
            list.push(Settings {
                encoding: e,
                rbf_start: Some(rbf_start),
                members: 1,
                ..base.clone()
            });
        }
        searches(&cv, &list);
        evaluate(1, list, &mut candidates);
    } else {
        // Stage 1: the forms (gravity inputs, middle size and penalty), then for the best so
        // far the penalty decade and the other encodings.
        evaluate(1, vary(&base, &forms, |s, f| s.form = f), &mut candidates);
    }
    if candidates.iter().all(|c| c.score.is_none()) {
        return Err(failed(&candidates));
    }
    // From here on some candidate has a score: the best always exists.
    let best = |candidates: &[Candidate]| better(candidates, 0, 1..candidates.len());
    let mut notes = Vec::new();
    if let Some(asked) = opts.folds
        && k < asked
    {
        notes.push(format!(
            "{asked} folds asked for, but the rows hold {distinct} distinct configurations: \
             {k} folds"
        ));
    }
    let mut chosen = best(&candidates);
    let with_rbf = try_rbf || mix_only;
    if opts.mlp_share.is_some() && !with_rbf {
        notes.push(format!(
            "an MLP share was given, but no blend of MLPs and the RBF network was tried (it \
             needs the pose form, MLPs, and at most {RBF_MAX_ROWS} rows)"
        ));
    }
    // The RBF hyperparameter searches run beside stages 2 and 3 (whose fits leave cores
    // idle between rounds) once stage 1 has fixed the pose form's encoding.
    std::thread::scope(|scope| {
        if !rbf_only {
            let w = candidates[best(&candidates)].settings.clone();
            evaluate(
                1,
                vary(&w, &penalties, |s, p| s.penalty = p),
                &mut candidates,
            );
            let w = candidates[best(&candidates)].settings.clone();
            evaluate(
                1,
                vary(&w, &encodings, |s, e| s.encoding = e),
                &mut candidates,
            );
            if with_rbf && let Some(p) = best_pose_mlp(&candidates) {
                let e = candidates[p].settings.encoding;
                let cv = &cv;
                scope.spawn(move || cv.hyper(e, rbf_start));
            }
            // Stage 2: hidden units, then a finer penalty step around the best.
            let w = candidates[best(&candidates)].settings.clone();
            evaluate(2, vary(&w, &hiddens, |s, h| s.hidden = h), &mut candidates);
            let w = candidates[best(&candidates)].settings.clone();
            if opts.penalty.is_none() {
                let step = [w.penalty / PENALTY_STEP, w.penalty * PENALTY_STEP].map(significant3);
                evaluate(2, vary(&w, &step, |s, p| s.penalty = p), &mut candidates);
            }
            chosen = best(&candidates);
            // Stage 3: the ensemble. The mean of several networks has at most the mean squared
            // error of its members (convexity), so a tie within ENSEMBLE_TIE goes to the ensemble.
            if opts.members.is_none() {
                let single = candidates[chosen].settings.clone();
                evaluate(
                    3,
                    vec![Settings {
                        members: ENSEMBLE_PROBE,
                        ..single
                    }],
                    &mut candidates,
                );
                let probe = candidates.len() - 1;
                if cv_rms(&candidates, probe) <= cv_rms(&candidates, chosen) * (1.0 + ENSEMBLE_TIE)
                {
                    chosen = probe;
                }
            }
        }
    });
    // Stage 3b: an RBF network from its search start, with the best pose-form MLPs (their
    // mean and the RBF network's blended at the best share) and alone, against the best so
    // far. The hyperparameters come from all training rows once; each fold fits only the
    // weights.
    if with_rbf {
        let pose_mlp = best_pose_mlp(&candidates);
        let first = candidates.len();
        let mut list = Vec::new();
        if let Some(p) = pose_mlp {
            list.push(Settings {
                network: Network::Mix,
                rbf_start: Some(rbf_start),
                mlp_share: opts.mlp_share,
                ..candidates[p].settings.clone()
            });
        }
        if !mix_only {
            list.push(Settings {
                network: Network::Rbf,
                form: Form::Pose,
                encoding: pose_mlp.map_or(base.encoding, |p| candidates[p].settings.encoding),
                hidden: 0,
                penalty: 0.0,
                members: 1,
                rbf_start: Some(rbf_start),
                refine: refines[0].clone(),
                mlp_share: None,
            });
        }
        searches(&cv, &list);
        evaluate(3, list, &mut candidates);
        chosen = if mix_only {
            // The network is fixed: the best of its own candidates, which need pose-form MLPs.
            if !(first..candidates.len()).any(|i| candidates[i].score.is_some()) {
                return Err(Error::Invalid(
                    "a mixed network: no pose-form MLP was fitted to mix the RBF network with \
                     (no members asked for, or every MLP candidate failed)"
                        .into(),
                ));
            }
            better(&candidates, first, first..candidates.len())
        } else {
            better(&candidates, chosen, first..candidates.len())
        };
    }
    // The compliance refinement that cross-validation adds on its own must win by a margin.
    let margin = |r: &Option<String>| {
        if auto_compliance.is_some() && *r == auto_compliance {
            1.0 + COMPLIANCE_MARGIN
        } else {
            1.0
        }
    };
    let judged = |candidates: &[Candidate], i: usize| {
        cv_rms(candidates, i) * margin(&candidates[i].settings.refine)
    };
    // Stage 4: refinement, judged for the network it will carry (early in the search, with
    // an unregularised single network, it looked worse where it finally helped 1.3x; judged
    // with one network instead of the ensemble, it lost by 0.6 % where the ensemble kept it
    // 1.1 % better on held-out real data).
    if refines.len() > 1 {
        let w = candidates[chosen].settings.clone();
        let first = candidates.len();
        // A mixed network's share is chosen again for each other refinement.
        let share = opts.mlp_share;
        let other = |s: &mut Settings, r: Option<String>| {
            if s.network == Network::Mix && s.refine != r {
                s.mlp_share = share;
            }
            s.refine = r;
        };
        let mut list = vary(&w, &refines, other);
        if w.network == Network::Mix {
            // A blend's MLPs cost most of its fits, and a refinement changes the residual they
            // learn. The refinements are judged first with the RBF network alone (the blend's
            // larger part: shares of 0.05-0.4 on real data) on the race folds, where every
            // candidate has been scored, and only the best of them is tried with the blend.
            let alone = Settings {
                network: Network::Rbf,
                hidden: 0,
                penalty: 0.0,
                members: 1,
                mlp_share: None,
                ..w.clone()
            };
            evaluate(
                4,
                vary(&alone, &refines, |s, r| s.refine = r),
                &mut candidates,
            );
            let proxy = |r: &Option<String>| {
                let raced = candidates
                    .iter()
                    .find(|c| {
                        c.settings
                            == Settings {
                                refine: r.clone(),
                                ..alone.clone()
                            }
                    })
                    .and_then(|c| c.race.as_ref());
                raced.map_or(f64::INFINITY, |t| t.score().position_rms_mm) * margin(r)
            };
            let best = refines
                .iter()
                .min_by(|a, b| proxy(a).total_cmp(&proxy(b)))
                .cloned();
            list.retain(|s| s.refine == w.refine || Some(&s.refine) == best.as_ref());
        }
        evaluate(4, list, &mut candidates);
        // A fixed mixed network stays one.
        let eligible = |candidates: &[Candidate], i: usize| {
            if mix_only && candidates[i].settings.network != Network::Mix {
                f64::INFINITY
            } else {
                judged(candidates, i)
            }
        };
        chosen = better_by(&candidates, chosen, first..candidates.len(), eligible);
    }
    // Stage 5: the model alone, without a network, as given and refined (no fits: a refined
    // model alone can win where the refined model with a network lost the race).
    if opts.members.is_none() {
        let w = candidates[chosen].settings.clone();
        let first = candidates.len();
        let alone = Settings {
            network: Network::Mlp,
            members: 0,
            rbf_start: None,
            mlp_share: None,
            ..w
        };
        evaluate(
            5,
            vary(&alone, &refines, |s, r| s.refine = r),
            &mut candidates,
        );
        chosen = better_by(&candidates, chosen, first..candidates.len(), judged);
    }
    let mut winner = candidates[chosen].settings.clone();
    // In a blend the MLPs' mean enters with the share s, its variance with s^2: at the shares
    // chosen (0.05-0.4 on real data) averaging 4 networks instead of 2 would lower the blend's
    // variance by at most s^2/4 of one network's, for twice the final fit. A mixed network
    // keeps the members cross-validation judged.
    if opts.members.is_none() && winner.members == ENSEMBLE_PROBE && winner.network != Network::Mix
    {
        winner.members = ENSEMBLE;
        // Told only when the ensemble is what was finally chosen (a later stage, the RBF
        // network's, can win over it).
        notes.push(format!(
            "{ENSEMBLE_PROBE} networks did not raise the cross-validated error over one: the \
             compensator averages {ENSEMBLE}"
        ));
    }
    if winner.members == 0 && opts.members != Some(0) {
        notes.push(
            "no network lowered the cross-validated error: the compensator is the model alone"
                .into(),
        );
    }
    if matches!(opts.refine, Refine::Params(_)) {
        notes.extend(refinement_notes(
            &tried,
            &refines,
            auto_compliance.as_deref(),
            winner.refine.as_deref(),
        ));
    }
    let rbf_hyper = if winner.has_rbf() {
        cv.hyper(winner.encoding, winner.rbf_start.unwrap_or(0))
            .ok()
    } else {
        None
    };
    // The chosen candidate's held-out error on every row (a refined model alone included:
    // a mis-measured row pulls the refinement too).
    let outliers = {
        let s = &candidates[chosen].settings;
        let r_idx = refines.iter().position(|r| r == &s.refine).unwrap_or(0);
        let round = rounds.load(Ordering::Relaxed);
        let mut held = vec![(f64::NAN, None); set.rows.len()];
        for (f, model) in refined[r_idx].iter().enumerate() {
            let model = model.as_ref().map_err(|e| Error::Invalid(e.to_string()))?;
            let c = cv.fit(f, s, model, round)?;
            let mut ws = Default::default();
            let errors = held_errors(&cv.held[f], |q| c.predict(q, &mut ws))?;
            let rows = (0..set.rows.len()).filter(|&i| fold_of[i] == f);
            for (i, e) in rows.zip(errors) {
                held[i] = (e.position_mm.unwrap_or(0.0), e.orientation_deg);
            }
        }
        outliers_of(set, &held, opts.outlier_k)
    };
    if !outliers.is_empty() {
        let rows: Vec<String> = outliers
            .iter()
            .map(|o| match o.line {
                0 => format!("row {}", o.row + 1),
                l => format!("line {l}"),
            })
            .collect();
        notes.push(format!(
            "{} training row(s) beyond {} robust sigmas of the cross-validated error ({}): {}",
            outliers.len(),
            opts.outlier_k,
            rows.join(", "),
            if opts.drop_outliers {
                "left out of the final fit (a mis-measured row, or a sharp feature of the robot \
                 one sample cannot tell; check them, or ask for them to be kept)"
            } else {
                "kept (a mis-measured row, or a sharp feature of the robot; check them, or \
                 ask for them to be dropped from the final fit)"
            }
        ));
    }
    Ok((
        winner,
        Some(Selection {
            folds: k,
            model: model.score(),
            candidates,
            chosen,
            notes,
            outliers,
            outlier_k: opts.outlier_k,
            rbf_hyper,
        }),
    ))
}

/// What the options leave open: the lists each stage of the search draws from, the
/// settings it starts from, and whether anything is open at all.
struct Space {
    refines: Vec<Option<String>>,
    /// The refinement with the joints' gravity compliances that cross-validation adds on its
    /// own (kept only by [`COMPLIANCE_MARGIN`]).
    auto_compliance: Option<String>,
    rbf_only: bool,
    mix_only: bool,
    forms: Vec<Form>,
    encodings: Vec<Encoding>,
    hiddens: Vec<usize>,
    penalties: Vec<f64>,
    base: Settings,
    /// The RBF network's search start tried by cross-validation.
    rbf_start: usize,
    try_rbf: bool,
    open: bool,
}

impl Space {
    fn of(robot: &Robot, opts: &CompensatorOptions, set: &MeasurementSet) -> Result<Space> {
        if let Some(s) = opts.mlp_share {
            check_share(s)?;
        }
        let (refines, auto_compliance) = match &opts.refine {
            Refine::Off if opts.compliance == Some(true) => {
                return Err(Error::Invalid(
                    "the joints' gravity compliances are refined with a selection: not without \
                     refinement"
                        .into(),
                ));
            }
            Refine::Off => (vec![None], None),
            Refine::Auto => refinements(AUTO_REFINE, false, opts.compliance),
            Refine::Params(p) => {
                // A selection that does not parse is refused before any fit, not reported
                // as a failed candidate.
                let names = names_compliance(robot, p)
                    .map_err(|e| Error::Invalid(format!("the refinement `{p}`: {e}")))?;
                refinements(p, names, opts.compliance)
            }
        };
        let rbf_only = opts.network == Some(Network::Rbf);
        let mix_only = opts.network == Some(Network::Mix);
        if (rbf_only || mix_only) && opts.form == Some(Form::Joint) {
            return Err(Error::Invalid(
                "an RBF network acts on the pose residual: it has no joint form".into(),
            ));
        }
        let forms: Vec<Form> = match opts.form {
            Some(f) => vec![f],
            None if rbf_only || mix_only => vec![Form::Pose],
            None => Form::ALL.to_vec(),
        };
        let encodings: Vec<Encoding> = opts.encoding.map_or(Encoding::ALL.to_vec(), |e| vec![e]);
        let fixed = |v: Option<usize>, all: &[usize]| v.map_or(all.to_vec(), |h| vec![h]);
        let hiddens: Vec<usize> = if rbf_only {
            vec![0]
        } else {
            fixed(opts.hidden, &HIDDEN)
        };
        let penalties: Vec<f64> = match opts.penalty {
            _ if rbf_only => vec![0.0],
            Some(p) => vec![p],
            None => PENALTIES.to_vec(),
        };
        let base = if rbf_only {
            Settings {
                network: Network::Rbf,
                form: Form::Pose,
                encoding: opts.encoding.unwrap_or(Encoding::Angles),
                hidden: 0,
                penalty: 0.0,
                members: opts.members.unwrap_or(1).min(1),
                rbf_start: opts.rbf_start,
                refine: refines[0].clone(),
                mlp_share: None,
            }
        } else {
            Settings {
                network: Network::Mlp,
                form: forms[0],
                encoding: opts.encoding.unwrap_or(Encoding::Gravity),
                hidden: opts.hidden.unwrap_or(HIDDEN[1]),
                penalty: opts.penalty.unwrap_or(PENALTIES[1]),
                members: opts.members.unwrap_or(1),
                rbf_start: opts.rbf_start,
                refine: refines[0].clone(),
                mlp_share: None,
            }
        };
        // The smooth start only, unless one is asked for: each start costs a search per
        // output, and with a kernel per output the smooth start's cross-validated error was
        // the lowest or within 0.8 % of it on the Series B pools tried (500 rows, seeds 0-2:
        // 0.286 against 0.296; 0.253 against 0.251; 0.244 against 0.265 mm).
        let rbf_start = opts.rbf_start.unwrap_or(0);
        // An RBF network (alone or with the MLPs) is tried where the network is left open
        // (and not fixed at none, `members` 0: the model alone), on the pose form, while its
        // kernel matrix stays small.
        let try_rbf = opts.network.is_none()
            && opts.members != Some(0)
            && forms.contains(&Form::Pose)
            && set.rows.len() <= RBF_MAX_ROWS;
        let open = refines.len() > 1
            || forms.len() > 1
            || encodings.len() > 1
            || hiddens.len() > 1
            || penalties.len() > 1
            || opts.members.is_none()
            || try_rbf
            || (mix_only && opts.mlp_share.is_none() && opts.members != Some(0));
        Ok(Space {
            refines,
            auto_compliance,
            rbf_only,
            mix_only,
            forms,
            encodings,
            hiddens,
            penalties,
            base,
            rbf_start,
            try_rbf,
            open,
        })
    }
}

/// The race that scores candidates: each is fitted on the race folds first and dropped there
/// when clearly worse than the best so far on the same folds ([`RACE_MARGIN`]); survivors
/// are fitted on the other folds.
struct Race<'a, 'c> {
    cv: &'a Cv<'c>,
    refines: &'a [Option<String>],
    /// Each refinement's model per fold.
    refined: &'a [Vec<Result<Robot>>],
    /// Folds.
    k: usize,
    /// Race folds.
    race: usize,
    /// Fold fits done (for progress).
    done: AtomicUsize,
    /// Evaluation rounds so far (warm starts come from earlier rounds).
    rounds: &'a AtomicUsize,
    progress: &'a (dyn Fn(usize, usize) + Sync),
}

impl Race<'_, '_> {
    /// Scores the settings of `list` not yet in `candidates` and appends them (stage
    /// `stage`).
    fn evaluate(&self, stage: usize, list: Vec<Settings>, candidates: &mut Vec<Candidate>) {
        let list: Vec<Settings> = list
            .into_iter()
            .filter(|s| !candidates.iter().any(|c| &c.settings == s))
            .collect();
        let total_now = self.done.load(Ordering::Relaxed) + list.len() * self.k;
        let round = self.rounds.fetch_add(1, Ordering::Relaxed);
        let run = |jobs: &[(usize, usize)]| {
            parallel_map(jobs.len(), |j| {
                let (c, f) = jobs[j];
                let s = &list[c];
                let r_idx = self
                    .refines
                    .iter()
                    .position(|r| r == &s.refine)
                    .unwrap_or(0);
                let out = match &self.refined[r_idx][f] {
                    Ok(m) => self.cv.run(f, s, m, round),
                    Err(e) => Err(Error::Invalid(e.to_string())),
                };
                (self.progress)(self.done.fetch_add(1, Ordering::Relaxed) + 1, total_now);
                out
            })
        };
        let fold_jobs = |cs: &[usize], fs: std::ops::Range<usize>| -> Vec<(usize, usize)> {
            cs.iter()
                .flat_map(|&c| fs.clone().map(move |f| (c, f)))
                .collect()
        };
        let all: Vec<usize> = (0..list.len()).collect();
        let first = fold_jobs(&all, 0..self.race);
        let mut results: HashMap<(usize, usize), Result<Vec<Sums>>> =
            first.iter().copied().zip(run(&first)).collect();
        // Over the race folds, at the candidate's best share.
        let race_sums = |c: usize, results: &HashMap<(usize, usize), Result<Vec<Sums>>>| {
            let mut t = Vec::new();
            for f in 0..self.race {
                add_shares(&mut t, results[&(c, f)].as_ref().ok()?);
            }
            Some(best_share(&t).1)
        };
        let rms = |t: &Sums| t.score().position_rms_mm;
        let reference = candidates
            .iter()
            .filter(|c| c.score.is_some())
            .filter_map(|c| c.race.as_ref().map(rms))
            .chain(
                all.iter()
                    .filter_map(|&c| race_sums(c, &results).as_ref().map(rms)),
            )
            .fold(f64::INFINITY, f64::min);
        let survivors: Vec<usize> = all
            .iter()
            .copied()
            .filter(|&c| {
                // The model alone fits nothing: nothing to save by dropping it.
                race_sums(c, &results).is_some_and(|t| {
                    list[c].members == 0 || rms(&t) <= reference * (1.0 + RACE_MARGIN)
                })
            })
            .collect();
        let rest = fold_jobs(&survivors, self.race..self.k);
        results.extend(rest.iter().copied().zip(run(&rest)));
        (self.progress)(total_now, total_now);
        self.done.store(total_now, Ordering::Relaxed);
        for (c, mut s) in list.into_iter().enumerate() {
            let raced = race_sums(c, &results);
            let mut total = Vec::new();
            let mut error = None;
            for f in 0..self.k {
                match results.get(&(c, f)) {
                    Some(Ok(x)) => add_shares(&mut total, x),
                    Some(Err(e)) => error = Some(e.to_string()),
                    None => {}
                }
            }
            let (share, total) = best_share(&total);
            if open_share(&s) && error.is_none() && total.rows > 0 {
                s.mlp_share = Some(SHARES[share]);
            }
            let kept = survivors.contains(&c);
            candidates.push(Candidate {
                stage,
                settings: s,
                score: (error.is_none() && kept).then(|| total.score()),
                pruned: (error.is_none() && !kept).then(|| total.score()),
                error,
                race: raced,
            });
        }
    }
}

/// Whether `s` is a mixed network whose MLP share cross-validation chooses (scored at each
/// of [`SHARES`]).
fn open_share(s: &Settings) -> bool {
    s.network == Network::Mix && s.mlp_share.is_none() && s.members > 0
}

/// `total += x`, share by share (`total` empty: `x`).
fn add_shares(total: &mut Vec<Sums>, x: &[Sums]) {
    if total.is_empty() {
        total.resize(x.len(), Sums::default());
    }
    total.iter_mut().zip(x).for_each(|(t, v)| t.add(*v));
}

/// The share of lowest summed squared position error (the first of equals) and its sums;
/// empty sums for none.
fn best_share(t: &[Sums]) -> (usize, Sums) {
    let mut best = 0;
    for (i, x) in t.iter().enumerate() {
        if x.pos < t[best].pos {
            best = i;
        }
    }
    (best, t.get(best).copied().unwrap_or_default())
}

/// The best-scored pose-form MLP candidate, the partner of a mixed candidate.
fn best_pose_mlp(candidates: &[Candidate]) -> Option<usize> {
    (0..candidates.len())
        .filter(|&i| {
            let c = &candidates[i].settings;
            c.form == Form::Pose && c.network == Network::Mlp && c.members > 0
        })
        .fold(None, |b: Option<usize>, i| {
            Some(b.map_or(i, |b| better(candidates, b, i..i + 1)))
        })
}

/// Cross-validated position RMS of candidate `i` (mm); infinite when it has no score.
fn cv_rms(candidates: &[Candidate], i: usize) -> f64 {
    candidates[i]
        .score
        .as_ref()
        .map_or(f64::INFINITY, |s| s.position_rms_mm)
}

/// Whether two refined models are the same kinematics: equal, or both rigid and equal
/// without their (zero) compliances.
fn same_model(a: &Result<Robot>, b: &Result<Robot>) -> bool {
    match (a, b) {
        (Ok(a), Ok(b)) if a.is_compliant() || b.is_compliant() => a == b,
        (Ok(a), Ok(b)) => a.rigid() == b.rigid(),
        _ => false,
    }
}

/// The best of `current` and the candidates in `new` (ties keep the earlier one).
fn better(candidates: &[Candidate], current: usize, new: std::ops::Range<usize>) -> usize {
    better_by(candidates, current, new, cv_rms)
}

/// [`better`] by the score `judged(candidates, index)` (lower is better).
fn better_by(
    candidates: &[Candidate],
    current: usize,
    new: std::ops::Range<usize>,
    judged: impl Fn(&[Candidate], usize) -> f64,
) -> usize {
    new.fold(current, |b, i| {
        if judged(candidates, i) < judged(candidates, b) {
            i
        } else {
            b
        }
    })
}

/// `x` to 3 significant digits (penalties read back as typed: 0.333, not 0.3333333333333333).
fn significant3(x: f64) -> f64 {
    if x == 0.0 || !x.is_finite() {
        return x;
    }
    let scale = 10f64.powi(2 - x.abs().log10().floor() as i32);
    (x * scale).round() / scale
}

fn failed(candidates: &[Candidate]) -> Error {
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

/// `base` with one setting changed to each of `values`.
fn vary<T: Clone>(base: &Settings, values: &[T], set: impl Fn(&mut Settings, T)) -> Vec<Settings> {
    values
        .iter()
        .map(|v| {
            let mut s = base.clone();
            set(&mut s, v.clone());
            s
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn penalties_keep_three_significant_digits() {
        assert_eq!(significant3(1.0 / 3.0), 0.333);
        assert_eq!(significant3(0.1 * 3.0), 0.3);
        assert_eq!(significant3(30.000000000000004), 30.0);
        assert_eq!(budget_epochs(FIT_WORK, 2000, 50, 60), 50);
        assert_eq!(budget_epochs(FIT_WORK, 150, 50, 60), 60);
    }

    #[test]
    fn refinements_add_the_compliances_as_asked() {
        let robot = crate::model::read_robot(
            std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("datasets/robots/ur10.toml"),
        )
        .unwrap();
        let refinements =
            |spec: &str, c| refinements(spec, names_compliance(&robot, spec).unwrap(), c);
        let s = |v: &[&str]| -> Vec<Option<String>> {
            std::iter::once(None)
                .chain(v.iter().map(|x| Some(x.to_string())))
                .collect()
        };
        let with = Some("full,compliance".to_string());
        assert_eq!(
            refinements("full", None),
            (s(&["full", "full,compliance"]), with.clone())
        );
        assert_eq!(refinements("full", Some(false)), (s(&["full"]), None));
        assert_eq!(
            refinements("full", Some(true)),
            (s(&["full,compliance"]), None)
        );
        // Named compliances are refined as named, whatever the flag.
        for c in [None, Some(true), Some(false)] {
            assert_eq!(refinements("full,k2.mx3", c), (s(&["full,k2.mx3"]), None));
        }
        assert!(!names_compliance(&robot, "offsets").unwrap());
        assert!(names_compliance(&robot, "offsets,compliance").unwrap());
        assert!(names_compliance(&robot, "no_such_parameter").is_err());
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
        let n = one(refinement_notes(&both, &k(&[]), added, None));
        assert!(n.contains("`full` changes nothing"), "{n}");
        // The geometry alone changed nothing; the compliances did, and lost by the margin.
        let n = refinement_notes(&both, &k(&["full,compliance"]), added, None);
        assert_eq!(n.len(), 2, "{n:?}");
        assert!(n[0].contains("`full` alone changes nothing"), "{n:?}");
        assert!(n[1].contains("not by 2 % or more"), "{n:?}");
        // ... or won.
        let n = refinement_notes(&both, &k(&["full,compliance"]), added, added);
        assert_eq!(n.len(), 2, "{n:?}");
        assert!(
            n[1].contains("added the joints' gravity compliances"),
            "{n:?}"
        );
        // Both changed it; the geometry was kept: nothing to tell.
        let n = refinement_notes(&both, &k(&["full", "full,compliance"]), added, Some("full"));
        assert!(n.is_empty(), "{n:?}");
        // A fixed selection that did not lower the error.
        let n = one(refinement_notes(
            &t(&["offsets"]),
            &k(&["offsets"]),
            None,
            None,
        ));
        assert!(
            n.contains("`offsets` did not lower") && !n.contains("2 %"),
            "{n}"
        );
        let n = one(refinement_notes(&t(&["offsets"]), &k(&[]), None, None));
        assert!(n.contains("`offsets` changes nothing"), "{n}");
    }
}
