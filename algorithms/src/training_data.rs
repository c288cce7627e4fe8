//! The check every model fitted to data runs first: one output per input
//! row, rows of one width, every value finite. Shared by the GP and the
//! polynomial and RBF surrogates, so their messages agree.

use thiserror::Error;

/// Training data that no model can be fitted to. Each message says what to do.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum DataError {
    #[error("{inputs} input rows but {outputs} outputs: give exactly one output per input row")]
    LengthMismatch { inputs: usize, outputs: usize },
    #[error("no training rows, or rows without inputs: give at least one input variable per row")]
    NoInputs,
    #[error(
        "input row {row} has {found} values but row 0 has {expected}: give every row the same \
         number of inputs"
    )]
    RaggedInputs {
        row: usize,
        expected: usize,
        found: usize,
    },
    #[error("{what} at row {row} is {value}: remove or repair rows with NaN or infinite values")]
    NonFiniteData {
        what: &'static str,
        row: usize,
        value: f64,
    },
}

/// Checks the shape and finiteness of `inputs` (one row per point) and
/// `outputs`; returns the number of input variables.
pub fn check(inputs: &[Vec<f64>], outputs: &[f64]) -> Result<usize, DataError> {
    if inputs.len() != outputs.len() {
        return Err(DataError::LengthMismatch {
            inputs: inputs.len(),
            outputs: outputs.len(),
        });
    }
    let d = inputs.first().map_or(0, Vec::len);
    if d == 0 {
        return Err(DataError::NoInputs);
    }
    for (row, values) in inputs.iter().enumerate() {
        if values.len() != d {
            return Err(DataError::RaggedInputs {
                row,
                expected: d,
                found: values.len(),
            });
        }
        if let Some(value) = values.iter().find(|v| !v.is_finite()) {
            return Err(DataError::NonFiniteData {
                what: "an input",
                row,
                value: *value,
            });
        }
        if !outputs[row].is_finite() {
            return Err(DataError::NonFiniteData {
                what: "the output",
                row,
                value: outputs[row],
            });
        }
    }
    Ok(d)
}

/// Per-input lower end and width of the data's bounding box, the box the
/// models map onto the unit box when no bounds are given. A constant input
/// (or a span that overflows) gets width 1.
pub(crate) fn data_box(inputs: &[Vec<f64>], d: usize) -> (Vec<f64>, Vec<f64>) {
    (0..d)
        .map(|k| {
            let (lo, hi) = inputs
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), x| {
                    (lo.min(x[k]), hi.max(x[k]))
                });
            let width = hi - lo;
            (
                lo,
                if width > 0.0 && width.is_finite() {
                    width
                } else {
                    1.0
                },
            )
        })
        .unzip()
}
