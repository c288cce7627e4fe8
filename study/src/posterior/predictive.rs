//! Predictions at posterior draws: the model run (for real, through the
//! logging evaluator, so an interrupted stage resumes without repeating a
//! run) at `predictive_runs` draws spread evenly over the chains, for the
//! fit cases and the validation cases alike.
//!
//! Each run's value is the model's; the interval a new measurement should
//! fall in adds what the model does not know: the output's discrepancy
//! (drawn from its conditional normal at that draw) and the measurement's
//! own error (its stated uncertainty, or the posterior's noise scale).
//! `predictive.csv` has both, one row per run, case and output.

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

use acq_algorithms::evaluation::Evaluator;
use acq_algorithms::mcmc::{quantile, Chains};
use acq_error::Result;

use super::super::run_directory::{evaluation_error, write_text, RunDirectory};
use super::super::simulator::StudySimulator;
use super::super::study::{Case, Measured, Model, Observation, Role, Study};
use super::likelihood::{standard_normal, Scales, StudyPosterior};
use super::settings::PosteriorSettings;

/// The case name of a study without named cases.
pub const MAIN_CASE: &str = "main";

/// One output of one case, predicted.
#[derive(Clone, Debug)]
pub struct Predicted {
    /// The case's name ([`MAIN_CASE`] without named cases).
    pub case: String,
    pub role: Role,
    /// The observation's name.
    pub name: String,
    pub measured: f64,
    pub uncertainty: Option<f64>,
    /// The model's value at each predictive run that succeeded.
    pub model: Vec<f64>,
    /// The same with a draw of the discrepancy and the measurement error.
    pub with_error: Vec<f64>,
}

impl Predicted {
    /// `(mean, q05, q95)` of what a new measurement would read.
    pub fn interval(&self) -> (f64, f64, f64) {
        let mut sorted = self.with_error.clone();
        sorted.sort_by(f64::total_cmp);
        let mean = sorted.iter().sum::<f64>() / sorted.len().max(1) as f64;
        (mean, quantile(&sorted, 0.05), quantile(&sorted, 0.95))
    }

    /// Whether the measured value lies in the 90 % interval.
    pub fn holds_measured(&self) -> bool {
        let (_, low, high) = self.interval();
        (low..=high).contains(&self.measured)
    }
}

/// A measured curve and the model's curves at the predictive runs.
#[derive(Clone, Debug)]
pub struct PredictedCurve {
    pub case: String,
    pub role: Role,
    pub name: String,
    pub axes: [String; 2],
    pub measured: Vec<(f64, f64)>,
    /// Its MAPE (%) at each run that succeeded.
    pub mape_pct: Vec<f64>,
    /// The model's curve at each run it could give again.
    pub runs: Vec<Vec<(f64, f64)>>,
}

/// What the predictive runs gave: each scalar observation's predictions
/// and each curve's runs.
#[derive(Clone, Debug, Default)]
pub struct Predictions {
    pub scalars: Vec<Predicted>,
    pub curves: Vec<PredictedCurve>,
}

/// Runs the model at evenly spread draws for every case and returns each
/// observation's predictions; writes `predictive.csv`.
#[allow(clippy::too_many_arguments)]
pub fn predictive_runs(
    study: &Study,
    model: &dyn Model,
    density: &StudyPosterior,
    chains: &Chains,
    scales: &[Scales],
    settings: &PosteriorSettings,
    directory: &RunDirectory,
    parallel: usize,
    resume: bool,
) -> Result<Predictions> {
    let draws: Vec<&Vec<f64>> = chains.pooled().collect();
    let runs = settings.predictive_runs.min(draws.len());
    let picked: Vec<usize> = (0..runs).map(|i| i * draws.len() / runs).collect();
    let points: Vec<Vec<f64>> = picked.iter().map(|&i| draws[i].clone()).collect();
    let outputs_by_role = model_runs_by_role(study, model, &points, directory, parallel, resume)?;
    let mut rng = ChaCha8Rng::seed_from_u64(settings.seed.wrapping_add(7));
    let delta = discrepancy_draws(&picked, scales, &mut rng);
    let mut predictions = Predictions::default();
    for (role, outputs) in [Role::Fit, Role::Validate]
        .into_iter()
        .zip(&outputs_by_role)
    {
        let runs = RoleRuns {
            role,
            picked: &picked,
            draws: &draws,
            outputs,
        };
        for (index, (case, observation)) in study.observations(role).into_iter().enumerate() {
            if case.priors {
                continue;
            }
            let at = ObservationAt {
                case,
                observation,
                index,
                case_name: if study.named_cases {
                    case.name.clone()
                } else {
                    MAIN_CASE.into()
                },
            };
            match &observation.measured {
                Measured::Scalar { value, uncertainty } => {
                    let mut entry = at.predicted(role, *value, *uncertainty);
                    add_scalar_runs(&mut entry, &at, &runs, density, scales, &delta, &mut rng);
                    predictions.scalars.push(entry);
                }
                Measured::Curve { points, axes, .. } => predictions
                    .curves
                    .push(predicted_curve(study, model, &at, &runs, points, axes)),
            }
        }
    }
    write_predictive_csv(directory, &predictions)?;
    Ok(predictions)
}

/// The model's outputs at `points` through the logging evaluator of each
/// role (fit, then validate), `None` for a run that failed; all `None`
/// for a role without cases.
fn model_runs_by_role(
    study: &Study,
    model: &dyn Model,
    points: &[Vec<f64>],
    directory: &RunDirectory,
    parallel: usize,
    resume: bool,
) -> Result<Vec<Vec<Option<Vec<f64>>>>> {
    let runs = points.len();
    let mut outputs_by_role = Vec::new();
    for (role, log) in [
        (Role::Fit, "posterior_runs_fit.csv"),
        (Role::Validate, "posterior_runs_validate.csv"),
    ] {
        let has_cases = study.cases_with(role).any(|(_, c)| !c.priors);
        if !has_cases || runs == 0 {
            outputs_by_role.push(vec![None; runs]);
            continue;
        }
        let simulator = StudySimulator::new(study, model, role);
        let path = directory.file(log);
        let mut evaluator = if resume {
            Evaluator::resume(&simulator, &path, parallel)
        } else {
            Evaluator::create(&simulator, &path, parallel)
        }
        .map_err(evaluation_error)?;
        let evaluations = evaluator.evaluate(points).map_err(evaluation_error)?;
        outputs_by_role.push(evaluations.into_iter().map(|e| e.outcome.ok()).collect());
    }
    Ok(outputs_by_role)
}

/// Each run's discrepancy per output of the density and site, drawn from
/// its conditional normal at that draw.
fn discrepancy_draws(
    picked: &[usize],
    scales: &[Scales],
    rng: &mut ChaCha8Rng,
) -> Vec<Vec<Vec<f64>>> {
    picked
        .iter()
        .map(|&i| {
            scales[i]
                .discrepancy
                .iter()
                .map(|output| {
                    output
                        .at_sites
                        .iter()
                        .map(|(mean, variance)| mean + variance.sqrt() * standard_normal(rng))
                        .collect()
                })
                .collect()
        })
        .collect()
}

/// The predictive runs of one role: which draws they were and what each gave.
struct RoleRuns<'a> {
    role: Role,
    /// Each run's index into `draws`.
    picked: &'a [usize],
    draws: &'a [&'a Vec<f64>],
    /// Each run's outputs, `None` where it failed.
    outputs: &'a [Option<Vec<f64>>],
}

/// One observation of a case, with its place among the role's outputs.
struct ObservationAt<'a> {
    case: &'a Case,
    observation: &'a Observation,
    /// Its index among the outputs of the role's simulator.
    index: usize,
    case_name: String,
}

impl ObservationAt<'_> {
    /// A scalar observation's prediction, before any run is added.
    fn predicted(&self, role: Role, measured: f64, uncertainty: Option<f64>) -> Predicted {
        Predicted {
            case: self.case_name.clone(),
            role,
            name: self.observation.name.clone(),
            measured,
            uncertainty,
            model: Vec::new(),
            with_error: Vec::new(),
        }
    }
}

/// Adds each successful run's model value to `entry`, and the same plus a
/// draw of the output's discrepancy at the case (`constant`: at every
/// case) and of the measurement error.
fn add_scalar_runs(
    entry: &mut Predicted,
    at: &ObservationAt<'_>,
    runs: &RoleRuns<'_>,
    density: &StudyPosterior,
    scales: &[Scales],
    delta: &[Vec<Vec<f64>>],
    rng: &mut ChaCha8Rng,
) {
    let group = density
        .outputs
        .iter()
        .enumerate()
        .find(|(_, o)| o.output == at.observation.output)
        .and_then(|(k, o)| Some((k, o.site_of(&at.case.name)?)));
    for (run, run_outputs) in runs.outputs.iter().enumerate() {
        let Some(run_outputs) = run_outputs else {
            continue;
        };
        let model_value = run_outputs[at.index];
        let discrepancy = group.map_or(0.0, |(k, site)| {
            delta[run]
                .get(k)
                .and_then(|at| at.get(site))
                .copied()
                .unwrap_or(0.0)
        });
        let noise_pct = scales[runs.picked[run]].noise_pct;
        let sd = density.measurement_sd(noise_pct, entry.measured, entry.uncertainty);
        entry.model.push(model_value);
        entry
            .with_error
            .push(model_value + discrepancy + sd * standard_normal(rng));
    }
}

/// A measured curve's prediction: its MAPE at each successful run, and the
/// model's curve at each of those runs it gives again (a solver's from the
/// run directory the run left).
fn predicted_curve(
    study: &Study,
    model: &dyn Model,
    at: &ObservationAt<'_>,
    runs: &RoleRuns<'_>,
    measured: &[(f64, f64)],
    axes: &[String; 2],
) -> PredictedCurve {
    let case_index = study
        .cases
        .iter()
        .position(|c| std::ptr::eq(c, at.case))
        .unwrap_or(0);
    let curve_runs = runs
        .picked
        .iter()
        .zip(runs.outputs)
        .filter(|(_, run)| run.is_some())
        .filter_map(|(&draw, _)| {
            let inputs = study.inputs_of(case_index, runs.draws[draw]);
            let run = model.run_again(&inputs, &[], &[at.observation.output.as_str()])?;
            run.curves.into_iter().next()
        })
        .collect();
    PredictedCurve {
        case: at.case_name.clone(),
        role: runs.role,
        name: at.observation.name.clone(),
        axes: axes.clone(),
        measured: measured.to_vec(),
        mape_pct: runs.outputs.iter().flatten().map(|o| o[at.index]).collect(),
        runs: curve_runs,
    }
}

/// `predictive.csv`: `run`, `case`, `output`, `value` (the model's; a
/// curve's MAPE, %), `with_error` (plus discrepancy and measurement error
/// draws; empty for a curve).
fn write_predictive_csv(directory: &RunDirectory, predictions: &Predictions) -> Result<()> {
    let mut text = String::from("run,case,output,value,with_error\n");
    for curve in &predictions.curves {
        for (run, value) in curve.mape_pct.iter().enumerate() {
            text.push_str(&format!(
                "{},{},{},{value},\n",
                run + 1,
                csv_field(&curve.case),
                csv_field(&curve.name)
            ));
        }
    }
    for entry in &predictions.scalars {
        for (run, (value, with_error)) in entry.model.iter().zip(&entry.with_error).enumerate() {
            text.push_str(&format!(
                "{},{},{},{value},{with_error}\n",
                run + 1,
                csv_field(&entry.case),
                csv_field(&entry.name)
            ));
        }
    }
    write_text(&directory.file("predictive.csv"), &text)
}

/// A CSV field, quoted when it holds a comma or a quote.
fn csv_field(text: &str) -> String {
    if text.contains([',', '"', '\n']) {
        format!("\"{}\"", text.replace('"', "\"\""))
    } else {
        text.to_string()
    }
}
