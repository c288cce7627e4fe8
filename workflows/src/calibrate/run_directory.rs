//! A calibration's run directory and the evaluator that logs into it.

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use acq_calib::evaluation::{EvaluationError, Evaluator, Simulator};
use acq_io::error::{AcqError, Result};
use nix::sys::signal::{sigaction, SaFlags, SigAction, SigHandler, SigSet, Signal};

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

/// From now on Ctrl-C (SIGINT) or SIGTERM ends the run with exit code
/// 130 and says how to continue it: every finished evaluation is already
/// whole in `evaluations.csv`, so `--resume` picks up from there.
pub fn say_how_to_resume_on_interrupt(run_directory: &Path) {
    let message = format!(
        "\nacq: interrupted; every finished model run is in {}. Run the same command with --resume to continue without repeating one.\n",
        run_directory.join("evaluations.csv").display()
    );
    if INTERRUPT_MESSAGE.set(message.into_bytes()).is_err() {
        return; // installed already
    }
    let action = SigAction::new(
        SigHandler::Handler(on_interrupt),
        SaFlags::empty(),
        SigSet::empty(),
    );
    for signal in [Signal::SIGINT, Signal::SIGTERM] {
        // SAFETY: `on_interrupt` calls only async-signal-safe functions
        // (write(2), _exit(2)) and reads a OnceLock that was set before
        // the handler was installed and is never changed again.
        let previous = unsafe { sigaction(signal, &action) };
        // A signal the shell set to be ignored (a background job) stays ignored.
        if let Ok(previous) = previous {
            if matches!(previous.handler(), SigHandler::SigIgn) {
                // SAFETY: puts back the disposition that was there.
                let _ = unsafe { sigaction(signal, &previous) };
            }
        }
    }
}

/// What the interrupt handler writes, built before it is installed.
static INTERRUPT_MESSAGE: OnceLock<Vec<u8>> = OnceLock::new();

extern "C" fn on_interrupt(_signal: nix::libc::c_int) {
    if let Some(message) = INTERRUPT_MESSAGE.get() {
        // SAFETY: write(2) on stderr with a buffer that lives for the whole
        // program; the result is ignored (nothing else can be done here).
        let _ = unsafe {
            nix::libc::write(
                nix::libc::STDERR_FILENO,
                message.as_ptr().cast(),
                message.len(),
            )
        };
    }
    // SAFETY: _exit(2) is async-signal-safe and ends the process at once;
    // the evaluation log holds only whole, synced lines, so nothing is lost.
    unsafe { nix::libc::_exit(130) }
}

/// An engine error as the CLI reports it: a bad log or setup is a
/// configuration problem (exit 2), a failed write an I/O failure.
pub fn evaluation_error(error: EvaluationError) -> AcqError {
    match error {
        EvaluationError::Io { path, source } => AcqError::io(path.display().to_string(), source),
        other => AcqError::Config(other.to_string()),
    }
}

/// Cores to use for parallel evaluations by default.
pub fn default_parallelism() -> usize {
    std::thread::available_parallelism().map_or(1, |n| n.get())
}
