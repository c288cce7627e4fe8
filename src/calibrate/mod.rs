//! `acq calibrate`: the workflows that fit a model to measurements with the
//! engine of `acq_calib`, and what they leave in the run directory.
//!
//! - [`excavator`]: DoE -> GP per pressure -> NSGA-II on the GP -> TOPSIS ->
//!   the pick re-run on the twin.
//! - [`gtn`]: flow curve from the test, L12 start, Bayesian optimisation of
//!   the curve MAPE.
//! - [`external`]: the same engine on a user's solver run as a command.
//!
//! Every workflow writes `evaluations.csv` as it goes (resumable with
//! `--resume`), then `summary.json` (the fixed interface), `report.md`, `report.html` and
//! SVG plots. Progress goes to stderr.

pub mod excavator;
pub mod external;
pub mod gtn;
pub mod progress;
pub mod report;

use std::path::{Path, PathBuf};

use acq_calib::bo::{minimise, BoError, BoResult, BoSettings};
use acq_calib::evaluation::{Evaluation, EvaluationError, Evaluator, Parameter, Simulator};
use clap::Subcommand;

use crate::error::{AcqError, Result};

#[derive(Subcommand, Debug)]
pub enum CalibrateCommand {
    /// Excavator front attachment: match the three cylinder pressures of a case.
    Excavator(excavator::CalibrateExcavatorArgs),
    /// GTN tensile twin: match a test's force-displacement curve.
    Gtn(gtn::CalibrateGtnArgs),
    /// A user's solver, run as a command per evaluation (spec file).
    External(external::CalibrateExternalArgs),
}

pub fn run(command: CalibrateCommand) -> Result<()> {
    match command {
        CalibrateCommand::Excavator(args) => excavator::run(args).map(drop),
        CalibrateCommand::Gtn(args) => gtn::run(args).map(drop),
        CalibrateCommand::External(args) => external::run(args),
    }
}

/// The run directory: created if missing; `evaluations.csv` in it must be
/// new unless the run resumes.
pub struct RunDirectory {
    pub path: PathBuf,
}

impl RunDirectory {
    pub fn create(path: &Path) -> Result<Self> {
        std::fs::create_dir_all(path)
            .map_err(|e| AcqError::io(format!("creating {}", path.display()), e))?;
        Ok(RunDirectory {
            path: path.to_path_buf(),
        })
    }

    pub fn file(&self, name: &str) -> PathBuf {
        self.path.join(name)
    }

    /// The evaluator logging to `evaluations.csv` here.
    pub fn evaluator<'a>(
        &self,
        simulator: &'a dyn Simulator,
        parallel: usize,
        resume: bool,
    ) -> Result<Evaluator<'a>> {
        let log = self.file("evaluations.csv");
        let evaluator = if resume {
            Evaluator::resume(simulator, &log, parallel)
        } else {
            Evaluator::create(simulator, &log, parallel)
        };
        evaluator.map_err(evaluation_error)
    }
}

/// An engine error as the CLI reports it: a bad log or setup is a
/// configuration problem (exit 2), a failed write an I/O failure.
pub fn evaluation_error(error: EvaluationError) -> AcqError {
    match error {
        EvaluationError::Io { path, source } => {
            AcqError::io(format!("writing {}", path.display()), source)
        }
        other => AcqError::Config(other.to_string()),
    }
}

/// Cores to use for parallel evaluations by default.
pub fn default_parallelism() -> usize {
    std::thread::available_parallelism().map_or(1, |n| n.get())
}

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

/// Bayesian optimisation of `loss(outputs)` through a logging evaluator: the
/// engine's unit-box points are scaled to the parameters, run (in parallel,
/// logged) and scored; a failed run is a missing loss. A log that cannot be
/// written stops the run with that error.
pub fn minimise_logged(
    evaluator: &mut Evaluator<'_>,
    parameters: &[Parameter],
    initial: Vec<Vec<f64>>,
    loss: impl Fn(&[f64]) -> f64,
    settings: &BoSettings,
) -> Result<BoResult> {
    let mut log_failure = None;
    let result = minimise::<BoError>(
        initial,
        |batch| {
            let values: Vec<Vec<f64>> = batch.iter().map(|u| from_unit(parameters, u)).collect();
            match evaluator.evaluate(&values) {
                Ok(evaluations) => Ok(evaluations
                    .iter()
                    .map(|e| e.outcome.as_ref().ok().map(|y| loss(y)))
                    .collect()),
                Err(error) => {
                    let message = error.to_string();
                    log_failure = Some(error);
                    Err(BoError::Settings(message))
                }
            }
        },
        settings,
    );
    if let Some(error) = log_failure {
        return Err(evaluation_error(error));
    }
    result.map_err(|e| AcqError::Config(e.to_string()))
}

/// The successful evaluations with their loss.
pub fn scored(evaluations: &[Evaluation], loss: impl Fn(&[f64]) -> f64) -> Vec<(&Evaluation, f64)> {
    evaluations
        .iter()
        .filter_map(|e| e.outcome.as_ref().ok().map(|y| (e, loss(y))))
        .collect()
}
