//! The measured values of a spec: numbers in the spec, holds of an `acq
//! extract` measured-values file (mean, and `std` or `std_of_mean` as the
//! uncertainty), and measured curves from CSV files next to the spec.

use std::path::Path;

use acq_algorithms::doe::read_csv_columns;
use acq_analysis::extract::measured::{read_measured, UncertaintyBasis};
use acq_analysis::loss::metrics::CurveMetric;
use acq_error::AcqError;

use super::schema::CurveSpec;
use crate::study::{Measured, Observation, SCATTER_OF_MEAN};

/// The points of columns `x` and `y` of a CSV with a header row; errors
/// name the file and line.
pub fn read_curve(path: &Path, x: &str, y: &str) -> Result<Vec<(f64, f64)>, String> {
    let text = acq_io::input::read_text(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let rows = read_csv_columns(&text, &[x, y], "point of the curve")
        .map_err(|e| format!("{}: {e}", path.display()))?;
    Ok(rows.iter().map(|row| (row[0], row[1])).collect())
}

/// A measured curve next to the spec, at least two points.
pub fn measured_curve(
    spec_directory: &Path,
    name: &str,
    file: &str,
    x: &str,
    y: &str,
) -> acq_error::Result<Vec<(f64, f64)>> {
    let path = spec_directory.join(file);
    acq_io::input::note_input(&path);
    let points =
        read_curve(&path, x, y).map_err(|e| AcqError::Malformed(format!("curve {name}: {e}")))?;
    if points.len() < 2 {
        return Err(AcqError::Malformed(format!(
            "curve {name}: {} has {} point(s); a measured curve needs at least 2",
            path.display(),
            points.len()
        )));
    }
    Ok(points)
}

/// A curve's `metric`: MAPE when none is given.
/// A curve its metric cannot score (no range to normalise by, no function
/// of x for MAPE) would fail every model run: refused now, before the
/// first, by scoring the measured curve against itself.
pub fn scoreable(
    name: &str,
    file: &str,
    metric: CurveMetric,
    points: &[(f64, f64)],
) -> Result<(), String> {
    acq_analysis::loss::metrics::score(metric, points, points)
        .map(|_| ())
        .map_err(|e| {
            let advice = match metric {
                CurveMetric::Mape => "a loop, or a curve that goes back, needs a metric that pairs points: metric = \"pcm\", \"frechet\", \"dtw\" or \"area\"",
                _ => "each axis of the measured curve needs a range, every point finite",
            };
            format!(
                "curve {name}: the measured curve in {file} cannot be scored by {}: {e}; {advice}",
                metric.as_str()
            )
        })
}

pub fn metric_of(metric: Option<&str>, curve: &str) -> Result<CurveMetric, String> {
    metric.map_or(Ok(CurveMetric::Mape), |text| {
        text.parse().map_err(|e| format!("curve {curve}: {e}"))
    })
}

pub fn weight_of(weight: Option<f64>, what: &str) -> Result<f64, String> {
    match weight {
        None => Ok(1.0),
        Some(w) if (0.0..=1e6).contains(&w) => Ok(w),
        Some(w) => Err(format!("{what}: weight = {w}; give a number from 0 to 1e6")),
    }
}

pub fn scalar(
    name: &str,
    value: f64,
    uncertainty: Option<f64>,
    weight: f64,
    source: String,
) -> Result<Observation, String> {
    // A 0 is only meaningful in standard uncertainties (a one-sided
    // penalty's target); relative errors divide by the value.
    if !(value.is_finite() && (value != 0.0 || uncertainty.is_some())) {
        return Err(format!(
            "{name}: measured must be a finite non-zero number (errors are relative to it; a 0 needs an uncertainty and residuals = \"normalised\"), got {value}"
        ));
    }
    if let Some(u) = uncertainty {
        if !(u.is_finite() && u > 0.0) {
            return Err(format!(
                "{name}: uncertainty = {u}; give the standard uncertainty, a finite number above 0, in the value's unit"
            ));
        }
    }
    Ok(Observation {
        name: name.to_string(),
        output: name.to_string(),
        measured: Measured::Scalar { value, uncertainty },
        weight,
        source,
        shared: Vec::new(),
    })
}

/// One entry of a case's `measured` table. A measured curve is the model's
/// curve of the same name: a [[curve]] says where a solver writes it; a
/// built-in twin gives its own, in `builtin_curve_units` (x, y).
pub fn case_observation(
    curves: &[CurveSpec],
    builtin_curve_units: Option<[&str; 2]>,
    spec_directory: &Path,
    name: &str,
    entry: &toml::Value,
) -> Result<Observation, String> {
    let number = |v: &toml::Value| v.as_float().or_else(|| v.as_integer().map(|i| i as f64));
    if let Some(value) = number(entry) {
        return scalar(name, value, None, 1.0, "spec".into());
    }
    let table = entry.as_table().ok_or_else(|| {
        format!("{name}: give a number, or a table with value, file (+ quantity), or file (+ x, y) for a curve")
    })?;
    let text = |key: &str| -> Result<Option<String>, String> {
        match table.get(key) {
            None => Ok(None),
            Some(v) => v
                .as_str()
                .map(|s| Some(s.to_string()))
                .ok_or_else(|| format!("{name}: {key} must be a string")),
        }
    };
    let allowed: &[&str] = if table.contains_key("value") {
        &["value", "uncertainty", "weight"]
    } else if table.contains_key("quantity") {
        &["file", "quantity", "hold", "uncertainty", "weight"]
    } else {
        &["file", "x", "y", "weight", "metric"]
    };
    if let Some(key) = table.keys().find(|k| !allowed.contains(&k.as_str())) {
        return Err(format!(
            "{name}: unknown key {key:?}; this kind of measured value takes {}",
            allowed.join(", ")
        ));
    }
    let weight = match table.get("weight") {
        None => 1.0,
        Some(v) => weight_of(
            Some(number(v).ok_or_else(|| format!("{name}: weight must be a number"))?),
            name,
        )?,
    };
    if let Some(value) = table.get("value") {
        let value = number(value).ok_or_else(|| format!("{name}: value must be a number"))?;
        let uncertainty = match table.get("uncertainty") {
            None => None,
            Some(u) => Some(number(u).ok_or_else(|| {
                format!("{name}: uncertainty must be a number (the standard uncertainty)")
            })?),
        };
        return scalar(name, value, uncertainty, weight, "spec".into());
    }
    let file = text("file")?.ok_or_else(|| {
        format!("{name}: give value = ..., or file = ... with quantity (a measured-values file) or x and y (a curve)")
    })?;
    let path = spec_directory.join(&file);
    if let Some(quantity) = text("quantity")? {
        return measured_value_from_file(
            name,
            &path,
            &quantity,
            text("hold")?.as_deref(),
            table.get("uncertainty"),
            weight,
        );
    }
    let (Some(x), Some(y)) = (text("x")?, text("y")?) else {
        return Err(format!(
            "{name}: a measured curve needs x and y (its column names in {file})"
        ));
    };
    let curve = curves.iter().find(|c| c.name == name);
    let (axes, curve_metric) = match (curve, builtin_curve_units) {
        (Some(curve), _) => (curve.axes(&x, &y), curve.metric.as_deref()),
        (None, Some([x_unit, y_unit])) => ([format!("{x} [{x_unit}]"), format!("{y} [{y_unit}]")], None),
        (None, None) => {
            return Err(format!(
                "{name}: a measured curve, but no [[curve]] named {name:?} says which file the solver writes it to"
            ))
        }
    };
    // The case's own metric, else its [[curve]]'s.
    let metric = metric_of(text("metric")?.as_deref().or(curve_metric), name)?;
    let points = measured_curve(spec_directory, name, &file, &x, &y).map_err(|e| e.to_string())?;
    scoreable(name, &file, metric, &points)?;
    Ok(Observation {
        name: name.to_string(),
        output: name.to_string(),
        measured: Measured::Curve {
            points,
            axes,
            metric,
        },
        weight,
        source: file,
        shared: Vec::new(),
    })
}

/// A measured value from an `acq extract` measured-values file.
fn measured_value_from_file(
    name: &str,
    path: &Path,
    quantity: &str,
    hold: Option<&str>,
    uncertainty: Option<&toml::Value>,
    weight: f64,
) -> Result<Observation, String> {
    let values = read_measured(path).map_err(|e| format!("{name}: {e}"))?;
    let mut holds: Vec<&str> = values.iter().map(|v| v.window.as_str()).collect();
    holds.dedup();
    let hold = match hold {
        Some(h) => h.to_string(),
        None if holds.len() == 1 => holds[0].to_string(),
        None => {
            return Err(format!(
                "{name}: {} has {} holds ({}); name one with hold = \"...\"",
                path.display(),
                holds.len(),
                holds.join(", ")
            ))
        }
    };
    let Some(value) = values
        .iter()
        .find(|v| v.window == hold && v.quantity == quantity)
    else {
        return Err(if holds.contains(&hold.as_str()) {
            format!(
                "{name}: {} has no {quantity} in hold {hold}",
                path.display()
            )
        } else {
            format!(
                "{name}: {} has no hold {hold:?}; it has {}",
                path.display(),
                holds.join(", ")
            )
        });
    };
    if !value.is_usable() {
        return Err(format!(
            "{name}: {quantity} in {hold} of {} is not fit to calibrate against (flags '{}': {})",
            path.display(),
            value.flags.join(";"),
            value.note
        ));
    }
    let mean = value
        .stats
        .mean
        .ok_or_else(|| format!("{name}: {quantity} in {hold} has no mean"))?;
    let spread = |basis: UncertaintyBasis| {
        value.standard_uncertainty(basis).ok_or_else(|| {
            format!("{name}: {quantity} in {hold} has no spread (fewer than 2 samples)")
        })
    };
    let (uncertainty, shared) = match uncertainty {
        None => (None, Vec::new()),
        Some(toml::Value::String(s)) if s == "std_of_mean" => {
            let (u, shared) = spread(UncertaintyBasis::Budget)?;
            (Some(u), shared)
        }
        Some(toml::Value::String(s)) if s == SCATTER_OF_MEAN => {
            (Some(spread(UncertaintyBasis::ReadingsScatter)?.0), Vec::new())
        }
        Some(toml::Value::String(s)) if s == "std" => {
            let std = value.stats.std.ok_or_else(|| {
                format!("{name}: {quantity} in {hold} has no std (fewer than 2 samples)")
            })?;
            (Some(std), Vec::new())
        }
        Some(v) => match v.as_float().or_else(|| v.as_integer().map(|i| i as f64)) {
            Some(u) => (Some(u), Vec::new()),
            None => {
                return Err(format!(
                    "{name}: uncertainty = {v}; give a number, \"std_of_mean\" (the value's budget), \"{SCATTER_OF_MEAN}\" (the readings' scatter only) or \"std\""
                ))
            }
        },
    };
    let mut observation = scalar(
        name,
        mean,
        uncertainty,
        weight,
        format!("{} ({hold}, {quantity} [{}])", path.display(), value.unit),
    )?;
    observation.shared = shared;
    Ok(observation)
}
