//! The posterior stage against what it must equal.
//!
//! - **Closed form**: a straight line `y = a + b t` at five points with
//!   normal noise of known sd and normal priors has a normal posterior
//!   with a known mean and covariance. Sampled by both paths: the model
//!   run at every step (in process), and a solver script through a spec
//!   (a Gaussian-process emulator of its logged runs, refined by real runs).
//! - **Coverage**: 400 replicates of a nonlinear toy with the truth drawn
//!   from the prior and known noise: the 90 % intervals hold the truth in
//!   86-94 % of them.
//! - **Model error**: a toy whose model lacks an offset the data have.
//!   Without discrepancy the intervals miss the truth in most replicates;
//!   with a constant discrepancy coverage is back and the posterior names
//!   the offset's size. A missing term that varies over the cases is
//!   predicted at an untested case by a GP discrepancy, and missed
//!   without one.
//! - **Shared transducer errors**: twenty holds read by one transducer
//!   whose calibration error is the same in each. Taken as shared, the
//!   90 % intervals hold the truth in 86-94 % of 200 replicates; taken as
//!   independent (each hold its own error), far fewer.

mod common;

use std::path::Path;

use acq_algorithms::mcmc::{quantile, sample, Marginal, SamplerSettings};
use acq_analysis::loss::metrics::CurveMetric;
use acq_study::extras::NoExtras;
use acq_study::method::{LeastSquaresMethod, Method, RunSettings};
use acq_study::posterior::likelihood::{standard_normal, StudyPosterior};
use acq_study::posterior::{Discrepancy, PosteriorSettings};
use acq_study::run_directory::RunDirectory;
use acq_study::spec::Spec;
use acq_study::study::{Case, Measured, Model, ModelRun, Observation, Role, Study};
use acq_study::study_runner::run_study;
use acq_workflows::calibrate::models::BUILTIN_MODELS;
use common::coverage::{correlated_curve_hits, truth_from_prior};
use common::toy::input;
use common::{external_summary, number};
use rand::SeedableRng;
use rand_distr::{Distribution, Normal, Uniform};
use serde_json::Value;

// ---- the straight line -------------------------------------------------------------------

const TIMES: [f64; 5] = [0.0, 1.0, 2.0, 3.0, 4.0];
/// Measured at a = 2, b = 0.7 with these errors (fixed, so the test is too).
const MEASURED: [f64; 5] = [2.3, 2.3, 3.5, 4.6, 4.6];
const NOISE_SD: f64 = 0.5;
/// The priors' means and sds: the bounds lie 8 sds away, so cutting the
/// normal prior there changes nothing measurable.
const PRIOR: [(f64, f64); 2] = [(1.0, 2.0), (0.5, 1.0)];

/// The spec of the line: the solver (awk) writes the five values.
fn line_spec(dir: &Path, posterior: &str) -> std::path::PathBuf {
    std::fs::write(
        dir.join("line.sh"),
        "awk -v a=\"$1\" -v b=\"$2\" 'BEGIN { printf \"{\"; for (i = 0; i < 5; i++) printf \"%s\\\"y%d\\\": %.17g\", (i ? \", \" : \"\"), i, a + b * i; print \"}\" }' > out.json\n",
    )
    .unwrap();
    let mut text = String::from(
        "command = [\"sh\", \"line.sh\", \"{a}\", \"{b}\"]\noutput_file = \"out.json\"\nparallel = 2\n",
    );
    for (name, (mean, sd)) in ["a", "b"].iter().zip(PRIOR) {
        text.push_str(&format!(
            "\n[[parameter]]\nname = \"{name}\"\nlower = {}\nupper = {}\nprior = {{ value = {mean}, uncertainty = {sd} }}\n",
            mean - 8.0 * sd,
            mean + 8.0 * sd
        ));
    }
    for (i, y) in MEASURED.iter().enumerate() {
        text.push_str(&format!(
            "\n[[output]]\nname = \"y{i}\"\nmeasured = {y}\nuncertainty = {NOISE_SD}\n"
        ));
    }
    text.push_str("\n[search]\nmethod = \"least-squares\"\nresiduals = \"normalised\"\nloss = \"squares\"\nmax_evals = 40\n");
    text.push_str(posterior);
    let spec = dir.join("spec.toml");
    std::fs::write(&spec, text).unwrap();
    spec
}

/// The posterior's mean and covariance in closed form:
/// `S = (X'X / s^2 + P^-1)^-1`, `m = S (X'y / s^2 + P^-1 m0)`.
fn closed_form() -> ([f64; 2], [[f64; 2]; 2]) {
    let s2 = NOISE_SD * NOISE_SD;
    let mut precision = [
        [1.0 / PRIOR[0].1.powi(2), 0.0],
        [0.0, 1.0 / PRIOR[1].1.powi(2)],
    ];
    let mut right = [PRIOR[0].0 * precision[0][0], PRIOR[1].0 * precision[1][1]];
    for (t, y) in TIMES.iter().zip(MEASURED) {
        let x = [1.0, *t];
        for i in 0..2 {
            right[i] += x[i] * y / s2;
            for j in 0..2 {
                precision[i][j] += x[i] * x[j] / s2;
            }
        }
    }
    let det = precision[0][0] * precision[1][1] - precision[0][1] * precision[1][0];
    let covariance = [
        [precision[1][1] / det, -precision[0][1] / det],
        [-precision[1][0] / det, precision[0][0] / det],
    ];
    let mean = [
        covariance[0][0] * right[0] + covariance[0][1] * right[1],
        covariance[1][0] * right[0] + covariance[1][1] * right[1],
    ];
    (mean, covariance)
}

/// The draws' mean and covariance agree with the closed form within 3
/// Monte-Carlo standard errors: `sd / sqrt(ess)` for a mean, and for a
/// covariance entry of a normal `sqrt((s_ii s_jj + s_ij^2) / ess)`, with
/// the smaller bulk ESS of the two.
fn assert_closed_form(draws: &[[f64; 2]], ess: [f64; 2], path: &str) {
    let (mean, covariance) = closed_form();
    let n = draws.len() as f64;
    let sample_mean = [0, 1].map(|i| draws.iter().map(|d| d[i]).sum::<f64>() / n);
    for i in 0..2 {
        let mcse = covariance[i][i].sqrt() / ess[i].sqrt();
        assert!(
            (sample_mean[i] - mean[i]).abs() < 3.0 * mcse,
            "{path}: mean {} of {}, MCSE {mcse}",
            sample_mean[i],
            mean[i]
        );
        for j in 0..2 {
            let sample = draws
                .iter()
                .map(|d| (d[i] - sample_mean[i]) * (d[j] - sample_mean[j]))
                .sum::<f64>()
                / (n - 1.0);
            let se = ((covariance[i][i] * covariance[j][j] + covariance[i][j].powi(2))
                / ess[i].min(ess[j]))
            .sqrt();
            assert!(
                (sample - covariance[i][j]).abs() < 3.0 * se,
                "{path}: covariance[{i}][{j}] {sample} of {}, se {se}",
                covariance[i][j]
            );
        }
    }
}

/// The draws of `a` and `b` in `posterior.csv`.
fn posterior_draws(run: &Path) -> Vec<[f64; 2]> {
    let text = std::fs::read_to_string(run.join("posterior.csv")).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    assert_eq!(header[..2], ["chain", "draw"]);
    assert_eq!(*header.last().unwrap(), "log_posterior");
    let column = |name: &str| header.iter().position(|h| *h == name).unwrap();
    let (a, b) = (column("a"), column("b"));
    lines
        .map(|line| {
            let fields: Vec<f64> = line.split(',').map(|f| f.parse().unwrap()).collect();
            [fields[a], fields[b]]
        })
        .collect()
}

fn ess_of(summary: &Value) -> [f64; 2] {
    ["a", "b"].map(|p| number(summary, &["posterior", p, "ess_bulk"]))
}

/// The line in process: cheap, so sampled directly.
struct Line;

impl Model for Line {
    fn run(
        &self,
        inputs: &[(String, f64)],
        scalars: &[&str],
        _curves: &[&str],
    ) -> Result<ModelRun, String> {
        let (a, b) = (input(inputs, "a")?, input(inputs, "b")?);
        Ok(ModelRun {
            scalars: scalars
                .iter()
                .map(|name| {
                    let i: f64 = name[1..].parse().unwrap();
                    a + b * i
                })
                .collect(),
            curves: Vec::new(),
        })
    }

    fn is_cheap(&self) -> bool {
        true
    }
}

/// A study of the line in process, searched by least squares, its
/// posterior with `posterior`, into `out`.
fn line_in_process(
    study: &Study,
    out: &Path,
    posterior: PosteriorSettings,
) -> acq_study::study_runner::StudyRun {
    let directory = RunDirectory::create(out).unwrap();
    run_study(
        study,
        &Line,
        &Method::LeastSquares(LeastSquaresMethod { max_evals: 40 }),
        Vec::new(),
        &directory,
        &RunSettings {
            label: "line".into(),
            title: "line".into(),
            spec_directory: out,
            parallel: 1,
            resume: false,
            posterior: Some(posterior),
            progress: None,
        },
        &NoExtras,
    )
    .unwrap()
}

/// The line's posterior sampled in process (2000 draws, 10 predictive
/// runs), and its summary.
fn line_posterior_summary(study: &Study, out: &Path) -> Value {
    line_in_process(
        study,
        out,
        PosteriorSettings {
            draws: 2000,
            seed: 5,
            predictive_runs: 10,
            ..PosteriorSettings::default()
        },
    );
    serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap()
}

#[test]
fn a_straight_line_with_normal_priors_has_the_closed_form_posterior_by_the_direct_path() {
    let dir = tempfile::tempdir().unwrap();
    let spec = Spec::load(&line_spec(dir.path(), ""), &BUILTIN_MODELS).unwrap();
    let out = dir.path().join("direct");
    let summary = line_posterior_summary(&spec.study, &out);
    for p in ["a", "b"] {
        assert!(number(&summary, &["posterior", p, "rhat"]) < 1.01);
    }
    assert_closed_form(&posterior_draws(&out), ess_of(&summary), "direct");
    // Every measured value has its predictive interval and is named by case.
    for i in 0..5 {
        let entry = &summary["predictive"]["main"][format!("y{i}")];
        assert!(number(entry, &["q05"]) < number(entry, &["q95"]), "{entry}");
        assert_eq!(number(entry, &["measured"]), MEASURED[i]);
    }
    let predictive = std::fs::read_to_string(out.join("predictive.csv")).unwrap();
    assert!(predictive.starts_with("run,case,output,value,with_error\n"));
    assert_eq!(predictive.lines().count(), 1 + 5 * 10);
}

/// A slope whose range ends below what the data say (b = 0.69 +- 0.16;
/// upper bound 0.55): its posterior piles against the bound. Its one
/// verdict says so, never "pinned down" (the check before read only
/// intervals that lay wholly within 2 % of the range from the bound), and
/// every table of the report and `summary.json` give that one verdict.
#[test]
fn a_slope_pressed_against_its_bound_is_said_to_be_so_everywhere_and_never_pinned_down() {
    let dir = tempfile::tempdir().unwrap();
    let spec_path = line_spec(dir.path(), "");
    let text = std::fs::read_to_string(&spec_path).unwrap();
    // b's bounds: 0.5 -+ 8.
    assert!(text.contains("upper = 8.5"), "{text}");
    std::fs::write(&spec_path, text.replace("upper = 8.5", "upper = 0.55")).unwrap();
    let spec = Spec::load(&spec_path, &BUILTIN_MODELS).unwrap();
    let out = dir.path().join("run");
    let summary = line_posterior_summary(&spec.study, &out);
    let q95 = number(&summary, &["posterior", "b", "q95"]);
    assert!(
        q95 > 0.55 - 0.01 * 8.05,
        "b's interval reaches the bound: {q95}"
    );
    // ...and is wider than the old check's 2 % of the range: a case it
    // called "pinned down".
    let q05 = number(&summary, &["posterior", "b", "q05"]);
    assert!(0.55 - q05 > 0.02 * 8.05, "{q05}");
    let verdict = summary["verdicts"]["b"].as_str().unwrap().to_string();
    assert!(
        verdict.starts_with("conflict") && verdict.contains("upper bound"),
        "{verdict}"
    );
    let report = common::report::read(&out);
    // Every table row of b ends with the one verdict.
    let rows: Vec<&str> = report
        .lines()
        .filter(|line| line.starts_with("| b |"))
        .collect();
    assert!(!rows.is_empty(), "{report}");
    for row in &rows {
        assert!(!row.contains("pinned down"), "{row}");
    }
    let posterior_row = rows
        .iter()
        .find(|row| row.contains(" .. "))
        .expect("the posterior table's row");
    assert!(
        posterior_row.trim_end_matches(" |").ends_with(&verdict),
        "{posterior_row} against {verdict}"
    );
    assert!(!report.contains("pin down b"), "{report}");
}

#[test]
fn a_straight_line_through_a_solver_script_has_the_closed_form_posterior_by_the_emulator() {
    let dir = tempfile::tempdir().unwrap();
    let spec = line_spec(
        dir.path(),
        "\n[posterior]\ndraws = 2000\nchains = 4\npredictive_runs = 4\nseed = 5\n",
    );
    let out = dir.path().join("emulated");
    let summary = external_summary(&spec, &out, &[]);
    assert_closed_form(&posterior_draws(&out), ess_of(&summary), "emulator");
    // The refinement's runs are logged apart from the search's, and the
    // report says how the posterior was sampled.
    assert!(out.join("posterior_refinement.csv").exists());
    let report = common::report::read(&out);
    eprintln!(
        "{}",
        report
            .lines()
            .find(|l| l.contains("emulator"))
            .unwrap_or("")
    );
    assert!(
        report.contains("Gaussian-process emulator"),
        "{}",
        &report[report.find("## Posterior").unwrap_or(0)..]
    );
}

// ---- coverage and model error ----------------------------------------------------------------

/// The posterior of `study` with `model(point, x)` as its outputs, sampled
/// from its middle: each parameter's marginal, and the discrepancy's mean
/// over the draws (0 without one).
fn toy_posterior(
    study: &Study,
    discrepancy: Discrepancy,
    model: impl Fn(&[f64], f64) -> f64 + Sync,
    seed: u64,
) -> (Vec<Marginal>, f64) {
    toy_posterior_warmed(study, discrepancy, model, seed, TOY_WARMUP)
}

/// The warm-up steps of [`toy_chains`] unless told.
const TOY_WARMUP: usize = 600;

/// [`toy_posterior`] with `warmup` steps before the kept draws.
fn toy_posterior_warmed(
    study: &Study,
    discrepancy: Discrepancy,
    model: impl Fn(&[f64], f64) -> f64 + Sync,
    seed: u64,
    warmup: usize,
) -> (Vec<Marginal>, f64) {
    let density = StudyPosterior::new(study, discrepancy, 0).unwrap();
    let xs: Vec<f64> = study.cases.iter().map(|c| c.inputs[0].1).collect();
    let outputs = |point: &[f64]| -> Vec<f64> { xs.iter().map(|&x| model(point, x)).collect() };
    let chains = toy_chains(study, &density, &outputs, seed, warmup);
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let deltas: Vec<f64> = chains
        .pooled()
        .filter_map(|point| {
            let scales = density.draw_scales(&outputs(point), &[], &mut rng);
            scales.discrepancy.first().map(|d| d.at_sites[0].0)
        })
        .collect();
    let delta = deltas.iter().sum::<f64>() / deltas.len().max(1) as f64;
    (chains.summaries(), delta)
}

/// Two chains of 400 draws of `density` with the fit outputs `outputs`,
/// started from the parameters' middles, after `warmup` steps.
fn toy_chains(
    study: &Study,
    density: &StudyPosterior,
    outputs: &(dyn Fn(&[f64]) -> Vec<f64> + Sync),
    seed: u64,
    warmup: usize,
) -> acq_algorithms::mcmc::Chains {
    let log_density =
        |point: &[f64]| density.log_prior(point) + density.log_likelihood(&outputs(point), &[]);
    let settings = SamplerSettings {
        chains: 2,
        draws: 400,
        warmup,
        thin: None,
        seed,
    };
    let middle: Vec<f64> = study.parameters.iter().map(|p| p.nominal).collect();
    sample(
        log_density,
        &density.support(),
        &[middle.clone(), middle],
        &vec![0.3; study.parameters.len()],
        &settings,
        &|_| {},
    )
    .unwrap()
}

/// The share of replicates whose 90 % interval holds the truth.
fn coverage(hits: &[bool]) -> f64 {
    hits.iter().filter(|h| **h).count() as f64 / hits.len() as f64
}

/// Each of the two parameters' 90 % intervals held the truth in 86-94 %
/// of the replicates.
fn assert_nominal_coverage(label: &str, hits: &[[bool; 2]]) {
    let [a, b] = [0, 1].map(|i| coverage(&hits.iter().map(|h| h[i]).collect::<Vec<_>>()));
    eprintln!("{label}: 90 % intervals holding the truth: a {a}, b {b}");
    assert!((0.86..=0.94).contains(&a), "{label}: coverage of a {a}");
    assert!((0.86..=0.94).contains(&b), "{label}: coverage of b {b}");
}

/// Twenty holds of a boom cylinder's loaded pressure, `p = p0 + c F` at
/// loads `F` of 0 to 47.5 kN (`p0` the attachment's own weight, bar; `c`
/// bar per kN), read by one transducer. Its certificate states U = 2 bar
/// at k = 2, so its error is normal with u = 1 bar, drawn once per
/// replicate and the same in all twenty holds; each hold's mean adds its
/// own scatter, 0.05 bar. The posterior either takes the transducer's
/// error as shared (one error, its covariance across the holds) or as
/// each hold's own. 200 replicates: the binomial sd of a 90 % share is
/// 2.1 %, so 86-94 % is about two sds either side.
#[test]
fn twenty_holds_of_one_transducer_do_not_pin_its_offset_below_its_accuracy() {
    use acq_study::study::SharedError;
    let bounds = [("p0", 20.0, 60.0), ("c", 1.0, 3.0)];
    let loads_kn: Vec<f64> = (0..20).map(|i| 2.5 * f64::from(i)).collect();
    let (transducer_u_bar, scatter_u_bar) = (1.0, 0.05);
    let total_u_bar = f64::hypot(transducer_u_bar, scatter_u_bar);
    let line = |p: &[f64], load_kn: f64| p[0] + p[1] * load_kn;
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(29);
    let unit = Normal::new(0.0, 1.0).unwrap();
    let (mut shared_hits, mut independent_hits) = (Vec::new(), Vec::new());
    let mut shared_widths = Vec::new();
    for replicate in 0..200 {
        let truth = truth_from_prior(&bounds, &mut rng);
        let offset_bar = transducer_u_bar * unit.sample(&mut rng);
        let measured: Vec<(f64, f64)> = loads_kn
            .iter()
            .map(|&f| {
                (
                    f,
                    line(&truth, f) + offset_bar + scatter_u_bar * unit.sample(&mut rng),
                )
            })
            .collect();
        let mut study = common::toy::toy_study(&bounds, &measured, total_u_bar);
        let (independent, _) = toy_posterior(&study, Discrepancy::None, line, replicate);
        for case in &mut study.cases {
            case.observations[0].shared = vec![SharedError {
                source: "boom_head_pressure".into(),
                effect: transducer_u_bar,
            }];
        }
        // One loose direction (p0 with the offset) across a tight one (c):
        // the chains need longer to learn that shape.
        let (shared, _) =
            toy_posterior_warmed(&study, Discrepancy::None, line, replicate, 4 * TOY_WARMUP);
        assert!(
            shared.iter().all(|m| m.rhat < 1.05),
            "replicate {replicate}: unconverged"
        );
        let held = |m: &[Marginal]| [0, 1].map(|i| (m[i].q05..=m[i].q95).contains(&truth[i]));
        shared_hits.push(held(&shared));
        independent_hits.push(held(&independent));
        shared_widths.push(shared[0].q95 - shared[0].q05);
    }
    let share =
        |hits: &[[bool; 2]], i: usize| coverage(&hits.iter().map(|h| h[i]).collect::<Vec<_>>());
    let width = shared_widths.iter().sum::<f64>() / shared_widths.len() as f64;
    eprintln!(
        "90 % intervals holding the truth, shared: p0 {} c {}; independent: p0 {} c {}; the shared p0 interval {width:.2} bar wide",
        share(&shared_hits, 0),
        share(&shared_hits, 1),
        share(&independent_hits, 0),
        share(&independent_hits, 1)
    );
    assert_nominal_coverage("shared transducer error", &shared_hits);
    // Independent errors average the offset away over twenty holds: the
    // p0 interval is about sqrt(20) too narrow and misses most often.
    assert!(
        share(&independent_hits, 0) < 0.6,
        "{}",
        share(&independent_hits, 0)
    );
    // No number of holds pins p0 below the transducer: the 90 % interval
    // is at least 2 x 1.645 x 1 bar wide (3.29 bar), less sampling error.
    assert!(width > 0.9 * 2.0 * 1.645 * transducer_u_bar, "{width}");
}

/// 400 replicates: the truth drawn from the uniform prior, the data from
/// the model at it plus known normal noise. If the posterior is right,
/// its 90 % interval holds the truth in 90 % of them; with 400 the
/// binomial sd of that share is 1.5 %, so 86-94 % is 2.7 sds either side.
#[test]
fn ninety_percent_intervals_hold_the_truth_ninety_percent_of_the_time() {
    let decay = |p: &[f64], x: f64| p[0] * (-p[1] * x).exp();
    let bounds = [("a", 0.5, 2.0), ("b", 0.2, 1.5)];
    let xs = [0.5, 1.0, 2.0, 3.0];
    let sd = 0.05;
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
    let noise = Normal::new(0.0, sd).unwrap();
    let mut hits = Vec::new();
    for replicate in 0..400 {
        let truth = truth_from_prior(&bounds, &mut rng);
        let measured: Vec<(f64, f64)> = xs
            .iter()
            .map(|&x| (x, decay(&truth, x) + noise.sample(&mut rng)))
            .collect();
        let study = common::toy::toy_study(&bounds, &measured, sd);
        let (marginals, _) = toy_posterior(&study, Discrepancy::None, decay, replicate);
        hits.push([0, 1].map(|i| (marginals[i].q05..=marginals[i].q95).contains(&truth[i])));
    }
    assert_nominal_coverage("toy", &hits);
}

/// The data have an offset of 0.8 the model lacks (`y = a x` against
/// `y = a x + 0.8`). Without discrepancy the slope is bent to make up for
/// it and its intervals miss; with a constant discrepancy they hold it
/// again, and the discrepancy's mean is the offset.
#[test]
fn a_missing_term_is_named_by_the_discrepancy_and_coverage_comes_back() {
    let line = |p: &[f64], x: f64| p[0] * x;
    let bounds = [("a", 0.0, 4.0)];
    let xs = [0.0, 0.5, 1.0, 1.5, 2.0, 3.0];
    let (sd, offset) = (0.1, 0.8);
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(12);
    let noise = Normal::new(0.0, sd).unwrap();
    let (mut without, mut with, mut offsets) = (Vec::new(), Vec::new(), Vec::new());
    for replicate in 0..100 {
        let slope = Uniform::new(0.5, 3.5).unwrap().sample(&mut rng);
        let measured: Vec<(f64, f64)> = xs
            .iter()
            .map(|&x| (x, slope * x + offset + noise.sample(&mut rng)))
            .collect();
        let study = common::toy::toy_study(&bounds, &measured, sd);
        let holds = |m: &[Marginal]| (m[0].q05..=m[0].q95).contains(&slope);
        let (plain, _) = toy_posterior(&study, Discrepancy::None, line, replicate);
        without.push(holds(&plain));
        let (allowing, delta) = toy_posterior(&study, Discrepancy::Constant, line, replicate);
        with.push(holds(&allowing));
        offsets.push(delta);
    }
    let (missed, held) = (coverage(&without), coverage(&with));
    assert!(missed < 0.5, "without discrepancy coverage {missed}");
    assert!(held > 0.8, "with a constant discrepancy coverage {held}");
    let mean_offset = offsets.iter().sum::<f64>() / offsets.len() as f64;
    eprintln!(
        "coverage without discrepancy {missed}, with {held}; the discrepancy's mean {mean_offset}"
    );
    assert!(
        (mean_offset - offset).abs() < 0.1,
        "the discrepancy's size {mean_offset} against {offset}"
    );
}

/// The data have a term the model lacks that varies over the cases
/// (`y = a x` against `y = a x + 0.6 sin(1.5 x)`, x over 0-3: a
/// stiffening the model leaves out, say), measured at six x. At an
/// untested x = 1.5 (a validate case) the posterior predicts the true
/// value `a x + 0.6 sin(1.5 x)` through the model plus its discrepancy
/// there. Without discrepancy, and with a constant one, the 90 %
/// predictive interval of the true value misses it in most replicates;
/// with a GP over x it holds it near the nominal rate (100 replicates,
/// binomial sd 3 %: at least 80 %).
#[test]
fn a_discrepancy_that_varies_over_the_inputs_predicts_an_untested_case() {
    let line = |p: &[f64], x: f64| p[0] * x;
    let missing = |x: f64| 0.6 * (1.5 * x).sin();
    let bounds = [("a", 0.0, 4.0)];
    let (xs, untested) = ([0.0, 0.5, 1.0, 2.0, 2.5, 3.0], 1.5);
    let sd = 0.1;
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(13);
    let noise = Normal::new(0.0, sd).unwrap();
    let mut hits: [Vec<bool>; 3] = Default::default();
    let mut widths = [0.0; 3];
    let replicates = 100;
    for replicate in 0..replicates {
        let slope = Uniform::new(0.5, 3.5).unwrap().sample(&mut rng);
        let truth = |x: f64| slope * x + missing(x);
        let measured: Vec<(f64, f64)> = xs
            .iter()
            .map(|&x| (x, truth(x) + noise.sample(&mut rng)))
            .collect();
        let mut study = common::toy::toy_study(&bounds, &measured, sd);
        let mut validate = study.cases[0].clone();
        validate.name = "untested".into();
        validate.role = Role::Validate;
        validate.inputs = vec![("x".into(), untested)];
        study.cases.push(validate);
        for (k, discrepancy) in [Discrepancy::None, Discrepancy::Constant, Discrepancy::Gp]
            .into_iter()
            .enumerate()
        {
            let interval = predicted_interval(&study, discrepancy, line, untested, replicate);
            hits[k].push((interval.0..=interval.1).contains(&truth(untested)));
            widths[k] += (interval.1 - interval.0) / replicates as f64;
        }
    }
    let [none, constant, gp] = [0, 1, 2].map(|k| coverage(&hits[k]));
    eprintln!(
        "90 % predictive intervals at the untested case holding the truth: none {none}, constant {constant}, gp {gp}; mean widths {widths:?}"
    );
    assert!(none < 0.5, "without discrepancy {none}");
    assert!(constant < 0.5, "with a constant discrepancy {constant}");
    assert!(gp >= 0.8, "with a GP discrepancy {gp}");
}

/// The 90 % interval of `model + discrepancy` at the validate case at
/// `x`, over the posterior of the fit cases.
fn predicted_interval(
    study: &Study,
    discrepancy: Discrepancy,
    model: impl Fn(&[f64], f64) -> f64 + Sync,
    x: f64,
    seed: u64,
) -> (f64, f64) {
    let density = StudyPosterior::new(study, discrepancy, 0).unwrap();
    let fit: Vec<f64> = study
        .cases
        .iter()
        .filter(|c| c.role == Role::Fit)
        .map(|c| c.inputs[0].1)
        .collect();
    let outputs = |point: &[f64]| -> Vec<f64> { fit.iter().map(|&x| model(point, x)).collect() };
    let chains = toy_chains(study, &density, &outputs, seed, TOY_WARMUP);
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let mut values: Vec<f64> = chains
        .pooled()
        .map(|point| {
            let scales = density.draw_scales(&outputs(point), &[], &mut rng);
            let delta = density.outputs.first().map_or(0.0, |output| {
                let site = output.site_of("untested").unwrap();
                let (mean, variance) = scales.discrepancy[0].at_sites[site];
                mean + variance.sqrt() * standard_normal(&mut rng)
            });
            model(point, x) + delta
        })
        .collect();
    values.sort_by(f64::total_cmp);
    (quantile(&values, 0.05), quantile(&values, 0.95))
}

// ---- a curve with correlated noise ------------------------------------------------------------

/// 400 replicates of the curve, 240 points as a tensile test has, with a
/// force transducer's AR(1) noise (sd 0.06 on forces of up to 5 to 15,
/// lag-one correlation 0.8: a correlation length of about 5 points, under
/// half of one of the 20 parts, so neighbouring parts' mean errors still
/// correlate by about 0.25): the posterior reads the curve as its parts'
/// mean errors ([`StudyPosterior`]'s curve treatment), and its 90 %
/// intervals hold the truth in 86-94 % of the replicates (the binomial sd
/// of the share is 1.5 %; measured 2026-11-27: 93.5 % and 93.25 %, a
/// little wide, since the noise's scale and correlation are estimated
/// from 20 parts). An i.i.d. likelihood on the 240 points would be
/// about three times too narrow here (the variance of a long mean of
/// AR(1) values is (1 + r) / (1 - r) = 9 times that of independent ones).
#[test]
fn a_curve_with_correlated_noise_gets_honest_intervals() {
    let hits = correlated_curve_hits(CurveMetric::Mape, 240, 400);
    assert_nominal_coverage("curve", &hits);
}

/// The same with the curve scored by dynamic time warping: its coupling's
/// signed distances averaged over 20 parts of the measured curve's
/// length, each part read with the measured curve's own scatter and a
/// scale the posterior estimates. DTW costs n m a run, so 150 replicates
/// of 80 points: the binomial sd of the share is 2.4 %. The intervals
/// must not be too narrow (at least 83 %, 2.9 sds below 90 %); they may
/// be a little wide (`cargo bench --bench curve_coverage`, 400 replicates
/// of 120 points, 2026-11-27: 96.0 % and 95.5 %), and not wider than
/// 99 % (measured here 2026-11-27: 94.0 % and 86.7 %). The other coupling metrics' intervals are too narrow on such a
/// curve (BENCHMARKS.md, "Coverage of a curve's posterior"), which the
/// report says where it shows them.
#[test]
fn a_curve_scored_by_dynamic_time_warping_gets_intervals_that_are_not_too_narrow() {
    let hits = correlated_curve_hits(CurveMetric::Dtw, 80, 150);
    let [a, b] = [0, 1].map(|i| coverage(&hits.iter().map(|h| h[i]).collect::<Vec<_>>()));
    eprintln!("dtw: 90 % intervals holding the truth: a {a}, b {b}");
    assert!((0.83..=0.99).contains(&a), "dtw: coverage of a {a}");
    assert!((0.83..=0.99).contains(&b), "dtw: coverage of b {b}");
}

// ---- a short measured curve ---------------------------------------------------------------------

/// Twelve points of a decay `y = a exp(-b x)` (x = 0.25 to 3), measured
/// as a force transducer reads, with noise of the same sd (0.02) all
/// along, fitted by a solver script (sh + awk) in 40 runs: fewer points
/// than a curve has parts (20), so no part holds the three points its own
/// noise estimate needs. The posterior must read the noise off the curve
/// as a whole and each point once: its chains converge, its 90 %
/// intervals hold the truth, and their widths are those of the
/// independent closed form of the same fit (least squares with the known
/// noise, linearised at the truth: `sd^2 (J'J)^-1`) within what
/// estimating the noise from 12 points and the correlation along the
/// curve adds: at least 0.7 and at most 4 times as wide. Before, the
/// noise was taken as 1e-9 of the force, every chain stayed where it
/// started, and the sampler ran 2 million steps (about seven minutes) to
/// say so.
#[test]
fn a_short_measured_curve_has_a_converged_posterior_as_wide_as_its_regression() {
    let dir = tempfile::tempdir().unwrap();
    let (a, b, noise_sd) = (3.0, 0.7, 0.02);
    let xs: Vec<f64> = (1..=12).map(|i| 0.25 * f64::from(i)).collect();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(21);
    let noise = Normal::new(0.0, noise_sd).unwrap();
    let mut measured = String::from("x,y\n");
    for &x in &xs {
        let y: f64 = a * (-b * x).exp() + noise.sample(&mut rng);
        measured.push_str(&format!("{x},{y:.12}\n"));
    }
    std::fs::write(dir.path().join("measured.csv"), measured).unwrap();
    std::fs::write(
        dir.path().join("decay.sh"),
        "awk -v a=\"$1\" -v b=\"$2\" 'BEGIN { print \"x,y\"; for (i = 1; i <= 12; i++) printf \"%.17g,%.17g\\n\", 0.25 * i, a * exp(-b * 0.25 * i) }' > curve.csv\n",
    )
    .unwrap();
    let spec = dir.path().join("spec.toml");
    std::fs::write(
        &spec,
        r#"command = ["sh", "decay.sh", "{a}", "{b}"]
parallel = 2

[[curve]]
name = "decay"
file = "curve.csv"
x = "x"
y = "y"
measured_file = "measured.csv"
measured_x = "x"
measured_y = "y"

[search]
method = "bo"
max_evals = 40

[[parameter]]
name = "a"
lower = 1.0
upper = 5.0

[[parameter]]
name = "b"
lower = 0.2
upper = 1.5

[posterior]
"#,
    )
    .unwrap();
    let summary = external_summary(&spec, &dir.path().join("run"), &["--seed", "1"]);
    // The closed form: J's columns are dy/da = exp(-b x) and dy/db =
    // -a x exp(-b x); the covariance is sd^2 (J'J)^-1.
    let (mut jaa, mut jab, mut jbb) = (0.0, 0.0, 0.0);
    for &x in &xs {
        let (da, db) = ((-b * x).exp(), -a * x * (-b * x).exp());
        jaa += da * da;
        jab += da * db;
        jbb += db * db;
    }
    let determinant = jaa * jbb - jab * jab;
    let sd_a = noise_sd * (jbb / determinant).sqrt();
    let sd_b = noise_sd * (jaa / determinant).sqrt();
    for (name, truth, sd) in [("a", a, sd_a), ("b", b, sd_b)] {
        let rhat = number(&summary, &["posterior", name, "rhat"]);
        assert!(rhat < 1.01, "{name}: R-hat {rhat}");
        let low = number(&summary, &["posterior", name, "q05"]);
        let high = number(&summary, &["posterior", name, "q95"]);
        assert!(
            low <= truth && truth <= high,
            "{name}: [{low}, {high}] against {truth}"
        );
        let ratio = (high - low) / (2.0 * 1.645 * sd);
        eprintln!("{name}: [{low}, {high}], {ratio:.2} times the regression's 90 % width");
        assert!(
            (0.7..=4.0).contains(&ratio),
            "{name}: [{low}, {high}] is {ratio:.2} times the regression's 90 % width"
        );
    }
}

// ---- resume ------------------------------------------------------------------------------------

/// A posterior stopped in the middle of its predictive runs (the solver
/// sends acq SIGTERM on its second) resumes with `--resume` without
/// repeating a finished run (search, refinement or predictive), and ends
/// with the posterior of a run never stopped, number for number.
#[test]
fn an_interrupted_posterior_resumes_without_repeating_a_run() {
    let dir = tempfile::tempdir().unwrap();
    let posterior = "\n[posterior]\ndraws = 500\nchains = 2\npredictive_runs = 3\nseed = 2\n";
    let spec = line_spec(dir.path(), posterior);
    // One run at a time, each counted in runs.log.
    let text = std::fs::read_to_string(&spec)
        .unwrap()
        .replace("parallel = 2", "parallel = 1");
    std::fs::write(&spec, text).unwrap();
    let solver = std::fs::read_to_string(dir.path().join("line.sh")).unwrap();
    std::fs::write(
        dir.path().join("line.sh"),
        format!(
            "echo run >> \"$3\"\nif [ -n \"$4\" ] && [ \"$(wc -l < \"$3\")\" -eq \"$4\" ]; then kill -TERM $PPID; sleep 5; fi\n{solver}"
        ),
    )
    .unwrap();
    let counted = |stop_at: &str| {
        let log = dir.path().join(format!("runs{stop_at}.log"));
        let text = std::fs::read_to_string(&spec).unwrap().replace(
            "\"{a}\", \"{b}\"]",
            &format!(
                "\"{{a}}\", \"{{b}}\", \"{}\", \"{stop_at}\"]",
                log.display()
            ),
        );
        let path = dir.path().join(format!("counted{stop_at}.toml"));
        std::fs::write(&path, text).unwrap();
        (path, log)
    };
    let runs = |log: &Path| {
        std::fs::read_to_string(log)
            .map(|t| t.lines().count())
            .unwrap_or(0)
    };
    // A run never stopped.
    let (whole_spec, whole_log) = counted("");
    let whole = external_summary(&whole_spec, &dir.path().join("whole"), &[]);
    let search_runs = std::fs::read_to_string(dir.path().join("whole/evaluations.csv"))
        .unwrap()
        .lines()
        .count()
        - 1;
    let refinement_runs =
        std::fs::read_to_string(dir.path().join("whole/posterior_refinement.csv"))
            .unwrap()
            .lines()
            .count()
            - 1;
    // Stopped at the second predictive run, after every search and
    // refinement run, then resumed.
    let stop_at = (search_runs + refinement_runs + 2).to_string();
    let (stopped_spec, stopped_log) = counted(&stop_at);
    let out = dir.path().join("stopped");
    let first = with_default_sigterm(&stopped_spec, &out);
    assert_eq!(first.status.code(), Some(130), "{}", common::stderr(&first));
    let resumed = external_summary(&stopped_spec, &out, &["--resume"]);
    // The run in flight when acq stopped is the only one run twice.
    assert_eq!(runs(&stopped_log), runs(&whole_log) + 1);
    assert_eq!(resumed["posterior"], whole["posterior"]);
    assert_eq!(resumed["predictive"], whole["predictive"]);
}

/// `acq calibrate external` with SIGTERM's default action: a test started
/// from a shell's background job may inherit it ignored, and exec keeps
/// it so.
fn with_default_sigterm(spec: &Path, out: &Path) -> std::process::Output {
    use nix::sys::signal::{signal, SigHandler, Signal};
    use std::os::unix::process::CommandExt;
    let mut command = std::process::Command::new(env!("CARGO_BIN_EXE_acq"));
    command.args([
        "calibrate",
        "external",
        "--spec",
        common::path_arg(spec),
        "--out",
        common::path_arg(out),
    ]);
    // SAFETY: only sigaction (async-signal-safe) runs between fork and exec.
    unsafe {
        command.pre_exec(|| {
            signal(Signal::SIGTERM, SigHandler::SigDfl)
                .map(drop)
                .map_err(std::io::Error::from)
        });
    }
    command.output().unwrap()
}

// ---- a peer: emcee and ArviZ -----------------------------------------------------------------

/// `y = a exp(-b t)` seen at t = 1 and 2 (sd 0.1): two values for two
/// parameters, a curved ridge of a posterior. acq's sampler and emcee's
/// affine-invariant ensemble (32 walkers) sample it in the same run; at
/// the 5, 25, 50, 75 and 95 % quantiles of emcee's draws, acq's share of
/// draws below is the quantile's level within 4 Monte-Carlo sds
/// (`sqrt(p (1 - p) (1 / ess_acq + 1 / ess_emcee))`, each ESS its own
/// tool's). And ArviZ's rank R-hat and bulk ESS of acq's chains equal
/// acq's own to 1e-9.
#[test]
fn a_banana_posterior_has_emcees_quantiles_and_arvizs_diagnostics() {
    let decay = |p: &[f64], t: f64| p[0] * (-p[1] * t).exp();
    let bounds = [("a", 0.2, 3.0), ("b", 0.05, 2.0)];
    let measured = [(1.0, 0.62), (2.0, 0.35)];
    let sd = 0.1;
    let study = common::toy::toy_study(&bounds, &measured, sd);
    let density = StudyPosterior::new(&study, Discrepancy::None, 0).unwrap();
    let log_density = |point: &[f64]| {
        let outputs: Vec<f64> = measured.iter().map(|&(t, _)| decay(point, t)).collect();
        density.log_prior(point) + density.log_likelihood(&outputs, &[])
    };
    let settings = SamplerSettings {
        chains: 4,
        draws: 4000,
        warmup: 2000,
        thin: None,
        seed: 21,
    };
    let chains = sample(
        log_density,
        &density.support(),
        &vec![vec![0.8, 0.4]; 4],
        &[0.3, 0.3],
        &settings,
        &|_| {},
    )
    .unwrap();
    let python = common::scratch_python("mcmc");
    let dir = tempfile::tempdir().unwrap();
    let draws = dir.path().join("acq.json");
    let by_parameter: Vec<Vec<Vec<f64>>> = (0..2).map(|i| chains.coordinate(i)).collect();
    std::fs::write(&draws, serde_json::json!(by_parameter).to_string()).unwrap();
    let output = std::process::Command::new(&python)
        .arg(common::root().join("tests/peers/banana_emcee.py"))
        .arg(&draws)
        .output()
        .unwrap();
    assert!(output.status.success(), "{}", common::stderr(&output));
    let theirs: Value = serde_json::from_slice(&output.stdout).unwrap();
    let levels = [0.05, 0.25, 0.5, 0.75, 0.95];
    let ours = chains.summaries();
    let emcee_ess = number(&theirs, &["ess"]);
    for (i, (name, _, _)) in bounds.iter().enumerate() {
        let pooled: Vec<f64> = by_parameter[i].iter().flatten().copied().collect();
        for (k, p) in levels.iter().enumerate() {
            let q = theirs["quantiles"][i][k].as_f64().unwrap();
            let below = pooled.iter().filter(|x| **x <= q).count() as f64 / pooled.len() as f64;
            let sd = (p * (1.0 - p) * (1.0 / ours[i].ess_bulk + 1.0 / emcee_ess)).sqrt();
            assert!(
                (below - p).abs() < 4.0 * sd,
                "{name}: {below} of acq's draws lie below emcee's {p} quantile {q} (sd {sd})"
            );
        }
        let rhat = theirs["rhat"][i].as_f64().unwrap();
        let ess = theirs["ess_bulk"][i].as_f64().unwrap();
        assert!(
            (ours[i].rhat - rhat).abs() <= 1e-9 * rhat,
            "{name}: R-hat {} against ArviZ {rhat}",
            ours[i].rhat
        );
        assert!(
            (ours[i].ess_bulk - ess).abs() <= 1e-9 * ess,
            "{name}: ESS {} against ArviZ {ess}",
            ours[i].ess_bulk
        );
    }
}

// ---- the emulator against the model itself ----------------------------------------------------

/// `y = a exp(-b t)` at t = 0.5, 1, 2, 3 (sd 0.05), in process.
struct Decay {
    cheap: bool,
}

impl Model for Decay {
    fn run(
        &self,
        inputs: &[(String, f64)],
        scalars: &[&str],
        _curves: &[&str],
    ) -> Result<ModelRun, String> {
        let (a, b, t) = (
            input(inputs, "a")?,
            input(inputs, "b")?,
            input(inputs, "x")?,
        );
        Ok(ModelRun {
            scalars: scalars.iter().map(|_| a * (-b * t).exp()).collect(),
            curves: Vec::new(),
        })
    }

    fn is_cheap(&self) -> bool {
        self.cheap
    }
}

/// The same nonlinear posterior sampled directly and on the emulator of
/// a search's 30 runs (refined where it lies): every 5 %, 50 % and 95 %
/// quantile within 10 % of the direct posterior's sd of each other (issue
/// 35's tolerance). The emulated run spends at most 20 model runs
/// beyond the search.
#[test]
fn the_emulated_posterior_matches_the_direct_one() {
    let measured = [(0.5, 1.05), (1.0, 0.74), (2.0, 0.41), (3.0, 0.22)];
    let study = common::toy::toy_study(&[("a", 0.5, 2.0), ("b", 0.2, 1.5)], &measured, 0.05);
    let dir = tempfile::tempdir().unwrap();
    let run = |cheap: bool| {
        let out = dir.path().join(if cheap { "direct" } else { "emulated" });
        let directory = RunDirectory::create(&out).unwrap();
        let method = Method::Bo(acq_study::method::BoMethod {
            start: "lhs".into(),
            start_runs: 20,
            max_evals: 30,
            target_loss: None,
            acquisition: None,
            patience: None,
            batch: 1,
            seed: 4,
            local_steps: false,
            deterministic: true,
        });
        let initial =
            acq_study::method::start_design(&study.search_parameters(), &method, dir.path())
                .unwrap();
        let finished = run_study(
            &study,
            &Decay { cheap },
            &method,
            initial,
            &directory,
            &RunSettings {
                label: "decay".into(),
                title: "decay".into(),
                spec_directory: dir.path(),
                parallel: 1,
                resume: false,
                progress: None,
                // 4 x 10,000 draws: each quantile's Monte-Carlo error is
                // then about 2 % of the sd, so the difference measures
                // the emulator, not the sampling.
                posterior: Some(PosteriorSettings {
                    draws: 10_000,
                    predictive_runs: 0,
                    seed: 8,
                    ..PosteriorSettings::default()
                }),
            },
            &NoExtras,
        )
        .unwrap();
        let refinement = std::fs::read_to_string(out.join("posterior_refinement.csv"))
            .map(|t| t.lines().count().saturating_sub(1))
            .unwrap_or(0);
        (finished.outcome.posterior.unwrap().marginals, refinement)
    };
    let (direct, _) = run(true);
    let (emulated, refinement_runs) = run(false);
    eprintln!("the emulator spent {refinement_runs} refinement runs beyond the search's 30");
    assert!(refinement_runs <= 20);
    let worst = direct
        .iter()
        .zip(&emulated)
        .flat_map(|(d, e)| [d.q05 - e.q05, d.q50 - e.q50, d.q95 - e.q95].map(|x| x.abs() / d.sd))
        .fold(0.0, f64::max);
    eprintln!("the largest quantile difference is {worst:.3} of the direct posterior's sd");
    for (name, (d, e)) in ["a", "b"].iter().zip(direct.iter().zip(&emulated)) {
        for (q, ours, theirs) in [
            ("5 %", d.q05, e.q05),
            ("50 %", d.q50, e.q50),
            ("95 %", d.q95, e.q95),
        ] {
            assert!(
                (ours - theirs).abs() <= 0.1 * d.sd,
                "{name} {q}: direct {ours}, emulated {theirs} (sd {})",
                d.sd
            );
        }
    }
}

// ---- the validation statement ------------------------------------------------------------------

/// A validation case of the straight line at t = 6: ASME V&V 20's
/// simulation result S and input uncertainty u_input are, in closed form,
/// the posterior's mean and sd of `a + 6 b` (`sqrt(x' C x)`, x = (1, 6));
/// from 2,000 predictive runs they are within 3 and 5 % of them.
#[test]
fn the_validation_statement_has_the_closed_form_prediction_and_input_uncertainty() {
    use acq_study::posterior::validation::validation_statements;
    let dir = tempfile::tempdir().unwrap();
    let mut study = Spec::load(&line_spec(dir.path(), ""), &BUILTIN_MODELS)
        .unwrap()
        .study;
    study.cases.push(Case::new(
        "check",
        Role::Validate,
        vec![Observation {
            name: "y6".into(),
            output: "y6".into(),
            measured: Measured::Scalar {
                value: 6.3,
                uncertainty: Some(0.4),
            },
            weight: 1.0,
            source: String::new(),
            shared: Vec::new(),
        }],
    ));
    let run = line_in_process(
        &study,
        &dir.path().join("validated"),
        PosteriorSettings {
            predictive_runs: 2000,
            seed: 6,
            // The solver's own numerical error from a mesh study.
            numerical_uncertainty: vec![("y6".into(), 0.3)],
            ..PosteriorSettings::default()
        },
    );
    let statements = validation_statements(run.outcome.posterior.as_ref().unwrap());
    assert_eq!(statements.len(), 1);
    let s = &statements[0];
    let (mean, covariance) = closed_form();
    let predicted = mean[0] + 6.0 * mean[1];
    let sd = (covariance[0][0] + 12.0 * covariance[0][1] + 36.0 * covariance[1][1]).sqrt();
    // 2,000 runs at draws of a chain: the mean's error is well under a
    // tenth of the sd, the sd's under 5 %.
    assert!(
        (s.simulated - predicted).abs() < 0.1 * sd,
        "S {} of {predicted}",
        s.simulated
    );
    assert!(
        (s.u_input / sd - 1.0).abs() < 0.05,
        "u_input {} of {sd}",
        s.u_input
    );
    assert_eq!(s.u_measured, 0.4);
    assert_eq!(s.u_num, 0.3);
    assert!((s.comparison_error - (s.simulated - 6.3)).abs() < 1e-12);
    let u_val = (0.09 + s.u_input.powi(2) + 0.16).sqrt();
    assert!((s.u_val - u_val).abs() < 1e-12);
    let report = common::report::read(&dir.path().join("validated"));
    assert!(report.contains("Validation (ASME V&V 20)"));
}

/// The shipped validation example (`examples/validation/`) gives the V&V 20
/// statement it is there to show: both values of its validate case, each
/// with the u_num the spec states, E = S - D, and the model error's
/// interval. Its measured values come from the spring's true stiffness
/// (2.5 kN/mm) with the model's own softening, so the model must agree
/// with them within u_val: a verdict that it does not would be a fault.
#[test]
fn the_shipped_validation_example_states_v_and_v_20() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("run");
    let spec = common::root().join("examples/validation/spec.toml");
    let summary = common::external_summary(&spec, &out, &[]);
    let k = summary["posterior"]["k_kn_per_mm"]["mean"]
        .as_f64()
        .unwrap();
    assert!((k - 2.5).abs() < 0.05, "k = {k}");
    let report = common::report::read(&out);
    let section = &report[report
        .find("### Validation (ASME V&V 20)")
        .expect("the V&V 20 section")..];
    for (output, u_num) in [("u_low_mm", "0.005000"), ("u_high_mm", "0.01000")] {
        let row = section
            .lines()
            .find(|l| l.starts_with(&format!("| C | {output} |")))
            .unwrap_or_else(|| panic!("{output} in\n{section}"));
        let cells: Vec<&str> = row.trim_matches('|').split('|').map(str::trim).collect();
        assert_eq!(cells[5], u_num, "{row}");
        assert_eq!(
            cells[6], "stated in the spec",
            "where u_num came from: {row}"
        );
        let (s, d, e): (f64, f64, f64) = (
            cells[2].parse().unwrap(),
            cells[3].parse().unwrap(),
            cells[4].parse().unwrap(),
        );
        assert!((s - d - e).abs() <= 1e-3 * s.abs(), "E = S - D: {row}");
        assert_eq!(cells[11], "within u_val", "{row}");
    }
}
