//! acq's Slurm executor on a real one-node Slurm cluster started by the
//! test (tests/common/slurm.rs), never a mock. The cluster starts once and
//! the scenarios run one after the other on it: the worked CalculiX
//! example calibrated on Slurm, the posterior's refinement and predictive
//! runs as jobs, a job cancelled from outside, acq's own
//! timeout, a requeued job, a drained and a failed node, acq killed with
//! SIGKILL and resumed, Ctrl-C that cancels acq's jobs and nobody
//! else's, and a lake's backlog ingested as jobs.
//!
//! The toy solver records every run it completes (its `SLURM_JOB_ID` and
//! inputs) in a file of its own, outside acq's bookkeeping: that file is
//! the independent check that no evaluation ran twice and none was lost.

mod common;

use std::collections::{BTreeMap, BTreeSet, HashMap};
use std::os::unix::process::CommandExt;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use common::calculix::{assert_bo_recovers_the_truth, example_at_test_mesh};
use common::slurm::{evaluations, log_rows, toy_study, Cluster};
use common::{path_arg, root};
use nix::sys::signal::{kill, signal, SigHandler, Signal};
use nix::unistd::Pid;

/// `acq calibrate external` against the cluster, started and not waited
/// for; stderr goes to `out`'s sibling `stderr.txt`.
fn start_acq(
    cluster: &Cluster,
    spec: &Path,
    out: &Path,
    extra: &[&str],
    environment: &[(&str, &str)],
) -> Child {
    let stderr = out.with_extension("stderr.txt");
    let mut command = Command::new(env!("CARGO_BIN_EXE_acq"));
    command
        .args(["calibrate", "external", "--spec", path_arg(spec)])
        .args(["--out", path_arg(out)])
        .args(extra)
        .env("SLURM_CONF", &cluster.conf)
        .env("ACQ_TEST_RAN", spec.with_file_name("ran.txt"))
        .envs(environment.iter().copied())
        .current_dir(root())
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(
            std::fs::OpenOptions::new()
                .create(true)
                .append(true)
                .open(stderr)
                .unwrap(),
        );
    // A test started from a non-interactive shell inherits an ignored
    // SIGINT, and exec keeps it ignored: give acq the default, as on a
    // terminal.
    // SAFETY: only sigaction (async-signal-safe) runs between fork and exec.
    unsafe {
        command.pre_exec(|| {
            signal(Signal::SIGINT, SigHandler::SigDfl)
                .map(drop)
                .map_err(std::io::Error::from)
        });
    }
    command.spawn().unwrap()
}

/// Each file of job `id`'s run directory with its first line (what a
/// failed check needs to tell a requeue from a run).
fn job_files(out: &Path, id: u64) -> Vec<(String, String)> {
    let Some((directory, _)) = submitted(out).into_iter().find(|&(_, job)| job == id) else {
        return Vec::new();
    };
    std::fs::read_dir(&directory)
        .map(|entries| {
            entries
                .filter_map(Result::ok)
                .map(|e| {
                    let first = std::fs::read_to_string(e.path())
                        .ok()
                        .and_then(|t| t.lines().next().map(str::to_string))
                        .unwrap_or_default();
                    (e.file_name().to_string_lossy().into_owned(), first)
                })
                .collect()
        })
        .unwrap_or_default()
}

fn said(out: &Path) -> String {
    std::fs::read_to_string(out.with_extension("stderr.txt")).unwrap_or_default()
}

/// Waits for acq to end within `limit`; its exit code.
fn finish(mut child: Child, out: &Path, limit: Duration) -> i32 {
    let deadline = Instant::now() + limit;
    loop {
        if let Some(status) = child.try_wait().unwrap() {
            return status.code().unwrap_or(-1);
        }
        if Instant::now() > deadline {
            let _ = child.kill();
            panic!("acq did not end in {limit:?}: {}", said(out));
        }
        std::thread::sleep(Duration::from_millis(100));
    }
}

/// Waits for acq to end well within `limit`.
fn finish_ok(child: Child, out: &Path, limit: Duration) {
    assert_eq!(finish(child, out, limit), 0, "{}", said(out));
}

/// Polls `condition` every 50 ms until it gives something.
fn wait_for<T>(what: &str, limit: Duration, mut condition: impl FnMut() -> Option<T>) -> T {
    let deadline = Instant::now() + limit;
    loop {
        if let Some(found) = condition() {
            return found;
        }
        assert!(Instant::now() < deadline, "no {what} within {limit:?}");
        std::thread::sleep(Duration::from_millis(50));
    }
}

/// The job ids acq noted in the run directories, by directory.
fn submitted(out: &Path) -> Vec<(PathBuf, u64)> {
    let mut jobs: Vec<(PathBuf, u64)> = std::fs::read_dir(out.join("runs"))
        .map(|entries| {
            entries
                .filter_map(|entry| {
                    let directory = entry.ok()?.path();
                    let id = std::fs::read_to_string(directory.join("slurm_job_id"))
                        .ok()?
                        .trim()
                        .parse()
                        .ok()?;
                    Some((directory, id))
                })
                .collect()
        })
        .unwrap_or_default();
    jobs.sort();
    jobs
}

/// The first job of the run in `state`.
fn a_job_in(cluster: &Cluster, out: &Path, state: &str) -> Option<u64> {
    submitted(out)
        .into_iter()
        .map(|(_, id)| id)
        .find(|&id| cluster.job(id).0 == state)
}

/// Waits for a job of the run in `state`.
fn wait_for_a_job_in(cluster: &Cluster, out: &Path, state: &str) -> u64 {
    let deadline = Instant::now() + Duration::from_secs(60);
    loop {
        if let Some(id) = a_job_in(cluster, out, state) {
            return id;
        }
        assert!(
            Instant::now() < deadline,
            "no job of acq {state} within a minute; acq said: {}",
            said(out)
        );
        std::thread::sleep(Duration::from_millis(50));
    }
}

/// What the solver itself recorded: `(SLURM_JOB_ID, inputs)` per
/// completed run.
fn solver_runs(dir: &Path) -> Vec<(String, String)> {
    std::fs::read_to_string(dir.join("ran.txt"))
        .unwrap_or_default()
        .lines()
        .map(|line| {
            let (id, params) = line.split_once(' ').unwrap();
            (id.to_string(), params.to_string())
        })
        .collect()
}

/// One scenario on the shared cluster.
type Scenario = fn(&Cluster);

#[test]
fn acq_on_a_real_slurm_cluster() {
    let cluster = Cluster::start();
    let scenarios: [(&str, Scenario); 9] = [
        ("the worked CalculiX example", calculix_example_on_slurm),
        ("the posterior's runs as jobs", posterior_runs_as_jobs),
        ("a job cancelled from outside", job_cancelled_from_outside),
        ("acq's own timeout", job_exceeding_acqs_timeout),
        ("a requeued job", requeued_job),
        ("a drained node and a failed one", drained_and_failed_node),
        ("SIGKILL, then --resume", killed_and_resumed),
        ("Ctrl-C", ctrl_c_cancels_only_acqs_jobs),
        ("a lake's backlog as jobs", lake_backlog_as_jobs),
    ];
    // ACQ_SLURM_SCENARIO=word runs only the scenarios whose name has it
    // (while working on one).
    let only = std::env::var("ACQ_SLURM_SCENARIO").unwrap_or_default();
    for (name, scenario) in scenarios {
        if !name.contains(&only) {
            continue;
        }
        eprintln!("== {name}");
        let start = Instant::now();
        scenario(&cluster);
        eprintln!("   passed in {:.1} s", start.elapsed().as_secs_f64());
        cluster.wait_for_node("idle", Duration::from_secs(60));
    }
}

/// The example's Bayesian optimisation with its jobs on Slurm recovers
/// the truth as it does locally (tests/calculix.rs, with the same bounds
/// and why), and every evaluation names the job it ran in. (Its other
/// study, surrogates and NSGA-II, submits the same jobs through the same
/// executor, two at a time: it runs locally only, once.)
fn calculix_example_on_slurm(cluster: &Cluster) {
    let dir = tempfile::tempdir().unwrap();
    example_at_test_mesh(dir.path());
    let spec = dir.path().join("spec-bo.toml");
    let text = std::fs::read_to_string(&spec).unwrap() + "\n[executor]\nkind = \"slurm\"\n";
    std::fs::write(&spec, text).unwrap();
    let out = dir.path().join("run");
    let child = start_acq(cluster, &spec, &out, &[], &[]);
    finish_ok(child, &out, Duration::from_secs(900));
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    assert_bo_recovers_the_truth(&summary);
    let rows = evaluations(&out);
    let logged: BTreeSet<u64> = rows
        .iter()
        .flat_map(|row| {
            row["job_id"]
                .split_whitespace()
                .map(|id| id.parse().unwrap())
                .collect::<Vec<u64>>()
        })
        .collect();
    let jobs: BTreeSet<u64> = submitted(&out).into_iter().map(|(_, id)| id).collect();
    assert!(
        jobs.is_subset(&logged) && !rows.iter().any(|row| row["job_id"].is_empty()),
        "every evaluation names its jobs, and every search job is logged"
    );
    for row in &rows {
        for seconds in ["queue_wait_s", "run_s"] {
            for value in row[seconds].split_whitespace() {
                let value: f64 = value.parse().unwrap();
                assert!((0.0..120.0).contains(&value), "{seconds} {value}: {row:?}");
            }
        }
    }
    let report = common::report::read(&out);
    assert!(
        report.contains("## Where the runs ran"),
        "the report gives each run's queue wait and run time"
    );
}

/// The posterior stage on Slurm: its refinement and predictive runs are
/// jobs like the search's, each logged with its job id, and the solver's
/// own record holds every job once.
fn posterior_runs_as_jobs(cluster: &Cluster) {
    let dir = tempfile::tempdir().unwrap();
    let (spec, out) = toy_study(dir.path(), 2, 6, 10, 120);
    let text = std::fs::read_to_string(&spec).unwrap()
        + "\n[posterior]\ndraws = 300\nchains = 2\npredictive_runs = 4\nseed = 3\n";
    std::fs::write(&spec, text).unwrap();
    let child = start_acq(cluster, &spec, &out, &[], &[]);
    finish_ok(child, &out, Duration::from_secs(600));
    let predictive = log_rows(&out, "posterior_runs_fit.csv");
    assert_eq!(predictive.len(), 4, "{predictive:?}");
    let mut logged: BTreeSet<String> = BTreeSet::new();
    for row in evaluations(&out)
        .iter()
        .chain(&log_rows(&out, "posterior_refinement.csv"))
        .chain(&predictive)
    {
        assert!(
            row["job_id"].parse::<u64>().is_ok(),
            "a run without its job: {row:?}"
        );
        logged.insert(row["job_id"].clone());
    }
    let runs = solver_runs(dir.path());
    let ran: BTreeSet<String> = runs.iter().map(|(id, _)| id.clone()).collect();
    assert_eq!(runs.len(), ran.len(), "a job ran twice: {runs:?}");
    assert_eq!(ran, logged, "every job is a logged run and no run is lost");
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    assert!(
        summary["posterior"]["x"]["q05"].as_f64().is_some(),
        "{summary:#}"
    );
}

/// A job scancelled by someone else is a failed evaluation that says so;
/// the study goes on to its budget.
fn job_cancelled_from_outside(cluster: &Cluster) {
    let dir = tempfile::tempdir().unwrap();
    // Four runs, two at a time: the victim is one of the first two, and
    // two more follow it (six took one more round of six seconds).
    let (spec, out) = toy_study(dir.path(), 2, 4, 4, 120);
    // Long enough that the job cannot end between the test seeing it run
    // and its scancel.
    let child = start_acq(cluster, &spec, &out, &[], &[("ACQ_TEST_SLEEP_S", "6")]);
    let victim = wait_for_a_job_in(cluster, &out, "RUNNING");
    cluster.run("scancel", &[&victim.to_string()]);
    finish_ok(child, &out, Duration::from_secs(300));
    let rows = evaluations(&out);
    assert_eq!(rows.len(), 4, "the study went on to its budget");
    let row = rows
        .iter()
        .find(|row| row["job_id"] == victim.to_string())
        .expect("the cancelled job's evaluation is logged");
    assert_eq!(row["status"], "failed");
    assert!(
        row["reason"].contains("cancelled from outside acq"),
        "{}",
        row["reason"]
    );
    assert_eq!(rows.iter().filter(|r| r["status"] == "ok").count(), 3);
}

/// A run longer than acq's timeout (shorter than Slurm's minute) is
/// scancelled by acq within about a second of it, and failed with the
/// reason; the others go on.
fn job_exceeding_acqs_timeout(cluster: &Cluster) {
    let dir = tempfile::tempdir().unwrap();
    // An LHS of 4 puts one point in each quarter of x: the two below 0 hang.
    let (spec, out) = toy_study(dir.path(), 2, 4, 4, 3);
    let start = Instant::now();
    let child = start_acq(cluster, &spec, &out, &[], &[("ACQ_TEST_HANG_BELOW_X", "0")]);
    finish_ok(child, &out, Duration::from_secs(120));
    // Two rounds of at most 3 s each plus scheduling, not Slurm's minute.
    assert!(
        start.elapsed() < Duration::from_secs(40),
        "acq's 3 s timeout was not enforced: {:?}",
        start.elapsed()
    );
    let rows = evaluations(&out);
    let timed_out: Vec<&HashMap<String, String>> =
        rows.iter().filter(|r| r["status"] == "failed").collect();
    assert_eq!(timed_out.len(), 2, "{rows:?}");
    for row in timed_out {
        assert!(row["x"].parse::<f64>().unwrap() < 0.0);
        assert!(
            row["reason"].contains("timed out after 3 s"),
            "{}",
            row["reason"]
        );
        let id: u64 = row["job_id"].parse().unwrap();
        assert_eq!(cluster.job(id).0, "CANCELLED", "acq scancelled job {id}");
    }
}

/// A job an admin requeues runs again (Slurm delays a requeued job by two
/// minutes; the test, as the admin, lets it start at once), and its
/// evaluation is the rerun's result, not a failure.
fn requeued_job(cluster: &Cluster) {
    let dir = tempfile::tempdir().unwrap();
    let (spec, out) = toy_study(dir.path(), 1, 2, 3, 120);
    let child = start_acq(cluster, &spec, &out, &[], &[("ACQ_TEST_SLEEP_S", "3")]);
    let job = wait_for_a_job_in(cluster, &out, "RUNNING");
    // Requeued once its script runs (Slurm says RUNNING a moment before it
    // launches the script; a requeue then may not stop the first run).
    let directory = submitted(&out)
        .into_iter()
        .find(|&(_, id)| id == job)
        .map(|(directory, _)| directory)
        .unwrap();
    wait_for("the job script's start", Duration::from_secs(10), || {
        directory.join("started_at").exists().then_some(())
    });
    cluster.run("scontrol", &["requeue", &job.to_string()]);
    cluster.wait_for_job(job, "PENDING", Duration::from_secs(30));
    wait_for("acq noticing the requeue", Duration::from_secs(10), || {
        said(&out).contains("requeued").then_some(())
    });
    finish_ok(child, &out, Duration::from_secs(120));
    cluster.wait_for_job(job, "COMPLETED", Duration::from_secs(30));
    assert_eq!(cluster.job(job), ("COMPLETED".into(), 1));
    let rows = evaluations(&out);
    assert!(rows.iter().all(|r| r["status"] == "ok"), "{rows:?}");
    let runs = solver_runs(dir.path());
    assert_eq!(
        runs.iter().filter(|(id, _)| *id == job.to_string()).count(),
        1,
        "the requeued job completed once (its first run was killed)"
    );
}

/// With the node drained, acq's next job waits and acq says why; once the
/// node is back it runs. A node that fails under a running job has Slurm
/// requeue it, and the evaluation is the rerun's.
fn drained_and_failed_node(cluster: &Cluster) {
    let dir = tempfile::tempdir().unwrap();
    let (spec, out) = toy_study(dir.path(), 1, 3, 3, 120);
    let child = start_acq(cluster, &spec, &out, &[], &[("ACQ_TEST_SLEEP_S", "2")]);
    let node = format!("NodeName={}", cluster.node);
    let first = wait_for_a_job_in(cluster, &out, "RUNNING");
    cluster.run(
        "scontrol",
        &["update", &node, "State=DRAIN", "Reason=acq-test"],
    );
    let waiting = wait_for(
        "a job waiting on the drained node",
        Duration::from_secs(30),
        || a_job_in(cluster, &out, "PENDING"),
    );
    assert_ne!(
        waiting, first,
        "the running job went on while the node drained"
    );
    wait_for(
        "acq saying why the job waits",
        Duration::from_secs(10),
        || {
            said(&out)
                .contains(&format!("Slurm job {waiting} waits"))
                .then_some(())
        },
    );
    cluster.run("scontrol", &["update", &node, "State=RESUME"]);
    // The third job: its node fails while it runs.
    let third = wait_for("third job running", Duration::from_secs(60), || {
        submitted(&out)
            .get(2)
            .map(|&(_, id)| id)
            .filter(|&id| cluster.job(id).0 == "RUNNING")
    });
    cluster.run(
        "scontrol",
        &["update", &node, "State=DOWN", "Reason=acq-test"],
    );
    cluster.wait_for_job(third, "PENDING", Duration::from_secs(30));
    cluster.wait_for_node("idle", Duration::from_secs(60));
    finish_ok(child, &out, Duration::from_secs(120));
    let rows = evaluations(&out);
    assert_eq!(rows.len(), 3);
    assert!(
        rows.iter().all(|r| r["status"] == "ok"),
        "{rows:?}\nacq said:\n{}\nthe job's files: {:?}\nthe controller's log of it:\n{}",
        said(&out),
        job_files(&out, third),
        cluster.log_of_job(third)
    );
    assert_eq!(
        cluster.job(third).1,
        1,
        "Slurm requeued the job of the failed node"
    );
}

/// acq killed with SIGKILL while jobs run; `--resume` re-attaches to them
/// (and collects those that ended meanwhile) instead of submitting them
/// again. The solver's own record: every point ran exactly once, and every
/// run is an evaluation.
fn killed_and_resumed(cluster: &Cluster) {
    let dir = tempfile::tempdir().unwrap();
    let (spec, out) = toy_study(dir.path(), 2, 4, 8, 120);
    let environment = [("ACQ_TEST_SLEEP_S", "2")];
    let child = start_acq(cluster, &spec, &out, &[], &environment);
    wait_for(
        "3 logged evaluations and 2 jobs in flight",
        Duration::from_secs(120),
        || {
            let logged = std::fs::read_to_string(out.join("evaluations.csv"))
                .map(|t| t.lines().count().saturating_sub(1))
                .unwrap_or(0);
            (logged >= 3 && submitted(&out).len() >= logged + 2).then_some(())
        },
    );
    kill(Pid::from_raw(child.id() as i32), Signal::SIGKILL).unwrap();
    assert_eq!(finish(child, &out, Duration::from_secs(10)), -1);
    let before = submitted(&out);
    let in_flight: Vec<u64> = before
        .iter()
        .map(|&(_, id)| id)
        .filter(|&id| matches!(cluster.job(id).0.as_str(), "RUNNING" | "PENDING"))
        .collect();
    let child = start_acq(cluster, &spec, &out, &["--resume"], &environment);
    finish_ok(child, &out, Duration::from_secs(300));
    let rows = evaluations(&out);
    assert_eq!(rows.len(), 8, "{rows:?}");
    assert!(rows.iter().all(|r| r["status"] == "ok"), "{rows:?}");
    let after = submitted(&out);
    assert_eq!(after.len(), 8, "one job per evaluation: {after:?}");
    for (directory, id) in &before {
        assert!(
            after.contains(&(directory.clone(), *id)),
            "job {id} of the killed run was submitted again"
        );
    }
    let runs = solver_runs(dir.path());
    let points: BTreeSet<&String> = runs.iter().map(|(_, params)| params).collect();
    assert_eq!(points.len(), runs.len(), "a point ran twice: {runs:?}");
    let ran: BTreeSet<String> = runs.iter().map(|(id, _)| id.clone()).collect();
    let logged: BTreeSet<String> = rows.iter().map(|r| r["job_id"].clone()).collect();
    assert_eq!(ran, logged, "every run is an evaluation and no run is lost");
    assert!(
        in_flight.iter().all(|id| logged.contains(&id.to_string())),
        "the jobs in flight at the kill were collected: {in_flight:?}"
    );
}

/// Ctrl-C: acq cancels the jobs it submitted, by id, and exits 130; a job
/// of someone else on the same cluster runs on. `--resume` then submits the
/// cancelled evaluation again and finishes.
fn ctrl_c_cancels_only_acqs_jobs(cluster: &Cluster) {
    let dir = tempfile::tempdir().unwrap();
    let foreign: u64 = String::from_utf8(
        cluster
            .run(
                "sbatch",
                &[
                    "--parsable",
                    "--job-name=someone-else",
                    &format!("--output={}/foreign.txt", dir.path().display()),
                    "--wrap",
                    "sleep 120",
                ],
            )
            .stdout,
    )
    .unwrap()
    .trim()
    .parse()
    .unwrap();
    cluster.wait_for_job(foreign, "RUNNING", Duration::from_secs(30));
    let (spec, out) = toy_study(dir.path(), 1, 2, 3, 120);
    let environment = [("ACQ_TEST_SLEEP_S", "30")];
    let child = start_acq(cluster, &spec, &out, &[], &environment);
    let ours = wait_for("acq's job running", Duration::from_secs(60), || {
        a_job_in(cluster, &out, "RUNNING")
    });
    kill(Pid::from_raw(child.id() as i32), Signal::SIGINT).unwrap();
    assert_eq!(
        finish(child, &out, Duration::from_secs(30)),
        130,
        "{}",
        said(&out)
    );
    assert!(
        said(&out).contains(&format!("cancelled its 1 Slurm job(s) {ours}")),
        "{}",
        said(&out)
    );
    cluster.wait_for_job(ours, "CANCELLED", Duration::from_secs(30));
    assert_eq!(cluster.job(foreign).0, "RUNNING", "another job was touched");
    cluster.run("scancel", &[&foreign.to_string()]);
    let child = start_acq(
        cluster,
        &spec,
        &out,
        &["--resume"],
        &[("ACQ_TEST_SLEEP_S", "0.5")],
    );
    finish_ok(child, &out, Duration::from_secs(120));
    let rows = evaluations(&out);
    assert_eq!(rows.len(), 3);
    assert!(
        rows.iter().all(|r| r["status"] == "ok"),
        "the evaluation acq cancelled ran again on --resume: {rows:?}"
    );
}

/// Every file of a lake's tables (not its manifest, whose entries carry
/// the time of their ingest) with its bytes, by path in the lake.
fn lake_tables(lake: &Path) -> BTreeMap<PathBuf, Vec<u8>> {
    let mut files = BTreeMap::new();
    let mut dirs: Vec<PathBuf> = ["samples", "holds", "measured"]
        .iter()
        .map(|table| lake.join(table))
        .collect();
    while let Some(dir) = dirs.pop() {
        for entry in std::fs::read_dir(&dir).into_iter().flatten().flatten() {
            let path = entry.path();
            if path.is_dir() {
                dirs.push(path);
            } else {
                let relative = path.strip_prefix(lake).unwrap().to_path_buf();
                files.insert(relative, std::fs::read(&path).unwrap());
            }
        }
    }
    files
}

/// A backlog (logs of three days, one of them in two files, one from a
/// logger whose buses are mapped in its folder only, and a recorded
/// session) ingested as three Slurm jobs gives the lake one
/// ingest on this machine gives, file for file and byte for byte; the
/// same command again runs the jobs again, which skip every source and
/// change no file.
fn lake_backlog_as_jobs(cluster: &Cluster) {
    let dir = tempfile::tempdir().unwrap();
    let rig = root().join("fixtures/rigs/excavator.toml");
    let scenario = root().join("fixtures/scenarios/excavator_case1.toml");
    let mut backlog = vec![root().join("fixtures/sessions/excavator_case2")];
    for (day, seed) in [(0u64, "1"), (1, "2"), (3, "3")] {
        let log = dir.path().join(format!("day{day}.log"));
        let start = (1_764_547_200 + day * 86_400).to_string();
        let simulated = common::acq(&[
            "simulate",
            "--rig",
            path_arg(&rig),
            "--scenario",
            path_arg(&scenario),
            "--seed",
            seed,
            "--start",
            &start,
            "-o",
            path_arg(&log),
        ]);
        assert!(simulated.status.success(), "{simulated:?}");
        backlog.push(log);
    }
    // The last day's log in two files, as a logger splits its files.
    let text = std::fs::read_to_string(backlog.last().unwrap()).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    let (first, second) = lines.split_at(lines.len() / 2);
    let last = backlog.pop().unwrap();
    for (part, lines) in [("a", first), ("b", second)] {
        let file = last.with_file_name(format!("day3{part}.log"));
        std::fs::write(&file, lines.join("\n") + "\n").unwrap();
        backlog.push(file);
    }
    // Day 1 from a logger whose wiring swaps the rig's two buses: the
    // mapping is scoped to its folder and has to reach the job that
    // ingests it (and no other: a job refuses a scope none of its sources
    // is under).
    let swapping_logger = dir.path().join("logger_b");
    std::fs::create_dir(&swapping_logger).unwrap();
    let day1 = swapping_logger.join("day1.log");
    let swapped = std::fs::read_to_string(&backlog[2])
        .unwrap()
        .replace(" can0 ", " swap ")
        .replace(" can1 ", " can0 ")
        .replace(" swap ", " can1 ");
    std::fs::write(&day1, swapped).unwrap();
    std::fs::remove_file(&backlog[2]).unwrap();
    backlog[2] = day1;
    let first_swap = format!("{}:can1=can0", swapping_logger.display());
    let second_swap = format!("{}:can0=can1", swapping_logger.display());
    let ingest = |lake: &Path, extra: &[&str]| {
        let mut command = Command::new(env!("CARGO_BIN_EXE_acq"));
        command
            .args(["lake", "ingest"])
            .args(backlog.iter().map(|p| path_arg(p)))
            .args(["--rig", path_arg(&rig), "--lake", path_arg(lake)])
            .args(["--bus", &first_swap, "--bus", &second_swap])
            .args(extra)
            .env("SLURM_CONF", &cluster.conf)
            .stdin(Stdio::null());
        let output = command.output().unwrap();
        let said = String::from_utf8_lossy(&output.stderr).into_owned();
        assert!(output.status.success(), "acq lake ingest {extra:?}: {said}");
        said
    };
    let here = dir.path().join("lake-here");
    ingest(&here, &[]);
    let on_slurm = dir.path().join("lake-on-slurm");
    let said = ingest(&on_slurm, &["--slurm", "--slices", "3"]);
    assert_eq!(said.matches(": done").count(), 3, "{said}");

    let expected = lake_tables(&here);
    let got = lake_tables(&on_slurm);
    // Three days of samples of every sensor, holds and measured values.
    assert!(expected.len() > 3 * 28, "{:?}", expected.keys());
    assert_eq!(
        got.keys().collect::<Vec<_>>(),
        expected.keys().collect::<Vec<_>>()
    );
    for (path, bytes) in &expected {
        assert!(&got[path] == bytes, "{} differs", path.display());
    }
    // Each slice ran as a job of the cluster, which completed.
    let slices: Vec<PathBuf> = std::fs::read_dir(on_slurm.join("_slurm"))
        .unwrap()
        .map(|entry| entry.unwrap().path())
        .collect();
    assert_eq!(slices.len(), 3);
    let mut listed = BTreeSet::new();
    for slice in &slices {
        let id: u64 = std::fs::read_to_string(slice.join("slurm_job_id"))
            .unwrap()
            .trim()
            .parse()
            .unwrap();
        // acq takes a job's exit status from its directory; the controller
        // may still say COMPLETING while the node's epilog runs.
        cluster.wait_for_job(id, "COMPLETED", Duration::from_secs(30));
        for line in std::fs::read_to_string(slice.join("inputs.txt"))
            .unwrap()
            .lines()
        {
            assert!(listed.insert(line.to_string()), "{line} in two slices");
        }
    }
    assert_eq!(listed.len(), backlog.len());

    // Again: every job runs again, skips its sources and changes nothing.
    let modified = |lake: &Path| -> Vec<std::time::SystemTime> {
        lake_tables(lake)
            .keys()
            .map(|p| std::fs::metadata(lake.join(p)).unwrap().modified().unwrap())
            .collect()
    };
    let before = modified(&on_slurm);
    let said = ingest(&on_slurm, &["--slurm", "--slices", "3"]);
    assert_eq!(said.matches(": done").count(), 3, "{said}");
    assert_eq!(modified(&on_slurm), before);
    let skipped: usize = slices
        .iter()
        .map(|slice| {
            std::fs::read_to_string(slice.join("stderr.txt"))
                .unwrap()
                .matches("unchanged since its ingest, skipped")
                .count()
        })
        .sum();
    assert_eq!(skipped, backlog.len());
}
