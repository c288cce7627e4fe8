//! A run directory as a Slurm job sees it: the job script (`job.sh`, kept
//! so `sbatch job.sh` runs the same solver again), and the one-line files
//! it and acq leave there (job id, submission and start times, the
//! solver's exit status), each written whole through a rename.

use std::path::{Path, PathBuf};
use std::time::{Duration, SystemTime, UNIX_EPOCH};

pub const JOB_SCRIPT: &str = "job.sh";
pub const JOB_ID: &str = "slurm_job_id";
pub const EXIT_STATUS: &str = "exit_status";
pub const STARTED_AT: &str = "started_at";
pub const SUBMITTED_AT: &str = "submitted_at";
/// Marks a job acq cancelled itself (Ctrl-C, an error): a `--resume`
/// submits it again rather than collect a cancelled job.
pub const CANCELLED_BY_ACQ: &str = "cancelled_by_acq";
/// How long the exit status of a job Slurm says completed is waited for
/// (a file written on the compute node can take a while to show on a
/// shared file system).
pub const STATUS_GRACE: Duration = Duration::from_secs(60);

/// A number from a one-line file of a run directory.
pub fn read_number(directory: &Path, name: &str) -> Option<f64> {
    std::fs::read_to_string(directory.join(name))
        .ok()?
        .trim()
        .parse()
        .ok()
}

/// `(restart count, start time)` the job script wrote when it started.
pub fn read_start(directory: &Path) -> Option<(u32, f64)> {
    let text = std::fs::read_to_string(directory.join(STARTED_AT)).ok()?;
    let mut words = text.split_whitespace();
    Some((words.next()?.parse().ok()?, words.next()?.parse().ok()?))
}

/// The solver's exit status once the job script has written it.
pub fn read_exit_status(directory: &Path) -> Option<i32> {
    std::fs::read_to_string(directory.join(EXIT_STATUS))
        .ok()?
        .trim()
        .parse()
        .ok()
}

/// A word as the shell reads it literally: in single quotes, with each
/// single quote closed, escaped and reopened.
pub fn shell_quote(word: &str) -> String {
    format!("'{}'", word.replace('\'', r"'\''"))
}

/// Writes `text` to `path` through a temporary file and a rename, so the
/// file is whole whenever it exists.
pub fn write_whole(path: &Path, text: &str) -> Result<(), String> {
    let partial: PathBuf = path.with_extension("partial");
    std::fs::write(&partial, text)
        .and_then(|()| std::fs::rename(&partial, path))
        .map_err(|e| format!("{}: {e}", path.display()))
}

pub fn now_s() -> f64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0.0, |d| d.as_secs_f64())
}

/// The job script for `argv`, after the `prelude` lines.
pub fn job_script(prelude: &[String], argv: &[String]) -> String {
    // A job Slurm signals (scancel, node failure, its time limit) ends
    // without an exit status of its own: the solver's status after the
    // signal is no verdict on the run, and the job's state says what
    // happened (a requeued job's rerun writes the status). Slurm may
    // signal the solver before the script, so the script may see the
    // solver die of SIGTERM (143) or SIGINT (130) before its own trap
    // runs: such a status is not written either (the job's state, or
    // the exit code Slurm keeps, still tells a solver that killed
    // itself so).
    let mut text = String::from(
        "#!/bin/bash\n\
         # Written by acq for one model run; `sbatch job.sh` here runs it again.\n\
         trap 'exit 143' TERM INT\n\
         rm -f exit_status exit_status.partial\n\
         echo \"${SLURM_RESTART_COUNT:-0} $(date +%s.%N)\" > started_at\n",
    );
    for line in prelude {
        text.push_str(line);
        text.push('\n');
    }
    let words: Vec<String> = argv.iter().map(|word| shell_quote(word)).collect();
    text.push_str(&words.join(" "));
    text.push_str(
        " </dev/null\n\
         status=$?\n\
         case \"$status\" in 130|143) exit \"$status\" ;; esac\n\
         echo \"$status\" > exit_status.partial && mv exit_status.partial exit_status\n\
         exit \"$status\"\n",
    );
    text
}

#[cfg(test)]
mod tests {
    use std::process::Command;

    use super::*;

    #[test]
    fn a_quoted_word_reaches_the_program_unchanged() {
        let words = ["plain", "with space", "it's", "$HOME", "*", "a\"b", ""];
        let script: Vec<String> = words.iter().map(|w| shell_quote(w)).collect();
        let output = Command::new("sh")
            .arg("-c")
            .arg(format!("printf '%s\\n' {}", script.join(" ")))
            .output()
            .unwrap();
        let printed = String::from_utf8(output.stdout).unwrap();
        assert_eq!(printed.lines().collect::<Vec<_>>(), words);
    }

    /// The script under real bash: a solver's own exit status is written,
    /// one that died of the signal Slurm sends is not (the job's state
    /// decides then: a node failure requeues it).
    #[test]
    fn a_solver_killed_by_sigterm_leaves_no_exit_status() {
        for (argv, code, written) in [
            (["sh", "-c", "exit 3"], 3, Some("3")),
            (["sh", "-c", "kill -TERM $$"], 143, None),
            (["sh", "-c", "kill -INT $$"], 130, None),
        ] {
            let dir = tempfile::tempdir().unwrap();
            let argv: Vec<String> = argv.iter().map(|w| w.to_string()).collect();
            std::fs::write(dir.path().join("job.sh"), job_script(&[], &argv)).unwrap();
            let status = Command::new("bash")
                .arg("job.sh")
                .current_dir(dir.path())
                .status()
                .unwrap();
            assert_eq!(status.code(), Some(code), "{argv:?}");
            let status_file = std::fs::read_to_string(dir.path().join(EXIT_STATUS)).ok();
            assert_eq!(status_file.as_deref().map(str::trim), written, "{argv:?}");
            assert!(dir.path().join(STARTED_AT).exists());
        }
    }
}
