//! The validation statement test engineers already know (ASME V&V 20):
//! for each validation case and output, the comparison error `E = S - D`
//! (simulation less measurement) and the validation uncertainty
//! `u_val = sqrt(u_num^2 + u_input^2 + u_D^2)`; the model's own error then
//! lies in `E +- k u_val` (k = 2, about 95 %).
//!
//! - `S`: the mean of the model's values at the predictive runs (the
//!   calibrated model's prediction, its parameters drawn from the
//!   posterior);
//! - `u_input`: their standard deviation, the parameters' uncertainty
//!   carried through the model (the study's uncertain inputs are its
//!   parameters);
//! - `u_D`: the measurement's stated uncertainty, or the posterior's
//!   noise scale;
//! - `u_num`: the solver's numerical uncertainty, from a mesh study: a
//!   spec states it per validate value (`[posterior]
//!   numerical_uncertainty`, from the user's own mesh study of their
//!   solver); where none is stated it is taken as 0 and the report says so.
//!
//! Beside it stands the posterior's own answer: whether the measured value
//! lies in its 90 % predictive interval, which also carries the
//! discrepancy. Where the two disagree the report says why.

use super::predictive::Predicted;
use super::PosteriorOutcome;
use crate::study::Role;

/// The coverage factor of the model error's interval.
pub const COVERAGE_FACTOR: f64 = 2.0;

/// One validation output's statement.
#[derive(Clone, Debug, PartialEq)]
pub struct ValidationStatement {
    pub case: String,
    pub name: String,
    /// `S` and `D`.
    pub simulated: f64,
    pub measured: f64,
    /// `E = S - D`.
    pub comparison_error: f64,
    pub u_num: f64,
    /// Where `u_num` came from: the spec, a mesh study, or nowhere (0).
    pub u_num_source: String,
    pub u_input: f64,
    pub u_measured: f64,
    /// `sqrt(u_num^2 + u_input^2 + u_D^2)`.
    pub u_val: f64,
    /// `E +- k u_val`: where the model's error lies.
    pub model_error: (f64, f64),
    /// `|E| <= k u_val`: no model error the validation can tell.
    pub within: bool,
    /// The posterior's answer: the measured value in its 90 % predictive
    /// interval.
    pub predictive_holds: bool,
}

/// The statement for every scalar output of every validation case.
pub fn validation_statements(posterior: &PosteriorOutcome) -> Vec<ValidationStatement> {
    let noise_pct = posterior
        .column("measurement_noise_pct")
        .map(|i| posterior.marginals[i].q50);
    posterior
        .predicted
        .scalars
        .iter()
        .filter(|p| p.role == Role::Validate && p.model.len() >= 2)
        .map(|p| statement(p, posterior, noise_pct))
        .collect()
}

fn statement(
    predicted: &Predicted,
    posterior: &PosteriorOutcome,
    noise_pct: Option<f64>,
) -> ValidationStatement {
    let n = predicted.model.len() as f64;
    let simulated = predicted.model.iter().sum::<f64>() / n;
    let u_input = (predicted
        .model
        .iter()
        .map(|v| (v - simulated).powi(2))
        .sum::<f64>()
        / (n - 1.0))
        .sqrt();
    let u_measured =
        posterior
            .density
            .measurement_sd(noise_pct, predicted.measured, predicted.uncertainty);
    // A mesh study's u_num is the case's own (`case/name`); one stated in
    // the spec is by name.
    let settings = &posterior.settings;
    let key = [
        format!("{}/{}", predicted.case, predicted.name),
        predicted.name.clone(),
    ]
    .into_iter()
    .find(|key| settings.numerical_uncertainty.iter().any(|(k, _)| k == key));
    let u_num = key.as_ref().map_or(0.0, |key| {
        settings
            .numerical_uncertainty
            .iter()
            .find(|(k, _)| k == key)
            .map_or(0.0, |(_, u)| *u)
    });
    let u_num_source = key
        .and_then(|key| {
            settings
                .numerical_uncertainty_sources
                .iter()
                .find(|(k, _)| *k == key)
                .map(|(_, source)| source.clone())
        })
        .unwrap_or_else(|| "none stated (0)".into());
    let u_val = (u_num * u_num + u_input * u_input + u_measured * u_measured).sqrt();
    let comparison_error = simulated - predicted.measured;
    ValidationStatement {
        case: predicted.case.clone(),
        name: predicted.name.clone(),
        simulated,
        measured: predicted.measured,
        comparison_error,
        u_num,
        u_num_source,
        u_input,
        u_measured,
        u_val,
        model_error: (
            comparison_error - COVERAGE_FACTOR * u_val,
            comparison_error + COVERAGE_FACTOR * u_val,
        ),
        within: comparison_error.abs() <= COVERAGE_FACTOR * u_val,
        predictive_holds: predicted.holds_measured(),
    }
}
