//! `robocal split`: a seeded random split of a measurement set (calibration / validation).

use super::data_args::{DataArgs, counted_joints, joints_of};
use anyhow::Result;
use clap::Args;
use robocal::data::measurement::{pair_units, split, write_measurements};
use std::path::PathBuf;

#[derive(Args)]
pub struct SplitArgs {
    /// Measurements to split.
    input: PathBuf,
    #[command(flatten)]
    data: DataArgs,
    /// Robot file (joint types and limits).
    #[arg(long)]
    robot: Option<PathBuf>,
    /// Fraction of rows for the first output (rows that share a pair label stay together: the
    /// first output may then hold one row more).
    #[arg(long, allow_negative_numbers = true, default_value_t = 0.5)]
    fraction: f64,
    /// Seed of the random split (the same seed gives the same parts).
    #[arg(long)]
    seed: u64,
    /// First part (canonical CSV).
    #[arg(long)]
    out_a: PathBuf,
    /// The rest (canonical CSV).
    #[arg(long)]
    out_b: PathBuf,
}

pub fn run(a: SplitArgs) -> Result<()> {
    use super::paths::{guard, opt, req};
    guard(
        &[
            req("input", &a.input),
            opt("--profile", a.data.profile.as_ref()),
            opt("--robot", a.robot.as_ref()),
        ],
        &[req("--out-a", &a.out_a), req("--out-b", &a.out_b)],
    )?;
    if !(0.0..=1.0).contains(&a.fraction) {
        usage!("--fraction must be within 0..1");
    }
    let profile = a.data.profile()?;
    let n = counted_joints(&a.input, a.robot.as_ref(), &profile)?;
    // A profile's joint unit converts every joint alike: a prismatic joint's length would be
    // read as an angle (a reviewer's metres became degrees), as `import` says too.
    if a.robot.is_none() && a.data.profile.is_some() {
        eprintln!(
            "note: no --robot: joints are taken as revolute and their limits are not checked"
        );
    }
    let joints = joints_of(a.robot.as_ref(), n)?;
    let set = a.data.read(&a.input, &joints)?;
    super::data_args::warn_lone_pairs(&a.input, &set);
    let (x, y) = split(&set, a.fraction, a.seed);
    for (part, flag) in [(&x, "--out-a"), (&y, "--out-b")] {
        if part.rows.is_empty() {
            usage!(
                "{flag} would get no rows ({} rows, --fraction {:?}): a file without rows is \
                 refused by every command",
                set.rows.len(),
                a.fraction
            );
        }
    }
    write_measurements(&x, &joints, &a.out_a)?;
    write_measurements(&y, &joints, &a.out_b)?;
    // Rows that share a pair label went to one part together: said, with the count.
    let labels = pair_units(&set).iter().filter(|u| u.len() > 1).count();
    let kept = if labels > 0 {
        format!(" ({labels} pair labels, each kept whole in one part)")
    } else {
        String::new()
    };
    told_after_on_stderr!(
        "split {} rows{kept}: {} into {}, {} into {}",
        set.rows.len(),
        x.rows.len(),
        a.out_a.display(),
        y.rows.len(),
        a.out_b.display()
    );
    Ok(())
}
