//! The Slurm commands acq runs: `squeue` for the states of its jobs (one
//! call for all of them), `scancel` by job id, `scontrol` for an exit
//! code. Each in a process group of its own.

use std::collections::HashMap;
use std::os::unix::process::CommandExt;
use std::process::{Command, Stdio};

/// What `squeue` said about a job.
#[derive(Clone, Debug, PartialEq)]
pub struct JobState {
    /// Slurm's state name: PENDING, RUNNING, COMPLETED, CANCELLED...
    pub state: String,
    /// Slurm's reason (why it pends).
    pub reason: String,
    /// Times Slurm requeued it.
    pub restarts: u32,
}

/// A pending reason worth telling the user: not just waiting its turn.
pub fn is_stuck(reason: &str) -> bool {
    !matches!(reason, "" | "None" | "Priority" | "Resources")
}

/// `squeue`'s states of `ids` (`None` when it cannot be asked).
pub fn query(ids: &[u64]) -> Option<HashMap<u64, JobState>> {
    if ids.is_empty() {
        return Some(HashMap::new());
    }
    let list: Vec<String> = ids.iter().map(u64::to_string).collect();
    let output = slurm_command("squeue")
        .args([
            "--all",
            "-h",
            "-t",
            "all",
            "-O",
            QUEUE_FORMAT,
            "-j",
            &list.join(","),
        ])
        .output()
        .ok()?;
    // One unknown id makes squeue fail; several unknown ones print nothing.
    if !output.status.success() {
        return String::from_utf8_lossy(&output.stderr)
            .contains("Invalid job id")
            .then(HashMap::new);
    }
    Some(parse_squeue(&String::from_utf8_lossy(&output.stdout)))
}

/// `squeue -O`'s fields, each ended by `|` (no padding): the restart
/// count is only in this long format.
pub const QUEUE_FORMAT: &str = "JobID:|,State:|,RestartCnt:|,Reason:|";

/// Lines `id|STATE|restarts|reason|` of `squeue -O QUEUE_FORMAT`.
pub fn parse_squeue(text: &str) -> HashMap<u64, JobState> {
    text.lines()
        .filter_map(|line| {
            let mut cells = line.trim_end().trim_end_matches('|').splitn(4, '|');
            let id = cells.next()?.trim().parse().ok()?;
            let state = cells.next()?.trim().to_string();
            let restarts = cells.next()?.trim().parse().unwrap_or(0);
            let reason = cells.next().unwrap_or("").trim().to_string();
            Some((
                id,
                JobState {
                    state,
                    reason,
                    restarts,
                },
            ))
        })
        .collect()
}

/// `scancel` of exactly these job ids.
pub fn cancel(ids: &[u64]) {
    let list: Vec<String> = ids.iter().map(u64::to_string).collect();
    let _ = slurm_command("scancel")
        .args(&list)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status();
}

/// A Slurm command in a process group of its own: Ctrl-C on the terminal
/// reaches acq, which cancels its jobs, and must not kill an `sbatch`
/// halfway (a job submitted but never noted).
pub fn slurm_command(program: &str) -> Command {
    let mut command = Command::new(program);
    command.stdin(Stdio::null()).process_group(0);
    command
}

/// The exit code Slurm recorded for the job (its script exits with the
/// solver's), from `scontrol show job` (`ExitCode=1:0`).
pub fn slurm_exit_code(id: u64) -> Option<i32> {
    scontrol_job(id).and_then(|(_, exit)| exit)
}

/// The job's state and exit code as the controller itself has them
/// (`scontrol show job`): the authority when `squeue` still shows an
/// ended run of a job Slurm has requeued.
pub fn scontrol_job(id: u64) -> Option<(String, Option<i32>)> {
    let output = slurm_command("scontrol")
        .args(["show", "job", &id.to_string()])
        .output()
        .ok()?;
    let text = String::from_utf8_lossy(&output.stdout);
    let field = |name: &str| {
        text.split_whitespace()
            .find_map(|word| word.strip_prefix(&format!("{name}=")))
            .map(str::to_string)
    };
    let state = field("JobState")?;
    let exit = field("ExitCode").and_then(|code| code.split(':').next()?.parse().ok());
    Some((state, exit))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn squeue_lines_are_read_and_junk_is_skipped() {
        let states = parse_squeue(
            "12|PENDING|0|ReqNodeNotAvail, UnavailableNodes:vm|\n13|RUNNING|1|None|\nnot a job\n",
        );
        assert_eq!(states.len(), 2);
        assert_eq!(states[&12].state, "PENDING");
        assert_eq!(states[&12].reason, "ReqNodeNotAvail, UnavailableNodes:vm");
        assert_eq!(states[&13].state, "RUNNING");
        assert_eq!((states[&12].restarts, states[&13].restarts), (0, 1));
        assert!(is_stuck(&states[&12].reason));
        assert!(!is_stuck("Resources"));
    }
}
