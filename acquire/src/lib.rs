//! Live acquisition: frames from and onto CAN buses.
//!
//! - [`bus`]: the bus seam (`Bus`, `FrameSource`, `FrameSink`) with SocketCAN,
//!   an in-process bus and a log file behind it.
//! - [`record`]: `acq record`, lossless recording into a session directory
//!   with live status.
//! - [`import`]: `acq import`, a session made from logger files, as if
//!   recorded.
//! - [`replay`]: the player: a log's frames onto interfaces on an absolute
//!   schedule (`acq replay`, `acq simulate`).
//! - [`simulate`]: the virtual rig: a scenario's sensors as timed frames.
//! - [`runtime`]: the tokio runtime they run on.
//!
//! The stage after the drivers and before the analysis: it knows nothing of
//! alignment, measured values, twins, calibration or reports.

pub mod bus;
pub mod import;
pub mod record;
pub mod replay;
pub mod simulate;

use acq_error::{AcqError, Result};

/// The async runtime the live commands run on: `threads` workers, or the
/// current thread alone for 1 (a player waits on the wall clock and needs no
/// second thread).
pub fn runtime(threads: usize) -> Result<tokio::runtime::Runtime> {
    let mut builder = if threads > 1 {
        let mut b = tokio::runtime::Builder::new_multi_thread();
        b.worker_threads(threads);
        b
    } else {
        tokio::runtime::Builder::new_current_thread()
    };
    builder
        .enable_all()
        .build()
        .map_err(|e| AcqError::io("starting the async runtime", e))
}
