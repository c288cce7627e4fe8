//! An in-process CAN network: named interfaces that deliver every frame sent
//! on them to every source opened on them, like vcan does.
//!
//! A source that falls more than the channel capacity behind loses the
//! oldest frames and reports them as dropped, as a full socket queue does.
//! Removing an interface is what unplugging an adapter is to its readers.

use std::collections::HashMap;
use std::sync::{Arc, Mutex};

use acq_can::{Frame, IfaceName};
use tokio::sync::broadcast::{self, error::RecvError, error::TryRecvError};

use super::{now_ns, Bus, BusError, FrameSink, FrameSource, OpenError, RxInfo, MAX_BATCH};

/// The in-process network; clones share it.
#[derive(Clone)]
pub struct MemoryBus {
    interfaces: Arc<Mutex<HashMap<IfaceName, broadcast::Sender<Frame>>>>,
    capacity: usize,
}

impl MemoryBus {
    /// A network whose sources buffer up to `capacity` frames each.
    pub fn new(capacity: usize) -> Self {
        MemoryBus {
            interfaces: Arc::default(),
            capacity: capacity.max(1),
        }
    }

    /// Creates an interface (`ip link add ... type vcan`); a no-op if it exists.
    pub fn add(&self, iface: IfaceName) {
        let mut interfaces = self.interfaces.lock().unwrap_or_else(|e| e.into_inner());
        interfaces
            .entry(iface)
            .or_insert_with(|| broadcast::channel(self.capacity).0);
    }

    /// Removes an interface: its sources see it go down.
    pub fn remove(&self, iface: IfaceName) {
        let mut interfaces = self.interfaces.lock().unwrap_or_else(|e| e.into_inner());
        interfaces.remove(&iface);
    }

    fn sender(&self, iface: IfaceName) -> Result<broadcast::Sender<Frame>, OpenError> {
        let interfaces = self.interfaces.lock().unwrap_or_else(|e| e.into_inner());
        interfaces.get(&iface).cloned().ok_or(OpenError::Missing {
            iface: iface.to_string(),
        })
    }
}

pub struct MemorySource {
    iface: IfaceName,
    receiver: broadcast::Receiver<Frame>,
    dropped: u64,
}

pub struct MemorySink {
    iface: IfaceName,
    bus: MemoryBus,
}

impl Bus for MemoryBus {
    type Source = MemorySource;
    type Sink = MemorySink;

    fn open_source(&self, iface: IfaceName) -> Result<MemorySource, OpenError> {
        Ok(MemorySource {
            iface,
            receiver: self.sender(iface)?.subscribe(),
            dropped: 0,
        })
    }

    fn open_sink(&self, iface: IfaceName) -> Result<MemorySink, OpenError> {
        self.sender(iface)?;
        Ok(MemorySink {
            iface,
            bus: self.clone(),
        })
    }
}

impl FrameSource for MemorySource {
    async fn recv_batch(&mut self, out: &mut Vec<Frame>) -> Result<RxInfo, BusError> {
        let down = || BusError::Down {
            iface: self.iface.to_string(),
        };
        loop {
            match self.receiver.recv().await {
                Ok(frame) => {
                    out.push(frame);
                    break;
                }
                Err(RecvError::Lagged(lost)) => self.dropped += lost,
                Err(RecvError::Closed) => return Err(down()),
            }
        }
        while out.len() < MAX_BATCH {
            match self.receiver.try_recv() {
                Ok(frame) => out.push(frame),
                Err(TryRecvError::Lagged(lost)) => self.dropped += lost,
                Err(TryRecvError::Empty) => break,
                Err(TryRecvError::Closed) => break, // reported on the next call
            }
        }
        Ok(RxInfo {
            dropped_total: Some(self.dropped),
        })
    }

    fn timestamp_source(&self) -> &'static str {
        "process"
    }
}

impl MemorySink {
    /// Puts `frame` on the interface, stamped `wire_unix_ns`.
    fn deliver(&self, frame: &Frame, wire_unix_ns: i64) -> Result<(), BusError> {
        let sender = self.bus.sender(self.iface).map_err(|_| BusError::Down {
            iface: self.iface.to_string(),
        })?;
        let mut frame = *frame;
        frame.iface = self.iface;
        frame.timestamp_ns = wire_unix_ns;
        // No receiver is not an error: frames on a bus nobody listens to are lost.
        let _ = sender.send(frame);
        Ok(())
    }
}

impl FrameSink for MemorySink {
    /// Stamped on the wire, now, as the kernel stamps a received frame.
    async fn send(&mut self, frame: &Frame) -> Result<(), BusError> {
        self.deliver(frame, now_ns())
    }

    /// Stamped with the time the sender's schedule gave it: the in-process
    /// wire has no delay of its own, and a thread's wake-up jitter is not
    /// part of the signal.
    async fn send_at(&mut self, frame: &Frame, wire_unix_ns: i64) -> Result<(), BusError> {
        self.deliver(frame, wire_unix_ns)
    }
}
