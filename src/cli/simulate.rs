//! `robocal simulate`: measurements of a virtual robot.

use super::output::writing;
use crate::data::JointInfo;
use crate::data::measurement::write_measurements;
use crate::kinematics::tool_pose;
use crate::model::{read_robot, write_robot};
use crate::sim::{Deviations, NonGeometric, Observe, Region, Simulation};
use anyhow::{Context, Result};
use clap::Args;
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
    /// Joint ranges to draw from (TOML `ranges = [[min, max], ...]`, deg). Default: the limits.
    #[arg(long)]
    region: Option<PathBuf>,
    /// Number of configurations (1 to 1000000).
    #[arg(long, value_parser = super::bounds::count)]
    count: usize,
    /// Random seed (configurations and noise).
    #[arg(long)]
    seed: u64,
    /// Noise on each position coordinate (mm, one standard deviation; 0 to 1000).
    #[arg(long, default_value_t = 0.0, value_parser = super::bounds::noise)]
    sigma_pos: f64,
    /// Noise on each orientation component (mrad, one standard deviation; 0 to 1000).
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
    /// The true robot (nominal + deviations) as a robot file.
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
        ],
        &[
            req("--out", &a.out),
            opt("--truth-out", a.truth_out.as_ref()),
            opt("--true-robot", a.true_robot.as_ref()),
        ],
    )?;
    let nominal = read_robot(&a.robot)?;
    let truth = match &a.deviations {
        Some(p) => Deviations::read(p, &nominal)?
            .apply(&nominal)
            .with_context(|| format!("{}: the deviated robot", p.display()))?,
        None => nominal.clone(),
    };
    let ng = match &a.nongeometric {
        Some(p) => NonGeometric::read(p, &nominal)?,
        None => NonGeometric::default(),
    };
    let region = match &a.region {
        Some(p) => Region::read(p, &nominal)?,
        None => Region::limits(&nominal),
    };
    let sim = Simulation {
        truth: &truth,
        nongeometric: &ng,
        region: &region,
        count: a.count,
        seed: a.seed,
        sigma_position_mm: a.sigma_pos,
        sigma_rotation_rad: a.sigma_rot * 1e-3,
        observe: a.measure,
    };
    let out = sim.run(a.out.clone())?;
    let joints = JointInfo::of(&nominal);
    writing(write_measurements(&out.measured, &joints, &a.out), &a.out)?;
    if let Some(p) = &a.truth_out {
        writing(write_measurements(&out.truth, &joints, p), p)?;
    }
    if let Some(p) = &a.true_robot {
        writing(write_robot(&truth, p), p)?;
    }
    // How far the nominal model is from the truth, in position (mm), as a first look.
    let errors: Vec<f64> = out
        .truth
        .rows
        .iter()
        .filter_map(|m| Some((tool_pose(&nominal, &m.q).translation.vector - m.position?).norm()))
        .collect();
    if !errors.is_empty() {
        let mean = errors.iter().sum::<f64>() / errors.len() as f64;
        let max = errors.iter().cloned().fold(0.0, f64::max);
        eprintln!(
            "simulated {} configurations into {}; nominal model vs truth: mean {mean:.4} mm, max {max:.4} mm",
            a.count,
            a.out.display()
        );
    } else {
        eprintln!(
            "simulated {} configurations into {}",
            a.count,
            a.out.display()
        );
    }
    Ok(())
}
