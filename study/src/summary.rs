//! `summary.json`, the fixed interface of a run directory: written here and
//! nowhere else. Each method has its keys (below); named cases add
//! `cases`, observations with uncertainties `chi_square`; a preset's own
//! keys come through [`Extras::summary`], which may also keep only a
//! preset's published keys.
//!
//! - `bo`: `best_loss_pct`, `best_outputs`, `best_params`,
//!   `evaluations_to_target`;
//! - `surrogate-moo`: `errors_initial_pct`, `errors_optimal_pct`,
//!   `optimal`, `surrogate_rmse`;
//! - `least-squares`: `errors_initial_pct`, `errors_optimal_pct`,
//!   `optimal`, `loss`, `sum_of_squares`, `iterations`, `stop`;
//! - every method: `evaluations`, `failed`, `wall_s`; with curves,
//!   `curve_metrics`: `{curve: {metric: value}}`, every metric
//!   (`mape`, `pcm`, `frechet`, `dtw`, `area`) at the calibrated point
//!   (null where the curves do not allow one, or the model cannot give
//!   its curve again), the curve keyed as in `errors_optimal_pct`;
//! - with the posterior stage: `posterior`, `predictive` and, with a
//!   discrepancy, `discrepancy` ([`super::posterior::report::summary_keys`]);
//!   with them `verdicts`: each parameter's one verdict in words
//!   ([`crate::verdict`]), as the report gives it.
//!
//! A mesh study's ([`mesh_study_summary`]): `mesh_study` (per scalar
//! output `sizes`, `values`, `order`, `extrapolated`, `e_a_pct`,
//! `e_ext_pct`, `gci_fine_pct`, `u_num`, `convergence`, `note`), `at`,
//! `evaluations`, `failed`, `wall_s`.

use acq_analysis::loss::metrics::{every_metric, CurveMetric};
use serde_json::{json, Map, Value};

use super::extras::Extras;
use super::outcome::{Found, StudyOutcome};
use super::posterior::report::summary_keys as posterior_summary_keys;
use super::study::{cases_json, chi_square, errors_json, Role, Study};

/// The summary of a finished study.
pub fn summary(study: &Study, outcome: &StudyOutcome, extras: &dyn Extras) -> Value {
    let StudyOutcome {
        found,
        calibrated,
        calibrated_outputs,
        fit_errors,
        validation_errors,
        evaluations,
        failed,
        wall_s,
        ..
    } = outcome;
    let parameters = study.search_parameters();
    let named = |values: &[f64]| -> Value {
        Value::Object(
            parameters
                .iter()
                .zip(values)
                .map(|(p, v)| (p.name.clone(), json!(v)))
                .collect(),
        )
    };
    let mut summary = Map::new();
    match found {
        Found::Bo(_) | Found::MultiFidelity(_) => {
            summary.insert(
                "best_loss_pct".into(),
                json!(study.loss(calibrated_outputs)),
            );
            summary.insert(
                "best_outputs".into(),
                Value::Object(
                    study
                        .output_keys(Role::Fit)
                        .into_iter()
                        .zip(calibrated_outputs)
                        .map(|(k, v)| (k, json!(v)))
                        .collect(),
                ),
            );
            summary.insert("best_params".into(), named(calibrated));
            let (to_target, two_levels) = match found {
                Found::Bo(result) => (result.evaluations_to_target, None),
                Found::MultiFidelity(mf) => {
                    (mf.result.evaluations_to_target, Some(mf.summary_json()))
                }
                _ => (None, None),
            };
            summary.insert("evaluations_to_target".into(), json!(to_target));
            if let Some(two_levels) = two_levels {
                summary.insert("multi_fidelity".into(), two_levels);
            }
        }
        Found::Moo(moo) => {
            summary.insert(
                "errors_initial_pct".into(),
                errors_json(&study.errors(Role::Fit, &moo.nominal_outputs)),
            );
            summary.insert("errors_optimal_pct".into(), errors_json(fit_errors));
            summary.insert("optimal".into(), named(calibrated));
            let keys = study.output_keys(Role::Fit);
            let rmse: Map<String, Value> = moo
                .surrogate_rmse
                .iter()
                .map(|(surrogate, row)| {
                    let by_output = keys.iter().zip(row).map(|(k, v)| (k.clone(), json!(v)));
                    (surrogate.clone(), Value::Object(by_output.collect()))
                })
                .collect();
            summary.insert("surrogate_rmse".into(), Value::Object(rmse));
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
        }
    }
    summary.insert("failed".into(), json!(failed));
    summary.insert("wall_s".into(), json!(wall_s));
    summary.insert("evaluations".into(), json!(evaluations.len()));
    if study.named_cases {
        let mut all = fit_errors.clone();
        all.extend(validation_errors.iter().cloned());
        summary.insert("cases".into(), cases_json(&all));
    }
    for (key, errors) in [
        ("chi_square", fit_errors),
        ("validation_chi_square", validation_errors),
    ] {
        if let Some((chi2, n)) = chi_square(errors) {
            summary.insert(key.into(), json!({"value": chi2, "observations": n}));
        }
    }
    if !outcome.curves.is_empty() {
        summary.insert("curve_metrics".into(), curve_metrics_json(study, outcome));
    }
    // A preset with a published key set (`acq calibrate gtn`) keeps only
    // its own.
    let mut summary = extras.summary(study, outcome, summary);
    // The posterior's keys whatever the preset keeps: they are every
    // study's, and so are the verdicts that read the posterior.
    if let Some(posterior) = &outcome.posterior {
        summary.extend(posterior_summary_keys(posterior));
        summary.insert("verdicts".into(), verdicts_json(study, outcome));
    }
    Value::Object(summary)
}

/// Each parameter's one verdict, as the report gives it.
fn verdicts_json(study: &Study, outcome: &StudyOutcome) -> Value {
    Value::Object(
        outcome
            .verdicts(study)
            .into_iter()
            .map(|v| (v.name, json!(v.words)))
            .collect(),
    )
}

/// `{curve: {metric: value}}` at the calibrated point.
fn curve_metrics_json(study: &Study, outcome: &StudyOutcome) -> Value {
    let by_curve = outcome.curves.iter().map(|curve| {
        let key = if study.named_cases {
            format!("{}/{}", curve.case, curve.name)
        } else {
            curve.name.clone()
        };
        let values: Map<String, Value> = match &curve.model {
            Some(model) => every_metric(&curve.measured, model)
                .into_iter()
                .map(|(metric, value)| {
                    (metric.to_string(), value.map_or(Value::Null, |v| json!(v)))
                })
                .collect(),
            None => CurveMetric::ALL
                .iter()
                .map(|metric| (metric.to_string(), Value::Null))
                .collect(),
        };
        (key, Value::Object(values))
    });
    Value::Object(by_curve.collect())
}

/// The summary of a mesh study; sizes and values in `spec_sizes`' order.
pub fn mesh_study_summary(
    outcome: &super::outcome::MeshStudyOutcome,
    spec_sizes: &[f64],
    wall_s: f64,
) -> Value {
    let studies: Map<String, Value> = outcome
        .outputs
        .iter()
        .map(|o| (o.key.clone(), output_json(o, spec_sizes)))
        .collect();
    let mut summary = json!({
        "mesh_study": studies,
        "at": outcome.at.iter().map(|(n, v)| (n.clone(), json!(v))).collect::<Map<_, _>>(),
        "evaluations": outcome.evaluations,
        "failed": outcome.failed,
        "wall_s": wall_s,
    });
    if !outcome.curves.is_empty() {
        let curves: Map<String, Value> = outcome
            .curves
            .iter()
            .map(|curve| {
                let parts: Vec<Value> = curve
                    .parts
                    .iter()
                    .map(|(x_from, x_to, part)| {
                        let mut entry = output_json(part, spec_sizes);
                        if let Value::Object(entry) = &mut entry {
                            entry.insert("x_from".into(), json!(x_from));
                            entry.insert("x_to".into(), json!(x_to));
                        }
                        entry
                    })
                    .collect();
                (
                    curve.key.clone(),
                    json!({ "x": curve.axes[0], "parts": parts }),
                )
            })
            .collect();
        summary["mesh_study_curves"] = Value::Object(curves);
    }
    summary
}

/// A number for JSON: `null` for none or not finite.
fn number(value: Option<f64>) -> Value {
    value
        .filter(|v| v.is_finite())
        .map_or(Value::Null, Value::from)
}

/// One output's entry of `summary.json`'s `mesh_study`: sizes and values
/// in the spec's order, as `[mesh_study] sizes` lists them (a size whose
/// run failed is left out, and the note names it).
fn output_json(output: &super::outcome::OutputConvergence, spec_sizes: &[f64]) -> Value {
    let Some(study) = &output.convergence else {
        return json!({
            "sizes": spec_sizes,
            "values": Value::Null,
            "order": Value::Null,
            "extrapolated": Value::Null,
            "e_a_pct": Value::Null,
            "e_ext_pct": Value::Null,
            "gci_fine_pct": Value::Null,
            "u_num": Value::Null,
            "convergence": Value::Null,
            "note": format!("runs failed at sizes {:?}: fewer than three values", output.failed_sizes),
        });
    };
    let ordered: Vec<(f64, f64)> = spec_sizes
        .iter()
        .filter_map(|h| {
            let at = study.sizes.iter().position(|s| s == h)?;
            Some((*h, study.values[at]))
        })
        .collect();
    json!({
        "sizes": ordered.iter().map(|p| p.0).collect::<Vec<_>>(),
        "values": ordered.iter().map(|p| p.1).collect::<Vec<_>>(),
        "order": number(study.order),
        "extrapolated": number(study.extrapolated),
        "e_a_pct": number(study.e_a_pct),
        "e_ext_pct": number(study.e_ext_pct),
        "gci_fine_pct": number(study.gci_fine_pct),
        "u_num": number(study.standard_uncertainty()),
        "u_num_by_size": ordered.iter().map(|p| number(study.standard_uncertainty_at(p.0))).collect::<Vec<_>>(),
        "convergence": study.convergence.name(),
        "note": if output.failed_sizes.is_empty() {
            study.note.clone()
        } else {
            format!("{}; runs failed at sizes {:?}", study.note, output.failed_sizes)
        },
    })
}
