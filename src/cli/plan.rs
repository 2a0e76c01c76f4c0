//! `robocal plan`: which configurations to measure, and the accuracy they will give.

use super::choices::{Criterion, Measure};
use super::data_args::SigmaArgs;
use super::output::{emit, num, parse_list};
use super::warnings::Warnings;
use anyhow::{Context, Result, bail};
use clap::Args;
use robocal::data::JointTable;
use robocal::identify::identifiability::RANK_TOL;
use robocal::model::{Robot, read_robot};
use robocal::plan::design::per_unit;
use robocal::plan::predict::Prediction;
use robocal::plan::{
    Constraints, Design, Pool, choose, enough_equations, pool, predict, smallest_meeting,
};
use robocal::sim::Region;
use std::io::IsTerminal;
use std::path::PathBuf;

/// Largest candidate pool drawn: each unit holds its Jacobian block three or four times over
/// (6 x p numbers each; some 1 GB at the largest pool with p = 30).
const MAX_POOL: usize = 200_000;

#[derive(Args)]
pub struct PlanArgs {
    /// Nominal robot file.
    #[arg(long)]
    robot: PathBuf,
    /// Units to measure: configurations, or pairs for --measure relative|distance.
    #[arg(long, value_parser = super::bounds::units, required_unless_present_any = ["target_mm", "evaluate"], conflicts_with_all = ["target_mm", "evaluate"])]
    count: Option<usize>,
    /// Plan the fewest units whose predicted mean position error is at most this (mm).
    #[arg(long, value_parser = super::bounds::target_mm, conflicts_with = "evaluate")]
    target_mm: Option<f64>,
    /// Predict the accuracy of an existing list instead of planning (CSV with q1..qN, deg;
    /// consecutive rows pair up for relative and distance).
    #[arg(long, conflicts_with = "candidates")]
    evaluate: Option<PathBuf>,
    /// Parameters to identify (as `identify --params`).
    #[arg(long, default_value = "full")]
    params: String,
    /// How the planned units will be measured (default: pose; with --evaluate, what the
    /// file measures, as `identify` reads it: position where it has x, y, z without rz, ry,
    /// rx, orientation where the reverse, distance where it has a distance column alone).
    #[arg(long, value_enum)]
    measure: Option<Measure>,
    /// Candidate configurations (CSV with q1..qN, deg); default: drawn within the limits.
    #[arg(long, conflicts_with = "region")]
    candidates: Option<PathBuf>,
    /// Joint ranges to draw candidates and the validation cloud from (TOML `ranges = [[min,
    /// max], ...]`, deg; mm for a prismatic joint).
    #[arg(long)]
    region: Option<PathBuf>,
    /// Candidate units drawn (1 to 200000).
    #[arg(long, default_value_t = 5000, conflicts_with = "candidates")]
    pool: usize,
    /// What the plan optimises (each one's value is printed with its unit and direction).
    #[arg(long, value_enum, default_value_t = Criterion::D)]
    criterion: Criterion,
    #[command(flatten)]
    sigma: SigmaArgs,
    /// Random seed (candidate pool, validation cloud, prediction draws).
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Angle kept from every revolute joint's limits (deg, 0 to 90; one that leaves a joint no
    /// room is an error).
    #[arg(long, default_value_t = 0.0)]
    margin_deg: f64,
    /// Lowest height of the tool origin (mm, z in the robot's world frame).
    #[arg(long, allow_hyphen_values = true)]
    floor_mm: Option<f64>,
    /// A box the tool origin must stay out of: "xmin,ymin,zmin,xmax,ymax,zmax" (mm).
    #[arg(long, allow_hyphen_values = true)]
    forbid: Option<String>,
    /// Validation configurations the prediction averages over (1 to 100000).
    #[arg(long, default_value_t = 300)]
    validation: usize,
    /// The planned configurations (CSV: id, pair, q1..qN in deg; from --candidates, each
    /// row's line there in source_line); with --evaluate (optional there), the list's
    /// configurations in the same columns (for relative and distance, each pair's two rows).
    #[arg(long, required_unless_present = "evaluate")]
    out: Option<PathBuf>,
    /// Everything the plan found, as JSON.
    #[arg(long)]
    report: Option<PathBuf>,
}

fn constraints(a: &PlanArgs) -> Result<Constraints> {
    if !(0.0..=90.0).contains(&a.margin_deg) {
        usage!("--margin-deg {}: give 0 to 90", a.margin_deg);
    }
    if a.floor_mm.is_some_and(|f| !f.is_finite()) {
        usage!("--floor-mm must be a number");
    }
    let forbidden = match &a.forbid {
        Some(s) => {
            let v = parse_list(s, "--forbid", 6)?;
            let (lo, hi) = (
                nalgebra::Vector3::new(v[0], v[1], v[2]),
                nalgebra::Vector3::new(v[3], v[4], v[5]),
            );
            if (0..3).any(|i| lo[i] > hi[i]) {
                usage!("--forbid {s}: give the box's minimum corner first, then its maximum");
            }
            Some((lo, hi))
        }
        None => None,
    };
    Ok(Constraints {
        margin: a.margin_deg.to_radians(),
        floor_mm: a.floor_mm,
        forbidden,
    })
}

/// Warns of the joints `--margin-deg` leaves under a tenth of their range of `region` (where
/// it leaves some: none is an error when the pool is drawn): the plan barely moves them, and
/// what they alone excite is poorly determined (a reviewer's FANUC at 59.999 deg, joint 2's
/// limits -50 to 70 deg, `--count 30 --seed 1`: base.z predicted to 405.6 mm, without a
/// word).
/// A `--region` that holds a joint at one value (a range under
/// [`robocal::identify::plausibility::HELD_JOINT_SPREAD`]) is warned of too: the plan cannot
/// move it, and the parameters its motion alone tells apart are left out (a FANUC region with
/// q3 held at 5 deg: 26 parameters of 30, without a word), as `identify` warns of such rows.
fn warn_narrow(robot: &Robot, region: &Region, limits: &Constraints, warnings: &mut Warnings) {
    use robocal::identify::plausibility::HELD_JOINT_SPREAD;
    for (i, (&[lo, hi], j)) in region.0.iter().zip(robot.joints()).enumerate() {
        let width = j.joint_type.to_file(hi) - j.joint_type.to_file(lo);
        if width < HELD_JOINT_SPREAD {
            let unit = j.joint_type.file_unit();
            warnings.say(format!(
                "the region holds joint {} within {:.4} to {:.4} {unit} (under \
                 {HELD_JOINT_SPREAD} {unit} of range): the plan cannot move it, and the \
                 parameters its motion alone tells apart are left out or planned as \
                 combinations that hold at that value only; widen its range",
                i + 1,
                j.joint_type.to_file(lo),
                j.joint_type.to_file(hi)
            ));
            continue;
        }
        if j.joint_type != robocal::model::JointType::Revolute || hi <= lo {
            continue;
        }
        let [llo, lhi] = j.limits_internal();
        let room = hi.min(lhi - limits.margin) - lo.max(llo + limits.margin);
        // (Exactly a tenth, as 54 deg of the FANUC's joint 2 leaves, is not under it.)
        if room > robocal::plan::pool::NO_ROOM && room < 0.1 * (hi - lo) * (1.0 - 1e-9) {
            warnings.say(format!(
                "--margin-deg {:.3} leaves joint {} {:.3} deg of its {:.1} deg range \
                 (under a tenth): \
                 the plan barely moves it, and the parameters it alone excites are poorly \
                 determined (see their predicted standard deviations)",
                limits.margin.to_degrees(),
                i + 1,
                room.to_degrees(),
                (hi - lo).to_degrees()
            ));
        }
    }
}

/// The configurations of a joints CSV (rad, mm) and the table read.
fn configurations(path: &PathBuf, robot: &Robot) -> Result<(Vec<Vec<f64>>, JointTable)> {
    let t = JointTable::read(path, robot)?;
    if t.joints.is_empty() {
        bail!("{}: no rows", path.display());
    }
    super::fk::warn_if_radians(path, robot, &t);
    Ok((
        (0..t.joints.len()).map(|r| t.internal(r, robot)).collect(),
        t,
    ))
}

/// The measure of a list to evaluate without `--measure`: what its columns hold, as
/// `identify` reads a measured file (pose with x, y, z and rz, ry, rx or with neither nor a
/// distance: a list of joints; position with the positions alone; orientation with the
/// angles alone; distance with a distance column alone), said in a note where it is not
/// pose.
fn measured_in(path: &std::path::Path, t: &robocal::data::Table) -> robocal::identify::Measure {
    use robocal::identify::Measure as M;
    let all = |names: &[&str]| names.iter().all(|c| t.column(c).is_some());
    let measure = match (all(&["x", "y", "z"]), all(&["rz", "ry", "rx"])) {
        (true, false) => M::Position,
        (false, true) => M::Orientation,
        (false, false) if all(&["distance"]) => M::Distance,
        _ => return M::Pose,
    };
    eprintln!(
        "note: {}: measure {}, as `identify` reads the file (of the measured columns it holds \
         the {} alone); give --measure to plan for another",
        path.display(),
        measure.name(),
        match measure {
            M::Position => "positions",
            M::Orientation => "orientations",
            _ => "distances",
        }
    );
    measure
}

/// The file lines of the configurations `qs` (read from `t`) that `constraints` refuse,
/// each with its index in `qs`.
fn refused_lines(
    robot: &Robot,
    qs: &[Vec<f64>],
    t: &JointTable,
    constraints: &Constraints,
) -> Vec<(usize, usize)> {
    let mut ws = robocal::kinematics::Frames::new(robot);
    (qs.iter().zip(&t.table.lines).enumerate())
        .filter(|(_, (q, _))| constraints.check(robot, q, &mut ws).is_some())
        .map(|(r, (_, &line))| (line, r))
        .collect()
}

/// "2, 5, 9": the lines of [`refused_lines`].
fn lines_of(refused: &[(usize, usize)]) -> String {
    let lines: Vec<usize> = refused.iter().map(|&(line, _)| line).collect();
    robocal::data::measurement::list_lines(&lines)
}

/// The units of the list `--evaluate` predicts for: a configuration each, or for relative
/// and distance the pairs `identify` forms of its rows (consecutive rows, (1, 2), (2, 3),
/// ..., or the two rows of each label of a `pair` column). A row beyond the joint limits is
/// an error naming its line; rows the cell's constraints (`--margin-deg`, `--floor-mm`,
/// `--forbid`) refuse are kept (the list is what will be measured) and named in a warning.
fn evaluated_list(
    path: &std::path::Path,
    (qs, t): (Vec<Vec<f64>>, JointTable),
    robot: &Robot,
    per: usize,
    cell: &Constraints,
    warnings: &mut Warnings,
) -> Result<(Pool, Vec<usize>, Vec<Vec<f64>>)> {
    let joints = robocal::data::measurement::JointInfo::of(robot);
    let beyond = refused_lines(robot, &qs, &t, &Constraints::default());
    if let Some(&(line, r)) = beyond.first() {
        // Both judge the limits with one tolerance: a row refused has a joint to name.
        let at = robocal::data::measurement::JointInfo::first_outside_at(&joints, &qs[r]);
        let (field, why) = match at {
            Some((j, why)) => (format!(" field `q{}`:", j + 1), why),
            None => (String::new(), "beyond the joint limits".into()),
        };
        bail!(
            "{}:{line}:{field} {why}: the prediction is for configurations the robot can reach \
             ({} row(s) beyond the limits of its robot file: lines {})",
            path.display(),
            beyond.len(),
            lines_of(&beyond)
        );
    }
    // A list `plan` evaluates is joints; a measured file's sigmas are not its noise model.
    let sigma_columns: Vec<&str> = ["sx", "sy", "sz", "srx", "sry", "srz"]
        .into_iter()
        .filter(|c| t.table.column(c).is_some())
        .collect();
    if !sigma_columns.is_empty() {
        warnings.say(format!(
            "{}: its sigma columns ({}) are not read: the prediction takes \
             --sigma-pos and --sigma-rot for every unit",
            path.display(),
            sigma_columns.join(", ")
        ));
    }
    let refused = refused_lines(robot, &qs, &t, cell);
    if !refused.is_empty() {
        warnings.say(format!(
            "{}: {} row(s) break the cell's constraints (--margin-deg, --floor-mm, \
             --forbid; lines {}): predicted as listed",
            path.display(),
            refused.len(),
            lines_of(&refused)
        ));
    }
    let lines = t.table.lines.clone();
    if per == 1 {
        let what = path.display().to_string();
        let pool = pool::from_configurations(robot, &qs, &Constraints::default(), 1, &what)?;
        return Ok((pool, lines, t.joints));
    }
    let labels: Vec<Option<&str>> = match t.table.column("pair") {
        Some(c) => (t.table.rows.iter())
            .map(|row| Some(row[c].as_str()).filter(|l| !l.is_empty()))
            .collect(),
        None => vec![None; qs.len()],
    };
    let pairs = robocal::data::pairs::pairs_of(&labels, &lines, path)?;
    let pool = pool::from_pairs(robot, &qs, &pairs, &Constraints::default());
    Ok((pool, lines, t.joints))
}

/// Prints a prediction: what the measure sees ([`Prediction`]'s position and orientation,
/// each where its measure sees it), and what it does not said so.
fn print_prediction(label: &str, p: &Prediction, measure: robocal::identify::Measure) {
    let name = measure.name();
    let a = if name.starts_with('o') { "an" } else { "a" };
    let position = p.position_mm.map_or_else(
        || {
            format!(
                "position not predicted ({a} {name} measure leaves the base's and the tool's \
                 positions at their nominal values)"
            )
        },
        |s| format!("position mean {:.4} mm, p95 {:.4} mm", s.mean, s.p95),
    );
    let orientation = p.orientation_deg.map_or_else(
        || {
            format!(
                "orientation not predicted ({a} {name} measure leaves the tool's rotation at \
                 its nominal value)"
            )
        },
        |s| format!("orientation mean {:.4} deg, p95 {:.4} deg", s.mean, s.p95),
    );
    say!("{label}: {position}; {orientation}");
}

/// Configurations the pose measure's identifiability is checked on (a rank analysis of the
/// pool's first ones: enough for every parameter a pose set identifies).
const POSE_CHECK_CONFIGURATIONS: usize = 500;

/// The warnings (printed by the caller) of the parameters pose measurements of the pool's
/// configurations would identify and `measure` (position, orientation, relative, distance)
/// cannot on the same pool (`design`; `what` names the pool in the warning): they keep their
/// nominal values in the plan, and its predicted errors leave their errors out (lengths under
/// orientation measurements, the base under distances); and, for a measure of positions,
/// of those a point off the file's tool point would identify too.
fn warn_unseen(
    robot: &Robot,
    params: &str,
    measure: robocal::identify::Measure,
    sigmas: robocal::identify::Sigmas,
    pool: &Pool,
    design: &Design,
    what: &str,
) -> Result<Vec<String>> {
    let mut warnings = Vec::new();
    let pose = identifiable(
        robot,
        params,
        robocal::identify::Measure::Pose,
        sigmas,
        pool,
    )?;
    let seen: Vec<String> = {
        let names = design.robot.parameters();
        design.params.iter().map(|&d| names[d].name()).collect()
    };
    let unseen: Vec<&String> = pose.iter().filter(|name| !seen.contains(name)).collect();
    if !unseen.is_empty() {
        warnings.push(format!(
            "measure {} cannot identify {} of the {} parameters pose measurements of \
             {what} identify ({}): they keep their nominal values, and the predicted errors \
             below leave their errors out",
            measure.name(),
            unseen.len(),
            pose.len(),
            unseen
                .iter()
                .map(|s| s.as_str())
                .collect::<Vec<_>>()
                .join(", ")
        ));
    }
    // Positions of a point identify more where it lies off the wrist's last axis: a file's
    // tool at the flange centre plans for a point the tracker does not measure (a UR10 at its
    // flange: 23 parameters; 100 mm off it, as a reflector on its mount sits, 25 (a5 and
    // alpha5), as `identify` found on the measured Series A).
    // The design's robot carries the tool as a 6-DOF transform whatever the file's row
    // (an MDH tool row is so identified); relative and distance measures are positions too.
    use robocal::identify::Measure as M;
    if matches!(measure, M::Position | M::Relative | M::Distance)
        && let Some(moved) = off_tool(&design.robot)
    {
        let at = identifiable(&design.robot, params, M::Position, sigmas, pool)?;
        let off = identifiable(&moved, params, M::Position, sigmas, pool)?;
        let more: Vec<&str> = (off.iter())
            .filter(|name| !at.contains(name))
            .map(|s| s.as_str())
            .collect();
        if !more.is_empty() {
            let r = &design.robot;
            let t = |name: &str| {
                let names = r.parameters();
                names
                    .iter()
                    .find(|p| p.name() == name)
                    .map_or(0.0, |&p| r.param(p))
            };
            warnings.push(format!(
                "the positions of a point moved {OFF_TOOL_MM} mm along each axis of \
                 the flange frame from the file's tool point (to ({:.1}, {:.1}, {:.1}) mm in \
                 it) identify {} parameter(s) more than the tool point's ({}): the plan is for \
                 a point at the file's tool; give the measured point's offset (the reflector's \
                 on its mount) in the file's [tool] to plan for it",
                t("tool.x") + OFF_TOOL_MM,
                t("tool.y") + OFF_TOOL_MM,
                t("tool.z") + OFF_TOOL_MM,
                more.len(),
                more.join(", ")
            ));
        }
    }
    Ok(warnings)
}

/// How far (mm, along each axis of the flange frame) [`off_tool`] moves the tool point.
const OFF_TOOL_MM: f64 = 100.0;

/// `robot` with its tool point moved by [`OFF_TOOL_MM`] along each of the x, y and z of the
/// frame the tool row starts from (the flange's; a tool row with `tool.x`, `tool.y` and
/// `tool.z`); None for another tool row.
fn off_tool(robot: &Robot) -> Option<Robot> {
    let ids = robot.parameters();
    let mut moved = Vec::new();
    for name in ["tool.x", "tool.y", "tool.z"] {
        let &id = ids.iter().find(|p| p.name() == name)?;
        moved.push((id, robot.param(id) + OFF_TOOL_MM));
    }
    robot.with_params(&moved).ok()
}

/// The names of the parameters of selection `params` that `measure` (pose or position) at
/// the first [`POSE_CHECK_CONFIGURATIONS`] configurations of `pool` identifies.
fn identifiable(
    robot: &Robot,
    params: &str,
    measure: robocal::identify::Measure,
    sigmas: robocal::identify::Sigmas,
    pool: &Pool,
) -> Result<Vec<String>> {
    let single = Pool {
        units: (pool.units.iter().flatten())
            .take(POSE_CHECK_CONFIGURATIONS)
            .map(|q| vec![q.clone()])
            .collect(),
        refused: Default::default(),
        sources: Vec::new(),
    };
    let cloud = vec![single.units[0][0].clone()];
    let pose =
        Design::new(robot, params, measure, sigmas, &single, cloud, RANK_TOL).context(format!(
            "the parameters {} measurements would identify, to hold the measure against",
            measure.name()
        ))?;
    let names = pose.robot.parameters();
    Ok(pose.params.iter().map(|&c| names[c].name()).collect())
}

/// Warns where `params` leaves out geometric parameters `full` identifies (pose
/// measurements of the same configurations): the plan takes them as exact, so its prediction
/// is the noise floor of the selection, not what a robot with deviations in them will give
/// (a reviewer's `--params offsets` on the FANUC with Table 6.1's deviations: 0.015 mm
/// predicted, 5.7 mm after identification, and `full` predicted worse, 0.040 mm).
fn warn_partial(
    robot: &Robot,
    params: &str,
    sigmas: robocal::identify::Sigmas,
    pool: &Pool,
    warnings: &mut Warnings,
) -> Result<()> {
    let pose = robocal::identify::Measure::Pose;
    let chosen = identifiable(robot, params, pose, sigmas, pool)?;
    let full = identifiable(robot, "full", pose, sigmas, pool)?;
    let left: Vec<&String> = full.iter().filter(|name| !chosen.contains(name)).collect();
    if !left.is_empty() {
        warnings.say(format!(
            "--params {params} leaves out {} of the {} parameters `full` identifies \
             ({}): the plan takes them as exact, so its predicted errors are those of a robot \
             whose deviations lie in --params alone (the noise floor of the selection, not a \
             forecast: a robot with deviations in the others misses by their effect, which \
             the prediction leaves out)",
            left.len(),
            full.len(),
            left.iter()
                .map(|s| s.as_str())
                .collect::<Vec<_>>()
                .join(", ")
        ));
    }
    Ok(())
}

pub fn run(a: PlanArgs) -> Result<()> {
    use super::paths::{guard, opt, req};
    guard(
        &[
            req("--robot", &a.robot),
            opt("--evaluate", a.evaluate.as_ref()),
            opt("--candidates", a.candidates.as_ref()),
            opt("--region", a.region.as_ref()),
        ],
        &[
            opt("--out", a.out.as_ref()),
            opt("--report", a.report.as_ref()),
        ],
    )?;
    if !(1..=MAX_POOL).contains(&a.pool) {
        usage!("--pool {}: give 1 to {MAX_POOL}", a.pool);
    }
    if !(1..=100_000).contains(&a.validation) {
        usage!("--validation {}: give 1 to 100000", a.validation);
    }
    let robot = read_robot(&a.robot)?;
    // What the command warns of, kept for its report.
    let mut warnings = Warnings::default();
    // A selection that names no parameter of this robot is a flag's value refused.
    if let Err(e) = robocal::identify::candidates(&robot, &a.params) {
        usage!("--params `{}`: {e}", a.params);
    }
    // The list to evaluate, read once: its columns also say what it measures.
    let evaluated = match &a.evaluate {
        Some(p) => Some((p, configurations(p, &robot)?)),
        None => None,
    };
    let measure: robocal::identify::Measure = match (a.measure, &evaluated) {
        (Some(m), _) => m.into(),
        (None, Some((p, (_, t)))) => measured_in(p, &t.table),
        (None, None) => robocal::identify::Measure::Pose,
    };
    if a.target_mm.is_some() && measure == robocal::identify::Measure::Orientation {
        usage!(
            "--target-mm sets a mean position error, which an orientation measure does not \
             predict (its positions keep their nominal values): give --count"
        );
    }
    {
        use robocal::identify::Measure as M;
        if a.sigma.sigma_rot.is_some() && matches!(measure, M::Position | M::Relative | M::Distance)
        {
            eprintln!(
                "note: --sigma-rot is not used: a {} measure has no orientation",
                measure.name()
            );
        }
    }
    let criterion: robocal::plan::Criterion = a.criterion.into();
    let per = per_unit(measure);
    let limits = constraints(&a)?;
    let region = match &a.region {
        Some(p) => {
            Region::read(p, &robot).inspect(|r| super::fk::warn_if_radian_region(p, &robot, r))?
        }
        None => Region::limits(&robot),
    };
    // A list evaluated or chosen from is taken as given: the margin only refuses its rows.
    if a.evaluate.is_none() && a.candidates.is_none() {
        warn_narrow(&robot, &region, &limits, &mut warnings);
    }
    // The pool, and the file lines and joints (file units, as read) of its configurations
    // where they were given.
    let (candidates, lines, listed): (Pool, Vec<usize>, Vec<Vec<f64>>) = match (
        evaluated,
        &a.candidates,
    ) {
        (Some((p, list)), _) => evaluated_list(p, list, &robot, per, &limits, &mut warnings)?,
        (None, Some(p)) => {
            let what = p.display().to_string();
            let (qs, t) = configurations(p, &robot)?;
            let pool = pool::from_configurations(&robot, &qs, &limits, per, &what)?;
            if pool.refused.total() > 0 {
                eprintln!(
                    "note: {}: {} candidate row(s) refused by the constraints (limits and margin \
                     {}, floor {}, forbidden box {}; lines {})",
                    what,
                    pool.refused.total(),
                    pool.refused.limits,
                    pool.refused.floor,
                    pool.refused.forbidden,
                    lines_of(&refused_lines(&robot, &qs, &t, &limits))
                );
            }
            (pool, t.table.lines.clone(), t.joints)
        }
        (None, None) => (
            pool::draw(&robot, &region, &limits, a.pool, per, a.seed)?,
            Vec::new(),
            Vec::new(),
        ),
    };
    // The cloud comes from its own stream of the seed: the pool does not move it.
    let cloud = pool::draw(
        &robot,
        &region,
        &limits,
        a.validation,
        1,
        a.seed ^ 0x9e37_79b9_7f4a_7c15,
    )?
    .into_configurations();
    let sigmas = a.sigma.sigmas();
    // A list to evaluate is held against what configurations spread over the region
    // identify (the pool `plan` would draw): parameters the list leaves out keep their
    // nominal values, and its prediction leaves their errors out.
    // Given candidates are held against it the same way: the validation cloud spans the
    // region whatever they span.
    let given = a.evaluate.as_ref().or(a.candidates.as_ref());
    let spread_pool = match given {
        Some(_) => Some(pool::draw(&robot, &region, &limits, a.pool, per, a.seed)?),
        None => None,
    };
    let spread = match &spread_pool {
        Some(spread_pool) => Some(
            Design::new(
                &robot,
                &a.params,
                measure,
                sigmas,
                spread_pool,
                cloud.clone(),
                RANK_TOL,
            )
            .with_context(|| {
                format!(
                    "what {} configurations spread over the region identify, to hold the list \
                     against",
                    a.pool
                )
            })?,
        ),
        None => None,
    };
    let design = Design::new(
        &robot,
        &a.params,
        measure,
        sigmas,
        &candidates,
        cloud,
        RANK_TOL,
    )
    .with_context(|| {
        format!(
            "planning `{}` on {} candidate units",
            a.params,
            candidates.units.len()
        )
    })?;
    let names = design.robot.parameters();
    for n in &design.notes {
        say!("note: {n}");
    }
    let dropped: Vec<String> = design
        .identifiability
        .dropped
        .iter()
        .map(|d| names[d.param].name())
        .collect();
    say!(
        "plan: {} candidate units ({} row{} each{}), measure {}, {} identifiable parameters{}",
        candidates.units.len(),
        per,
        if per == 1 { "" } else { "s" },
        match candidates.refused.total() {
            0 => String::new(),
            k => format!(
                "; {k} refused: {} limits and margin, {} floor, {} forbidden box",
                candidates.refused.limits, candidates.refused.floor, candidates.refused.forbidden
            ),
        },
        measure.name(),
        design.p(),
        if dropped.is_empty() {
            String::new()
        } else {
            format!(" ({} left out: {})", dropped.len(), dropped.join(", "))
        }
    );
    if let (Some(list), Some(spread)) = (given, &spread)
        && design.p() < spread.p()
    {
        let spread_drops: Vec<usize> = spread
            .identifiability
            .dropped
            .iter()
            .map(|d| d.param)
            .collect();
        let missed: Vec<String> = (design.identifiability.dropped.iter())
            .filter(|d| !spread_drops.contains(&d.param))
            .map(|d| names[d.param].name())
            .collect();
        let (what, verb, then) = if a.evaluate.is_some() {
            ("list", "identifies", "not comparable with a planned list's")
        } else {
            (
                "candidates",
                "identify",
                "a plan from them leaves them at their nominal values too (give candidates \
                 that move every joint)",
            )
        };
        warnings.say(format!(
            "{}: the {what} {verb} {} of the {} parameters that {} configurations \
             spread over the region identify; {} ({}) keep their nominal values, and the \
             prediction below leaves their errors out: it is optimistic, {then}",
            list.display(),
            design.p(),
            spread.p(),
            a.pool,
            missed.len(),
            missed.join(", ")
        ));
    }
    if measure != robocal::identify::Measure::Pose {
        // What the measure cannot see at all: against the spread configurations where a list
        // is evaluated (what the list itself leaves out is the warning above).
        let (pool, against, what) = match (&spread_pool, &spread) {
            (Some(p), Some(d)) => (
                p,
                d,
                format!("{} configurations spread over the region", a.pool),
            ),
            _ => (&candidates, &design, "these configurations".to_string()),
        };
        for w in warn_unseen(&robot, &a.params, measure, sigmas, pool, against, &what)? {
            warnings.say(w);
        }
    }
    warn_partial(
        &robot,
        &a.params,
        sigmas,
        spread_pool.as_ref().unwrap_or(&candidates),
        &mut warnings,
    )?;
    let (units, chosen) = match (&a.evaluate, a.target_mm, a.count) {
        (Some(p), _, _) => {
            // As identification would refuse the list: too few equations.
            enough_equations(&design, design.units())
                .with_context(|| format!("--evaluate {}", p.display()))?;
            ((0..design.units()).collect::<Vec<_>>(), None)
        }
        (None, Some(t), _) => {
            let bar = if std::io::stderr().is_terminal() {
                let b = indicatif::ProgressBar::new_spinner();
                b.enable_steady_tick(std::time::Duration::from_millis(200));
                b
            } else {
                indicatif::ProgressBar::hidden()
            };
            let (c, _) = smallest_meeting(&design, criterion, t, a.seed, &mut |n| {
                bar.set_message(format!("--target-mm {t}: planning {n} units"));
                bar.tick();
            })?;
            bar.finish_and_clear();
            say!("target {t} mm: {} units", c.units.len());
            (c.units.clone(), Some(c))
        }
        (None, None, Some(n)) => {
            if n > design.units() {
                usage!(
                    "--count {n}: the candidates hold {} units (--pool, or the rows of \
                     --candidates)",
                    design.units()
                );
            }
            let c = choose(&design, n, criterion, &[])?;
            (c.units.clone(), Some(c))
        }
        (None, None, None) => usage!("give --count, --target-mm or --evaluate"),
    };
    let prediction = predict(&design, &units, a.seed).with_context(|| {
        format!(
            "{} units do not identify every parameter: measure more, or more varied, configurations",
            units.len()
        )
    })?;
    if let Some(c) = &chosen {
        say!(
            "criterion {} ({}): {:.6} after the greedy start, {:.6} after {} exchange(s)",
            criterion.name(),
            criterion.value_words(),
            c.greedy_value,
            c.value,
            c.exchanges
        );
    }
    say!("parameter    unit     predicted std");
    for p in &prediction.parameters {
        say!("{:<12} {:<8} {:>14.6}", p.name, p.unit, p.std);
    }
    // The cloud is drawn within the cell's constraints too: where the robot will work, which
    // a floor or a box narrows (a plan under --floor-mm 3300 predicted 0.029 mm there, 0.19
    // over the whole region), said so.
    let within: Vec<&str> = [
        (a.floor_mm.is_some(), "--floor-mm"),
        (a.forbid.is_some(), "--forbid"),
    ]
    .iter()
    .filter(|(given, _)| *given)
    .map(|(_, flag)| *flag)
    .collect();
    print_prediction(
        &format!(
            "predicted error of {} units over {} validation configurations{}",
            units.len(),
            a.validation,
            if within.is_empty() {
                String::new()
            } else {
                format!(
                    " (drawn within {} too: where the robot will work, not the whole region)",
                    within.join(" and ")
                )
            }
        ),
        &prediction,
        measure,
    );
    // What as many units taken as they come from the pool would give, for comparison.
    let random_prediction = if chosen.is_some() && a.candidates.is_none() {
        let first: Vec<usize> = (0..units.len()).collect();
        let r = predict(&design, &first, a.seed);
        if let Some(r) = &r {
            print_prediction("the same number of random units from the pool", r, measure);
        }
        r
    } else {
        None
    };
    // A row from a given file is written as read there (a round trip through radians moves
    // the last digit of some: a reviewer's 32 of 480 cells), a drawn one in file units.
    let mut rows: Vec<Vec<f64>> = Vec::new();
    for &u in &units {
        for (k, q) in candidates.units[u].iter().enumerate() {
            rows.push(match candidates.sources.get(u) {
                Some(source) => listed[source[k]].clone(),
                None => robot.joints_to_file(q),
            });
        }
    }
    if let Some(out) = &a.out {
        let n = robot.dof();
        // Where each row came from in a given file: its ids are the plan's order.
        let source_lines: Vec<usize> = units
            .iter()
            .flat_map(|&u| candidates.sources.get(u).into_iter().flatten())
            .map(|&i| lines[i])
            .collect();
        let mut headers = vec!["id".to_string()];
        if per == 2 {
            headers.push("pair".into());
        }
        if !source_lines.is_empty() {
            headers.push("source_line".into());
        }
        headers.extend(robocal::data::joint_columns(n));
        let cells: Vec<Vec<String>> = rows
            .iter()
            .enumerate()
            .map(|(k, q)| {
                let mut cells = vec![format!("{}", k + 1)];
                if per == 2 {
                    cells.push(format!("{}", k / 2 + 1));
                }
                if let Some(line) = source_lines.get(k) {
                    cells.push(line.to_string());
                }
                cells.extend(q.iter().map(|v| num(*v, None)));
                cells
            })
            .collect();
        emit(&headers, &cells, headers.len(), false, Some(out))?;
        told_after!("wrote {} ({} rows)", out.display(), rows.len());
    }
    if let Some(path) = &a.report {
        let report = robocal::reports::PlanReport {
            robot: a.robot.display().to_string(),
            params: a.params.clone(),
            measure: measure.name().into(),
            criterion: criterion.name().into(),
            inputs: robocal::reports::PlanInputs {
                seed: a.seed,
                evaluate: a.evaluate.as_ref().map(|p| p.display().to_string()),
                candidates: a.candidates.as_ref().map(|p| p.display().to_string()),
                region: a.region.as_ref().map(|p| p.display().to_string()),
                pool: (a.evaluate.is_none() && a.candidates.is_none()).then_some(a.pool),
                count: a.count,
                target_mm: a.target_mm,
                margin_deg: a.margin_deg,
                floor_mm: a.floor_mm,
                forbid_mm: (limits.forbidden).map(|(lo, hi)| [lo.x, lo.y, lo.z, hi.x, hi.y, hi.z]),
                validation: a.validation,
            },
            sigma_position_mm: sigmas.position_mm,
            sigma_rotation_mrad: sigmas.rotation_rad * 1e3,
            candidate_units: candidates.units.len(),
            refused: candidates.refused,
            identifiable: design.params.iter().map(|&c| names[c].name()).collect(),
            not_identifiable: dropped,
            units: units.len(),
            rows,
            value: chosen.as_ref().map(|c| c.value),
            greedy_value: chosen.as_ref().map(|c| c.greedy_value),
            exchanges: chosen.as_ref().map(|c| c.exchanges),
            prediction,
            random_prediction,
            warnings: warnings.into_vec(),
        };
        // Tagged as every report is (`kind`), so that `robocal report` reads it.
        super::summary::write_report(path, &robocal::reports::Report::Plan(report))?;
    }
    Ok(())
}
