//! Why a study stopped, as a type a caller can match: a study at the rig
//! (or a script) may go on when every run failed, but not when its files
//! cannot be written. Each converts into the [`AcqError`] the command
//! reports, with the same message and exit code as before.

use std::path::PathBuf;

use acq_error::AcqError;

/// Why a study run ended without a calibration.
#[derive(Debug, thiserror::Error)]
pub enum StudyError {
    /// Every model run failed: the model, not the search, needs fixing.
    #[error("none of the {runs} model runs succeeded; the first failed with: {first_reason}. Each run's stdout.txt and stderr.txt are in {}, every reason in {}", runs_directory.display(), log.display())]
    NoRunSucceeded {
        runs: usize,
        first_reason: String,
        runs_directory: PathBuf,
        log: PathBuf,
    },
    /// The model runs at the calibrated point for the fit cases, but not
    /// for the validation cases.
    #[error("the model fails on the validation cases at the calibrated parameters: {reason}")]
    ValidationFailed { reason: String },
    /// A file of the run directory or its log that could not be read or
    /// written, or settings the engine refused: as the command reports it.
    #[error(transparent)]
    Command(#[from] AcqError),
}

impl From<StudyError> for AcqError {
    fn from(error: StudyError) -> Self {
        match error {
            StudyError::Command(error) => error,
            other => AcqError::Config(other.to_string()),
        }
    }
}
