//! The one runner of every study (the presets' and a user's): a [`Study`]
//! on a [`Model`] by one of the methods, then the validation cases at the
//! calibrated point, the identifiability analysis, the calibrated curves,
//! and the run directory's files: `summary.json` ([`super::summary`]), the
//! report ([`super::report`]) and what the study's [`Extras`] add.
//!
//! - `bo`: Bayesian optimisation of the study's loss ([`minimise_logged`]).
//! - `surrogate-moo`: [`surrogate_moo`] over the study's objectives.
//! - `least-squares`: bounded Levenberg-Marquardt on the study's residuals
//!   from the nominal point ([`acq_algorithms::least_squares`]), for cheap,
//!   smooth models (the built-in excavator twin); its last Jacobian is the
//!   identifiability analysis's.
//!
//! The fit runs log to `evaluations.csv`, the validation runs to
//! `validation.csv`; both resume.

use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use acq_algorithms::bo::Outcome;
use acq_algorithms::evaluation::{Evaluation, Evaluator, Parameter};
use acq_algorithms::gp::GpSettings;
use acq_algorithms::least_squares::{least_squares, LeastSquaresError, LeastSquaresSettings};
use acq_algorithms::multi_fidelity::MultiFidelitySettings;
use acq_algorithms::trust_region::TrustRegionSettings;
use acq_error::{AcqError, Result};

use super::error::StudyError;
use acq_report::document::Document;
use acq_report::number::count;

use super::extras::Extras;
use super::identifiability::{identifiability, identifiability_json, Local};
use super::mesh_study::with_mesh_parameter;
use super::method::{Method, RunSettings, CURVE_PARTS};
use super::outcome::{CalibratedCurve, Found, LeastSquaresFound, MultiFidelityFound, StudyOutcome};
use super::part_slopes::PartSlopesLog;
use super::posterior::{run_posterior, SearchResult};
use super::progress::Progress;
use super::report::{study_report, write_report};
use super::run_directory::{evaluation_error, write_text, RunDirectory};
use super::search::{
    bo_settings, from_unit, minimise_logged, minimise_two_levels_logged, scored, to_unit,
};
use super::simulator::StudySimulator;
use super::study::{Measured, Model, Observation, ObservationError, Role, Study};
use super::summary::summary;
use super::surrogate_moo::surrogate_moo;

/// Runs every case once at the nominal point, fit and validate alike: a
/// study whose model refuses a name or a value says so before it starts.
/// For models that cost little to run (the built-in twins).
pub fn check_at_nominal(study: &Study, model: &dyn Model) -> std::result::Result<(), String> {
    use acq_algorithms::evaluation::Simulator;
    for role in [Role::Fit, Role::Validate] {
        StudySimulator::new(study, model, role)
            .evaluate(&study.nominal())
            .map_err(|e| format!("at the nominal point: {e}"))?;
    }
    Ok(())
}

/// A finished study: what it found and its report (also on disk).
pub struct StudyRun {
    pub outcome: StudyOutcome,
    pub report: Document,
}

/// Runs the study and writes its run directory: `initial` is the BO start
/// design ([`start_design`]; ignored by the other methods).
pub fn run_study(
    study: &Study,
    model: &dyn Model,
    method: &Method,
    initial: Vec<Vec<f64>>,
    directory: &RunDirectory,
    settings: &RunSettings<'_>,
    extras: &dyn Extras,
) -> Result<StudyRun, StudyError> {
    let mut outcome = calibrate_study(study, model, method, initial, directory, settings)?;
    if let Some(posterior) = &settings.posterior {
        let search = SearchResult {
            calibrated: &outcome.calibrated,
            coarse_evaluations: &outcome.coarse_evaluations,
            evaluations: if outcome.evaluations_with_curve_parts.is_empty() {
                &outcome.evaluations
            } else {
                &outcome.evaluations_with_curve_parts
            },
        };
        outcome.posterior = Some(run_posterior(
            study,
            model,
            &search,
            posterior,
            directory,
            settings.parallel,
            settings.resume,
        )?);
    }
    if let Some(analysis) = &outcome.identifiability {
        write_text(
            &directory.file("identifiability.json"),
            &format!(
                "{:#}\n",
                identifiability_json(analysis, &study.search_parameters())
            ),
        )?;
    }
    write_text(
        &directory.file("summary.json"),
        &format!("{:#}\n", summary(study, &outcome, extras)),
    )?;
    let report = study_report(study, method, &outcome, settings, extras)?;
    write_report(directory, &report, &extras.title(settings).1)?;
    println!(
        "{}",
        extras
            .closing_line(study, &outcome)
            .unwrap_or_else(|| format!(
                "loss {:.4} after {} ({} failed)",
                study.loss(&outcome.calibrated_outputs),
                count(outcome.evaluations.len(), "model evaluation"),
                outcome.failed,
            ))
    );
    extras.files(study, &outcome, directory)?;
    println!("{}", closing_lines(study, &outcome));
    println!("report: {}", directory.file("report.html").display());
    Ok(StudyRun { outcome, report })
}

/// What a calibration found, in the lines before the report's path: the
/// parameters (the posterior's median and 90 % interval where one was
/// sampled, the search's pick named as such), which lie on a bound of
/// their range, whether the chains converged, and how many measured
/// values lie inside their predictive intervals; so the answer is on the
/// terminal without opening the report, and no line contradicts another.
fn closing_lines(study: &Study, outcome: &StudyOutcome) -> String {
    use acq_report::number::plain;
    let bound_of = |name: &str, value: f64| {
        study
            .parameters
            .iter()
            .find(|p| p.search.name == name)
            .and_then(|p| p.search.bound_reached(value))
    };
    let picked = outcome.calibrated_by_name(study);
    let marked = |name: &str, value: f64| match bound_of(name, value) {
        Some(side) => format!("{name} = {} ({side})", plain(value, 6)),
        None => format!("{name} = {}", plain(value, 6)),
    };
    let on_bounds: Vec<&str> = picked
        .iter()
        .filter(|(name, value)| bound_of(name, *value).is_some())
        .map(|(name, _)| name.as_str())
        .collect();
    let mut lines = Vec::new();
    if !on_bounds.is_empty() {
        lines.push(format!(
            "on a bound of its range: {} (of {}): the optimum may lie beyond it, or the data do not pin it (the report's identifiability section says which)",
            on_bounds.join(", "),
            count(picked.len(), "parameter")
        ));
    }
    let Some(posterior) = outcome.posterior.as_ref() else {
        let items: Vec<String> = picked.iter().map(|(n, v)| marked(n, *v)).collect();
        lines.push(format!("calibrated: {}", items.join(", ")));
        return lines.join("\n");
    };
    let items: Vec<String> = picked.iter().map(|(n, v)| marked(n, *v)).collect();
    lines.push(format!("the search's pick: {}", items.join(", ")));
    let medians: Vec<String> = picked
        .iter()
        .map(|(name, value)| {
            match posterior.column(name).map(|c| &posterior.marginals[c]) {
                Some(m) => {
                    // An interval that runs to a bound is cut by the prior
                    // there: said, so it is not read as the data's.
                    let reaches = [m.q05, m.q95]
                        .into_iter()
                        .filter_map(|end| bound_of(name, end))
                        .map(|side| format!(" (reaches the {side})"))
                        .next()
                        .unwrap_or_default();
                    format!(
                        "{name} = {} [{} .. {}]{reaches}",
                        plain(m.q50, 6),
                        plain(m.q05, 4),
                        plain(m.q95, 4)
                    )
                }
                None => format!("{name} = {}", plain(*value, 6)),
            }
        })
        .collect();
    lines.push(format!(
        "calibrated (posterior median [90 % interval]): {}",
        medians.join(", ")
    ));
    lines.push(convergence_line(posterior));
    if let Some(line) = predictive_line(posterior) {
        lines.push(line);
    }
    lines.join("\n")
}

/// The chains' convergence in one line: the worst R-hat and the least
/// effective sample sizes, and what has not converged.
fn convergence_line(posterior: &super::posterior::PosteriorOutcome) -> String {
    let parameters = &posterior.marginals[..posterior.marginals.len().min(posterior.names.len())];
    let worst_rhat = parameters.iter().map(|m| m.rhat).fold(f64::NAN, f64::max);
    let least = |ess: fn(&acq_algorithms::mcmc::Marginal) -> f64| {
        parameters.iter().map(ess).fold(f64::NAN, f64::min)
    };
    let measures = format!(
        "{}, R-hat {:.3} at most, bulk ESS {:.0} and tail ESS {:.0} at least",
        count(posterior.settings.chains, "chain"),
        worst_rhat,
        least(|m| m.ess_bulk),
        least(|m| m.ess_tail)
    );
    let unconverged = posterior.unconverged();
    if unconverged.is_empty() {
        format!("convergence: converged ({measures})")
    } else {
        format!(
            "convergence: NOT CONVERGED for {} ({measures}): read no interval as final; run longer (more draws)",
            unconverged.join(", ")
        )
    }
}

/// How many measured values lie inside their 90 % predictive intervals,
/// naming those that do not; `None` without scalar predictions.
fn predictive_line(posterior: &super::posterior::PosteriorOutcome) -> Option<String> {
    use acq_report::number::plain;
    let scalars: Vec<_> = posterior
        .predicted
        .scalars
        .iter()
        .filter(|p| !p.with_error.is_empty())
        .collect();
    if scalars.is_empty() {
        return None;
    }
    let outside: Vec<String> = scalars
        .iter()
        .filter(|p| !p.holds_measured())
        .map(|p| {
            let (_, low, high) = p.interval();
            format!(
                "{} {} outside [{} .. {}]",
                p.name,
                plain(p.measured, 5),
                plain(low, 4),
                plain(high, 4)
            )
        })
        .collect();
    let inside = scalars.len() - outside.len();
    let mut line = format!(
        "predictive: {inside} of {} lie inside their 90 % predictive intervals",
        count(scalars.len(), "measured value")
    );
    if !outside.is_empty() {
        line.push_str(&format!(
            "; {}: the model with its error does not reproduce them (a model error to add, or a prior to widen)",
            outside.join(", ")
        ));
    }
    Some(line)
}

/// The calibrated parameters and the model's outputs there: the pick of
/// the Pareto front, the least-squares point, or the best run of a
/// Bayesian search.
fn calibrated_point(
    study: &Study,
    found: &Found,
    parameters: &[Parameter],
    evaluations: &[Evaluation],
    directory: &RunDirectory,
) -> Result<(Vec<f64>, Vec<f64>), StudyError> {
    Ok(match found {
        Found::Moo(moo) => (moo.optimal.clone(), moo.optimal_outputs.clone()),
        Found::LeastSquares(ls) => (
            from_unit(parameters, &ls.result.point),
            ls.result.outputs.clone(),
        ),
        Found::Bo(_) | Found::MultiFidelity(_) => {
            let scored = scored(evaluations, |y| study.loss(y));
            let Some(&(best, _)) = scored.iter().min_by(|a, b| a.1.total_cmp(&b.1)) else {
                return Err(StudyError::NoRunSucceeded {
                    runs: evaluations.len(),
                    first_reason: "no run gave a loss".into(),
                    runs_directory: directory.file("runs"),
                    log: directory.file("evaluations.csv"),
                });
            };
            (
                best.parameters.clone(),
                best.outcome.clone().unwrap_or_default(),
            )
        }
    })
}

/// The parts each curve's errors are cut into for the method's local
/// steps (none without them).
fn curve_parts_of(method: &Method) -> usize {
    match method {
        Method::Bo(bo) if bo.local_steps => CURVE_PARTS,
        Method::MultiFidelity(mf) if mf.local_steps => CURVE_PARTS,
        _ => 0,
    }
}

/// The most model runs the method makes, for the progress line.
fn run_budget(method: &Method, parameters: usize) -> usize {
    match method {
        Method::Bo(bo) => bo.max_evals,
        Method::MultiFidelity(mf) => mf.max_evals,
        Method::SurrogateMoo(moo) => moo.budget(parameters),
        Method::LeastSquares(ls) => ls.max_evals + parameters,
    }
}

/// The fit cases as the search runs them: with their curves' parts for
/// local steps, and for Bayesian optimisation's local steps each run's own
/// slopes of them when the model gives them (kept in `part_slopes.csv`).
fn search_simulator<'a>(
    study: &'a Study,
    model: &'a dyn Model,
    (method, curve_parts): (&Method, usize),
    directory: &RunDirectory,
    resume: bool,
) -> Result<StudySimulator<'a>> {
    let simulator = StudySimulator::new(study, model, Role::Fit).with_curve_parts(curve_parts);
    if !(matches!(method, Method::Bo(bo) if bo.local_steps) && simulator.wants_part_slopes()) {
        return Ok(simulator);
    }
    let names: Vec<String> = study
        .search_parameters()
        .into_iter()
        .map(|p| p.name)
        .collect();
    let path = directory.file("part_slopes.csv");
    let log = PartSlopesLog::open(&path, &names, resume)
        .map_err(|e| AcqError::io(path.display().to_string(), e))?;
    Ok(simulator.with_part_slopes(log))
}

/// Runs the search on the fit cases, then the validate cases at the
/// calibrated point, then the identifiability analysis.
pub fn calibrate_study(
    study: &Study,
    model: &dyn Model,
    method: &Method,
    initial: Vec<Vec<f64>>,
    directory: &RunDirectory,
    settings: &RunSettings<'_>,
) -> Result<StudyOutcome, StudyError> {
    let parameters = study.search_parameters();
    let curve_parts = curve_parts_of(method);
    // Two levels: the element size is a parameter of the runs, logged.
    let levels = match method {
        Method::MultiFidelity(mf) => Some([mf.cheap_mesh, mf.expensive_mesh]),
        _ => None,
    };
    let levelled = levels.map(|meshes| with_mesh_parameter(study, &meshes));
    let expensive = levels.map(|[_, expensive]| expensive);
    let run_study = levelled.as_ref().unwrap_or(study);
    let simulator = search_simulator(
        run_study,
        model,
        (method, curve_parts),
        directory,
        settings.resume,
    )?;
    let budget = run_budget(method, parameters.len());
    let progress = Progress::new(settings.label.clone(), budget)
        .with_status(|| model.status())
        .with_observer(settings.progress);
    let start = Instant::now();
    let mut evaluator = directory
        .evaluator(&simulator, settings.parallel, settings.resume)?
        .with_progress(|e| {
            // The best loss shown is the expensive level's.
            let cheap =
                levels.is_some_and(|[_, expensive]| e.parameters.last() != Some(&expensive));
            let loss = e
                .outcome
                .as_ref()
                .ok()
                .filter(|_| !cheap)
                .map(|y| study.loss(y));
            progress.record(loss, e.outcome.is_err(), e.from_log);
        });
    let found = redrawn_while(&progress, model.status().is_some(), || {
        search(
            study,
            method,
            &mut evaluator,
            &parameters,
            initial,
            curve_parts,
            &|values| simulator.take_part_slopes(values),
        )
    });
    progress.finish();
    if evaluator.evaluations().iter().all(|e| e.outcome.is_err()) {
        if let Some(first) = evaluator.evaluations().first() {
            let reason = first.outcome.as_ref().err().cloned().unwrap_or_default();
            return Err(StudyError::NoRunSucceeded {
                runs: evaluator.evaluations().len(),
                first_reason: reason,
                runs_directory: directory.file("runs"),
                log: directory.file("evaluations.csv"),
            });
        }
    }
    let found = found?;
    // The curve parts served the search only; what follows sees the
    // observations.
    let observations = study.observations(Role::Fit).len();
    let evaluations_with_curve_parts = if curve_parts > 0 {
        searched_evaluations(evaluator.evaluations(), usize::MAX, expensive)
    } else {
        Vec::new()
    };
    let evaluations = searched_evaluations(evaluator.evaluations(), observations, expensive);
    // The posterior's emulator learns from the coarse runs too, as it
    // gets the fine ones (with their curve parts when logged).
    let kept = if curve_parts > 0 {
        usize::MAX
    } else {
        observations
    };
    let coarse_evaluations = levels.map_or_else(Vec::new, |[cheap, _]| {
        searched_evaluations(evaluator.evaluations(), kept, Some(cheap))
    });
    let failed = evaluations.iter().filter(|e| e.outcome.is_err()).count();
    let (calibrated, calibrated_outputs) =
        calibrated_point(study, &found, &parameters, &evaluations, directory)?;
    let fit_errors = study.errors(Role::Fit, &calibrated_outputs);
    let validation_errors = validate(study, model, &calibrated, directory, settings)?;
    let local = match &found {
        Found::LeastSquares(ls) => Local::Jacobian(&ls.result.output_jacobian),
        other => Local::Surrogates(other.gps()),
    };
    let identifiability =
        identifiability(study, &evaluations, &calibrated, &calibrated_outputs, local);
    let curves = calibrated_curves(study, model, &calibrated);
    Ok(StudyOutcome {
        found,
        calibrated,
        calibrated_outputs,
        fit_errors,
        validation_errors,
        evaluations,
        evaluations_with_curve_parts,
        coarse_evaluations,
        failed,
        wall_s: start.elapsed().as_secs_f64(),
        identifiability,
        note_columns: model.note_columns().to_vec(),
        curves,
        posterior: None,
    })
}

/// Runs `work`; on a terminal, and when the model has a status (runs
/// under way elsewhere, a cluster), the progress line is redrawn every
/// second meanwhile, so a job's pending -> running shows.
fn redrawn_while<T>(progress: &Progress, has_status: bool, work: impl FnOnce() -> T) -> T {
    let searching = AtomicBool::new(true);
    std::thread::scope(|scope| {
        if progress.is_redrawn() && has_status {
            scope.spawn(|| {
                let mut ticks = 0u32;
                while searching.load(Ordering::Relaxed) {
                    std::thread::sleep(Duration::from_millis(100));
                    ticks += 1;
                    if ticks % 10 == 0 {
                        progress.redraw();
                    }
                }
            });
        }
        let result = work();
        searching.store(false, Ordering::Relaxed);
        result
    })
}

/// The search's runs as what follows sees them (the calibrated point,
/// identifiability, the posterior's emulator): the first `observations`
/// outputs, and of two levels the runs at `size`, without their size.
fn searched_evaluations(
    runs: &[Evaluation],
    observations: usize,
    size: Option<f64>,
) -> Vec<Evaluation> {
    let mut evaluations = runs.to_vec();
    if let Some(size) = size {
        evaluations.retain(|e| e.parameters.last() == Some(&size));
        for evaluation in &mut evaluations {
            evaluation.parameters.pop();
        }
    }
    for evaluation in &mut evaluations {
        if let Ok(outputs) = &mut evaluation.outcome {
            outputs.truncate(observations);
        }
    }
    evaluations
}

/// The method's search through the logging evaluator.
fn search(
    study: &Study,
    method: &Method,
    evaluator: &mut Evaluator<'_>,
    parameters: &[Parameter],
    initial: Vec<Vec<f64>>,
    curve_parts: usize,
    part_slopes: &dyn Fn(&[f64]) -> Vec<f64>,
) -> Result<Found> {
    match method {
        Method::Bo(bo) => {
            let bo_settings = bo_settings(
                bo.batch,
                bo.target_loss,
                bo.max_evals,
                bo.patience,
                bo.acquisition,
                bo.seed,
                bo.local_steps.then(|| TrustRegionSettings {
                    absolute: study.local_steps_in_absolute_values(),
                    ..TrustRegionSettings::default()
                }),
            );
            minimise_logged(
                evaluator,
                parameters,
                initial,
                |values, y| Outcome {
                    loss: study.loss(y),
                    residuals: study.local_residuals(y, curve_parts),
                    slopes: study.local_residual_slopes(&part_slopes(values), curve_parts),
                },
                &bo_settings,
                !bo.deterministic,
            )
            .map(Found::Bo)
        }
        Method::MultiFidelity(mf) => {
            let settings = MultiFidelitySettings {
                max_evaluations: mf.max_evals,
                max_expensive: mf.max_expensive,
                target_loss: mf.target_loss,
                gp: GpSettings {
                    seed: mf.seed,
                    ..MultiFidelitySettings::default().gp
                },
                seed: mf.seed,
                local_steps: mf.local_steps.then(|| TrustRegionSettings {
                    absolute: study.local_steps_in_absolute_values(),
                    ..TrustRegionSettings::default()
                }),
                ..MultiFidelitySettings::default()
            };
            let meshes = [mf.cheap_mesh, mf.expensive_mesh];
            // With local steps the expensive start is the cheap start's
            // best, and a two-level design (L12) holds only the box's
            // corners: the cheap start also runs the nominal point (the
            // middle of the box where the study gives none), as a
            // factorial design's centre point does.
            let mut cheap_start = initial;
            let nominal = to_unit(parameters, &study.nominal());
            if mf.local_steps && !cheap_start.contains(&nominal) {
                cheap_start.push(nominal);
            }
            minimise_two_levels_logged(
                evaluator,
                parameters,
                cheap_start,
                mf.expensive_start_runs,
                meshes,
                |y| Outcome {
                    loss: study.loss(y),
                    residuals: study.local_residuals(y, curve_parts),
                    // The two levels' local steps take the levels' difference
                    // into their model, not one run's slopes.
                    slopes: Vec::new(),
                },
                &settings,
            )
            .map(|result| Found::MultiFidelity(Box::new(MultiFidelityFound { result, meshes })))
        }
        Method::SurrogateMoo(moo) => surrogate_moo(
            evaluator,
            parameters,
            &study.nominal(),
            &|y: &[f64]| study.objectives(y),
            moo,
        )
        .map(|m| Found::Moo(Box::new(m))),
        Method::LeastSquares(ls) => {
            least_squares_logged(evaluator, study, parameters, ls.max_evals)
                .map(|found| Found::LeastSquares(Box::new(found)))
        }
    }
}

/// Levenberg-Marquardt from the nominal point through the logging
/// evaluator: each Jacobian's shifted points go as one batch (in parallel
/// on a solver with several slots), every run is logged, and a resumed
/// search replays the same points from the log.
fn least_squares_logged(
    evaluator: &mut Evaluator<'_>,
    study: &Study,
    parameters: &[Parameter],
    max_evals: usize,
) -> Result<LeastSquaresFound> {
    let start = to_unit(parameters, &study.nominal());
    let mut nominal_outputs = None;
    let settings = LeastSquaresSettings {
        max_evaluations: max_evals,
        ..LeastSquaresSettings::default()
    };
    let result = least_squares(
        start,
        |points| {
            let values: Vec<Vec<f64>> = points.iter().map(|u| from_unit(parameters, u)).collect();
            let evaluations = evaluator.evaluate(&values)?;
            let outputs: Vec<Option<Vec<f64>>> =
                evaluations.into_iter().map(|e| e.outcome.ok()).collect();
            if nominal_outputs.is_none() {
                nominal_outputs = Some(outputs.first().cloned().flatten());
            }
            Ok(outputs)
        },
        |y| study.residuals(y),
        &settings,
    )
    .map_err(|error| match error {
        LeastSquaresError::Run(error) => evaluation_error(error),
        other => AcqError::Config(other.to_string()),
    })?;
    Ok(LeastSquaresFound {
        nominal_outputs: nominal_outputs.flatten().unwrap_or_default(),
        result,
    })
}

/// Runs the validation cases at the calibrated point (logged in
/// `validation.csv`); their errors, or none without validation cases.
fn validate(
    study: &Study,
    model: &dyn Model,
    calibrated: &[f64],
    directory: &RunDirectory,
    settings: &RunSettings<'_>,
) -> Result<Vec<ObservationError>, StudyError> {
    if study.cases_with(Role::Validate).next().is_none() {
        return Ok(Vec::new());
    }
    let simulator = StudySimulator::new(study, model, Role::Validate);
    let log = directory.file("validation.csv");
    let mut evaluator = if settings.resume {
        Evaluator::resume(&simulator, &log, 1)
    } else {
        Evaluator::create(&simulator, &log, 1)
    }
    .map_err(evaluation_error)?;
    let run = evaluator
        .evaluate(&[calibrated.to_vec()])
        .map_err(evaluation_error)?;
    let outputs = run[0]
        .outcome
        .clone()
        .map_err(|reason| StudyError::ValidationFailed { reason })?;
    Ok(study.errors(Role::Validate, &outputs))
}

/// Each case's observed curves at the calibrated point, as the model gives
/// them again ([`Model::run_again`]: a twin runs, a solver answers from
/// the run directory of the run it made there).
fn calibrated_curves(study: &Study, model: &dyn Model, calibrated: &[f64]) -> Vec<CalibratedCurve> {
    let mut curves = Vec::new();
    for (index, case) in study.cases.iter().enumerate() {
        let observed: Vec<&Observation> = case
            .observations
            .iter()
            .filter(|o| matches!(o.measured, Measured::Curve { .. }))
            .collect();
        if observed.is_empty() || case.priors {
            continue;
        }
        let names: Vec<&str> = observed.iter().map(|o| o.output.as_str()).collect();
        let run = model.run_again(&study.inputs_of(index, calibrated), &[], &names);
        for (k, observation) in observed.into_iter().enumerate() {
            let Measured::Curve {
                points,
                axes,
                metric,
            } = &observation.measured
            else {
                continue;
            };
            curves.push(CalibratedCurve {
                case: case.name.clone(),
                name: observation.output.clone(),
                measured: points.clone(),
                axes: axes.clone(),
                metric: *metric,
                model: run.as_ref().and_then(|r| r.curves.get(k).cloned()),
            });
        }
    }
    curves
}
