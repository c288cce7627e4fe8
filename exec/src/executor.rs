//! Where a model run happens: the seam between a study and the machine
//! that runs the user's solver.
//!
//! An [`Executor`] runs one prepared command in its run directory and says
//! whether it succeeded. [`LocalExecutor`] runs it as a child process of
//! acq (several at once: the study's `parallel`);
//! [`crate::slurm::SlurmExecutor`] submits it as a batch job instead. Everything else about a run (its
//! directory, staged files, `params.json`, reading the outputs, retries)
//! stays with the caller, so every executor runs the same jobs.

use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// One solver run to execute.
pub struct Job<'a> {
    /// Program and arguments, placeholders already replaced (no shell).
    pub argv: &'a [String],
    /// The run directory: the working directory, and where `stdout.txt`
    /// and `stderr.txt` go.
    pub directory: &'a Path,
    /// Longer than this and the run is killed and failed.
    pub timeout: Duration,
}

/// How a job went.
pub struct Execution {
    /// `Ok` when the job ran to a zero exit status; otherwise why not, in
    /// words a user can act on (the exit status and the end of stderr, a
    /// timeout, a program that cannot start, the cluster's verdict).
    pub outcome: Result<(), String>,
    /// One text per [`Executor::note_columns`].
    pub notes: Vec<String>,
}

/// Runs jobs.
pub trait Executor: Sync {
    fn execute(&self, job: &Job<'_>) -> Execution;

    /// What the executor notes about each job for the evaluation log
    /// (a cluster's job id, queue wait, run time). None by default.
    fn note_columns(&self) -> &[String] {
        &[]
    }

    /// Whether `directory` holds a job this executor started before acq
    /// was stopped, which it will re-attach to (or collect, when it has
    /// finished) instead of starting it again.
    fn holds_job(&self, _directory: &Path) -> bool {
        false
    }

    /// The jobs under way, for the progress line.
    fn status(&self) -> Option<String> {
        None
    }
}

/// Child processes of acq on this machine.
pub struct LocalExecutor;

impl Executor for LocalExecutor {
    fn execute(&self, job: &Job<'_>) -> Execution {
        Execution {
            outcome: run_locally(job),
            notes: Vec::new(),
        }
    }
}

/// One job as a child process, killed (with its children) at its timeout.
fn run_locally(job: &Job<'_>) -> Result<(), String> {
    {
        let directory = job.directory;
        let stdout =
            std::fs::File::create(directory.join("stdout.txt")).map_err(|e| e.to_string())?;
        let stderr =
            std::fs::File::create(directory.join("stderr.txt")).map_err(|e| e.to_string())?;
        let (program, arguments) = job
            .argv
            .split_first()
            .ok_or_else(|| "the command is empty".to_string())?;
        let mut child = Command::new(program)
            .args(arguments)
            .current_dir(directory)
            .stdin(Stdio::null())
            .stdout(stdout)
            .stderr(stderr)
            .spawn()
            .map_err(|e| format!("cannot start {program:?}: {e}"))?;
        let deadline = Instant::now() + job.timeout;
        let status = loop {
            match child.try_wait() {
                Ok(Some(status)) => break status,
                Ok(None) if Instant::now() >= deadline => {
                    // A solver started through a shell or a wrapper has
                    // children of its own: kill the whole tree, leaves first.
                    kill_process_tree(child.id());
                    let _ = child.kill();
                    let _ = child.wait();
                    return Err(format!(
                        "timed out after {} s (killed)",
                        job.timeout.as_secs_f64()
                    ));
                }
                Ok(None) => std::thread::sleep(Duration::from_millis(20)),
                Err(e) => return Err(format!("waiting for the solver: {e}")),
            }
        };
        if status.success() {
            Ok(())
        } else {
            Err(format!(
                "the solver exited with {status}: {}",
                end_of_stderr(directory)
            ))
        }
    }
}

/// The last three lines of a run's `stderr.txt`, joined by " / ".
pub fn end_of_stderr(directory: &Path) -> String {
    let text = std::fs::read_to_string(directory.join("stderr.txt")).unwrap_or_default();
    let mut last: Vec<&str> = text.lines().rev().take(3).collect();
    last.reverse();
    last.join(" / ")
}

/// SIGKILL to `root` and every descendant (found through /proc before
/// any is killed), parents first: a wrapper script whose child died first
/// could otherwise go on and write its outputs before its own kill (a
/// timed-out run that looks finished). The solver stays in acq's process
/// group, so Ctrl-C on the terminal still reaches it; a timeout has to find
/// its children itself.
fn kill_process_tree(root: u32) {
    let parent_of = |pid: u32| -> Option<u32> {
        let stat = std::fs::read_to_string(format!("/proc/{pid}/stat")).ok()?;
        // The command name in parentheses may hold spaces: parse after it.
        let after = stat.rsplit_once(')')?.1;
        after.split_whitespace().nth(1)?.parse().ok()
    };
    let all: Vec<u32> = std::fs::read_dir("/proc")
        .map(|entries| {
            entries
                .filter_map(|e| e.ok()?.file_name().to_str()?.parse().ok())
                .collect()
        })
        .unwrap_or_default();
    let mut tree = vec![root];
    let mut index = 0;
    while index < tree.len() {
        let parent = tree[index];
        tree.extend(
            all.iter()
                .copied()
                .filter(|&pid| parent_of(pid) == Some(parent)),
        );
        index += 1;
    }
    // Breadth-first from the root: parents before their children.
    for &pid in &tree {
        if let Ok(pid) = i32::try_from(pid) {
            let _ = nix::sys::signal::kill(
                nix::unistd::Pid::from_raw(pid),
                nix::sys::signal::Signal::SIGKILL,
            );
        }
    }
}
