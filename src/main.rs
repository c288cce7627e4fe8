//! The `acq` binary: parses the command line and maps errors to exit codes.

use std::process::ExitCode;

mod cli;

fn main() -> ExitCode {
    let cli = cli::parse();
    match cli::run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(error) if error.is_broken_pipe() => ExitCode::SUCCESS,
        Err(error) => {
            eprintln!("acq: error: {error}");
            ExitCode::from(error.exit_code())
        }
    }
}
