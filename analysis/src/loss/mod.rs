//! The loss stage of the pipeline: measured values -> loss. One number that
//! says how far a simulation is from the measurement, for a calibration to
//! minimise.
//!
//! - [`curve`]: the mean absolute percentage error (MAPE) between a
//!   measured and a simulated force-displacement curve, as the published
//!   tensile/GTN calibration defines it, with its loose ends tied.
//!
//! - [`metrics`]: metrics that compare curves point to point along them
//!   (PCM, discrete Fréchet, DTW, the area between them), for curves that
//!   loop, drop or end early, each with signed residuals.
//!
//! Relative errors of steady-hold measured values (the excavator's
//! pressures and gauge stresses) come in a later issue.

pub mod curve;
pub mod metrics;

pub use curve::{
    curve_errors_by_part, curve_mape, CurveLossError, CurveMape, CurveMapeOptions, CurveName,
    SplitMape,
};
