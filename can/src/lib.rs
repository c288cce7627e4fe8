//! CAN for `acq`: frames, the log files that hold them, and the protocols
//! that give their bytes a meaning (DBC signals, CANopen CiA 404, J1939).
//!
//! No I/O runtime (no tokio, no sockets): the readers take any `BufRead`
//! and the writers any `Write`, so everything here runs the same on a live
//! bus, on a log file and under a fuzzer. What a rig's sensors make of the
//! decoded values is `acq-rig`'s.
//!
//! - [`frame`]: the CAN frame (classic, FD, remote, error) with timestamp and interface;
//!   [`id_index`]: places by CAN id, for the lookups made once a frame.
//! - [`log`]: log files: the record every reader yields, one module per format
//!   (can-utils `candump -L`, Vector ASC and BLF), and the reader that picks the format.
//! - [`kernel`]: the SocketCAN `can_frame`/`canfd_frame` byte layout; [`bus_error`]: error frames.
//! - [`bits`]: bit fields in both byte orders, shared by all protocols.
//! - [`dbc`]: DBC signals, compiled from the `can-dbc` AST.
//! - [`canopen`], [`j1939`]: the two device protocols on the rigs; [`j1939_tp`]: J1939
//!   messages longer than 8 bytes put back together (BAM and RTS/CTS).

pub mod bits;
pub mod bus_error;
pub mod canopen;
pub mod dbc;
mod decimal;
pub mod frame;
mod hex;
pub mod id_index;
pub mod j1939;
pub mod j1939_tp;
pub mod kernel;
pub mod log;

pub use frame::{CanId, Direction, Frame, FrameFields, FrameKind, IfaceName};
pub use id_index::IdIndex;
pub use log::{FrameBatch, LogFormat, LogReader, LogRecord, ParseError, Place, ReadError};
