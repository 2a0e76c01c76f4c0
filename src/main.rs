fn main() -> std::process::ExitCode {
    robocal::cli::main()
}
