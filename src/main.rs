//! The `volasso` binary: parses the command line, runs it, reports the one error.
fn main() -> std::process::ExitCode {
    volasso::cli::main()
}
