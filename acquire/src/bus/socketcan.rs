//! A Linux SocketCAN interface (a real adapter or vcan) through the
//! `socketcan` crate, driven by tokio.
//!
//! The socketcan crate opens, binds and configures the socket. Frames are
//! read with `recvmsg` (through nix) because only its control messages carry,
//! with each frame, the kernel receive timestamp and the queue's drop counter
//! (SO_RXQ_OVFL); the bytes are converted by `acq_can::kernel`, which
//! keeps every bit the kernel delivered.

use std::fs;
use std::io::{self, IoSliceMut};
use std::os::fd::AsRawFd;
use std::time::Duration;

use acq_can::kernel::{self, CANFD_MTU};
use acq_can::{Frame, IfaceName};
use nix::errno::Errno;
use nix::sys::socket::{
    recvmsg, setsockopt, sockopt, ControlMessageOwned, MsgFlags, TimestampingFlag, Timestamps,
};
use socketcan::{CanFdSocket, Socket, SocketOptions};
use tokio::io::unix::AsyncFd;
use tokio::io::Interest;

use super::{now_ns, Bus, BusError, FrameSink, FrameSource, OpenError, RxInfo, MAX_BATCH};

/// Receive buffer asked for: about 60,000 classic frames, so a burst while
/// the disk stalls is absorbed by the kernel instead of dropped.
const RECEIVE_BUFFER_BYTES: usize = 8 << 20;

/// The host's SocketCAN interfaces.
#[derive(Clone, Copy, Debug, Default)]
pub struct SocketCanBus;

pub struct SocketCanSource {
    socket: AsyncFd<CanFdSocket>,
    state: ReceiveState,
}

/// Everything a receive updates besides the socket.
struct ReceiveState {
    iface: IfaceName,
    hardware_timestamps: bool,
    /// SO_RXQ_OVFL is a wrapping u32; widened here.
    dropped_last_raw: u32,
    dropped_total: u64,
    control: Vec<u8>,
}

pub struct SocketCanSink {
    iface: IfaceName,
    socket: AsyncFd<CanFdSocket>,
}

/// Whether `iface` exists and is up, read from sysfs.
pub fn interface_state(iface: &str) -> Result<(), OpenError> {
    let flags = fs::read_to_string(format!("/sys/class/net/{iface}/flags")).map_err(|_| {
        OpenError::Missing {
            iface: iface.to_owned(),
        }
    })?;
    let flags = u32::from_str_radix(flags.trim().trim_start_matches("0x"), 16).unwrap_or(0);
    const IFF_UP: u32 = 0x1;
    if flags & IFF_UP == 0 {
        return Err(OpenError::Down {
            iface: iface.to_owned(),
        });
    }
    Ok(())
}

fn open_socket(iface: IfaceName) -> Result<CanFdSocket, OpenError> {
    let name = iface.as_str();
    interface_state(name)?;
    let io = |source: io::Error| OpenError::Io {
        iface: name.to_owned(),
        source,
    };
    let socket = CanFdSocket::open(name).map_err(|e| match e.raw_os_error() {
        Some(code) if code == Errno::EAFNOSUPPORT as i32 => OpenError::NoCanSupport {
            detail: e.to_string(),
        },
        Some(code) if code == Errno::ENODEV as i32 => OpenError::Missing {
            iface: name.to_owned(),
        },
        _ => io(e),
    })?;
    socket.set_nonblocking(true).map_err(io)?;
    Ok(socket)
}

/// ENETDOWN / ENODEV mean the interface went down or away (it may come
/// back); anything else is an I/O error.
fn bus_error(iface: IfaceName, source: io::Error) -> BusError {
    match source.raw_os_error() {
        Some(code) if code == Errno::ENETDOWN as i32 || code == Errno::ENODEV as i32 => {
            BusError::Down {
                iface: iface.to_string(),
            }
        }
        _ => BusError::Io {
            iface: iface.to_string(),
            source,
        },
    }
}

/// Hands the socket to tokio's reactor.
fn register(socket: CanFdSocket) -> io::Result<AsyncFd<CanFdSocket>> {
    // SAFETY: `register` needs the descriptor to stay open and the same for
    // the AsyncFd's whole life. `CanFdSocket` owns it (a socket2::Socket, an
    // OwnedFd) from `open` until it is dropped, which happens only with the
    // AsyncFd: nothing here calls `into_inner` or `into_raw_fd`, and its
    // `as_raw_fd` returns that one descriptor on every call.
    // ERROR too: an interface that goes down or away reports ENETDOWN /
    // ENODEV as a socket error (EPOLLERR), not as readable data.
    let interest = Interest::READABLE | Interest::WRITABLE | Interest::ERROR;
    Ok(unsafe { AsyncFd::register_with_interest(socket, interest) }?)
}

fn errno_io(errno: Errno) -> io::Error {
    io::Error::from_raw_os_error(errno as i32)
}

impl Bus for SocketCanBus {
    type Source = SocketCanSource;
    type Sink = SocketCanSink;

    fn open_source(&self, iface: IfaceName) -> Result<SocketCanSource, OpenError> {
        let socket = open_socket(iface)?;
        let name = iface.as_str();
        let io = |source: io::Error| OpenError::Io {
            iface: name.to_owned(),
            source,
        };
        socket.set_error_filter_accept_all().map_err(io)?;
        setsockopt(&socket, sockopt::RxqOvfl, &1).map_err(|e| io(errno_io(e)))?;
        // Root may exceed rmem_max; anyone else gets what the limit allows.
        if setsockopt(&socket, sockopt::RcvBufForce, &RECEIVE_BUFFER_BYTES).is_err() {
            let _ = setsockopt(&socket, sockopt::RcvBuf, &RECEIVE_BUFFER_BYTES);
        }
        let hardware_timestamps = socket.has_hw_timestamps();
        let mut flags = TimestampingFlag::SOF_TIMESTAMPING_SOFTWARE
            | TimestampingFlag::SOF_TIMESTAMPING_RX_SOFTWARE;
        if hardware_timestamps {
            flags |= TimestampingFlag::SOF_TIMESTAMPING_RX_HARDWARE
                | TimestampingFlag::SOF_TIMESTAMPING_RAW_HARDWARE;
        }
        setsockopt(&socket, sockopt::Timestamping, &flags).map_err(|e| io(errno_io(e)))?;
        Ok(SocketCanSource {
            socket: register(socket).map_err(io)?,
            state: ReceiveState {
                iface,
                hardware_timestamps,
                dropped_last_raw: 0,
                dropped_total: 0,
                control: nix::cmsg_space!(Timestamps, u32),
            },
        })
    }

    fn open_sink(&self, iface: IfaceName) -> Result<SocketCanSink, OpenError> {
        let socket = open_socket(iface)?;
        let io = |source: io::Error| OpenError::Io {
            iface: iface.to_string(),
            source,
        };
        // A sending socket reads nothing, so its queue never fills.
        socket.set_filter_drop_all().map_err(io)?;
        Ok(SocketCanSink {
            iface,
            socket: register(socket).map_err(io)?,
        })
    }
}

impl ReceiveState {
    fn bus_error(&self, source: io::Error) -> BusError {
        bus_error(self.iface, source)
    }

    /// One non-blocking `recvmsg`: `Ok(None)` when the queue is empty.
    fn read_one(&mut self, socket: &CanFdSocket) -> Result<Option<Frame>, BusError> {
        let mut bytes = [0u8; CANFD_MTU];
        let fd = socket.as_raw_fd();
        let mut iov = [IoSliceMut::new(&mut bytes)];
        let (size, stamp, dropped) = match recvmsg::<()>(
            fd,
            &mut iov,
            Some(&mut self.control),
            MsgFlags::MSG_DONTWAIT,
        ) {
            Ok(message) => {
                let mut stamp = None;
                let mut dropped = None;
                for control in message.cmsgs().into_iter().flatten() {
                    match control {
                        ControlMessageOwned::ScmTimestampsns(times) => {
                            let hardware = times.hw_raw;
                            let software = times.system;
                            stamp = if self.hardware_timestamps
                                && (hardware.tv_sec() != 0 || hardware.tv_nsec() != 0)
                            {
                                Some(hardware)
                            } else if software.tv_sec() != 0 || software.tv_nsec() != 0 {
                                Some(software)
                            } else {
                                None
                            };
                        }
                        ControlMessageOwned::RxqOvfl(count) => dropped = Some(count),
                        _ => {}
                    }
                }
                (message.bytes, stamp, dropped)
            }
            Err(Errno::EAGAIN) => return Ok(None),
            Err(errno) => return Err(self.bus_error(errno_io(errno))),
        };
        if let Some(raw) = dropped {
            self.dropped_total += u64::from(raw.wrapping_sub(self.dropped_last_raw));
            self.dropped_last_raw = raw;
        }
        let timestamp_ns = stamp
            .map(|t| t.tv_sec() * 1_000_000_000 + t.tv_nsec())
            .unwrap_or_else(now_ns);
        kernel::parse(&bytes[..size], self.iface, timestamp_ns)
            .map(Some)
            .map_err(|e| BusError::Io {
                iface: self.iface.to_string(),
                source: io::Error::new(io::ErrorKind::InvalidData, e),
            })
    }
}

impl FrameSource for SocketCanSource {
    async fn recv_batch(&mut self, out: &mut Vec<Frame>) -> Result<RxInfo, BusError> {
        loop {
            let state = &mut self.state;
            let mut ready = self
                .socket
                .ready(Interest::READABLE | Interest::ERROR)
                .await
                .map_err(|e| state.bus_error(e))?;
            let start = out.len();
            while out.len() - start < MAX_BATCH {
                match state.read_one(ready.get_inner())? {
                    Some(frame) => out.push(frame),
                    None => {
                        ready.clear_ready();
                        break;
                    }
                }
            }
            if out.len() > start {
                return Ok(RxInfo {
                    dropped_total: Some(state.dropped_total),
                });
            }
        }
    }

    fn timestamp_source(&self) -> &'static str {
        if self.state.hardware_timestamps {
            "hardware"
        } else {
            "kernel"
        }
    }
}

impl FrameSink for SocketCanSink {
    async fn send(&mut self, frame: &Frame) -> Result<(), BusError> {
        let (bytes, size) = kernel::encode(frame);
        let iface = self.iface;
        let fail = |source: io::Error| bus_error(iface, source);
        loop {
            let mut ready = self.socket.writable().await.map_err(fail)?;
            match ready.try_io(|socket| {
                nix::unistd::write(socket.get_ref(), &bytes[..size]).map_err(errno_io)
            }) {
                Ok(Ok(_)) => return Ok(()),
                // A real controller's transmit queue is full: wait for it to drain.
                Ok(Err(e)) if e.raw_os_error() == Some(Errno::ENOBUFS as i32) => {
                    tokio::time::sleep(Duration::from_micros(200)).await
                }
                Ok(Err(e)) => return Err(fail(e)),
                Err(_would_block) => continue,
            }
        }
    }
}
