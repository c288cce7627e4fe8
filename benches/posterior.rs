//! The posterior stage on the built-in excavator twin, sampled directly:
//! 4 chains of 1,000 kept draws (the target: every R-hat below
//! 1.01 in under 5 s on two cores). Each case is calibrated with and
//! without `--posterior` in the same run; the difference is the stage's
//! time (sampling, the scales, 50 predictive runs, the files).
//!
//! Then effective samples per second against emcee 3.1.6 (the
//! affine-invariant ensemble, 32 walkers; Python in a scratch virtualenv
//! made from the package registry) on the same banana-shaped posterior in
//! the same run: acq's smallest bulk ESS over its wall time, emcee's draws
//! over its integrated autocorrelation time over its wall time (the
//! sampling alone in both).
//!
//! `cargo bench --bench posterior`

use std::path::Path;
use std::time::Instant;

use acq_algorithms::evaluation::Parameter;
use acq_algorithms::mcmc::{sample, SamplerSettings};
use acq_study::extras::NoExtras;
use acq_study::method::{start_design, BoMethod, Method, RunSettings};
use acq_study::posterior::likelihood::StudyPosterior;
use acq_study::posterior::Discrepancy;
use acq_study::posterior::PosteriorSettings;
use acq_study::run_directory::RunDirectory;
use acq_study::study::{
    Case, LossKind, Measured, Model, ModelRun, Observation, Residuals, Role, Study, StudyParameter,
};
use acq_study::study_runner::run_study;
use acq_workflows::calibrate::excavator::{run, CalibrateExcavatorOptions, ExcavatorPosterior};

// A benchmark reports without a peer: it takes `try_peer_python` only.
#[allow(dead_code)]
#[path = "../tests/common/peers.rs"]
mod peers;
#[path = "../tests/common/toy.rs"]
mod toy;

fn median(mut values: Vec<f64>) -> f64 {
    values.sort_by(f64::total_cmp);
    values[values.len() / 2]
}

fn main() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let arguments =
        |case: &str, out: &Path, posterior: bool, discrepancy| CalibrateExcavatorOptions {
            posterior: posterior.then_some(ExcavatorPosterior {
                discrepancy,
                draws_per_chain: ExcavatorPosterior::DRAWS_PER_CHAIN,
            }),
            ..CalibrateExcavatorOptions::published(
                &root.join(format!("data/excavator/{case}.toml")),
                out,
            )
        };
    println!("posterior of the excavator twin, sampled directly (4 chains x 1,000 draws)");
    for (case, discrepancy, label) in [
        ("case1", Discrepancy::None, "noise scale estimated"),
        ("case1", Discrepancy::Constant, "constant discrepancy"),
        ("case2", Discrepancy::None, "noise scale estimated"),
    ] {
        let mut stage_s = Vec::new();
        let mut worst_rhat = 0.0f64;
        let mut least_ess = f64::INFINITY;
        for _ in 0..3 {
            let dir = tempfile::tempdir().expect("temp dir");
            let start = Instant::now();
            run(arguments(
                case,
                &dir.path().join("search"),
                false,
                discrepancy,
            ))
            .expect("search");
            let search_s = start.elapsed().as_secs_f64();
            let start = Instant::now();
            run(arguments(
                case,
                &dir.path().join("posterior"),
                true,
                discrepancy,
            ))
            .expect("posterior");
            stage_s.push(start.elapsed().as_secs_f64() - search_s);
            let summary: serde_json::Value = serde_json::from_str(
                &std::fs::read_to_string(dir.path().join("posterior/summary.json"))
                    .expect("summary"),
            )
            .expect("json");
            for entry in summary["posterior"]
                .as_object()
                .expect("posterior")
                .values()
            {
                worst_rhat = worst_rhat.max(entry["rhat"].as_f64().unwrap_or(f64::INFINITY));
                least_ess = least_ess.min(entry["ess_bulk"].as_f64().unwrap_or(0.0));
            }
        }
        println!(
            "  {case}, {label}: posterior stage median {:.2} s (min {:.2} s) over {} runs; largest R-hat {worst_rhat:.4}, least bulk ESS {least_ess:.0}",
            median(stage_s.clone()),
            stage_s.iter().copied().fold(f64::INFINITY, f64::min),
            stage_s.len()
        );
    }
    banana_against_emcee();
    emulated_eight_parameters();
}

/// Ten outputs of eight parameters in [0, 1], nearly linear with a square
/// each: `y_k = sum_i sin(k + i + 1) x_i + 0.3 x_(k mod 8)^2`.
struct EightParameters;

impl Model for EightParameters {
    fn run(
        &self,
        inputs: &[(String, f64)],
        scalars: &[&str],
        _curves: &[&str],
    ) -> Result<ModelRun, String> {
        let x: Vec<f64> = (0..8)
            .map(|i| toy::input(inputs, &format!("x{i}")))
            .collect::<Result<_, _>>()?;
        Ok(ModelRun {
            scalars: scalars
                .iter()
                .map(|name| eight_parameter_output(&x, name[1..].parse().unwrap_or(0)))
                .collect(),
            curves: Vec::new(),
        })
    }
}

fn eight_parameter_output(x: &[f64], k: usize) -> f64 {
    (0..8)
        .map(|i| ((k + i + 1) as f64).sin() * x[i])
        .sum::<f64>()
        + 0.3 * x[k % 8].powi(2)
}

/// The target: the emulated posterior of 8 parameters from 100
/// logged runs in under 30 s of acq's own time (the model here runs in
/// microseconds, so the stage's wall time is acq's), with at most 20
/// refinement runs.
fn emulated_eight_parameters() {
    let truth: Vec<f64> = (0..8).map(|i| 0.3 + 0.05 * i as f64).collect();
    let study = Study {
        parameters: (0..8)
            .map(|i| StudyParameter {
                search: Parameter::new(format!("x{i}"), 0.0, 1.0),
                input: format!("x{i}"),
                case: None,
                nominal: 0.5,
                prior: None,
            })
            .collect(),
        cases: vec![Case::new(
            "main",
            Role::Fit,
            (0..10)
                .map(|k| Observation {
                    name: format!("y{k}"),
                    output: format!("y{k}"),
                    measured: Measured::Scalar {
                        // The truth's values, off by a fixed half sd either way.
                        value: eight_parameter_output(&truth, k)
                            + if k % 2 == 0 { 0.01 } else { -0.01 },
                        uncertainty: Some(0.02),
                    },
                    weight: 1.0,
                    source: String::new(),
                    shared: Vec::new(),
                })
                .collect(),
        )],
        named_cases: false,
        residuals: Residuals::Normalised,
        loss: LossKind::Squares,
    };
    let dir = tempfile::tempdir().expect("temp dir");
    let directory = RunDirectory::create(&dir.path().join("run")).expect("run directory");
    let method = Method::Bo(BoMethod {
        start: "lhs".into(),
        start_runs: 100,
        max_evals: 100,
        target_loss: None,
        acquisition: None,
        patience: None,
        batch: 1,
        seed: 3,
        local_steps: false,
        deterministic: true,
    });
    let initial = start_design(&study.search_parameters(), &method, dir.path()).expect("design");
    let run = run_study(
        &study,
        &EightParameters,
        &method,
        initial,
        &directory,
        &RunSettings {
            label: "eight".into(),
            title: "eight".into(),
            spec_directory: dir.path(),
            parallel: 1,
            resume: false,
            progress: None,
            posterior: Some(PosteriorSettings {
                predictive_runs: 10,
                seed: 3,
                ..PosteriorSettings::default()
            }),
        },
        &NoExtras,
    )
    .expect("study");
    let posterior = run.outcome.posterior.expect("posterior");
    let refinement = std::fs::read_to_string(directory.file("posterior_refinement.csv"))
        .map(|t| t.lines().count().saturating_sub(1))
        .unwrap_or(0);
    let worst_rhat = posterior.marginals[..8]
        .iter()
        .map(|m| m.rhat)
        .fold(0.0, f64::max);
    let held = posterior.marginals[..8]
        .iter()
        .zip(&truth)
        .filter(|(m, t)| (m.q05..=m.q95).contains(*t))
        .count();
    println!(
        "emulated posterior, 8 parameters from 100 logged runs: {:.1} s (acq's own: the model runs in microseconds), {refinement} refinement runs, largest R-hat {worst_rhat:.4}, the truth inside {held} of 8 90 % intervals",
        posterior.wall_s
    );
}

/// The banana: `y = a exp(-b t)` seen at t = 1 and 2, sd 0.1.
const TIMES: [f64; 2] = [1.0, 2.0];
const MEASURED: [f64; 2] = [0.62, 0.35];
const SD: f64 = 0.1;
const BOUNDS: [(&str, f64, f64); 2] = [("a", 0.2, 3.0), ("b", 0.05, 2.0)];

fn banana_against_emcee() {
    let measured: Vec<(f64, f64)> = TIMES.iter().copied().zip(MEASURED).collect();
    let study = toy::toy_study(&BOUNDS, &measured, SD);
    let density = StudyPosterior::new(&study, Discrepancy::None, 0).expect("density");
    let log_density = |p: &[f64]| {
        let outputs: Vec<f64> = TIMES.iter().map(|t| p[0] * (-p[1] * t).exp()).collect();
        density.log_prior(p) + density.log_likelihood(&outputs, &[])
    };
    let settings = SamplerSettings {
        chains: 4,
        draws: 4000,
        warmup: 2000,
        thin: None,
        seed: 21,
    };
    let mut rates = Vec::new();
    for _ in 0..3 {
        let start = Instant::now();
        let chains = sample(
            log_density,
            &density.support(),
            &vec![vec![0.8, 0.4]; 4],
            &[0.3, 0.3],
            &settings,
            &|_| {},
        )
        .expect("chains");
        let seconds = start.elapsed().as_secs_f64();
        let ess = chains
            .summaries()
            .iter()
            .map(|m| m.ess_bulk)
            .fold(f64::INFINITY, f64::min);
        rates.push((ess / seconds, ess, seconds));
    }
    let Some(python) = emcee_python() else {
        println!(
            "  emcee: no scratch virtualenv could be made (python3 -m venv, pip); no comparison"
        );
        return;
    };
    let output = std::process::Command::new(&python)
        .arg(Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/peers/banana_emcee.py"))
        .output()
        .expect("python");
    let theirs: serde_json::Value = serde_json::from_slice(&output.stdout).expect("emcee's rates");
    let theirs: Vec<[f64; 3]> = serde_json::from_value(theirs["runs"].clone()).expect("runs");
    let median_rate = |mut r: Vec<f64>| median(std::mem::take(&mut r));
    let ours = median_rate(rates.iter().map(|r| r.0).collect());
    let emcee = median_rate(theirs.iter().map(|r| r[0]).collect());
    println!(
        "banana posterior, effective samples per second (median of 3): acq {ours:.0} (ESS {:.0} in {:.2} s), emcee {emcee:.0} (ESS {:.0} in {:.2} s): {:.1} times",
        rates[0].1,
        rates[0].2,
        theirs[0][1],
        theirs[0][2],
        ours / emcee
    );
}

/// The Python of the peers' virtualenv with emcee (scripts/python-peers,
/// as the tests make it), or `None` when it cannot be made.
fn emcee_python() -> Option<std::path::PathBuf> {
    peers::try_peer_python(
        Path::new(env!("CARGO_MANIFEST_DIR")),
        Path::new(env!("CARGO_TARGET_TMPDIR")),
        "mcmc",
    )
    .ok()
}
