//! The progress line of a calibration on stderr: a bar redrawn in place on a
//! terminal, a plain line every tenth of the budget (and at the end)
//! otherwise, so CI logs stay short. A host may take the lines instead
//! ([`route_lines`]): the Python package hands them to `sys.stderr`, which
//! a notebook shows and the process's file descriptor 2 is not.

use std::io::{IsTerminal, Write};
use std::sync::{Mutex, RwLock};
use std::time::Instant;

/// Where a host wants the progress lines, each with its newline.
type LineSink = Box<dyn Fn(&str) + Send + Sync>;

/// Process-wide, as stderr itself is.
static LINES: RwLock<Option<LineSink>> = RwLock::new(None);

/// Sends every progress line to `sink` from now on (`None`: stderr again).
/// Routed lines are plain lines, never a bar redrawn in place.
pub fn route_lines(sink: Option<LineSink>) {
    if let Ok(mut lines) = LINES.write() {
        *lines = sink;
    }
}

fn routed() -> bool {
    LINES.read().is_ok_and(|lines| lines.is_some())
}

/// One plain line, to the host's sink or stderr.
fn print_line(line: &str) {
    match LINES.read() {
        Ok(lines) if lines.is_some() => {
            if let Some(sink) = lines.as_ref() {
                sink(&format!("{line}\n"));
            }
        }
        _ => eprintln!("{line}"),
    }
}

/// The numbers of the progress line, for a host that draws its own bar
/// (a notebook's).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ProgressSnapshot {
    pub done: usize,
    /// The evaluation budget (a study may end short of it).
    pub total: usize,
    pub failed: usize,
    /// Runs taken from the log of a resumed study.
    pub reused: usize,
    pub best_loss: Option<f64>,
    pub elapsed_s: f64,
}

/// Told of every evaluation, after the line's own numbers are updated.
pub type ProgressObserver<'a> = &'a (dyn Fn(&ProgressSnapshot) + Sync);

pub struct Progress<'a> {
    label: String,
    total: usize,
    terminal: bool,
    state: Mutex<State>,
    /// What the runs under way are doing (a cluster's job counts).
    status: Option<Box<dyn Fn() -> Option<String> + Sync + 'a>>,
    observer: Option<ProgressObserver<'a>>,
}

struct State {
    done: usize,
    failed: usize,
    reused: usize,
    best: Option<f64>,
    last_plain_decile: usize,
    /// `done` when the last plain line was printed.
    last_plain_done: usize,
    start: Instant,
}

impl<'a> Progress<'a> {
    /// `total` is the evaluation budget (the bar's 100 %).
    pub fn new(label: impl Into<String>, total: usize) -> Self {
        Progress {
            label: label.into(),
            total: total.max(1),
            terminal: !routed() && std::io::stderr().is_terminal(),
            state: Mutex::new(State {
                done: 0,
                failed: 0,
                reused: 0,
                best: None,
                last_plain_decile: 0,
                last_plain_done: 0,
                start: Instant::now(),
            }),
            status: None,
            observer: None,
        }
    }

    /// Tells `observer` of every evaluation too.
    pub fn with_observer(mut self, observer: Option<ProgressObserver<'a>>) -> Self {
        self.observer = observer;
        self
    }

    /// Adds `status` (when it says something) to every line.
    pub fn with_status(mut self, status: impl Fn() -> Option<String> + Sync + 'a) -> Self {
        self.status = Some(Box::new(status));
        self
    }

    /// One more evaluation; `loss` is its loss when it has one.
    pub fn record(&self, loss: Option<f64>, failed: bool, reused: bool) {
        let Ok(mut state) = self.state.lock() else {
            return;
        };
        state.done += 1;
        state.failed += usize::from(failed);
        state.reused += usize::from(reused);
        if let Some(loss) = loss.filter(|l| l.is_finite()) {
            state.best = Some(state.best.map_or(loss, |b| b.min(loss)));
        }
        if let Some(observer) = self.observer {
            observer(&ProgressSnapshot {
                done: state.done,
                total: self.total,
                failed: state.failed,
                reused: state.reused,
                best_loss: state.best,
                elapsed_s: state.start.elapsed().as_secs_f64(),
            });
        }
        let line = self.line(&state);
        if self.terminal {
            eprint!("\r{line}\x1b[K");
            let _ = std::io::stderr().flush();
        } else {
            let decile = state.done * 10 / self.total;
            if decile > state.last_plain_decile {
                state.last_plain_decile = decile;
                state.last_plain_done = state.done;
                print_line(&line);
            }
        }
    }

    fn line(&self, state: &State) -> String {
        const WIDTH: usize = 24;
        let filled = (state.done * WIDTH / self.total).min(WIDTH);
        let best = state
            .best
            .map_or_else(|| "-".to_string(), |b| format!("{b:.4}"));
        let status = self
            .status
            .as_ref()
            .and_then(|status| status())
            .map_or_else(String::new, |status| format!("; {status}"));
        format!(
            "{} [{}{}] {}/{} evaluations, best loss {best}, {} failed, {} from the log, {:.0} s{status}",
            self.label,
            "#".repeat(filled),
            " ".repeat(WIDTH - filled),
            state.done,
            self.total,
            state.failed,
            state.reused,
            state.start.elapsed().as_secs_f64()
        )
    }

    /// Redraws the line on a terminal, so that the status of runs under
    /// way (a cluster's pending and running jobs) stays current between
    /// evaluations. Does nothing elsewhere.
    pub fn redraw(&self) {
        if !self.terminal {
            return;
        }
        if let Ok(state) = self.state.lock() {
            eprint!("\r{}\x1b[K", self.line(&state));
            let _ = std::io::stderr().flush();
        }
    }

    /// Whether [`Progress::redraw`] draws anything.
    pub fn is_redrawn(&self) -> bool {
        self.terminal
    }

    /// Ends the bar's line on a terminal; elsewhere prints the final count
    /// unless it was the last line printed (the total is a budget, which a
    /// run may end short of).
    pub fn finish(&self) {
        if self.terminal {
            eprintln!();
        } else if let Ok(state) = self.state.lock() {
            if state.done > state.last_plain_done {
                print_line(&self.line(&state));
            }
        }
    }
}
