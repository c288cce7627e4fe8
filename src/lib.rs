//! `acq`: acquisition bridge and calibration core for test engineers who
//! validate finite-element digital twins against measurements.
//!
//! The binary is thin glue over this library, and this library over the
//! driver crate `acq_drivers` (frames, logs, protocols, sensors). Data flows
//! one way: bus -> frames -> decoded samples -> aligned table -> measured
//! values -> loss -> calibration -> report; no module reaches back up.
//!
//! - [`cli`]: argument definitions and dispatch.
//! - [`decode`]: `acq decode`, logs to CSV through DBC files or a rig.
//! - [`input`], [`output`]: opening logs and writing results; [`error`]: exit codes.
//! - [`interp`]: not-a-knot cubic spline through measured or simulated curves.
//! - [`loss`]: measured vs simulated -> one number (curve MAPE).
//! - [`tensile_cli`]: `acq tensile-props`, material properties of a tensile test.
//! - [`calibrate`]: `acq calibrate excavator|gtn|external`, the workflows over `acq_calib`.
//! - [`engine_cli`]: `acq gp fit|predict` and `acq moo`, the engine's blocks on their own.

pub mod align;
pub mod bus;
pub mod calibrate;
pub mod cli;
pub mod decode;
pub mod demo;
pub mod document;
pub mod engine_cli;
pub mod error;
pub mod extract;
pub mod input;
pub mod interp;
pub mod live_cli;
pub mod loss;
pub mod offline_cli;
pub mod output;
pub mod plot;
pub mod record;
pub mod recording;
pub mod replay;
pub mod sensitivity;
pub mod session;
pub mod simulate;
pub mod tensile_cli;
pub mod tensile_model;
pub mod twin_cli;
