//! The posterior in the report and in `summary.json`: what each parameter
//! can still be, in numbers and in words; whether the chains converged;
//! how large the model's own error is next to the measurement's; which
//! measured values the predictions hold; and a corner plot.

use acq_analysis::loss::metrics::CurveMetric;
use acq_report::document::{Document, Figure, Table};
use acq_report::plot::{grid_svg, sparse_grid_svg, Chart, Series, SeriesStyle};
use serde_json::{json, Map, Value};

use acq_algorithms::mcmc::{quantile, Marginal, Support};

use super::discrepancy::Form;
use super::likelihood::PriorInterval;
use super::predictive::{Predicted, PredictedCurve};
use super::validation::{validation_statements, COVERAGE_FACTOR};
use super::{unconverged, PosteriorOutcome, ESS_PER_CHAIN, RHAT_LIMIT};
use crate::study::Role;
use crate::verdict::{verdict_of, ParameterVerdict};

/// A parameter is pinned down when its 90 % interval spans at most this
/// share of its prior range, and is not identified when it spans at least
/// the other (a uniform prior's own 90 % interval spans 0.9).
const PINNED_SHARE: f64 = 0.25;
const UNIDENTIFIED_SHARE: f64 = 0.75;

/// Draws shown per scatter panel of the corner plot.
const CORNER_POINTS: usize = 600;

/// `posterior`, `predictive` and (with discrepancy) `discrepancy` of the
/// summary.
pub fn summary_keys(posterior: &PosteriorOutcome) -> Vec<(String, Value)> {
    let density = &posterior.density;
    let marginal_json = |index: usize| {
        let m = &posterior.marginals[index];
        json!({
            "mean": m.mean, "sd": m.sd, "q05": m.q05, "q50": m.q50, "q95": m.q95,
            "rhat": finite_or_null(m.rhat), "ess_bulk": finite_or_null(m.ess_bulk),
        })
    };
    let mut parameters = Map::new();
    let noise = posterior.column("measurement_noise_pct");
    for index in (0..density.coordinates.len()).chain(noise) {
        parameters.insert(posterior.names[index].clone(), marginal_json(index));
    }
    let mut predictive = Map::new();
    for entry in &posterior.predicted.scalars {
        let (mean, q05, q95) = entry.interval();
        let case = predictive
            .entry(entry.case.clone())
            .or_insert_with(|| json!({}));
        case[&entry.name] = json!({
            "mean": finite_or_null(mean), "q05": finite_or_null(q05),
            "q95": finite_or_null(q95), "measured": entry.measured,
        });
    }
    let mut keys = vec![
        ("posterior".to_string(), Value::Object(parameters)),
        ("predictive".to_string(), Value::Object(predictive)),
    ];
    if !density.outputs.is_empty() {
        let discrepancy: Map<String, Value> = posterior
            .discrepancy
            .iter()
            .map(|d| (d.key.clone(), json!({"mean": d.mean, "sd": d.sd})))
            .collect();
        keys.push(("discrepancy".to_string(), Value::Object(discrepancy)));
    }
    keys
}

fn finite_or_null(value: f64) -> Value {
    if value.is_finite() {
        json!(value)
    } else {
        Value::Null
    }
}

/// The report's posterior section.
pub fn write_section(
    report: &mut Document,
    posterior: &PosteriorOutcome,
    verdicts: &[ParameterVerdict],
) {
    report.heading(2, "Posterior: how far the parameters can move");
    report.paragraph(sampling_sentence(posterior));
    report.paragraph(convergence_sentence(posterior));
    write_coverage_caveat(report, posterior);
    report.table(marginals_table(posterior, verdicts));
    report.paragraph("How well the chains estimate each marginal:");
    report.table(chains_table(posterior));
    report.paragraph(verdicts_in_words(verdicts));
    write_discrepancy(report, posterior);
    write_predictive(report, &posterior.predicted.scalars);
    write_validation_statement(report, posterior);
    write_curve_bands(report, &posterior.predicted.curves);
    report.figure(Figure {
        file: "posterior_trace_rank.svg".into(),
        caption: "each parameter's chains: the draws in order (left; chains that mix overlap, none drifts) and the ranks of each chain's draws among all (right; chains that sample one posterior spread their ranks evenly, near the dotted line), as ArviZ's plot_trace and plot_rank".into(),
        svg: trace_and_rank_svg(posterior),
    });
    report.figure(Figure {
        file: "posterior_corner.svg".into(),
        caption: "posterior draws: each parameter's histogram over its prior range (diagonal) and each pair's draws (below it)".into(),
        svg: corner_svg(posterior),
    });
}

/// What was sampled, how long it took and the prior.
fn sampling_sentence(posterior: &PosteriorOutcome) -> String {
    format!(
        "The posterior of the parameters given the fit cases' measured values and their uncertainty, {} ({:.1} s). Prior: uniform over the bounds{}.",
        posterior.path,
        posterior.wall_s,
        if posterior
            .density
            .coordinates
            .iter()
            .any(|c| c.normal.is_some())
        {
            ", times the stated normal priors"
        } else {
            ""
        }
    )
}

/// Whether the chains converged, and what to do when they did not.
fn convergence_sentence(posterior: &PosteriorOutcome) -> String {
    let unconverged = posterior.unconverged();
    if unconverged.is_empty() {
        format!(
            "Converged: every R-hat is below {RHAT_LIMIT} and every bulk and tail ESS at least {:.0} (the MCSE of each mean is its sd over the root of the ESS; the HDI is the narrowest interval holding 90 % of the draws, as ArviZ computes them).",
            ESS_PER_CHAIN * posterior.settings.chains as f64
        )
    } else {
        format!(
            "**Not converged**: {}. The numbers below are not to be trusted yet: sample longer (`draws` under `[posterior]` in a spec, `--posterior-draws` with a preset, e.g. {}) or with more chains.",
            unconverged.join(", "),
            (posterior.settings.draws * 4).clamp(100, super::settings::MAX_DRAWS)
        )
    }
}

/// The table of each coordinate's marginal and verdict (a parameter's is
/// its one verdict, [`crate::verdict`]; the discrepancy's scales are stated
/// with it, below). The chains' diagnostics are a table of their own: in
/// one the verdict was pushed past a page's width.
fn marginals_table(posterior: &PosteriorOutcome, verdicts: &[ParameterVerdict]) -> Table {
    let mut table = Table::new(&[
        "parameter",
        "prior range",
        "median [5 % .. 95 %]",
        "mean ± sd",
        "90 % HDI",
        "90 % interval / range",
        "verdict",
    ]);
    for (index, (name, m)) in posterior.names.iter().zip(&posterior.marginals).enumerate() {
        let (range, share) = range_and_share(posterior, index);
        let verdict = match verdict_of(verdicts, name) {
            Some(verdict) => verdict.words.clone(),
            None => posterior_verdict(posterior, index, None),
        };
        table.row(vec![
            name.clone(),
            range,
            format!("{} [{} .. {}]", short(m.q50), short(m.q05), short(m.q95)),
            format!("{} ± {}", short(m.mean), short(m.sd)),
            format!("{} .. {}", short(m.hdi90.0), short(m.hdi90.1)),
            format!("{:.0} %", 100.0 * share),
            verdict,
        ]);
    }
    table
}

/// Each coordinate's chain diagnostics, as ArviZ's `summary` gives them.
fn chains_table(posterior: &PosteriorOutcome) -> Table {
    let mut table = Table::new(&[
        "parameter",
        "MCSE of the mean",
        "R-hat",
        "bulk ESS",
        "tail ESS",
    ]);
    for (name, m) in posterior.names.iter().zip(&posterior.marginals) {
        table.row(vec![
            name.clone(),
            short(m.mcse_mean),
            format!("{:.3}", m.rhat),
            format!("{:.0}", m.ess_bulk),
            format!("{:.0}", m.ess_tail),
        ]);
    }
    table
}

/// Coordinate `index`'s prior range as written and the share of it its
/// 90 % interval spans.
fn range_and_share(posterior: &PosteriorOutcome, index: usize) -> (String, f64) {
    let name = &posterior.names[index];
    let log_uniform = match posterior
        .density
        .coordinates
        .iter()
        .find(|c| &c.name == name)
    {
        Some(coordinate) => coordinate.log_uniform,
        // The scales are log-uniform, the correlations uniform.
        None => !name.starts_with("curve_error_correlation."),
    };
    prior_range_and_interval_share(
        &posterior.supports[index],
        &posterior.marginals[index],
        log_uniform,
    )
}

/// What the posterior says of coordinate `index`, in words; `bound` the
/// bound its 90 % interval reaches, if any. A parameter on its bound is
/// never pinned down.
pub(crate) fn posterior_verdict(
    posterior: &PosteriorOutcome,
    index: usize,
    bound: Option<&str>,
) -> String {
    let name = &posterior.names[index];
    let m = &posterior.marginals[index];
    let unsettled = !unconverged(
        std::slice::from_ref(name),
        std::slice::from_ref(m),
        posterior.settings.chains,
    )
    .is_empty();
    if name.starts_with("discrepancy_sd.") {
        return "see the discrepancy below".into();
    }
    if unsettled {
        return "not converged: no verdict until its chains agree".into();
    }
    // The predictive check: a model that misses a fit value gives the
    // intervals of a model that misses.
    let misses = posterior
        .predicted
        .scalars
        .iter()
        .any(|p| p.role == Role::Fit && !p.holds_measured());
    if misses {
        let on = bound
            .map(|side| format!(", against its {side}"))
            .unwrap_or_default();
        return format!("conflict: the model misses fit values (the predictive check below){on}, so this is a model's that misses; allow a model error or fix the model");
    }
    let (_, share) = range_and_share(posterior, index);
    // The data and the prior disagree: the posterior's median outside
    // the prior's own 90 % interval.
    let outside_prior = posterior
        .density
        .coordinates
        .iter()
        .find(|c| &c.name == name)
        .map(|c| c.prior_interval())
        .is_some_and(|p: PriorInterval| !(p.q05..=p.q95).contains(&m.q50));
    match bound {
        Some(side) if share <= PINNED_SHARE => format!(
            "conflict: the data push it against its {side} (the model misses, or the range is too narrow)"
        ),
        Some(side) if share < UNIDENTIFIED_SHARE => {
            format!("narrowed, its interval cut by its {side}")
        }
        _ if outside_prior => "conflict: the data pull it outside its prior's 90 % interval (check the model and the prior)".into(),
        _ if share <= PINNED_SHARE => "pinned down".into(),
        _ if share >= UNIDENTIFIED_SHARE => {
            "not identified: the data leave it near its prior".into()
        }
        _ => "narrowed".into(),
    }
}

/// The prior range as written in the table, and the share of it the 90 %
/// interval spans (along the log for a log-uniform prior; NaN without a
/// bounded range).
fn prior_range_and_interval_share(
    support: &Support,
    m: &Marginal,
    log_uniform: bool,
) -> (String, f64) {
    match *support {
        Support::Interval { lower, upper } if log_uniform => (
            format!("{} .. {} (log)", short(lower), short(upper)),
            (m.q95 / m.q05).ln() / (upper / lower).ln(),
        ),
        Support::Interval { lower, upper } => (
            format!("{} .. {}", short(lower), short(upper)),
            (m.q95 - m.q05) / (upper - lower),
        ),
        _ => ("-".into(), f64::NAN),
    }
}

/// Which parameters the measured values pin down and which they leave
/// near their prior, in words.
fn verdicts_in_words(verdicts: &[ParameterVerdict]) -> String {
    let named = |prefix: &str| -> Vec<&str> {
        verdicts
            .iter()
            .filter(|v| v.words.starts_with(prefix))
            .map(|v| v.name.as_str())
            .collect()
    };
    let (conflicts, unsettled) = (named("conflict"), named("not converged"));
    let mut caveats = String::new();
    if !unsettled.is_empty() {
        caveats.push_str(&format!(
            " No verdict for {}: the chains have not converged.",
            list_or(&unsettled, "")
        ));
    }
    if !conflicts.is_empty() {
        caveats.push_str(&format!(
            " The data conflict with the prior or the model for {}: their intervals say where a model that misses is pushed, not where the parameter lies.",
            list_or(&conflicts, "")
        ));
    }
    let (pinned, loose) = (named("pinned down"), named("not identified"));
    format!(
        "In words: the measured values pin down {}; they leave {} near {} prior range. A parameter is pinned down when its 90 % interval spans at most {:.0} % of its range, not identified from {:.0} %.{caveats}",
        list_or(&pinned, "no parameter"),
        list_or(&loose, "no parameter"),
        if loose.len() == 1 { "its" } else { "their" },
        100.0 * PINNED_SHARE,
        100.0 * UNIDENTIFIED_SHARE
    )
}

/// Each output's discrepancy next to its measurement uncertainty, and the
/// verdict in words.
/// Where a fit curve is scored by a metric whose posterior intervals
/// acq measured as too narrow, says so (`benches/curve_coverage.rs`:
/// on a noisy saturating curve, PCM's, Fréchet's and the area's 90 %
/// intervals held the truth in 68 to 88 % of 400 replicates; MAPE's and
/// DTW's in 92 to 96 %).
fn write_coverage_caveat(report: &mut Document, posterior: &PosteriorOutcome) {
    let curves: Vec<(&str, CurveMetric)> = posterior
        .density
        .curves
        .iter()
        .map(|c| (c.key.as_str(), c.metric))
        .collect();
    if let Some(caveat) = coverage_caveat(&curves) {
        report.paragraph(caveat);
    }
}

/// The caveat for the fit curves `(key, metric)` whose metric's intervals
/// are too narrow, or `None`. Only the area's: PCM and Fréchet read their
/// residuals from DTW's coupling ([`CurveMetric::residual_coupling`]) and
/// hold the truth as often as DTW.
fn coverage_caveat(curves: &[(&str, CurveMetric)]) -> Option<String> {
    let narrow: Vec<String> = curves
        .iter()
        .filter(|(_, metric)| metric.residual_coupling() == CurveMetric::Area)
        .map(|(key, metric)| format!("`{key}` ({})", metric.as_str()))
        .collect();
    if narrow.is_empty() {
        return None;
    }
    Some(format!(
        "**Read the intervals below as too narrow**: {} scored by the area between the curves, whose 90 % intervals held the truth in only 83 to 87 % of 400 replicates of a noisy curve with a known truth (acq's check, `cargo bench --bench curve_coverage`; with MAPE, DTW, PCM and Fréchet, 92 to 96 %). To sign off on how far the parameters can move, score the curve by `mape` or `dtw`.",
        if narrow.len() == 1 {
            format!("{} is", narrow[0])
        } else {
            format!("{} are", narrow.join(", "))
        }
    ))
}

fn write_discrepancy(report: &mut Document, posterior: &PosteriorOutcome) {
    let density = &posterior.density;
    if density.outputs.is_empty() {
        return;
    }
    report.heading(3, "Model discrepancy");
    let mut table = Table::new(&[
        "output",
        "discrepancy mean",
        "sd",
        "5 %",
        "95 %",
        "its scale tau (median)",
        "measurement uncertainty",
        "verdict",
    ]);
    let (mut model_errors, mut confounded) = (Vec::new(), Vec::new());
    let noise_pct = posterior
        .column("measurement_noise_pct")
        .map(|i| posterior.marginals[i].q50);
    for d in &posterior.discrepancy {
        let output = &density.outputs[d.output];
        let measurement = output
            .observations
            .iter()
            .map(|&i| {
                let o = &density.observations[i];
                density.measurement_sd(noise_pct, o.measured, o.uncertainty)
            })
            .fold(0.0f64, f64::max);
        let tau = posterior
            .column(&format!("discrepancy_sd.{}", output.output))
            .map_or(f64::NAN, |i| posterior.marginals[i].q50);
        // Three answers: the 90 % interval of the discrepancy leaves out 0
        // (the model misses whatever the parameters); it holds 0 but
        // reaches far beyond the measurement's uncertainty (the data
        // cannot tell the model's error from the parameters'); or it stays
        // within a few measurement uncertainties.
        let largest = d.q05.abs().max(d.q95.abs());
        let verdict = if d.q05 > 0.0 || d.q95 < 0.0 {
            model_errors.push(format!(
                "{} (by {} to {})",
                d.key,
                short(d.q05),
                short(d.q95)
            ));
            "the model misses: no parameter set in the range explains it"
        } else if largest > 3.0 * measurement {
            confounded.push(format!("{} (up to {})", d.key, short(largest)));
            "model or parameters: the data cannot tell"
        } else {
            "within what the measurement can tell"
        };
        table.row(vec![
            d.key.clone(),
            short(d.mean),
            short(d.sd),
            short(d.q05),
            short(d.q95),
            short(tau),
            short(measurement),
            verdict.into(),
        ]);
    }
    report.table(table);
    for output in &density.outputs {
        if let Form::Gp(gp) = &output.form {
            let length = posterior
                .column(&format!("discrepancy_length.{}", output.output))
                .map_or(f64::NAN, |i| posterior.marginals[i].q50);
            report.paragraph(format!(
                "The discrepancy of {} varies over {} (a Gaussian process, correlation length {} of their range, median): at a fit case it is what the measurement there leaves to the model; at a validate case it is predicted from the fit cases near it, and its interval grows back to the scale tau far from them.",
                output.output,
                gp.inputs.join(", "),
                short(length)
            ));
        }
    }
    let mut words = Vec::new();
    if !model_errors.is_empty() {
        words.push(format!(
            "The model, not the parameters, explains the misfit of {}: the 90 % interval of its additive error leaves out zero, so no parameter set in the prior range reproduces the measured value.",
            model_errors.join(", ")
        ));
    }
    if !confounded.is_empty() {
        words.push(format!(
            "For {}, the model may miss by far more than the measurement's uncertainty, but the parameters could also take it up: these cases cannot tell the two apart. A load case that moves the parameters differently from the model's error would.",
            confounded.join(", ")
        ));
    }
    if words.is_empty() {
        words.push("No output needs a model error beyond what the measurement can tell: the parameters explain the misfit.".into());
    }
    report.paragraph(words.join(" "));
}

/// The ASME V&V 20 statement for each validation output, beside the
/// posterior's own answer.
fn write_validation_statement(report: &mut Document, posterior: &PosteriorOutcome) {
    let statements = validation_statements(posterior);
    if statements.is_empty() {
        return;
    }
    report.heading(3, "Validation (ASME V&V 20)");
    let numerical = if posterior.settings.numerical_uncertainty.is_empty() {
        "u_num is taken as 0 (the study states no numerical uncertainty: `mesh_study` or `numerical_uncertainty` under `[posterior]`)"
    } else {
        "u_num the solver's numerical uncertainty (\"u_num from\" says where each came from; 0 where none is stated)"
    };
    report.paragraph(format!(
        "E = S - D, S the model's mean at the predictive runs, D the measured value; u_val = sqrt(u_num^2 + u_input^2 + u_D^2), u_input the spread of the model's values over the posterior's parameters, u_D the measurement's uncertainty, {numerical}. The model's error lies in E +- {COVERAGE_FACTOR} u_val."
    ));
    let mut table = Table::new(&[
        "case",
        "output",
        "S",
        "D",
        "E",
        "u_num",
        "u_num from",
        "u_input",
        "u_D",
        "u_val",
        "model error in",
        "V&V 20",
        "posterior",
    ]);
    let mut disagreements = Vec::new();
    for s in &statements {
        let (low, high) = s.model_error;
        table.row(vec![
            s.case.clone(),
            s.name.clone(),
            short(s.simulated),
            short(s.measured),
            short(s.comparison_error),
            short(s.u_num),
            s.u_num_source.clone(),
            short(s.u_input),
            short(s.u_measured),
            short(s.u_val),
            format!("{} .. {}", short(low), short(high)),
            if s.within {
                "within u_val"
            } else {
                "**model error**"
            }
            .into(),
            if s.predictive_holds {
                "inside 90 %"
            } else {
                "**outside 90 %**"
            }
            .into(),
        ]);
        if s.within != s.predictive_holds {
            disagreements.push(format!("{}/{}", s.case, s.name));
        }
    }
    report.table(table);
    report.paragraph(if disagreements.is_empty() {
        "V&V 20 and the posterior agree on every validation output.".to_string()
    } else {
        format!(
            "They disagree on {}: V&V 20 compares the mean prediction at k = {COVERAGE_FACTOR} with the uncertainties added in quadrature, the posterior draws whole predictions (with the discrepancy, where the study allows one) at 90 %; near the edge the two can fall either side.",
            disagreements.join(", ")
        )
    });
}

/// The predictive intervals against the measured values.
fn write_predictive(report: &mut Document, predicted: &[Predicted]) {
    if predicted.is_empty() {
        return;
    }
    report.heading(3, "Predictions at posterior draws");
    let mut table = Table::new(&[
        "case",
        "role",
        "output",
        "measured",
        "predicted mean",
        "5 %",
        "95 %",
        "model runs",
        "measured inside",
    ]);
    let mut outside = Vec::new();
    let mut validation_outside = 0;
    let mut validation = 0;
    for entry in predicted {
        let (mean, low, high) = entry.interval();
        let inside = entry.holds_measured();
        if entry.role == Role::Validate {
            validation += 1;
            validation_outside += usize::from(!inside);
        }
        if !inside {
            outside.push(format!("{}/{}", entry.case, entry.name));
        }
        table.row(vec![
            entry.case.clone(),
            entry.role.name().into(),
            entry.name.clone(),
            short(entry.measured),
            short(mean),
            short(low),
            short(high),
            entry.model.len().to_string(),
            if inside { "yes" } else { "**no**" }.into(),
        ]);
    }
    report.table(table);
    let fit_outside = predicted
        .iter()
        .any(|p| p.role == Role::Fit && !p.holds_measured());
    let mut words = if outside.is_empty() {
        "Every measured value lies inside its 90 % predictive interval (model runs at posterior draws, plus the discrepancy and the measurement's error).".to_string()
    } else {
        format!(
            "Outside their 90 % predictive interval: {}.",
            outside.join(", ")
        )
    };
    if fit_outside {
        words.push_str(" The model cannot reproduce the fit values within their measurement uncertainty: the parameters' intervals above are those of a model that misses, so read no verdict from them. Allow a model error (`--discrepancy constant`, or `discrepancy` under `[posterior]`), or look for the input or the part of the model that is wrong.");
    }
    if validation > 0 {
        words.push_str(&if validation_outside == 0 {
            " Validation carries over: every validation case's measured value is predicted within the stated uncertainty.".to_string()
        } else {
            format!(
                " Validation does not carry over: {validation_outside} of {validation} validation values fall outside."
            )
        });
    }
    report.paragraph(words);
}

/// Each measured curve with the band the model's curves at the predictive
/// runs span (5 % to 95 % at each x of the measured curve, a simulated
/// curve counting as 0 past its end, as the MAPE does).
fn write_curve_bands(report: &mut Document, curves: &[PredictedCurve]) {
    for (index, curve) in curves.iter().enumerate() {
        if curve.runs.is_empty() {
            report.paragraph(format!(
                "{}/{}: the model's curves at the predictive runs could not be read back, so no band is drawn.",
                curve.case, curve.name
            ));
            continue;
        }
        let step = (curve.measured.len() / 200).max(1);
        let xs: Vec<f64> = curve.measured.iter().step_by(step).map(|p| p.0).collect();
        let mut bands = [Vec::new(), Vec::new(), Vec::new()];
        for &x in &xs {
            let mut values: Vec<f64> = curve.runs.iter().map(|run| value_at(run, x)).collect();
            values.sort_by(f64::total_cmp);
            for (band, p) in bands.iter_mut().zip([0.05, 0.5, 0.95]) {
                band.push((x, quantile(&values, p)));
            }
        }
        // The band as the error against the measured curve, %, where the
        // band is too narrow to see on the curve itself.
        let measured_at: Vec<f64> = xs.iter().map(|&x| value_at(&curve.measured, x)).collect();
        let relative = |band: &[(f64, f64)]| -> Vec<(f64, f64)> {
            band.iter()
                .zip(&measured_at)
                .map(|(&(x, y), &m)| {
                    (
                        x,
                        if m.abs() > 0.0 {
                            100.0 * (y - m) / m
                        } else {
                            f64::NAN
                        },
                    )
                })
                .collect()
        };
        let errors = Chart::new(
            "model against measured",
            curve.axes[0].clone(),
            "model - measured [% of measured]",
        )
        .with_series(Series::new("model, median", relative(&bands[1])))
        .with_series(Series::new("model, 5 %", relative(&bands[0])).with_style(SeriesStyle::Dashed))
        .with_series(
            Series::new("model, 95 %", relative(&bands[2])).with_style(SeriesStyle::Dashed),
        )
        .with_reference_line(0.0, "measured");
        let [low, middle, high] = bands;
        let mut mape = curve.mape_pct.clone();
        mape.sort_by(f64::total_cmp);
        let chart = Chart::new(
            "measured and predicted",
            curve.axes[0].clone(),
            curve.axes[1].clone(),
        )
        .with_series(Series::new("measured", curve.measured.clone()))
        .with_series(Series::new("model, median", middle))
        .with_series(Series::new("model, 5 %", low).with_style(SeriesStyle::Dashed))
        .with_series(Series::new("model, 95 %", high).with_style(SeriesStyle::Dashed));
        report.figure(Figure {
            file: format!("posterior_band_{}.svg", index + 1),
            caption: format!(
                "{}/{} ({}): the model's curves at {} posterior draws, 5 % to 95 % at each x; their MAPE {:.2} % to {:.2} % (5 % to 95 %)",
                curve.case,
                curve.name,
                curve.role.name(),
                curve.runs.len(),
                quantile(&mape, 0.05),
                quantile(&mape, 0.95)
            ),
            svg: grid_svg(
                &format!("{}/{}", curve.case, curve.name),
                &[chart, errors],
                2,
                520.0,
                380.0,
            ),
        });
    }
}

/// A curve's y at `x` by linear interpolation; 0 past its end (as the
/// MAPE counts a simulation that stopped), its first y before its start.
fn value_at(curve: &[(f64, f64)], x: f64) -> f64 {
    let Some(last) = curve.last() else {
        return f64::NAN;
    };
    if x > last.0 {
        return 0.0;
    }
    match curve.iter().position(|p| p.0 >= x) {
        Some(0) | None => curve[0].1,
        Some(k) => {
            let (a, b) = (curve[k - 1], curve[k]);
            if b.0 == a.0 {
                b.1
            } else {
                a.1 + (b.1 - a.1) * (x - a.0) / (b.0 - a.0)
            }
        }
    }
}

/// Points drawn per chain in a trace: enough to see a drift or a stuck
/// stretch, few enough for a light page.
const TRACE_POINTS: usize = 400;
/// Bins of a rank plot.
const RANK_BINS: usize = 20;

/// Per parameter, a trace (draw index against value, a line per chain)
/// and a rank plot (each chain's count of draws per bin of their ranks
/// among all draws, with the count a uniform spread gives).
fn trace_and_rank_svg(posterior: &PosteriorOutcome) -> String {
    let shown: Vec<usize> = (0..posterior.names.len())
        .filter(|&i| !posterior.names[i].starts_with("discrepancy_sd."))
        .collect();
    let chains = posterior.draws.len();
    let draws = posterior.draws.first().map_or(0, Vec::len);
    let step = (draws / TRACE_POINTS).max(1);
    let mut panels = Vec::new();
    for &i in &shown {
        let name = &posterior.names[i];
        let mut trace = Chart::new(format!("{name}: trace"), "draw", name.clone());
        for (c, chain) in posterior.draws.iter().enumerate() {
            let points = chain
                .iter()
                .enumerate()
                .step_by(step)
                .map(|(k, d)| (k as f64, d[i]))
                .collect();
            trace = trace.with_series(Series::new(format!("chain {}", c + 1), points));
        }
        panels.push(trace);
        let mut pooled: Vec<(f64, usize)> = posterior
            .draws
            .iter()
            .enumerate()
            .flat_map(|(c, chain)| chain.iter().map(move |d| (d[i], c)))
            .collect();
        pooled.sort_by(|a, b| a.0.total_cmp(&b.0));
        let total = pooled.len().max(1);
        let mut counts = vec![vec![0usize; RANK_BINS]; chains];
        for (rank, (_, c)) in pooled.iter().enumerate() {
            counts[*c][rank * RANK_BINS / total] += 1;
        }
        let mut rank = Chart::new(format!("{name}: ranks"), "rank bin (of all draws)", "draws")
            .with_reference_line(draws as f64 / RANK_BINS as f64, "uniform");
        for (c, bins) in counts.iter().enumerate() {
            let points = bins
                .iter()
                .enumerate()
                .flat_map(|(b, n)| [(b as f64, *n as f64), ((b + 1) as f64, *n as f64)])
                .collect();
            rank = rank.with_series(Series::new(format!("chain {}", c + 1), points));
        }
        let top = counts.iter().flatten().copied().max().unwrap_or(0) as f64;
        let uniform = draws as f64 / RANK_BINS as f64;
        // From zero, so a chain's shortfall shows at its true size.
        panels.push(rank.with_y_range(0.0, 1.1 * top.max(uniform).max(1.0)));
    }
    grid_svg("chains", &panels, 2, 360.0, 200.0)
}

/// Pairwise draws and marginal histograms over each coordinate's prior
/// range (the discrepancy scales left out: they are stated above).
fn corner_svg(posterior: &PosteriorOutcome) -> String {
    let shown: Vec<usize> = (0..posterior.names.len())
        .filter(|&i| !posterior.names[i].starts_with("discrepancy_sd."))
        .collect();
    let draws: Vec<&Vec<f64>> = posterior.draws.iter().flatten().collect();
    let step = (draws.len() / CORNER_POINTS).max(1);
    // Each axis spans the draws (0.5 % to 99.5 %, widened by a tenth),
    // or the prior range where they fill half of it; the title says
    // which.
    let prior = |i: usize| match posterior.supports[i] {
        Support::Interval { lower, upper } => Some((lower, upper)),
        _ => None,
    };
    let range = |i: usize| {
        let mut values: Vec<f64> = draws.iter().map(|d| d[i]).collect();
        values.sort_by(f64::total_cmp);
        let (low, high) = (quantile(&values, 0.005), quantile(&values, 0.995));
        let pad = 0.1 * (high - low).max(1e-12 * low.abs().max(1.0));
        match prior(i) {
            Some((lower, upper)) if high - low >= 0.5 * (upper - lower) => (lower, upper),
            Some((lower, upper)) => ((low - pad).max(lower), (high + pad).min(upper)),
            None => (low - pad, high + pad),
        }
    };
    let name = |i: usize| posterior.names[i].clone();
    let title = |i: usize| match prior(i) {
        Some((lower, upper)) if range(i) != (lower, upper) => {
            format!("{}, prior {}-{}", name(i), trimmed(lower), trimmed(upper))
        }
        _ => name(i),
    };
    let mut panels = Vec::new();
    for &row in &shown {
        for &column in &shown {
            panels.push(if column > row {
                None
            } else if column == row {
                let (low, high) = range(row);
                let densities = histogram(draws.iter().map(|d| d[row]), low, high, 30);
                // From zero: a density axis cut above it exaggerates its shape.
                let top = densities.iter().map(|(_, y)| *y).fold(0.0, f64::max);
                Some(
                    Chart::new(title(row), name(row), "density")
                        .with_series(Series::new("", densities))
                        .with_x_range(low, high)
                        .with_y_range(0.0, 1.05 * top.max(f64::MIN_POSITIVE)),
                )
            } else {
                let (x_low, x_high) = range(column);
                let (y_low, y_high) = range(row);
                let points = draws
                    .iter()
                    .step_by(step)
                    .map(|d| (d[column], d[row]))
                    .collect();
                Some(
                    Chart::new("", name(column), name(row))
                        .with_series(Series::new("", points).with_style(SeriesStyle::Markers))
                        .with_x_range(x_low, x_high)
                        .with_y_range(y_low, y_high),
                )
            });
        }
    }
    let size = if shown.len() > 4 { 200.0 } else { 260.0 };
    sparse_grid_svg("posterior", &panels, shown.len(), size, size)
}

/// `value` in at most four significant digits, without trailing zeros.
fn trimmed(value: f64) -> String {
    let text = short(value);
    if text.contains('.') && !text.contains('e') {
        text.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        text
    }
}

/// A histogram as a step line of densities over `bins` equal bins.
fn histogram(
    values: impl Iterator<Item = f64>,
    low: f64,
    high: f64,
    bins: usize,
) -> Vec<(f64, f64)> {
    let mut counts = vec![0usize; bins];
    let mut total = 0usize;
    let width = (high - low) / bins as f64;
    for value in values {
        total += 1;
        if width > 0.0 && (low..=high).contains(&value) {
            counts[(((value - low) / width) as usize).min(bins - 1)] += 1;
        }
    }
    let mut points = Vec::with_capacity(2 * bins);
    for (k, &count) in counts.iter().enumerate() {
        let height = count as f64 / (total.max(1) as f64 * width);
        points.push((low + k as f64 * width, height));
        points.push((low + (k + 1) as f64 * width, height));
    }
    points
}

fn list_or(names: &[&str], none: &str) -> String {
    if names.is_empty() {
        none.to_string()
    } else {
        names.join(", ")
    }
}

/// Four significant digits.
fn short(value: f64) -> String {
    if !value.is_finite() {
        return "-".into();
    }
    let magnitude = value.abs();
    if magnitude == 0.0 {
        return "0".into();
    }
    if !(1e-3..1e6).contains(&magnitude) {
        format!("{value:.3e}")
    } else {
        let decimals = (3 - magnitude.log10().floor() as i32).clamp(0, 6) as usize;
        format!("{value:.decimals$}")
    }
}

#[cfg(test)]
mod tests {
    use super::{coverage_caveat, short, trimmed, CurveMetric};

    #[test]
    fn a_curve_scored_by_the_area_is_named_for_its_too_narrow_intervals_and_no_other_is() {
        assert_eq!(
            coverage_caveat(&[
                ("loop", CurveMetric::Dtw),
                ("pull", CurveMetric::Mape),
                ("cycle", CurveMetric::Pcm),
                ("hold", CurveMetric::Frechet),
            ]),
            None
        );
        let caveat = coverage_caveat(&[
            ("loop", CurveMetric::Area),
            ("pull", CurveMetric::Mape),
            ("cycle", CurveMetric::Area),
        ])
        .unwrap();
        assert!(
            caveat.contains("`loop` (area), `cycle` (area) are scored"),
            "{caveat}"
        );
        assert!(!caveat.contains("pull"), "{caveat}");
        let one = coverage_caveat(&[("a", CurveMetric::Area)]).unwrap();
        assert!(one.contains("`a` (area) is scored"), "{one}");
    }

    #[test]
    fn numbers_are_written_with_four_significant_digits_and_zero_as_zero() {
        assert_eq!(short(0.0), "0");
        assert_eq!(short(-0.0), "0");
        assert_eq!(short(123.456), "123.5");
        assert_eq!(short(0.012345), "0.01235");
        assert_eq!(short(2.5e-5), "2.500e-5");
        assert_eq!(short(f64::NAN), "-");
        assert_eq!(trimmed(0.25), "0.25");
        assert_eq!(trimmed(800.0), "800");
        assert_eq!(trimmed(2.5e-5), "2.500e-5");
    }
}
