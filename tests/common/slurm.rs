//! A real one-node Slurm cluster on this machine, for the tests of acq's
//! Slurm executor: Debian's `slurmctld`, `slurmd` and `munge`, started in a
//! temporary directory with a generated `slurm.conf` (the recipe of
//! `../shared/reference/slurm-on-one-machine.md`), on free ports so that
//! nothing else on the machine is disturbed. Stopped by the pids in its
//! pid files when dropped. scripts/test installs the packages.

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

pub struct Cluster {
    directory: tempfile::TempDir,
    pub conf: PathBuf,
    pub node: String,
    /// munged's pid when this cluster started it.
    started_munged: Option<i32>,
}

fn require(program: &str) {
    let found = Command::new("sh")
        .args(["-c", &format!("command -v {program}")])
        .output()
        .is_ok_and(|o| o.status.success());
    assert!(
        found,
        "{program} is not installed; the Slurm tests start a real cluster. Install \
         slurmctld slurmd slurm-client munge (scripts/test does)"
    );
}

fn free_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0")
        .and_then(|listener| listener.local_addr())
        .map(|address| address.port())
        .expect("a free TCP port")
}

fn pid_in(path: &Path) -> Option<i32> {
    std::fs::read_to_string(path).ok()?.trim().parse().ok()
}

fn alive(pid: i32) -> bool {
    Path::new(&format!("/proc/{pid}")).exists()
        && !std::fs::read_to_string(format!("/proc/{pid}/stat"))
            .unwrap_or_default()
            .contains(") Z ")
}

impl Cluster {
    pub fn start() -> Cluster {
        for program in [
            "munged",
            "slurmctld",
            "slurmd",
            "sbatch",
            "squeue",
            "scontrol",
        ] {
            require(program);
        }
        let started_munged = start_munged();
        let directory = tempfile::Builder::new()
            .prefix("acq-slurm-")
            .tempdir()
            .unwrap();
        let dir = directory.path();
        for sub in ["spool", "state", "log"] {
            std::fs::create_dir_all(dir.join(sub)).unwrap();
        }
        let node = String::from_utf8(Command::new("hostname").arg("-s").output().unwrap().stdout)
            .unwrap()
            .trim()
            .to_string();
        let cpus = std::thread::available_parallelism().map_or(1, |n| n.get());
        let d = dir.display();
        let conf = dir.join("slurm.conf");
        // `cred_expire` is also how long Slurm holds a requeued job back
        // (its BeginTime): 10 s instead of 120 s, so the requeue scenarios
        // wait for Slurm's own start, and a pending job is looked at every
        // 2 s (`sched_interval`, 60 s by default) once it may start.
        // Starting it early by hand (`scontrol update StartTime=now`) raced
        // the node's revocation of the killed run's credential: one full run
        // in four on 2026-11-30 saw the rerun refused and the job FAILED
        // without running.
        std::fs::write(
            &conf,
            format!(
                "ClusterName=acqtest\n\
                 SlurmctldHost={node}\n\
                 SlurmctldPort={}\n\
                 SlurmdPort={}\n\
                 AuthType=auth/munge\n\
                 ProctrackType=proctrack/linuxproc\n\
                 TaskPlugin=task/none\n\
                 SchedulerType=sched/backfill\n\
                 SelectType=select/cons_tres\n\
                 SelectTypeParameters=CR_Core\n\
                 SlurmctldPidFile={d}/slurmctld.pid\n\
                 SlurmdPidFile={d}/slurmd.pid\n\
                 SlurmdSpoolDir={d}/spool\n\
                 StateSaveLocation={d}/state\n\
                 SlurmctldLogFile={d}/log/ctld.log\n\
                 SlurmdLogFile={d}/log/d.log\n\
                 SlurmUser=root\n\
                 ReturnToService=2\n\
                 KillWait=2\n\
                 AuthInfo=cred_expire=10\n\
                 SchedulerParameters=sched_interval=2\n\
                 NodeName={node} CPUs={cpus} State=UNKNOWN\n\
                 PartitionName=debug Nodes={node} Default=YES MaxTime=INFINITE State=UP\n",
                free_port(),
                free_port()
            ),
        )
        .unwrap();
        let cluster = Cluster {
            directory,
            conf,
            node,
            started_munged,
        };
        for daemon in ["/usr/sbin/slurmctld", "/usr/sbin/slurmd"] {
            let status = Command::new(daemon)
                .arg("-f")
                .arg(&cluster.conf)
                .env("SLURM_CONF", &cluster.conf)
                .stdin(Stdio::null())
                .status()
                .unwrap();
            assert!(status.success(), "{daemon} did not start: {status}");
        }
        cluster.wait_for_node("idle", Duration::from_secs(60));
        cluster
    }

    /// A Slurm command against this cluster.
    pub fn command(&self, program: &str) -> Command {
        let mut command = Command::new(program);
        command.env("SLURM_CONF", &self.conf).stdin(Stdio::null());
        command
    }

    pub fn run(&self, program: &str, args: &[&str]) -> Output {
        let output = self.command(program).args(args).output().unwrap();
        assert!(
            output.status.success(),
            "{program} {args:?}: {}",
            String::from_utf8_lossy(&output.stderr)
        );
        output
    }

    /// The controller's log lines that name job `id`: what a failed check
    /// on a job prints, since the cluster's directory goes with the test.
    pub fn log_of_job(&self, id: u64) -> String {
        let log =
            std::fs::read_to_string(self.directory.path().join("log/ctld.log")).unwrap_or_default();
        let name = format!("JobId={id}");
        let names_job = |line: &str| {
            line.match_indices(&name)
                .any(|(at, _)| !line[at + name.len()..].starts_with(|c: char| c.is_ascii_digit()))
        };
        log.lines()
            .filter(|line| names_job(line))
            .collect::<Vec<_>>()
            .join("\n")
    }

    /// The node's state as `sinfo` says it (`idle`, `mix`, `drain`...).
    pub fn node_state(&self) -> String {
        let output = self.run("sinfo", &["-h", "-N", "-o", "%t"]);
        String::from_utf8_lossy(&output.stdout).trim().to_string()
    }

    pub fn wait_for_node(&self, state: &str, limit: Duration) {
        let deadline = Instant::now() + limit;
        loop {
            let output = self
                .command("sinfo")
                .args(["-h", "-N", "-o", "%t"])
                .output()
                .unwrap();
            let now = String::from_utf8_lossy(&output.stdout).trim().to_string();
            if now == state {
                return;
            }
            assert!(
                Instant::now() < deadline,
                "the test cluster's node is {now:?}, not {state:?}, after {limit:?}; logs in {}",
                self.directory.path().join("log").display()
            );
            std::thread::sleep(Duration::from_millis(200));
        }
    }

    /// `(state, restarts)` of a job from `scontrol show job`.
    pub fn job(&self, id: u64) -> (String, u32) {
        let output = self.run("scontrol", &["show", "job", &id.to_string()]);
        let text = String::from_utf8_lossy(&output.stdout).into_owned();
        let field = |name: &str| -> String {
            text.split_whitespace()
                .find_map(|word| word.strip_prefix(&format!("{name}=")))
                .unwrap_or("")
                .to_string()
        };
        (field("JobState"), field("Restarts").parse().unwrap_or(0))
    }

    /// Waits until job `id` is in `state`.
    pub fn wait_for_job(&self, id: u64, state: &str, limit: Duration) {
        let deadline = Instant::now() + limit;
        loop {
            let (now, _) = self.job(id);
            if now == state {
                return;
            }
            assert!(
                Instant::now() < deadline,
                "job {id} is {now}, not {state}, after {limit:?}"
            );
            std::thread::sleep(Duration::from_millis(100));
        }
    }
}

impl Drop for Cluster {
    fn drop(&mut self) {
        let dir = self.directory.path();
        let mut pids: Vec<i32> = ["slurmd.pid", "slurmctld.pid"]
            .iter()
            .filter_map(|name| pid_in(&dir.join(name)))
            .collect();
        pids.extend(self.started_munged);
        for &pid in &pids {
            let _ = nix::sys::signal::kill(
                nix::unistd::Pid::from_raw(pid),
                nix::sys::signal::Signal::SIGTERM,
            );
        }
        let deadline = Instant::now() + Duration::from_secs(10);
        while pids.iter().any(|&pid| alive(pid)) && Instant::now() < deadline {
            std::thread::sleep(Duration::from_millis(100));
        }
        for &pid in pids.iter().filter(|&&pid| alive(pid)) {
            let _ = nix::sys::signal::kill(
                nix::unistd::Pid::from_raw(pid),
                nix::sys::signal::Signal::SIGKILL,
            );
        }
    }
}

/// Starts munged unless it runs; its pid when started here.
fn start_munged() -> Option<i32> {
    let pid_file = Path::new("/run/munge/munged.pid");
    if pid_in(pid_file).is_some_and(alive) {
        return None;
    }
    let _ = std::fs::create_dir_all("/run/munge");
    let _ = Command::new("chown")
        .args(["munge:munge", "/run/munge"])
        .status();
    let status = Command::new("/usr/sbin/munged")
        .arg("--force")
        .stdin(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .unwrap();
    assert!(
        status.success(),
        "munged did not start ({status}); the Slurm tests need munge's key (/etc/munge/munge.key) and root"
    );
    let deadline = Instant::now() + Duration::from_secs(10);
    loop {
        if let Some(pid) = pid_in(pid_file).filter(|&pid| alive(pid)) {
            return Some(pid);
        }
        assert!(Instant::now() < deadline, "munged wrote no pid file");
        std::thread::sleep(Duration::from_millis(50));
    }
}

/// A toy solver for the Slurm tests and bench: sleeps `ACQ_TEST_SLEEP_S`
/// (0.5 s by default; 600 s when x < `ACQ_TEST_HANG_BELOW_X`), records its
/// run (`SLURM_JOB_ID` and inputs) in `ACQ_TEST_RAN` when set, and writes
/// two smooth outputs.
const TOY_SOLVER: &str = r#"import json, os, sys, time
params = json.load(open(sys.argv[1]))
x, y = params["x"], params["y"]
hang_below = os.environ.get("ACQ_TEST_HANG_BELOW_X")
if hang_below is not None and x < float(hang_below):
    time.sleep(600)
time.sleep(float(os.environ.get("ACQ_TEST_SLEEP_S", "0.5")))
if "ACQ_TEST_RAN" in os.environ:
    with open(os.environ["ACQ_TEST_RAN"], "a") as ran:
        ran.write(os.environ.get("SLURM_JOB_ID", "-") + " " + json.dumps(params, sort_keys=True) + "\n")
json.dump({"f": 1.0 + (x - 0.3) ** 2 + (y + 0.2) ** 2, "g": 2.0 + x * y}, open(sys.argv[2], "w"))
"#;

/// A BO study of the toy solver on Slurm in `dir`, `parallel` jobs at a
/// time, `evaluations` of them after a start design of `start_runs`; its
/// spec and run directory.
pub fn toy_study(
    dir: &Path,
    parallel: usize,
    start_runs: usize,
    evaluations: usize,
    timeout_s: u32,
) -> (PathBuf, PathBuf) {
    std::fs::write(dir.join("solver.py"), TOY_SOLVER).unwrap();
    let spec = dir.join("spec.toml");
    std::fs::write(
        &spec,
        format!(
            r#"command = ["python3", "solver.py", "{{params}}", "{{out}}"]
output_file = "out.json"
timeout_s = {timeout_s}

[executor]
kind = "slurm"
parallel = {parallel}

[[parameter]]
name = "x"
lower = -1.0
upper = 1.0

[[parameter]]
name = "y"
lower = -1.0
upper = 1.0

[[output]]
name = "f"
measured = 1.0

[[output]]
name = "g"
measured = 1.94

[search]
method = "bo"
start_runs = {start_runs}
max_evals = {evaluations}
patience = 1000
"#
        ),
    )
    .unwrap();
    (spec, dir.join("run"))
}

/// The rows of `name`, a log in the run directory `out` (empty when
/// there is none), each as column -> text.
pub fn log_rows(out: &Path, name: &str) -> Vec<HashMap<String, String>> {
    let Ok(mut reader) = csv::Reader::from_path(out.join(name)) else {
        return Vec::new();
    };
    let header = reader.headers().unwrap().clone();
    reader
        .records()
        .map(|record| {
            header
                .iter()
                .map(String::from)
                .zip(record.unwrap().iter().map(String::from))
                .collect()
        })
        .collect()
}

/// The rows of `evaluations.csv` by column name.
pub fn evaluations(out: &Path) -> Vec<HashMap<String, String>> {
    log_rows(out, "evaluations.csv")
}
