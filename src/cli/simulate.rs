//! `robocal simulate`: measurements of a virtual robot.

use super::choices::Observe;
use super::output::writing;
use anyhow::{Context, Result};
use clap::Args;
use robocal::data::JointInfo;
use robocal::data::JointTable;
use robocal::data::measurement::Measurement;
use robocal::data::measurement::MeasurementWriter;
use robocal::kinematics::tool_pose;
use robocal::model::Robot;
use robocal::model::{read_robot, write_robot};
use robocal::sim::{Configurations, Deviations, NonGeometric, Region, Simulation};
use std::io::IsTerminal;
use std::path::PathBuf;

#[derive(Args)]
pub struct SimulateArgs {
    /// Nominal robot file.
    #[arg(long)]
    robot: PathBuf,
    /// Parameter deviations (TOML; parameter names; mm and mrad). None: the nominal geometry.
    #[arg(long)]
    deviations: Option<PathBuf>,
    /// Non-geometric errors (TOML: compliance, gear, backlash). None: purely geometric.
    #[arg(long)]
    nongeometric: Option<PathBuf>,
    /// Joint ranges to draw from (TOML `ranges = [[min, max], ...]`, deg; mm for a prismatic
    /// joint). Default: the limits.
    #[arg(long)]
    region: Option<PathBuf>,
    /// Number of configurations to draw (1 to 1000000).
    #[arg(long, value_parser = super::bounds::count, required_unless_present = "joints")]
    count: Option<usize>,
    /// Measure at these configurations, in their order, instead of drawing them (CSV with
    /// q1..qN, deg; mm for a prismatic joint; within the limits), e.g. `plan --out`: its `id`,
    /// `set` and `pair` columns label the rows, its other columns are carried through.
    #[arg(long, conflicts_with_all = ["count", "region"])]
    joints: Option<PathBuf>,
    /// Random seed (configurations and noise; noise only with --joints).
    #[arg(long)]
    seed: u64,
    /// Noise on each position coordinate (mm, one standard deviation; 0, or 1e-6 to 1000).
    #[arg(long, default_value_t = 0.0, value_parser = super::bounds::noise)]
    sigma_pos: f64,
    /// Noise on each orientation component (mrad, one standard deviation; 0, or 1e-6 to 1000).
    #[arg(long, default_value_t = 0.0, value_parser = super::bounds::noise)]
    sigma_rot: f64,
    /// What the sensor reports.
    #[arg(long, value_enum, default_value_t = Observe::Pose)]
    measure: Observe,
    /// Measurement CSV to write.
    #[arg(long)]
    out: PathBuf,
    /// Noise-free poses of the same rows (CSV).
    #[arg(long)]
    truth_out: Option<PathBuf>,
    /// The true robot (nominal + deviations; not --nongeometric's errors) as a robot file.
    #[arg(long)]
    true_robot: Option<PathBuf>,
}

pub fn run(a: SimulateArgs) -> Result<()> {
    use super::paths::{guard, opt, req};
    guard(
        &[
            req("--robot", &a.robot),
            opt("--deviations", a.deviations.as_ref()),
            opt("--nongeometric", a.nongeometric.as_ref()),
            opt("--region", a.region.as_ref()),
            opt("--joints", a.joints.as_ref()),
        ],
        &[
            req("--out", &a.out),
            opt("--truth-out", a.truth_out.as_ref()),
            opt("--true-robot", a.true_robot.as_ref()),
        ],
    )?;
    let nominal = read_robot(&a.robot)?;
    let truth = match &a.deviations {
        Some(p) => {
            let d = Deviations::read(p, &nominal)?;
            if let Some(w) = large_deviations(&d) {
                eprintln!("warning: {}: {w}", p.display());
            }
            d.apply(&nominal)
                .with_context(|| format!("{}: the deviated robot", p.display()))?
        }
        None => nominal.clone(),
    };
    let ng = match &a.nongeometric {
        Some(p) => NonGeometric::read(p, &nominal)?,
        None => NonGeometric::default(),
    };
    let region = match &a.region {
        Some(p) => Region::read(p, &nominal)
            .inspect(|r| super::fk::warn_if_radian_region(p, &nominal, r))?,
        None => Region::limits(&nominal),
    };
    let given = match &a.joints {
        Some(p) => Some(Given::read(p, &nominal)?),
        None => None,
    };
    let configurations = match (&given, a.count) {
        (Some(g), _) => Configurations::Given(&g.q),
        (None, Some(count)) => Configurations::Drawn {
            region: &region,
            count,
        },
        (None, None) => anyhow::bail!("give --count (configurations to draw) or --joints"),
    };
    // A noise the sensor's measure does not report is said to be unused, not dropped silently.
    let unused = match a.measure {
        Observe::Orientation if a.sigma_pos > 0.0 => Some(("--sigma-pos", "orientations")),
        Observe::Position if a.sigma_rot > 0.0 => Some(("--sigma-rot", "positions")),
        _ => None,
    };
    if let Some((flag, only)) = unused {
        eprintln!("note: {flag} is unused: the sensor reports {only} only (--measure)");
    }
    let rows = configurations.count();
    let sim = Simulation {
        truth: &truth,
        nongeometric: &ng,
        configurations,
        seed: a.seed,
        sigma_position_mm: a.sigma_pos,
        sigma_rotation_rad: a.sigma_rot * 1e-3,
        observe: a.measure.into(),
    };
    // Rows stream to the files as they are drawn: a million of them need no memory.
    let joints = JointInfo::of(&nominal);
    let (mut measured_layout, mut truth_layout) = sim.layouts();
    if let Some(g) = &given {
        for l in [&mut measured_layout, &mut truth_layout] {
            l.set = g.set.is_some();
            l.pair = g.pair.is_some();
            l.extra = g
                .extra
                .iter()
                .map(|&c| g.t.table.headers[c].clone())
                .collect();
        }
        if let Some(note) = super::output::renamed_note(&measured_layout, joints.len()) {
            told_after_on_stderr!("{note}");
        }
    }
    let mut out = writing(
        MeasurementWriter::create(&a.out, measured_layout, &joints),
        &a.out,
    )?;
    let mut truth_out = match &a.truth_out {
        Some(p) => Some(writing(
            MeasurementWriter::create(p, truth_layout, &joints),
            p,
        )?),
        None => None,
    };
    // How far the nominal model is from the truth, in position (mm), as a first look.
    let (mut sum, mut max, mut count) = (0.0, 0.0f64, 0usize);
    let bar = super::compensator_args::progress_bar(std::io::stderr().is_terminal());
    bar.set_length(rows as u64);
    let mut k = 0;
    sim.run_each(|mut m, mut t| {
        match &given {
            Some(g) => {
                g.label(k, &mut m);
                g.label(k, &mut t);
                out.write_with_joints(&m, &g.t.joints[k])?;
                if let Some(w) = truth_out.as_mut() {
                    w.write_with_joints(&t, &g.t.joints[k])?;
                }
            }
            None => {
                out.write(&m)?;
                if let Some(w) = truth_out.as_mut() {
                    w.write(&t)?;
                }
            }
        }
        k += 1;
        if let Some(p) = t.position {
            let e = (tool_pose(&nominal, &t.q).translation.vector - p).norm();
            sum += e;
            max = max.max(e);
            count += 1;
        }
        bar.inc(1);
        Ok(())
    })?;
    bar.finish_and_clear();
    writing(out.finish(), &a.out)?;
    if let (Some(w), Some(p)) = (truth_out, &a.truth_out) {
        writing(w.finish(), p)?;
    }
    if let Some(p) = &a.true_robot {
        writing(write_robot(&truth, p), p)?;
        // The file is the geometry the rows were simulated with: what --nongeometric adds
        // (a compliance the model could carry, gear errors and backlash it could not) is not
        // in it, and the file misses the rows by that much.
        let left: Vec<&str> = [
            ng.compliance.is_some().then_some("gravity compliance"),
            (!ng.gear.is_empty()).then_some("gear errors"),
            ng.backlash.is_some().then_some("backlash"),
        ]
        .into_iter()
        .flatten()
        .collect();
        if let (false, Some(n)) = (left.is_empty(), &a.nongeometric) {
            told_after_on_stderr!(
                "note: {} holds the nominal and the deviations only: the {} of {} are not in \
                 it, so it misses the rows by what they add",
                p.display(),
                match left.split_last() {
                    Some((last, [])) => last.to_string(),
                    Some((last, rest)) => format!("{} and {last}", rest.join(", ")),
                    None => String::new(),
                },
                n.display()
            );
        }
    }
    let of = match &a.joints {
        Some(p) => format!(" of {}", p.display()),
        None => String::new(),
    };
    if count > 0 {
        let mean = sum / count as f64;
        told_after_on_stderr!(
            "simulated {rows} configurations{of} into {}; nominal model vs truth: mean {mean:.4} mm, max {max:.4} mm",
            a.out.display()
        );
    } else {
        told_after_on_stderr!(
            "simulated {rows} configurations{of} into {}",
            a.out.display()
        );
    }
    Ok(())
}

/// Angle deviations (mrad) beyond which a deviations file is probably in another unit: 100
/// mrad is 5.7 deg, far beyond a robot's manufacturing errors (thesis Table 6.1: 1-3 mrad);
/// degrees written as mrad pass below the file's bound of two turns.
const LARGE_DEVIATION_MRAD: f64 = 100.0;
/// The same for lengths (mm): 100 mm is a wrong link, not a calibration's error.
const LARGE_DEVIATION_MM: f64 = 100.0;
/// The same for a joint's compliance (mrad per kN m): 100 bends a joint 5.7 deg under 1 kN m,
/// where the compliant arms simulated in the tests take 0.02 to 20. The mass-free
/// coefficients (compliance times kg or kg m) have no such scale and are not checked.
const LARGE_DEVIATION_COMPLIANCE: f64 = 100.0;

/// A warning naming the deviations beyond [`LARGE_DEVIATION_MRAD`],
/// [`LARGE_DEVIATION_MM`] or [`LARGE_DEVIATION_COMPLIANCE`], if any (each with its file
/// value: mm, mrad for an angle, mrad per kN m for a compliance).
fn large_deviations(d: &Deviations) -> Option<String> {
    use robocal::model::Field;
    let mut angle = false;
    let large: Vec<String> = (d.0.iter())
        .filter_map(|(id, v)| {
            let (unit, _) = robocal::sim::deviations::file_unit(id.field);
            let bound = match id.field {
                Field::C => LARGE_DEVIATION_COMPLIANCE,
                Field::K { .. } => return None,
                f if f.is_angle() => LARGE_DEVIATION_MRAD,
                _ => LARGE_DEVIATION_MM,
            };
            let value = robocal::sim::deviations::to_file(id.field, *v);
            (value.abs() > bound).then(|| {
                angle |= id.field.is_angle();
                let shown = robocal::data::measurement::as_typed(value);
                format!("{} {shown} {unit}", id.name())
            })
        })
        .collect();
    (!large.is_empty()).then(|| {
        format!(
            "deviations beyond {LARGE_DEVIATION_MRAD} mrad ({:.1} deg), {LARGE_DEVIATION_MM} \
             mm or {LARGE_DEVIATION_COMPLIANCE} mrad/kNm, far beyond a robot's manufacturing \
             errors: {}{}; simulated as given",
            (LARGE_DEVIATION_MRAD * 1e-3).to_degrees(),
            large.join(", "),
            if angle {
                " (angles are read in mrad: degrees given as mrad?)"
            } else {
                ""
            }
        )
    })
}

/// The configurations of `--joints`: the file's joints and the columns that label or ride
/// along with each row.
struct Given {
    /// The file as read (joints in file units: deg, mm).
    t: JointTable,
    /// Each row's joints (rad, mm).
    q: Vec<Vec<f64>>,
    /// The `id`, `set` and `pair` columns, where the file has them.
    id: Option<usize>,
    set: Option<usize>,
    pair: Option<usize>,
    /// The other columns (not joints nor labels), carried through in their order.
    extra: Vec<usize>,
}

impl Given {
    /// Reads `path` as `robot`'s joints: every row within the joint limits (a configuration
    /// the robot cannot take is an error naming its line).
    fn read(path: &std::path::Path, robot: &Robot) -> Result<Given> {
        // The table reader refuses a file without rows.
        let t = JointTable::read(path, robot)?;
        super::fk::warn_if_radians(path, robot, &t);
        let info = JointInfo::of(robot);
        let q: Vec<Vec<f64>> = (0..t.joints.len()).map(|r| t.internal(r, robot)).collect();
        for (r, q) in q.iter().enumerate() {
            if let Some((j, why)) = JointInfo::first_outside_at(&info, q) {
                anyhow::bail!(
                    "{}:{}: field `q{}`: {why}: the robot cannot be measured there",
                    path.display(),
                    t.table.lines[r],
                    j + 1
                );
            }
        }
        let col = |name: &str| t.table.column(name);
        let joint_names = robocal::data::joint_columns(robot.dof());
        let labels = ["id", "set", "pair"];
        let extra = (0..t.table.headers.len())
            .filter(|&c| {
                let h = &t.table.headers[c];
                !joint_names.contains(h) && !labels.contains(&h.as_str())
            })
            .collect();
        Ok(Given {
            id: col("id"),
            set: col("set"),
            pair: col("pair"),
            extra,
            q,
            t,
        })
    }

    /// Labels row `k`'s measurement `m` as the file does (a blank label is no label) and
    /// carries its other cells.
    fn label(&self, k: usize, m: &mut Measurement) {
        let cells = &self.t.table.rows[k];
        let text = |c: Option<usize>| c.map(|c| cells[c].clone()).filter(|s| !s.is_empty());
        if self.id.is_some() {
            m.id = text(self.id);
        }
        m.set = text(self.set);
        m.pair = text(self.pair);
        m.extra = self.extra.iter().map(|&c| cells[c].clone()).collect();
    }
}
