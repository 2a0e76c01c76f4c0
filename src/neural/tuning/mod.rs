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
//! encodings; (2) hidden units, then a finer penalty step; (3) the ensemble, kept where its
//! cross-validated error is lower or within [`ENSEMBLE_TIE`] above, then the RBF network from
//! its search start, alone and
//! blended with the best pose-form MLPs at the MLPs' share of lowest cross-validated error
//! among [`SHARES`] (its hyperparameters searched once on the training rows, at most
//! [`super::rbf::HYPER_BLOCKS`] blocks of [`super::rbf::HYPER_ROWS`] of them, beside stages 2
//! and 3; the folds fit only its
//! weights); (4) refinement (for a blend, judged first by the RBF network alone fitted on
//! the race folds only, a proxy never chosen, and the best refinement then tried with the
//! blend), of the leader and, where it could carry it past the leader, of the best of the
//! other family (MLPs alone, or networks with an RBF network, alone or blended); (5) no
//! network at all, kept unless the network beats it by [`NETWORK_MARGIN`]
//! and, row by row, with a paired z of [`NETWORK_Z`]; a network with an RBF network that
//! passes is tested again on held-out rows no hyperparameter search saw, which decides (where
//! it fails and the network is not fixed, the best network without one is tested instead).
//! Candidates are fitted
//! with a phase 2 of fixed work ([`CV_WORK`]) and without phase 1, and raced: each is scored
//! on [`RACE_FOLDS`] folds first and dropped there when it is more than [`RACE_MARGIN`] worse
//! than the best so far on the same folds. The chosen settings are then fitted in full.

mod cv;
mod fold_plan;
mod notes;
mod race;
mod rank;
mod rows;
mod shares;
mod space;
mod stages;

use super::parallel::parallel_map;
use super::selection::Sums;
pub use super::selection::{Candidate, NetworkTest, Outlier, Score, Selection, Unseen, UnseenTest};
pub use super::settings::OUTLIER_K;
use super::settings::{CompensatorOptions, Network, Refine, Settings};
use super::train::MIN_ROWS;
use crate::data::MeasurementSet;
use crate::error::{Error, Result};
use crate::model::Robot;
use cv::Cv;
use fold_plan::{Folds, fold_plan, more_folds_help, network_rows};
pub use fold_plan::{rows_needed, too_few_rows};
pub use notes::outlier_note;
use notes::{
    alone_model, below_or_above, failed, network_note, paired_rows, raw_ratio, refinement_notes,
    refinement_test_note, with_margin,
};
use race::Race;
use rows::sums;
pub use rows::{folds, outliers_of, subset};
use space::Space;
pub use space::names_compliance;
use stages::Search;
use std::collections::HashMap;
use std::sync::Mutex;
use std::sync::atomic::AtomicUsize;

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

/// Relative cross-validated error by which the best network must beat the best model alone
/// (as given or refined) to be kept: the network is the best of some twenty candidates, a
/// choice that is optimistic by itself, and a network that learns nothing but the rows' noise
/// can still come out a fraction of a percent ahead; kept, it adds that noise to every
/// prediction (on a simulated SCARA whose geometry `full` identifies completely, a blend of
/// MLPs and the RBF network 0.4 % ahead of the refined model in cross-validation raised the
/// error against the truth by 11 % RMS and the max by 44 %, where the refined model alone
/// halves both). Where a robot has errors a network can learn it
/// wins by far more (30-60 % on real UR10 data, 17 % over the compliant model alone on the
/// simulated non-geometric robot). The margin alone does not catch every such network (on
/// Case D, `full` identified, a blend 2.6 % ahead was worse against the truth than the
/// refined model alone, 0.0134 against 0.0099 mm): [`NETWORK_Z`] asks for more where the
/// rows are few. Both sides are judged as every
/// candidate is: a refinement with the compliances cross-validation adds on its own carries
/// [`COMPLIANCE_MARGIN`] as well.
pub const NETWORK_MARGIN: f64 = 0.02;

/// Share of the chosen candidate's cross-validated squared position error above which one
/// listed outlier's own held-out error makes the settings be chosen again without the
/// listed rows ([`CompensatorOptions::reselect`]): 1 - (1 - [`NETWORK_MARGIN`])^2, the share
/// whose removal alone moves a cross-validated RMS by the margin that decides between a
/// network and the model alone. A gross row makes it in a set of any size (one 5 mm row,
/// 54 % of 100 Series A rows'); a heavy tail of rows just beyond the cut of 5 robust sigmas,
/// each under it, does not (Series A's pools of 2000: chosen again without such rows,
/// they held out 1.3-1.7 % worse, in twice the time).
pub const RESELECT_SHARE: f64 = NETWORK_MARGIN * (2.0 - NETWORK_MARGIN);

/// Paired z (row by row over every held-out row, [`NetworkTest::z`]) by which the network
/// chosen in stages 1-4 must be below the best model alone to be kept, besides
/// [`NETWORK_MARGIN`]: a lower RMS over a few hundred rows can be a few rows' noise, and the
/// network is the best of some twenty candidates, which makes its score optimistic. The level
/// is a rule, not a probability: the candidates are not independent (-2.8 would be the
/// one-sided 5 % level corrected for twenty that were), rows of one fold share a fit, and
/// every training row enters, outliers included. Rows that repeat one arm configuration are
/// averaged into one value first (`rank::paired_z`): measuring every pose five times, or
/// one pose fifty times, must not make a network look surer. It was set between what was
/// seen on our
/// simulations, nearer the side to reject: on ten drawn robots (150 training rows,
/// `tests/simulated_robots.rs`) the networks that lowered the mean error against the truth
/// by 19-47 % had z from -9.1 to -3.3; the three that were 2-6 % ahead of the refined model
/// alone in cross-validation but 3-10 % worse against the truth had z from -2.4 to -1.1. On
/// Case D, `full` identified, a blend 2.6 % ahead (z -2.1) was worse against the truth
/// (0.0134 against 0.0099 mm). On the real UR10 the networks had z about -21 (Series B,
/// pools of 1000) and -5.9 to -8.7 (pools of 150); on the simulated non-geometric robot -5.8
/// to -7.6.
pub const NETWORK_Z: f64 = 2.5;

/// Ratio of a network's cross-validated RMS to the model alone's from which a network the
/// options fix gets a warning whatever its paired z ([`NETWORK_Z`]): a quarter above is no
/// noise, and a few rows of huge errors (which no paired z weighs by their size) are what a
/// user would meet on new rows.
pub const FIXED_NETWORK_WORSE: f64 = 1.25;

/// Relative cross-validated error by which a refinement cross-validation ranks first must beat
/// the best candidate without it to be kept, as [`NETWORK_MARGIN`] for a network: a refinement
/// re-estimates tens of parameters on the training rows, which act on every pose, and is the
/// best of several candidates. Where the data determine the parameters it wins by far more
/// (the refined model alone 15-80 % ahead on the simulated robots with compliance or
/// geometric errors the identification missed). Both sides are judged as every candidate
/// is: a refinement with the compliances that cross-validation adds on its own carries
/// [`COMPLIANCE_MARGIN`] too (about 4 % in all).
pub const REFINEMENT_MARGIN: f64 = 0.02;

/// Paired z by which a refinement must be below the best candidate without it, besides
/// [`REFINEMENT_MARGIN`], as [`NETWORK_Z`] for a network: on 30 rows of the real UR10 a
/// refinement 3.8 % ahead in cross-validation raised the held-out error from 0.4557 to 0.8379
/// mm RMS.
pub const REFINEMENT_Z: f64 = 2.5;

/// What [`select_settings`] says beside a selection: notes on a test that could not be had,
/// and warnings on a choice made without one.
#[derive(Debug, Clone, Default)]
pub struct Remarks {
    /// What the user should know.
    pub notes: Vec<String>,
    /// What the user must know before using the compensator.
    pub warnings: Vec<String>,
}

/// The settings to fit: `opts`'s fixed choices, the rest chosen by cross-validation on `set`
/// (None when nothing was left to choose), and remarks. Where the rows are too few to
/// cross-validate a network ([`too_few_rows`]) and the options leave it open, the model alone
/// as given, with a warning that says why.
pub fn select_settings(
    robot: &Robot,
    set: &MeasurementSet,
    opts: &CompensatorOptions,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<(Settings, Option<Selection>, Remarks)> {
    let space = Space::of(robot, opts)?;
    // Nothing to choose (a fixed mix, its share given, keeps, output by output, the start of
    // highest likelihood): the settings are the options'. A network among them is still
    // cross-validated against the model alone where asked (`test_fixed`), for the user to
    // know; those figures choose nothing.
    let fixed = (!space.open).then(|| {
        let network = opts.network.unwrap_or(Network::Mlp);
        let mlp_share = opts.mlp_share.filter(|_| network == Network::Mix);
        Settings {
            network,
            mlp_share,
            ..space.base.clone()
        }
    });
    match fixed {
        Some(settings) if !(opts.test_fixed && settings.has_network()) => {
            Ok((settings, None, Remarks::default()))
        }
        // The test informs only: where it cannot be had (fewer than 2 folds, a fold too small
        // to fit), the fixed fit stands without it, as it did before the test, and says so.
        Some(settings) => Ok(
            match cross_validate(robot, set, opts, progress, space, Some(settings.clone())) {
                Ok((settings, selection)) => (settings, selection, Remarks::default()),
                Err(e) => (
                    settings,
                    None,
                    Remarks {
                        notes: vec![format!(
                            "the fixed network could not be held against the model alone by \
                             cross-validation ({e}): it is fitted as fixed, untested"
                        )],
                        warnings: Vec::new(),
                    },
                ),
            },
        ),
        // Too few rows for any network the search would try: the model as given, which
        // needs no rows, where the options allow it (before, 2-4 rows failed with every
        // candidate's error where 6 gave the model alone).
        None if opts.members.is_none_or(|m| m == 0)
            && let Some(why) = too_few_rows(robot, set, opts) =>
        {
            let alone = Settings {
                refine: None,
                ..stages::model_alone_of(&space.base)
            };
            // Rows enough for a network, of too few configurations to fold, can still fit
            // one untested with every choice fixed.
            let fix = match (network_rows(opts), opts.folds) {
                // Fewer folds asked for than rows allow: more leave more rows to train on,
                // where one fold per configuration would leave enough.
                (Some(need), Some(f)) if more_folds_help(robot, set, f, need) => {
                    " (or more --folds)"
                }
                (Some(need), _) if set.rows.len() >= need => {
                    " (or fix every choice to fit a network untested)"
                }
                _ => "",
            };
            Ok((
                alone,
                None,
                Remarks {
                    notes: Vec::new(),
                    warnings: vec![format!(
                        "{why}: the compensator is the model alone (as given, nothing \
                         refined); measure more configurations{fix}"
                    )],
                },
            ))
        }
        None => {
            if let Some(why) = too_few_rows(robot, set, opts) {
                return Err(Error::Invalid(format!(
                    "{why}, and the members are fixed at {} network(s): leave them open \
                     (the model alone), or fix every choice (--network, --form, --encoding, \
                     --hidden, --penalty, --refine) to fit a network on at least {} rows \
                     untested",
                    opts.members.unwrap_or(0),
                    network_rows(opts).unwrap_or(MIN_ROWS)
                )));
            }
            cross_validate(robot, set, opts, progress, space, None)
                .map(|(settings, selection)| (settings, selection, Remarks::default()))
        }
    }
}

/// [`select_settings`] where cross-validation runs: the choice among what `space` leaves
/// open, or, with `fixed` settings, their test against the model alone (the settings stay
/// `fixed`, no outlier is listed, no hyperparameters are handed on).
fn cross_validate(
    robot: &Robot,
    set: &MeasurementSet,
    opts: &CompensatorOptions,
    progress: &(dyn Fn(usize, usize) + Sync),
    mut space: Space,
    fixed: Option<Settings>,
) -> Result<(Settings, Option<Selection>)> {
    let Folds {
        groups,
        distinct,
        want,
        fold_of,
        k,
    } = fold_plan(robot, set, opts);
    if k < 2 || want < 2 {
        return Err(Error::Invalid(format!(
            "choosing the settings by cross-validation needs at least 2 folds of distinct \
             configurations (asked for {want}, the rows' {distinct} distinct configurations \
             give {k}); fix the network, form, encoding, hidden units, penalty, ensemble size \
             and refinement instead"
        )));
    }
    let cv = Cv {
        robot,
        train: (0..k).map(|f| subset(set, |i| fold_of[i] != f)).collect(),
        held: (0..k).map(|f| subset(set, |i| fold_of[i] == f)).collect(),
        held_index: (0..k)
            .map(|f| (0..set.rows.len()).filter(|&i| fold_of[i] == f).collect())
            .collect(),
        groups,
        opts,
        nets: Mutex::new(HashMap::new()),
        warm: Mutex::new(HashMap::new()),
        fitted: Mutex::new(HashMap::new()),
        set,
        hypers: Mutex::new(HashMap::new()),
        fold_hypers: Mutex::new(HashMap::new()),
        rbf_fits: Mutex::new(HashMap::new()),
    };
    let rounds = AtomicUsize::new(0);
    let mut model = Sums::default();
    for f in 0..k {
        model.add(sums(&cv.held[f], |q| {
            crate::kinematics::tool_pose(robot, q)
        })?);
    }
    let tried: Vec<String> = space.refines.iter().flatten().cloned().collect();
    // Stages 1 to 3 fit every candidate with the first refinement's models; the other
    // refinements' (stage 4 on) are computed beside them, in one thread: the folds' fits
    // leave a core idle at the end of most rounds (five folds on two cores), and the
    // refinements were the first 50 ms of a 150-pose training with nothing beside them.
    let first = space.refines[0].clone();
    let first_models = parallel_map(k, |f| cv.model(f, &first));
    let mut notes = Vec::new();
    let with_rbf = space.try_rbf || space.mix_only;
    // Each candidate is first scored on the race folds; one that is already clearly worse
    // there than the best so far on the same folds is dropped before the other folds.
    let mut race = Race {
        cv: &cv,
        refined: vec![(first, first_models)],
        k,
        race: if k > RACE_FOLDS { RACE_FOLDS } else { k },
        done: AtomicUsize::new(0),
        rounds: &rounds,
        progress,
    };
    let (early, others) = std::thread::scope(|scope| {
        let others = (space.refines.len() > 1).then(|| {
            let later = &space.refines[1..];
            let cv = &cv;
            scope.spawn(move || {
                (later.iter())
                    .map(|spec| (spec.clone(), (0..k).map(|f| cv.model(f, spec)).collect()))
                    .collect::<Vec<_>>()
            })
        });
        let mut search = Search::new(&race, &space, opts);
        let early = stages_1_to_3(&mut search, &mut notes, with_rbf, distinct, k);
        // A panic there is a defect: it goes on as one in the refinements' own fits would
        // have, not as refinements silently left out.
        let others = others.map(|h| h.join().unwrap_or_else(|e| std::panic::resume_unwind(e)));
        let found = search.found();
        (early.map(|()| found), others)
    });
    let found = early?;
    race.refined.extend(others.unwrap_or_default());
    distinct_refinements(&mut race.refined);
    space.refines = race.refined.iter().map(|(r, _)| r.clone()).collect();
    let mut search = Search::resume(&race, &space, opts, found);
    if space.refines.len() > 1 {
        search.refinement();
    }
    search.model_alone(opts.members.is_some());
    let Search {
        candidates,
        chosen,
        network_test,
        chosen_rows,
        rbf_network_test,
        unseen_error,
        refinement_tests,
        fixed_network_test,
        ..
    } = search;
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
    notes.extend(
        refinement_tests
            .iter()
            .map(|t| refinement_test_note(t, &candidates)),
    );
    if let Some(e) = &unseen_error {
        notes.push(format!(
            "the network with an RBF network could not be tested on rows no hyperparameter \
             search saw ({e}): its cross-validated figures decide"
        ));
    }
    // Where the network with an RBF network failed on unseen rows and another was held
    // against the model alone instead, both tests are told, in that order.
    const OTHER: &str = "the best network without an RBF network";
    if let Some(t) = &rbf_network_test {
        let then = format!("{OTHER} is held against the model alone instead");
        notes.push(network_note(t, &candidates, "the network", &then));
    }
    if let Some(t) = &network_test {
        let network = if rbf_network_test.is_some() {
            OTHER
        } else {
            "the network"
        };
        notes.push(network_note(
            t,
            &candidates,
            network,
            "the compensator is the model alone",
        ));
    } else if winner.members == 0 && opts.members != Some(0) {
        notes.push(format!(
            "no network's cross-validated error was {:.0} % or more below the model's alone: \
             the compensator is the model alone",
            NETWORK_MARGIN * 100.0
        ));
    }
    // A network the options fix is kept. Where the model alone is significantly better on
    // the rows it did not see (the network test's level, the other way round), the user is
    // warned; where the network is only not significantly better, told.
    let mut warnings = Vec::new();
    if let Some(t) = fixed_network_test.as_ref().filter(|t| !t.kept) {
        let model = alone_model(&candidates[t.alone].settings);
        let (raw, judged) = raw_ratio(t, &candidates);
        let figures = format!(
            "the network's cross-validated error is {} the model alone's ({model}{}), {}",
            below_or_above(raw),
            with_margin(judged(t.ratio)),
            paired_rows(t, NETWORK_Z)
        );
        // A few rows of a network's huge errors keep the paired z low (a reviewer's fixed
        // network at 55 times the model's RMS had z 1.4, and missed held-out rows by 65 mm):
        // so far above, the RMS alone warns.
        if t.ratio > 1.0 && (t.z >= NETWORK_Z || t.z.is_nan() || raw >= FIXED_NETWORK_WORSE) {
            warnings.push(format!(
                "{figures}: the compensator keeps the network as --members fixes it, but the \
                 model alone is more accurate on rows it did not see (leave --members open and \
                 train drops a network that does not help)"
            ));
        } else {
            notes.push(format!(
                "{figures}: not {:.0} % or more below with a paired z of -{NETWORK_Z} or lower, \
                 which a network left open must reach; kept as --members fixes it",
                NETWORK_MARGIN * 100.0
            ));
        }
    }
    // Where a refinement's test rejected it, its note says why; "did not lower the
    // cross-validated error" would contradict it.
    let rejected = refinement_tests.iter().any(|t| !t.kept);
    if matches!(opts.refine, Refine::Params(_)) && !(rejected && winner.refine.is_none()) {
        let scored = candidates
            .iter()
            .any(|c| c.settings.refine.is_some() && c.error.is_none());
        notes.extend(refinement_notes(
            &tried,
            &space.refines,
            space.auto_compliance.as_deref(),
            scored,
            winner.refine.as_deref(),
        ));
    }
    let rbf_hyper = if winner.has_rbf() {
        cv.hyper(winner.encoding, winner.rbf_start).ok()
    } else {
        None
    };
    // The chosen candidate's held-out error on every row (a refined model alone included:
    // a mis-measured row pulls the refinement too).
    let outliers = if fixed.is_some() {
        Vec::new()
    } else {
        let mut held = vec![(f64::NAN, None); set.rows.len()];
        // Stage 5 has them where it held a network against the model alone.
        let per_fold = match chosen_rows {
            Some(rows) => rows,
            None => race.held_rows(&candidates[chosen].settings)?,
        };
        for (index, errors) in cv.held_index.iter().zip(per_fold) {
            for (&i, e) in index.iter().zip(errors) {
                held[i] = (e.position_mm.unwrap_or(0.0), e.orientation_deg);
            }
        }
        outliers_of(set, &held, &cv.groups, opts.outlier_k)
    };
    // With every choice fixed the search only informs: the fit is the options' settings,
    // on every row, its RBF network taking the hyperparameters its test searched on them
    // (the same search, cached: searched again it doubled a fixed network's training time),
    // as a chosen one does.
    let (winner, rbf_hyper) = match fixed {
        Some(settings) => {
            let searched = (settings.has_rbf() && settings.refine.is_none())
                .then(|| cv.hyper(settings.encoding, settings.rbf_start).ok())
                .flatten();
            (settings, searched)
        }
        None => (winner, rbf_hyper),
    };
    Ok((
        winner,
        Some(Selection {
            folds: k,
            model: model.score(),
            candidates,
            chosen,
            notes,
            outliers,
            outliers_left_out: false,
            first_outliers: Vec::new(),
            outlier_k: opts.outlier_k,
            rbf_hyper,
            network_test,
            rbf_network_test,
            refinement_tests,
            fixed_network_test,
            warnings,
        }),
    ))
}

/// Stages 1 to 3 of the search (the forms, the MLPs, the RBF network), each candidate fitted
/// with the first refinement; notes on what the options asked for that could not be had go
/// to `notes`. An error where every candidate of stage 1 failed, or where the network is
/// fixed to a blend and no pose-form MLP was fitted to blend ([`Search::rbf`]).
fn stages_1_to_3(
    search: &mut Search,
    notes: &mut Vec<String>,
    with_rbf: bool,
    distinct: usize,
    k: usize,
) -> Result<()> {
    let (space, opts) = (search.space, search.opts);
    search.first();
    if search.candidates.iter().all(|c| c.score.is_none()) {
        return Err(failed(&search.candidates));
    }
    // From here on some candidate has a score: the best always exists.
    if let Some(asked) = opts.folds
        && k < asked
    {
        notes.push(format!(
            "{asked} folds asked for, but the rows hold {distinct} distinct configurations: \
             {k} folds"
        ));
    }
    search.chosen = search.best();
    if opts.mlp_share.is_some() && !with_rbf {
        notes.push(
            "an MLP share was given, but no blend of MLPs and the RBF network was tried (it \
             needs the pose form and MLPs)"
                .to_string(),
        );
    }
    if !space.rbf_only {
        search.mlps(with_rbf);
    }
    if with_rbf {
        search.rbf()?;
    }
    Ok(())
}

/// Takes out of `refined` (each refinement with its models, one per fold) every refinement
/// whose models are an earlier one's on every fold (the compliances all screened out): it is
/// the same candidate, taken out before anything is fitted with it.
fn distinct_refinements(refined: &mut Vec<(Option<String>, Vec<Result<Robot>>)>) {
    let mut kept: Vec<(Option<String>, Vec<Result<Robot>>)> = Vec::with_capacity(refined.len());
    for (spec, models) in refined.drain(..) {
        let repeated = (kept.iter())
            .any(|(_, earlier)| earlier.iter().zip(&models).all(|(a, b)| same_model(a, b)));
        if !repeated {
            kept.push((spec, models));
        }
    }
    *refined = kept;
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
