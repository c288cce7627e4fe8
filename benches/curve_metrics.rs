//! Each curve metric against `similaritymeasures` 1.5.0 on 1,000-point
//! curves, in the same run (BENCHMARKS.md, "Curve metrics"): a pull to
//! fracture against a stiffer one that breaks earlier, a hysteresis loop
//! against one of another phase, and a pull against a simulation that ends
//! at 70 % of it (900 points, so the area's point insertion runs too).
//! acq's time is the full `matched` (value, coupling, signed distances),
//! what a study computes per run; the library's is its value alone. The
//! library runs in a scratch virtualenv (made on first use from the
//! package registry), never in acq's dependencies.
//!
//! `cargo bench --bench curve_metrics` (about a minute on 2 cores).

use std::time::Instant;

use acq_analysis::loss::metrics::{matched, CurveMetric};

#[path = "../tests/common/mod.rs"]
mod common;

const METRICS: [CurveMetric; 4] = [
    CurveMetric::Pcm,
    CurveMetric::Frechet,
    CurveMetric::Dtw,
    CurveMetric::Area,
];

fn sampled(count: usize, shape: impl Fn(f64) -> [f64; 2]) -> Vec<[f64; 2]> {
    (0..count)
        .map(|k| shape(k as f64 / (count - 1) as f64))
        .collect()
}

fn pull(stiffness: f64, break_at: f64, end: f64) -> impl Fn(f64) -> [f64; 2] {
    move |t: f64| {
        let u = t * end;
        let drop = if u > break_at {
            ((1.0 - u) / (1.0 - break_at)).max(0.0)
        } else {
            1.0
        };
        [8.0 * u, 40.0 * (1.0 - (-stiffness * u).exp()) * drop]
    }
}

fn hysteresis(phase: f64) -> impl Fn(f64) -> [f64; 2] {
    move |t: f64| {
        let a = std::f64::consts::TAU * 1.5 * t;
        [a.sin(), (a + phase).sin() + 0.1 * a.cos()]
    }
}

fn main() {
    let pairs = [
        (
            "pull, the simulation breaking earlier",
            sampled(1000, pull(10.0, 0.9, 1.0)),
            sampled(1000, pull(12.0, 0.8, 1.0)),
        ),
        (
            "hysteresis loops, 1.5 turns",
            sampled(1000, hysteresis(0.6)),
            sampled(1000, hysteresis(0.75)),
        ),
        (
            "pull, the simulation ending at 70 % (900 points)",
            sampled(1000, pull(10.0, 0.9, 1.0)),
            sampled(900, pull(10.5, 0.9, 0.7)),
        ),
    ];
    let python = common::scratch_python("curves");
    let dir = tempfile::tempdir().unwrap();
    let data = dir.path().join("pairs.json");
    let as_json: Vec<_> = pairs.iter().map(|(_, m, s)| (m, s)).collect();
    std::fs::write(&data, serde_json::json!(as_json).to_string()).unwrap();
    let script = common::root().join("tests/similaritymeasures/metrics.py");
    // The library's best of three runs.
    let mut theirs = vec![[f64::INFINITY; 4]; pairs.len()];
    for _ in 0..3 {
        let output = std::process::Command::new(&python)
            .args([common::path_arg(&script), common::path_arg(&data), "--time"])
            .output()
            .unwrap();
        assert!(output.status.success(), "{}", common::stderr(&output));
        let run: Vec<[f64; 4]> = serde_json::from_slice(&output.stdout).unwrap();
        for (best, times) in theirs.iter_mut().zip(run) {
            for (b, t) in best.iter_mut().zip(times) {
                *b = b.min(t);
            }
        }
    }
    println!("| curves | metric | acq (median) | similaritymeasures (best of 3) | acq faster by |");
    println!("|---|---|---|---|---|");
    let mut slowest_ratio = f64::INFINITY;
    for ((name, measured, simulated), library) in pairs.iter().zip(&theirs) {
        for (metric, &library_s) in METRICS.iter().zip(library) {
            let mut times: Vec<f64> = (0..15)
                .map(|_| {
                    let start = Instant::now();
                    let result = matched(*metric, measured, simulated).unwrap();
                    std::hint::black_box(result);
                    start.elapsed().as_secs_f64()
                })
                .collect();
            times.sort_by(f64::total_cmp);
            let ours = times[times.len() / 2];

            let ratio = library_s / ours;
            slowest_ratio = slowest_ratio.min(ratio);
            println!(
                "| {name} | {metric} | {:.3} ms | {:.1} ms | {ratio:.0}x |",
                ours * 1e3,
                library_s * 1e3
            );
        }
    }
    println!("smallest ratio: {slowest_ratio:.0}x (target: at least 50x)");
}
