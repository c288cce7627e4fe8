//! `acq simulate`: the virtual rig. Every sensor of a rig on the wire in its
//! own protocol (CANopen PDOs with boot-up and heartbeats, J1939 broadcasts,
//! DBC messages), each device at its own rate with its own clock error,
//! frame jitter, measurement noise and occasional lost frames, following a
//! scenario: idle, load build-up, steady hold, release; or a measured curve.
//!
//! The generator is a merge of one timed stream per message (a device):
//! deterministic for a given seed, in time order, in constant memory.

pub mod scenario;

use std::cmp::Reverse;
use std::collections::{BTreeMap, BinaryHeap};

use acq_can::canopen::heartbeat_cob_id;
use acq_can::j1939::{J1939Id, GLOBAL_ADDRESS};
use acq_can::{CanId, Frame, IfaceName};
use acq_rig::{Rig, Sensor, SensorSource};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

use acq_error::{AcqError, Result};
use scenario::{Curve, Scenario};

/// J1939 priority of the simulated broadcasts (the default for non-control PGNs).
const J1939_PRIORITY: u8 = 6;
/// CANopen NMT states sent in heartbeats.
const NMT_BOOT_UP: u8 = 0x00;
const NMT_OPERATIONAL: u8 = 0x05;

#[derive(Clone, Debug)]
enum Payload {
    /// Sensor values encoded into a frame of `len` bytes filled with `fill`.
    Sensors {
        sensors: Vec<usize>,
        len: usize,
        fill: u8,
    },
    /// A CANopen heartbeat; the first one is the boot-up message.
    Heartbeat { first: bool },
}

/// One device's timed stream of one message.
#[derive(Clone, Debug)]
struct Stream {
    iface: IfaceName,
    id: CanId,
    payload: Payload,
    /// Nominal period times this device's clock error.
    period_ns: f64,
    phase_ns: f64,
    jitter: Normal<f64>,
    jitter_limit_ns: f64,
    /// Frames of this stream may be lost (never boot-up messages).
    droppable: bool,
    index: u64,
    rng: ChaCha8Rng,
}

impl Stream {
    fn time_ns(&mut self) -> i64 {
        let jitter = self
            .jitter
            .sample(&mut self.rng)
            .clamp(-self.jitter_limit_ns, self.jitter_limit_ns);
        (self.phase_ns + self.index as f64 * self.period_ns + jitter).round() as i64
    }
}

/// What a sensor reads over time.
#[derive(Clone, Debug)]
enum Profile {
    /// Idle, then each hold's level in turn.
    Levels { idle: f64, holds: Vec<f64> },
    /// Follows a curve column; after the curve's end, `after_end` if given
    /// (a load that drops at fracture), else the last value.
    Column {
        column: String,
        after_end: Option<f64>,
    },
}

/// The traffic of a rig under a scenario, frame by frame in time order.
pub struct Simulation<'r> {
    rig: &'r Rig,
    scenario: Scenario,
    curve: Option<Curve>,
    profiles: Vec<Profile>,
    noise: Vec<Normal<f64>>,
    streams: Vec<Stream>,
    queue: BinaryHeap<Reverse<(i64, usize)>>,
    start_ns: i64,
    end_ns: i64,
    drop_probability: f64,
    noise_rng: ChaCha8Rng,
    drop_rng: ChaCha8Rng,
    pub frames_dropped: u64,
    /// Rig sensors the scenario says nothing about (sent as 0).
    pub unspecified_sensors: Vec<String>,
}

impl<'r> Simulation<'r> {
    /// Traffic starting at `start_ns` (Unix ns) for the scenario's duration.
    pub fn new(
        rig: &'r Rig,
        scenario: Scenario,
        curve: Option<Curve>,
        seed: u64,
        start_ns: i64,
    ) -> Result<Self> {
        for name in scenario.sensor.keys() {
            if rig.sensor(name).is_none() {
                let known: Vec<&str> = rig.sensors.iter().map(|s| s.name.as_str()).collect();
                return Err(AcqError::Config(format!(
                    "scenario sensor {name:?} is not in the rig {}; its sensors are: {}",
                    rig.path.display(),
                    known.join(", ")
                )));
            }
        }
        for (k, hold) in scenario.hold.iter().enumerate() {
            if let Some(name) = hold.level.keys().find(|name| rig.sensor(name).is_none()) {
                return Err(AcqError::Config(format!(
                    "scenario hold {}: level.{name} is not a sensor of the rig {}",
                    k + 1,
                    rig.path.display()
                )));
            }
        }
        let devices = scenario.devices;
        let mut unspecified_sensors = Vec::new();
        let mut profiles = Vec::new();
        let mut noise = Vec::new();
        for sensor in &rig.sensors {
            let spec = scenario.sensor.get(&sensor.name);
            let profile = match spec {
                Some(s) if s.column.is_some() => Profile::Column {
                    column: s.column.clone().unwrap_or_default(),
                    after_end: s.after_end,
                },
                Some(s) => {
                    let hold = s.hold.or(s.idle).unwrap_or(0.0);
                    Profile::Levels {
                        idle: s.idle.unwrap_or(0.0),
                        holds: hold_levels(&scenario, &sensor.name, hold),
                    }
                }
                None if holds_name(&scenario, &sensor.name) => Profile::Levels {
                    idle: 0.0,
                    holds: hold_levels(&scenario, &sensor.name, 0.0),
                },
                None => {
                    unspecified_sensors.push(sensor.name.clone());
                    Profile::Levels {
                        idle: 0.0,
                        holds: vec![0.0; scenario.hold_count()],
                    }
                }
            };
            let scale = match &profile {
                Profile::Levels { idle, holds } => {
                    holds.iter().fold(idle.abs(), |m, h| m.max(h.abs()))
                }
                Profile::Column { column, .. } => curve
                    .as_ref()
                    .and_then(|c| c.columns.get(column))
                    .map_or(0.0, |values| {
                        values.iter().fold(0.0f64, |m, v| m.max(v.abs()))
                    }),
            };
            let std = spec
                .and_then(|s| s.noise)
                .unwrap_or(devices.relative_noise * scale);
            noise
                .push(Normal::new(0.0, std).map_err(|e| {
                    AcqError::Config(format!("sensor {}: noise: {e}", sensor.name))
                })?);
            profiles.push(profile);
        }
        let duration_s = curve
            .as_ref()
            .map_or(scenario.total_s(), |c| c.duration_s());
        let mut master = ChaCha8Rng::seed_from_u64(seed);
        let streams = build_streams(rig, &devices, &mut master)?;
        check_levels_can_be_sent(rig, &streams, &profiles, curve.as_ref())?;
        let mut queue = BinaryHeap::new();
        let mut simulation = Simulation {
            rig,
            scenario,
            curve,
            profiles,
            noise,
            streams,
            queue: BinaryHeap::new(),
            start_ns,
            end_ns: (duration_s * 1e9).round() as i64,
            drop_probability: devices.drop_probability,
            noise_rng: ChaCha8Rng::seed_from_u64(master.random()),
            drop_rng: ChaCha8Rng::seed_from_u64(master.random()),
            frames_dropped: 0,
            unspecified_sensors,
        };
        for (index, stream) in simulation.streams.iter_mut().enumerate() {
            queue.push(Reverse((stream.time_ns(), index)));
        }
        simulation.queue = queue;
        Ok(simulation)
    }

    /// About how many frames the whole scenario sends (every stream's
    /// duration over its period).
    pub fn expected_frames(&self) -> u64 {
        self.streams
            .iter()
            .map(|stream| (self.end_ns as f64 / stream.period_ns.max(1.0)).ceil() as u64 + 1)
            .sum()
    }

    /// Every steady hold, (start, end) in Unix ns.
    pub fn hold_windows_ns(&self) -> Vec<(i64, i64)> {
        self.scenario
            .hold_windows_s()
            .into_iter()
            .map(|(a, b)| {
                (
                    self.start_ns + (a * 1e9) as i64,
                    self.start_ns + (b * 1e9) as i64,
                )
            })
            .collect()
    }

    /// The value sensor `index` reads at `t_s` seconds, without noise.
    pub fn true_value(&self, index: usize, t_s: f64) -> f64 {
        match &self.profiles[index] {
            Profile::Levels { idle, holds } => {
                let (k, fraction) = self.scenario.load_fraction(t_s);
                idle + (holds[k] - idle) * fraction
            }
            Profile::Column { column, after_end } => {
                let Some(curve) = self.curve.as_ref() else {
                    return 0.0;
                };
                match after_end {
                    Some(value) if curve.is_past_end(t_s) => *value,
                    _ => curve.value(column, t_s).unwrap_or(0.0),
                }
            }
        }
    }

    fn frame(&mut self, stream_index: usize, time_ns: i64) -> Frame {
        let stream = &self.streams[stream_index];
        let t_s = time_ns as f64 * 1e-9;
        let mut data = [0u8; 64];
        let len = match &stream.payload {
            Payload::Heartbeat { first } => {
                data[0] = if *first { NMT_BOOT_UP } else { NMT_OPERATIONAL };
                1
            }
            Payload::Sensors { sensors, len, fill } => {
                data[..*len].fill(*fill);
                for &index in sensors {
                    let value =
                        self.true_value(index, t_s) + self.noise[index].sample(&mut self.noise_rng);
                    encode_sensor(self.rig, index, value, &mut data[..*len]);
                }
                *len
            }
        };
        Frame::data(
            self.start_ns + time_ns,
            stream.iface,
            stream.id,
            &data[..len],
        )
        .or_else(|_| {
            Frame::fd(
                self.start_ns + time_ns,
                stream.iface,
                stream.id,
                0,
                &data[..len],
            )
        })
        .unwrap_or_else(|_| {
            Frame::data(self.start_ns + time_ns, stream.iface, stream.id, &[])
                .expect("an empty frame is valid")
        })
    }

    /// The next frame in time order, or `None` at the end of the scenario.
    pub fn next_frame(&mut self) -> Option<Frame> {
        loop {
            let Reverse((time_ns, index)) = self.queue.pop()?;
            if time_ns > self.end_ns {
                continue; // this stream is done
            }
            let frame = self.frame(index, time_ns);
            let stream = &mut self.streams[index];
            let droppable = stream.droppable;
            if let Payload::Heartbeat { first } = &mut stream.payload {
                *first = false;
            }
            stream.index += 1;
            let next = stream.time_ns();
            self.queue.push(Reverse((next.max(time_ns + 1), index)));
            if droppable && self.drop_rng.random::<f64>() < self.drop_probability {
                self.frames_dropped += 1;
                continue;
            }
            return Some(frame);
        }
    }
}

/// The sensors sharing one CAN id: one device frame.
struct MessagePlan {
    id: CanId,
    sensors: Vec<usize>,
    len: usize,
    /// What unused bytes hold.
    fill: u8,
    rate_hz: f64,
}

/// One stream per message: sensors sharing a CAN id are one device frame.
fn build_streams(
    rig: &Rig,
    devices: &scenario::Devices,
    master: &mut ChaCha8Rng,
) -> Result<Vec<Stream>> {
    let (messages, nodes) = plan_messages(rig)?;
    let mut clocks = DeviceClocks { devices, master };
    let mut streams = Vec::new();
    let mut boot_s: BTreeMap<(usize, u8), f64> = BTreeMap::new();
    for (&(bus, node), heartbeat_ms) in &nodes {
        let Some(id) = heartbeat_cob_id(node) else {
            continue;
        };
        let boot = 0.001 + 0.05 * (node as f64 / 128.0);
        boot_s.insert((bus, node), boot);
        // A node without heartbeat sends only its boot-up (one period longer than any test).
        let period_s = heartbeat_ms.map_or(1e9, |ms| ms * 1e-3);
        streams.push(clocks.stream(
            period_s,
            boot,
            false,
            rig.buses[bus].iface,
            id,
            Payload::Heartbeat { first: true },
        ));
    }
    for ((bus, _), plan) in messages {
        let MessagePlan {
            id,
            sensors,
            len,
            fill,
            rate_hz,
        } = plan;
        let node_boot = sensors.iter().find_map(|&i| match rig.sensors[i].source {
            SensorSource::Canopen { node_id, .. } => boot_s.get(&(bus, node_id)).copied(),
            _ => None,
        });
        let period_s = 1.0 / rate_hz;
        // PDOs start after their node booted; others anywhere in their first period.
        let phase = node_boot.map_or(0.0, |b| b + 0.005) + period_s * (id.raw() % 97) as f64 / 97.0;
        let payload = Payload::Sensors { sensors, len, fill };
        streams.push(clocks.stream(period_s, phase, true, rig.buses[bus].iface, id, payload));
    }
    Ok(streams)
}

/// The rig's device frames by (bus, CAN id key), and its CANopen nodes by
/// (bus, node id) with their heartbeat period, ms (`None`: no heartbeat).
type MessagesAndNodes = (
    BTreeMap<(usize, u32), MessagePlan>,
    BTreeMap<(usize, u8), Option<f64>>,
);

/// Groups the rig's sensors into device frames (the largest length and
/// rate among a frame's sensors) and collects its CANopen nodes.
fn plan_messages(rig: &Rig) -> Result<MessagesAndNodes> {
    let mut messages: BTreeMap<(usize, u32), MessagePlan> = BTreeMap::new();
    let mut nodes: BTreeMap<(usize, u8), Option<f64>> = BTreeMap::new();
    for (index, sensor) in rig.sensors.iter().enumerate() {
        if let SensorSource::Canopen {
            node_id,
            heartbeat_ms,
            ..
        } = &sensor.source
        {
            nodes.insert((sensor.bus, *node_id), *heartbeat_ms);
        }
        let (id, len, fill) = sensor_frame(rig, sensor)?;
        let plan = messages
            .entry((sensor.bus, id.key()))
            .or_insert(MessagePlan {
                id,
                sensors: Vec::new(),
                len: 0,
                fill,
                rate_hz: 0.0,
            });
        plan.sensors.push(index);
        plan.len = plan.len.max(len);
        plan.rate_hz = plan.rate_hz.max(sensor.rate_hz);
    }
    Ok((messages, nodes))
}

/// The frame a sensor's device sends it in: (CAN id, bytes it needs, what
/// unused bytes hold); an error for a DBC message the bus lacks, a
/// multiplexed DBC signal or a PGN without a J1939 id.
fn sensor_frame(rig: &Rig, sensor: &Sensor) -> Result<(CanId, usize, u8)> {
    Ok(match &sensor.source {
        SensorSource::Dbc {
            id,
            signal_index,
            source_address,
            ..
        } => {
            let message = rig.buses[sensor.bus].dbc.message(*id).ok_or_else(|| {
                AcqError::Config(format!("sensor {}: DBC message {id} missing", sensor.name))
            })?;
            if message.signals[*signal_index].multiplexer_value.is_some() {
                return Err(AcqError::Config(format!(
                    "sensor {}: simulating multiplexed DBC signals is not supported",
                    sensor.name
                )));
            }
            // A J1939 message is sent from the address the rig takes it from.
            let id = match (source_address, J1939Id::from_can_id(*id)) {
                (Some(source_address), Some(declared)) => J1939Id {
                    source_address: *source_address,
                    ..declared
                }
                .to_can_id()
                .unwrap_or(*id),
                _ => *id,
            };
            (id, message.size, 0x00)
        }
        SensorSource::Canopen {
            cob_id, mapping, ..
        } => (*cob_id, mapping.field.end_byte(), 0x00),
        SensorSource::J1939 {
            pgn,
            source_address,
            ..
        } => {
            let id = J1939Id {
                priority: J1939_PRIORITY,
                pgn: *pgn,
                source_address: source_address.unwrap_or(0x80),
                destination_address: GLOBAL_ADDRESS,
            }
            .to_can_id()
            .ok_or_else(|| {
                AcqError::Config(format!("sensor {}: PGN {pgn} has no J1939 id", sensor.name))
            })?;
            // Unused J1939 bytes are 0xFF ("not available").
            (id, 8, 0xFF)
        }
    })
}

/// Gives each device its own clock error, jitter and random stream, drawn
/// from the master generator in the order the streams are made.
struct DeviceClocks<'a> {
    devices: &'a scenario::Devices,
    master: &'a mut ChaCha8Rng,
}

impl DeviceClocks<'_> {
    /// A device's stream of one message: nominal `period_s` off by a clock
    /// error in ±`clock_ppm`, first sent at `phase_s`.
    fn stream(
        &mut self,
        period_s: f64,
        phase_s: f64,
        droppable: bool,
        iface: IfaceName,
        id: CanId,
        payload: Payload,
    ) -> Stream {
        let devices = self.devices;
        let ppm = self
            .master
            .random_range(-devices.clock_ppm..=devices.clock_ppm.max(0.0));
        let period_ns = period_s * 1e9 * (1.0 + ppm * 1e-6);
        let jitter_ns = devices.jitter_us * 1e3;
        Stream {
            iface,
            id,
            payload,
            period_ns,
            phase_ns: phase_s * 1e9,
            jitter: Normal::new(0.0, jitter_ns)
                .unwrap_or_else(|_| Normal::new(0.0, 0.0).expect("zero std is valid")),
            // Never reorder a device's own frames.
            jitter_limit_ns: (3.0 * jitter_ns).min(0.4 * period_ns),
            droppable,
            index: 0,
            rng: ChaCha8Rng::seed_from_u64(self.master.random()),
        }
    }
}

/// Writes sensor `index`'s engineering `value` into its frame's payload, as
/// its device would send it.
fn encode_sensor(rig: &Rig, index: usize, value: f64, payload: &mut [u8]) {
    let sensor = &rig.sensors[index];
    // Engineering value -> the channel value the device sends.
    let channel = sensor.conversion.invert(value).unwrap_or(0.0);
    match &sensor.source {
        SensorSource::Dbc {
            id, signal_index, ..
        } => {
            if let Some(message) = rig.buses[sensor.bus].dbc.message(*id) {
                message.signals[*signal_index].encode(channel, payload);
            }
        }
        SensorSource::Canopen { mapping, .. } => {
            mapping.encode(channel, payload);
        }
        SensorSource::J1939 { spn, .. } => {
            spn.encode(channel, payload);
        }
    }
}

/// Sensor `name`'s level in each hold: the hold's own, else `default`.
fn hold_levels(scenario: &Scenario, name: &str, default: f64) -> Vec<f64> {
    if scenario.hold.is_empty() {
        return vec![default];
    }
    scenario
        .hold
        .iter()
        .map(|h| h.level.get(name).copied().unwrap_or(default))
        .collect()
}

/// Whether a `[[hold]]` sets sensor `name`.
fn holds_name(scenario: &Scenario, name: &str) -> bool {
    scenario.hold.iter().any(|h| h.level.contains_key(name))
}

/// Refuses a scenario level (idle, hold, or a curve column's extremes) that
/// its sensor's device cannot send: encoded as the device would and decoded
/// as acq would, it must come back within 2 % of itself (or of 5 % of the
/// sensor's largest level, for levels near zero). Out of the field's range a
/// value saturates or wraps, and the simulation would send another number
/// than the scenario says.
fn check_levels_can_be_sent(
    rig: &Rig,
    streams: &[Stream],
    profiles: &[Profile],
    curve: Option<&Curve>,
) -> Result<()> {
    let mut decoder = acq_rig::sensors::SensorDecoder::new(rig);
    for stream in streams {
        let Payload::Sensors { sensors, len, fill } = &stream.payload else {
            continue;
        };
        for &index in sensors {
            let levels: Vec<(&str, f64)> = match &profiles[index] {
                Profile::Levels { idle, holds } => std::iter::once(("idle", *idle))
                    .chain(holds.iter().map(|h| ("hold", *h)))
                    .collect(),
                Profile::Column { column, after_end } => {
                    let values = curve.and_then(|c| c.columns.get(column));
                    let extremes = values.map_or((0.0, 0.0), |v| {
                        v.iter()
                            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &x| {
                                (lo.min(x), hi.max(x))
                            })
                    });
                    let mut levels = vec![
                        ("the curve's smallest value", extremes.0),
                        ("the curve's largest value", extremes.1),
                    ];
                    levels.extend(after_end.map(|v| ("after_end", v)));
                    levels
                }
            };
            let scale = levels.iter().fold(0.0f64, |m, (_, v)| m.max(v.abs()));
            let sensor = &rig.sensors[index];
            for (what, value) in levels {
                let (low, high) = sensor.kind.physical_range();
                if !(low..=high).contains(&value) {
                    return Err(AcqError::Config(format!(
                        "sensor.{}: {what} = {value:?} {unit} is no {kind} a sensor reads (from {low} to {high} {unit})",
                        sensor.name,
                        unit = sensor.unit(),
                        kind = sensor.kind.name(),
                    )));
                }
                let mut data = vec![*fill; *len];
                encode_sensor(rig, index, value, &mut data);
                let frame = Frame::data(0, stream.iface, stream.id, &data)
                    .or_else(|_| Frame::fd(0, stream.iface, stream.id, 0, &data));
                let mut sent = None;
                if let Ok(frame) = frame {
                    decoder.decode(&frame, |event| {
                        if let acq_rig::sensors::SensorEvent::Sample(sample) = event {
                            if sample.sensor == index {
                                sent = sample.value;
                            }
                        }
                    });
                }
                let tolerance = 0.02 * value.abs().max(0.05 * scale);
                if sent.is_none_or(|sent| (sent - value).abs() > tolerance) {
                    return Err(AcqError::Config(format!(
                        "sensor.{}: {what} = {value:?} {} cannot be sent by its device: it arrives as {}; give a value inside the sensor's range",
                        sensor.name,
                        sensor.unit(),
                        sent.map_or("no value".to_string(), |v| format!("{v}"))
                    )));
                }
            }
        }
    }
    Ok(())
}
