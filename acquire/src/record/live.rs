//! Which sensors are alive: the live decoder behind the status display.
//!
//! A sensor is silent when no sample came within [`SILENCE_PERIODS`] of its
//! expected period, or when its CANopen node's heartbeat was lost.

use acq_can::canopen::{HeartbeatEvent, NmtState};
use acq_can::Frame;
use acq_io::session::SensorRecord;
use acq_rig::sensors::{SensorDecoder, SensorEvent};
use acq_rig::Rig;

/// Silent after this many expected periods without a sample.
pub const SILENCE_PERIODS: i64 = 3;

#[derive(Clone, Debug)]
pub struct SensorState {
    pub name: String,
    pub unit: String,
    pub expected_rate_hz: f64,
    period_ns: i64,
    pub samples: u64,
    first_sample_ns: Option<i64>,
    last_sample_ns: Option<i64>,
    /// When the last sample arrived, on the recorder's clock.
    last_arrival_ns: Option<i64>,
    pub last_value: Option<f64>,
    pub heartbeat_lost: bool,
    pub nmt_state: Option<NmtState>,
    pub silent: bool,
    pub silences: u64,
}

impl SensorState {
    /// Why it is silent, for the status line.
    pub fn silence_reason(&self) -> &'static str {
        if self.heartbeat_lost {
            "heartbeat lost"
        } else if self.last_arrival_ns.is_none() {
            "never seen"
        } else {
            "no frame within 3 periods"
        }
    }

    /// Seconds since the last sample arrived.
    pub fn age_s(&self, now_ns: i64) -> Option<f64> {
        self.last_arrival_ns.map(|t| (now_ns - t) as f64 * 1e-9)
    }

    fn observed_rate_hz(&self) -> f64 {
        match (self.first_sample_ns, self.last_sample_ns) {
            (Some(first), Some(last)) if last > first && self.samples > 1 => {
                (self.samples - 1) as f64 / ((last - first) as f64 * 1e-9)
            }
            _ => 0.0,
        }
    }
}

/// Live decoding of a rig's sensors.
pub struct Liveness<'r> {
    decoder: SensorDecoder<'r>,
    pub sensors: Vec<SensorState>,
    started_ns: i64,
}

impl<'r> Liveness<'r> {
    pub fn new(rig: &'r Rig, started_ns: i64) -> Self {
        let sensors = rig
            .sensors
            .iter()
            .map(|s| SensorState {
                name: s.name.clone(),
                unit: s.unit().to_string(),
                expected_rate_hz: s.rate_hz,
                period_ns: s.period_ns(),
                samples: 0,
                first_sample_ns: None,
                last_sample_ns: None,
                last_arrival_ns: None,
                last_value: None,
                heartbeat_lost: false,
                nmt_state: None,
                silent: false,
                silences: 0,
            })
            .collect();
        Liveness {
            decoder: SensorDecoder::new(rig),
            sensors,
            started_ns,
        }
    }

    /// Decodes one frame that arrived at `arrival_ns`.
    pub fn on_frame(&mut self, frame: &Frame, arrival_ns: i64) {
        let Liveness {
            decoder, sensors, ..
        } = self;
        let mut heartbeats = Vec::new();
        decoder.decode(frame, |event| match event {
            SensorEvent::Sample(sample) => {
                let state = &mut sensors[sample.sensor];
                state.samples += 1;
                state.first_sample_ns.get_or_insert(sample.time_ns);
                state.last_sample_ns = Some(sample.time_ns);
                state.last_arrival_ns = Some(arrival_ns);
                state.last_value = sample.value;
            }
            SensorEvent::Heartbeat { bus, event } => heartbeats.push((bus, event)),
        });
        for (bus, event) in heartbeats {
            self.on_heartbeat(bus, event);
        }
    }

    fn on_heartbeat(&mut self, bus: usize, event: HeartbeatEvent) {
        let (node, lost, state) = match event {
            HeartbeatEvent::StateChanged { node, state, .. } => (node, false, Some(state)),
            HeartbeatEvent::Lost { node, .. } => (node, true, None),
        };
        let members: Vec<usize> = self.decoder.node_sensors(bus, node).collect();
        for index in members {
            let sensor = &mut self.sensors[index];
            sensor.heartbeat_lost = lost;
            if state.is_some() {
                sensor.nmt_state = state;
            }
        }
    }

    /// Re-evaluates silence at `now_ns`.
    pub fn tick(&mut self, now_ns: i64) {
        let mut heartbeats = Vec::new();
        self.decoder.check_heartbeats(now_ns, |event| {
            if let SensorEvent::Heartbeat { bus, event } = event {
                heartbeats.push((bus, event));
            }
        });
        for (bus, event) in heartbeats {
            self.on_heartbeat(bus, event);
        }
        for sensor in &mut self.sensors {
            let reference = sensor.last_arrival_ns.unwrap_or(self.started_ns);
            let silent =
                sensor.heartbeat_lost || now_ns - reference > SILENCE_PERIODS * sensor.period_ns;
            if silent && !sensor.silent {
                sensor.silences += 1;
            }
            sensor.silent = silent;
        }
    }

    pub fn records(&self) -> Vec<SensorRecord> {
        self.sensors
            .iter()
            .map(|s| SensorRecord {
                name: s.name.clone(),
                unit: s.unit.to_owned(),
                expected_rate_hz: s.expected_rate_hz,
                samples: s.samples,
                observed_rate_hz: (s.observed_rate_hz() * 1000.0).round() / 1000.0,
                last_value: s.last_value,
                silent_at_end: s.silent,
                silences: s.silences,
            })
            .collect()
    }
}
