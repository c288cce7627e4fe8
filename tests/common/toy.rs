//! Toy studies the posterior's tests and benchmarks share (also compiled
//! into `benches/posterior.rs` by path).

use acq_algorithms::evaluation::Parameter;
use acq_study::study::{
    Case, LossKind, Measured, Observation, Residuals, Role, Study, StudyParameter,
};

/// A study of one output `y` measured at several `x`, one case each (so a
/// constant discrepancy is shared by them all), with known uncertainty.
pub fn toy_study(parameters: &[(&str, f64, f64)], measured: &[(f64, f64)], sd: f64) -> Study {
    Study {
        parameters: toy_parameters(parameters),
        cases: measured
            .iter()
            .enumerate()
            .map(|(i, &(x, y))| Case {
                inputs: vec![("x".into(), x)],
                ..Case::new(
                    format!("x{i}"),
                    Role::Fit,
                    vec![Observation {
                        name: "y".into(),
                        output: "y".into(),
                        measured: Measured::Scalar {
                            value: y,
                            uncertainty: Some(sd),
                        },
                        weight: 1.0,
                        source: String::new(),
                        shared: Vec::new(),
                    }],
                )
            })
            .collect(),
        named_cases: true,
        residuals: Residuals::Normalised,
        loss: LossKind::Squares,
    }
}

/// Shared parameters `(name, lower, upper)`, each nominal in its middle.
pub fn toy_parameters(parameters: &[(&str, f64, f64)]) -> Vec<StudyParameter> {
    parameters
        .iter()
        .map(|&(name, lower, upper)| StudyParameter {
            search: Parameter::new(name, lower, upper),
            input: name.into(),
            case: None,
            nominal: (lower + upper) / 2.0,
            prior: None,
        })
        .collect()
}

/// A model run's input by name, or which is missing.
pub fn input(inputs: &[(String, f64)], name: &str) -> Result<f64, String> {
    inputs
        .iter()
        .find(|(n, _)| n == name)
        .map(|(_, v)| *v)
        .ok_or_else(|| format!("no input {name}"))
}
