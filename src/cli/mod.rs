//! The `robocal` command line: a thin layer over the library.

use std::sync::atomic::{AtomicBool, Ordering};

/// Set when one of the command's outputs is this process's standard output (`--out
/// /dev/stdout`, or `--out F > F`): the summary lines then go to standard error, so that the
/// output holds the file's bytes alone and reads back.
static SUMMARY_ON_STDERR: AtomicBool = AtomicBool::new(false);

/// Whether [`say!`] writes to standard error ([`SUMMARY_ON_STDERR`]).
fn summary_on_stderr() -> bool {
    SUMMARY_ON_STDERR.load(Ordering::Relaxed)
}

/// `println!` for a command's summary lines: to standard output, or to standard error where an
/// output file is standard output ([`SUMMARY_ON_STDERR`]); a line that cannot be written is
/// kept as the command's failure ([`SUMMARY_LOST`]), not a panic.
macro_rules! say {
    ($($arg:tt)*) => {
        $crate::cli::say_line(format_args!($($arg)*))
    };
}

/// A summary line that says an output was written ("wrote X", "plots: N pictures in D"): held
/// until every output is in place ([`robocal::io::all_or_nothing`]) and printed then, so that
/// a later error, which discards every output, does not follow a "wrote" that is no longer
/// true. In order, after the command's other lines.
macro_rules! told_after {
    ($($arg:tt)*) => {
        $crate::cli::hold_line(false, format!($($arg)*))
    };
}

/// [`told_after!`] for a line of standard error (the commands whose standard output can be
/// their data: split, simulate, import).
macro_rules! told_after_on_stderr {
    ($($arg:tt)*) => {
        $crate::cli::hold_line(true, format!($($arg)*))
    };
}

/// A flag's value refused after parsing (out of its range, or against another flag): a usage
/// error, which ends the command with code 2 as clap's own do ([`Usage`]).
macro_rules! usage {
    ($($arg:tt)*) => {
        return Err(anyhow::Error::new($crate::cli::Usage(format!($($arg)*))))
    };
}

/// A usage error found after parsing ([`usage!`]): exit code 2, as clap's.
#[derive(Debug)]
pub struct Usage(pub String);

impl std::fmt::Display for Usage {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for Usage {}

/// The lines of [`told_after!`]: whether each goes to standard error, and its text.
static HELD: std::sync::Mutex<Vec<(bool, String)>> = std::sync::Mutex::new(Vec::new());

/// Holds one line until the outputs are in place ([`told_after!`]).
fn hold_line(stderr: bool, line: String) {
    HELD.lock()
        .unwrap_or_else(|p| p.into_inner())
        .push((stderr, line));
}

/// Prints the held lines ([`told_after!`]), in order; where the command failed they are
/// dropped (the error says what was kept).
fn print_held(printed: bool) {
    let held = std::mem::take(&mut *HELD.lock().unwrap_or_else(|p| p.into_inner()));
    if !printed {
        return;
    }
    for (stderr, line) in held {
        if stderr {
            eprintln!("{line}");
        } else {
            say_line(format_args!("{line}"));
        }
    }
}

/// The first failure to write a summary line to standard output ([`say!`]): a full device, a
/// closed pipe. The command goes on (its output files are whole and written as usual) and
/// ends with it ([`summary_failure`]) rather than with a panic halfway.
static SUMMARY_LOST: std::sync::Mutex<Option<std::io::Error>> = std::sync::Mutex::new(None);

/// One summary line ([`say!`]).
fn say_line(args: std::fmt::Arguments) {
    if summary_on_stderr() {
        eprintln!("{args}");
        return;
    }
    use std::io::Write;
    let mut out = std::io::stdout().lock();
    if let Err(e) = writeln!(out, "{args}").and_then(|()| out.flush()) {
        let mut lost = SUMMARY_LOST.lock().unwrap_or_else(|p| p.into_inner());
        lost.get_or_insert(e);
    }
}

/// How a command whose summary could not be written ends: quietly with the shell's code for
/// a closed pipe (128 + 13, as `robocal ... | head`), else with the error and code 1.
fn summary_failure() -> Option<ExitCode> {
    let lost = SUMMARY_LOST
        .lock()
        .unwrap_or_else(|p| p.into_inner())
        .take()?;
    if lost.kind() == std::io::ErrorKind::BrokenPipe {
        return Some(ExitCode::from(141));
    }
    eprintln!(
        "error: writing the summary to standard output: {lost} (the output files, if any, were \
         written whole)"
    );
    Some(ExitCode::from(1))
}

mod bounds;
mod case_d;
mod choices;
mod compensate;
mod compensator_args;
mod data_args;
mod evaluate;
mod fk;
mod identify;
mod ik;
mod import;
mod interrupt;
mod output;
mod paths;
mod plan;
mod plan_study;
mod predict;
mod report;
mod reproduce;
mod simulate;
mod split;
mod summary;
mod train;
mod unchecked;
mod warnings;

use clap::{CommandFactory, FromArgMatches, Parser, Subcommand};
use std::process::ExitCode;

#[derive(Parser)]
#[command(
    name = "robocal",
    version,
    about = "Kinematic calibration of industrial robots (mm, degrees)"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Forward kinematics: tool pose (x, y, z mm; rz, ry, rx deg, R = Rz Ry Rx) for joints.
    Fk(fk::FkArgs),
    /// Inverse kinematics: joints (deg) for a tool pose.
    Ik(ik::IkArgs),
    /// Converts a foreign measurement export to canonical CSV through an import profile.
    Import(import::ImportArgs),
    /// Simulates measurements of a virtual robot (deviations, non-geometric errors, noise).
    Simulate(simulate::SimulateArgs),
    /// Splits measurements at random (seeded) into two files, e.g. calibration and validation.
    Split(split::SplitArgs),
    /// Identifies kinematic parameters from measurements and writes the calibrated robot.
    Identify(identify::IdentifyArgs),
    /// Reports the accuracy of a robot model on measurements.
    Evaluate(evaluate::EvaluateArgs),
    /// Reproduces the thesis's case studies A-D (identification) beside the thesis's figures.
    Reproduce(reproduce::ReproduceArgs),
    /// Trains a neural compensator (the model and a network in series: MLPs, an RBF network
    /// or both) on measurements.
    Train(train::TrainArgs),
    /// Compensated tool poses for joint configurations.
    Predict(predict::PredictArgs),
    /// Fake targets: joints at which the calibrated (compensated) robot reaches each desired
    /// pose, and the nominal pose an unmodified controller must be given for them.
    ///
    /// Targets are in the calibrated model's world frame (the tracker's, where `identify`
    /// registered it). The residual_mm, residual_deg and written_miss columns, errors of a
    /// solve, keep 9 decimals whatever --decimals says.
    Compensate(compensate::CompensateArgs),
    /// One self-contained HTML page (tables and pictures) from a run folder.
    Report(report::ReportArgs),
    /// Thesis Case D end to end (Table 6.6) and the non-geometric robot, beside the thesis.
    CaseD(case_d::CaseDArgs),
    /// Plans the measurements: the configurations that identify the robot best, and the
    /// accuracy they will give, before measuring.
    Plan(plan::PlanArgs),
    /// Planned against random configurations on simulated robots over seeds: the error each
    /// leaves after identification, and the prediction made before measuring.
    PlanStudy(plan_study::PlanStudyArgs),
}

/// Exit code of `compensate` when some targets have no command, and of `ik --poses` when some
/// poses have no solution (the others are written).
pub const EXIT_SOME_TARGETS_FAILED: u8 = 3;

/// Runs the command line; errors are printed with their context and give exit code 1 (2 for
/// a usage error, from clap; [`EXIT_SOME_TARGETS_FAILED`] from `compensate` and `ik`). A command's
/// output files appear together when it succeeds, and none of them when it fails.
pub fn main() -> ExitCode {
    quiet_on_closed_stdout();
    interrupt::clean_up_on_interrupt();
    let matches = Cli::command().get_matches();
    let mut cli = Cli::from_arg_matches(&matches).unwrap_or_else(|e| e.exit());
    if let Some((_, m)) = matches.subcommand() {
        // Which flags were given, for the checks that refuse a flag with a default.
        let given: Vec<String> = m
            .ids()
            .filter(|id| {
                m.value_source(id.as_str()) == Some(clap::parser::ValueSource::CommandLine)
            })
            .map(|id| id.to_string())
            .collect();
        match &mut cli.command {
            Command::Train(a) => a.build.given = given,
            Command::CaseD(a) => a.build.given = given,
            _ => {}
        }
    }
    let mut code = ExitCode::SUCCESS;
    let result = robocal::io::all_or_nothing(|| match cli.command {
        Command::Fk(a) => fk::run(a),
        Command::Plan(a) => plan::run(a),
        Command::PlanStudy(a) => plan_study::run_study(a),
        Command::Ik(a) => ik::run(a).map(|failed| {
            if failed {
                code = ExitCode::from(EXIT_SOME_TARGETS_FAILED);
            }
        }),
        Command::Import(a) => import::run(a),
        Command::Simulate(a) => simulate::run(a),
        Command::Split(a) => split::run(a),
        Command::Identify(a) => identify::run_identify(a),
        Command::Evaluate(a) => evaluate::run_evaluate(a),
        Command::Reproduce(a) => reproduce::run(a),
        Command::Train(a) => train::run_train(a),
        Command::Predict(a) => predict::run_predict(a),
        Command::Compensate(a) => compensate::run(a).map(|failed| {
            if let Some(msg) = failed {
                eprintln!("warning: {msg}");
                code = ExitCode::from(EXIT_SOME_TARGETS_FAILED);
            }
        }),
        Command::Report(a) => report::run(a),
        Command::CaseD(a) => case_d::run_case_d(a),
    });
    print_held(result.is_ok());
    match result {
        Ok(()) => summary_failure().unwrap_or(code),
        Err(e) => {
            // `robocal fk ... | head`: the reader has what it wanted; ended as a closed pipe
            // ends a summary line ([`summary_failure`]), quietly with 128 + SIGPIPE, but for
            // the files written before it.
            let closed = closed_pipe(&e);
            if !closed {
                eprintln!("error: {}", capped(&format!("{e:#}")));
            }
            let n = robocal::io::discarded_outputs();
            let kept = robocal::io::kept_outputs();
            if !kept.is_empty() {
                let names: Vec<String> = kept.iter().map(|p| p.display().to_string()).collect();
                let when = if closed {
                    "before its pipe's reader closed"
                } else {
                    "before it failed"
                };
                eprintln!(
                    "note: {} output(s) had been written, complete, {when}: {}{}",
                    kept.len(),
                    capped(&names.join(", ")),
                    if n > 0 {
                        format!(" ({n} other(s) discarded)")
                    } else {
                        String::new()
                    }
                );
            } else if n > 0 {
                eprintln!(
                    "note: no output file was written ({n} prepared before the error were discarded)"
                );
            }
            let usage = e.chain().any(|c| c.is::<Usage>());
            ExitCode::from(match (closed, usage) {
                (true, _) => 141,
                (false, true) => 2,
                (false, false) => 1,
            })
        }
    }
}

/// Whether `e` is a write into a pipe its reader closed (an [`std::io::Error`] of kind
/// `BrokenPipe` anywhere in its chain, also as the library's [`robocal::error::Error::Io`]).
fn closed_pipe(e: &anyhow::Error) -> bool {
    e.chain().any(|c| {
        let io = c.downcast_ref::<std::io::Error>().or_else(|| {
            match c.downcast_ref::<robocal::error::Error>() {
                Some(robocal::error::Error::Io { cause, .. }) => Some(cause),
                _ => None,
            }
        });
        io.is_some_and(|io| io.kind() == std::io::ErrorKind::BrokenPipe)
    })
}

/// `robocal ... | head` closes our stdout early; Rust's `println!` then panics (and
/// `eprintln!` with `2>&1`, or where [`say!`] prints on standard error). End quietly with the
/// shell's code for SIGPIPE (128 + 13) instead of printing a panic.
fn quiet_on_closed_stdout() {
    let default = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| {
        let msg = info
            .payload()
            .downcast_ref::<String>()
            .map(String::as_str)
            .or_else(|| info.payload().downcast_ref::<&str>().copied())
            .unwrap_or("");
        let printing =
            msg.contains("failed printing to stdout") || msg.contains("failed printing to stderr");
        if printing && msg.contains("Broken pipe") {
            // Exiting skips the transaction's own clean-up: its temporary files and the
            // folders it made go first.
            robocal::io::abandon();
            std::process::exit(141);
        }
        default(info);
    }));
}

/// A message of at most [`MAX_MESSAGE`] characters: a megabyte of header, key or cell is
/// cut, with the length said, not echoed whole.
fn capped(msg: &str) -> String {
    let n = msg.chars().count();
    if n <= MAX_MESSAGE {
        return msg.to_string();
    }
    let head: String = msg.chars().take(MAX_MESSAGE).collect();
    format!("{head}... (cut: the message has {n} characters)")
}

/// The longest error message printed whole (characters).
const MAX_MESSAGE: usize = 2000;
