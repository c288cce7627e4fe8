//! Live acquisition: frames from and onto CAN buses.
//!
//! - [`bus`]: the bus seam (`Bus`, `FrameSource`, `FrameSink`) with SocketCAN,
//!   an in-process bus and a log file behind it.
//! - [`record`]: `acq record`, lossless recording into a session directory
//!   with live status.
//! - [`replay`]: the player: a log's frames onto interfaces on an absolute
//!   schedule (`acq replay`, `acq simulate`).
//! - [`simulate`]: the virtual rig: a scenario's sensors as timed frames.
//!
//! The stage after the drivers and before the analysis: it knows nothing of
//! alignment, measured values, twins, calibration or reports.

pub mod bus;
pub mod record;
pub mod replay;
pub mod simulate;
