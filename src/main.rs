//! The `robocal` command line: a thin layer over the library (argument parsing, progress
//! bars, printing); see `robocal --help`.

mod cli;

fn main() -> std::process::ExitCode {
    cli::main()
}
