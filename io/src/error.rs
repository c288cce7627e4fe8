//! Errors of the `acq` commands, each with the exit code scripts rely on.

use std::io;
use std::path::Path;

/// Why a command failed. The variant decides the exit code:
/// usage/configuration 2, malformed input 3, anything else (I/O) 1.
#[derive(Debug, thiserror::Error)]
pub enum AcqError {
    /// Bad command line or configuration (rig, DBC, missing file).
    #[error("{0}")]
    Config(String),
    /// Input data that is not what its format says (`file:line: expected ...`).
    #[error("{0}")]
    Malformed(String),
    /// Stopped by Ctrl-C (or SIGTERM) after leaving its files whole.
    #[error("{0}")]
    Interrupted(String),
    /// Reading or writing failed.
    #[error("{context}: {source}")]
    Io {
        context: String,
        #[source]
        source: io::Error,
    },
}

impl AcqError {
    pub const EXIT_FAILURE: u8 = 1;
    pub const EXIT_CONFIG: u8 = 2;
    pub const EXIT_MALFORMED: u8 = 3;
    /// 128 + SIGINT, what a shell reports for a command stopped by Ctrl-C.
    pub const EXIT_INTERRUPTED: u8 = 130;

    pub fn exit_code(&self) -> u8 {
        match self {
            AcqError::Config(_) => Self::EXIT_CONFIG,
            AcqError::Malformed(_) => Self::EXIT_MALFORMED,
            AcqError::Interrupted(_) => Self::EXIT_INTERRUPTED,
            AcqError::Io { .. } => Self::EXIT_FAILURE,
        }
    }

    pub fn io(context: impl Into<String>, source: io::Error) -> Self {
        AcqError::Io {
            context: context.into(),
            source,
        }
    }

    /// A file that could not be opened is a usage error (exit 2), naming it.
    pub fn open(path: &Path, source: io::Error) -> Self {
        AcqError::Config(format!("cannot open {}: {source}", path.display()))
    }

    /// True when the reader of our output went away (`acq decode | head`):
    /// not a failure of ours.
    pub fn is_broken_pipe(&self) -> bool {
        matches!(self, AcqError::Io { source, .. } if source.kind() == io::ErrorKind::BrokenPipe)
    }
}

pub type Result<T, E = AcqError> = std::result::Result<T, E>;
