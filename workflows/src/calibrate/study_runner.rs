//! Runs a [`Study`] on a [`Model`] with either published method, then
//! checks the validation cases at the calibrated point and writes
//! `summary.json` and the report.
//!
//! - `bo`: Bayesian optimisation of the study's loss ([`minimise_logged`]).
//! - `surrogate-moo`: [`surrogate_moo`] over the study's objectives.
//! - `least-squares`: bounded Levenberg-Marquardt on the study's residuals
//!   from the nominal point ([`acq_calib::least_squares`]), for cheap,
//!   smooth models (the built-in excavator twin); its last Jacobian is the
//!   identifiability analysis's.
//!
//! The fit runs log to `evaluations.csv`, the validation runs to
//! `validation.csv`; both resume.

use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use acq_calib::bo::{Acquisition, Outcome};
use acq_calib::doe::{
    full_factorial, latin_hypercube, orthogonal_array_l12, read_design_csv, sobol_points,
    two_level_to_unit,
};
use acq_calib::evaluation::{Evaluation, Evaluator, Parameter};
use acq_calib::least_squares::{
    least_squares, LeastSquaresError, LeastSquaresResult, LeastSquaresSettings, Stop as LsStop,
};
use acq_calib::trust_region::TrustRegionSettings;
use acq_io::error::{AcqError, Result};
use acq_report::document::{Document, Figure, Table};
use acq_report::plot::{chart_svg, Chart, Series, SeriesStyle};
use serde_json::{json, Map, Value};

use super::identifiability::{
    identifiability, identifiability_json, write_identifiability, Identifiability, Local,
};
use super::progress::Progress;
use super::report::{pareto_svg, write_report, write_text};
use super::run_directory::{evaluation_error, RunDirectory};
use super::search::{
    bo_settings, distinct_best, from_unit as acq_calib_from_unit, minimise_logged, scored, to_unit,
};
use super::study::{
    cases_json, chi_square, errors_json, LossKind, Model, ObservationError, Residuals, Role, Study,
    StudySimulator,
};
use super::surrogate_moo::{rounds_sentence, surrogate_moo, SurrogateMooSettings};

/// Bayesian optimisation's settings in a study.
#[derive(Clone, Debug)]
pub struct BoMethod {
    /// lhs, sobol, l12, factorial, or a CSV file of points.
    pub start: String,
    pub start_runs: usize,
    pub max_evals: usize,
    pub target_loss: Option<f64>,
    pub acquisition: Option<Acquisition>,
    pub patience: Option<usize>,
    /// Points proposed (and run) at once.
    pub batch: usize,
    pub seed: u64,
    /// Local trust-region steps on the residuals (each curve's errors in
    /// [`CURVE_PARTS`] parts) between the global ones.
    pub local_steps: bool,
}

/// How many parts of a curve the local steps of a search see: enough to
/// tell the elastic rise, the hardening, the necking and the drop apart.
pub const CURVE_PARTS: usize = 20;

/// Least squares' settings in a study.
#[derive(Clone, Debug)]
pub struct LeastSquaresMethod {
    /// Model runs at most (each Jacobian costs one per parameter).
    pub max_evals: usize,
}

/// The search method of a study.
#[derive(Clone, Debug)]
pub enum Method {
    Bo(BoMethod),
    SurrogateMoo(SurrogateMooSettings),
    LeastSquares(LeastSquaresMethod),
}

/// How a study runs, besides its method.
pub struct RunSettings<'a> {
    /// The progress line's label.
    pub label: String,
    /// For messages and the report's title (the spec's path).
    pub title: String,
    /// Where a CSV start design's path starts.
    pub spec_directory: &'a Path,
    pub parallel: usize,
    pub resume: bool,
}

/// The start design in the unit box; read before the run directory exists,
/// so a refused design leaves nothing behind.
pub fn start_design(
    parameters: &[Parameter],
    bo: &BoMethod,
    spec_directory: &Path,
) -> Result<Vec<Vec<f64>>> {
    let d = parameters.len();
    let n = bo.start_runs;
    let config = |e: String| AcqError::Config(format!("search.start: {e}"));
    Ok(match bo.start.as_str() {
        "lhs" => latin_hypercube(n, d, bo.seed),
        "sobol" => sobol_points(n, d, Some(bo.seed)).map_err(|e| config(e.to_string()))?,
        "l12" => two_level_to_unit(&orthogonal_array_l12(d).map_err(|e| config(e.to_string()))?),
        "factorial" => full_factorial(&vec![2; d]).map_err(|e| config(e.to_string()))?,
        file => {
            let path = spec_directory.join(file);
            let text = std::fs::read_to_string(&path).map_err(|e| AcqError::open(&path, e))?;
            acq_io::input::note_input(&path);
            let names: Vec<&str> = parameters.iter().map(|p| p.name.as_str()).collect();
            let points = read_design_csv(&text, &names)
                .map_err(|e| AcqError::Malformed(format!("{}: {e}", path.display())))?;
            points.iter().map(|p| to_unit(parameters, p)).collect()
        }
    })
}

/// Runs every case once at the nominal point, fit and validate alike: a
/// study whose model refuses a name or a value says so before it starts.
/// For models that cost little to run (the built-in twins).
pub fn check_at_nominal(study: &Study, model: &dyn Model) -> std::result::Result<(), String> {
    use acq_calib::evaluation::Simulator;
    for role in [Role::Fit, Role::Validate] {
        StudySimulator::new(study, model, role)
            .evaluate(&study.nominal())
            .map_err(|e| format!("at the nominal point: {e}"))?;
    }
    Ok(())
}

/// What a study found.
pub struct StudyOutcome {
    pub found: Found,
    /// The calibrated point (search vector) and the fit outputs there.
    pub calibrated: Vec<f64>,
    pub calibrated_outputs: Vec<f64>,
    pub fit_errors: Vec<ObservationError>,
    pub validation_errors: Vec<ObservationError>,
    /// Every fit evaluation, from the log or run now.
    pub evaluations: Vec<Evaluation>,
    pub failed: usize,
    pub wall_s: f64,
    pub identifiability: Option<Identifiability>,
    /// The model's note columns (where each run happened), as logged.
    pub note_columns: Vec<String>,
}

/// Runs the study; `initial` is the BO start design (ignored by
/// surrogate-moo). Writes summary.json and the report into `directory`.
pub fn run_study(
    study: &Study,
    model: &dyn Model,
    method: &Method,
    initial: Vec<Vec<f64>>,
    directory: &RunDirectory,
    settings: &RunSettings<'_>,
) -> Result<()> {
    let outcome = calibrate_study(study, model, method, initial, directory, settings)?;
    write_study(study, &outcome, directory, settings)
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
) -> Result<StudyOutcome> {
    let parameters = study.search_parameters();
    let curve_parts = match method {
        Method::Bo(bo) if bo.local_steps => CURVE_PARTS,
        _ => 0,
    };
    let simulator = StudySimulator::new(study, model, Role::Fit).with_curve_parts(curve_parts);
    let budget = match method {
        Method::Bo(bo) => bo.max_evals,
        Method::SurrogateMoo(moo) => moo.budget(parameters.len()),
        Method::LeastSquares(ls) => ls.max_evals + parameters.len(),
    };
    let progress = Progress::new(settings.label.clone(), budget).with_status(|| model.status());
    let start = Instant::now();
    let mut evaluator = directory
        .evaluator(&simulator, settings.parallel, settings.resume)?
        .with_progress(|e| {
            let loss = e.outcome.as_ref().ok().map(|y| study.loss(y));
            progress.record(loss, e.outcome.is_err(), e.from_log);
        });
    // On a terminal the line is redrawn every second while runs are under
    // way elsewhere (a cluster), so a job's pending -> running shows.
    let searching = AtomicBool::new(true);
    let found = std::thread::scope(|scope| {
        if progress.is_redrawn() && model.status().is_some() {
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
        let found = match method {
            Method::Bo(bo) => {
                let bo_settings = bo_settings(
                    bo.batch,
                    bo.target_loss,
                    bo.max_evals,
                    bo.patience,
                    bo.acquisition,
                    bo.seed,
                    bo.local_steps.then(|| TrustRegionSettings {
                        // A mean or largest error is a sum of absolute values,
                        // not of squares.
                        absolute: study.loss != LossKind::Squares,
                        ..TrustRegionSettings::default()
                    }),
                );
                minimise_logged(
                    &mut evaluator,
                    &parameters,
                    initial,
                    |y| Outcome {
                        loss: study.loss(y),
                        residuals: study.local_residuals(y, curve_parts),
                    },
                    &bo_settings,
                )
                .map(Found::Bo)
            }
            Method::SurrogateMoo(moo) => surrogate_moo(
                &mut evaluator,
                &parameters,
                &study.nominal(),
                &|y: &[f64]| study.objectives(y),
                moo,
            )
            .map(|m| Found::Moo(Box::new(m))),
            Method::LeastSquares(ls) => {
                least_squares_logged(&mut evaluator, study, &parameters, ls.max_evals)
                    .map(|found| Found::LeastSquares(Box::new(found)))
            }
        };
        searching.store(false, Ordering::Relaxed);
        found
    });
    progress.finish();
    if evaluator.evaluations().iter().all(|e| e.outcome.is_err()) {
        if let Some(first) = evaluator.evaluations().first() {
            let reason = first.outcome.as_ref().err().cloned().unwrap_or_default();
            return Err(AcqError::Config(format!(
                "none of the {} model runs succeeded; the first failed with: {reason}. Each run's stdout.txt and stderr.txt are in {}, every reason in {}",
                evaluator.evaluations().len(),
                directory.file("runs").display(),
                directory.file("evaluations.csv").display()
            )));
        }
    }
    let found = found?;
    // The curve parts served the search only; what follows sees the
    // observations.
    let observations = study.observations(Role::Fit).len();
    let mut evaluations = evaluator.evaluations().to_vec();
    for evaluation in &mut evaluations {
        if let Ok(outputs) = &mut evaluation.outcome {
            outputs.truncate(observations);
        }
    }
    let failed = evaluations.iter().filter(|e| e.outcome.is_err()).count();
    let (calibrated, calibrated_outputs) = match &found {
        Found::Moo(moo) => (moo.optimal.clone(), moo.optimal_outputs.clone()),
        Found::LeastSquares(ls) => (
            acq_calib_from_unit(&parameters, &ls.result.point),
            ls.result.outputs.clone(),
        ),
        Found::Bo(_) => {
            let scored = scored(&evaluations, |y| study.loss(y));
            let Some(&(best, _)) = scored.iter().min_by(|a, b| a.1.total_cmp(&b.1)) else {
                return Err(AcqError::Config(format!(
                    "none of the {} model runs succeeded; see {}",
                    evaluations.len(),
                    directory.file("evaluations.csv").display()
                )));
            };
            (
                best.parameters.clone(),
                best.outcome.clone().unwrap_or_default(),
            )
        }
    };
    let fit_errors = study.errors(Role::Fit, &calibrated_outputs);
    let validation_errors = validate(study, model, &calibrated, directory, settings)?;
    let local = match &found {
        Found::LeastSquares(ls) => Local::Jacobian(&ls.result.output_jacobian),
        other => Local::Surrogates(other.gps()),
    };
    let identifiability =
        identifiability(study, &evaluations, &calibrated, &calibrated_outputs, local);
    Ok(StudyOutcome {
        found,
        calibrated,
        calibrated_outputs,
        fit_errors,
        validation_errors,
        evaluations,
        failed,
        wall_s: start.elapsed().as_secs_f64(),
        identifiability,
        note_columns: model.note_columns().to_vec(),
    })
}

/// The study's `summary.json` (each method's fixed keys) and its report.
pub fn write_study(
    study: &Study,
    outcome: &StudyOutcome,
    directory: &RunDirectory,
    settings: &RunSettings<'_>,
) -> Result<()> {
    let StudyOutcome {
        found,
        calibrated,
        calibrated_outputs,
        fit_errors,
        validation_errors,
        evaluations: all_evaluations,
        failed,
        wall_s,
        identifiability: analysis,
        note_columns,
    } = outcome;
    let (failed, wall_s) = (*failed, *wall_s);
    let parameters = study.search_parameters();
    let evaluations = all_evaluations.len();
    let scored = scored(all_evaluations, |y| study.loss(y));

    // summary.json: the fixed keys of each method.
    let mut summary = Map::new();
    let named = |values: &[f64]| -> Value {
        Value::Object(
            parameters
                .iter()
                .zip(values)
                .map(|(p, v)| (p.name.clone(), json!(v)))
                .collect(),
        )
    };
    match &found {
        Found::Bo(result) => {
            summary.insert(
                "best_loss_pct".into(),
                json!(study.loss(calibrated_outputs)),
            );
            summary.insert(
                "best_outputs".into(),
                Value::Object(
                    simulator_outputs(study)
                        .into_iter()
                        .zip(calibrated_outputs)
                        .map(|(k, v)| (k, json!(v)))
                        .collect(),
                ),
            );
            summary.insert("best_params".into(), named(calibrated));
            summary.insert(
                "evaluations_to_target".into(),
                json!(result.evaluations_to_target),
            );
            summary.insert("failed".into(), json!(failed));
            summary.insert("wall_s".into(), json!(wall_s));
        }
        Found::Moo(moo) => {
            summary.insert(
                "errors_initial_pct".into(),
                errors_json(&study.errors(Role::Fit, &moo.nominal_outputs)),
            );
            summary.insert("errors_optimal_pct".into(), errors_json(fit_errors));
            summary.insert("optimal".into(), named(calibrated));
            let mut rmse = Map::new();
            let keys = simulator_outputs(study);
            for (surrogate, row) in &moo.surrogate_rmse {
                rmse.insert(
                    surrogate.clone(),
                    Value::Object(
                        keys.iter()
                            .zip(row)
                            .map(|(k, v)| (k.clone(), json!(v)))
                            .collect(),
                    ),
                );
            }
            summary.insert("surrogate_rmse".into(), Value::Object(rmse));
            summary.insert("failed".into(), json!(failed));
            summary.insert("wall_s".into(), json!(wall_s));
        }
        Found::LeastSquares(ls) => {
            summary.insert(
                "errors_initial_pct".into(),
                errors_json(&study.errors(Role::Fit, &ls.nominal_outputs)),
            );
            summary.insert("errors_optimal_pct".into(), errors_json(fit_errors));
            summary.insert("optimal".into(), named(calibrated));
            summary.insert("loss".into(), json!(study.loss(calibrated_outputs)));
            summary.insert("sum_of_squares".into(), json!(ls.result.cost));
            summary.insert("iterations".into(), json!(ls.result.iterations));
            summary.insert(
                "stop".into(),
                json!(format!("{:?}", ls.result.stop).to_lowercase()),
            );
            summary.insert("failed".into(), json!(failed));
            summary.insert("wall_s".into(), json!(wall_s));
        }
    }
    summary.insert("evaluations".into(), json!(evaluations));
    if study.named_cases {
        let mut all = fit_errors.clone();
        all.extend(validation_errors.iter().cloned());
        summary.insert("cases".into(), cases_json(&all));
    }
    for (key, errors) in [
        ("chi_square", &fit_errors),
        ("validation_chi_square", &validation_errors),
    ] {
        if let Some((chi2, n)) = chi_square(errors) {
            summary.insert(key.into(), json!({"value": chi2, "observations": n}));
        }
    }
    if let Some(analysis) = analysis {
        write_text(
            &directory.file("identifiability.json"),
            &format!("{:#}\n", identifiability_json(analysis, &parameters)),
        )?;
    }
    write_text(
        &directory.file("summary.json"),
        &format!("{:#}\n", Value::Object(summary)),
    )?;

    // The report.
    let mut report = Document::new();
    report.heading(1, format!("Calibration with {}", settings.title));
    let method_sentence = match &found {
        Found::Bo(result) => format!(
            "Bayesian optimisation of the {} error: best loss {:.4} after {evaluations} model evaluations ({failed} failed), {wall_s:.1} s; stopped: {:?}.",
            if study.loss == super::study::LossKind::Max { "largest" } else { "weighted mean" },
            study.loss(calibrated_outputs),
            result.stop
        ),
        Found::Moo(moo) => format!(
            "Surrogate + NSGA-II: {evaluations} model evaluations ({failed} failed) in {wall_s:.1} s; {} among {} Pareto points. {}",
            moo.pick_sentence(),
            moo.front.len(),
            rounds_sentence(&moo.rounds)
        ),
        Found::LeastSquares(ls) => format!(
            "Least squares (Levenberg-Marquardt from the nominal point): sum of squared residuals {:.4} after {} iterations and {evaluations} model evaluations ({failed} failed), {wall_s:.1} s; stopped: {}.",
            ls.result.cost,
            ls.result.iterations,
            match ls.result.stop {
                LsStop::Converged => "converged",
                LsStop::NoDescent => "no step lowers the residuals further (a local minimum, perhaps on a bound)",
                LsStop::Budget => "the run budget (max_evals) is spent; the search had not converged",
            }
        ),
    };
    report.paragraph(method_sentence);
    let nominal_errors = match &found {
        Found::Moo(moo) => Some(study.errors(Role::Fit, &moo.nominal_outputs)),
        Found::LeastSquares(ls) => Some(study.errors(Role::Fit, &ls.nominal_outputs)),
        Found::Bo(_) => None,
    };
    report.heading(2, "Fit cases");
    report.table(errors_table(fit_errors, nominal_errors.as_deref()));
    if !validation_errors.is_empty() {
        report
            .heading(2, "Validation cases (never seen by the search)")
            .table(errors_table(validation_errors, None));
        let largest =
            |errors: &[ObservationError]| errors.iter().map(|e| e.error_pct).fold(0.0f64, f64::max);
        let (fit, validation) = (largest(fit_errors), largest(validation_errors));
        report.paragraph(if validation > 2.0 * fit.max(1.0) {
            format!(
                "The largest validation error, {validation:.2} %, is well above the largest fit error, {fit:.2} %: the calibrated model does not carry over to the validation cases. Suspect the model (a missing effect) before the parameters."
            )
        } else {
            format!(
                "The largest validation error is {validation:.2} % against {fit:.2} % on the fit cases: the calibrated model predicts the cases it was not fitted to about as well as those it was."
            )
        });
    }
    if let Some(sentence) = chi_square_sentence("fit", fit_errors, parameters.len()) {
        report.paragraph(sentence);
    }
    if let Some(sentence) = chi_square_sentence("validation", validation_errors, 0) {
        report.paragraph(sentence);
    }
    report.heading(2, "Parameters");
    let mut table = Table::new(&[
        "parameter",
        "scale",
        "lower",
        "upper",
        "nominal",
        "calibrated",
        "note",
    ]);
    for ((p, sp), v) in parameters.iter().zip(&study.parameters).zip(calibrated) {
        let unit = p.to_unit(*v);
        table.row(vec![
            p.name.clone(),
            format!("{:?}", p.scale).to_lowercase(),
            format!("{}", p.lower),
            format!("{}", p.upper),
            format!("{}", sp.nominal),
            format!("{v:.6}"),
            if !(0.01..=0.99).contains(&unit) {
                "on a bound: the optimum may lie outside the range".into()
            } else {
                String::new()
            },
        ]);
    }
    report.table(table);
    write_identifiability(&mut report, analysis, &parameters);
    match &found {
        Found::Moo(moo) => {
            let keys = simulator_outputs(study);
            report.heading(
                2,
                format!("Surrogates: RMSE on the {} test runs", moo.test_runs),
            );
            let mut header = vec!["surrogate".to_string()];
            header.extend(keys.iter().cloned());
            let header: Vec<&str> = header.iter().map(String::as_str).collect();
            let mut table = Table::new(&header);
            for (name, row) in &moo.surrogate_rmse {
                let mut cells = vec![name.clone()];
                cells.extend(row.iter().map(|v| format!("{v:.4}")));
                table.row(cells);
            }
            let names: Vec<String> = keys.iter().map(|k| format!("{k} error")).collect();
            let names: Vec<&str> = names.iter().map(String::as_str).collect();
            report.table(table);
            if names.len() >= 2 {
                report.figure(Figure {
                    file: "pareto.svg".into(),
                    caption: format!(
                        "Pareto front of the GP errors (NSGA-II), {} pick",
                        moo.picked_by
                    ),
                    svg: pareto_svg(
                        "Pareto front of the GP errors",
                        &names,
                        &moo.front,
                        moo.pick,
                    ),
                });
            }
        }
        Found::Bo(_) => {
            let candidates = distinct_best(&parameters, &scored, 5, 0.25);
            report.heading(
                2,
                "Distinct good parameter sets (at least 0.25 apart in the unit box)",
            );
            let mut header = vec!["run".to_string(), "loss".to_string()];
            header.extend(parameters.iter().map(|p| p.name.clone()));
            let header: Vec<&str> = header.iter().map(String::as_str).collect();
            let mut table = Table::new(&header);
            for c in &candidates {
                let mut cells = vec![c.evaluation_id.to_string(), format!("{:.4}", c.loss)];
                cells.extend(c.parameters.iter().map(|v| format!("{v:.5}")));
                table.row(cells);
            }
            report.table(table);
        }
        Found::LeastSquares(_) => {}
    }
    report.figure(Figure {
        file: "loss.svg".into(),
        caption: "loss per model evaluation".into(),
        svg: chart_svg(&loss_chart(study, all_evaluations), 720.0, 420.0),
    });
    write_runs_section(&mut report, note_columns, all_evaluations);
    write_report(directory, &report, "Calibration study")?;
    println!(
        "loss {:.4} after {evaluations} model evaluations ({failed} failed); report in {}",
        study.loss(calibrated_outputs),
        directory.file("report.md").display()
    );
    Ok(())
}

/// Where each evaluation ran (the model's notes: a cluster's job ids,
/// queue waits and run times), when the model notes anything.
fn write_runs_section(report: &mut Document, columns: &[String], evaluations: &[Evaluation]) {
    if columns.is_empty()
        || evaluations
            .iter()
            .all(|e| e.notes.iter().all(String::is_empty))
    {
        return;
    }
    report.heading(2, "Where the runs ran");
    // Per-job seconds, over every job of every evaluation.
    let seconds = |column: &str| -> Vec<f64> {
        let Some(index) = columns.iter().position(|c| c == column) else {
            return Vec::new();
        };
        evaluations
            .iter()
            .filter_map(|e| e.notes.get(index))
            .flat_map(|note| note.split_whitespace().filter_map(|v| v.parse().ok()))
            .collect()
    };
    let (waits, runs) = (seconds("queue_wait_s"), seconds("run_s"));
    if !waits.is_empty() && !runs.is_empty() {
        let median = |values: &[f64]| {
            let mut sorted = values.to_vec();
            sorted.sort_by(f64::total_cmp);
            sorted[sorted.len() / 2]
        };
        let largest = |values: &[f64]| values.iter().copied().fold(0.0f64, f64::max);
        report.paragraph(format!(
            "{} jobs: queue wait median {:.2} s (largest {:.2} s), run time median {:.2} s (largest {:.2} s). Evaluations answered from the log of an earlier run show the notes logged then.",
            runs.len(),
            median(&waits),
            largest(&waits),
            median(&runs),
            largest(&runs)
        ));
    }
    let mut header = vec!["evaluation".to_string(), "status".to_string()];
    header.extend(columns.iter().cloned());
    let header: Vec<&str> = header.iter().map(String::as_str).collect();
    let mut table = Table::new(&header);
    for evaluation in evaluations {
        let mut cells = vec![
            evaluation.id.to_string(),
            if evaluation.outcome.is_ok() {
                "ok"
            } else {
                "failed"
            }
            .to_string(),
        ];
        cells.extend(evaluation.notes.iter().cloned());
        table.row(cells);
    }
    report.table(table);
}

/// What a method found.
pub enum Found {
    Bo(acq_calib::bo::BoResult),
    Moo(Box<super::surrogate_moo::SurrogateMoo>),
    LeastSquares(Box<LeastSquaresFound>),
}

impl Found {
    fn gps(&self) -> Option<&[acq_calib::gp::Gp]> {
        match self {
            Found::Moo(moo) => Some(&moo.gps),
            Found::Bo(_) | Found::LeastSquares(_) => None,
        }
    }
}

/// What a least-squares search found, and where it started.
pub struct LeastSquaresFound {
    pub result: LeastSquaresResult,
    /// The fit outputs at the nominal point (the search's start).
    pub nominal_outputs: Vec<f64>,
}

/// Levenberg-Marquardt from the nominal point through the logging
/// evaluator: each Jacobian's shifted points go as one batch (in parallel
/// on a solver with several slots), every run is logged, and a resumed
/// search replays the same points from the log.
fn least_squares_logged(
    evaluator: &mut acq_calib::evaluation::Evaluator<'_>,
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
            let values: Vec<Vec<f64>> = points
                .iter()
                .map(|u| acq_calib_from_unit(parameters, u))
                .collect();
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

/// The fit simulator's output names.
fn simulator_outputs(study: &Study) -> Vec<String> {
    study
        .observations(Role::Fit)
        .into_iter()
        .map(|(case, o)| study.key(case, o))
        .collect()
}

/// Runs the validation cases at the calibrated point (logged in
/// `validation.csv`); their errors, or none without validation cases.
fn validate(
    study: &Study,
    model: &dyn Model,
    calibrated: &[f64],
    directory: &RunDirectory,
    settings: &RunSettings<'_>,
) -> Result<Vec<ObservationError>> {
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
    let outputs = run[0].outcome.clone().map_err(|reason| {
        AcqError::Config(format!(
            "the model fails on the validation cases at the calibrated parameters: {reason}"
        ))
    })?;
    Ok(study.errors(Role::Validate, &outputs))
}

/// A relative error, or "-" where there is none (a measured 0).
fn percent(error_pct: f64) -> String {
    if error_pct.is_finite() {
        format!("{error_pct:.3}")
    } else {
        "-".into()
    }
}

fn errors_table(errors: &[ObservationError], nominal: Option<&[ObservationError]>) -> Table {
    let mut header = vec![
        "case",
        "observation",
        "measured",
        "calibrated model",
        "error [%]",
    ];
    if nominal.is_some() {
        header.insert(3, "error at nominal [%]");
    }
    header.push("residual / u");
    let mut table = Table::new(&header);
    for (i, e) in errors.iter().enumerate() {
        let mut cells = vec![
            e.case.clone(),
            e.name.clone(),
            e.measured
                .map_or_else(|| "curve".into(), |m| format!("{m}")),
            if e.measured.is_some() {
                format!("{:.6}", e.model)
            } else {
                format!("MAPE {:.3} %", e.model)
            },
            percent(e.error_pct),
        ];
        if let Some(nominal) = nominal {
            cells.insert(3, percent(nominal[i].error_pct));
        }
        cells.push(
            e.normalised
                .map_or_else(String::new, |z| format!("{z:+.2}")),
        );
        table.row(cells);
    }
    table
}

/// Chi-square in words: is the misfit what the uncertainties allow?
fn chi_square_sentence(what: &str, errors: &[ObservationError], fitted: usize) -> Option<String> {
    let (chi2, n) = chi_square(errors)?;
    let dof = n.saturating_sub(fitted).max(1) as f64;
    // Beyond about 3 standard deviations (2 dof) of the chi-square
    // distribution the misfit is more than the instruments explain.
    let limit = dof + 3.0 * (2.0 * dof).sqrt();
    Some(if chi2 <= limit {
        format!(
            "On the {what} cases, chi-square = {chi2:.2} for {n} observations with uncertainties ({dof:.0} degrees of freedom): the calibrated model agrees with the measurement within what the instruments can tell."
        )
    } else {
        format!(
            "On the {what} cases, chi-square = {chi2:.2} for {n} observations with uncertainties ({dof:.0} degrees of freedom, expected at most about {limit:.1}): the misfit is larger than the stated uncertainties explain. Either the model misses an effect or the uncertainties are too small."
        )
    })
}

fn loss_chart(study: &Study, evaluations: &[Evaluation]) -> Chart {
    let mut best_so_far = f64::INFINITY;
    let mut running = Vec::new();
    let mut each = Vec::new();
    for e in evaluations {
        if let Ok(y) = &e.outcome {
            let loss = study.loss(y);
            best_so_far = best_so_far.min(loss);
            each.push((e.id as f64, loss));
        }
        running.push((e.id as f64, best_so_far));
    }
    let unit = if study.residuals == Residuals::Normalised {
        "loss [standard uncertainties]"
    } else {
        "loss [%]"
    };
    Chart::new("Loss per model evaluation", "evaluation", unit)
        .with_series(Series::new("run", each).with_style(SeriesStyle::Markers))
        .with_series(Series::new("best so far", running))
}
