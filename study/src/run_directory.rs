//! A calibration's run directory and the evaluator that logs into it.

use std::path::{Path, PathBuf};

use acq_algorithms::evaluation::{EvaluationError, Evaluator, Simulator};
use acq_error::{AcqError, Result};

/// The run directory: created if missing; `evaluations.csv` in it must be
/// new unless the run resumes.
pub struct RunDirectory {
    pub path: PathBuf,
}

impl RunDirectory {
    pub fn create(path: &Path) -> Result<Self> {
        acq_io::output::create_dir(path)?;
        Ok(RunDirectory {
            path: path.to_path_buf(),
        })
    }

    pub fn file(&self, name: &str) -> PathBuf {
        self.path.join(name)
    }

    /// The evaluator logging to `evaluations.csv` here.
    pub fn evaluator<'a>(
        &self,
        simulator: &'a dyn Simulator,
        parallel: usize,
        resume: bool,
    ) -> Result<Evaluator<'a>> {
        let log = self.file("evaluations.csv");
        let evaluator = if resume {
            Evaluator::resume(simulator, &log, parallel)
        } else {
            Evaluator::create(simulator, &log, parallel)
        };
        evaluator.map_err(evaluation_error)
    }
}

/// Writes a whole file: it appears under its name only when complete
/// ([`acq_io::output::Output::write_complete`]).
pub fn write_text(path: &Path, text: &str) -> Result<()> {
    acq_io::output::Output::write_complete(path, text.as_bytes())
}

/// An engine error as the CLI reports it: a bad log or setup is a
/// configuration problem (exit 2), a failed write an I/O failure.
pub fn evaluation_error(error: EvaluationError) -> AcqError {
    match error {
        EvaluationError::Io { path, source } => AcqError::io(path.display().to_string(), source),
        EvaluationError::Stopped => AcqError::Interrupted(EvaluationError::Stopped.to_string()),
        other => AcqError::Config(other.to_string()),
    }
}

/// Cores to use for parallel evaluations by default.
pub fn default_parallelism() -> usize {
    std::thread::available_parallelism().map_or(1, |n| n.get())
}
