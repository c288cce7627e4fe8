//! Offline analysis: from recorded frames to measured values.
//!
//! The data flows through the modules in this order:
//! - [`decode`]: `acq decode`, logs to CSV through DBC files or a rig.
//! - [`recording`]: a session directory (or log) as samples through its rig,
//!   each bus's clock offset removed.
//! - [`zero`]: a rest state before (and after) the test sets each channel's
//!   offset; the session keeps the record and every reader applies it.
//! - [`shunt`]: a strain channel's recorded shunt step against the one its
//!   shunt simulates: the gain correction the session keeps.
//! - [`align`]: every sensor on one time base, gaps flagged (`acq align`).
//! - [`extract`]: steady holds to measured values with their uncertainty and
//!   plausibility flags; a tensile test to its curve and its material
//!   properties (`acq extract`, `acq tensile-props`).
//! - [`interp`]: the not-a-knot cubic spline curves are compared through.
//! - [`loss`]: measured vs simulated as one number (curve MAPE).
//!
//! Reads sessions through `acq-io`; knows nothing of live buses, twins,
//! calibration or reports.

pub mod align;
pub mod decode;
pub mod extract;
pub mod interp;
pub mod loss;
pub mod recording;
pub mod shunt;
pub mod zero;
