//! The rig file: which buses a test uses and, per sensor, what it measures,
//! how it is addressed on the bus and how its value is scaled.
//!
//! ```toml
//! [rig]
//! name = "DX55 front attachment"
//!
//! [[bus]]
//! name = "machine"
//! iface = "can0"
//! bitrate = 250000
//! dbc = ["../dbc/daq.dbc"]        # relative to this file
//!
//! [[sensor]]
//! name = "boom_head_pressure"
//! kind = "pressure"                # pressure | force | strain | inclination | displacement
//! rate_hz = 100                    # expected rate; silence past 3 periods is a gap
//! canopen = { node_id = 0x25, pdo = 1, byte = 0, type = "int32", decimal_digits = 2, heartbeat_ms = 1000 }
//! ```
//!
//! Optional per sensor: `interpolation = "linear" | "hold" | "nearest"`
//! (how alignment reads between samples: linear for continuous values,
//! the default; hold for states), `range = [lo, hi]` (full scale in the
//! output unit, for saturation checks). Per bus: `clock_offset_ms` (this
//! bus's clock minus the reference clock) or `clock_sync = { signal,
//! reference }` (estimate it by cross-correlating a sensor of this bus with
//! one on another bus that sees the same event). `[[pair]] sensors = ["sg03",
//! "sg04"]` declares gauges that should read alike (symmetric points);
//! `[[row]] sensors = [...]` gauges in order along one member, each
//! expected near the line through its neighbours;
//! `[specimen] diameter_mm, gauge_length_mm` describes a tensile bar.
//!
//! Exactly one of `dbc = { message, signal }`, `canopen = {...}` or
//! `j1939 = { pgn, source_address, start_bit, length_bits, resolution, offset }`
//! says where the value is. `unit` is the unit the channel is sent in
//! (default: the DBC signal's unit, else the kind's own unit); the output is
//! always in the kind's unit (bar, kN, MPa, deg, mm). Optional `scale` and
//! `offset` apply the sensor's calibration in the channel's unit first.
//! Loading collects every problem in the file, each with its line.
//!
//! Besides the file itself ([`Rig::load`]):
//! - [`profiles`]: sensor physics (pressure, force, strain, inclination,
//!   displacement), a channel's unit to the kind's;
//! - [`sensors`]: frames -> samples through a rig, each sensor decoded in its
//!   own protocol (`acq-can`) and converted to its engineering unit.

pub mod bus_map;
mod error;
mod file;
mod lines;
mod load;
pub mod profiles;
mod record;
mod record_keys;
mod rows;
mod sections;
mod sensor_file;
pub mod sensors;

pub use bus_map::BusMapping;
pub use error::{RigError, RigProblem};
pub use record::{
    Accuracy, Certificate, PolynomialCertificate, SensorRecord, ShuntSetup, TemperatureEffect,
};
pub use rows::SensorRow;
pub use sensor_file::Transducer;

use std::path::PathBuf;

use acq_can::canopen::PdoMapping;
use acq_can::dbc::DbcDatabase;
use acq_can::frame::{CanId, IfaceName};
use acq_can::j1939::Spn;
use serde::Deserialize;

use crate::profiles::{pressure, Conversion, SensorKind};

// ---- The validated rig ------------------------------------------------------

/// One CAN bus of the rig.
#[derive(Clone, Debug)]
pub struct Bus {
    pub name: String,
    pub iface: IfaceName,
    pub bitrate: Option<u32>,
    /// DBC files as resolved paths.
    pub dbc_files: Vec<PathBuf>,
    /// All messages of this bus's DBC files.
    pub dbc: DbcDatabase,
    pub clock: BusClock,
}

/// How a bus's timestamps relate to the rig's reference clock.
#[derive(Clone, Debug, Default, PartialEq)]
pub enum BusClock {
    /// Same clock as the reference (one recorder stamps every bus).
    #[default]
    Reference,
    /// This bus's clock minus the reference clock, ms.
    OffsetMs(f64),
    /// Estimate the offset by cross-correlating `signal` (a sensor of this
    /// bus) with `reference` (a sensor on another bus): sensor indices.
    Estimate { signal: usize, reference: usize },
}

/// How to read a sensor between two of its samples.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Interpolation {
    /// Straight line between neighbours: continuous quantities.
    #[default]
    Linear,
    /// The last value until the next: states, counters, set points.
    Hold,
    /// The closer neighbour.
    Nearest,
}

impl Interpolation {
    pub fn name(self) -> &'static str {
        match self {
            Interpolation::Linear => "linear",
            Interpolation::Hold => "hold",
            Interpolation::Nearest => "nearest",
        }
    }
}

/// Two sensors that should read alike (gauges at symmetric points).
#[derive(Clone, Debug, PartialEq)]
pub struct SensorPair {
    /// Sensor indices.
    pub sensors: [usize; 2],
    /// Allowed difference relative to the larger magnitude, %.
    pub tolerance_pct: f64,
    /// Differences below this (output unit) are always accepted: two
    /// near-zero readings can differ by 100 % and still agree.
    pub tolerance: f64,
    pub line: usize,
}

/// Default pair tolerance, % of the larger reading.
pub const PAIR_TOLERANCE_PCT: f64 = 25.0;

/// A round tensile bar.
#[derive(Clone, Copy, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Specimen {
    pub diameter_mm: f64,
    /// Length the displacement is measured over (engineering strain = u / L).
    pub gauge_length_mm: f64,
}

impl Specimen {
    pub fn area_mm2(&self) -> f64 {
        std::f64::consts::PI * 0.25 * self.diameter_mm * self.diameter_mm
    }
}

/// Where a sensor's value is on the bus.
#[derive(Clone, Debug)]
pub enum SensorSource {
    Dbc {
        id: CanId,
        message: String,
        signal: String,
        signal_index: usize,
        /// The message's parameter group when the DBC declares it J1939: its
        /// frames then match by PGN from any source address and priority,
        /// as `acq decode` matches them (the DBC's own id often names 0xFE,
        /// where the machine's controller sends from its own address).
        j1939_pgn: Option<u32>,
        /// The one source address a J1939 message is taken from (rig file
        /// `dbc = { ..., source_address = 0x00 }`): two controllers that
        /// send one PGN stay apart.
        source_address: Option<u8>,
    },
    Canopen {
        node_id: u8,
        pdo: u8,
        cob_id: CanId,
        mapping: PdoMapping,
        /// Heartbeat producer period, if the node sends one.
        heartbeat_ms: Option<f64>,
    },
    J1939 {
        pgn: u32,
        /// `None`: accept any sender.
        source_address: Option<u8>,
        spn_number: Option<u32>,
        spn: Spn,
    },
}

impl SensorSource {
    pub fn protocol(&self) -> &'static str {
        match self {
            SensorSource::Dbc { .. } => "dbc",
            SensorSource::Canopen { .. } => "canopen",
            SensorSource::J1939 { .. } => "j1939",
        }
    }
}

/// One sensor, ready to decode.
#[derive(Clone, Debug)]
pub struct Sensor {
    pub name: String,
    pub kind: SensorKind,
    /// Index into [`Rig::buses`].
    pub bus: usize,
    pub source: SensorSource,
    /// Unit the channel is sent in.
    pub channel_unit: String,
    /// Unit of the sensor's values: its kind's, or an other quantity's own
    /// ([`Sensor::unit`]).
    pub output_unit: String,
    /// Expected sample rate.
    pub rate_hz: f64,
    /// Channel value -> output (calibration, then the kind's physics).
    pub conversion: Conversion,
    pub location: Option<u32>,
    pub description: Option<String>,
    pub interpolation: Interpolation,
    /// Full scale `[lo, hi]` in the output unit, if declared.
    pub range: Option<[f64; 2]>,
    /// What is known of the transducer's accuracy: its certificate and
    /// data sheet. Empty for a sensor without a record.
    pub record: SensorRecord,
    /// A zero window (`acq zero`, `acq record --zero-before`) sets this
    /// channel's offset: it reads its kind's zero at rest.
    pub zero_at_rest: bool,
    /// 1-based line of the sensor in the rig file.
    pub line: usize,
}

impl Rig {
    /// What each sensor's record says of its calibration on `today`
    /// (`YYYY-MM-DD`): a certificate past its due date, or no certificate
    /// at all, as lines a test engineer acts on.
    ///
    /// Sensors with neither a transducer record nor a certificate share
    /// a line for each source of their uncertainty: a rig of thirty bare
    /// channels is one or two facts, not thirty.
    pub fn calibration_status(&self, today: &str) -> Vec<String> {
        let bare = |s: &Sensor| s.record.transducer.is_none() && s.record.certificate.is_none();
        let scatter_only: Vec<&Sensor> = self
            .sensors
            .iter()
            .filter(|s| bare(s) && s.record.is_empty())
            .collect();
        let sheet_only: Vec<&Sensor> = self
            .sensors
            .iter()
            .filter(|s| bare(s) && !s.record.is_empty())
            .collect();
        let mut lines: Vec<String> = self
            .sensors
            .iter()
            .filter(|s| {
                let group = if s.record.is_empty() {
                    &scatter_only
                } else {
                    &sheet_only
                };
                !(bare(s) && group.len() > 1)
            })
            .map(|sensor| self.sensor_status(sensor, today))
            .collect();
        for (group, source) in [
            (
                &sheet_only,
                "their data sheets' accuracy and resolution only",
            ),
            (
                &scatter_only,
                "their uncertainty is the readings' scatter only",
            ),
        ] {
            if group.len() < 2 {
                continue;
            }
            let who = if group.len() == self.sensors.len() {
                format!("every sensor ({})", group.len())
            } else {
                let names: Vec<String> = group.iter().map(|s| format!("'{}'", s.name)).collect();
                format!("{} sensors ({})", group.len(), names.join(", "))
            };
            lines.push(format!("{who}: no certificate: {source}"));
        }
        lines
    }

    /// One sensor's calibration, as [`Rig::calibration_status`] says it.
    fn sensor_status(&self, sensor: &Sensor, today: &str) -> String {
        let who = match &sensor.record.transducer {
            Some(t) => {
                let made: Vec<&str> = [t.maker.as_deref(), t.model.as_deref()]
                    .into_iter()
                    .flatten()
                    .collect();
                format!(
                    "sensor '{}' ({}serial {}, {})",
                    sensor.name,
                    if made.is_empty() {
                        String::new()
                    } else {
                        format!("{}, ", made.join(" "))
                    },
                    t.serial,
                    t.entered_at
                )
            }
            None => format!("sensor '{}'", sensor.name),
        };
        match &sensor.record.certificate {
            Some(Certificate { due: Some(due), .. }) if due.as_str() < today => format!(
                "{who}: PAST DUE: its calibration was due on {due}; recalibrate it, or know that its certificate no longer vouches for it"
            ),
            Some(certificate) => format!(
                "{who}: certificate {} of {}, calibrated {}, due {}",
                certificate.id.as_deref().unwrap_or("(no number)"),
                certificate.lab.as_deref().unwrap_or("(no lab)"),
                certificate.date.as_deref().unwrap_or("(no date)"),
                certificate.due.as_deref().unwrap_or("(no due date)"),
            ),
            None => format!(
                "{who}: no certificate{}",
                if sensor.record.is_empty() {
                    ": its uncertainty is the readings' scatter only"
                } else {
                    ": its data sheet's accuracy and resolution only"
                }
            ),
        }
    }
}

impl Sensor {
    /// The unit of this sensor's output.
    pub fn unit(&self) -> &str {
        &self.output_unit
    }

    /// Expected period between samples, ns.
    pub fn period_ns(&self) -> i64 {
        (1e9 / self.rate_hz).round() as i64
    }
}

/// A hydraulic cylinder with a transducer on each chamber.
#[derive(Clone, Debug)]
pub struct Cylinder {
    pub name: String,
    pub bore: pressure::CylinderBore,
    /// The bore's and the rod's diameter tolerances, `+-mm` (0 when not stated).
    pub bore_tolerance_mm: f64,
    pub rod_tolerance_mm: f64,
    /// Sensor indices.
    pub head_sensor: usize,
    pub rod_sensor: usize,
}

/// A validated rig.
#[derive(Clone, Debug)]
pub struct Rig {
    pub name: String,
    pub description: Option<String>,
    pub path: PathBuf,
    /// The sensor file its sensors' records come from, if it names one.
    pub sensor_file: Option<PathBuf>,
    pub buses: Vec<Bus>,
    pub sensors: Vec<Sensor>,
    pub cylinders: Vec<Cylinder>,
    pub pairs: Vec<SensorPair>,
    /// `[[row]]`: sensors in order along one member.
    pub rows: Vec<SensorRow>,
    pub specimen: Option<Specimen>,
    /// Non-fatal remarks (skipped DBC messages and the like).
    pub warnings: Vec<String>,
}

/// The highest sensor rate a rig may declare, Hz: more frames per second
/// than a CAN bus carries at 8 Mbit/s, so anything above is a typo.
pub const MAX_RATE_HZ: f64 = 100_000.0;
