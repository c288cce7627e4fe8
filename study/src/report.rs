//! The report of a study, written here for every study: what the search
//! did, the errors of every case, each observed curve against the
//! calibrated model's, the parameters and what the data pin down, what the
//! method shows of itself (surrogates, Pareto front, Sobol indices, the
//! distinct good parameter sets), the loss per run and where the runs ran.
//! A preset or model adds its own sections through [`Extras::sections`].
//!
//! Also the plumbing every report shares: a report as Markdown, HTML and
//! its SVG files ([`write_report`]), and the Pareto-front plot.

use acq_algorithms::evaluation::Evaluation;
use acq_algorithms::least_squares::Stop as LsStop;
use acq_algorithms::sobol_indices::sobol_indices;
use acq_analysis::loss::curve::{curve_errors_along, CurveMapeOptions};
use acq_analysis::loss::metrics::{matched, points_of, CurveMetric};
use acq_error::Result;
use acq_report::document::{Document, Figure, Table};
use acq_report::plot::{chart_svg, grid_svg, Chart, Series, SeriesStyle};

use super::extras::{Extras, Section};
use super::identifiability::{write_identifiability, Identifiability};
use super::method::{Method, RunSettings};
use super::outcome::{CalibratedCurve, Found, StudyOutcome};
use super::run_directory::{write_text, RunDirectory};
use super::search::{distinct_best, scored};
use super::study::{chi_square, LossKind, ObservationError, Residuals, Role, Study};
use super::surrogate_moo::rounds_sentence;
use super::verdict::{verdict_of, Evidence, ParameterVerdict};

/// Writes a report into its run directory: every figure as its SVG file,
/// `report.md` (figures linked) and `report.html` (one page, figures inline).
pub fn write_report(directory: &RunDirectory, report: &Document, title: &str) -> Result<()> {
    for figure in report.figures() {
        write_text(&directory.file(&figure.file), &figure.svg)?;
    }
    write_text(&directory.file("report.md"), &report.to_markdown())?;
    write_text(&directory.file("report.html"), &report.to_html(title))
}

/// The report of a finished study, with the extras' title and sections.
pub fn study_report(
    study: &Study,
    method: &Method,
    outcome: &StudyOutcome,
    settings: &RunSettings<'_>,
    extras: &dyn Extras,
) -> Result<Document> {
    let parameters = study.search_parameters();
    let mut report = Document::new();
    report.heading(1, extras.title(settings).0);
    report.paragraph(method_sentence(study, outcome));
    extras.sections(study, outcome, &mut report)?;
    let nominal_errors = match &outcome.found {
        Found::Moo(moo) => Some(study.errors(Role::Fit, &moo.nominal_outputs)),
        Found::LeastSquares(ls) => Some(study.errors(Role::Fit, &ls.nominal_outputs)),
        Found::Bo(_) | Found::MultiFidelity(_) => None,
    };
    report.heading(2, "Fit cases");
    report.table(errors_table(&outcome.fit_errors, nominal_errors.as_deref()));
    write_validation(&mut report, outcome);
    if let Some(sentence) = chi_square_sentence("fit", &outcome.fit_errors, parameters.len()) {
        report.paragraph(sentence);
    }
    if let Some(sentence) = chi_square_sentence("validation", &outcome.validation_errors, 0) {
        report.paragraph(sentence);
    }
    write_curves(&mut report, &outcome.curves);
    super::measurement_report::write_measurement_uncertainty(&mut report, study);
    write_parameters(&mut report, study, &outcome.calibrated, extras);
    // One verdict per parameter, read by every table below.
    let verdicts = outcome.verdicts(study);
    write_identifiability(
        &mut report,
        &outcome.identifiability,
        &parameters,
        &verdicts,
    );
    if let Some(posterior) = &outcome.posterior {
        super::posterior::report::write_section(&mut report, posterior, &verdicts);
    }
    match (&outcome.found, method) {
        (Found::Moo(moo), Method::SurrogateMoo(settings)) => {
            let totals = write_surrogates(&mut report, study, moo, settings, extras);
            if let Some(analysis) = &outcome.identifiability {
                write_one_verdict(&mut report, analysis, &parameters, &totals, &verdicts);
            }
        }
        (Found::Bo(result), _) => write_candidates(
            &mut report,
            study,
            outcome,
            result.evaluations_to_target,
            extras,
        ),
        (Found::MultiFidelity(mf), _) => write_candidates(
            &mut report,
            study,
            outcome,
            mf.result.evaluations_to_target,
            extras,
        ),
        _ => {}
    }
    let target = match method {
        Method::Bo(bo) => bo.target_loss,
        Method::MultiFidelity(mf) => mf.target_loss,
        _ => None,
    };
    let (chart, caption) = match &outcome.found {
        Found::MultiFidelity(mf) => (
            two_level_loss_chart(
                study,
                &outcome.evaluations,
                &outcome.coarse_evaluations,
                mf.meshes,
                target,
            ),
            "loss of each run of both levels against the simulation time spent".into(),
        ),
        _ => (
            loss_chart(study, &outcome.evaluations, target),
            "loss per model evaluation".into(),
        ),
    };
    report.figure(Figure {
        file: "loss.svg".into(),
        caption,
        svg: chart_svg(&chart, 720.0, 420.0),
    });
    write_runs_section(&mut report, &outcome.note_columns, &outcome.evaluations);
    Ok(report)
}

/// What the search did, in one sentence.
fn method_sentence(study: &Study, outcome: &StudyOutcome) -> String {
    let evaluations = outcome.evaluations.len();
    let (failed, wall_s) = (outcome.failed, outcome.wall_s);
    match &outcome.found {
        Found::Bo(result) => format!(
            "Bayesian optimisation of the {} error: best loss {:.4} after {} ({failed} failed), {wall_s:.1} s; it stopped when {}.",
            if study.loss == LossKind::Max { "largest" } else { "weighted mean" },
            study.loss(&outcome.calibrated_outputs),
            acq_report::number::count(evaluations, "model evaluation"),
            result.stop.words()
        ),
        Found::MultiFidelity(mf) => {
            use acq_algorithms::multi_fidelity::Fidelity;
            let result = &mf.result;
            format!(
                "Two-level search of the {} error (local steps: the cheap level mapped onto the expensive one and descended, each end checked by an expensive run; when they cannot go on, co-kriging over both levels, each next run and its level chosen by expected improvement per second): best loss {:.4} at mesh {} after {} runs at mesh {} ({:.2} s a run) and {} at mesh {} ({:.2} s a run), {failed} of the expensive ones failed, {wall_s:.1} s; {}; {}; it stopped when {}.",
                if study.loss == LossKind::Max { "largest" } else { "weighted mean" },
                study.loss(&outcome.calibrated_outputs),
                mf.meshes[1],
                result.count(Fidelity::Expensive),
                mf.meshes[1],
                result.cost_s[1],
                result.count(Fidelity::Cheap),
                mf.meshes[0],
                result.cost_s[0],
                result.rho.map_or_else(
                    || "no co-kriging step was needed".to_string(),
                    |r| format!("co-kriging's rho {r:.3}")
                ),
                result.level_loss_difference().map_or_else(
                    || "no point was run at both levels".to_string(),
                    |d| format!(
                        "at the {} points both levels ran, their losses differed by a median of {:.3}",
                        d.points, d.median
                    )
                ),
                result.stop.words()
            )
        }
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
    }
}

fn write_validation(report: &mut Document, outcome: &StudyOutcome) {
    let (fit_errors, validation_errors) = (&outcome.fit_errors, &outcome.validation_errors);
    if validation_errors.is_empty() {
        return;
    }
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

/// Each observed curve: measured and calibrated model overlaid, and the
/// signed error along it (on the grid the curve MAPE is computed on).
fn write_curves(report: &mut Document, curves: &[CalibratedCurve]) {
    if curves.is_empty() {
        return;
    }
    report.heading(2, "Curves: measured and calibrated");
    let single = curves.len() == 1;
    for curve in curves {
        let label = format!("{} ({})", curve.name, curve.case);
        let Some(model) = &curve.model else {
            report.paragraph(format!(
                "{label}: the calibrated run's curve is no longer in its run directory, so it cannot be drawn."
            ));
            continue;
        };
        let [x, y] = &curve.axes;
        let overlay = Chart::new("measured and calibrated", x, y)
            .with_series(
                Series::new("measured", curve.measured.clone()).with_style(SeriesStyle::Markers),
            )
            .with_series(Series::new("calibrated model", model.clone()));
        let mut charts = vec![overlay];
        if curve.metric != CurveMetric::Mape {
            match matched(curve.metric, &points_of(&curve.measured), &points_of(model)) {
                Ok(result) => {
                    let along: Vec<(f64, f64)> = result
                        .pairs
                        .iter()
                        .map(|p| (100.0 * p.along, 100.0 * p.signed_distance))
                        .collect();
                    let largest = along.iter().map(|p| p.1.abs()).fold(0.0f64, f64::max);
                    report.paragraph(format!(
                        "{label}: {} {:.4} (both curves divided by the measured one's range); the largest gap between coupled points is {largest:.2} % of that range.",
                        curve.metric.as_str().to_uppercase(),
                        result.value
                    ));
                    charts.push(
                        Chart::new(
                            "gap along the measured curve",
                            "along the measured curve [% of its length]",
                            "model - measured [% of range]",
                        )
                        .with_series(Series::new("signed gap", along))
                        .with_reference_line(0.0, "0"),
                    );
                }
                Err(error) => {
                    report.paragraph(format!("{label}: {error}."));
                }
            }
        } else {
            match curve_errors_along(&curve.measured, model, CurveMapeOptions::default()) {
                Ok((mape, errors)) => {
                    let largest = errors.iter().map(|e| e.1.abs()).fold(0.0f64, f64::max);
                    report.paragraph(format!(
                    "{label}: MAPE {:.3} % over {} grid points from {x} = {} to {}; largest error {largest:.3} %{}.",
                    mape.mape_percent,
                    mape.grid_points - mape.excluded_points,
                    short(mape.grid_start_mm),
                    short(mape.grid_end_mm),
                    if mape.padded_points > 0 {
                        format!(
                            "; the model's curve ends before the measured one, and its {} points past the end count as zero",
                            mape.padded_points
                        )
                    } else {
                        String::new()
                    }
                ));
                    charts.push(
                        Chart::new("error along the curve", x, "model - measured [%]")
                            .with_series(Series::new("error", errors))
                            .with_reference_line(0.0, "0"),
                    );
                }
                Err(error) => {
                    report.paragraph(format!("{label}: no error along it: {error}."));
                }
            }
        }
        let file = if single {
            "curve.svg".to_string()
        } else {
            format!(
                "curve-{}-{}.svg",
                file_safe(&curve.case),
                file_safe(&curve.name)
            )
        };
        report.figure(Figure {
            file,
            caption: format!("{label}: measured vs calibrated, and the error along it"),
            svg: grid_svg(&label, &charts, 1, 720.0, 360.0),
        });
    }
}

/// A name as part of a file name: letters, digits, `-` and `_`.
fn file_safe(name: &str) -> String {
    name.chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' {
                c
            } else {
                '_'
            }
        })
        .collect()
}

fn write_parameters(report: &mut Document, study: &Study, calibrated: &[f64], extras: &dyn Extras) {
    report.heading(2, extras.heading(Section::Parameters, "Parameters".into()));
    let mut table = Table::new(&[
        "parameter",
        "lower",
        "upper",
        "scale",
        "nominal",
        "calibrated",
        "position in range",
        "note",
    ]);
    for (p, v) in study.parameters.iter().zip(calibrated) {
        let search = &p.search;
        let unit = search.to_unit(*v);
        table.row(vec![
            search.name.clone(),
            short(search.lower),
            short(search.upper),
            format!("{:?}", search.scale).to_lowercase(),
            short(p.nominal),
            short(*v),
            format!("{:.0} %", 100.0 * unit),
            match search.bound_reached(*v) {
                Some(_) => "on a bound: the optimum may lie outside the range".into(),
                None => String::new(),
            },
        ]);
    }
    report.table(table);
}

/// The surrogate-MOO method's own sections: how good the surrogates are,
/// the Pareto front and its pick, and the Sobol indices on the GPs.
fn write_surrogates(
    report: &mut Document,
    study: &Study,
    moo: &super::surrogate_moo::SurrogateMoo,
    settings: &super::surrogate_moo::SurrogateMooSettings,
    extras: &dyn Extras,
) -> Vec<Option<(f64, String)>> {
    let keys = study.output_keys(Role::Fit);
    let parameters = study.search_parameters();
    report.heading(
        2,
        extras.heading(
            Section::Surrogates,
            format!("Surrogates: RMSE on the {} test runs", moo.test_runs),
        ),
    );
    let mut header = vec!["surrogate"];
    header.extend(keys.iter().map(String::as_str));
    let mut table = Table::new(&header);
    for (name, row) in &moo.surrogate_rmse {
        let mut cells = vec![name.clone()];
        cells.extend(row.iter().map(|v| acq_report::number::plain(*v, 4)));
        table.row(cells);
    }
    report.table(table).paragraph(format!(
        "GP: {:?} kernel, one length scale per input, constant mean, noise fitted, {} training runs. {}",
        settings.kernel,
        moo.rounds.last().map_or(0, |r| r.training_runs),
        rounds_sentence(&moo.rounds),
    ));
    report.heading(2, "Pareto front").paragraph(format!(
        "{} points (population {}, {} generations, Pareto fraction {}); {}.",
        moo.front.len(),
        settings.population,
        settings.generations,
        settings.pareto_fraction,
        moo.pick_sentence(),
    ));
    let names: Vec<String> = keys
        .iter()
        .zip(study.objective_units())
        .map(|(k, unit)| format!("{k} error [{unit}]"))
        .collect();
    let names: Vec<&str> = names.iter().map(String::as_str).collect();
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
    // Variance-based sensitivity of each observation, on its GP (cheap:
    // 1024 (d + 2) GP predictions per output instead of model runs).
    report.heading(
        2,
        "Sensitivity: Sobol indices from the GPs (first order / total, 1024 base samples)",
    );
    let mut header = vec!["observation"];
    header.extend(parameters.iter().map(|p| p.name.as_str()));
    let mut table = Table::new(&header);
    // Per parameter: its largest total index and the observation it is of.
    let mut totals: Vec<Option<(f64, String)>> = vec![None; parameters.len()];
    for (key, gp) in keys.iter().zip(&moo.gps) {
        let indices = sobol_indices(
            |u| gp.predict(u).mean,
            parameters.len(),
            1024,
            settings.seed,
        );
        let mut cells = vec![key.clone()];
        if let Ok(indices) = &indices {
            for (largest, total) in totals.iter_mut().zip(&indices.total) {
                if total.is_finite() && largest.as_ref().is_none_or(|(t, _)| total > t) {
                    *largest = Some((*total, key.clone()));
                }
            }
        }
        match indices {
            Ok(indices) => cells.extend(
                indices
                    .first_order
                    .iter()
                    .zip(&indices.total)
                    .map(|(first, total)| format!("{first:.3} / {total:.3}")),
            ),
            Err(error) => cells.push(error.to_string()),
        }
        table.row(cells);
    }
    report.table(table);
    totals
}

/// A total Sobol index at or above this share of an observation's variance
/// is a parameter that matters over its range.
const MATTERS: f64 = 0.05;

/// One verdict per input, where the two sensitivities could seem to
/// disagree: the global one (Sobol on the GPs, over the whole range: does
/// the input move the outputs?) and the local one (at the calibrated
/// point: can the measured values fix it?). The verdict is the
/// parameter's one verdict ([`crate::verdict`]); the Sobol index says why.
fn write_one_verdict(
    report: &mut Document,
    analysis: &Identifiability,
    parameters: &[acq_algorithms::evaluation::Parameter],
    totals: &[Option<(f64, String)>],
    verdicts: &[ParameterVerdict],
) {
    use crate::identifiability::{local_verdict, strongest_partner};
    report.heading(3, "One verdict per input");
    report.paragraph(
        "The Sobol index asks whether an input moves the outputs over its whole range; the identifiability asks whether the measured values fix it at the calibrated point. The verdict is the one every table of this report gives (the posterior's where there is one, a bound's where the value reaches one, else the calibrated point's); the Sobol index says why.",
    );
    let mut table = Table::new(&[
        "parameter",
        "largest total Sobol index",
        "at the calibrated point",
        "verdict",
    ]);
    for (j, p) in parameters.iter().enumerate() {
        let local = local_verdict(analysis, j);
        let (total, of) = totals[j].clone().unwrap_or((f64::NAN, String::new()));
        let matters = total >= MATTERS;
        let partner = strongest_partner(analysis, j)
            .map(|(k, rho)| format!("{} (ρ = {rho:+.2})", parameters[k].name));
        let one = verdict_of(verdicts, &p.name);
        let verdict = match (one.map(|v| v.evidence), local, matters) {
            (Some(Evidence::CalibratedPoint) | None, "identified", true) => "identified: it moves the outputs and the data fix it".to_string(),
            (Some(Evidence::CalibratedPoint) | None, "identified", false) => "identified near the calibrated point, though over its whole range it moves the outputs little".to_string(),
            (Some(Evidence::CalibratedPoint) | None, "weakly identified", _) => "weakly identified: the data bound it to 10-50 % of its range".to_string(),
            (Some(Evidence::CalibratedPoint) | None, _, true) => format!(
                "not identified on its own: it moves the outputs, but the data fix only its combination with {}; the value found is one of many equally good",
                partner.unwrap_or_else(|| "the other inputs".into())
            ),
            (Some(Evidence::CalibratedPoint) | None, _, false) => "not identified: over its range it moves the outputs little next to the other inputs, and the data cannot fix it; fix it from elsewhere".to_string(),
            // The posterior's or a bound's verdict, with the Sobol index's why.
            (Some(_), _, matters) => format!(
                "{}; {}",
                one.map_or("", |v| v.words.as_str()),
                if matters { "it moves the outputs over its range" } else { "over its range it moves the outputs little" }
            ),
        };
        table.row(vec![
            p.name.clone(),
            if total.is_finite() {
                format!("{} ({of})", acq_report::number::plain(total, 2))
            } else {
                "-".into()
            },
            local.to_string(),
            verdict,
        ]);
    }
    report.table(table);
}

/// Bayesian optimisation's own section: not one answer, but the best
/// parameter sets nearly as good as the best that are far apart, and how
/// far they spread.
fn write_candidates(
    report: &mut Document,
    study: &Study,
    outcome: &StudyOutcome,
    evaluations_to_target: Option<usize>,
    extras: &dyn Extras,
) {
    let parameters = study.search_parameters();
    let scored = scored(&outcome.evaluations, |y| study.loss(y));
    let best = scored.iter().map(|s| s.1).fold(f64::INFINITY, f64::min);
    let near: Vec<(&Evaluation, f64)> = scored
        .iter()
        .copied()
        .filter(|(_, loss)| *loss <= 1.25 * best + 0.25)
        .collect();
    let candidates = distinct_best(&parameters, &near, 5, 0.25);
    report
        .heading(
            2,
            extras.heading(
                Section::Candidates,
                "Distinct good parameter sets (at least 0.25 apart in the unit box)".into(),
            ),
        )
        .paragraph(format!(
            "{} runs lie within 1.25 x best + 0.25 of the best loss; the best {} of them that are at least 0.25 apart in the unit box:",
            near.len(),
            candidates.len()
        ));
    let mut header = vec!["run".to_string(), "loss".to_string()];
    header.extend(parameters.iter().map(|p| p.name.clone()));
    let header: Vec<&str> = header.iter().map(String::as_str).collect();
    let mut table = Table::new(&header);
    for c in &candidates {
        let mut cells = vec![c.evaluation_id.to_string(), short(c.loss)];
        cells.extend(c.parameters.iter().map(|v| short(*v)));
        table.row(cells);
    }
    report.table(table);
    if candidates.len() < 2 {
        if evaluations_to_target.is_some() {
            report.paragraph(
                "The run stopped as soon as it reached the target, before it could map the region \
                 of good fits. For that picture, run on with a lower target (0 runs the whole \
                 budget) and `--resume` into the same directory: nothing is repeated.",
            );
        }
        return;
    }
    let mut spread = Table::new(&[
        "parameter",
        "min among them",
        "max among them",
        "spread / range",
    ]);
    for (k, p) in parameters.iter().enumerate() {
        let (low, high) = candidates
            .iter()
            .map(|c| c.parameters[k])
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), v| {
                (l.min(v), h.max(v))
            });
        spread.row(vec![
            p.name.clone(),
            short(low),
            short(high),
            format!("{:.0} %", 100.0 * (p.to_unit(high) - p.to_unit(low)).abs()),
        ]);
    }
    report.table(spread);
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
        let status = if evaluation.outcome.is_ok() {
            "ok"
        } else {
            "failed"
        };
        let mut cells = vec![evaluation.id.to_string(), status.to_string()];
        cells.extend(evaluation.notes.iter().cloned());
        table.row(cells);
    }
    report.table(table);
}

/// A number to 6 significant digits, without trailing zeros: the
/// bounds and nominals as a reader would write them.
fn short(value: f64) -> String {
    acq_report::number::plain(value, 6)
}

/// A relative error, or "-" where there is none (a measured 0, a curve
/// scored by a coupling metric).
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
            e.measured.map_or_else(|| "curve".into(), short),
            match e.curve_metric {
                None => short(e.model),
                Some(CurveMetric::Mape) => format!("MAPE {:.3} %", e.model),
                Some(metric) => format!("{} {:.4}", metric.as_str().to_uppercase(), e.model),
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
    let observations = acq_report::number::count(n, "observation");
    let freedom = match dof as usize {
        1 => "1 degree of freedom".to_string(),
        dof => format!("{dof} degrees of freedom"),
    };
    Some(if chi2 <= limit {
        format!(
            "On the {what} cases, chi-square = {chi2:.2} for {observations} with uncertainties ({freedom}): the calibrated model agrees with the measurement within what the instruments can tell."
        )
    } else {
        format!(
            "On the {what} cases, chi-square = {chi2:.2} for {observations} with uncertainties ({freedom}, expected at most about {limit:.1}): the misfit is larger than the stated uncertainties explain. Either the model misses an effect or the uncertainties are too small."
        )
    })
}

/// Each run's loss and the best so far; the search's target, if it has one.
fn loss_chart(study: &Study, evaluations: &[Evaluation], target: Option<f64>) -> Chart {
    let mut best_so_far = f64::INFINITY;
    let mut running = Vec::new();
    let mut each = Vec::new();
    // In the order the runs were asked for: a parallel batch logs them as
    // they finish, and the line would double back.
    let mut evaluations: Vec<&Evaluation> = evaluations.iter().collect();
    evaluations.sort_by_key(|e| e.id);
    for e in evaluations {
        if let Ok(y) = &e.outcome {
            let loss = study.loss(y);
            best_so_far = best_so_far.min(loss);
            each.push((e.id as f64, loss));
        }
        running.push((e.id as f64, best_so_far));
    }
    let chart = Chart::new("Loss per model evaluation", "evaluation", loss_unit(study))
        .with_series(Series::new("run", each).with_style(SeriesStyle::Markers))
        .with_series(Series::new("best so far", running));
    with_target(chart, target)
}

/// A two-level search's runs against the simulation time spent so far
/// (both levels' run times summed in the log's order), each level's own
/// markers and the best expensive run so far: what each level cost and
/// what it bought, which a plot per evaluation hides (a cheap run and an
/// expensive one take the same width there).
fn two_level_loss_chart(
    study: &Study,
    expensive: &[Evaluation],
    cheap: &[Evaluation],
    [cheap_mesh, expensive_mesh]: [f64; 2],
    target: Option<f64>,
) -> Chart {
    let mut runs: Vec<(usize, LevelRunCost)> = expensive
        .iter()
        .map(|e| (e, true))
        .chain(cheap.iter().map(|e| (e, false)))
        .map(|(e, is_expensive)| {
            let loss = e.outcome.as_ref().ok().map(|y| study.loss(y));
            (e.id, (e.wall_s, loss, is_expensive))
        })
        .collect();
    runs.sort_by_key(|(id, _)| *id);
    let runs: Vec<LevelRunCost> = runs.into_iter().map(|(_, run)| run).collect();
    let [cheap_points, expensive_points, running] = two_level_series(&runs);
    let chart = Chart::new(
        "Loss per run, both levels",
        "simulation time so far [s]",
        loss_unit(study),
    )
    .with_series(
        Series::new(format!("run at mesh {}", short(cheap_mesh)), cheap_points)
            .with_style(SeriesStyle::Markers),
    )
    .with_series(
        Series::new(
            format!("run at mesh {}", short(expensive_mesh)),
            expensive_points,
        )
        .with_style(SeriesStyle::Markers),
    )
    .with_series(Series::new(
        format!("best at mesh {} so far", short(expensive_mesh)),
        running,
    ));
    with_target(chart, target)
}

/// A run as the two-level plot sees it: wall time (s), loss (`None`:
/// failed), whether it ran at the expensive level.
type LevelRunCost = (f64, Option<f64>, bool);

/// The cheap runs, the expensive runs and the best expensive loss so far
/// (a step line), each against the simulation time spent once the run
/// ended, for runs in the log's order.
fn two_level_series(runs: &[LevelRunCost]) -> [Vec<(f64, f64)>; 3] {
    let mut spent_s = 0.0;
    let mut best_so_far = f64::INFINITY;
    let [mut cheap, mut expensive, mut running] = [Vec::new(), Vec::new(), Vec::new()];
    for &(wall_s, loss, is_expensive) in runs {
        if wall_s.is_finite() {
            spent_s += wall_s;
        }
        match (loss, is_expensive) {
            (Some(loss), true) => {
                if loss < best_so_far && best_so_far.is_finite() {
                    // A step, not a slope: the best holds until a run beats it.
                    running.push((spent_s, best_so_far));
                }
                best_so_far = best_so_far.min(loss);
                expensive.push((spent_s, loss));
            }
            (Some(loss), false) => cheap.push((spent_s, loss)),
            (None, _) => {}
        }
        if best_so_far.is_finite() {
            running.push((spent_s, best_so_far));
        }
    }
    running.dedup();
    [cheap, expensive, running]
}

/// The loss axis's label.
fn loss_unit(study: &Study) -> &'static str {
    match (study.residuals, study.loss) {
        (Residuals::Normalised, _) => "loss [standard uncertainties]",
        (Residuals::Relative, LossKind::Max) => "largest error [%]",
        (Residuals::Relative, _) => "loss [%]",
    }
}

/// The search's target as a line, when it has one above zero.
fn with_target(chart: Chart, target: Option<f64>) -> Chart {
    match target {
        Some(target) if target > 0.0 => {
            chart.with_reference_line(target, format!("target {target}"))
        }
        _ => chart,
    }
}

/// The Pareto front as scatter plots of each pair of objectives, the pick
/// marked. One chart for two objectives, three for three.
pub fn pareto_svg(title: &str, names: &[&str], front: &[Vec<f64>], pick: usize) -> String {
    let objectives = names.len();
    let pairs: Vec<(usize, usize)> = (0..objectives)
        .flat_map(|a| (a + 1..objectives).map(move |b| (a, b)))
        .collect();
    let charts: Vec<Chart> = pairs
        .iter()
        .map(|&(a, b)| {
            let points = front.iter().map(|f| (f[a], f[b])).collect();
            let chosen = front
                .get(pick)
                .map(|f| vec![(f[a], f[b])])
                .unwrap_or_default();
            Chart::new(format!("{} vs {}", names[b], names[a]), names[a], names[b])
                .with_series(Series::new("Pareto front", points).with_style(SeriesStyle::Markers))
                .with_series(Series::new("pick", chosen).with_style(SeriesStyle::Markers))
        })
        .collect();
    if charts.len() == 1 {
        chart_svg(&charts[0], 640.0, 440.0)
    } else {
        grid_svg(title, &charts, charts.len().min(3), 420.0, 340.0)
    }
}

#[cfg(test)]
mod tests {
    use super::{short, two_level_series};

    #[test]
    fn the_two_level_plot_adds_up_the_time_and_steps_the_best() {
        // cheap 0.5 s, expensive 4 s (failed), expensive 3 s at 2.0,
        // cheap 0.5 s, expensive 3 s at 1.0, expensive 3 s at 1.5.
        let runs = [
            (0.5, Some(9.0), false),
            (4.0, None, true),
            (3.0, Some(2.0), true),
            (0.5, Some(0.5), false),
            (3.0, Some(1.0), true),
            (3.0, Some(1.5), true),
        ];
        let [cheap, expensive, best] = two_level_series(&runs);
        assert_eq!(cheap, [(0.5, 9.0), (8.0, 0.5)]);
        assert_eq!(expensive, [(7.5, 2.0), (11.0, 1.0), (14.0, 1.5)]);
        // A cheap run's low loss is not the answer; the best falls only
        // at the expensive run that beats it, straight down.
        assert_eq!(
            best,
            [
                (7.5, 2.0),
                (8.0, 2.0),
                (11.0, 2.0),
                (11.0, 1.0),
                (14.0, 1.0)
            ]
        );
    }

    #[test]
    fn short_numbers_keep_six_significant_digits() {
        assert_eq!(short(0.15000000000000002), "0.15");
        assert_eq!(short(2.6070192019999974), "2.60702");
        assert_eq!(short(121.5), "121.5");
        assert_eq!(short(-0.43), "-0.43");
        assert_eq!(short(210000.0), "210000");
        assert_eq!(short(0.0), "0");
        assert_eq!(short(f64::NAN), "NaN");
    }
}
