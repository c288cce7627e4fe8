//! Ctrl-C and SIGTERM. A recording stops cleanly and the page stops
//! serving; a calibration runs the library's interrupt hooks (a cluster
//! executor cancels its jobs), says how to resume and exits with 130.
//! Signals and process exits belong to the binary: the libraries take a
//! future that resolves when they should stop.

use std::path::Path;
use std::sync::OnceLock;
use std::time::Duration;

use acq_acquire::record::StopReason;

use acq_exec::interrupt::run_interrupt_hooks;
use nix::sys::signal::Signal;

/// From now on Ctrl-C (SIGINT) or SIGTERM ends the run with exit code
/// 130 and says how to continue it: every finished evaluation is already
/// whole in `evaluations.csv`, so `--resume` picks up from there. Before
/// that, the library's interrupt hooks run.
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
            run_interrupt_hooks();
            eprintln!("{message}");
            std::process::exit(130);
        });
        if signals.next().is_some() {
            std::process::exit(130);
        }
    });
}

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

/// Resolves when SIGINT or SIGTERM arrives, or the duration is reached:
/// the stop of `acq record`. The signals are caught from the call on, not
/// from the first poll: a caller that says "Ctrl-C to stop" after calling
/// it never lets a Ctrl-C kill the process before it listens.
pub fn stop_on_signal_or(
    duration: Option<Duration>,
) -> impl std::future::Future<Output = StopReason> + Send + 'static {
    let signal = signal_arrival();
    async move {
        let timeout = async {
            match duration {
                Some(d) => tokio::time::sleep(d).await,
                None => std::future::pending().await,
            }
        };
        tokio::select! {
            name = signal => StopReason::Signal(name),
            _ = timeout => StopReason::Duration,
        }
    }
}

/// Resolves when SIGINT or SIGTERM arrives: the stop of the page. Caught
/// from the call on, as [`stop_on_signal_or`].
pub fn interrupted() -> impl std::future::Future<Output = ()> + Send + 'static {
    let stop = stop_on_signal_or(None);
    async move {
        stop.await;
    }
}

/// The name of the first SIGINT or SIGTERM after the call. The handlers
/// are in place when this returns (signal-hook registers them at once; a
/// tokio signal stream would only on its first poll); a thread of its own
/// waits for the signal, so no runtime is needed to call it.
fn signal_arrival() -> impl std::future::Future<Output = &'static str> + Send + 'static {
    let (arrived, arrival) = tokio::sync::oneshot::channel();
    match signal_hook::iterator::Signals::new([Signal::SIGINT as i32, Signal::SIGTERM as i32]) {
        Ok(mut signals) => {
            std::thread::spawn(move || {
                if let Some(signal) = signals.forever().next() {
                    let name = if signal == Signal::SIGINT as i32 {
                        "SIGINT"
                    } else {
                        "SIGTERM"
                    };
                    let _ = arrived.send(name);
                }
            });
        }
        // Without signal handlers Ctrl-C would kill us mid-write; the sender
        // is dropped and the stop never comes, rather than risking it.
        Err(_) => drop(arrived),
    }
    async move {
        match arrival.await {
            Ok(name) => name,
            Err(_) => std::future::pending().await,
        }
    }
}
