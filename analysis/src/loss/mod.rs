//! The loss stage of the pipeline: measured values -> loss. One number that
//! says how far a simulation is from the measurement, for a calibration to
//! minimise.
//!
//! - [`curve`]: the mean absolute percentage error (MAPE) between a
//!   measured and a simulated force-displacement curve, as the published
//!   tensile/GTN calibration defines it, with its loose ends tied.
//!
//! Relative errors of steady-hold measured values (the excavator's
//! pressures and gauge stresses) come in a later issue.

pub mod curve;

pub use curve::{
    curve_errors_by_part, curve_mape, CurveLossError, CurveMape, CurveMapeOptions, CurveName,
    SplitMape,
};
