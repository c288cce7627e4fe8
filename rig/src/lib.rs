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

use std::collections::HashMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use acq_metrology::bridge::{BridgeArm, BridgeType, ShuntCheck, StrainConversion};
use acq_metrology::curve::CalibrationCurve;
use serde::Deserialize;
use toml::Spanned;

mod lines;
pub mod profiles;
mod record_keys;
mod rows;
mod sensor_file;
pub mod sensors;
pub use rows::SensorRow;
pub use sensor_file::Transducer;

use lines::line_of;
use record_keys::{AccuracyFile, CalibrationFile, TemperatureFile};

use crate::profiles::{
    displacement, force, inclination, pressure, strain, Conversion, Linear, ProfileError,
    SensorKind,
};
use acq_can::bits::BitField;
use acq_can::canopen::{self, PdoMapping, PdoType};
use acq_can::dbc::DbcDatabase;
use acq_can::frame::{CanId, IfaceName};
use acq_can::j1939::Spn;

// ---- The file as written ----------------------------------------------------

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RigFile {
    rig: Option<RigMetaFile>,
    #[serde(default, rename = "bus")]
    buses: Vec<Spanned<BusFile>>,
    #[serde(default, rename = "sensor")]
    sensors: Vec<Spanned<SensorFile>>,
    #[serde(default, rename = "cylinder")]
    cylinders: Vec<Spanned<CylinderFile>>,
    #[serde(default, rename = "pair")]
    pairs: Vec<Spanned<PairFile>>,
    #[serde(default, rename = "row")]
    rows: Vec<Spanned<rows::RowFile>>,
    specimen: Option<Spanned<Specimen>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct PairFile {
    sensors: [String; 2],
    tolerance_pct: Option<f64>,
    tolerance: Option<f64>,
}

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct ClockSyncFile {
    signal: String,
    reference: String,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RigMetaFile {
    name: Option<String>,
    description: Option<String>,
    /// Transducers' records shared by rigs, keyed by serial number.
    sensor_file: Option<String>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct BusFile {
    name: String,
    iface: String,
    bitrate: Option<u32>,
    #[serde(default)]
    dbc: Vec<String>,
    clock_offset_ms: Option<f64>,
    clock_sync: Option<ClockSyncFile>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SensorFile {
    name: String,
    /// The transducer's serial number: its record comes from the rig's
    /// sensor file.
    serial: Option<String>,
    kind: SensorKind,
    bus: Option<String>,
    unit: Option<String>,
    rate_hz: f64,
    scale: Option<f64>,
    offset: Option<f64>,
    dbc: Option<DbcAddress>,
    canopen: Option<CanopenAddress>,
    j1939: Option<J1939Address>,
    // Profile constants.
    gauge_factor: Option<f64>,
    bridge: Option<strain::Bridge>,
    youngs_modulus_gpa: Option<f64>,
    mm_per_mv_per_v: Option<f64>,
    /// Gauge or measuring-point number on the structure.
    location: Option<u32>,
    description: Option<String>,
    interpolation: Option<Interpolation>,
    range: Option<[f64; 2]>,
    /// The certificate: points (reading, value), their uncertainties, dates.
    calibration: Option<CalibrationFile>,
    /// The data sheet's accuracy limit (rectangular).
    accuracy: Option<AccuracyFile>,
    /// The smallest step of the value, in the kind's unit.
    resolution: Option<f64>,
    /// The shunt resistor a strain channel's amplifier switches in, and the
    /// arm it goes across (`acq shunt`).
    shunt: Option<ShuntFile>,
    /// The data sheet's temperature coefficients and the rig's temperatures.
    temperature: Option<TemperatureFile>,
    /// The gauge factor's tolerance, `+-%` (the gauge maker's lot value).
    gauge_factor_tolerance_pct: Option<f64>,
    /// The standard uncertainty of `youngs_modulus_gpa`, GPa.
    youngs_modulus_uncertainty_gpa: Option<f64>,
    /// Whether the channel reads its kind's zero at rest, so that a zero
    /// window sets its offset; by default pressures, forces, strains and
    /// displacements do and inclinations do not.
    zero_at_rest: Option<bool>,
}

/// `shunt = { resistor_ohm = 100000, gauge_ohm = 350, ... }` of a strain sensor.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ShuntFile {
    resistor_ohm: f64,
    /// `+-%`, rectangular.
    #[serde(default)]
    resistor_tolerance_pct: f64,
    /// The shunted arm's resistance (the gauge's, with its leads where the
    /// shunt is switched in at the amplifier).
    gauge_ohm: f64,
    #[serde(default)]
    gauge_tolerance_pct: f64,
    /// 1-4: arms 1 and 3 raise the output when their resistance rises.
    #[serde(default = "first_arm")]
    arm: u8,
    /// `"linear"` (default) or `"bridge_law"` (the amplifier inverts the
    /// bridge's exact law).
    conversion: Option<String>,
    /// How far the step may be off the expected one before the check is
    /// refused, %.
    #[serde(default = "default_shunt_tolerance_pct")]
    tolerance_pct: f64,
}

fn first_arm() -> u8 {
    1
}

/// A healthy channel shows the shunt's step within a fraction of a per
/// cent; 1 % leaves room for lead resistance and still catches a wrong
/// gauge factor (2.0 against 2.1 is 5 %) or bridge type (a factor of 2).
fn default_shunt_tolerance_pct() -> f64 {
    1.0
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct DbcAddress {
    message: String,
    signal: String,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct CanopenAddress {
    node_id: u8,
    pdo: u8,
    byte: usize,
    #[serde(rename = "type")]
    data_type: PdoType,
    #[serde(default)]
    decimal_digits: u8,
    heartbeat_ms: Option<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct J1939Address {
    pgn: u32,
    source_address: Option<u8>,
    spn: Option<u32>,
    start_bit: u64,
    length_bits: u64,
    resolution: f64,
    offset: f64,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct CylinderFile {
    name: String,
    bore_mm: f64,
    rod_mm: f64,
    /// The bore's and the rod's diameter tolerance, `+-mm` (rectangular).
    bore_tolerance_mm: Option<f64>,
    rod_tolerance_mm: Option<f64>,
    head_sensor: String,
    rod_sensor: String,
}

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

/// A transducer's certificate and data-sheet limits, as the rig states them.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SensorRecord {
    /// The line through the certificate's points; it is the sensor's
    /// conversion (reading to value) where given.
    pub curve: Option<CalibrationCurve>,
    /// A certificate's polynomial instead, with its stated uncertainty.
    pub polynomial: Option<PolynomialCertificate>,
    pub certificate: Option<Certificate>,
    /// The data sheet's limit, rectangular.
    pub accuracy: Option<Accuracy>,
    /// The smallest step of the value, in the kind's unit.
    pub resolution: Option<f64>,
    /// A strain channel's shunt calibration set-up.
    pub shunt: Option<ShuntSetup>,
    /// How far the rig's temperature may move the value.
    pub temperature: Option<TemperatureEffect>,
    /// A strain channel's gauge factor tolerance, `+-%`: a span error.
    pub gauge_factor_tolerance_pct: Option<f64>,
    /// A strain channel's Young's modulus and its standard uncertainty,
    /// GPa: the stress is the strain times it.
    pub youngs_modulus_gpa: Option<(f64, f64)>,
    /// Which transducer it is, when the record came from a sensor file.
    pub transducer: Option<Transducer>,
}

/// A certificate that states a polynomial (reading to value) and one
/// expanded uncertainty for it over its range.
#[derive(Clone, Debug, PartialEq)]
pub struct PolynomialCertificate {
    /// `c0, c1, ...`: value `= sum c_i r^i`.
    pub coefficients: Vec<f64>,
    /// The stated expanded uncertainty over its `k`.
    pub standard_uncertainty: f64,
}

/// A data sheet's temperature coefficients over the rig's temperatures:
/// the largest departure from the reference temperature bounds the drift.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TemperatureEffect {
    pub zero_pct_fs_per_k: f64,
    pub span_pct_per_k: f64,
    /// `max |T - T_ref|` over the rig's range, K.
    pub largest_departure_k: f64,
}

/// What a strain channel's shunt check needs besides the recorded step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShuntSetup {
    /// The bridge, the shunt and the gauge; its measured step is 0 until
    /// [`ShuntSetup::check`] gives it one.
    pub bridge: ShuntCheck,
    /// The channel's values are stress: MPa per unit strain (`E`).
    pub stress_mpa_per_strain: f64,
    /// The largest `|measured / expected - 1|` corrected, %.
    pub tolerance_pct: f64,
}

impl ShuntSetup {
    /// The check of a measured step of the channel's value (MPa) with its
    /// standard error and degrees of freedom.
    pub fn check(&self, step_mpa: f64, standard_error_mpa: f64, dof: Option<f64>) -> ShuntCheck {
        ShuntCheck {
            measured_strain: step_mpa / self.stress_mpa_per_strain,
            measured_standard_error_strain: standard_error_mpa / self.stress_mpa_per_strain,
            measured_dof: dof,
            ..self.bridge
        }
    }
}

impl Rig {
    /// What each sensor's record says of its calibration on `today`
    /// (`YYYY-MM-DD`): a certificate past its due date, or no certificate
    /// at all, as lines a test engineer acts on.
    pub fn calibration_status(&self, today: &str) -> Vec<String> {
        self.sensors
            .iter()
            .map(|sensor| {
                let who = match &sensor.record.transducer {
                    Some(t) => {
                        let made: Vec<&str> = [t.maker.as_deref(), t.model.as_deref()]
                            .into_iter()
                            .flatten()
                            .collect();
                        format!(
                            "sensor '{}' ({}serial {}, {})",
                            sensor.name,
                            if made.is_empty() { String::new() } else { format!("{}, ", made.join(" ")) },
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
            })
            .collect()
    }
}

impl SensorRecord {
    /// Whether anything is known beyond the readings' own scatter.
    pub fn is_empty(&self) -> bool {
        self.curve.is_none()
            && self.polynomial.is_none()
            && self.accuracy.is_none()
            && self.resolution.is_none()
            && self.temperature.is_none()
            && self.gauge_factor_tolerance_pct.is_none()
            && self.youngs_modulus_gpa.is_none()
    }
}

/// Where a calibration was made, and until when it holds.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Certificate {
    pub lab: Option<String>,
    pub id: Option<String>,
    /// `YYYY-MM-DD`.
    pub date: Option<String>,
    pub due: Option<String>,
}

/// A data sheet's accuracy limit, `+-` this share.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Accuracy {
    /// Of the full scale (the `range`'s span), %.
    PercentOfFullScale(f64),
    /// Of the reading, %.
    PercentOfReading(f64),
    /// The class's parts as a data sheet states them, each % of full
    /// scale (0 where not stated).
    PartsOfFullScale {
        nonlinearity: f64,
        hysteresis: f64,
        repeatability: f64,
    },
}

impl Sensor {
    /// The unit of this sensor's output.
    pub fn unit(&self) -> &'static str {
        self.kind.output_unit()
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

/// Each `[[sensor]]` that names a `serial` takes its transducer's record
/// from the sensor file; what each sensor is, by name.
fn take_transducer_records(
    sensors: &mut [Spanned<SensorFile>],
    sensor_file: Option<&Path>,
    findings: &mut RigFindings,
) -> HashMap<String, Transducer> {
    let mut transducers = HashMap::new();
    let mut records = None;
    for spanned in sensors.iter_mut() {
        let line = line_of(findings.text, spanned.span().start);
        let sensor = spanned.get_mut();
        let Some(serial) = sensor.serial.clone() else {
            continue;
        };
        let Some(path) = sensor_file else {
            findings.report(line, format!("sensor '{}': serial = \"{serial}\" needs the rig's sensor file: add sensor_file = \"sensors.toml\" under [rig]", sensor.name));
            continue;
        };
        if let Some((other, _)) = transducers
            .iter()
            .find(|(_, t): &(&String, &Transducer)| t.serial == serial)
        {
            findings.report(line, format!("sensor '{}': serial '{serial}' is sensor '{other}' already; one transducer cannot be two channels", sensor.name));
            continue;
        }
        let loaded = records.get_or_insert_with(|| sensor_file::SensorRecords::load(path));
        let merged = match loaded {
            Ok(records) => records.take(&serial).and_then(|(record, transducer)| {
                merge_record(sensor, record, &transducer.entered_at)?;
                Ok(transducer)
            }),
            Err(message) => {
                findings.report(line, format!("sensor '{}': {message}", sensor.name));
                break;
            }
        };
        match merged {
            Ok(transducer) => {
                transducers.insert(sensor.name.clone(), transducer);
            }
            Err(message) => findings.report(line, format!("sensor '{}': {message}", sensor.name)),
        }
    }
    transducers
}

/// Gives `sensor` every key of a transducer's `record` that the rig
/// leaves out; a key both state is refused (one place says it).
fn merge_record(
    sensor: &mut SensorFile,
    mut record: sensor_file::TransducerRecord,
    entered_at: &str,
) -> Result<(), String> {
    let both = |key: &str| {
        format!("both the rig and the transducer's record ({entered_at}) state {key}; keep one")
    };
    fill(&mut sensor.range, &mut record.range).map_err(|_| both("range"))?;
    fill(&mut sensor.calibration, &mut record.calibration).map_err(|_| both("calibration"))?;
    fill(&mut sensor.accuracy, &mut record.accuracy).map_err(|_| both("accuracy"))?;
    fill(&mut sensor.resolution, &mut record.resolution).map_err(|_| both("resolution"))?;
    fill(&mut sensor.temperature, &mut record.temperature).map_err(|_| both("temperature"))?;
    fill(
        &mut sensor.gauge_factor_tolerance_pct,
        &mut record.gauge_factor_tolerance_pct,
    )
    .map_err(|_| both("gauge_factor_tolerance_pct"))
}

/// Moves `from` into `into` when only `from` holds a value; an error when
/// both do.
fn fill<T>(into: &mut Option<T>, from: &mut Option<T>) -> Result<(), ()> {
    match (into.is_some(), from.is_some()) {
        (true, true) => Err(()),
        (false, true) => {
            *into = from.take();
            Ok(())
        }
        _ => Ok(()),
    }
}

/// The highest sensor rate a rig may declare, Hz: more frames per second
/// than a CAN bus carries at 8 Mbit/s, so anything above is a typo.
pub const MAX_RATE_HZ: f64 = 100_000.0;

/// One thing wrong in a rig file.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct RigProblem {
    /// 1-based line, when known.
    pub line: Option<usize>,
    pub message: String,
}

/// A rig file that cannot be used, with every problem found.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct RigError {
    pub path: PathBuf,
    pub problems: Vec<RigProblem>,
}

impl std::fmt::Display for RigError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let count = self.problems.len();
        write!(
            f,
            "{} has {count} problem{}:",
            self.path.display(),
            if count == 1 { "" } else { "s" }
        )?;
        for problem in &self.problems {
            match problem.line {
                Some(line) => write!(f, "\n  {}:{line}: {}", self.path.display(), problem.message)?,
                None => write!(f, "\n  {}: {}", self.path.display(), problem.message)?,
            }
        }
        Ok(())
    }
}

impl std::error::Error for RigError {}

impl Rig {
    /// Reads, parses and validates a rig file (and the DBC files it names).
    pub fn load(path: &Path) -> Result<Rig, RigError> {
        let fail = |message: String| RigError {
            path: path.to_path_buf(),
            problems: vec![RigProblem {
                line: None,
                message,
            }],
        };
        // A FIFO or a device would block or never end.
        if std::fs::metadata(path).is_ok_and(|m| !m.is_file()) {
            return Err(fail(
                "not a regular file; give the rig file's path".to_string(),
            ));
        }
        let text = std::fs::read_to_string(path)
            .map_err(|e| fail(format!("cannot read the rig file: {e}")))?;
        let base = path.parent().unwrap_or(Path::new("."));
        Self::parse(&text, path, base)
    }

    /// Parses rig text; DBC paths are resolved against `base`.
    pub fn parse(text: &str, path: &Path, base: &Path) -> Result<Rig, RigError> {
        let mut file: RigFile = toml::from_str(text).map_err(|e| RigError {
            path: path.to_path_buf(),
            problems: vec![RigProblem {
                line: e.span().map(|s| line_of(text, s.start)),
                message: e.message().trim().to_string(),
            }],
        })?;
        let mut findings = RigFindings {
            text,
            problems: Vec::new(),
            warnings: Vec::new(),
        };
        if file.sensors.is_empty() {
            findings.report(1, "no [[sensor]] defined: a rig needs at least one".into());
        }
        if file.buses.is_empty() {
            findings.report(
                1,
                "no [[bus]] defined: add one with name, iface (e.g. can0) and its dbc files".into(),
            );
        }
        let mut buses = read_buses(&file.buses, base, &mut findings);
        let sensor_file = file
            .rig
            .as_ref()
            .and_then(|meta| meta.sensor_file.as_deref())
            .map(|name| base.join(name));
        let transducers =
            take_transducer_records(&mut file.sensors, sensor_file.as_deref(), &mut findings);
        let mut sensors = read_sensors(&file.sensors, &buses, &mut findings);
        for sensor in &mut sensors {
            sensor.record.transducer = transducers.get(&sensor.name).cloned();
        }
        let cylinders = read_cylinders(&file.cylinders, &sensors, &mut findings);
        resolve_clock_sync(&file.buses, &mut buses, &sensors, &mut findings);
        let pairs = read_pairs(&file.pairs, &sensors, &mut findings);
        let named: Vec<(&str, SensorKind)> =
            sensors.iter().map(|s| (s.name.as_str(), s.kind)).collect();
        let (rows, row_problems) = rows::read_rows(&file.rows, &named, findings.text);
        for (line, message) in row_problems {
            findings.report(line, message);
        }
        let specimen = read_specimen(file.specimen.as_ref(), &mut findings);
        let RigFindings {
            problems, warnings, ..
        } = findings;

        if !problems.is_empty() {
            return Err(RigError {
                path: path.to_path_buf(),
                problems,
            });
        }
        let meta = file.rig.unwrap_or(RigMetaFile {
            name: None,
            description: None,
            sensor_file: None,
        });
        Ok(Rig {
            name: meta.name.unwrap_or_else(|| {
                path.file_stem()
                    .map(|s| s.to_string_lossy().into_owned())
                    .unwrap_or_default()
            }),
            description: meta.description,
            path: path.to_path_buf(),
            sensor_file,
            buses,
            sensors,
            cylinders,
            pairs,
            rows,
            specimen,
            warnings,
        })
    }

    /// Points the rig's buses at the interfaces a recording used: unchanged
    /// when every bus's interface is among them (or the rig has one bus),
    /// else bus by bus in order. Returns a note per remapped bus, or why the
    /// interfaces cannot be matched.
    pub fn assign_interfaces(&mut self, interfaces: &[IfaceName]) -> Result<Vec<String>, String> {
        if self.buses.len() == 1 || self.buses.iter().all(|b| interfaces.contains(&b.iface)) {
            return Ok(Vec::new());
        }
        if self.buses.len() != interfaces.len() {
            let names: Vec<String> = self
                .buses
                .iter()
                .map(|b| format!("{} ({})", b.name, b.iface))
                .collect();
            return Err(format!(
                "the rig has buses {} but {} interface(s) were used; give one interface per rig bus, in order",
                names.join(", "),
                interfaces.len()
            ));
        }
        let mut notes = Vec::new();
        for (bus, iface) in self.buses.iter_mut().zip(interfaces) {
            if bus.iface != *iface {
                notes.push(format!(
                    "rig bus {} ({}) recorded on {iface}",
                    bus.name, bus.iface
                ));
                bus.iface = *iface;
            }
        }
        Ok(notes)
    }

    pub fn sensor(&self, name: &str) -> Option<(usize, &Sensor)> {
        self.sensors
            .iter()
            .enumerate()
            .find(|(_, s)| s.name == name)
    }

    /// A plain-text account of the rig: what `acq check-rig` prints.
    pub fn explain(&self) -> String {
        let mut text = String::new();
        let _ = writeln!(text, "rig '{}' ({}): OK", self.name, self.path.display());
        if let Some(description) = &self.description {
            let _ = writeln!(text, "  {description}");
        }
        for bus in &self.buses {
            let bitrate = bus
                .bitrate
                .map(|b| format!(", {} kbit/s", b / 1000))
                .unwrap_or_default();
            let _ = writeln!(
                text,
                "bus '{}' on {}{bitrate}: {} DBC messages from {} file(s)",
                bus.name,
                bus.iface,
                bus.dbc.messages().len(),
                bus.dbc_files.len()
            );
        }
        let _ = writeln!(text, "{} sensors:", self.sensors.len());
        for sensor in &self.sensors {
            let address = match &sensor.source {
                SensorSource::Dbc { id, message, signal, .. } => format!("DBC {message}.{signal} (id {id})"),
                SensorSource::Canopen { node_id, pdo, cob_id, mapping, heartbeat_ms } => format!(
                    "CANopen node 0x{node_id:02X} TPDO{pdo} (COB-ID {cob_id}) {} at byte {}, {} decimal digits{}",
                    mapping.data_type.name(),
                    mapping.field.end_byte() - mapping.data_type.size_bytes(),
                    mapping.decimal_digits,
                    heartbeat_ms.map(|h| format!(", heartbeat {h} ms")).unwrap_or_default()
                ),
                SensorSource::J1939 { pgn, source_address, spn_number, spn } => format!(
                    "J1939 PGN {pgn}{} from {}, {} bits x {} + {}",
                    spn_number.map(|n| format!(" SPN {n}")).unwrap_or_default(),
                    source_address.map(|a| format!("SA 0x{a:02X}")).unwrap_or_else(|| "any SA".into()),
                    spn.field.length_bits(),
                    spn.resolution,
                    spn.offset
                ),
            };
            let _ = writeln!(
                text,
                "  {:<24} {:<12} {:>7} Hz  {} -> {}  {}",
                sensor.name,
                sensor.kind.name(),
                sensor.rate_hz,
                sensor.channel_unit,
                sensor.unit(),
                address
            );
        }
        for cylinder in &self.cylinders {
            let _ = writeln!(
                text,
                "cylinder '{}': bore {} mm, rod {} mm, head {} / rod {}",
                cylinder.name,
                cylinder.bore.bore_diameter_mm,
                cylinder.bore.rod_diameter_mm,
                self.sensors[cylinder.head_sensor].name,
                self.sensors[cylinder.rod_sensor].name
            );
        }
        for row in &self.rows {
            let names: Vec<&str> = row
                .sensors
                .iter()
                .map(|&k| self.sensors[k].name.as_str())
                .collect();
            let _ = writeln!(
                text,
                "row {}: each expected near the line through its neighbours",
                names.join(", ")
            );
        }
        for pair in &self.pairs {
            let [a, b] = pair.sensors;
            let _ = writeln!(
                text,
                "pair {} / {}: should agree within {} % (or {} {})",
                self.sensors[a].name,
                self.sensors[b].name,
                pair.tolerance_pct,
                pair.tolerance,
                self.sensors[a].unit()
            );
        }
        for bus in &self.buses {
            match bus.clock {
                BusClock::Reference => {}
                BusClock::OffsetMs(ms) => {
                    let _ = writeln!(
                        text,
                        "bus '{}' clock: {ms} ms ahead of the reference",
                        bus.name
                    );
                }
                BusClock::Estimate { signal, reference } => {
                    let _ = writeln!(
                        text,
                        "bus '{}' clock: offset estimated from {} against {}",
                        bus.name, self.sensors[signal].name, self.sensors[reference].name
                    );
                }
            }
        }
        if let Some(specimen) = &self.specimen {
            let _ = writeln!(
                text,
                "specimen: diameter {} mm ({:.4} mm^2), gauge length {} mm",
                specimen.diameter_mm,
                specimen.area_mm2(),
                specimen.gauge_length_mm
            );
        }
        for warning in &self.warnings {
            let _ = writeln!(text, "warning: {warning}");
        }
        text
    }
}

/// Protocol addressing -> compiled source, plus the channel unit the
/// protocol itself declares (a DBC signal's unit).
fn compile_source(
    sensor: &SensorFile,
    bus: &Bus,
) -> Result<(SensorSource, Option<String>), String> {
    if let Some(address) = &sensor.dbc {
        let Some(message) = bus.dbc.message_by_name(&address.message) else {
            let known: Vec<&str> = bus
                .dbc
                .messages()
                .iter()
                .map(|m| m.name.as_str())
                .take(20)
                .collect();
            return Err(if bus.dbc_files.is_empty() {
                format!(
                    "DBC message '{}' but bus '{}' has no dbc files",
                    address.message, bus.name
                )
            } else {
                format!(
                    "unknown DBC message '{}' on bus '{}' (messages: {})",
                    address.message,
                    bus.name,
                    known.join(", ")
                )
            });
        };
        let Some((signal_index, signal)) = message.signal(&address.signal) else {
            let known: Vec<&str> = message.signals.iter().map(|s| s.name.as_str()).collect();
            return Err(format!(
                "unknown signal '{}' in DBC message '{}' (signals: {})",
                address.signal,
                message.name,
                known.join(", ")
            ));
        };
        let unit = (!signal.unit.is_empty()).then(|| signal.unit.clone());
        return Ok((
            SensorSource::Dbc {
                id: message.id,
                message: message.name.clone(),
                signal: signal.name.clone(),
                signal_index,
            },
            unit,
        ));
    }
    if let Some(address) = &sensor.canopen {
        let cob_id = canopen::tpdo_cob_id(address.pdo, address.node_id).ok_or_else(|| {
            format!(
                "canopen node_id must be 1..=127 and pdo 1..=4 (TPDO1-4), got node_id {} pdo {}",
                address.node_id, address.pdo
            )
        })?;
        let mapping = PdoMapping::new(address.byte, address.data_type, address.decimal_digits)
            .map_err(|e| format!("canopen mapping: {e}"))?;
        if let Some(period) = address.heartbeat_ms {
            if !(period > 0.0 && period.is_finite()) {
                return Err(format!(
                    "canopen heartbeat_ms must be positive, got {period}"
                ));
            }
        }
        return Ok((
            SensorSource::Canopen {
                node_id: address.node_id,
                pdo: address.pdo,
                cob_id,
                mapping,
                heartbeat_ms: address.heartbeat_ms,
            },
            None,
        ));
    }
    let address = sensor.j1939.as_ref().ok_or("no address")?;
    if address.pgn > 0x3_FFFF {
        return Err(format!("j1939 pgn {} is larger than 18 bits", address.pgn));
    }
    let field = BitField::new(
        acq_can::bits::ByteOrder::LittleEndian,
        address.start_bit,
        address.length_bits,
    )
    .ok()
    .ok_or_else(|| {
        format!(
            "j1939 field of {} bits at bit {} does not fit in 64 bytes (a parameter group longer than 8 bytes comes by the transport protocol; acq reads SPNs in its first 64)",
            address.length_bits, address.start_bit
        )
    })?;
    if !(address.resolution.is_finite() && address.resolution != 0.0 && address.offset.is_finite())
    {
        return Err("j1939 resolution must be a non-zero number and offset a number".into());
    }
    Ok((
        SensorSource::J1939 {
            pgn: address.pgn,
            source_address: address.source_address,
            spn_number: address.spn,
            spn: Spn {
                field,
                resolution: address.resolution,
                offset: address.offset,
            },
        },
        None,
    ))
}

fn profile_conversion(sensor: &SensorFile, unit: &str) -> Result<Linear, ProfileError> {
    match sensor.kind {
        SensorKind::Pressure => pressure::to_bar(unit),
        SensorKind::Force => force::to_kilonewton(unit),
        SensorKind::Inclination => inclination::to_degrees(unit),
        SensorKind::Displacement => displacement::to_millimetres(unit, sensor.mm_per_mv_per_v),
        SensorKind::Strain => strain::to_stress_mpa(
            unit,
            strain::StrainChannel {
                youngs_modulus_gpa: sensor.youngs_modulus_gpa.ok_or_else(|| {
                    ProfileError::Invalid(
                        "a strain sensor needs youngs_modulus_gpa (SWS490A steel: 210)".into(),
                    )
                })?,
                gauge_factor: sensor.gauge_factor,
                bridge: sensor.bridge,
            },
        ),
    }
}

/// What reading a rig file found: each problem with its line, and the
/// warnings of its DBC files (entries they skip).
struct RigFindings<'t> {
    text: &'t str,
    problems: Vec<RigProblem>,
    warnings: Vec<String>,
}

impl RigFindings<'_> {
    fn report(&mut self, line: usize, message: String) {
        self.problems.push(RigProblem {
            line: Some(line),
            message,
        });
    }
}

/// `[[bus]]`: each bus with its interface, its DBC files merged, and its
/// clock (a `clock_sync`'s sensors are resolved once every sensor is known).
fn read_buses(entries: &[Spanned<BusFile>], base: &Path, findings: &mut RigFindings) -> Vec<Bus> {
    let mut buses: Vec<Bus> = Vec::new();
    for spanned in entries {
        let line = line_of(findings.text, spanned.span().start);
        let bus = spanned.get_ref();
        if buses.iter().any(|b| b.name == bus.name) {
            findings.report(line, format!("bus '{}' is defined twice", bus.name));
            continue;
        }
        let Some(iface) = IfaceName::new(&bus.iface) else {
            findings.report(
                line,
                format!(
                    "bus '{}': iface '{}' is not an interface name (1-15 characters, no spaces)",
                    bus.name, bus.iface
                ),
            );
            continue;
        };
        let mut database = DbcDatabase::new();
        let mut dbc_files = Vec::new();
        for relative in &bus.dbc {
            let dbc_path = base.join(relative);
            if !dbc_path.is_file() {
                findings.report(
                    line,
                    format!(
                        "bus '{}': DBC file {} not found (paths are relative to the rig file)",
                        bus.name,
                        dbc_path.display()
                    ),
                );
                continue;
            }
            match DbcDatabase::load(&dbc_path).and_then(|(one, skipped)| {
                database.merge(one)?;
                Ok(skipped)
            }) {
                Ok(skipped) => findings.warnings.extend(skipped.into_iter().map(|w| w.0)),
                Err(e) => findings.report(line, format!("bus '{}': {e}", bus.name)),
            }
            dbc_files.push(dbc_path);
        }
        let clock = match (bus.clock_offset_ms, &bus.clock_sync) {
            (Some(_), Some(_)) => {
                findings.report(
                    line,
                    format!(
                        "bus '{}': give clock_offset_ms or clock_sync, not both",
                        bus.name
                    ),
                );
                BusClock::Reference
            }
            (Some(ms), None) if !ms.is_finite() => {
                findings.report(
                    line,
                    format!(
                        "bus '{}': clock_offset_ms must be a number of milliseconds",
                        bus.name
                    ),
                );
                BusClock::Reference
            }
            (Some(ms), None) => BusClock::OffsetMs(ms),
            // Sensor names are resolved once every sensor is known.
            (None, _) => BusClock::Reference,
        };
        buses.push(Bus {
            name: bus.name.clone(),
            iface,
            bitrate: bus.bitrate,
            dbc_files,
            dbc: database,
            clock,
        });
    }
    buses
}

/// `[[sensor]]`: each sensor once, then the sensors that share an address.
fn read_sensors(
    entries: &[Spanned<SensorFile>],
    buses: &[Bus],
    findings: &mut RigFindings,
) -> Vec<Sensor> {
    let mut sensors: Vec<Sensor> = Vec::new();
    let mut names: HashMap<String, usize> = HashMap::new();
    for spanned in entries {
        let line = line_of(findings.text, spanned.span().start);
        let sensor = spanned.get_ref();
        let name = &sensor.name;
        if let Some(first) = names.insert(name.clone(), line) {
            findings.report(
                line,
                format!("sensor '{name}' is defined twice (first on line {first})"),
            );
            continue;
        }
        if let Some(sensor) = read_sensor(sensor, line, buses, findings) {
            sensors.push(sensor);
        }
    }
    check_overlaps(&sensors, buses, &mut |line, message| {
        findings.report(line, message)
    });
    sensors
}

/// One `[[sensor]]` on `line`: its bus, where it is on the bus, its unit,
/// conversion and range; `None` once a problem is reported.
fn read_sensor(
    sensor: &SensorFile,
    line: usize,
    buses: &[Bus],
    findings: &mut RigFindings,
) -> Option<Sensor> {
    let name = &sensor.name;
    if name.is_empty() || name.contains([',', '"', '\n']) {
        findings.report(line, format!("sensor name '{name}' must be non-empty without commas or quotes (it is a CSV column)"));
        return None;
    }
    if !(sensor.rate_hz > 0.0 && sensor.rate_hz <= MAX_RATE_HZ) {
        findings.report(line, format!("sensor '{name}': rate_hz must be a number of samples per second above 0 and at most {MAX_RATE_HZ} (a CAN FD bus carries fewer frames), got {}", sensor.rate_hz));
    }
    let bus = match (&sensor.bus, buses.len()) {
        (Some(bus_name), _) => match buses.iter().position(|b| &b.name == bus_name) {
            Some(i) => i,
            None => {
                let known: Vec<&str> = buses.iter().map(|b| b.name.as_str()).collect();
                findings.report(
                    line,
                    format!(
                        "sensor '{name}': unknown bus '{bus_name}' (buses: {})",
                        known.join(", ")
                    ),
                );
                return None;
            }
        },
        (None, 1) => 0,
        (None, 0) => return None,
        (None, _) => {
            findings.report(
                line,
                format!("sensor '{name}': the rig has several buses; say which with bus = \"...\""),
            );
            return None;
        }
    };
    let addresses = [
        sensor.dbc.is_some(),
        sensor.canopen.is_some(),
        sensor.j1939.is_some(),
    ];
    if addresses.iter().filter(|&&a| a).count() != 1 {
        findings.report(line, format!("sensor '{name}': give exactly one of dbc = {{ message, signal }}, canopen = {{ node_id, pdo, byte, type }} or j1939 = {{ pgn, start_bit, length_bits, resolution, offset }}"));
        return None;
    }
    let (source, default_unit) = match compile_source(sensor, &buses[bus]) {
        Ok(compiled) => compiled,
        Err(message) => {
            findings.report(line, format!("sensor '{name}': {message}"));
            return None;
        }
    };
    let channel_unit = sensor
        .unit
        .clone()
        .or(default_unit)
        .unwrap_or_else(|| sensor.kind.output_unit().to_string());
    let physics = match profile_conversion(sensor, &channel_unit) {
        Ok(physics) => physics,
        Err(e) => {
            findings.report(line, format!("sensor '{name}': {e}"));
            return None;
        }
    };
    let record = match read_record(sensor) {
        Ok(record) => record,
        Err(message) => {
            findings.report(line, format!("sensor '{name}': {message}"));
            return None;
        }
    };
    let calibration = Linear {
        gain: sensor.scale.unwrap_or(1.0),
        offset: sensor.offset.unwrap_or(0.0),
    };
    if !(calibration.gain.is_finite() && calibration.gain != 0.0 && calibration.offset.is_finite())
    {
        findings.report(
            line,
            format!("sensor '{name}': scale must be a non-zero number and offset a number"),
        );
        return None;
    }
    if let Some([lo, hi]) = sensor.range {
        if !(lo.is_finite() && hi.is_finite() && lo < hi) {
            findings.report(line, format!("sensor '{name}': range must be [low, high] with low < high in {}, got [{lo}, {hi}]", sensor.kind.output_unit()));
            return None;
        }
    }
    Some(Sensor {
        name: name.clone(),
        kind: sensor.kind,
        bus,
        source,
        channel_unit,
        rate_hz: sensor.rate_hz,
        // The certificate's points take the reading to the kind's unit
        // themselves: the physics is in them.
        conversion: match (&record.polynomial, &record.curve) {
            (Some(polynomial), _) => Conversion::Polynomial(polynomial.coefficients.clone()),
            (None, Some(curve)) => Conversion::Linear(Linear {
                gain: curve.slope,
                offset: curve.intercept - curve.slope * curve.reading_mean,
            }),
            (None, None) => Conversion::Linear(physics.after(calibration)),
        },
        location: sensor.location,
        description: sensor.description.clone(),
        interpolation: sensor.interpolation.unwrap_or_default(),
        range: sensor.range,
        record,
        zero_at_rest: sensor
            .zero_at_rest
            .unwrap_or(sensor.kind.reads_zero_at_rest()),
        line,
    })
}

/// A sensor's certificate and data-sheet limits, checked.
fn read_record(sensor: &SensorFile) -> Result<SensorRecord, String> {
    let unit = sensor.kind.output_unit();
    let mut record = SensorRecord::default();
    if let Some(calibration) = &sensor.calibration {
        if sensor.scale.is_some() || sensor.offset.is_some() {
            return Err("give either a certificate's calibration or scale and offset, not both (the certificate is the conversion)".into());
        }
        read_certificate_dates(calibration)?;
        match &calibration.polynomial {
            Some(coefficients) => {
                record.polynomial = Some(read_polynomial(sensor, calibration, coefficients)?)
            }
            None => record.curve = Some(read_points(calibration, unit)?),
        }
        record.certificate = Some(Certificate {
            lab: calibration.lab.clone(),
            id: calibration.certificate.clone(),
            date: calibration.date.clone(),
            due: calibration.due.clone(),
        });
    }
    if let Some(accuracy) = &sensor.accuracy {
        record.accuracy = Some(read_accuracy(sensor, accuracy)?);
    }
    if let Some(shunt) = &sensor.shunt {
        record.shunt = Some(read_shunt(sensor, shunt)?);
    }
    if let Some(temperature) = &sensor.temperature {
        record.temperature = Some(read_temperature(sensor, temperature)?);
    }
    read_strain_uncertainties(sensor, &mut record)?;
    if let Some(step) = sensor.resolution {
        if !(step.is_finite() && step > 0.0) {
            return Err(format!(
                "resolution = {step}: give the value's smallest step in {unit}, above 0"
            ));
        }
        record.resolution = Some(step);
    }
    Ok(record)
}

/// The data sheet's accuracy: one class (a share of full scale or of the
/// reading) or its parts (non-linearity, hysteresis, repeatability, each
/// a share of full scale), not both.
fn read_accuracy(sensor: &SensorFile, accuracy: &AccuracyFile) -> Result<Accuracy, String> {
    let unit = sensor.kind.output_unit();
    let parts = [
        accuracy.nonlinearity_pct_fs,
        accuracy.hysteresis_pct_fs,
        accuracy.repeatability_pct_fs,
    ];
    let needs_range = || {
        if sensor.range.is_none() {
            Err(format!(
                "accuracy: a share of full scale needs the sensor's range = [low, high] in {unit}"
            ))
        } else {
            Ok(())
        }
    };
    if parts.iter().any(Option::is_some) {
        if accuracy.percent_of_full_scale.is_some() || accuracy.percent_of_reading.is_some() {
            return Err("accuracy: give the class (percent_of_full_scale or percent_of_reading) or its parts (nonlinearity_pct_fs, hysteresis_pct_fs, repeatability_pct_fs), not both: the class already holds its parts".into());
        }
        if let Some(bad) = parts
            .iter()
            .flatten()
            .find(|p| !(p.is_finite() && **p >= 0.0))
        {
            return Err(format!(
                "accuracy: {bad} %: give each part as a share of at least 0"
            ));
        }
        needs_range()?;
        let [nonlinearity, hysteresis, repeatability] = parts.map(|p| p.unwrap_or(0.0));
        return Ok(Accuracy::PartsOfFullScale {
            nonlinearity,
            hysteresis,
            repeatability,
        });
    }
    match (accuracy.percent_of_full_scale, accuracy.percent_of_reading) {
        (Some(pct), None) if pct.is_finite() && pct > 0.0 => {
            needs_range()?;
            Ok(Accuracy::PercentOfFullScale(pct))
        }
        (None, Some(pct)) if pct.is_finite() && pct > 0.0 => Ok(Accuracy::PercentOfReading(pct)),
        (Some(pct), None) | (None, Some(pct)) => {
            Err(format!("accuracy: {pct} %: give a share above 0"))
        }
        _ => Err("accuracy: give one of percent_of_full_scale or percent_of_reading (or the parts nonlinearity_pct_fs, hysteresis_pct_fs, repeatability_pct_fs)".into()),
    }
}

/// The temperature coefficients, checked: non-negative, a range in order,
/// and a share of full scale only with the sensor's `range`.
fn read_temperature(
    sensor: &SensorFile,
    temperature: &TemperatureFile,
) -> Result<TemperatureEffect, String> {
    let [low, high] = temperature.range_c;
    let reference = temperature.reference_c;
    if !(low.is_finite() && high.is_finite() && reference.is_finite() && low <= high) {
        return Err(format!(
            "temperature: range_c = [{low}, {high}] with reference_c = {reference}: give the lowest and highest temperature at the rig, in C, lowest first"
        ));
    }
    for (key, value) in [
        ("zero_pct_fs_per_k", temperature.zero_pct_fs_per_k),
        ("span_pct_per_k", temperature.span_pct_per_k),
    ] {
        if !(value.is_finite() && value >= 0.0) {
            return Err(format!(
                "temperature: {key} = {value}: give the data sheet's coefficient as a limit of at least 0"
            ));
        }
    }
    if temperature.zero_pct_fs_per_k > 0.0 && sensor.range.is_none() {
        return Err(format!(
            "temperature: zero_pct_fs_per_k needs the sensor's range = [low, high] in {}",
            sensor.kind.output_unit()
        ));
    }
    Ok(TemperatureEffect {
        zero_pct_fs_per_k: temperature.zero_pct_fs_per_k,
        span_pct_per_k: temperature.span_pct_per_k,
        largest_departure_k: (low - reference).abs().max((high - reference).abs()),
    })
}

/// A strain channel's gauge factor tolerance and Young's modulus
/// uncertainty, checked.
fn read_strain_uncertainties(sensor: &SensorFile, record: &mut SensorRecord) -> Result<(), String> {
    let strain_only = |key: &str| format!("{key} is a strain channel's (kind = \"strain\")");
    if let Some(pct) = sensor.gauge_factor_tolerance_pct {
        if sensor.kind != SensorKind::Strain {
            return Err(strain_only("gauge_factor_tolerance_pct"));
        }
        if !(0.0..100.0).contains(&pct) {
            return Err(format!(
                "gauge_factor_tolerance_pct = {pct}: give the gauge maker's tolerance in %, at least 0 (foil gauges: about 1)"
            ));
        }
        record.gauge_factor_tolerance_pct = Some(pct);
    }
    if let Some(u) = sensor.youngs_modulus_uncertainty_gpa {
        let (SensorKind::Strain, Some(modulus)) = (sensor.kind, sensor.youngs_modulus_gpa) else {
            return Err(strain_only("youngs_modulus_uncertainty_gpa"));
        };
        if !(u.is_finite() && u >= 0.0 && u < modulus) {
            return Err(format!(
                "youngs_modulus_uncertainty_gpa = {u}: give a standard uncertainty of at least 0 and below the modulus ({modulus} GPa)"
            ));
        }
        record.youngs_modulus_gpa = Some((modulus, u));
    }
    Ok(())
}

/// A certificate's points: their stated uncertainties (standard, or
/// expanded with `k` at `level`), and the line through them.
fn read_points(calibration: &CalibrationFile, unit: &str) -> Result<CalibrationCurve, String> {
    let standard = match (&calibration.uncertainties, calibration.k, calibration.level) {
        (_, Some(_), None) => {
            return Err("calibration: k needs the level of confidence it is for (e.g. level = 0.95)".into())
        }
        (_, None, Some(_)) => {
            return Err("calibration: level needs the coverage factor k the certificate states".into())
        }
        (None, Some(_), Some(_)) => {
            return Err("calibration: k and level are for the points' uncertainties; give uncertainties = [...] too".into())
        }
        (Some(_), Some(k), Some(level)) if !(k.is_finite() && k >= 1.0 && level > 0.0 && level < 1.0) => {
            return Err(format!("calibration: k = {k} at level = {level}: give k of at least 1 and a level between 0 and 1"))
        }
        (Some(u), Some(k), Some(_)) => Some(u.iter().map(|u| u / k).collect::<Vec<f64>>()),
        (Some(u), None, None) => Some(u.clone()),
        (None, None, None) => None,
    };
    let curve = CalibrationCurve::fit(&calibration.points, standard.as_deref())
        .map_err(|e| format!("calibration: {e} ({unit} for values)"))?;
    if curve.slope == 0.0 || !curve.slope.is_finite() {
        return Err("calibration: the points' values do not change with the reading; a sensor needs a slope".into());
    }
    Ok(curve)
}

/// A certificate's polynomial with its stated expanded uncertainty: finite
/// coefficients of at least a line, and (with the sensor's `range`) a
/// slope of one sign over the readings of the range, so that every value
/// has one reading.
fn read_polynomial(
    sensor: &SensorFile,
    calibration: &CalibrationFile,
    coefficients: &[f64],
) -> Result<PolynomialCertificate, String> {
    let unit = sensor.kind.output_unit();
    if !calibration.points.is_empty() || calibration.uncertainties.is_some() {
        return Err(
            "calibration: give the certificate's points or its polynomial, not both".into(),
        );
    }
    if coefficients.len() < 2
        || coefficients.iter().any(|c| !c.is_finite())
        || coefficients[1..].iter().all(|&c| c == 0.0)
    {
        return Err(format!("calibration: polynomial = {coefficients:?}: give finite coefficients c0, c1, ... (value = c0 + c1 r + c2 r^2 ..., r the reading) with a term in r"));
    }
    let (Some(expanded), Some(k), Some(level)) = (
        calibration.expanded_uncertainty,
        calibration.k,
        calibration.level,
    ) else {
        return Err(format!("calibration: a polynomial needs the certificate's expanded_uncertainty (in {unit}) with its k and level"));
    };
    if !(expanded.is_finite()
        && expanded >= 0.0
        && k.is_finite()
        && k >= 1.0
        && level > 0.0
        && level < 1.0)
    {
        return Err(format!("calibration: expanded_uncertainty = {expanded} with k = {k} at level = {level}: give an uncertainty of at least 0, k of at least 1 and a level between 0 and 1"));
    }
    let conversion = Conversion::Polynomial(coefficients.to_vec());
    if let Some([low, high]) = sensor.range {
        let ends = (conversion.invert(low), conversion.invert(high));
        let (Some(from), Some(to)) = ends else {
            return Err(format!("calibration: the polynomial gives no reading for the range's ends {low} and {high} {unit}; check its coefficients"));
        };
        let sign = conversion.slope(from).signum();
        let steps = 200;
        if (0..=steps).any(|i| {
            conversion
                .slope(from + (to - from) * i as f64 / steps as f64)
                .signum()
                != sign
        }) {
            return Err(format!("calibration: the polynomial turns back within the range {low} to {high} {unit}: a value there would have two readings"));
        }
    }
    Ok(PolynomialCertificate {
        coefficients: coefficients.to_vec(),
        standard_uncertainty: expanded / k,
    })
}

/// A certificate's dates: `YYYY-MM-DD`, the due date not before the
/// calibration's.
fn read_certificate_dates(calibration: &CalibrationFile) -> Result<(), String> {
    for (key, date) in [("date", &calibration.date), ("due", &calibration.due)] {
        if let Some(date) = date {
            if !is_date(date) {
                return Err(format!(
                    "calibration: {key} = \"{date}\": give a date as YYYY-MM-DD"
                ));
            }
        }
    }
    if let (Some(date), Some(due)) = (&calibration.date, &calibration.due) {
        if due < date {
            return Err(format!(
                "calibration: due {due} is before the calibration's date {date}"
            ));
        }
    }
    Ok(())
}

/// A strain channel's shunt set-up, checked: the gauge factor, bridge and
/// Young's modulus come from the sensor's own keys.
fn read_shunt(sensor: &SensorFile, shunt: &ShuntFile) -> Result<ShuntSetup, String> {
    if sensor.kind != SensorKind::Strain {
        return Err("shunt: a shunt check is for a strain channel (kind = \"strain\")".into());
    }
    let (Some(gauge_factor), Some(bridge), Some(youngs_modulus_gpa)) = (
        sensor.gauge_factor,
        sensor.bridge,
        sensor.youngs_modulus_gpa,
    ) else {
        return Err(
            "shunt: the check needs the sensor's gauge_factor, bridge and youngs_modulus_gpa"
                .into(),
        );
    };
    let arm = match shunt.arm {
        1 => BridgeArm::R1,
        2 => BridgeArm::R2,
        3 => BridgeArm::R3,
        4 => BridgeArm::R4,
        other => {
            return Err(format!(
                "shunt: arm = {other}: give the arm the shunt goes across, 1 to 4"
            ))
        }
    };
    let conversion = match shunt.conversion.as_deref() {
        None | Some("linear") => StrainConversion::Linear,
        Some("bridge_law") => StrainConversion::InverseOfBridgeLaw,
        Some(other) => {
            return Err(format!(
                "shunt: conversion = \"{other}\": give \"linear\" (strain = 4 V/V / (GF k)) or \"bridge_law\" (the bridge's exact law inverted)"
            ))
        }
    };
    if !(shunt.tolerance_pct > 0.0 && shunt.tolerance_pct < 100.0) {
        return Err(format!(
            "shunt: tolerance_pct = {}: give how far the step may be off, in % above 0 and below 100",
            shunt.tolerance_pct
        ));
    }
    let setup = ShuntSetup {
        bridge: ShuntCheck {
            bridge: match bridge {
                strain::Bridge::Quarter => BridgeType::Quarter,
                strain::Bridge::Half => BridgeType::HalfBending,
                strain::Bridge::Full => BridgeType::FullBending,
            },
            conversion,
            arm,
            gauge_ohm: shunt.gauge_ohm,
            gauge_tolerance_pct: shunt.gauge_tolerance_pct,
            shunt_ohm: shunt.resistor_ohm,
            shunt_tolerance_pct: shunt.resistor_tolerance_pct,
            gauge_factor,
            measured_strain: 0.0,
            measured_standard_error_strain: 0.0,
            measured_dof: None,
        },
        stress_mpa_per_strain: strain::uniaxial_stress_mpa(1.0, youngs_modulus_gpa),
        tolerance_pct: shunt.tolerance_pct,
    };
    // The expected step with its budget: every input checked here, at
    // the rig's line, rather than when a session is read.
    setup
        .bridge
        .expected_budget()
        .map_err(|e| format!("shunt: {e}"))?;
    Ok(setup)
}

/// `YYYY-MM-DD` with a month 1-12 and a day 1-31 (string order is then
/// date order).
fn is_date(text: &str) -> bool {
    let parts: Vec<&str> = text.split('-').collect();
    let number = |part: &str, digits: usize, range: std::ops::RangeInclusive<u32>| {
        part.len() == digits
            && part.bytes().all(|b| b.is_ascii_digit())
            && part.parse::<u32>().is_ok_and(|n| range.contains(&n))
    };
    parts.len() == 3
        && number(parts[0], 4, 1900..=9999)
        && number(parts[1], 2, 1..=12)
        && number(parts[2], 2, 1..=31)
}

/// `[[cylinder]]`: each cylinder's bore and its two chambers' pressure sensors.
fn read_cylinders(
    entries: &[Spanned<CylinderFile>],
    sensors: &[Sensor],
    findings: &mut RigFindings,
) -> Vec<Cylinder> {
    let mut cylinders = Vec::new();
    for spanned in entries {
        let line = line_of(findings.text, spanned.span().start);
        let cylinder = spanned.get_ref();
        let find = |sensor_name: &str, chamber: &str| match sensors
            .iter()
            .position(|s| s.name == sensor_name)
        {
            Some(i) if sensors[i].kind == SensorKind::Pressure => Ok(i),
            Some(_) => Err(format!(
                "cylinder '{}': {chamber} sensor '{sensor_name}' is not a pressure sensor",
                cylinder.name
            )),
            None => Err(format!(
                "cylinder '{}': no sensor named '{sensor_name}' for the {chamber} chamber",
                cylinder.name
            )),
        };
        let bore = pressure::CylinderBore::new(cylinder.bore_mm, cylinder.rod_mm)
            .map_err(|e| format!("cylinder '{}': {e}", cylinder.name))
            .and_then(|bore| {
                for (key, tolerance) in [
                    ("bore_tolerance_mm", cylinder.bore_tolerance_mm),
                    ("rod_tolerance_mm", cylinder.rod_tolerance_mm),
                ] {
                    if tolerance.is_some_and(|t| !(t.is_finite() && t >= 0.0 && t < cylinder.rod_mm)) {
                        return Err(format!(
                            "cylinder '{}': {key} = {}: give the diameter's tolerance in mm, at least 0 and well below the rod's diameter",
                            cylinder.name,
                            tolerance.unwrap_or_default()
                        ));
                    }
                }
                Ok(bore)
            });
        match (
            find(&cylinder.head_sensor, "head"),
            find(&cylinder.rod_sensor, "rod"),
            bore,
        ) {
            (Ok(head_sensor), Ok(rod_sensor), Ok(bore)) => cylinders.push(Cylinder {
                name: cylinder.name.clone(),
                bore,
                bore_tolerance_mm: cylinder.bore_tolerance_mm.unwrap_or(0.0),
                rod_tolerance_mm: cylinder.rod_tolerance_mm.unwrap_or(0.0),
                head_sensor,
                rod_sensor,
            }),
            (head, rod, bore) => {
                for message in [head.err(), rod.err(), bore.err()].into_iter().flatten() {
                    findings.report(line, message);
                }
            }
        }
    }
    cylinders
}

/// A bus's `clock_sync`: the signal on this bus and the reference on
/// another, which estimate its clock's offset.
fn resolve_clock_sync(
    entries: &[Spanned<BusFile>],
    buses: &mut [Bus],
    sensors: &[Sensor],
    findings: &mut RigFindings,
) {
    for spanned in entries {
        let line = line_of(findings.text, spanned.span().start);
        let bus = spanned.get_ref();
        let (Some(sync), Some(bus_index)) = (
            &bus.clock_sync,
            buses.iter().position(|b| b.name == bus.name),
        ) else {
            continue;
        };
        let find = |name: &str| sensors.iter().position(|s| s.name == name);
        match (find(&sync.signal), find(&sync.reference)) {
            (Some(signal), Some(reference)) => {
                if sensors[signal].bus != bus_index {
                    findings.report(
                        line,
                        format!(
                            "bus '{}': clock_sync signal '{}' is on bus '{}', not on this bus",
                            bus.name, sync.signal, buses[sensors[signal].bus].name
                        ),
                    );
                } else if sensors[reference].bus == bus_index {
                    findings.report(line, format!("bus '{}': clock_sync reference '{}' must be on another bus (it gives the reference clock)", bus.name, sync.reference));
                } else {
                    buses[bus_index].clock = BusClock::Estimate { signal, reference };
                }
            }
            (signal, reference) => {
                for (found, name) in [(signal, &sync.signal), (reference, &sync.reference)] {
                    if found.is_none() {
                        findings.report(
                            line,
                            format!("bus '{}': clock_sync names no sensor '{name}'", bus.name),
                        );
                    }
                }
            }
        }
    }
}

/// `[[pair]]`: two sensors of one kind that should read alike.
fn read_pairs(
    entries: &[Spanned<PairFile>],
    sensors: &[Sensor],
    findings: &mut RigFindings,
) -> Vec<SensorPair> {
    let mut pairs = Vec::new();
    for spanned in entries {
        let line = line_of(findings.text, spanned.span().start);
        let pair = spanned.get_ref();
        let found: Vec<Option<usize>> = pair
            .sensors
            .iter()
            .map(|name| sensors.iter().position(|s| &s.name == name))
            .collect();
        let tolerance_pct = pair.tolerance_pct.unwrap_or(PAIR_TOLERANCE_PCT);
        let tolerance = pair.tolerance.unwrap_or(0.0);
        if !(tolerance_pct.is_finite()
            && tolerance_pct >= 0.0
            && tolerance.is_finite()
            && tolerance >= 0.0)
        {
            findings.report(
                line,
                "pair: tolerance_pct and tolerance must be numbers >= 0".into(),
            );
            continue;
        }
        match (found[0], found[1]) {
            (Some(a), Some(b)) if a == b => findings.report(
                line,
                format!("pair: '{}' is paired with itself", pair.sensors[0]),
            ),
            (Some(a), Some(b)) if sensors[a].kind != sensors[b].kind => {
                findings.report(
                    line,
                    format!(
                "pair: '{}' measures {} but '{}' measures {}; a pair compares like with like",
                pair.sensors[0], sensors[a].kind.name(), pair.sensors[1], sensors[b].kind.name()
            ),
                )
            }
            (Some(a), Some(b)) => pairs.push(SensorPair {
                sensors: [a, b],
                tolerance_pct,
                tolerance,
                line,
            }),
            _ => {
                for (found, name) in found.iter().zip(&pair.sensors) {
                    if found.is_none() {
                        findings.report(line, format!("pair: no sensor named '{name}'"));
                    }
                }
            }
        }
    }
    pairs
}

/// `[specimen]`: a tensile specimen's diameter and gauge length.
fn read_specimen(
    entry: Option<&Spanned<Specimen>>,
    findings: &mut RigFindings,
) -> Option<Specimen> {
    entry.and_then(|spanned| {
        let specimen = *spanned.get_ref();
        if specimen.diameter_mm > 0.0
            && specimen.gauge_length_mm > 0.0
            && specimen.diameter_mm.is_finite()
            && specimen.gauge_length_mm.is_finite()
        {
            Some(specimen)
        } else {
            findings.report(
                line_of(findings.text, spanned.span().start),
                "specimen: diameter_mm and gauge_length_mm must be positive lengths in mm".into(),
            );
            None
        }
    })
}

/// Two sensors reading the same bits, or a CANopen COB-ID that a DBC message
/// on the same bus also claims, would silently mix values: refuse both.
fn check_overlaps(sensors: &[Sensor], buses: &[Bus], report: &mut impl FnMut(usize, String)) {
    for (i, a) in sensors.iter().enumerate() {
        for b in &sensors[..i] {
            if a.bus != b.bus {
                continue;
            }
            let same = match (&a.source, &b.source) {
                (
                    SensorSource::Dbc {
                        id: ia, signal: sa, ..
                    },
                    SensorSource::Dbc {
                        id: ib, signal: sb, ..
                    },
                ) => ia == ib && sa == sb,
                (
                    SensorSource::Canopen {
                        cob_id: ca,
                        mapping: ma,
                        ..
                    },
                    SensorSource::Canopen {
                        cob_id: cb,
                        mapping: mb,
                        ..
                    },
                ) => {
                    let range = |m: &PdoMapping| {
                        (m.field.end_byte() - m.data_type.size_bytes())..m.field.end_byte()
                    };
                    let (ra, rb) = (range(ma), range(mb));
                    ca == cb && ra.start < rb.end && rb.start < ra.end
                }
                (
                    SensorSource::J1939 {
                        pgn: pa,
                        source_address: xa,
                        spn: na,
                        ..
                    },
                    SensorSource::J1939 {
                        pgn: pb,
                        source_address: xb,
                        spn: nb,
                        ..
                    },
                ) => pa == pb && (xa == xb || xa.is_none() || xb.is_none()) && na.field == nb.field,
                _ => false,
            };
            if same {
                report(a.line, format!("sensor '{}' reads the same value as sensor '{}' (line {}): duplicate id/address", a.name, b.name, b.line));
            }
        }
        if let SensorSource::Canopen { cob_id, .. } = &a.source {
            if let Some(message) = buses[a.bus].dbc.message(*cob_id) {
                report(a.line, format!("sensor '{}': COB-ID {cob_id} is also DBC message '{}' on bus '{}': duplicate id", a.name, message.name, buses[a.bus].name));
            }
        }
    }
}
