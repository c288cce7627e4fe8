//! Work to do before acq stops on Ctrl-C or SIGTERM: a cluster executor
//! cancels the jobs it submitted. The program that takes the signal runs
//! the hooks, then ends.

use std::sync::Mutex;

/// Runs `hook` when the run is interrupted (Ctrl-C, SIGTERM), before acq
/// exits: a cluster executor cancels the jobs it submitted. The program
/// that takes the signal calls [`run_interrupt_hooks`].
pub fn on_interrupt(hook: impl FnOnce() + Send + 'static) {
    INTERRUPT_HOOKS
        .lock()
        .unwrap_or_else(|p| p.into_inner())
        .push(Box::new(hook));
}

/// Runs (once) every hook given to [`on_interrupt`]; the caller then ends
/// the run. Every finished evaluation is already whole in
/// `evaluations.csv`, so the same command with `--resume` picks up there.
pub fn run_interrupt_hooks() {
    let hooks = std::mem::take(&mut *INTERRUPT_HOOKS.lock().unwrap_or_else(|p| p.into_inner()));
    for hook in hooks {
        hook();
    }
}

type InterruptHook = Box<dyn FnOnce() + Send>;
static INTERRUPT_HOOKS: Mutex<Vec<InterruptHook>> = Mutex::new(Vec::new());
