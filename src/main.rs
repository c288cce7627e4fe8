//! The `acq` binary: parses the command line and maps errors to exit codes.

use std::process::ExitCode;

use acq_error::AcqError;

mod cli;

fn main() -> ExitCode {
    let cli = cli::parse();
    match cli::run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(error) if error.is_broken_pipe() => ExitCode::SUCCESS,
        Err(error) => {
            eprintln!("acq: error: {error}");
            ExitCode::from(exit_code(&error))
        }
    }
}

/// The exit code of a failed command, by the error's kind: the one place
/// it is chosen (the `after_help` of `acq --help` states it).
fn exit_code(error: &AcqError) -> u8 {
    match error {
        AcqError::Io { .. } => 1,
        AcqError::Config(_) | AcqError::Open(_) => 2,
        AcqError::Malformed(_) => 3,
        // 128 + SIGINT, what a shell reports for a command stopped by Ctrl-C.
        AcqError::Interrupted(_) => 130,
    }
}
