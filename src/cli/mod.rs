//! The `robocal` command line: a thin layer over the library.

mod fk;
mod ik;
mod output;

use clap::{Parser, Subcommand};
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
}

/// Runs the command line; errors are printed with their context and give exit code 1.
pub fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Fk(a) => fk::run(a),
        Command::Ik(a) => ik::run(a),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::from(1)
        }
    }
}
