//! The one error of the `acq` commands, by kind: what a caller branches on,
//! and what the binary turns into the exit code scripts rely on (the one
//! mapping, in `src/main.rs`). A leaf: every stage's crate uses it, it uses
//! none of them.

use std::io;
use std::path::Path;

/// Why a command failed. A caller branches on the kind; the binary maps
/// it to the exit code (usage/configuration and an input that cannot be
/// opened 2, malformed input 3, interrupted 130, I/O 1).
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
    /// An input file that could not be opened (missing, unreadable): a
    /// usage error to the command line (exit 2), an `OSError` to Python.
    /// Boxed: every `Result` of acq carries this error, kept small.
    #[error("{0}")]
    Open(Box<OpenFailure>),
    /// Reading or writing failed.
    #[error("{context}: {source}")]
    Io {
        context: String,
        #[source]
        source: io::Error,
    },
}

impl AcqError {
    pub fn io(context: impl Into<String>, source: io::Error) -> Self {
        AcqError::Io {
            context: context.into(),
            source,
        }
    }

    /// A file that could not be opened is a usage error (exit 2), naming it.
    pub fn open(path: &Path, source: io::Error) -> Self {
        AcqError::Open(Box::new(OpenFailure {
            path: path.display().to_string(),
            source,
        }))
    }

    /// True when the reader of our output went away (`acq decode | head`):
    /// not a failure of ours.
    pub fn is_broken_pipe(&self) -> bool {
        matches!(self, AcqError::Io { source, .. } if source.kind() == io::ErrorKind::BrokenPipe)
    }
}

/// A file that could not be opened, and why.
#[derive(Debug, thiserror::Error)]
#[error("cannot open {path}: {source}")]
pub struct OpenFailure {
    /// The path as given, displayed.
    pub path: String,
    #[source]
    pub source: io::Error,
}

pub type Result<T, E = AcqError> = std::result::Result<T, E>;
