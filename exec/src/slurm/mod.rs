//! Model runs as Slurm batch jobs: one `sbatch --parsable` per run.
//!
//! Each run's directory gets a job script, `job.sh`, kept for the user
//! (`sbatch job.sh` in that directory runs the same solver again). It runs
//! the prelude lines (`module load abaqus`), then the solver's argv with
//! every word quoted (no shell expansion), and writes the solver's exit
//! status to `exit_status` (through a rename, so it is whole when seen) and
//! its start time to `started_at`. A job Slurm signals writes no status:
//! what the solver returned after the signal says nothing of the run. The job id goes to `slurm_job_id` the
//! moment `sbatch` answers.
//!
//! A run has ended when `exit_status` appears (polled every 50 ms) or when
//! Slurm says the job ended without one (cancelled, timed out, node
//! failure). Job states come from `squeue` (one call for all of acq's jobs,
//! at most once a second); no accounting database is needed. acq's own
//! timeout counts from the job's start, not its submission: a job waiting
//! in the queue is not slow. What the cluster does to a job:
//! - a non-zero exit: a failed run, with the end of its stderr;
//! - cancelled by someone else, or Slurm's time limit: a failed run, with
//!   the state;
//! - requeued (by an admin, or preempted with requeue): Slurm runs it
//!   again; acq waits for the rerun and says so;
//! - preempted (cancel mode), node failure, boot failure: the cluster's
//!   fault, not the solver's; submitted again, at most twice;
//! - a drained node: the job waits, and the progress line says why.
//!
//! On acq's timeout, Ctrl-C or SIGTERM, acq `scancel`s the jobs it
//! submitted, by id, and nothing else. After SIGKILL the jobs run on; a
//! `--resume` finds their ids in the run directories and re-attaches
//! (collecting those that finished meanwhile) instead of submitting again.
//!
//! - [`client`]: the Slurm commands (`squeue`, `scancel`, `scontrol`);
//! - [`job_files`]: the job script and the files a job leaves.

use std::collections::{BTreeMap, HashMap};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant, UNIX_EPOCH};

use self::client::{
    cancel, is_stuck, query, scontrol_job, slurm_command, slurm_exit_code, JobState,
};
use self::job_files::{
    job_script, now_s, read_exit_status, read_number, read_start, write_whole, CANCELLED_BY_ACQ,
    EXIT_STATUS, JOB_ID, JOB_SCRIPT, STARTED_AT, STATUS_GRACE, SUBMITTED_AT,
};
use crate::executor::{end_of_stderr, Execution, Executor, Job};

mod client;
mod job_files;

/// The user's `[executor]` options for Slurm.
#[derive(Clone, Debug, Default)]
pub struct SlurmSettings {
    pub partition: Option<String>,
    pub account: Option<String>,
    /// Slurm's format (`30`, `1:30:00`, `2-00:00:00`) [default: acq's
    /// timeout rounded up to whole minutes, plus one].
    pub time_limit: Option<String>,
    pub cpus_per_job: Option<u32>,
    /// Slurm's `--mem` format (`4G`).
    pub memory_per_job: Option<String>,
    /// More `sbatch` arguments, as given.
    pub sbatch_args: Vec<String>,
    /// Shell lines run before the solver in the job script.
    pub prelude: Vec<String>,
}

/// How often a waiting run looks for its exit status file.
const FILE_POLL: Duration = Duration::from_millis(50);
/// How often `squeue` is asked (one call for all jobs).
const QUEUE_POLL: Duration = Duration::from_millis(500);
/// Times a job the cluster lost (node failure, preemption) is submitted
/// again before the run is failed.
const RESUBMISSIONS: u32 = 2;
/// Successful `squeue` answers without a job before it counts as gone
/// (a shared file system may show its exit status a moment late).
const GONE_AFTER_POLLS: u32 = 4;
/// When a scancel for acq's timeout has not ended the job, it is sent again.
const CANCEL_AGAIN: Duration = Duration::from_secs(10);

/// acq's jobs still in Slurm, by id.
type LiveJobs = BTreeMap<u64, LiveJob>;

struct LiveJob {
    phase: Phase,
    directory: PathBuf,
}

#[derive(Clone, Debug, PartialEq)]
enum Phase {
    Pending(String),
    Running,
}

/// The latest `squeue` answer, shared by every waiting run.
#[derive(Default)]
struct QueueView {
    asked: Option<Instant>,
    /// `None` when the last call failed (no news: nothing is concluded).
    states: Option<HashMap<u64, JobState>>,
    /// Successful answers in a row that did not list a job.
    missing: HashMap<u64, u32>,
}

/// Forgets the job a run directory holds once it has ended (its exit
/// status written), so that the next [`Executor::execute`] there submits
/// the command again instead of collecting that job: for commands that are
/// cheap to repeat and whose inputs may have changed since (an ingest that
/// skips what it has done). A job still queued or running is kept, to be
/// re-attached.
pub fn forget_finished_job(directory: &Path) {
    if read_exit_status(directory).is_some() {
        // The job script too: by it, `squeue` would still name the ended
        // job (Slurm lists ended jobs for a while) as this directory's.
        for file in [EXIT_STATUS, STARTED_AT, JOB_ID, SUBMITTED_AT, JOB_SCRIPT] {
            let _ = std::fs::remove_file(directory.join(file));
        }
    }
}

pub struct SlurmExecutor {
    settings: SlurmSettings,
    columns: Vec<String>,
    queue: Mutex<QueueView>,
    live: Arc<Mutex<LiveJobs>>,
    /// Set when Ctrl-C or SIGTERM came (before the jobs are cancelled).
    interrupting: Arc<AtomicBool>,
    /// Runs ended well and not.
    ended: Mutex<(usize, usize)>,
}

/// Why Slurm cannot take acq's jobs here: a caller may fall back to the
/// local executor, or say where to run acq instead.
#[derive(Debug, thiserror::Error)]
pub enum SlurmUnavailable {
    /// Its client commands are not installed here.
    #[error("executor kind = \"slurm\": cannot run squeue ({source}); run acq where Slurm's client commands are installed (a login node)")]
    NotInstalled { source: std::io::Error },
    /// They are, but the controller does not answer.
    #[error("executor kind = \"slurm\": Slurm does not answer: {said}{}", slurm_conf.as_ref().map(|conf| format!(" (SLURM_CONF={conf})")).unwrap_or_default())]
    NotAnswering {
        said: String,
        slurm_conf: Option<String>,
    },
}

impl SlurmExecutor {
    /// Checks that Slurm answers (its commands are installed and the
    /// controller is up, `SLURM_CONF` honoured) and arranges for acq's jobs
    /// to be cancelled on Ctrl-C or SIGTERM.
    pub fn new(settings: SlurmSettings) -> Result<Self, SlurmUnavailable> {
        let probe = Command::new("squeue")
            .args(["-h", "-o", "%i", "-j", "1"])
            .stdin(Stdio::null())
            .output()
            .map_err(|source| SlurmUnavailable::NotInstalled { source })?;
        let said = String::from_utf8_lossy(&probe.stderr);
        if !probe.status.success() && !said.contains("Invalid job id") {
            return Err(SlurmUnavailable::NotAnswering {
                said: said.trim().to_string(),
                slurm_conf: std::env::var("SLURM_CONF").ok(),
            });
        }
        let live = Arc::new(Mutex::new(LiveJobs::new()));
        let interrupting = Arc::new(AtomicBool::new(false));
        let (on_interrupt, flag) = (Arc::clone(&live), Arc::clone(&interrupting));
        crate::interrupt::on_interrupt(move || {
            // Under the lock, so no submission slips in between.
            flag.store(true, Ordering::SeqCst);
            let ids = cancel_live(&on_interrupt);
            if !ids.is_empty() {
                eprintln!(
                    "\nacq: cancelled its {} Slurm job(s) {}",
                    ids.len(),
                    ids.iter().map(u64::to_string).collect::<Vec<_>>().join(" ")
                );
            }
        });
        Ok(SlurmExecutor {
            settings,
            columns: vec!["job_id".into(), "queue_wait_s".into(), "run_s".into()],
            queue: Mutex::new(QueueView::default()),
            live,
            interrupting,
            ended: Mutex::new((0, 0)),
        })
    }

    /// `sbatch`'s arguments for a run in `directory`.
    fn sbatch_arguments(&self, directory: &Path, timeout: Duration) -> Vec<String> {
        let name = directory
            .file_name()
            .map_or_else(|| "run".into(), |n| n.to_string_lossy().into_owned());
        let minutes = timeout.as_secs().div_ceil(60) + 1;
        let mut arguments = vec![
            "--parsable".to_string(),
            format!("--job-name=acq-{name}"),
            format!("--chdir={}", directory.display()),
            "--output=stdout.txt".into(),
            "--error=stderr.txt".into(),
            format!(
                "--time={}",
                self.settings
                    .time_limit
                    .clone()
                    .unwrap_or_else(|| minutes.to_string())
            ),
        ];
        let settings = &self.settings;
        arguments.extend(
            settings
                .partition
                .iter()
                .map(|p| format!("--partition={p}")),
        );
        arguments.extend(settings.account.iter().map(|a| format!("--account={a}")));
        arguments.extend(
            settings
                .cpus_per_job
                .iter()
                .map(|c| format!("--cpus-per-task={c}")),
        );
        arguments.extend(settings.memory_per_job.iter().map(|m| format!("--mem={m}")));
        arguments.extend(settings.sbatch_args.iter().cloned());
        arguments.push(JOB_SCRIPT.into());
        arguments
    }

    /// Writes the job script and submits it; returns the job id, which is
    /// in `slurm_job_id` before this returns.
    fn submit(&self, job: &Job<'_>) -> Result<u64, String> {
        let directory = job.directory;
        // A rerun in this directory must not be taken for an earlier one.
        for stale in [EXIT_STATUS, STARTED_AT, JOB_ID] {
            let _ = std::fs::remove_file(directory.join(stale));
        }
        write_whole(
            &directory.join(JOB_SCRIPT),
            &job_script(&self.settings.prelude, job.argv),
        )?;
        write_whole(&directory.join(SUBMITTED_AT), &format!("{}\n", now_s()))?;
        self.park_if_interrupted();
        let output = slurm_command("sbatch")
            .args(self.sbatch_arguments(directory, job.timeout))
            .current_dir(directory)
            .output()
            .map_err(|e| format!("cannot run sbatch: {e}"))?;
        let answer = String::from_utf8_lossy(&output.stdout);
        // `--parsable` prints `id` or `id;cluster`.
        let id = answer
            .trim()
            .split(';')
            .next()
            .and_then(|id| id.parse::<u64>().ok())
            .filter(|_| output.status.success())
            .ok_or_else(|| {
                format!(
                    "sbatch refused the job: {}",
                    String::from_utf8_lossy(&output.stderr).trim()
                )
            })?;
        write_whole(&directory.join(JOB_ID), &format!("{id}\n"))?;
        let _ = std::fs::remove_file(directory.join(CANCELLED_BY_ACQ));
        {
            // The interrupt hook cancels what is live under this lock: a job
            // submitted after it went through is cancelled here.
            let mut live = lock(&self.live);
            if self.interrupting.load(Ordering::SeqCst) {
                let _ = std::fs::write(directory.join(CANCELLED_BY_ACQ), "");
                cancel(&[id]);
            } else {
                live.insert(
                    id,
                    LiveJob {
                        phase: Phase::Pending(String::new()),
                        directory: directory.to_path_buf(),
                    },
                );
            }
        }
        self.park_if_interrupted();
        Ok(id)
    }

    /// The job of an interrupted run in `directory`: its id from
    /// `slurm_job_id`, or, when acq died between `sbatch` and writing it,
    /// from `squeue` by the job script's path.
    fn job_of(&self, directory: &Path) -> Option<u64> {
        if directory.join(CANCELLED_BY_ACQ).exists() && read_exit_status(directory).is_none() {
            return None;
        }
        if let Some(id) = std::fs::read_to_string(directory.join(JOB_ID))
            .ok()
            .and_then(|text| text.trim().parse().ok())
        {
            return Some(id);
        }
        let script = directory.join(JOB_SCRIPT);
        if !script.is_file() {
            return None;
        }
        let output = slurm_command("squeue")
            .args(["--all", "-h", "-t", "all", "-o", "%i|%o"])
            .output()
            .ok()?;
        let text = String::from_utf8_lossy(&output.stdout);
        let id = text.lines().find_map(|line| {
            let (id, command) = line.split_once('|')?;
            (Path::new(command.trim()) == script).then(|| id.trim().parse().ok())?
        })?;
        let _ = write_whole(&directory.join(JOB_ID), &format!("{id}\n"));
        Some(id)
    }

    /// What Slurm last said about `id` (asking it when the answer is
    /// older than [`QUEUE_POLL`]); `Err(missing)` when it did not list
    /// the job in `missing` successful answers in a row.
    fn state_of(&self, id: u64) -> Option<Result<JobState, u32>> {
        let mut view = lock(&self.queue);
        if view.asked.is_none_or(|asked| asked.elapsed() >= QUEUE_POLL) {
            let ids: Vec<u64> = lock(&self.live).keys().copied().collect();
            view.states = query(&ids);
            view.asked = Some(Instant::now());
            if let Some(states) = view.states.clone() {
                for id in ids {
                    let missing = view.missing.entry(id).or_default();
                    *missing = if states.contains_key(&id) {
                        0
                    } else {
                        *missing + 1
                    };
                }
            }
        }
        let states = view.states.as_ref()?;
        Some(match states.get(&id) {
            Some(state) => Ok(state.clone()),
            None => Err(view.missing.get(&id).copied().unwrap_or(0)),
        })
    }

    /// Waits for job `id` in `directory` to end; `Err` says why it failed,
    /// `Ok(None)` that the cluster lost it (to be submitted again).
    fn wait(&self, id: u64, job: &Job<'_>) -> Result<Option<()>, String> {
        let directory = job.directory;
        let mut started: Option<Instant> = None;
        let mut last_reason = String::new();
        let mut cancelled_at: Option<Instant> = None;
        let mut restarts_seen = 0;
        // When Slurm first said the job ended with the script's own status.
        let mut ended_at: Option<Instant> = None;
        loop {
            self.park_if_interrupted();
            if let Some(status) = read_exit_status(directory) {
                return solver_outcome(id, status, directory);
            }
            let answer = self.state_of(id);
            if let Some(Ok(state)) = &answer {
                if state.restarts > restarts_seen {
                    restarts_seen = state.restarts;
                    started = None;
                    eprintln!(
                        "acq: Slurm job {id} was requeued ({} restart(s)); waiting for its rerun",
                        state.restarts
                    );
                }
            }
            match answer {
                Some(Ok(state)) => match state.state.as_str() {
                    "PENDING" | "REQUEUED" | "REQUEUE_HOLD" | "REQUEUE_FED" | "SUSPENDED"
                    | "SPECIAL_EXIT" | "RESV_DEL_HOLD" => {
                        if state.reason != last_reason && is_stuck(&state.reason) {
                            eprintln!("acq: Slurm job {id} waits: {}", state.reason);
                        }
                        last_reason.clone_from(&state.reason);
                        ended_at = None;
                        self.set_phase(id, directory, Phase::Pending(state.reason));
                    }
                    "RUNNING" | "CONFIGURING" | "COMPLETING" | "STAGE_OUT" | "SIGNALING"
                    | "RESIZING" => {
                        let since = *started.get_or_insert_with(Instant::now);
                        ended_at = None;
                        self.set_phase(id, directory, Phase::Running);
                        // From this run's own start when it wrote it (the
                        // queue's answer may be half a second old), not an
                        // earlier run's before a requeue.
                        let running_s = read_start(directory)
                            .filter(|&(restarts, _)| restarts == restarts_seen)
                            .map_or_else(|| since.elapsed().as_secs_f64(), |(_, t)| now_s() - t);
                        // Sent again should the first scancel get lost.
                        let cancel_due = cancelled_at
                            .map_or(running_s > job.timeout.as_secs_f64(), |at| {
                                at.elapsed() > CANCEL_AGAIN
                            });
                        if cancel_due {
                            cancel(&[id]);
                            cancelled_at = Some(Instant::now());
                        }
                    }
                    "COMPLETED" | "FAILED" => {
                        // The script ran to its end: its exit status is on
                        // the way (a shared file system may show it late),
                        // and Slurm has it too. Polled with the queue, not
                        // waited for blindly: a node that fails under the
                        // job can show it FAILED for a moment before Slurm
                        // requeues it, and then the rerun's status counts.
                        if ended_at.is_none() {
                            eprintln!(
                                "acq: Slurm job {id} ended as {} and its exit status is not in its directory yet; waiting up to {} s",
                                state.state,
                                STATUS_GRACE.as_secs()
                            );
                        }
                        let since = *ended_at.get_or_insert_with(Instant::now);
                        // Listing the directory refreshes NFS's cache of it.
                        let _ = std::fs::read_dir(directory).map(|entries| entries.count());
                        if since.elapsed() >= STATUS_GRACE {
                            // The controller's own view: a requeued job's
                            // ended run can linger in squeue's answer.
                            if let Some((now, _)) = scontrol_job(id) {
                                if !matches!(now.as_str(), "COMPLETED" | "FAILED") {
                                    eprintln!(
                                        "acq: Slurm job {id}: squeue says {}, the controller {now}; waiting on",
                                        state.state
                                    );
                                    ended_at = None;
                                    std::thread::sleep(FILE_POLL);
                                    continue;
                                }
                            }
                            let status = slurm_exit_code(id).ok_or_else(|| {
                                format!(
                                    "Slurm job {id} ended as {} and its exit status is nowhere: {}",
                                    state.state,
                                    end_of_stderr(directory)
                                )
                            })?;
                            return solver_outcome(id, status, directory);
                        }
                    }
                    ended => {
                        self.park_if_interrupted();
                        return ended_without_status(id, ended, cancelled_at.is_some(), job);
                    }
                },
                Some(Err(missing)) if missing >= GONE_AFTER_POLLS => {
                    return Err(format!(
                        "Slurm job {id} is gone without an exit status (purged from the controller, or lost): {}",
                        end_of_stderr(directory)
                    ));
                }
                _ => {}
            }
            std::thread::sleep(FILE_POLL);
        }
    }

    /// Once Ctrl-C or SIGTERM has come, a run neither ends nor submits:
    /// acq is about to exit, and a cancelled job must not be logged as a
    /// failed evaluation (a `--resume` runs it again instead).
    fn park_if_interrupted(&self) {
        while self.interrupting.load(Ordering::SeqCst) {
            std::thread::sleep(Duration::from_secs(1));
        }
    }

    fn set_phase(&self, id: u64, directory: &Path, phase: Phase) {
        lock(&self.live).insert(
            id,
            LiveJob {
                phase,
                directory: directory.to_path_buf(),
            },
        );
    }

    /// The job's notes: id, queue wait and run time in seconds.
    fn notes(&self, id: Option<u64>, directory: &Path) -> Vec<String> {
        let submitted = read_number(directory, SUBMITTED_AT);
        let started = read_start(directory).map(|(_, t)| t);
        let ended = std::fs::metadata(directory.join(EXIT_STATUS))
            .and_then(|m| m.modified())
            .ok()
            .and_then(|t| t.duration_since(UNIX_EPOCH).ok())
            .map(|d| d.as_secs_f64());
        // "-" for what is unknown (a job cancelled while it pended), so
        // that the notes of several jobs stay aligned column by column.
        let seconds = |from: Option<f64>, to: Option<f64>| match (from, to) {
            (Some(from), Some(to)) => format!("{:.3}", (to - from).max(0.0)),
            _ => "-".into(),
        };
        vec![
            id.map_or_else(|| "-".into(), |id| id.to_string()),
            seconds(submitted, started),
            seconds(started, ended),
        ]
    }
}

impl Executor for SlurmExecutor {
    fn execute(&self, job: &Job<'_>) -> Execution {
        let mut id = self.job_of(job.directory);
        let mut outcome = Err(String::new());
        let mut lost = Vec::new();
        for _ in 0..=RESUBMISSIONS {
            let this = match id.take() {
                Some(id) => Ok(id),
                None => self.submit(job),
            };
            let this = match this {
                Ok(this) => this,
                Err(reason) => {
                    outcome = Err(reason);
                    break;
                }
            };
            if !lock(&self.live).contains_key(&this) {
                self.set_phase(this, job.directory, Phase::Pending(String::new()));
            }
            let waited = self.wait(this, job);
            lock(&self.live).remove(&this);
            id = Some(this);
            match waited {
                Ok(Some(())) => {
                    outcome = Ok(());
                    break;
                }
                Ok(None) => {
                    // Should Slurm requeue it after all, two runs would share
                    // the directory.
                    cancel(&[this]);
                    lost.push(this);
                    eprintln!("acq: Slurm lost job {this}; submitting it again");
                    id = None;
                    outcome = Err(format!(
                        "the cluster lost the job {} times (node failure, preemption): jobs {}",
                        lost.len(),
                        lost.iter()
                            .map(u64::to_string)
                            .collect::<Vec<_>>()
                            .join(" ")
                    ));
                }
                Err(reason) => {
                    outcome = Err(reason);
                    break;
                }
            }
        }
        {
            let mut ended = lock(&self.ended);
            if outcome.is_ok() {
                ended.0 += 1;
            } else {
                ended.1 += 1;
            }
        }
        let last = id.or_else(|| lost.last().copied());
        Execution {
            outcome,
            notes: self.notes(last, job.directory),
        }
    }

    fn note_columns(&self) -> &[String] {
        &self.columns
    }

    /// A run directory with a job script whose job acq did not cancel
    /// itself (or which finished anyway): re-attached or collected. A run
    /// acq cancelled is run again in a fresh directory.
    fn holds_job(&self, directory: &Path) -> bool {
        directory.join(JOB_SCRIPT).is_file()
            && (!directory.join(CANCELLED_BY_ACQ).exists() || read_exit_status(directory).is_some())
    }

    fn status(&self) -> Option<String> {
        let live = lock(&self.live);
        let pending: Vec<&String> = live
            .values()
            .filter_map(|job| match &job.phase {
                Phase::Pending(reason) => Some(reason),
                Phase::Running => None,
            })
            .collect();
        let running = live.len() - pending.len();
        let (done, failed) = *lock(&self.ended);
        let why = pending
            .iter()
            .find(|reason| is_stuck(reason))
            .map_or_else(String::new, |reason| format!(" ({reason})"));
        Some(format!(
            "jobs: {} pending{why}, {running} running, {done} done, {failed} failed",
            pending.len()
        ))
    }
}

/// Cancels every live job, marking its directory first so that a
/// `--resume` submits it again; returns the ids.
fn cancel_live(live: &Mutex<LiveJobs>) -> Vec<u64> {
    let live = lock(live);
    for job in live.values() {
        let _ = std::fs::write(job.directory.join(CANCELLED_BY_ACQ), "");
    }
    let ids: Vec<u64> = live.keys().copied().collect();
    if !ids.is_empty() {
        cancel(&ids);
    }
    ids
}

/// Why a job that ended without an exit status failed, or `Ok(None)` when
/// the cluster lost it and it is worth submitting again.
fn ended_without_status(
    id: u64,
    state: &str,
    cancelled_by_acq: bool,
    job: &Job<'_>,
) -> Result<Option<()>, String> {
    let stderr = end_of_stderr(job.directory);
    match state {
        "CANCELLED" if cancelled_by_acq => Err(format!(
            "Slurm job {id}: timed out after {} s of running (acq's timeout_s; scancelled): {stderr}",
            job.timeout.as_secs_f64()
        )),
        "CANCELLED" => Err(format!(
            "Slurm job {id} was cancelled from outside acq (scancel): {stderr}"
        )),
        "TIMEOUT" => Err(format!(
            "Slurm job {id} hit its time limit (state TIMEOUT; raise time_limit): {stderr}"
        )),
        "NODE_FAIL" | "PREEMPTED" | "BOOT_FAIL" => {
            eprintln!("acq: Slurm job {id} ended as {state}");
            Ok(None)
        }
        "OUT_OF_MEMORY" => Err(format!(
            "Slurm job {id} ran out of memory (state OUT_OF_MEMORY; raise memory_per_job): {stderr}"
        )),
        other => Err(format!(
            "Slurm job {id} ended as {other} without the solver's exit status: {stderr}"
        )),
    }
}

/// The run's outcome from the solver's exit status.
fn solver_outcome(id: u64, status: i32, directory: &Path) -> Result<Option<()>, String> {
    if status == 0 {
        Ok(Some(()))
    } else {
        Err(format!(
            "Slurm job {id}: the solver exited with status {status}: {}",
            end_of_stderr(directory)
        ))
    }
}

fn lock<T>(mutex: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    mutex
        .lock()
        .unwrap_or_else(|poisoned| poisoned.into_inner())
}
