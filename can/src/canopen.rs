//! CANopen: the CiA 301 predefined connection set and CiA 404 measuring
//! devices (pressure transducers, amplifiers).
//!
//! What a recording needs: which COB-ID carries which node's TPDO, how a
//! mapped process value is read and scaled, the heartbeat (node state and
//! a timeout that declares a node lost), and the NMT frame that starts
//! nodes which boot into pre-operational.

use crate::bits::BitField;
use crate::frame::{CanId, Frame, FrameFields, IfaceName};

/// Valid node ids are 1..=127.
pub const MAX_NODE_ID: u8 = 127;
const TPDO_BASE: [u16; 4] = [0x180, 0x280, 0x380, 0x480];
const HEARTBEAT_BASE: u16 = 0x700;
const NMT_ID: u16 = 0x000;

/// COB-ID of TPDO `pdo` (1..=4) of `node` (predefined connection set).
pub fn tpdo_cob_id(pdo: u8, node: u8) -> Option<CanId> {
    if !(1..=4).contains(&pdo) || !(1..=MAX_NODE_ID).contains(&node) {
        return None;
    }
    CanId::standard(TPDO_BASE[usize::from(pdo - 1)] + u16::from(node))
}

/// COB-ID of `node`'s heartbeat.
pub fn heartbeat_cob_id(node: u8) -> Option<CanId> {
    (1..=MAX_NODE_ID)
        .contains(&node)
        .then(|| CanId::Standard(HEARTBEAT_BASE + u16::from(node)))
}

/// The node whose heartbeat this id is, if it is one.
#[inline]
pub fn heartbeat_node(id: CanId) -> Option<u8> {
    match id {
        CanId::Standard(raw) if (HEARTBEAT_BASE + 1..=HEARTBEAT_BASE + 127).contains(&raw) => {
            Some((raw - HEARTBEAT_BASE) as u8)
        }
        _ => None,
    }
}

/// NMT state as a heartbeat reports it (CiA 301, 7.2.8.3.2).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum NmtState {
    BootUp,
    Stopped,
    Operational,
    PreOperational,
    /// A state byte CiA 301 does not define.
    Unknown(u8),
}

impl NmtState {
    pub fn from_byte(byte: u8) -> Self {
        // Bit 7 is the toggle bit of node guarding; heartbeats send it as 0.
        match byte & 0x7F {
            0x00 => NmtState::BootUp,
            0x04 => NmtState::Stopped,
            0x05 => NmtState::Operational,
            0x7F => NmtState::PreOperational,
            _ => NmtState::Unknown(byte),
        }
    }
}

/// The NMT "start remote node" command for `node` (0 = all nodes).
pub fn nmt_start_frame(iface: IfaceName, node: u8) -> Frame {
    // Two bytes in an 11-bit frame cannot exceed the classic limits.
    Frame::data(0, iface, CanId::Standard(NMT_ID), &[0x01, node])
        .expect("a 2-byte classic frame is always valid")
}

/// Data type of a mapped object (CiA 301 basic types used by CiA 404 devices).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Deserialize, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum PdoType {
    Int8,
    Uint8,
    Int16,
    Uint16,
    Int32,
    Uint32,
    Real32,
}

impl PdoType {
    /// The name used in rig files.
    pub fn name(self) -> &'static str {
        match self {
            PdoType::Int8 => "int8",
            PdoType::Uint8 => "uint8",
            PdoType::Int16 => "int16",
            PdoType::Uint16 => "uint16",
            PdoType::Int32 => "int32",
            PdoType::Uint32 => "uint32",
            PdoType::Real32 => "real32",
        }
    }

    pub fn size_bytes(self) -> usize {
        match self {
            PdoType::Int8 | PdoType::Uint8 => 1,
            PdoType::Int16 | PdoType::Uint16 => 2,
            PdoType::Int32 | PdoType::Uint32 | PdoType::Real32 => 4,
        }
    }
}

/// Where one process value sits in a TPDO and how it is scaled.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PdoMapping {
    pub field: BitField,
    pub data_type: PdoType,
    /// CiA 404 "decimal digits" (object 0x6132): an integer process value
    /// `raw` means `raw / 10^decimals`. Ignored for REAL32.
    pub decimal_digits: u8,
}

/// A mapping that does not fit.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
pub enum MappingError {
    #[error("a {size}-byte value at byte {offset} does not fit in the 8 bytes of a PDO")]
    OutsidePdo { offset: usize, size: usize },
    #[error("{0} decimal digits is more than the 9 a 32-bit value can use")]
    TooManyDecimals(u8),
}

impl PdoMapping {
    /// A value of `data_type` at byte `offset` of the PDO (CANopen is little-endian).
    pub fn new(
        offset: usize,
        data_type: PdoType,
        decimal_digits: u8,
    ) -> Result<Self, MappingError> {
        let size = data_type.size_bytes();
        if offset + size > 8 {
            return Err(MappingError::OutsidePdo { offset, size });
        }
        if decimal_digits > 9 {
            return Err(MappingError::TooManyDecimals(decimal_digits));
        }
        let field = BitField::little_endian_bytes(offset, size as u64 * 8)
            .map_err(|_| MappingError::OutsidePdo { offset, size })?;
        Ok(PdoMapping {
            field,
            data_type,
            decimal_digits,
        })
    }

    /// The process value in the device's unit; `None` if the PDO is too short.
    #[inline]
    pub fn process_value(&self, payload: &[u8]) -> Option<f64> {
        let raw = self.field.extract(payload)?;
        let integer = match self.data_type {
            PdoType::Real32 => return Some(f64::from(f32::from_bits(raw as u32))),
            PdoType::Int8 | PdoType::Int16 | PdoType::Int32 => self.field.sign_extend(raw) as f64,
            PdoType::Uint8 | PdoType::Uint16 | PdoType::Uint32 => raw as f64,
        };
        Some(integer / 10f64.powi(i32::from(self.decimal_digits)))
    }

    /// Encodes a process value into a PDO payload (the inverse, for simulators).
    pub fn encode(&self, value: f64, payload: &mut [u8]) -> Option<()> {
        let raw = match self.data_type {
            PdoType::Real32 => u64::from((value as f32).to_bits()),
            _ => {
                let scaled = (value * 10f64.powi(i32::from(self.decimal_digits))).round();
                (scaled as i64) as u64
            }
        };
        self.field.insert(payload, raw)
    }
}

/// What the heartbeat monitor noticed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum HeartbeatEvent {
    /// A node sent a state different from the last one it sent.
    StateChanged {
        node: u8,
        state: NmtState,
        time_ns: i64,
    },
    /// No heartbeat from `node` within its timeout; `last_seen_ns` is when
    /// the last one came (`None`: never).
    Lost {
        node: u8,
        last_seen_ns: Option<i64>,
        time_ns: i64,
    },
}

#[derive(Clone, Copy, Debug)]
struct WatchedNode {
    node: u8,
    timeout_ns: i64,
    last_seen_ns: Option<i64>,
    state: Option<NmtState>,
    lost: bool,
}

/// Tracks the heartbeats of a set of nodes against their timeouts.
///
/// Time comes from the frames (or the caller's clock), never from the
/// system, so the same log always gives the same events.
#[derive(Clone, Debug, Default)]
pub struct HeartbeatMonitor {
    nodes: Vec<WatchedNode>,
    started_ns: Option<i64>,
}

impl HeartbeatMonitor {
    /// Watches `node`, declaring it lost after `timeout_ns` without a heartbeat.
    pub fn watch(&mut self, node: u8, timeout_ns: i64) {
        if let Some(existing) = self.nodes.iter_mut().find(|n| n.node == node) {
            existing.timeout_ns = existing.timeout_ns.min(timeout_ns);
            return;
        }
        self.nodes.push(WatchedNode {
            node,
            timeout_ns,
            last_seen_ns: None,
            state: None,
            lost: false,
        });
    }

    /// Feeds a frame; heartbeats of watched nodes update their state.
    ///
    /// Returns whether the frame is a heartbeat of a watched node (one
    /// without a change of state emits nothing, and is still the node's).
    pub fn on_frame(&mut self, frame: &Frame, emit: impl FnMut(HeartbeatEvent)) -> bool {
        self.on_fields(frame.fields(), emit)
    }

    /// [`HeartbeatMonitor::on_frame`] for a frame's fields.
    pub fn on_fields(
        &mut self,
        frame: FrameFields<'_>,
        mut emit: impl FnMut(HeartbeatEvent),
    ) -> bool {
        self.started_ns.get_or_insert(frame.timestamp_ns);
        // Most buses have no watched node: nothing to look up per frame.
        if self.nodes.is_empty() {
            return false;
        }
        let Some(node) = heartbeat_node(frame.id) else {
            return false;
        };
        let Some(&byte) = frame.payload.first() else {
            return false;
        };
        let Some(watched) = self.nodes.iter_mut().find(|n| n.node == node) else {
            return false;
        };
        let state = NmtState::from_byte(byte);
        watched.last_seen_ns = Some(frame.timestamp_ns);
        watched.lost = false;
        if watched.state != Some(state) {
            watched.state = Some(state);
            emit(HeartbeatEvent::StateChanged {
                node,
                state,
                time_ns: frame.timestamp_ns,
            });
        }
        true
    }

    /// Declares lost every node silent for longer than its timeout at `now_ns`
    /// (each loss reported once, until the node is heard again).
    pub fn check(&mut self, now_ns: i64, mut emit: impl FnMut(HeartbeatEvent)) {
        let start = self.started_ns.unwrap_or(now_ns);
        for watched in &mut self.nodes {
            let reference = watched.last_seen_ns.unwrap_or(start);
            if !watched.lost && now_ns.saturating_sub(reference) > watched.timeout_ns {
                watched.lost = true;
                emit(HeartbeatEvent::Lost {
                    node: watched.node,
                    last_seen_ns: watched.last_seen_ns,
                    time_ns: now_ns,
                });
            }
        }
    }

    /// Whether `node` is currently considered alive.
    pub fn is_alive(&self, node: u8) -> bool {
        self.nodes
            .iter()
            .find(|n| n.node == node)
            .is_some_and(|n| n.last_seen_ns.is_some() && !n.lost)
    }

    pub fn state(&self, node: u8) -> Option<NmtState> {
        self.nodes
            .iter()
            .find(|n| n.node == node)
            .and_then(|n| n.state)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn iface() -> IfaceName {
        IfaceName::new("can0").unwrap()
    }

    #[test]
    fn predefined_connection_set() {
        assert_eq!(tpdo_cob_id(1, 0x21), Some(CanId::Standard(0x1A1)));
        assert_eq!(tpdo_cob_id(4, 127), Some(CanId::Standard(0x4FF)));
        assert_eq!(tpdo_cob_id(5, 1), None);
        assert_eq!(tpdo_cob_id(1, 0), None);
        assert_eq!(heartbeat_node(CanId::Standard(0x721)), Some(0x21));
        assert_eq!(heartbeat_node(CanId::Standard(0x700)), None);
        assert_eq!(heartbeat_node(CanId::Extended(0x721)), None);
        let nmt = nmt_start_frame(iface(), 0x21);
        assert_eq!(
            (nmt.id, nmt.payload()),
            (CanId::Standard(0), &[0x01, 0x21][..])
        );
    }

    #[test]
    fn process_values_scale_like_cia_404() {
        let int32 = PdoMapping::new(0, PdoType::Int32, 2).unwrap();
        // 7335 with two decimal digits is 73.35 bar.
        assert_eq!(int32.process_value(&7335i32.to_le_bytes()), Some(73.35));
        assert_eq!(int32.process_value(&(-150i32).to_le_bytes()), Some(-1.5));
        let uint16 = PdoMapping::new(2, PdoType::Uint16, 1).unwrap();
        assert_eq!(uint16.process_value(&[0, 0, 0xFF, 0xFF]), Some(6553.5));
        let real = PdoMapping::new(4, PdoType::Real32, 5).unwrap();
        let mut payload = [0u8; 8];
        payload[4..].copy_from_slice(&193.46f32.to_le_bytes());
        assert_eq!(real.process_value(&payload), Some(f64::from(193.46f32)));
        assert!(PdoMapping::new(6, PdoType::Int32, 0).is_err());
        assert_eq!(int32.process_value(&[0, 0]), None);
        let mut encoded = [0u8; 8];
        int32.encode(216.66, &mut encoded).unwrap();
        assert_eq!(int32.process_value(&encoded), Some(216.66));
    }

    #[test]
    fn heartbeat_timeout_marks_a_node_lost_and_found() {
        let mut monitor = HeartbeatMonitor::default();
        monitor.watch(0x21, 3_000_000_000);
        let beat = |t: i64| Frame::data(t, iface(), CanId::Standard(0x721), &[0x05]).unwrap();
        let mut events = Vec::new();
        monitor.on_frame(&beat(0), |e| events.push(e));
        assert!(monitor.is_alive(0x21));
        monitor.check(2_000_000_000, |e| events.push(e));
        assert_eq!(events.len(), 1, "{events:?}");
        monitor.check(3_500_000_000, |e| events.push(e));
        assert_eq!(
            events[1],
            HeartbeatEvent::Lost {
                node: 0x21,
                last_seen_ns: Some(0),
                time_ns: 3_500_000_000
            }
        );
        assert!(!monitor.is_alive(0x21));
        monitor.check(4_000_000_000, |e| events.push(e));
        assert_eq!(events.len(), 2, "a loss is reported once");
        assert!(
            monitor.on_frame(&beat(5_000_000_000), |e| events.push(e)),
            "a watched node's heartbeat"
        );
        let unchanged = events.len();
        assert!(
            monitor.on_frame(&beat(5_500_000_000), |e| events.push(e)),
            "still the node's heartbeat with no change of state"
        );
        assert_eq!(events.len(), unchanged);
        assert!(monitor.is_alive(0x21));
        assert_eq!(monitor.state(0x21), Some(NmtState::Operational));
    }

    #[test]
    fn a_node_never_heard_is_lost_after_its_timeout_from_the_start() {
        let mut monitor = HeartbeatMonitor::default();
        monitor.watch(5, 1_000);
        let other = Frame::data(10, iface(), CanId::Standard(0x123), &[]).unwrap();
        assert!(!monitor.on_frame(&other, |_| {}), "no heartbeat");
        let mut events = Vec::new();
        monitor.check(2_000, |e| events.push(e));
        assert!(matches!(
            events[0],
            HeartbeatEvent::Lost {
                node: 5,
                last_seen_ns: None,
                ..
            }
        ));
    }
}
