//! A study fed the holds as they close (`acq record --study`, `acq view
//! --study`). The view knows nothing of what the study computes: a worker
//! thread hands it every hold so far whenever the holds change, keeps the
//! newest panel it publishes, and the server shows that as `study` in
//! `/api/state`. The study's work never holds up the feed or the server:
//! the worker polls the sessions' hold versions and takes the holds by
//! copy.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use acq_analysis::extract::measured::MeasuredValue;
use serde_json::Value;

use crate::live::SharedSession;

/// What a study does with the holds.
pub trait HoldsStudy: Send + 'static {
    /// Every hold so far, in order, by name with its values; `publish`
    /// the panel (JSON for the page, lines for the terminal) after each
    /// step.
    fn update(
        &mut self,
        holds: &[(String, Vec<MeasuredValue>)],
        publish: &mut dyn FnMut(Value, &[String]),
    );
}

/// A closure is a study.
impl<F> HoldsStudy for F
where
    F: FnMut(&[(String, Vec<MeasuredValue>)], &mut dyn FnMut(Value, &[String])) + Send + 'static,
{
    fn update(
        &mut self,
        holds: &[(String, Vec<MeasuredValue>)],
        publish: &mut dyn FnMut(Value, &[String]),
    ) {
        self(holds, publish)
    }
}

/// The newest panel, shared with the server.
#[derive(Debug, Default)]
pub struct StudyPanel {
    /// `null` until the first panel.
    pub json: Value,
    /// A study update is under way.
    pub updating: bool,
    /// Counts panels.
    pub version: u64,
}

pub type SharedStudy = Arc<Mutex<StudyPanel>>;

/// How often the worker looks for changed holds.
const POLL: Duration = Duration::from_millis(100);

/// The study's nice value: on a CPU the recorder's readers need, a study
/// thread at nice 10 gets about a tenth of a reader's share, so the
/// recording never waits for the posterior (threads the study starts
/// inherit it). Raising one's own nice value needs no privilege.
pub const STUDY_NICE: i32 = 10;

/// Lowers the calling thread's priority to [`STUDY_NICE`]; a refusal
/// (a system without per-thread nice values) leaves it as it was.
fn yield_to_the_recorder() {
    let _ = rustix::process::setpriority_process(Some(rustix::thread::gettid()), STUDY_NICE);
}

/// The study's thread.
pub struct StudyWorker {
    panel: SharedStudy,
    stop: Arc<AtomicBool>,
    thread: Option<std::thread::JoinHandle<()>>,
}

fn lock<T>(mutex: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    mutex.lock().unwrap_or_else(|p| p.into_inner())
}

/// Every hold of `sessions` with its values, in order; with several
/// sessions each name is `session/hold`.
fn holds_of(sessions: &[SharedSession]) -> Vec<(String, Vec<MeasuredValue>)> {
    let several = sessions.len() > 1;
    let mut holds = Vec::new();
    for shared in sessions {
        let view = lock(shared);
        for hold in &view.holds {
            if let Some(values) = &hold.values {
                let name = if several {
                    format!("{}/{}", view.name, hold.name)
                } else {
                    hold.name.clone()
                };
                holds.push((name, values.clone()));
            }
        }
    }
    holds
}

impl StudyWorker {
    /// Starts the worker over `sessions`; `say` prints the panel's lines.
    pub fn start(
        mut study: Box<dyn HoldsStudy>,
        sessions: Vec<SharedSession>,
        say: Box<dyn Fn(&str) + Send>,
    ) -> StudyWorker {
        let panel: SharedStudy = Arc::default();
        let stop = Arc::new(AtomicBool::new(false));
        let thread = {
            let (panel, stop) = (panel.clone(), stop.clone());
            std::thread::Builder::new()
                .name("acq-study".into())
                .spawn(move || {
                    yield_to_the_recorder();
                    let mut seen: Option<Vec<u64>> = None;
                    loop {
                        // Read the flag before the versions: a stop asked
                        // after the last holds were set still sees them.
                        let stopping = stop.load(Ordering::SeqCst);
                        let versions: Vec<u64> =
                            sessions.iter().map(|s| lock(s).holds_version).collect();
                        if seen.as_ref() != Some(&versions) {
                            seen = Some(versions);
                            let holds = holds_of(&sessions);
                            lock(&panel).updating = true;
                            study.update(&holds, &mut |json, words| {
                                for line in words {
                                    say(line);
                                }
                                let mut panel = lock(&panel);
                                panel.json = json;
                                panel.version += 1;
                            });
                            lock(&panel).updating = false;
                            continue;
                        }
                        if stopping {
                            break;
                        }
                        std::thread::sleep(POLL);
                    }
                })
                .ok()
        };
        StudyWorker {
            panel,
            stop,
            thread,
        }
    }

    /// The panel the server shows.
    pub fn panel(&self) -> SharedStudy {
        self.panel.clone()
    }

    /// Brings the study up to the holds as they are now, then stops the
    /// thread; the last panel.
    pub fn finish(mut self) -> Value {
        self.stop.store(true, Ordering::SeqCst);
        if let Some(thread) = self.thread.take() {
            let _ = thread.join();
        }
        lock(&self.panel).json.clone()
    }
}

impl Drop for StudyWorker {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::SeqCst);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The study runs below the recorder: its thread, and a thread it
    /// starts (as the sampler's chains are), at nice STUDY_NICE while the
    /// caller's stays as it was.
    #[test]
    fn the_study_and_its_threads_run_below_the_recorder() {
        let nice = || rustix::process::getpriority_process(Some(rustix::thread::gettid())).unwrap();
        let caller = nice();
        let study = move |_: &[(String, Vec<MeasuredValue>)],
                          publish: &mut dyn FnMut(Value, &[String])| {
            let chain = std::thread::spawn(nice).join().unwrap();
            publish(serde_json::json!([nice(), chain]), &[]);
        };
        let worker = StudyWorker::start(Box::new(study), Vec::new(), Box::new(|_| {}));
        let panel = worker.finish();
        let expected = STUDY_NICE.max(caller);
        assert_eq!(panel, serde_json::json!([expected, expected]));
        assert_eq!(nice(), caller, "the caller's priority is its own");
    }
}
