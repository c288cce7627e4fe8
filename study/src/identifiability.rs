//! Which parameters the data pin down: a local analysis at the calibrated
//! point on the GP surrogates of the fit observations (the method's own
//! GPs, or GPs fitted to the logged runs after Bayesian optimisation), or
//! on the model itself linearised there (after a least-squares search,
//! whose last Jacobian it is).
//!
//! - **Scalars only** (Gauss-Newton): with residuals `r_i` (a scalar's
//!   `(model - measured) / u` when its standard uncertainty u is known, else
//!   its relative error in %), the Jacobian `J = dr/du` over the unit box
//!   gives the covariance `C = (J^T J)^-1` of the parameters in the
//!   residuals' unit squared: its diagonal is how far each parameter can
//!   move for one unit of residual.
//! - **With a curve** (whose MAPE is no signed residual): the loss's
//!   Hessian `H` on the GP means by central differences gives `C = 2 H^-1`:
//!   how far each parameter can move before the loss rises by one point.
//!
//! A direction the data do not see (an eigenvalue of `J^T J` or `H` below
//! 1e-10 of the largest, or negative) makes the parameters in it
//! unidentified; a spread over half the range is the same in practice; a
//! pair with |correlation| > 0.9 is pinned down only as a combination. The
//! loss along each parameter through the optimum (the others held) is drawn
//! from the same GPs.

use acq_algorithms::evaluation::{Evaluation, Parameter};
use acq_algorithms::gp::{Gp, GpSettings, Kernel};
use acq_report::document::{Document, Figure, Table};
use acq_report::plot::{chart_svg, Chart, Series};
use nalgebra::{DMatrix, Dyn, SymmetricEigen};

use super::search::to_unit;
use super::study::{Measured, Role, Study};
use super::verdict::{verdict_of, ParameterVerdict};

/// The analysis at one point.
pub struct Identifiability {
    /// Per parameter: how much the loss changes along its whole range, the
    /// others held at the optimum.
    pub sensitivity: Vec<f64>,
    /// Per parameter: its spread for one unit of residual, as a fraction
    /// of its range (infinite when not identified).
    pub spread_of_range: Vec<f64>,
    /// Correlation matrix (NaN where a parameter is not identified).
    pub correlation: Vec<Vec<f64>>,
    /// True when every residual is in standard uncertainties, so the
    /// spread is the parameter's standard uncertainty.
    pub in_uncertainties: bool,
    /// From the loss's curvature (a curve is observed): the spread is how
    /// far a parameter moves before the loss rises by one point.
    pub from_loss_curvature: bool,
    /// The loss along each parameter (unit position, loss), others held.
    pub slices: Vec<Vec<(f64, f64)>>,
    /// Taken on the model's own outputs, linearised (else on GPs).
    pub on_the_model: bool,
}

/// The fit outputs at a unit-box point, near the calibrated one.
type Predictor<'a> = dyn Fn(&[f64]) -> Vec<f64> + 'a;

/// What the analysis looks at the outputs through.
pub enum Local<'a> {
    /// The method's GPs of the fit outputs, or none: GPs are fitted to
    /// the logged runs.
    Surrogates(Option<&'a [Gp]>),
    /// The model's own outputs linearised at the calibrated point: d output
    /// / d unit-box position, one row per fit output (a least-squares
    /// search's last Jacobian).
    Jacobian(&'a [Vec<f64>]),
}

impl Identifiability {
    /// Each parameter's standard uncertainty in its own unit (infinite when
    /// not identified), when every residual is in standard uncertainties.
    pub fn standard_uncertainties(&self, parameters: &[Parameter]) -> Option<Vec<f64>> {
        self.in_uncertainties.then(|| {
            self.spread_of_range
                .iter()
                .zip(parameters)
                .map(|(&s, p)| s * (p.upper - p.lower))
                .collect()
        })
    }
}

/// The analysis, or `None` when the surrogates cannot be had (too few
/// successful runs).
pub fn identifiability(
    study: &Study,
    evaluations: &[Evaluation],
    calibrated: &[f64],
    calibrated_outputs: &[f64],
    local: Local<'_>,
) -> Option<Identifiability> {
    let parameters = study.search_parameters();
    let d = parameters.len();
    let at = to_unit(&parameters, calibrated);
    let on_the_model = matches!(local, Local::Jacobian(_));
    let (predicted, jacobian) =
        local_outputs(local, &parameters, evaluations, &at, calibrated_outputs)?;
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
    let has_curve = observations
        .iter()
        .any(|(_, o)| matches!(o.measured, Measured::Curve { .. }));
    let information = if has_curve {
        loss_hessian(&|u: &[f64]| study.loss(&predicted(u)), &at) / 2.0
    } else {
        gauss_newton_information(&observations, &jacobian, in_uncertainties)
    };
    let eigen = SymmetricEigen::new(information);
    let largest = eigen.eigenvalues.iter().fold(0.0f64, |a, &b| a.max(b));
    // Directions the data barely see are left out of the inverse: their
    // spread is reported as infinite instead of as a huge number.
    let cutoff = largest * 1e-10;
    let slices = loss_slices(study, &*predicted, &at);
    let sensitivity = loss_change_along_range(&slices);
    let covariance = covariance_of_seen_directions(&eigen, cutoff);
    let unseen = in_unseen_directions(&eigen, cutoff);
    let spread_of_range: Vec<f64> = (0..d)
        .map(|j| {
            if unseen[j] || sensitivity[j] == 0.0 {
                f64::INFINITY
            } else {
                covariance[(j, j)].max(0.0).sqrt()
            }
        })
        .collect();
    let correlation = correlation_of_identified(&covariance, &spread_of_range);
    Some(Identifiability {
        sensitivity,
        spread_of_range,
        correlation,
        in_uncertainties: in_uncertainties && !has_curve,
        from_loss_curvature: has_curve,
        slices,
        on_the_model,
    })
}

/// Outputs near the calibrated point `at`, and their Jacobian there: the
/// GPs' means and gradients (the given GPs, or GPs fitted to the logged
/// runs; `None` when too few runs succeeded), or the model linearised.
fn local_outputs<'a>(
    local: Local<'a>,
    parameters: &[Parameter],
    evaluations: &[Evaluation],
    at: &[f64],
    calibrated_outputs: &[f64],
) -> Option<(Box<Predictor<'a>>, DMatrix<f64>)> {
    let d = parameters.len();
    Some(match local {
        Local::Surrogates(Some(gps)) => (
            Box::new(move |u: &[f64]| gp_means(gps, u)),
            gp_jacobian(gps, at, d),
        ),
        Local::Surrogates(None) => {
            let fitted = fit_gps(parameters, evaluations)?;
            let jacobian = gp_jacobian(&fitted, at, d);
            (Box::new(move |u: &[f64]| gp_means(&fitted, u)), jacobian)
        }
        Local::Jacobian(rows) => {
            let jacobian = DMatrix::from_fn(rows.len(), d, |i, j| rows[i][j]);
            let centre = at.to_vec();
            let outputs = calibrated_outputs.to_vec();
            let linear = jacobian.clone();
            (
                Box::new(move |u: &[f64]| {
                    let shift = DMatrix::from_fn(d, 1, |j, _| u[j] - centre[j]);
                    let change = &linear * shift;
                    outputs
                        .iter()
                        .enumerate()
                        .map(|(i, y)| y + change[(i, 0)])
                        .collect()
                }),
                jacobian,
            )
        }
    })
}

/// The GPs' means at a unit-box point: the outputs they stand for.
fn gp_means(gps: &[Gp], u: &[f64]) -> Vec<f64> {
    gps.iter().map(|gp| gp.predict(u).mean).collect()
}

/// d GP mean / d unit-box position at `at`, one row per GP, `d` columns.
fn gp_jacobian(gps: &[Gp], at: &[f64], d: usize) -> DMatrix<f64> {
    let mut jacobian = DMatrix::<f64>::zeros(gps.len(), d);
    for (i, gp) in gps.iter().enumerate() {
        let gradient = gp.predict_with_gradient(at).mean_gradient;
        for (j, g) in gradient.iter().enumerate() {
            jacobian[(i, j)] = *g;
        }
    }
    jacobian
}

/// The loss along each parameter through `at` (the others held), at 41
/// evenly spaced unit positions: (unit position, loss).
fn loss_slices(study: &Study, predicted: &Predictor<'_>, at: &[f64]) -> Vec<Vec<(f64, f64)>> {
    (0..at.len())
        .map(|j| {
            (0..=40)
                .map(|step| {
                    let mut u = at.to_vec();
                    u[j] = step as f64 / 40.0;
                    (u[j], study.loss(&predicted(&u)))
                })
                .collect()
        })
        .collect()
}

/// How much the loss changes along each parameter's whole range: the
/// spread of its slice.
fn loss_change_along_range(slices: &[Vec<(f64, f64)>]) -> Vec<f64> {
    slices
        .iter()
        .map(|slice| {
            let (low, high) = slice
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &(_, l)| {
                    (lo.min(l), hi.max(l))
                });
            high - low
        })
        .collect()
}

/// The inverse of the information over the directions the data see (an
/// eigenvalue above `cutoff` and positive).
fn covariance_of_seen_directions(eigen: &SymmetricEigen<f64, Dyn>, cutoff: f64) -> DMatrix<f64> {
    let d = eigen.eigenvectors.nrows();
    let mut covariance = DMatrix::<f64>::zeros(d, d);
    for (k, &lambda) in eigen.eigenvalues.iter().enumerate() {
        if lambda > cutoff && lambda > 0.0 {
            let v = eigen.eigenvectors.column(k);
            covariance += (v * v.transpose()) / lambda;
        }
    }
    covariance
}

/// Per parameter: whether it takes part (a component over 0.1) in a
/// direction the data do not see.
fn in_unseen_directions(eigen: &SymmetricEigen<f64, Dyn>, cutoff: f64) -> Vec<bool> {
    (0..eigen.eigenvectors.nrows())
        .map(|j| {
            eigen.eigenvalues.iter().enumerate().any(|(k, &l)| {
                // Below the cutoff, negative, or NaN: a direction the data do not see.
                l.partial_cmp(&cutoff) != Some(std::cmp::Ordering::Greater)
                    && eigen.eigenvectors[(j, k)].abs() > 0.1
            })
        })
        .collect()
}

/// The correlation matrix of the parameters, NaN where one of the pair
/// has no finite spread.
fn correlation_of_identified(covariance: &DMatrix<f64>, spread_of_range: &[f64]) -> Vec<Vec<f64>> {
    let d = spread_of_range.len();
    (0..d)
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
        .collect()
}

/// `J^T J` of the scalar residuals, from the outputs' Jacobian.
fn gauss_newton_information(
    observations: &[(&super::study::Case, &super::study::Observation)],
    outputs_jacobian: &DMatrix<f64>,
    in_uncertainties: bool,
) -> DMatrix<f64> {
    let mut jacobian = outputs_jacobian.clone();
    for (i, (_, observation)) in observations.iter().enumerate() {
        let scale = match &observation.measured {
            Measured::Scalar {
                uncertainty: Some(u),
                ..
            } if in_uncertainties => 1.0 / u,
            Measured::Scalar { value, .. } => 100.0 / value.abs(),
            Measured::Curve { .. } => 1.0,
        };
        for j in 0..jacobian.ncols() {
            jacobian[(i, j)] *= scale;
        }
    }
    jacobian.transpose() * jacobian
}

/// The Hessian of `loss` at `at` in the unit box by central differences
/// (step 0.02; the stencil is moved inside the box at a bound).
fn loss_hessian(loss: &dyn Fn(&[f64]) -> f64, at: &[f64]) -> DMatrix<f64> {
    const STEP: f64 = 0.02;
    let centre: Vec<f64> = at.iter().map(|u| u.clamp(STEP, 1.0 - STEP)).collect();
    let d = centre.len();
    let value = |shifts: &[(usize, f64)]| {
        let mut u = centre.clone();
        for &(i, h) in shifts {
            u[i] += h;
        }
        loss(&u)
    };
    let f0 = value(&[]);
    let mut hessian = DMatrix::<f64>::zeros(d, d);
    for i in 0..d {
        hessian[(i, i)] = (value(&[(i, STEP)]) - 2.0 * f0 + value(&[(i, -STEP)])) / (STEP * STEP);
        for j in 0..i {
            let mixed = (value(&[(i, STEP), (j, STEP)])
                - value(&[(i, STEP), (j, -STEP)])
                - value(&[(i, -STEP), (j, STEP)])
                + value(&[(i, -STEP), (j, -STEP)]))
                / (4.0 * STEP * STEP);
            hessian[(i, j)] = mixed;
            hessian[(j, i)] = mixed;
        }
    }
    hessian
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
    if let Some(uncertainties) = analysis.standard_uncertainties(parameters) {
        out.insert(
            "standard_uncertainty".into(),
            by_name(&mut uncertainties.into_iter().map(finite)),
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
    one_verdicts: &[ParameterVerdict],
) {
    report.heading(2, "Identifiability: what the data pin down");
    let Some(analysis) = analysis else {
        report.paragraph("Too few successful model runs for the surrogates this analysis needs.");
        return;
    };
    report.paragraph(how_the_spread_was_found(analysis));
    let (table, verdicts) = verdict_table(analysis, parameters, one_verdicts);
    let mut sentences = verdict_sentences(&verdicts, analysis, parameters);
    sentences.extend(where_the_verdict_differs(
        analysis,
        parameters,
        one_verdicts,
    ));
    report.table(table).paragraph(sentences.join(" "));
    if parameters.len() > 1 {
        report.table(correlation_table(analysis, parameters));
    }
    report.figure(loss_slices_figure(analysis, parameters));
}

/// The sentence that says where the analysis was made and what its spread
/// is a spread for.
fn how_the_spread_was_found(analysis: &Identifiability) -> String {
    let unit = if analysis.from_loss_curvature {
        "a rise of the loss by one point"
    } else if analysis.in_uncertainties {
        "one standard uncertainty of every observation"
    } else {
        "1 % of relative error per observation"
    };
    format!(
        "At the calibrated point, {}{}. The spread is how far a parameter can move for {unit}, as a share of its range{}.",
        if analysis.on_the_model {
            "on the model itself (central differences)"
        } else {
            "on GP surrogates of each observation"
        },
        if analysis.from_loss_curvature {
            " (from the loss's curvature, as a curve is observed)"
        } else {
            " (linearised)"
        },
        if analysis.in_uncertainties {
            ": its standard uncertainty"
        } else {
            ""
        }
    )
}

/// The parameters that are not (or weakly) identified, by name, by why.
#[derive(Default)]
struct Verdicts<'a> {
    /// Not identified, and the loss barely changes along them.
    flat: Vec<&'a str>,
    /// Not identified though the loss changes along them.
    confounded: Vec<&'a str>,
    /// Spread between 10 and 50 % of the range.
    weak: Vec<&'a str>,
}

/// The table of each parameter's loss change, spread and verdict, and the
/// parameters sorted by verdict.
fn verdict_table<'a>(
    analysis: &Identifiability,
    parameters: &'a [Parameter],
    one_verdicts: &[ParameterVerdict],
) -> (Table, Verdicts<'a>) {
    let mut table = Table::new(&[
        "parameter",
        "loss change along its range",
        "spread",
        "at the calibrated point",
        "verdict",
    ]);
    let largest = analysis.sensitivity.iter().fold(0.0f64, |a, &b| a.max(b));
    let mut verdicts = Verdicts::default();
    for (j, p) in parameters.iter().enumerate() {
        let spread = analysis.spread_of_range[j];
        let verdict = local_verdict(analysis, j);
        match verdict {
            "not identified" if analysis.sensitivity[j] <= 1e-3 * largest => {
                verdicts.flat.push(p.name.as_str())
            }
            "not identified" => verdicts.confounded.push(p.name.as_str()),
            "weakly identified" => verdicts.weak.push(p.name.as_str()),
            _ => {}
        }
        let value_spread = spread * (p.upper - p.lower);
        table.row(vec![
            p.name.clone(),
            acq_report::number::plain(analysis.sensitivity[j], 4),
            spread_words(spread, value_spread),
            verdict.into(),
            verdict_of(one_verdicts, &p.name)
                .map_or_else(|| verdict.to_string(), |v| v.words.clone()),
        ]);
    }
    (table, verdicts)
}

/// A spread as a share of the range and in the parameter's unit; beyond
/// the range it is no number worth reading (thousands of percent), only
/// that the data do not bound it there.
fn spread_words(spread_of_range: f64, value_spread: f64) -> String {
    if !spread_of_range.is_finite() {
        "unbounded".into()
    } else if spread_of_range > 1.0 {
        "beyond its range".into()
    } else {
        format!(
            "{:.1} % (±{})",
            100.0 * spread_of_range,
            acq_report::number::plain(value_spread, 4)
        )
    }
}

/// The local verdict of parameter `j` in one word, as the table gives it.
pub fn local_verdict(analysis: &Identifiability, j: usize) -> &'static str {
    let spread = analysis.spread_of_range[j];
    if !spread.is_finite() || spread > 0.5 {
        "not identified"
    } else if spread > 0.1 {
        "weakly identified"
    } else {
        "identified"
    }
}

/// The parameter most correlated with `j` (|ρ| above 0.5), if any.
pub fn strongest_partner(analysis: &Identifiability, j: usize) -> Option<(usize, f64)> {
    analysis.correlation[j]
        .iter()
        .enumerate()
        .filter(|&(k, rho)| k != j && rho.is_finite() && rho.abs() > 0.5)
        .max_by(|a, b| a.1.abs().total_cmp(&b.1.abs()))
        .map(|(k, rho)| (k, *rho))
}

/// The verdicts and the strongly correlated pairs in words, or that every
/// parameter is pinned down.
fn verdict_sentences(
    verdicts: &Verdicts<'_>,
    analysis: &Identifiability,
    parameters: &[Parameter],
) -> Vec<String> {
    let mut sentences = Vec::new();
    if !verdicts.flat.is_empty() {
        sentences.push(format!(
            "Flat in the data, so not identified: {}. Fix them at a value from elsewhere, or add an observation they move.",
            verdicts.flat.join(", ")
        ));
    }
    if !verdicts.confounded.is_empty() {
        sentences.push(format!(
            "Seen by the data but not identified on their own: {}. Combinations of them leave every observation unchanged (more parameters than independent observations, or parameters that act alike); the values found are one of many equally good answers.",
            verdicts.confounded.join(", ")
        ));
    }
    if !verdicts.weak.is_empty() {
        sentences.push(format!(
            "Weakly identified (spread 10-50 % of the range): {}.",
            verdicts.weak.join(", ")
        ));
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
            "At the calibrated point every parameter is fixed on its own: none is flat in the data and no pair is strongly correlated."
                .into(),
        );
    }
    sentences
}

/// Where a parameter's one verdict is not the calibrated point's, why:
/// the posterior weighs the whole range where the linearisation sees one
/// point, and a bound stops what the point could say.
fn where_the_verdict_differs(
    analysis: &Identifiability,
    parameters: &[Parameter],
    one_verdicts: &[ParameterVerdict],
) -> Option<String> {
    let differ: Vec<String> = parameters
        .iter()
        .enumerate()
        .filter_map(|(j, p)| {
            let one = verdict_of(one_verdicts, &p.name)?;
            let local = local_verdict(analysis, j);
            (one.short() != local).then(|| format!("{} ({local} here; {})", p.name, one.short()))
        })
        .collect();
    (!differ.is_empty()).then(|| {
        format!(
            "The verdict column is each parameter's one verdict, read by every table of this report: the posterior's where there is one (it weighs the measured values over the whole range, where the linearisation sees only the calibrated point), and a bound's where the value or its interval reaches one. It differs from the calibrated point's for {}.",
            differ.join(", ")
        )
    })
}

/// The correlation matrix as a table, "-" where it is not defined.
fn correlation_table(analysis: &Identifiability, parameters: &[Parameter]) -> Table {
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
    table
}

/// The figure of the loss along each parameter through the optimum.
fn loss_slices_figure(analysis: &Identifiability, parameters: &[Parameter]) -> Figure {
    let mut chart = Chart::new(
        "Loss along each parameter through the optimum (GP, others held)",
        "position in the parameter's range (0 = lower, 1 = upper)",
        "loss",
    );
    for (p, slice) in parameters.iter().zip(&analysis.slices) {
        chart = chart.with_series(Series::new(p.name.clone(), slice.clone()));
    }
    Figure {
        file: "identifiability.svg".into(),
        caption: "loss along each parameter through the optimum".into(),
        svg: chart_svg(&chart, 720.0, 420.0),
    }
}

#[cfg(test)]
mod tests {
    use super::spread_words;

    /// A spread past the range is said as such, not as thousands of
    /// percent; within it, as a share and in the parameter's unit.
    #[test]
    fn a_spread_beyond_the_range_is_not_a_percentage() {
        assert_eq!(spread_words(39.15, 3915.0), "beyond its range");
        assert_eq!(spread_words(f64::INFINITY, f64::INFINITY), "unbounded");
        assert_eq!(spread_words(0.573, 5.7311), "57.3 % (±5.731)");
    }
}
