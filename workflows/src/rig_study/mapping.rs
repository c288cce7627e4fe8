//! `[holds]`: how a hold's measured values become a load case.
//!
//! Each entry of `[holds.inputs]` (the model's inputs, by input name) and
//! `[holds.observe]` (the observations, by the model's output name) is
//! - a number: an input fixed for every hold (inputs only);
//! - a quantity's name: its mean in the hold, with its standard error;
//! - `{ quantity, uncertainty, instrument }`: `uncertainty` is
//!   `"std_of_mean"` (the default: the value's budget, the std over the
//!   square root of the effective sample count with the sensors'
//!   certificates and accuracy where the rig states them),
//!   `"scatter_of_mean"` (that standard error alone), `"std"` (the spread
//!   of the readings) or a number in the quantity's unit; `instrument` (0
//!   by default) is the transducer's own standard uncertainty
//!   (calibration, linearity, zero offset), added in quadrature.
//!
//! A sensor's certificate and accuracy error and a stated `instrument`
//! are the same in every hold: they are shared errors of every hold's
//! value (one error per sensor, or per quantity for `instrument`), which
//! the posterior does not average away.
//!
//! The quantities are those of `acq extract` (each sensor, and each
//! cylinder's `_net_force` and `_loaded_pressure`); a hold in which one of
//! them is missing or flagged is not used, and the page says why.

use acq_analysis::extract::measured::{MeasuredValue, UncertaintyBasis};
use acq_analysis::extract::quantities::RigQuantities;
use acq_metrology::budget::SharedError;

use acq_study::spec::schema::HoldsSpec;
use acq_study::spec::SpecProblem;

/// Where an uncertainty comes from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Spread {
    /// The value's budget (the standard error of the hold's mean with the
    /// sensors' Type B sources, each sensor's shared by every hold).
    StdOfMean,
    /// The standard error of the hold's mean alone.
    ScatterOfMean,
    /// The spread of the readings in the hold.
    Std,
    /// A stated standard uncertainty, in the quantity's unit.
    Stated(f64),
}

/// A value read from a hold.
#[derive(Clone, Debug, PartialEq)]
pub struct FromHold {
    pub quantity: String,
    pub spread: Spread,
    /// The transducer's standard uncertainty, added in quadrature, the
    /// same error in every hold.
    pub instrument: f64,
}

/// A value read from a hold: its mean, its standard uncertainty, and the
/// parts of that which every hold shares.
#[derive(Clone, Debug, PartialEq)]
pub struct HoldValue {
    pub mean: f64,
    pub standard_uncertainty: f64,
    pub shared: Vec<SharedError>,
}

/// Where an input's value comes from.
#[derive(Clone, Debug, PartialEq)]
pub enum InputSource {
    Fixed(f64),
    Measured(FromHold),
}

/// The `[holds]` table, checked.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct HoldMapping {
    /// By input name, in the file's (sorted) order.
    pub inputs: Vec<(String, InputSource)>,
    /// By the model's output name.
    pub observations: Vec<(String, FromHold)>,
}

/// One hold read through the mapping.
#[derive(Clone, Debug, PartialEq)]
pub struct HoldReading {
    pub name: String,
    /// Each input: its value and standard uncertainty (0 when fixed).
    pub inputs: Vec<(String, f64, f64)>,
    /// Each observation: its mean and standard uncertainty.
    pub observations: Vec<(String, f64, f64)>,
    /// Each observation's errors shared with every other hold (its
    /// sensors'), in the order of `observations`.
    pub shared: Vec<Vec<SharedError>>,
}

const INPUTS: &str = "[holds.inputs]";
const OBSERVE: &str = "[holds.observe]";

impl FromHold {
    fn parse(value: &toml::Value) -> Result<FromHold, String> {
        match value {
            toml::Value::String(quantity) => Ok(FromHold {
                quantity: quantity.clone(),
                spread: Spread::StdOfMean,
                instrument: 0.0,
            }),
            toml::Value::Table(table) => {
                if let Some(key) = table
                    .keys()
                    .find(|k| !["quantity", "uncertainty", "instrument"].contains(&k.as_str()))
                {
                    return Err(format!(
                        "unknown key {key:?}; give quantity, and optionally uncertainty and instrument"
                    ));
                }
                let quantity = table
                    .get("quantity")
                    .and_then(toml::Value::as_str)
                    .ok_or("give quantity = \"NAME\", the hold quantity it is read from")?
                    .to_string();
                let spread = match table.get("uncertainty") {
                    None => Spread::StdOfMean,
                    Some(toml::Value::String(s)) if s == "std_of_mean" => Spread::StdOfMean,
                    Some(toml::Value::String(s)) if s == "scatter_of_mean" => {
                        Spread::ScatterOfMean
                    }
                    Some(toml::Value::String(s)) if s == "std" => Spread::Std,
                    Some(value) => match number(value) {
                        Some(u) if u > 0.0 && u.is_finite() => Spread::Stated(u),
                        _ => {
                            return Err(format!(
                                "uncertainty = {value}; give \"std_of_mean\", \"scatter_of_mean\", \"std\" or a positive number in the quantity's unit"
                            ))
                        }
                    },
                };
                let instrument = match table.get("instrument") {
                    None => 0.0,
                    Some(value) => match number(value) {
                        Some(u) if u >= 0.0 && u.is_finite() => u,
                        _ => {
                            return Err(format!(
                                "instrument = {value}; give the transducer's standard uncertainty, a number of at least 0 in the quantity's unit"
                            ))
                        }
                    },
                };
                Ok(FromHold {
                    quantity,
                    spread,
                    instrument,
                })
            }
            other => Err(format!(
                "{other} is neither a quantity's name nor {{ quantity = ..., uncertainty = ..., instrument = ... }}"
            )),
        }
    }

    /// Its mean and standard uncertainty in a hold's values.
    pub fn read(&self, values: &[MeasuredValue]) -> Result<HoldValue, String> {
        let value = values
            .iter()
            .find(|v| v.quantity == self.quantity)
            .ok_or_else(|| format!("{} is not in the hold", self.quantity))?;
        if !value.flags.is_empty() {
            return Err(format!(
                "{} is flagged ({})",
                self.quantity,
                value.flags.join(", ")
            ));
        }
        let mean = value
            .stats
            .mean
            .filter(|m| m.is_finite())
            .ok_or_else(|| format!("{} has no value in the hold", self.quantity))?;
        let basis = |basis| {
            value
                .standard_uncertainty(basis)
                .unwrap_or((0.0, Vec::new()))
        };
        let (spread, mut shared) = match self.spread {
            Spread::Stated(u) => (u, Vec::new()),
            Spread::Std => (value.stats.std.unwrap_or(0.0), Vec::new()),
            Spread::StdOfMean => basis(UncertaintyBasis::Budget),
            Spread::ScatterOfMean => basis(UncertaintyBasis::ReadingsScatter),
        };
        let total = spread.hypot(self.instrument);
        if !(total > 0.0 && total.is_finite()) {
            return Err(format!(
                "{} has no spread in the hold (a constant reading); give it an instrument uncertainty",
                self.quantity
            ));
        }
        if self.instrument > 0.0 {
            shared.push(SharedError {
                source: format!("{} instrument", self.quantity),
                effect: self.instrument,
            });
        }
        Ok(HoldValue {
            mean,
            standard_uncertainty: total,
            shared,
        })
    }
}

fn number(value: &toml::Value) -> Option<f64> {
    value
        .as_float()
        .or_else(|| value.as_integer().map(|i| i as f64))
}

impl HoldMapping {
    /// The `[holds]` table as written, checked for form.
    pub fn parse(spec: &HoldsSpec) -> Result<HoldMapping, SpecProblem> {
        let mut mapping = HoldMapping::default();
        for (name, value) in &spec.inputs {
            let source =
                match number(value) {
                    Some(x) if x.is_finite() => InputSource::Fixed(x),
                    Some(x) => {
                        return Err(SpecProblem::key(
                            INPUTS,
                            name,
                            format!("input {name} = {x}; give a finite number"),
                        ))
                    }
                    None => InputSource::Measured(FromHold::parse(value).map_err(|e| {
                        SpecProblem::key(INPUTS, name, format!("input {name}: {e}"))
                    })?),
                };
            mapping.inputs.push((name.clone(), source));
        }
        for (name, value) in &spec.observe {
            let source = FromHold::parse(value)
                .map_err(|e| SpecProblem::key(OBSERVE, name, format!("observation {name}: {e}")))?;
            mapping.observations.push((name.clone(), source));
        }
        if mapping.observations.is_empty() {
            return Err(SpecProblem::file(
                "[holds.observe] is empty: name the model's outputs a hold measures (\"cylinder_force_kN.boom\" = \"boom_net_force\")",
            ));
        }
        Ok(mapping)
    }

    /// Every quantity named is one the rig's holds carry.
    pub fn check_quantities(&self, rig: &RigQuantities) -> Result<(), SpecProblem> {
        let known = |quantity: &str| rig.get(quantity).is_some();
        let listed = || {
            rig.quantities
                .iter()
                .map(|q| format!("{} ({})", q.name, q.unit))
                .collect::<Vec<_>>()
                .join(", ")
        };
        for (name, source) in &self.inputs {
            if let InputSource::Measured(from) = source {
                if !known(&from.quantity) {
                    return Err(SpecProblem::key(
                        INPUTS,
                        name,
                        format!(
                            "input {name}: the rig's holds have no quantity {:?}; they have {}",
                            from.quantity,
                            listed()
                        ),
                    ));
                }
            }
        }
        for (name, from) in &self.observations {
            if !known(&from.quantity) {
                return Err(SpecProblem::key(
                    OBSERVE,
                    name,
                    format!(
                        "observation {name}: the rig's holds have no quantity {:?}; they have {}",
                        from.quantity,
                        listed()
                    ),
                ));
            }
        }
        Ok(())
    }

    /// The inputs an operator sets and the rig measures, by input name.
    pub fn measured_inputs(&self) -> impl Iterator<Item = (&str, &FromHold)> {
        self.inputs
            .iter()
            .filter_map(|(name, source)| match source {
                InputSource::Measured(from) => Some((name.as_str(), from)),
                InputSource::Fixed(_) => None,
            })
    }

    /// The fixed inputs, by input name.
    pub fn fixed_inputs(&self) -> impl Iterator<Item = (&str, f64)> {
        self.inputs
            .iter()
            .filter_map(|(name, source)| match source {
                InputSource::Fixed(x) => Some((name.as_str(), *x)),
                InputSource::Measured(_) => None,
            })
    }

    /// One hold's values through the mapping; why not, when a quantity it
    /// needs is missing, flagged or without a spread.
    pub fn read(&self, name: &str, values: &[MeasuredValue]) -> Result<HoldReading, String> {
        let inputs = self
            .inputs
            .iter()
            .map(|(input, source)| match source {
                InputSource::Fixed(x) => Ok((input.clone(), *x, 0.0)),
                InputSource::Measured(from) => {
                    let value = from.read(values)?;
                    Ok((input.clone(), value.mean, value.standard_uncertainty))
                }
            })
            .collect::<Result<Vec<_>, String>>()?;
        let (observations, shared) = self
            .observations
            .iter()
            .map(|(output, from)| {
                let value = from.read(values)?;
                Ok((
                    (output.clone(), value.mean, value.standard_uncertainty),
                    value.shared,
                ))
            })
            .collect::<Result<Vec<_>, String>>()?
            .into_iter()
            .unzip();
        Ok(HoldReading {
            name: name.to_string(),
            inputs,
            observations,
            shared,
        })
    }
}
