//! acq's Slurm executor on a real one-node cluster (started here, as the
//! tests start it: tests/common/slurm.rs).
//!
//! 1. Slot efficiency: a solver that sleeps S = 2 s, 2 slots, 20
//!    evaluations of a BO study. Wall time over (20 x S / 2); the target is
//!    at most 1.15. Each job's scheduling overhead is split into submit ->
//!    start (the `queue_wait_s` acq logs) and the rest of its evaluation
//!    beyond the solver's run (sbatch, noticing the end, reading outputs).
//! 2. A real solver: the CalculiX example (4x20 mesh, 16 runs, 2 slots) on
//!    Slurm, for the spread of a nonlinear FE solver's run times across the
//!    parameter box.
//! 3. A scale table computed from those measurements: the tensile study's
//!    150 runs of 96 s (Abaqus/Explicit on 4 CPUs, `../shared/reference/`)
//!    on 1, 8 and 32 slots, in synchronous batches (each batch waits for
//!    its slowest run) and as they finish (acq's way), with the measured
//!    per-run overhead and the CalculiX run times' spread scaled to 96 s.
//!
//! `cargo bench --bench slurm` (needs munge and Slurm's daemons: scripts/test
//! installs them).

#[path = "../tests/common/slurm.rs"]
#[allow(dead_code)]
mod cluster;

use std::collections::HashMap;
use std::path::Path;
use std::process::Command;
use std::time::Instant;

const SLEEP_S: f64 = 2.0;
const SLOTS: usize = 2;
const EVALUATIONS: usize = 20;

fn median(values: &[f64]) -> f64 {
    let mut sorted = values.to_vec();
    sorted.sort_by(f64::total_cmp);
    sorted[sorted.len() / 2]
}

/// Runs a study; its wall time in seconds.
fn calibrate(cluster: &cluster::Cluster, spec: &Path, run: &Path) -> f64 {
    calibrate_with(cluster, spec, run, &[])
}

fn calibrate_with(
    cluster: &cluster::Cluster,
    spec: &Path,
    run: &Path,
    environment: &[(&str, &str)],
) -> f64 {
    let start = Instant::now();
    let output = Command::new(env!("CARGO_BIN_EXE_acq"))
        .args(["calibrate", "external", "--spec"])
        .arg(spec)
        .arg("--out")
        .arg(run)
        .env("SLURM_CONF", &cluster.conf)
        .envs(environment.iter().copied())
        .output()
        .expect("acq runs");
    let wall = start.elapsed().as_secs_f64();
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    wall
}

/// Per evaluation: (queue wait, solver run, the rest of the evaluation).
fn split(rows: &[HashMap<String, String>]) -> Vec<(f64, f64, f64)> {
    rows.iter()
        .map(|row| {
            let number = |name: &str| row[name].parse::<f64>().expect(name);
            let (wait, run, wall) = (number("queue_wait_s"), number("run_s"), number("wall_s"));
            (wait, run, (wall - wait - run).max(0.0))
        })
        .collect()
}

/// Wall time of `runs` (run times in s) on `slots`, each run costing
/// `overhead_s` more: in synchronous batches, or started as slots free.
fn schedule(runs: &[f64], slots: usize, overhead_s: f64, batches: bool) -> f64 {
    if batches {
        runs.chunks(slots)
            .map(|batch| batch.iter().copied().fold(0.0, f64::max) + overhead_s)
            .sum()
    } else {
        let mut free_at = vec![0.0f64; slots];
        for run in runs {
            let slot = (0..slots)
                .min_by(|&a, &b| free_at[a].total_cmp(&free_at[b]))
                .expect("a slot");
            free_at[slot] += run + overhead_s;
        }
        free_at.into_iter().fold(0.0, f64::max)
    }
}

fn main() {
    let cluster = cluster::Cluster::start();
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));

    // 1. Slot efficiency.
    let dir = tempfile::tempdir().expect("temp dir");
    let (spec, run) = cluster::toy_study(dir.path(), SLOTS, 4, EVALUATIONS, 60);
    let sleep = SLEEP_S.to_string();
    let wall = calibrate_with(&cluster, &spec, &run, &[("ACQ_TEST_SLEEP_S", &sleep)]);
    let rows = cluster::evaluations(&run);
    assert_eq!(rows.len(), EVALUATIONS, "the study ran its whole budget");
    let parts = split(&rows);
    let ideal = EVALUATIONS as f64 * SLEEP_S / SLOTS as f64;
    let waits: Vec<f64> = parts.iter().map(|p| p.0).collect();
    let runs: Vec<f64> = parts.iter().map(|p| p.1).collect();
    let rests: Vec<f64> = parts.iter().map(|p| p.2).collect();
    let overhead = |p: &(f64, f64, f64)| p.0 + p.2 + (p.1 - SLEEP_S).max(0.0);
    let overheads: Vec<f64> = parts.iter().map(overhead).collect();
    println!(
        "BENCH slurm slots: {EVALUATIONS} evaluations of a {SLEEP_S} s solver on {SLOTS} slots: wall {wall:.1} s, ideal {ideal:.1} s, ratio {:.3}",
        wall / ideal
    );
    println!(
        "BENCH slurm overhead per evaluation: submit->start median {:.3} s (max {:.3}), solver run median {:.3} s (python start included), sbatch + end->collected median {:.3} s (max {:.3}); all overhead median {:.3} s",
        median(&waits),
        waits.iter().copied().fold(0.0, f64::max),
        median(&runs),
        median(&rests),
        rests.iter().copied().fold(0.0, f64::max),
        median(&overheads)
    );

    // 2. The CalculiX example on Slurm.
    let dir = tempfile::tempdir().expect("temp dir");
    let example = root.join("examples/calculix-tensile");
    for file in ["tensile.py", "measured.csv"] {
        std::fs::copy(example.join(file), dir.path().join(file)).expect("example file");
    }
    let text = std::fs::read_to_string(example.join("spec-bo.toml"))
        .expect("spec")
        .replace("\"6x30\"", "\"4x20\"")
        .replace("max_evals = 24", "max_evals = 16")
        + "\n[executor]\nkind = \"slurm\"\n";
    let spec = dir.path().join("spec.toml");
    std::fs::write(&spec, text).expect("spec");
    let run = dir.path().join("run");
    let wall = calibrate(&cluster, &spec, &run);
    let parts = split(&cluster::evaluations(&run));
    let runs: Vec<f64> = parts.iter().map(|p| p.1).collect();
    let mean = runs.iter().sum::<f64>() / runs.len() as f64;
    let spread =
        (runs.iter().map(|r| (r - mean).powi(2)).sum::<f64>() / (runs.len() - 1) as f64).sqrt();
    let per_run_overhead = median(&parts.iter().map(|p| p.0 + p.2).collect::<Vec<_>>());
    println!(
        "BENCH slurm calculix 4x20: {} runs on {SLOTS} slots in {wall:.1} s; run time mean {mean:.2} s, coefficient of variation {:.3}; overhead per run median {per_run_overhead:.3} s",
        runs.len(),
        spread / mean
    );

    // 3. The tensile study at cluster scale, from the measurements.
    const STUDY_RUNS: usize = 150;
    const STUDY_RUN_S: f64 = 96.0;
    let scaled: Vec<f64> = (0..STUDY_RUNS)
        .map(|i| runs[i % runs.len()] * STUDY_RUN_S / mean)
        .collect();
    let toy_overhead = median(&overheads);
    println!(
        "| slots | synchronous batches | as they finish | saved | (150 runs of 96 s mean, CalculiX spread {:.1} %, {toy_overhead:.2} s overhead per run) |",
        100.0 * spread / mean
    );
    println!("|---|---|---|---|");
    for slots in [1, 8, 32] {
        let batches = schedule(&scaled, slots, toy_overhead, true);
        let finish = schedule(&scaled, slots, toy_overhead, false);
        println!(
            "| {slots} | {:.0} min | {:.0} min | {:.0} % |",
            batches / 60.0,
            finish / 60.0,
            100.0 * (1.0 - finish / batches)
        );
    }
}
