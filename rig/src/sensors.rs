//! Frames -> samples, through a rig: each sensor decoded in its own protocol
//! and converted to its engineering unit.
//!
//! Frames are matched to a bus by interface name; a rig with a single bus
//! takes frames from any interface (so a log recorded on `can0` decodes the
//! same after a replay on `vcan0`).

use rustc_hash::FxHashMap;

use crate::profiles::Conversion;
use crate::{Rig, SensorSource};
use acq_can::canopen::{HeartbeatEvent, HeartbeatMonitor, PdoMapping};
use acq_can::dbc::{MessageCodec, PhysicalValue, UnswitchedSignal};
use acq_can::frame::{CanId, Frame, FrameFields, FrameKind, IfaceName};
use acq_can::j1939::J1939Id;
use acq_can::j1939_tp::{Reassembler, TP_CM_PGN, TP_DT_PGN};
use acq_can::{FrameBatch, IdIndex};

/// One value of one sensor at one instant.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sample {
    pub time_ns: i64,
    /// Index into [`Rig::sensors`].
    pub sensor: usize,
    /// `None`: the device sent "error" or "not available" (J1939), or a
    /// value that is not a finite number. A missing sample, never a number.
    pub value: Option<f64>,
}

/// What decoding a frame produced.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SensorEvent {
    Sample(Sample),
    /// A CANopen node's heartbeat changed state or timed out; `sensors`
    /// lists the rig's sensors on that node via [`SensorDecoder::node_sensors`].
    Heartbeat {
        bus: usize,
        event: HeartbeatEvent,
    },
}

/// What a frame was to the rig.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FrameUse {
    /// At least one sensor value came from it.
    Decoded,
    /// A heartbeat or other protocol frame the rig follows.
    Protocol,
    /// No sensor of the rig is on this id.
    Unknown,
    /// A known id whose frame was too short or did not match its message.
    Undecodable,
    /// An error or remote frame.
    NotData,
}

/// A sensor of a DBC or CANopen id as the per-frame loop needs it: its
/// message found in the bus's DBC once, not per frame and signal, and none
/// of the rig's sensor record (hundreds of bytes) read per frame.
struct IdSensor<'r> {
    sensor: usize,
    channel: IdChannel<'r>,
    conversion: &'r Conversion,
}

/// Where an [`IdSensor`]'s value lies in its frames.
enum IdChannel<'r> {
    /// Signal `signal_index` of `message`, found in the bus's DBC once.
    Dbc {
        message: &'r MessageCodec,
        signal_index: usize,
    },
    /// A signal of a message without multiplexors, nearly every DBC
    /// sensor's: decoded with no look at switches.
    Unswitched(UnswitchedSignal<'r>),
    Canopen(&'r PdoMapping),
}

/// Entries by (bus, CAN id), found through each bus's [`IdIndex`].
struct IdTable<T> {
    entries: Vec<Vec<T>>,
    /// Per bus, each id's place in `entries`.
    by_bus: Vec<IdIndex>,
}

impl<T> IdTable<T> {
    fn new(buses: usize) -> Self {
        IdTable {
            entries: Vec::new(),
            by_bus: vec![IdIndex::new(); buses],
        }
    }

    fn push(&mut self, bus: usize, id: CanId, entry: T) {
        let Some(index) = self.by_bus.get_mut(bus) else {
            return;
        };
        let place = match index.get(id) {
            Some(place) => place as usize,
            None => {
                self.entries.push(Vec::new());
                index.insert(id, (self.entries.len() - 1) as u32);
                self.entries.len() - 1
            }
        };
        self.entries[place].push(entry);
    }

    #[inline]
    fn get(&self, bus: usize, id: CanId) -> Option<&[T]> {
        let place = self.by_bus.get(bus)?.get(id)?;
        self.entries.get(place as usize).map(Vec::as_slice)
    }
}

#[derive(Clone, Copy, Debug)]
struct J1939Entry {
    source_address: Option<u8>,
    sensor: usize,
}

/// A J1939 sensor's channel value in one parameter group's bytes.
enum J1939Value {
    /// `None`: the SPN says "not available" or "error".
    Value(Option<f64>),
    /// The group does not carry it (a multiplexer selects another signal).
    NotCarried,
    /// The group is too short for it.
    Undecodable,
}

/// Decodes frames into sensor samples for one rig.
pub struct SensorDecoder<'r> {
    rig: &'r Rig,
    /// Sensors by (bus, CAN id) for DBC and CANopen sources.
    by_id: IdTable<IdSensor<'r>>,
    /// J1939 sensors by (bus, PGN).
    by_pgn: FxHashMap<(usize, u32), Vec<J1939Entry>>,
    heartbeats: Vec<HeartbeatMonitor>,
    /// J1939 transport-protocol sessions per bus (messages over 8 bytes).
    transport: Vec<Reassembler>,
}

/// A heartbeat lost after this many producer periods.
pub const HEARTBEAT_TIMEOUT_PERIODS: f64 = 3.0;

impl<'r> SensorDecoder<'r> {
    pub fn new(rig: &'r Rig) -> Self {
        let mut by_id = IdTable::new(rig.buses.len());
        let mut by_pgn: FxHashMap<(usize, u32), Vec<J1939Entry>> = FxHashMap::default();
        let mut heartbeats = vec![HeartbeatMonitor::default(); rig.buses.len()];
        for (index, sensor) in rig.sensors.iter().enumerate() {
            match &sensor.source {
                // A J1939 message of a DBC matches by PGN, as J1939 tools
                // match it, never by its id too (a frame is one value).
                SensorSource::Dbc {
                    j1939_pgn: Some(pgn),
                    source_address,
                    ..
                }
                | SensorSource::J1939 {
                    pgn,
                    source_address,
                    ..
                } => by_pgn
                    .entry((sensor.bus, *pgn))
                    .or_default()
                    .push(J1939Entry {
                        source_address: *source_address,
                        sensor: index,
                    }),
                SensorSource::Dbc {
                    id, signal_index, ..
                } => {
                    // A message the bus's DBC lacks decodes nothing.
                    if let Some(message) = rig.buses[sensor.bus].dbc.message(*id) {
                        by_id.push(
                            sensor.bus,
                            *id,
                            IdSensor {
                                sensor: index,
                                channel: match message.unswitched(*signal_index) {
                                    Some(signal) => IdChannel::Unswitched(signal),
                                    None => IdChannel::Dbc {
                                        message,
                                        signal_index: *signal_index,
                                    },
                                },
                                conversion: &sensor.conversion,
                            },
                        );
                    }
                }
                SensorSource::Canopen {
                    cob_id,
                    node_id,
                    mapping,
                    heartbeat_ms,
                    ..
                } => {
                    by_id.push(
                        sensor.bus,
                        *cob_id,
                        IdSensor {
                            sensor: index,
                            channel: IdChannel::Canopen(mapping),
                            conversion: &sensor.conversion,
                        },
                    );
                    if let Some(period_ms) = heartbeat_ms {
                        let timeout_ns =
                            (period_ms * 1e6 * HEARTBEAT_TIMEOUT_PERIODS).round() as i64;
                        heartbeats[sensor.bus].watch(*node_id, timeout_ns);
                    }
                }
            }
        }
        SensorDecoder {
            rig,
            by_id,
            by_pgn,
            heartbeats,
            transport: vec![Reassembler::default(); rig.buses.len()],
        }
    }

    /// A J1939 sensor's channel value in a parameter group's bytes: an SPN
    /// the rig file places, or a signal of a DBC's J1939 message.
    fn j1939_value(&self, bus: usize, source: &SensorSource, payload: &[u8]) -> J1939Value {
        match source {
            SensorSource::J1939 { spn, .. } => {
                if spn.field.end_byte() > payload.len() {
                    J1939Value::Undecodable
                } else {
                    J1939Value::Value(spn.value(payload))
                }
            }
            SensorSource::Dbc {
                id, signal_index, ..
            } => {
                let Some(message) = self.rig.buses[bus].dbc.message(*id) else {
                    return J1939Value::NotCarried;
                };
                match message.decode_signal(payload, *signal_index) {
                    Ok(Some(value)) => J1939Value::Value(Some(value.as_f64())),
                    Ok(None) => J1939Value::NotCarried,
                    Err(_) => J1939Value::Undecodable,
                }
            }
            SensorSource::Canopen { .. } => J1939Value::NotCarried,
        }
    }

    /// The bus a frame belongs to.
    #[inline]
    pub fn bus_of(&self, frame: &Frame) -> Option<usize> {
        self.bus_of_iface(frame.iface)
    }

    /// The bus of frames received on `iface`.
    #[inline]
    fn bus_of_iface(&self, iface: IfaceName) -> Option<usize> {
        if self.rig.buses.len() == 1 {
            return Some(0);
        }
        self.rig.buses.iter().position(|b| b.iface == iface)
    }

    /// Decodes one frame, emitting samples and heartbeat events in order.
    pub fn decode(&mut self, frame: &Frame, emit: impl FnMut(SensorEvent)) -> FrameUse {
        match self.bus_of(frame) {
            Some(bus) => self.decode_on_bus(bus, frame.fields(), emit),
            None => FrameUse::Unknown,
        }
    }

    /// Decodes every frame of `batch` in order, as [`SensorDecoder::decode`]
    /// would one by one: `emit` is given each event with the index of its
    /// frame in the batch. The bus of each interface is looked up once per
    /// batch, not once per frame.
    pub fn decode_batch(&mut self, batch: &FrameBatch, mut emit: impl FnMut(usize, SensorEvent)) {
        let buses: Vec<Option<usize>> = batch
            .interfaces
            .iter()
            .map(|iface| self.bus_of_iface(*iface))
            .collect();
        for (index, interface) in batch.interface.iter().enumerate() {
            if let Some(bus) = buses[usize::from(*interface)] {
                self.decode_on_bus(bus, batch.fields(index), |event| emit(index, event));
            }
        }
    }

    /// Decodes one frame of bus `bus`.
    fn decode_on_bus(
        &mut self,
        bus: usize,
        frame: FrameFields<'_>,
        mut emit: impl FnMut(SensorEvent),
    ) -> FrameUse {
        // A watched node's heartbeat is the rig's protocol, a change of
        // state or not.
        let mut protocol = self.heartbeats[bus].on_fields(frame, |event| {
            emit(SensorEvent::Heartbeat { bus, event });
        });
        self.heartbeats[bus].check(frame.timestamp_ns, |event| {
            emit(SensorEvent::Heartbeat { bus, event })
        });
        if !matches!(frame.kind, FrameKind::Data { .. } | FrameKind::Fd { .. }) {
            return FrameUse::NotData;
        }
        let payload = frame.payload;
        let time_ns = frame.timestamp_ns;
        let mut decoded = false;
        let mut undecodable = false;
        if let Some(sensors) = self.by_id.get(bus, frame.id) {
            for sensor in sensors {
                // `None`: not in this frame (not selected by the
                // multiplexer, or past the end of a longer message).
                let reading = match sensor.channel {
                    IdChannel::Dbc {
                        message,
                        signal_index,
                    } => message
                        .decode_signal(payload, signal_index)
                        .map(|value| value.map(PhysicalValue::as_f64))
                        .map_err(drop),
                    IdChannel::Unswitched(signal) => signal
                        .decode(payload)
                        .map(|value| value.map(PhysicalValue::as_f64))
                        .map_err(drop),
                    IdChannel::Canopen(mapping) => {
                        mapping.process_value(payload).map(Some).ok_or(())
                    }
                };
                let reading = match reading {
                    Ok(Some(reading)) => reading,
                    Ok(None) => continue,
                    Err(()) => {
                        undecodable = true;
                        continue;
                    }
                };
                decoded = true;
                let value = sensor.conversion.apply(reading);
                emit(SensorEvent::Sample(Sample {
                    time_ns,
                    sensor: sensor.sensor,
                    value: value.is_finite().then_some(value),
                }));
            }
        }
        if let Some(id) = J1939Id::from_can_id(frame.id) {
            // A transport-protocol frame may complete a longer message: its
            // SPNs are decoded at the time of its last packet.
            let reassembled = self.transport[bus].on_frame(id, payload, time_ns);
            if matches!(id.pgn, TP_CM_PGN | TP_DT_PGN) {
                protocol = true;
            }
            let messages = [
                Some((id.pgn, id.source_address, payload)),
                reassembled
                    .as_ref()
                    .map(|m| (m.pgn, m.source_address, m.data.as_slice())),
            ];
            for (pgn, source_address, payload) in messages.into_iter().flatten() {
                let Some(entries) = self.by_pgn.get(&(bus, pgn)) else {
                    continue;
                };
                for entry in entries {
                    if entry.source_address.is_some_and(|sa| sa != source_address) {
                        continue;
                    }
                    let sensor = &self.rig.sensors[entry.sensor];
                    let value = match self.j1939_value(bus, &sensor.source, payload) {
                        J1939Value::Value(value) => value,
                        J1939Value::NotCarried => continue,
                        J1939Value::Undecodable => {
                            undecodable = true;
                            continue;
                        }
                    };
                    decoded = true;
                    emit(SensorEvent::Sample(Sample {
                        time_ns,
                        sensor: entry.sensor,
                        value: value
                            .map(|v| sensor.conversion.apply(v))
                            .filter(|v| v.is_finite()),
                    }));
                }
            }
        }
        match (decoded, undecodable, protocol) {
            (true, _, _) => FrameUse::Decoded,
            (false, true, _) => FrameUse::Undecodable,
            (false, false, true) => FrameUse::Protocol,
            (false, false, false) => FrameUse::Unknown,
        }
    }

    /// Checks heartbeat timeouts at `now_ns` without a frame (end of a log,
    /// or a live clock tick).
    pub fn check_heartbeats(&mut self, now_ns: i64, mut emit: impl FnMut(SensorEvent)) {
        for (bus, monitor) in self.heartbeats.iter_mut().enumerate() {
            monitor.check(now_ns, |event| emit(SensorEvent::Heartbeat { bus, event }));
        }
    }

    /// The sensors of the rig on CANopen node `node` of bus `bus`.
    pub fn node_sensors(&self, bus: usize, node: u8) -> impl Iterator<Item = usize> + '_ {
        self.rig
            .sensors
            .iter()
            .enumerate()
            .filter_map(move |(i, s)| match s.source {
                SensorSource::Canopen { node_id, .. } if s.bus == bus && node_id == node => Some(i),
                _ => None,
            })
    }
}
