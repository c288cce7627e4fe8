//! An external curve study on tests it was not designed on.
//!
//! The user's solver is a Bouc-Wen hysteresis element written as a shell
//! script (`fixtures/hysteresis/boucwen.sh`, awk; gamma = 0.5 known), and
//! the study fits k, alpha and beta from one measured loop with `acq
//! calibrate external` (Bayesian optimisation, `l12` start, local steps
//! on the coupling's signed residuals: the defaults), once per coupling
//! metric.
//!
//! Each synthetic test is the element at a parameter set from a maximin
//! Latin hypercube over the search box, measured as a rig would measure it:
//! 120 points a cycle where the model writes 150 (another x grid), with
//! Gaussian noise of 0.25 % of the displacement's range on x and 1 % of
//! the force's range on y. The target is the metric's value at the truth
//! on that noisy loop: a search that reaches it has found a point as good
//! as the truth (the best fit is never worse than the truth, so the target
//! can always be reached). The count is of simulations to target, the 12
//! start runs included.
//!
//! Two sets with their own seeds: `tune` (6 tests), on which this bench
//! was set up, and `held-out` (20 tests), run only to report; the search
//! itself was designed on neither. `ACQ_BENCH_SET=tune|held-out|all`
//! (default all); `ACQ_BENCH_MAX_EVALS` (default 60); `ACQ_BENCH_KEEP=DIR`
//! keeps the tests and run directories.
//!
//! `cargo bench --bench curve_study_generalisation`

use std::path::{Path, PathBuf};
use std::process::Command;

use acq_algorithms::doe::latin_hypercube;
use acq_analysis::loss::metrics::{matched, CurveMetric};
use acq_workflows::calibrate::external::{run, CalibrateExternalOptions};
use rand::SeedableRng;
use rand_distr::{Distribution, Normal};

/// (name, lower, upper) of the searched parameters.
const BOX: [(&str, f64, f64); 3] = [("k", 1.0, 3.0), ("alpha", 0.05, 0.6), ("beta", 0.5, 3.0)];
const GAMMA: f64 = 0.5;
const MODEL_POINTS: usize = 150;
const MEASURED_POINTS: usize = 120;
const X_NOISE_OF_RANGE: f64 = 0.0025;
const Y_NOISE_OF_RANGE: f64 = 0.01;
const TUNE_SEED: u64 = 41;
const TUNE_TESTS: usize = 16;
const HELD_OUT_SEED: u64 = 43;
const HELD_OUT_TESTS: usize = 20;
const METRICS: [(&str, CurveMetric); 4] = [
    ("pcm", CurveMetric::Pcm),
    ("frechet", CurveMetric::Frechet),
    ("dtw", CurveMetric::Dtw),
    ("area", CurveMetric::Area),
];

/// Runs the element at `values` (k, alpha, beta) with `points` a cycle
/// into `out`; its `(x, force)` points.
fn bouc_wen(dir: &Path, values: &[f64], points: usize, out: &str) -> Vec<[f64; 2]> {
    let status = Command::new("sh")
        .current_dir(dir)
        .arg("boucwen.sh")
        .args(values.iter().map(|v| format!("{v:.17}")))
        .arg(format!("{GAMMA}"))
        .arg(points.to_string())
        .arg(out)
        .status()
        .expect("sh runs");
    assert!(status.success(), "boucwen.sh failed");
    read_loop(&dir.join(out))
}

fn read_loop(path: &Path) -> Vec<[f64; 2]> {
    std::fs::read_to_string(path)
        .expect("a loop")
        .lines()
        .skip(1)
        .map(|line| {
            let mut fields = line
                .split(',')
                .map(|f| f.trim().parse::<f64>().expect("a number"));
            [fields.next().expect("x"), fields.next().expect("force")]
        })
        .collect()
}

fn range(points: &[[f64; 2]], axis: usize) -> f64 {
    let (low, high) = points
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), p| {
            (l.min(p[axis]), h.max(p[axis]))
        });
    high - low
}

struct Test {
    name: String,
    truth: Vec<f64>,
    dir: PathBuf,
    /// The truth's loop at the model's sampling, to score the truth by.
    truth_loop: Vec<[f64; 2]>,
    measured: Vec<[f64; 2]>,
}

fn make_set(root: &Path, work: &Path, set: &str, seed: u64, count: usize) -> Vec<Test> {
    let design = latin_hypercube(count, BOX.len(), seed);
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed * 1000);
    design
        .iter()
        .enumerate()
        .map(|(index, unit)| {
            let name = format!("{set}-{index:02}");
            let dir = work.join(&name);
            std::fs::create_dir_all(&dir).expect("test dir");
            std::fs::copy(
                root.join("fixtures/hysteresis/boucwen.sh"),
                dir.join("boucwen.sh"),
            )
            .expect("the script");
            let truth: Vec<f64> = BOX
                .iter()
                .zip(unit)
                .map(|((_, lower, upper), u)| lower + u * (upper - lower))
                .collect();
            let truth_loop = bouc_wen(&dir, &truth, MODEL_POINTS, "truth.csv");
            let exact = bouc_wen(&dir, &truth, MEASURED_POINTS, "exact.csv");
            let x_noise = Normal::new(0.0, X_NOISE_OF_RANGE * range(&exact, 0)).expect("sd");
            let y_noise = Normal::new(0.0, Y_NOISE_OF_RANGE * range(&exact, 1)).expect("sd");
            let measured: Vec<[f64; 2]> = exact
                .iter()
                .map(|p| {
                    [
                        p[0] + x_noise.sample(&mut rng),
                        p[1] + y_noise.sample(&mut rng),
                    ]
                })
                .collect();
            let mut csv = String::from("x,force\n");
            for p in &measured {
                csv.push_str(&format!("{:.12},{:.12}\n", p[0], p[1]));
            }
            std::fs::write(dir.join("measured.csv"), csv).expect("measured");
            Test {
                name,
                truth,
                dir,
                truth_loop,
                measured,
            }
        })
        .collect()
}

fn spec(test: &Test, metric: &str, target: f64, max_evals: usize) -> PathBuf {
    let mut text = format!(
        r#"command = ["sh", "boucwen.sh", "{{k}}", "{{alpha}}", "{{beta}}", "{GAMMA}", "{MODEL_POINTS}", "curve.csv"]
parallel = 1

[[curve]]
name = "loop"
file = "curve.csv"
x = "x"
y = "force"
measured_file = "measured.csv"
measured_x = "x"
measured_y = "force"
metric = "{metric}"

[search]
method = "bo"
start = "l12"
max_evals = {max_evals}
target_loss_pct = {target:e}
"#
    );
    for (name, lower, upper) in BOX {
        text.push_str(&format!(
            "\n[[parameter]]\nname = \"{name}\"\nlower = {lower:?}\nupper = {upper:?}\n"
        ));
    }
    let path = test.dir.join(format!("{metric}.toml"));
    std::fs::write(&path, text).expect("spec");
    path
}

struct Row {
    test: String,
    metric: &'static str,
    target: f64,
    best: f64,
    to_target: Option<usize>,
    evaluations: usize,
    /// The largest error of a found parameter, in % of its range.
    worst_parameter_pct: f64,
}

fn calibrate(test: &Test, metric: &'static str, kind: CurveMetric, max_evals: usize) -> Row {
    let target = matched(kind, &test.measured, &test.truth_loop)
        .expect("the truth scores")
        .value;
    let out = test.dir.join(format!("run-{metric}"));
    if out.exists() {
        std::fs::remove_dir_all(&out).expect("an earlier run");
    }
    run(CalibrateExternalOptions {
        spec: spec(test, metric, target, max_evals),
        out: out.clone(),
        resume: false,
        seed: 1,
    })
    .expect("the study runs");
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).expect("summary"))
            .expect("json");
    let worst_parameter_pct = BOX
        .iter()
        .zip(&test.truth)
        .map(|((name, lower, upper), truth)| {
            let found = summary["best_params"][name].as_f64().expect("a parameter");
            100.0 * (found - truth).abs() / (upper - lower)
        })
        .fold(0.0, f64::max);
    Row {
        test: test.name.clone(),
        metric,
        target,
        best: summary["best_loss_pct"].as_f64().expect("best loss"),
        to_target: summary["evaluations_to_target"]
            .as_u64()
            .map(|n| n as usize),
        evaluations: summary["evaluations"].as_u64().unwrap_or(0) as usize,
        worst_parameter_pct,
    }
}

fn report(set: &str, tests: &[Test], rows: &[Row], max_evals: usize) {
    println!("\n{set}: simulations to the truth's own value, within {max_evals}");
    println!("| test | truth k, alpha, beta | metric | truth's value | best | simulations to target | worst parameter, % of range |");
    println!("|---|---|---|---|---|---|---|");
    for row in rows {
        let truth = &tests
            .iter()
            .find(|t| t.name == row.test)
            .expect("test")
            .truth;
        println!(
            "| {} | {:.3}, {:.3}, {:.3} | {} | {:.5} | {:.5} | {} | {:.2} |",
            row.test,
            truth[0],
            truth[1],
            truth[2],
            row.metric,
            row.target,
            row.best,
            row.to_target
                .map_or(format!("not in {}", row.evaluations), |n| n.to_string()),
            row.worst_parameter_pct
        );
    }
    for (metric, _) in METRICS {
        let of_metric: Vec<&Row> = rows.iter().filter(|r| r.metric == metric).collect();
        let mut counts: Vec<usize> = of_metric.iter().filter_map(|r| r.to_target).collect();
        counts.sort_unstable();
        let within_30 = counts.iter().filter(|&&n| n <= 30).count();
        let mut errors: Vec<f64> = of_metric.iter().map(|r| r.worst_parameter_pct).collect();
        errors.sort_by(f64::total_cmp);
        println!(
            "{set}, {metric}: {} of {} reach the truth's value within 30 ({:.0} %), {} within {max_evals}; median {}, max {}; worst parameter's error at the best point: median {:.1} % of its range, largest {:.1} %",
            within_30,
            of_metric.len(),
            100.0 * within_30 as f64 / of_metric.len().max(1) as f64,
            counts.len(),
            counts.get(counts.len() / 2).map_or("-".into(), |m| m.to_string()),
            counts.last().map_or("-".into(), |m| m.to_string()),
            errors.get(errors.len() / 2).copied().unwrap_or(f64::NAN),
            errors.last().copied().unwrap_or(f64::NAN),
        );
    }
}

fn main() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let which = std::env::var("ACQ_BENCH_SET").unwrap_or_else(|_| "all".into());
    let max_evals: usize = std::env::var("ACQ_BENCH_MAX_EVALS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(60);
    let scratch = tempfile::tempdir().expect("temp dir");
    let work = std::env::var_os("ACQ_BENCH_KEEP")
        .map(PathBuf::from)
        .unwrap_or_else(|| scratch.path().to_path_buf());
    let mut sets = Vec::new();
    if matches!(which.as_str(), "tune" | "all") {
        sets.push(("tune", make_set(root, &work, "tune", TUNE_SEED, TUNE_TESTS)));
    }
    if matches!(which.as_str(), "held-out" | "all") {
        sets.push((
            "held-out",
            make_set(root, &work, "held-out", HELD_OUT_SEED, HELD_OUT_TESTS),
        ));
    }
    for (set, tests) in &sets {
        let mut rows = Vec::new();
        for test in tests {
            for (metric, kind) in METRICS {
                let row = calibrate(test, metric, kind, max_evals);
                eprintln!(
                    "{} {metric}: target {:.5}, best {:.5}, to target {:?}",
                    row.test, row.target, row.best, row.to_target
                );
                rows.push(row);
            }
        }
        report(set, tests, &rows, max_evals);
    }
}
