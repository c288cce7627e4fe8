//! The search steps the workflows share: parameters to and from the engine's
//! unit box, Bayesian optimisation through the logging evaluator, and the
//! best distinct parameter sets of a run.

use acq_algorithms::bo::{
    minimise, minimise_as_they_finish, Acquisition, BoError, BoResult, BoSettings, Finished,
    Outcome, RunsAsTheyFinish,
};
use acq_algorithms::evaluation::{AsyncRuns, Evaluation, EvaluationError, Evaluator, Parameter};
use acq_algorithms::gp::{GpSettings, Kernel};
use acq_algorithms::multi_fidelity::{
    ExpensiveStart, Fidelity, MultiFidelityResult, MultiFidelitySettings,
};
use acq_algorithms::trust_region::TrustRegionSettings;
use acq_error::{AcqError, Result};

use super::run_directory::evaluation_error;

/// Parameter values of a unit-box point.
pub fn from_unit(parameters: &[Parameter], unit: &[f64]) -> Vec<f64> {
    parameters
        .iter()
        .zip(unit)
        .map(|(p, &u)| p.from_unit(u.clamp(0.0, 1.0)))
        .collect()
}

/// A unit-box point of parameter values.
pub fn to_unit(parameters: &[Parameter], values: &[f64]) -> Vec<f64> {
    parameters
        .iter()
        .zip(values)
        .map(|(p, &v)| p.to_unit(v))
        .collect()
}

/// One of the best distinct parameter sets of a run.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Candidate {
    pub evaluation_id: usize,
    pub loss: f64,
    pub parameters: Vec<f64>,
}

/// Non-uniqueness: the best `count` evaluations that are at least
/// `min_distance` apart in the unit box (so near-copies of the best do not
/// crowd out a different answer), best first.
pub fn distinct_best(
    parameters: &[Parameter],
    evaluations: &[(&Evaluation, f64)],
    count: usize,
    min_distance: f64,
) -> Vec<Candidate> {
    let mut sorted: Vec<&(&Evaluation, f64)> = evaluations.iter().collect();
    sorted.sort_by(|a, b| a.1.total_cmp(&b.1));
    let mut chosen: Vec<Candidate> = Vec::new();
    for (evaluation, loss) in sorted {
        let unit = to_unit(parameters, &evaluation.parameters);
        let far = chosen.iter().all(|c| {
            let other = to_unit(parameters, &c.parameters);
            unit.iter()
                .zip(&other)
                .map(|(a, b)| (a - b).powi(2))
                .sum::<f64>()
                .sqrt()
                >= min_distance
        });
        if far {
            chosen.push(Candidate {
                evaluation_id: evaluation.id,
                loss: *loss,
                parameters: evaluation.parameters.clone(),
            });
            if chosen.len() == count {
                break;
            }
        }
    }
    chosen
}

/// Bayesian optimisation of `score(parameter values, outputs)` (the loss,
/// and residuals for local steps) through a logging evaluator: the engine's unit-box points
/// are scaled to the parameters, run (in parallel, logged) and scored; a
/// failed run is a missing loss. A log that cannot be
/// written stops the run with that error.
///
/// With more than one slot (`settings.batch`) and `as_they_finish`, the
/// runs go as they finish ([`minimise_as_they_finish`]): a new point is
/// proposed as soon as one run ends, so no slot waits for the slowest run
/// of a batch, but which run ends first (machine load) steers the search.
/// Otherwise the points go in synchronous batches: the result depends only
/// on the inputs and the seed.
pub fn minimise_logged(
    evaluator: &mut Evaluator<'_>,
    parameters: &[Parameter],
    initial: Vec<Vec<f64>>,
    score: impl Fn(&[f64], &[f64]) -> Outcome,
    settings: &BoSettings,
    as_they_finish: bool,
) -> Result<BoResult> {
    if settings.batch > 1 && as_they_finish {
        let slots = settings.batch;
        let result = evaluator.run_async(slots, |runs| {
            let mut adapter = LoggedRuns {
                runs,
                parameters,
                started: Vec::new(),
                score: &score,
            };
            minimise_as_they_finish::<LoggedRunError>(initial, &mut adapter, slots, settings)
        });
        return result.map_err(|error| match error {
            LoggedRunError::Log(error) => evaluation_error(error),
            LoggedRunError::Search(error) => AcqError::Config(error.to_string()),
        });
    }
    let mut log_failure = None;
    let result = minimise::<BoError, Outcome>(
        initial,
        |batch| {
            let values: Vec<Vec<f64>> = batch.iter().map(|u| from_unit(parameters, u)).collect();
            evaluate_kept(evaluator, &values, &mut log_failure, |e| {
                e.outcome.as_ref().ok().map(|y| score(&e.parameters, y))
            })
        },
        settings,
    );
    if let Some(error) = log_failure {
        return Err(evaluation_error(error));
    }
    result.map_err(|e| AcqError::Config(e.to_string()))
}

/// The two-level search ([`acq_algorithms::multi_fidelity`]) through a logging
/// evaluator whose simulator takes the element size as its last
/// parameter (`mesh`): each unit-box point is scaled to the parameters,
/// given its level's size, run (the start designs in parallel), logged
/// and scored. A failed run is a missing loss; a log that cannot be
/// written stops the run with that error.
pub fn minimise_two_levels_logged(
    evaluator: &mut Evaluator<'_>,
    parameters: &[Parameter],
    cheap_start: Vec<Vec<f64>>,
    expensive_start_runs: usize,
    meshes: [f64; 2],
    score: impl Fn(&[f64]) -> Outcome,
    settings: &MultiFidelitySettings,
) -> Result<MultiFidelityResult> {
    // The local steps start from the best expensive run: the expensive
    // start goes where the cheap start design did best. Without them the
    // co-kriging's global steps need the design's spread: its first points.
    let expensive_start = if settings.local_steps.is_some() {
        ExpensiveStart::BestCheap(expensive_start_runs)
    } else {
        ExpensiveStart::Points(
            cheap_start
                .iter()
                .take(expensive_start_runs)
                .cloned()
                .collect(),
        )
    };
    let mut log_failure = None;
    let result = acq_algorithms::multi_fidelity::minimise::<BoError>(
        cheap_start,
        expensive_start,
        |level, points| {
            let mesh = match level {
                Fidelity::Cheap => meshes[0],
                Fidelity::Expensive => meshes[1],
            };
            let values: Vec<Vec<f64>> = points
                .iter()
                .map(|u| {
                    let mut values = from_unit(parameters, u);
                    values.push(mesh);
                    values
                })
                .collect();
            evaluate_kept(evaluator, &values, &mut log_failure, |e| {
                (e.outcome.as_ref().ok().map(|y| score(y)), e.wall_s)
            })
        },
        settings,
    );
    if let Some(error) = log_failure {
        return Err(evaluation_error(error));
    }
    result.map_err(|e| AcqError::Config(e.to_string()))
}

/// Runs `values` and reads each evaluation with `read`; a log that
/// cannot be written is kept in `log_failure` (the caller reports it)
/// and stops the search.
fn evaluate_kept<T>(
    evaluator: &mut Evaluator<'_>,
    values: &[Vec<f64>],
    log_failure: &mut Option<EvaluationError>,
    read: impl Fn(&Evaluation) -> T,
) -> std::result::Result<Vec<T>, BoError> {
    match evaluator.evaluate(values) {
        Ok(evaluations) => Ok(evaluations.iter().map(read).collect()),
        Err(error) => {
            let message = error.to_string();
            *log_failure = Some(error);
            Err(BoError::Settings(message))
        }
    }
}

/// The successful evaluations with their loss.
pub fn scored(evaluations: &[Evaluation], loss: impl Fn(&[f64]) -> f64) -> Vec<(&Evaluation, f64)> {
    evaluations
        .iter()
        .filter_map(|e| e.outcome.as_ref().ok().map(|y| (e, loss(y))))
        .collect()
}

/// The Bayesian optimisation every study runs (the GTN preset and external
/// studies alike): a Matern-5/2 GP with one length scale per parameter,
/// three fits from seeded starts, and the noise left free (the losses of
/// FE runs are rough at the scale of their convergence tolerances).
pub fn bo_settings(
    batch: usize,
    target_loss: Option<f64>,
    max_evaluations: usize,
    patience: Option<usize>,
    acquisition: Option<Acquisition>,
    seed: u64,
    local_steps: Option<TrustRegionSettings>,
) -> BoSettings {
    let defaults = BoSettings::default();
    BoSettings {
        acquisition: acquisition.unwrap_or(defaults.acquisition),
        batch: batch.max(1),
        target_loss,
        max_evaluations,
        patience,
        gp: GpSettings {
            kernel: Kernel::Matern52,
            ard: true,
            restarts: 3,
            seed,
            ..GpSettings::default()
        },
        seed,
        local_steps,
        ..defaults
    }
}

/// Why a run-as-they-finish search stopped short.
enum LoggedRunError {
    Log(EvaluationError),
    Search(BoError),
}

impl From<BoError> for LoggedRunError {
    fn from(error: BoError) -> Self {
        LoggedRunError::Search(error)
    }
}

/// The engine's unit-box points on the logging evaluator's runs.
struct LoggedRuns<'r, 'e, 'a, L> {
    runs: &'r mut AsyncRuns<'e, 'a>,
    parameters: &'r [Parameter],
    /// (parameter values, unit point) of the points started.
    started: Vec<(Vec<f64>, Vec<f64>)>,
    score: &'r L,
}

impl<L: Fn(&[f64], &[f64]) -> Outcome> RunsAsTheyFinish<LoggedRunError>
    for LoggedRuns<'_, '_, '_, L>
{
    fn start(&mut self, unit_point: Vec<f64>) -> std::result::Result<(), LoggedRunError> {
        let values = from_unit(self.parameters, &unit_point);
        self.runs
            .start(values.clone())
            .map_err(LoggedRunError::Log)?;
        self.started.push((values, unit_point));
        Ok(())
    }

    fn next_done(&mut self) -> std::result::Result<Option<Finished>, LoggedRunError> {
        let Some(evaluation) = self.runs.next_done().map_err(LoggedRunError::Log)? else {
            return Ok(None);
        };
        let index = self
            .started
            .iter()
            .position(|(values, _)| *values == evaluation.parameters)
            .ok_or_else(|| {
                LoggedRunError::Log(EvaluationError::Setup(
                    "a finished run matches no started point".into(),
                ))
            })?;
        let (_, unit_point) = self.started.remove(index);
        let outcome = evaluation
            .outcome
            .as_ref()
            .ok()
            .map(|y| (self.score)(&evaluation.parameters, y));
        Ok(Some((unit_point, outcome)))
    }
}
