//! The [`Study`] a spec defines: its cases with their observations (read
//! from the spec and the files it names), its parameters (shared, or one
//! case's own, with priors), and the checks that need them all (every
//! value can be scored the way `[search]` asks).

use std::path::Path;

use acq_algorithms::evaluation::Parameter;

use super::model::ModelKind;
use super::observations::{
    case_observation, measured_curve, metric_of, scalar, scoreable, weight_of,
};
use super::problem::SpecProblem;
use super::schema::SpecFile;
use crate::study::{Case, Measured, Observation, Prior, Residuals, Role, Study, StudyParameter};

/// The study of a spec whose sections have passed [`super::checks`];
/// `command`: its model is the spec's command (which needs its
/// `output_file`), not a built-in twin or a model the caller brings.
pub fn study(
    file: &SpecFile,
    spec_directory: &Path,
    model: &ModelKind,
) -> Result<Study, SpecProblem> {
    let command = matches!(model, ModelKind::Command(_));
    let mut cases = if file.cases.is_empty() {
        vec![implicit_case(file, spec_directory)?]
    } else {
        named_cases(file, spec_directory, model)?
    };
    if cases.iter().all(|c| c.role != Role::Fit) {
        return Err(SpecProblem::file(
            "every case is a validate case; the search needs at least one fit case",
        ));
    }
    let needs_output_file = cases.iter().any(|c| {
        c.observations
            .iter()
            .any(|o| matches!(o.measured, Measured::Scalar { .. }))
    });
    if needs_output_file && file.output_file.is_empty() && command {
        return Err(SpecProblem::file(
            "output_file: name the file the command writes its outputs to",
        ));
    }
    let parameters = parameters(file, &cases)?;
    if let Some(priors) = Case::priors(&parameters) {
        if let Some(index) = file.cases.iter().position(|c| c.name == priors.name) {
            return Err(SpecProblem::table(
                "[[case]]",
                index,
                "the case name \"prior\" is taken by the parameters' priors; rename the case",
            ));
        }
        if file.search.residuals != Residuals::Normalised {
            return Err(SpecProblem::file(
                "a [[parameter]] prior is a penalty in standard deviations: set search.residuals = \"normalised\" (and give the measured values their uncertainties)",
            ));
        }
        cases.push(priors);
    }
    let search_parameters: Vec<Parameter> = parameters.iter().map(|p| p.search.clone()).collect();
    acq_algorithms::evaluation::validate_parameters(&search_parameters)
        .map_err(|e| SpecProblem::file(e.to_string()))?;
    scorable(&cases, file.search.residuals)?;
    Ok(Study {
        parameters,
        named_cases: !file.cases.is_empty(),
        cases,
        residuals: file.search.residuals,
        loss: file.search.loss,
    })
}

/// Without `[[case]]`: one fit case of the `[[output]]`s and `[[curve]]`s.
fn implicit_case(file: &SpecFile, spec_directory: &Path) -> Result<Case, SpecProblem> {
    let mut observations = Vec::new();
    for (index, o) in file.outputs.iter().enumerate() {
        let here = |message: String| SpecProblem::table("[[output]]", index, message);
        let weight = weight_of(o.weight, &o.name).map_err(here)?;
        observations.push(
            scalar(&o.name, o.measured, o.uncertainty, weight, "spec".into())
                .map_err(|e| here(format!("output {e}")))?,
        );
    }
    for (index, c) in file.curves.iter().enumerate() {
        let here = |message: String| SpecProblem::table("[[curve]]", index, message);
        let (Some(measured_file), Some(x), Some(y)) =
            (&c.measured_file, &c.measured_x, &c.measured_y)
        else {
            return Err(here(format!(
                "curve {}: give measured_file, measured_x and measured_y (the measured curve to compare with)",
                c.name
            )));
        };
        let weight = weight_of(c.weight, &c.name).map_err(here)?;
        let metric = metric_of(c.metric.as_deref(), &c.name).map_err(here)?;
        let points = measured_curve(spec_directory, &c.name, measured_file, x, y)
            .map_err(SpecProblem::malformed)?;
        scoreable(&c.name, measured_file, metric, &points).map_err(here)?;
        observations.push(Observation {
            name: c.name.clone(),
            output: c.name.clone(),
            measured: Measured::Curve {
                points,
                axes: c.axes(x, y),
                metric,
            },
            weight,
            source: measured_file.clone(),
            shared: Vec::new(),
        });
    }
    Ok(Case {
        name: "the test".into(),
        role: Role::Fit,
        inputs: Vec::new(),
        observations,
        priors: false,
    })
}

/// The `[[case]]`s, each with its role, fixed inputs and observations.
fn named_cases(
    file: &SpecFile,
    spec_directory: &Path,
    model: &ModelKind,
) -> Result<Vec<Case>, SpecProblem> {
    for (index, c) in file.curves.iter().enumerate() {
        if c.measured_file.is_some() {
            return Err(SpecProblem::table(
                "[[curve]]",
                index,
                format!("curve {}: with [[case]], the measured curve goes in each case's measured table ({} = {{ file = ..., x = ..., y = ... }})", c.name, c.name),
            ));
        }
    }
    // A built-in model's own curve, in its units.
    let builtin_curve_units = match model {
        ModelKind::Builtin(builtin) => builtin.curve_units,
        _ => None,
    };
    let mut cases = Vec::new();
    for (index, c) in file.cases.iter().enumerate() {
        let here = |message: String| {
            SpecProblem::table("[[case]]", index, format!("case {}: {message}", c.name))
        };
        if c.name.is_empty() || c.name.contains(['/', ',', '"', '\n']) {
            return Err(here(
                "give a name of letters, digits and underscores".into(),
            ));
        }
        if file.cases[..index].iter().any(|d| d.name == c.name) {
            return Err(here("the name is given twice".into()));
        }
        if c.measured.is_empty() {
            return Err(here(format!(
                "no measured values; a {} case needs at least one observation",
                c.role.name()
            )));
        }
        for (name, value) in &c.inputs {
            if !value.is_finite() {
                return Err(here(format!(
                    "input {name} = {value}; give a finite number"
                )));
            }
            let calibrated_here = file
                .parameters
                .iter()
                .any(|p| &p.name == name && p.case.as_ref().is_none_or(|case| case == &c.name));
            if calibrated_here {
                return Err(here(format!(
                    "input {name} is also a [[parameter]]; a value is either fixed or calibrated"
                )));
            }
        }
        let observations = c
            .measured
            .iter()
            .map(|(name, entry)| {
                case_observation(
                    &file.curves,
                    builtin_curve_units,
                    spec_directory,
                    name,
                    entry,
                )
            })
            .collect::<Result<Vec<_>, _>>()
            .map_err(|e| here(format!("measured {e}")))?;
        cases.push(Case {
            name: c.name.clone(),
            role: c.role,
            inputs: c.inputs.iter().map(|(k, v)| (k.clone(), *v)).collect(),
            observations,
            priors: false,
        });
    }
    Ok(cases)
}

/// The `[[parameter]]`s: shared, or one fit case's own.
/// The largest bound a parameter may have, in size.
pub const MAX_BOUND: f64 = 1e100;

pub fn parameters(file: &SpecFile, cases: &[Case]) -> Result<Vec<StudyParameter>, SpecProblem> {
    let mut parameters = Vec::new();
    for (index, p) in file.parameters.iter().enumerate() {
        let here = |message: String| {
            SpecProblem::table(
                "[[parameter]]",
                index,
                format!("parameter {}: {message}", p.name),
            )
        };
        let case = match &p.case {
            None => None,
            Some(name) => {
                let Some(found) = cases.iter().position(|c| &c.name == name) else {
                    return Err(here(format!(
                        "case = {name:?} names no [[case]]; the cases are {}",
                        cases
                            .iter()
                            .map(|c| c.name.as_str())
                            .collect::<Vec<_>>()
                            .join(", ")
                    )));
                };
                if cases[found].role == Role::Validate {
                    return Err(here(format!(
                        "case {name} is a validate case, which the search never sees; give its value as a fixed input"
                    )));
                }
                Some(found)
            }
        };
        // The bounds first: a nominal outside them may be their mistake.
        // A bound past 1e100 is no physical number, and its arithmetic
        // (the range, the midpoint) overflows to inf and NaN.
        if !(p.lower.is_finite()
            && p.upper.is_finite()
            && p.lower < p.upper
            && p.lower.abs() <= MAX_BOUND
            && p.upper.abs() <= MAX_BOUND)
        {
            return Err(here(format!(
                "lower = {}, upper = {}: give finite bounds with lower below upper, each at most {MAX_BOUND:e} in size",
                p.lower, p.upper
            )));
        }
        if p.scale == acq_algorithms::evaluation::Scale::Log && p.lower <= 0.0 {
            return Err(here(format!(
                "scale = \"log\" needs lower above 0 (equal steps in ratio), got lower = {}; give a positive lower bound or scale = \"linear\"",
                p.lower
            )));
        }
        let search_name = match &p.case {
            Some(case) => format!("{case}/{}", p.name),
            None => p.name.clone(),
        };
        let search = Parameter::new(search_name, p.lower, p.upper).with_scale(p.scale);
        // Without a nominal, a prior's value (where the parameter is
        // expected), else the middle of the range.
        let nominal = p
            .nominal
            .or(p.prior.as_ref().map(|prior| prior.value))
            .unwrap_or_else(|| search.midpoint());
        if !(nominal >= p.lower && nominal <= p.upper) {
            // Name where the value came from: the user may not have
            // written a nominal at all.
            let from = if p.nominal.is_some() {
                "nominal"
            } else {
                "the prior's value (the nominal where none is given)"
            };
            return Err(here(format!(
                "{from} = {nominal} lies outside the bounds {} .. {}",
                p.lower, p.upper
            )));
        }
        let prior = match &p.prior {
            None => None,
            Some(prior)
                if prior.value.is_finite()
                    && prior.uncertainty.is_finite()
                    && prior.uncertainty > 0.0 =>
            {
                Some(Prior {
                    value: prior.value,
                    uncertainty: prior.uncertainty,
                })
            }
            Some(prior) => {
                return Err(here(format!(
                    "prior = {{ value = {}, uncertainty = {} }}: give a finite value and an uncertainty above 0",
                    prior.value, prior.uncertainty
                )))
            }
        };
        parameters.push(StudyParameter {
            search,
            input: p.name.clone(),
            case,
            nominal,
            prior,
        });
    }
    for (index, p) in file.parameters.iter().enumerate() {
        let clash = file.parameters[..index].iter().any(|q| {
            q.name == p.name && (q.case.is_none() || p.case.is_none() || q.case == p.case)
        });
        if clash {
            return Err(SpecProblem::table(
                "[[parameter]]",
                index,
                format!("parameter {} is listed twice for the same case", p.name),
            ));
        }
    }
    Ok(parameters)
}

/// Every scalar can be scored as `residuals` asks: normalised residuals
/// divide by an uncertainty, relative errors by the value.
fn scorable(cases: &[Case], residuals: Residuals) -> Result<(), SpecProblem> {
    let find = |unscorable: &dyn Fn(&Measured) -> bool| {
        cases.iter().find_map(|c| {
            c.observations
                .iter()
                .find(|o| unscorable(&o.measured))
                .map(|o| (c, o))
        })
    };
    match residuals {
        Residuals::Normalised => {
            let without = find(&|m| {
                matches!(
                    m,
                    Measured::Scalar {
                        uncertainty: None,
                        ..
                    }
                )
            });
            if let Some((case, o)) = without {
                return Err(SpecProblem::file(format!(
                    "search.residuals = \"normalised\" divides by each value's uncertainty, and {} of {} has none; give it one",
                    o.name, case.name
                )));
            }
        }
        Residuals::Relative => {
            let zero = find(&|m| matches!(m, Measured::Scalar { value, .. } if *value == 0.0));
            if let Some((case, o)) = zero {
                return Err(SpecProblem::file(format!(
                    "{} of {} is measured as 0, and relative errors divide by it; use search.residuals = \"normalised\" (its uncertainty is the scale)",
                    o.name, case.name
                )));
            }
        }
    }
    Ok(())
}
