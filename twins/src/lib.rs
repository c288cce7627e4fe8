//! The digital twins `acq` calibrates, as plain numerical models.
//!
//! They take physical inputs (strokes in mm, loads in kN) and return physical
//! outputs (pressures in bar, stresses in MPa). They know nothing of CAN,
//! recordings or calibration; the calibration engine drives them.
//!
//! - [`plane_frame`]: planar Euler-Bernoulli frame finite elements.
//! - [`excavator`]: the DX55-class front attachment (statics + frame FE).
//! - [`tensile`]: the round tensile bar with GTN ductile damage (axisymmetric FE).

pub mod excavator;
pub mod plane_frame;
pub mod tensile;
