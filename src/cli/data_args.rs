//! Flags shared by every command that reads measurements.

use anyhow::Result;
use clap::Args;
use robocal::data::measurement::{lines_also_in, list_lines, parse_measurements};
use robocal::data::{JointInfo, MeasurementSet, Profile, ReadOptions, ReadReport, Table};
use robocal::model::{Robot, read_robot};
use std::path::{Path, PathBuf};

#[derive(Args, Debug, Clone)]
pub struct DataArgs {
    /// Import profile (TOML) for a foreign CSV layout; default: canonical CSV.
    #[arg(long)]
    pub profile: Option<PathBuf>,
    /// Joints outside the robot's limits are an error instead of a warning.
    #[arg(long)]
    pub strict: bool,
    /// Drop rows that do not parse (listed on stderr) instead of stopping.
    #[arg(long)]
    pub skip_bad_rows: bool,
    /// The profile once read: a profile given as a pipe (`<(...)`, /dev/stdin) can be read
    /// only once, and every measurement file of a command is read under it.
    #[arg(skip)]
    loaded: std::sync::OnceLock<Profile>,
}

impl DataArgs {
    pub fn profile(&self) -> Result<Profile> {
        if let Some(p) = self.loaded.get() {
            return Ok(p.clone());
        }
        let p = Profile::read_or_default(self.profile.as_deref())?;
        Ok(self.loaded.get_or_init(|| p).clone())
    }

    pub fn options(&self) -> ReadOptions {
        ReadOptions {
            strict: self.strict,
            skip_bad_rows: self.skip_bad_rows,
        }
    }

    /// Reads a measurement file and prints what the read noticed.
    pub fn read(&self, path: &Path, joints: &[JointInfo]) -> Result<MeasurementSet> {
        Ok(self.read_noted(path, joints)?.0)
    }

    /// [`DataArgs::read`], also returning what the read noticed as one line per warning
    /// (for a JSON report).
    pub fn read_noted(
        &self,
        path: &Path,
        joints: &[JointInfo],
    ) -> Result<(MeasurementSet, Vec<String>)> {
        let profile = self.profile()?;
        let t = Table::read_with(path, profile.delimiter, profile.decimal_comma)?;
        let (set, report) = parse_measurements(&t, joints, &profile, &self.options())?;
        print_report(path, &report);
        Ok((set, report_lines(path, &report)))
    }
}

/// Set-level tracker sigmas for rows that carry none (identify, train).
#[derive(Args, Debug, Clone)]
pub struct SigmaArgs {
    /// Position sigma (mm, 1e-6 to 1000) for rows without sx,sy,sz (default 0.033, the
    /// thesis's tracker); `plan` takes it for every measurement it plans (it reads no sigma
    /// columns).
    #[arg(long, allow_negative_numbers = true, value_parser = super::bounds::sigma)]
    pub sigma_pos: Option<f64>,
    /// Orientation sigma (mrad, 1e-6 to 1000) for rows without srx,sry,srz (default
    /// 0.174); `plan` takes it for every measurement it plans (it reads no sigma columns).
    #[arg(long, allow_negative_numbers = true, value_parser = super::bounds::sigma)]
    pub sigma_rot: Option<f64>,
}

impl SigmaArgs {
    /// A note for each sigma flag given that no row of `set` uses: every row carries its
    /// own sigma columns of that kind.
    pub fn unused(&self, set: &MeasurementSet) -> Vec<String> {
        let own = |f: fn(&robocal::data::Measurement) -> bool| set.rows.iter().all(f);
        [
            (self.sigma_pos.is_some() && own(|m| m.sigma_position.is_some()))
                .then_some("--sigma-pos is not used: every row carries its own position sigmas"),
            (self.sigma_rot.is_some() && own(|m| m.sigma_rotation.is_some()))
                .then_some("--sigma-rot is not used: every row carries its own orientation sigmas"),
        ]
        .into_iter()
        .flatten()
        .map(String::from)
        .collect()
    }

    /// The sigmas in internal units (mm, rad), defaults where not given.
    pub fn sigmas(&self) -> robocal::identify::Sigmas {
        let d = robocal::identify::Sigmas::default();
        robocal::identify::Sigmas {
            position_mm: self.sigma_pos.unwrap_or(d.position_mm),
            rotation_rad: self.sigma_rot.map_or(d.rotation_rad, |s| s * 1e-3),
        }
    }
}

/// Most reasons for dropped rows listed, on the terminal and in a report.
const SKIPPED_SHOWN: usize = 20;

/// The warnings of a read, each naming `path`; and for its dropped rows a heading with their
/// lines and the first [`SKIPPED_SHOWN`] reasons.
fn report_parts<'a>(
    path: &Path,
    report: &'a ReadReport,
) -> (Vec<String>, Option<(String, Vec<&'a str>)>) {
    let warnings = (report.warnings.iter())
        .map(|w| format!("{}: {w}", path.display()))
        .collect();
    let skipped = (!report.skipped.is_empty()).then(|| {
        let lines: Vec<usize> = report.skipped.iter().map(|(l, _)| *l).collect();
        let heading = format!(
            "{}: dropped {} bad row(s) (lines {})",
            path.display(),
            lines.len(),
            list_lines(&lines)
        );
        let why = (report.skipped.iter().take(SKIPPED_SHOWN))
            .map(|(_, w)| w.as_str())
            .collect();
        (heading, why)
    });
    (warnings, skipped)
}

/// What [`print_report`] prints, one line per warning and one for the dropped rows (their
/// reasons joined), for a JSON report.
fn report_lines(path: &Path, report: &ReadReport) -> Vec<String> {
    let (mut out, skipped) = report_parts(path, report);
    if let Some((heading, why)) = skipped {
        let more = if report.skipped.len() > SKIPPED_SHOWN {
            "; ..."
        } else {
            ""
        };
        out.push(format!("{heading}: {}{more}", why.join("; ")));
    }
    out
}

/// Prints warnings and dropped rows to stderr.
pub fn print_report(path: &Path, report: &ReadReport) {
    let (warnings, skipped) = report_parts(path, report);
    for w in warnings {
        eprintln!("warning: {w}");
    }
    if let Some((heading, why)) = skipped {
        eprintln!("warning: {heading}:");
        for w in why {
            eprintln!("  {w}");
        }
    }
}

/// The joints of a file read without a robot file (`import`, `split`): as many as the
/// profile names, else as many as `q1, q2, ...` head `input`'s columns; none is an error
/// naming the file. With a robot file, 0 (the robot says).
pub fn counted_joints(input: &Path, robot: Option<&PathBuf>, profile: &Profile) -> Result<usize> {
    Ok(match (robot, &profile.columns.joints) {
        (Some(_), _) => 0,
        (None, Some(j)) => j.len(),
        (None, None) => {
            let t = Table::read_with(input, profile.delimiter, profile.decimal_comma)?;
            let n = (1..)
                .take_while(|i| t.column(&format!("q{i}")).is_some())
                .count();
            if n == 0 {
                anyhow::bail!(
                    "{}: no joint columns q1, q2, ... (give --robot, or a profile that names \
                     them){}",
                    input.display(),
                    t.delimiter_hint()
                );
            }
            n
        }
    })
}

/// Reads an optional robot argument.
pub fn joints_of(robot: Option<&PathBuf>, fallback: usize) -> Result<Vec<JointInfo>> {
    Ok(match robot {
        Some(p) => JointInfo::of(&robocal::model::read_robot(p)?),
        None => JointInfo::revolute(fallback),
    })
}

/// The data of a fit on measurements, as [`open_fit`] reads them.
pub struct FitInputs {
    pub robot: Robot,
    pub data: MeasurementSet,
    pub validation: Option<MeasurementSet>,
    /// What the reads noticed (printed already), one line each, for a JSON report.
    pub read_warnings: Vec<String>,
}

/// Warns of rows of `set` (read from `path`) whose pair label no other row carries
/// ([`robocal::data::measurement::lone_pair_lines`]), which `import` and `split` write as
/// read: the relative and distance measures cannot use them.
pub(super) fn warn_lone_pairs(path: &Path, set: &robocal::data::MeasurementSet) {
    let lines = robocal::data::measurement::lone_pair_lines(set);
    if !lines.is_empty() {
        eprintln!(
            "warning: {}: {} row(s) carry a pair label no other row carries (lines {}): their \
             partner was dropped (a bad row) or is missing, and the relative and distance \
             measures cannot pair them; written as read",
            path.display(),
            lines.len(),
            robocal::data::measurement::list_lines(&lines)
        );
    }
}

/// The warning for validation rows (`val`, read from `val_path`) that are rows of the
/// training data too (`set`, from `data`): their figures are not held out. `kind` names the
/// rows (`validation`, `data`), `held` says when they are fitted ones (`train`'s validation
/// rows always; `evaluate`'s where the other file trained the model or the compensator).
pub(super) fn shared_rows_warning(
    val_path: &Path,
    val: &MeasurementSet,
    data: &Path,
    set: &MeasurementSet,
    (kind, held): (&str, &str),
) -> Option<String> {
    let lines = lines_also_in(val, set);
    if lines.is_empty() {
        return None;
    }
    let what = if lines.len() == val.rows.len() {
        format!(
            "every {kind} row ({}) is a row of {} too",
            lines.len(),
            data.display()
        )
    } else {
        format!(
            "{} of {} {kind} rows (lines {}) are rows of {} too",
            lines.len(),
            val.rows.len(),
            list_lines(&lines),
            data.display()
        )
    };
    Some(format!(
        "{}: {what}, the same joints and reading: {held}their figures are fitted ones, not \
         held out (split the rows with `robocal split` for a held-out check)",
        val_path.display()
    ))
}

/// The model and the data of a fit on measurements (`identify`, `train`), after refusing
/// outputs that name one of its inputs or each other ([`super::paths::guard`]).
pub fn open_fit(
    robot: &Path,
    data: &Path,
    validate: Option<&PathBuf>,
    read: &DataArgs,
    out: &Path,
    report: Option<&PathBuf>,
    plot: Option<&PathBuf>,
) -> Result<FitInputs> {
    use super::paths::{guard, opt, req};
    guard(
        &[
            req("--robot", robot),
            req("--data", data),
            opt("--validate", validate),
            opt("--profile", read.profile.as_ref()),
        ],
        &[
            req("--out", out),
            opt("--report", report),
            opt("--plot", plot),
        ],
    )?;
    let model = read_robot(robot)?;
    let joints = JointInfo::of(&model);
    let (set, mut read_warnings) = read.read_noted(data, &joints)?;
    let val = match validate {
        Some(p) => {
            let (v, w) = read.read_noted(p, &joints)?;
            read_warnings.extend(w);
            if let Some(w) = shared_rows_warning(p, &v, data, &set, ("validation", "")) {
                eprintln!("warning: {w}");
                read_warnings.push(w);
            }
            Some(v)
        }
        None => None,
    };
    Ok(FitInputs {
        robot: model,
        data: set,
        validation: val,
        read_warnings,
    })
}
