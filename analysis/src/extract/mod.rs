//! Aligned samples -> the numbers a calibration consumes: per steady hold
//! the mean of every sensor with its spread and plausibility flags, or a
//! tensile test's force-displacement curve.
//!
//! - [`holds`]: where the load is held (rolling standard deviation).
//! - [`stats`]: mean, std, effective n, 95 % interval of one window.
//! - [`uncertainty`]: where a value's uncertainty comes from (the scatter,
//!   and the sensor's certificate, accuracy class and resolution: JCGM 100),
//!   as contributions to `acq_metrology::budget`, which does the arithmetic.
//! - [`net_force`]: a cylinder's net force budget and its Monte Carlo check.
//! - [`plausibility`]: stuck, saturated, noisy, partner disagreement.
//! - [`measured`]: the measured-values CSV (written here, read by calibrate).
//! - [`tensile`]: force-displacement curve, zeroed and cut at fracture.
//! - [`tensile_props`]: E, Rp0.2, UTS, flow curve and post-UTS slope bounds of a test curve.
//! - [`run`]: both workflows over a recording.
//! - [`live`]: the holds and their values as a stream, while recording.

pub mod holds;
pub mod live;
pub mod measured;
pub mod net_force;
pub mod plausibility;
pub mod quantities;
pub mod run;
pub mod stats;
pub mod tensile;
pub mod tensile_props;
pub mod uncertainty;
