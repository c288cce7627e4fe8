//! A calibration's run directory and the evaluator that logs into it.

use std::path::{Path, PathBuf};
use std::sync::{Mutex, OnceLock};

use acq_calib::evaluation::{EvaluationError, Evaluator, Simulator};
use acq_io::error::{AcqError, Result};
use nix::sys::signal::Signal;

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

/// From now on Ctrl-C (SIGINT) or SIGTERM ends the run with exit code
/// 130 and says how to continue it: every finished evaluation is already
/// whole in `evaluations.csv`, so `--resume` picks up from there. Before
/// that, the hooks of [`on_interrupt`] run (a cluster executor cancels
/// the jobs it submitted).
///
/// The signal is taken by a thread of its own (signal-hook's self-pipe),
/// not in a handler, so the hooks may start programs (`scancel`).
pub fn say_how_to_resume_on_interrupt(run_directory: &Path) {
    let message = format!(
        "\nacq: interrupted; every finished model run is in {}. Run the same command with --resume to continue without repeating one.",
        run_directory.join("evaluations.csv").display()
    );
    if INTERRUPT_WATCHER.set(()).is_err() {
        return; // installed already
    }
    // A signal the shell set to be ignored (a background job) stays ignored.
    let wanted: Vec<i32> = [Signal::SIGINT, Signal::SIGTERM]
        .into_iter()
        .filter(|&signal| !is_ignored(signal))
        .map(|signal| signal as i32)
        .collect();
    let Ok(mut signals) = signal_hook::iterator::Signals::new(&wanted) else {
        return;
    };
    std::thread::spawn(move || {
        let mut signals = signals.forever();
        if signals.next().is_none() {
            return;
        }
        // The hooks (scancel) may hang on a cluster that does not answer:
        // a second Ctrl-C ends acq at once.
        std::thread::spawn(move || {
            eprintln!("\nacq: stopping (Ctrl-C again to stop at once)");
            let hooks =
                std::mem::take(&mut *INTERRUPT_HOOKS.lock().unwrap_or_else(|p| p.into_inner()));
            for hook in hooks {
                hook();
            }
            eprintln!("{message}");
            std::process::exit(130);
        });
        if signals.next().is_some() {
            std::process::exit(130);
        }
    });
}

/// Runs `hook` when the run is interrupted (Ctrl-C, SIGTERM), before acq
/// exits; see [`say_how_to_resume_on_interrupt`].
pub fn on_interrupt(hook: impl FnOnce() + Send + 'static) {
    INTERRUPT_HOOKS
        .lock()
        .unwrap_or_else(|p| p.into_inner())
        .push(Box::new(hook));
}

type InterruptHook = Box<dyn FnOnce() + Send>;
static INTERRUPT_HOOKS: Mutex<Vec<InterruptHook>> = Mutex::new(Vec::new());
static INTERRUPT_WATCHER: OnceLock<()> = OnceLock::new();

/// Whether `signal` is ignored (by the shell that started acq).
fn is_ignored(signal: Signal) -> bool {
    let mut current = std::mem::MaybeUninit::<nix::libc::sigaction>::zeroed();
    // SAFETY: sigaction(2) with a null new action only reads the current
    // one into `current`, a zeroed sigaction struct it may overwrite.
    let read =
        unsafe { nix::libc::sigaction(signal as i32, std::ptr::null(), current.as_mut_ptr()) };
    // SAFETY: a zeroed sigaction is a valid value, filled in when `read` is 0.
    let current = unsafe { current.assume_init() };
    read == 0 && current.sa_sigaction == nix::libc::SIG_IGN
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
