//! The bus seam: where frames come from and go to.
//!
//! The recorder and the player are written against [`Bus`], with three
//! implementations: [`socketcan`] (a Linux CAN interface, real or vcan),
//! [`memory`] (an in-process bus, so most tests run on any machine) and
//! [`logfile`] (a candump/ASC log as a source, a candump log as a sink).

pub mod logfile;
pub mod memory;
pub mod socketcan;

use std::future::Future;
use std::io;

use acq_can::{Frame, IfaceName};

/// The most frames one [`FrameSource::recv_batch`] appends.
pub const MAX_BATCH: usize = 256;

/// What a receive returned besides its frames.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RxInfo {
    /// Frames the receive queue dropped since the source was opened
    /// (SO_RXQ_OVFL on SocketCAN; lag on the in-process bus), if known.
    pub dropped_total: Option<u64>,
}

/// Why an interface could not be opened.
#[derive(Debug, thiserror::Error)]
pub enum OpenError {
    #[error("CAN interface {iface} does not exist. Create a virtual one with:\n    sudo modprobe vcan && sudo ip link add dev {iface} type vcan && sudo ip link set up {iface}\n(or connect the adapter and bring it up: sudo ip link set {iface} up type can bitrate 500000)")]
    Missing { iface: String },
    #[error("CAN interface {iface} is down. Bring it up with:\n    sudo ip link set up {iface}\n(a real adapter also needs its bitrate: sudo ip link set {iface} up type can bitrate 500000)")]
    Down { iface: String },
    #[error("this kernel has no SocketCAN support (AF_CAN: {detail}); load it with `sudo modprobe can-raw vcan`, or run the checks in a VM (tests/vcan-vm/README.md)")]
    NoCanSupport { detail: String },
    #[error("{iface}: {source}")]
    Io { iface: String, source: io::Error },
}

/// Why a receive or send stopped.
#[derive(Debug, thiserror::Error)]
pub enum BusError {
    /// The interface went down or disappeared; it may come back.
    #[error("interface {iface} went down or disappeared")]
    Down { iface: String },
    /// The source has no more frames (end of a log file).
    #[error("end of input")]
    Closed,
    #[error("{iface}: {source}")]
    Io { iface: String, source: io::Error },
}

/// Receives frames from one interface.
pub trait FrameSource: Send + 'static {
    /// Waits for at least one frame, then appends it and every frame already
    /// waiting (at most [`MAX_BATCH`]) to `out`, stamped with the receive time
    /// and this source's interface.
    fn recv_batch(
        &mut self,
        out: &mut Vec<Frame>,
    ) -> impl Future<Output = Result<RxInfo, BusError>> + Send;

    /// Whether timestamps come from the controller's clock ("hardware"),
    /// the kernel ("kernel") or this process ("process").
    fn timestamp_source(&self) -> &'static str;
}

/// Sends frames on one interface.
pub trait FrameSink: Send + 'static {
    /// Sends one frame (its interface field is ignored: the sink's own is used).
    fn send(&mut self, frame: &Frame) -> impl Future<Output = Result<(), BusError>> + Send;

    /// Sends one frame that a player's schedule puts on the wire at
    /// `wire_unix_ns`. A bus whose receivers stamp frames themselves (the
    /// kernel, on SocketCAN) ignores the time; the in-process bus stamps the
    /// frame with it, so that what a replay records does not depend on when
    /// a thread got to run.
    fn send_at(
        &mut self,
        frame: &Frame,
        wire_unix_ns: i64,
    ) -> impl Future<Output = Result<(), BusError>> + Send {
        let _ = wire_unix_ns;
        self.send(frame)
    }
}

/// A set of interfaces frames can be received from and sent to.
pub trait Bus: Clone + Send + Sync + 'static {
    type Source: FrameSource;
    type Sink: FrameSink;

    fn open_source(&self, iface: IfaceName) -> Result<Self::Source, OpenError>;
    fn open_sink(&self, iface: IfaceName) -> Result<Self::Sink, OpenError>;
}

/// Nanoseconds since the Unix epoch, now.
pub fn now_ns() -> i64 {
    let since = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .unwrap_or_default();
    i64::try_from(since.as_nanos()).unwrap_or(i64::MAX)
}
