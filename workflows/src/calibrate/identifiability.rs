//! Which parameters the data pin down: a local, linearised analysis at the
//! calibrated point on the GP surrogates of the fit observations (the
//! method's own GPs, or GPs fitted to the logged runs after Bayesian
//! optimisation).
//!
//! With residuals `r_i` (a scalar's `(model - measured) / u` when its
//! standard uncertainty u is known, else its relative error in %; a curve's
//! MAPE in %), the Jacobian `J = dr/du` over the unit box gives the
//! Gauss-Newton covariance `C = (J^T J)^-1` of the parameters (in the
//! residuals' unit squared): its diagonal is how far each parameter can
//! move for one unit of residual, its off-diagonal the correlations. A
//! parameter whose column of J is near zero, or whose spread exceeds half
//! its range, is not identified; a pair with |correlation| > 0.9 is pinned
//! down only as a combination. The loss along each parameter through the
//! optimum (the others held) is drawn from the same GPs.

use acq_calib::evaluation::{Evaluation, Parameter};
use acq_calib::gp::{Gp, GpSettings, Kernel};
use acq_report::document::{Document, Figure, Table};
use acq_report::plot::{chart_svg, Chart, Series};
use nalgebra::{DMatrix, SymmetricEigen};

use super::search::to_unit;
use super::study::{Measured, Role, Study};

/// The analysis at one point.
pub struct Identifiability {
    /// Per parameter: the change of the residual vector's norm across the
    /// whole range (linearised), in the residuals' unit.
    pub sensitivity: Vec<f64>,
    /// Per parameter: its spread for one unit of residual, as a fraction
    /// of its range (infinite when not identified).
    pub spread_of_range: Vec<f64>,
    /// Correlation matrix (NaN where a parameter is not identified).
    pub correlation: Vec<Vec<f64>>,
    /// True when every residual is in standard uncertainties, so the
    /// spread is the parameter's standard uncertainty.
    pub in_uncertainties: bool,
    /// The loss along each parameter (unit position, loss), others held.
    pub slices: Vec<Vec<(f64, f64)>>,
}

/// The analysis, or `None` when the surrogates cannot be had (too few
/// successful runs).
pub fn identifiability(
    study: &Study,
    evaluations: &[Evaluation],
    calibrated: &[f64],
    gps: Option<&[Gp]>,
) -> Option<Identifiability> {
    let parameters = study.search_parameters();
    let d = parameters.len();
    let fitted;
    let gps = match gps {
        Some(gps) => gps,
        None => {
            fitted = fit_gps(&parameters, evaluations)?;
            &fitted
        }
    };
    let observations = study.observations(Role::Fit);
    let in_uncertainties = observations.iter().all(|(_, o)| {
        matches!(
            o.measured,
            Measured::Scalar {
                uncertainty: Some(_),
                ..
            }
        )
    });
    // d(residual_i)/d(unit_j) from each GP's mean gradient.
    let at = to_unit(&parameters, calibrated);
    let mut jacobian = DMatrix::<f64>::zeros(observations.len(), d);
    for (i, ((_, observation), gp)) in observations.iter().zip(gps).enumerate() {
        let gradient = gp.predict_with_gradient(&at).mean_gradient;
        let scale = match &observation.measured {
            Measured::Scalar {
                uncertainty: Some(u),
                ..
            } if in_uncertainties => 1.0 / u,
            Measured::Scalar { value, .. } => 100.0 / value.abs(),
            Measured::Curve { .. } => 1.0,
        };
        for j in 0..d {
            jacobian[(i, j)] = gradient[j] * scale;
        }
    }
    let sensitivity: Vec<f64> = (0..d).map(|j| jacobian.column(j).norm()).collect();
    let information = jacobian.transpose() * &jacobian;
    let eigen = SymmetricEigen::new(information);
    let largest = eigen.eigenvalues.iter().fold(0.0f64, |a, &b| a.max(b));
    // Directions the data barely see are left out of the inverse: their
    // spread is reported as infinite instead of as a huge number.
    let cutoff = largest * 1e-10;
    let mut covariance = DMatrix::<f64>::zeros(d, d);
    for (k, &lambda) in eigen.eigenvalues.iter().enumerate() {
        if lambda > cutoff && lambda > 0.0 {
            let v = eigen.eigenvectors.column(k);
            covariance += (v * v.transpose()) / lambda;
        }
    }
    let unseen: Vec<bool> = (0..d)
        .map(|j| {
            eigen
                .eigenvalues
                .iter()
                .enumerate()
                .any(|(k, &l)| l <= cutoff && eigen.eigenvectors[(j, k)].abs() > 0.1)
        })
        .collect();
    let spread_of_range: Vec<f64> = (0..d)
        .map(|j| {
            if unseen[j] || sensitivity[j] == 0.0 {
                f64::INFINITY
            } else {
                covariance[(j, j)].max(0.0).sqrt()
            }
        })
        .collect();
    let correlation = (0..d)
        .map(|a| {
            (0..d)
                .map(|b| {
                    if spread_of_range[a].is_finite() && spread_of_range[b].is_finite() {
                        covariance[(a, b)] / (covariance[(a, a)] * covariance[(b, b)]).sqrt()
                    } else {
                        f64::NAN
                    }
                })
                .collect()
        })
        .collect();
    let slices = (0..d)
        .map(|j| {
            (0..=40)
                .map(|step| {
                    let mut u = at.clone();
                    u[j] = step as f64 / 40.0;
                    let predicted: Vec<f64> = gps.iter().map(|gp| gp.predict(&u).mean).collect();
                    (u[j], study.loss(&predicted))
                })
                .collect()
        })
        .collect();
    Some(Identifiability {
        sensitivity,
        spread_of_range,
        correlation,
        in_uncertainties,
        slices,
    })
}

/// GPs of the fit outputs on the logged runs (unit-box inputs).
fn fit_gps(parameters: &[Parameter], evaluations: &[Evaluation]) -> Option<Vec<Gp>> {
    let (x, y): (Vec<Vec<f64>>, Vec<Vec<f64>>) = evaluations
        .iter()
        .filter_map(|e| Some((to_unit(parameters, &e.parameters), e.outcome.clone().ok()?)))
        .unzip();
    if x.len() < parameters.len() + 2 {
        return None;
    }
    let settings = GpSettings {
        kernel: Kernel::Matern52,
        ard: true,
        restarts: 2,
        input_bounds: Some(vec![(0.0, 1.0); parameters.len()]),
        ..GpSettings::default()
    };
    (0..y[0].len())
        .map(|k| {
            let column: Vec<f64> = y.iter().map(|row| row[k]).collect();
            Gp::fit(&x, &column, &settings).ok()
        })
        .collect()
}

/// The analysis for `summary.json`: per parameter its spread as a share of
/// its range, its standard uncertainty in its own unit when every residual
/// is in standard uncertainties, and the correlations.
pub fn identifiability_json(
    analysis: &Identifiability,
    parameters: &[Parameter],
) -> serde_json::Value {
    use serde_json::{json, Map, Value};
    let finite = |x: f64| if x.is_finite() { json!(x) } else { Value::Null };
    let by_name = |values: &mut dyn Iterator<Item = Value>| -> Value {
        Value::Object(
            parameters
                .iter()
                .map(|p| p.name.clone())
                .zip(values)
                .collect(),
        )
    };
    let mut out = Map::new();
    out.insert(
        "spread_of_range".into(),
        by_name(&mut analysis.spread_of_range.iter().map(|&s| finite(s))),
    );
    if analysis.in_uncertainties {
        out.insert(
            "standard_uncertainty".into(),
            by_name(
                &mut analysis
                    .spread_of_range
                    .iter()
                    .zip(parameters)
                    .map(|(&s, p)| finite(s * (p.upper - p.lower))),
            ),
        );
    }
    out.insert(
        "correlation".into(),
        by_name(
            &mut analysis
                .correlation
                .iter()
                .map(|row| by_name(&mut row.iter().map(|&r| finite(r)))),
        ),
    );
    Value::Object(out)
}

/// The report section: the table, the statements in words, the slices.
pub fn write_identifiability(
    report: &mut Document,
    analysis: &Option<Identifiability>,
    parameters: &[Parameter],
) {
    report.heading(2, "Identifiability: what the data pin down");
    let Some(analysis) = analysis else {
        report.paragraph("Too few successful model runs for the surrogates this analysis needs.");
        return;
    };
    let unit = if analysis.in_uncertainties {
        "one standard uncertainty of every observation"
    } else {
        "1 % of relative error (or MAPE) per observation"
    };
    report.paragraph(format!(
        "Linearised at the calibrated point on GP surrogates of each observation. The spread is how far a parameter can move for {unit}, as a share of its range{}.",
        if analysis.in_uncertainties {
            ": its standard uncertainty"
        } else {
            ""
        }
    ));
    let mut table = Table::new(&[
        "parameter",
        "residual change over the range",
        "spread",
        "verdict",
    ]);
    let mut sentences = Vec::new();
    for (j, p) in parameters.iter().enumerate() {
        let spread = analysis.spread_of_range[j];
        let largest = analysis.sensitivity.iter().fold(0.0f64, |a, &b| a.max(b));
        let verdict = if !spread.is_finite() || spread > 0.5 {
            sentences.push(if analysis.sensitivity[j] <= 1e-3 * largest {
                format!(
                    "{} is not identified: the data change too little when it moves.",
                    p.name
                )
            } else {
                format!(
                    "{} is not identified on its own: the data see it, but a combination with other parameters leaves them unchanged (more parameters than independent observations, or parameters that act alike).",
                    p.name
                )
            });
            "not identified"
        } else if spread > 0.1 {
            "weakly identified"
        } else {
            "identified"
        };
        let value_spread = spread * (p.upper - p.lower);
        table.row(vec![
            p.name.clone(),
            format!("{:.4}", analysis.sensitivity[j]),
            if spread.is_finite() {
                format!("{:.1} % (±{value_spread:.4})", 100.0 * spread)
            } else {
                "unbounded".into()
            },
            verdict.into(),
        ]);
    }
    for a in 0..parameters.len() {
        for b in a + 1..parameters.len() {
            let rho = analysis.correlation[a][b];
            if rho.abs() > 0.9 {
                sentences.push(format!(
                    "{} and {} are strongly correlated (ρ = {rho:+.2}): the data pin down a combination of them, not each one.",
                    parameters[a].name, parameters[b].name
                ));
            }
        }
    }
    if sentences.is_empty() {
        sentences.push(
            "Every parameter is pinned down on its own: none is flat in the data and no pair is strongly correlated."
                .into(),
        );
    }
    report.table(table).paragraph(sentences.join(" "));
    if parameters.len() > 1 {
        let mut header = vec![String::from("correlation")];
        header.extend(parameters.iter().map(|p| p.name.clone()));
        let header: Vec<&str> = header.iter().map(String::as_str).collect();
        let mut table = Table::new(&header);
        for (a, p) in parameters.iter().enumerate() {
            let mut cells = vec![p.name.clone()];
            cells.extend(analysis.correlation[a].iter().map(|r| {
                if r.is_finite() {
                    format!("{r:+.2}")
                } else {
                    "-".into()
                }
            }));
            table.row(cells);
        }
        report.table(table);
    }
    let mut chart = Chart::new(
        "Loss along each parameter through the optimum (GP, others held)",
        "position in the parameter's range (0 = lower, 1 = upper)",
        "loss",
    );
    for (p, slice) in parameters.iter().zip(&analysis.slices) {
        chart = chart.with_series(Series::new(p.name.clone(), slice.clone()));
    }
    report.figure(Figure {
        file: "identifiability.svg".into(),
        caption: "loss along each parameter through the optimum".into(),
        svg: chart_svg(&chart, 720.0, 420.0),
    });
}
