//! The solves behind [`IkSolver::nearest`], [`IkSolver::ranked`] and [`IkSolver::all`]
//! for a model without a closed form of its own: from the seed and the closed-form starts,
//! from reflections across folds, from solutions moved within the limits and, as a last
//! resort, from starts spread over the joints' turns (steps 3-6 of [`super`]).

use super::track::PULLS;
use super::{IkFailure, IkSolver, IkStart};
use crate::kinematics::Pose;
use crate::kinematics::fold::across_fold;
use crate::kinematics::ik_closed::Branch;
use crate::kinematics::ik_numeric::{IkSolution, ToolModel};
use crate::kinematics::spread::around;
use crate::model::joint_distance;

/// Two solutions closer than this in every joint (rad or mm) are one. Next to a fold a solve
/// that reaches the pose to 1e-9 mm can still end up to about 1e-6 rad along the direction
/// in which the pose barely moves (the error is quadratic there), so one configuration solved
/// from several starts came back as several solutions at 1e-7 (a reviewer: up to 8 rows for a
/// UR10 pose on its calibrated elbow's fold); no encoder tells apart configurations 1e-6 rad
/// apart (the closed form's [`super::super::ik_closed`] roots are merged at the same distance).
const SAME_SOLUTION: f64 = 1e-6;

/// Whether joints `a` and `b` (rad, mm) are one solution: within [`SAME_SOLUTION`] in every
/// joint.
fn same_solution(a: &[f64], b: &[f64]) -> bool {
    a.iter().zip(b).all(|(x, y)| (x - y).abs() < SAME_SOLUTION)
}

/// Starts of the last-resort search ([`IkSolver`]'s `refined`), spread over the turn around
/// the reference ([`around`]): where no start a nominal's closed form gives converges within
/// the limits, where no branch of the nominal reaches the pose, or where two branches' starts
/// led to one solution. Next to a singularity a calibrated arm's solutions can lie where no branch's
/// start leads (next to the shoulder singularity of a UR10 with four times a real
/// calibration's deviations, 20 of 3000 poses had no solution without it, and 172 did not
/// list their own configuration; 95 with it). Where a start converges one time in three (as
/// there), 16 all fail one time in 650. Only such poses pay for it, each solve at most
/// [`SEARCH_ITERATIONS`] iterations: 1.7 % of random poses of a calibrated UR10, but 27 % of
/// poses made by the nominal with its wrist straight (q5 = 0: its two wrist flips give one
/// start, and the arm's flip is found in one search of nine, 0.45 ms each); a pose no start
/// reaches (inside the shoulder's cylinder) costs 16 short solves, about 1 ms on a rigid
/// model. A pose whose every solution leaves the limits pays it too (after the solves from
/// those solutions moved within the limits, [`LIMIT_INSET`]): on a calibrated FANUC drawn 15 %
/// of each range beyond its limits, 2940 such poses of 5000 took 1.7 s instead of 0.5 s.
const SEARCH_STARTS: usize = 16;

/// Starts of the search where no closed form gives any: around the middle of the ranges,
/// the only starts without a seed; around the seed, where its solve found no solution within
/// the limits. On 100 random poses of a calibrated UR10 (the tests') without a seed, the
/// solution nearest the middle was as near as the one the nominal's closed-form starts give
/// for 100 with 64 starts, 96 with 32, 86 with 16 ([`SEARCH_STARTS`]).
const SPREAD_ONLY_STARTS: usize = 64;

/// Iterations of a search solve at most: from the spread starts, solves that converged took 8
/// to 34 iterations but for 2 of 74 (72 and 74), on the UR10 with four times a calibration's
/// deviations next to its shoulder singularity; a start that needs more is one of many.
const SEARCH_ITERATIONS: usize = 40;

/// How far inside its limits (a fraction of its range) a joint of a solution outside them is
/// moved to start a solve that should end within them ([`Robot::moved_within_limits`]): next
/// to a straight elbow a calibrated arm's two elbow solutions can lie a few degrees apart, one
/// just inside a limit and the other just outside it, and every closed-form start led to the
/// one outside. On a UR10 with four times a calibration's deviations, its elbow within [0,
/// 160] deg, 23 of 20,000 configurations drawn within the limits read outside-limits before;
/// the spread search alone solved 19 of them, these starts alone 20, both all 23.
///
/// [`Robot::moved_within_limits`]: crate::model::Robot::moved_within_limits
const LIMIT_INSET: f64 = 0.01;

/// The solutions a run of solves found, and the failure to report where there are none.
struct Found {
    /// Distinct solutions within the limits.
    sols: Vec<IkSolution>,
    /// The joint distance from the reference of the nearest solution outside the limits
    /// (infinite where there is none).
    nearest_outside: f64,
    /// The failure where `sols` is empty.
    failure: IkFailure,
    /// Distinct solutions outside the limits (joints, rad or mm).
    outside: Vec<Vec<f64>>,
}

impl<M: ToolModel> IkSolver<M> {
    /// Every distinct converged solution within the limits, one numerical solve from the
    /// seed (when given) and from each closed-form start, and from each solution's reflection
    /// across a fold near it ([`across_fold`]); where every solution found leaves
    /// the limits, from each moved within them ([`LIMIT_INSET`]); where a nominal's closed
    /// form gave starts and none converged within the limits, where no branch of it reaches
    /// the pose, or where the solves found fewer distinct solutions than it has branches
    /// there, from [`SEARCH_STARTS`] starts spread over the turn around the reference too.
    /// Without a closed form's starts, where there is no seed or its solve found no solution
    /// within the limits, from [`SPREAD_ONLY_STARTS`] such starts (before the reflections and
    /// the moves within the limits). The failure when none.
    pub(super) fn refined(
        &mut self,
        target: &Pose,
        seed: Option<&[f64]>,
        reference: &[f64],
    ) -> std::result::Result<Vec<IkSolution>, IkFailure> {
        let mut starts: Vec<Vec<f64>> = seed.map(<[f64]>::to_vec).into_iter().collect();
        let closed = self.starts(target, reference, &[]);
        let present: Vec<Branch> = closed.iter().map(|(_, _, b, _)| *b).collect();
        let carried = self.carried(target, closed);
        starts.extend(carried);
        // A calibrated arm a little longer (or shorter) than the nominal reaches poses just
        // beyond the nominal's reach, on some branches or on all: those branches start at
        // their nearest to the pose, carried onto the model's solution where there is one.
        let beyond = self.beyond_starts(target, reference, &present);
        let none_yet = beyond.is_empty();
        starts.extend(beyond);
        let nominal = matches!(self.start, IkStart::Nominal(_));
        // Where no branch reaches the pose, the closed form's solutions of the same pose moved
        // a little toward (or away from) the base start numerical solves too: the pull that
        // gave them, if one did. Where none did either, the pose lies past the nominal's
        // reach on every branch, and a seed's solve that does not converge (the only other
        // start) says no more than that.
        let mut past_reach = false;
        let pulled = if present.is_empty() && nominal {
            let found = self.pulled_starts(target, reference);
            past_reach = found.is_none() && none_yet;
            found.map(|(pull, joints)| {
                starts.extend(joints);
                pull
            })
        } else {
            None
        };
        let mut found = Found {
            sols: Vec::new(),
            nearest_outside: f64::INFINITY,
            failure: self.no_start(),
            outside: Vec::new(),
        };
        let all = self.opts.max_iterations;
        for q0 in &starts {
            self.solve_start(target, q0, reference, all, &mut found);
        }
        // No closed form gave a start: where there is no seed, or its solve found no solution
        // within the limits, starts spread over the joints' turns around the reference (step
        // 6, more of them: they are the only ones), before the reflections and the moves
        // within the limits below, which start from what they find too.
        let spread = !nominal && found.sols.is_empty();
        if spread {
            // Without a seed, a search solve's failure is the only one.
            let keep = seed.is_some();
            self.search(target, reference, SPREAD_ONLY_STARTS, keep, &mut found);
        }
        // Fewer distinct solutions than the nominal has branches at the pose: two branches'
        // starts led to one solution, as where a calibrated arm's solutions crowd next to a
        // singularity. Counted before the reflections' and the moved starts' solutions, which
        // need not be those the search would find (counted after, a UR10 with four times a
        // calibration's deviations lost 2 solutions of a pose next to its shoulder).
        let crowded = found.sols.len() + found.outside.len() < present.len();
        // Next to a fold (a straight elbow, the shoulder's cylinder) the pose's other solution
        // there lies across it, where the nominal's starts may not lead: each solution's
        // reflection across a fold within reach starts a solve.
        let mut solved: Vec<Vec<f64>> = found.sols.iter().map(|s| s.q.clone()).collect();
        solved.extend(found.outside.iter().cloned());
        for q in solved {
            if let Some(q0) = self.reflected(&q) {
                self.solve_start(target, &q0, reference, SEARCH_ITERATIONS, &mut found);
            }
        }
        // Every solution found leaves the limits: each moved within them starts a solve (next
        // to a singularity the arm's solution within the limits can lie a degree from one
        // outside them that every start led to).
        if found.sols.is_empty() && !found.outside.is_empty() {
            for q in std::mem::take(&mut found.outside) {
                let q0 = self.model.robot().moved_within_limits(&q, LIMIT_INSET);
                found.outside.push(q);
                self.solve_start(target, &q0, reference, all, &mut found);
            }
        }
        let searched = nominal && (crowded || present.is_empty() || found.sols.is_empty());
        if searched {
            self.search(target, reference, SEARCH_STARTS, true, &mut found);
        }
        let search_note = if spread && seed.is_none() {
            format!(
                " (from each of {SPREAD_ONLY_STARTS} starts spread over the joints' turns \
                 around the middle of the ranges, the only starts without a seed or a closed \
                 form; seed joints near a solution start a solve there)"
            )
        } else if spread || searched {
            format!(
                "; nor do solves from {} starts spread over the joints' turns around the {}",
                if spread {
                    SPREAD_ONLY_STARTS
                } else {
                    SEARCH_STARTS
                },
                if seed.is_some() {
                    "seed"
                } else {
                    "middle of the ranges"
                }
            )
        } else {
            String::new()
        };
        match (found.failure, pulled) {
            _ if !found.sols.is_empty() => Ok(found.sols),
            _ if past_reach && found.nearest_outside.is_infinite() => {
                Err(IkFailure::Unreachable(format!(
                    "the closed form of the nominal model has no solution, for the pose nor for \
                     it moved by up to {:.0} % of its distance toward or away from the base{}{search_note}: \
                     no configuration of this model found reaches it",
                    PULLS[PULLS.len() - 1] * 100.0,
                    if seed.is_some() {
                        "; nor does a solve from the seed"
                    } else {
                        ""
                    },
                )))
            }
            (IkFailure::NotConverged(why), Some(moved)) => Err(IkFailure::Unreachable(format!(
                "the closed form of the nominal model has no solution (the pose is beyond \
                     its reach), and solves from the nearest poses it reaches (moved by {:.0} % \
                     of the distance toward or away from the base){} do not reach it on this \
                     model either: {why}{search_note}",
                moved * 100.0,
                if seed.is_some() {
                    " and from the seed"
                } else {
                    ""
                },
            ))),
            (IkFailure::NotConverged(why), None) => {
                Err(IkFailure::NotConverged(format!("{why}{search_note}")))
            }
            (IkFailure::Unreachable(why), None) => {
                Err(IkFailure::Unreachable(format!("{why}{search_note}")))
            }
            (failure, _) => Err(failure),
        }
    }

    /// Solves of `target` from `count` starts spread over the joints' turns around
    /// `reference` ([`around`]), at most [`SEARCH_ITERATIONS`] each, into `found`. Where the
    /// search finds a solution outside the limits nearer the reference than any before, it
    /// names the failure; else, with `keep`, the earlier starts' failure stands (not a search
    /// solve's that did not converge).
    fn search(
        &mut self,
        target: &Pose,
        reference: &[f64],
        count: usize,
        keep: bool,
        found: &mut Found,
    ) {
        let outside = found.nearest_outside;
        let failure = std::mem::replace(&mut found.failure, self.no_start());
        for k in 0..count {
            let q0 = around(self.model.robot(), reference, k);
            self.solve_start(target, &q0, reference, SEARCH_ITERATIONS, found);
        }
        if keep && found.nearest_outside == outside {
            found.failure = failure;
        }
    }

    /// One numerical solve of `target` from `q0` (at most `iterations` iterations), its
    /// solution in the whole-turn copy nearest `reference`, added to `found`: a new solution
    /// within the limits to its solutions, else (the nearest `reference` of those outside the
    /// limits, or a solve that did not converge where none has converged) as its failure.
    fn solve_start(
        &mut self,
        target: &Pose,
        q0: &[f64],
        reference: &[f64],
        iterations: usize,
        found: &mut Found,
    ) {
        let solved = self.refine_within(target, q0, iterations).map(|mut sol| {
            // The solve ends in whichever whole-turn copy its steps reach.
            let robot = self.model.robot();
            if let Some(q) = robot.turns_near(&sol.q, reference) {
                sol.outside_limits = robot.joints_outside_limits(&q);
                sol.q = q;
            }
            sol
        });
        match solved {
            Ok(sol) if sol.outside_limits.is_empty() => {
                if !found.sols.iter().any(|o| same_solution(&o.q, &sol.q)) {
                    found.sols.push(sol);
                }
            }
            Ok(sol) => {
                if !found.outside.iter().any(|o| same_solution(o, &sol.q)) {
                    found.outside.push(sol.q.clone());
                }
                let d = joint_distance(&sol.q, reference);
                if d < found.nearest_outside {
                    found.nearest_outside = d;
                    found.failure = IkFailure::OutsideLimits(sol.outside_limits);
                }
            }
            Err(e) if found.nearest_outside.is_infinite() => {
                found.failure = IkFailure::NotConverged(e.to_string())
            }
            Err(_) => {}
        }
    }

    /// Solution `q` reflected across a fold of the model within
    /// [`FOLD_NEAR_RAD`](crate::kinematics::fold::FOLD_NEAR_RAD) ([`across_fold`]), if any.
    fn reflected(&mut self, q: &[f64]) -> Option<Vec<f64>> {
        across_fold(&mut self.model, q, self.opts.length_scale_mm, &mut self.jac)
    }
}
