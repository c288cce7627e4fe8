//! The rig file as written: what serde reads, before any check.

use acq_can::canopen::PdoType;
use serde::Deserialize;
use toml::Spanned;

use crate::profiles::{strain, SensorKind};
use crate::record_keys::{AccuracyFile, CalibrationFile, TemperatureFile};
use crate::{Interpolation, Specimen};

// ---- The file as written ----------------------------------------------------

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RigFile {
    pub(crate) rig: Option<RigMetaFile>,
    #[serde(default, rename = "bus")]
    pub(crate) buses: Vec<Spanned<BusFile>>,
    #[serde(default, rename = "sensor")]
    pub(crate) sensors: Vec<Spanned<SensorFile>>,
    #[serde(default, rename = "cylinder")]
    pub(crate) cylinders: Vec<Spanned<CylinderFile>>,
    #[serde(default, rename = "pair")]
    pub(crate) pairs: Vec<Spanned<PairFile>>,
    #[serde(default, rename = "row")]
    pub(crate) rows: Vec<Spanned<crate::rows::RowFile>>,
    pub(crate) specimen: Option<Spanned<Specimen>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct PairFile {
    pub(crate) sensors: [String; 2],
    pub(crate) tolerance_pct: Option<f64>,
    pub(crate) tolerance: Option<f64>,
}

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct ClockSyncFile {
    pub(crate) signal: String,
    pub(crate) reference: String,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RigMetaFile {
    pub(crate) name: Option<String>,
    pub(crate) description: Option<String>,
    /// Transducers' records shared by rigs, keyed by serial number.
    pub(crate) sensor_file: Option<String>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct BusFile {
    pub(crate) name: String,
    pub(crate) iface: String,
    pub(crate) bitrate: Option<u32>,
    #[serde(default)]
    pub(crate) dbc: Vec<String>,
    pub(crate) clock_offset_ms: Option<f64>,
    pub(crate) clock_sync: Option<ClockSyncFile>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct SensorFile {
    pub(crate) name: String,
    /// The transducer's serial number: its record comes from the rig's
    /// sensor file.
    pub(crate) serial: Option<String>,
    pub(crate) kind: SensorKind,
    pub(crate) bus: Option<String>,
    pub(crate) unit: Option<String>,
    pub(crate) rate_hz: f64,
    pub(crate) scale: Option<f64>,
    pub(crate) offset: Option<f64>,
    pub(crate) dbc: Option<DbcAddress>,
    pub(crate) canopen: Option<CanopenAddress>,
    pub(crate) j1939: Option<J1939Address>,
    // Profile constants.
    pub(crate) gauge_factor: Option<f64>,
    pub(crate) bridge: Option<strain::Bridge>,
    pub(crate) youngs_modulus_gpa: Option<f64>,
    pub(crate) mm_per_mv_per_v: Option<f64>,
    /// Gauge or measuring-point number on the structure.
    pub(crate) location: Option<u32>,
    pub(crate) description: Option<String>,
    pub(crate) interpolation: Option<Interpolation>,
    pub(crate) range: Option<[f64; 2]>,
    /// The certificate: points (reading, value), their uncertainties, dates.
    pub(crate) calibration: Option<CalibrationFile>,
    /// The data sheet's accuracy limit (rectangular).
    pub(crate) accuracy: Option<AccuracyFile>,
    /// The smallest step of the value, in the kind's unit.
    pub(crate) resolution: Option<f64>,
    /// The shunt resistor a strain channel's amplifier switches in, and the
    /// arm it goes across (`acq shunt`).
    pub(crate) shunt: Option<ShuntFile>,
    /// The data sheet's temperature coefficients and the rig's temperatures.
    pub(crate) temperature: Option<TemperatureFile>,
    /// The gauge factor's tolerance, `+-%` (the gauge maker's lot value).
    pub(crate) gauge_factor_tolerance_pct: Option<f64>,
    /// The standard uncertainty of `youngs_modulus_gpa`, GPa.
    pub(crate) youngs_modulus_uncertainty_gpa: Option<f64>,
    /// Whether the channel reads its kind's zero at rest, so that a zero
    /// window sets its offset; by default pressures, forces, strains and
    /// displacements do and inclinations do not.
    pub(crate) zero_at_rest: Option<bool>,
}

/// `shunt = { resistor_ohm = 100000, gauge_ohm = 350, ... }` of a strain sensor.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct ShuntFile {
    pub(crate) resistor_ohm: f64,
    /// `+-%`, rectangular.
    #[serde(default)]
    pub(crate) resistor_tolerance_pct: f64,
    /// The shunted arm's resistance (the gauge's, with its leads where the
    /// shunt is switched in at the amplifier).
    pub(crate) gauge_ohm: f64,
    #[serde(default)]
    pub(crate) gauge_tolerance_pct: f64,
    /// 1-4: arms 1 and 3 raise the output when their resistance rises.
    #[serde(default = "first_arm")]
    pub(crate) arm: u8,
    /// `"linear"` (default) or `"bridge_law"` (the amplifier inverts the
    /// bridge's exact law).
    pub(crate) conversion: Option<String>,
    /// How far the step may be off the expected one before the check is
    /// refused, %.
    #[serde(default = "default_shunt_tolerance_pct")]
    pub(crate) tolerance_pct: f64,
}

pub(crate) fn first_arm() -> u8 {
    1
}

/// A healthy channel shows the shunt's step within a fraction of a per
/// cent; 1 % leaves room for lead resistance and still catches a wrong
/// gauge factor (2.0 against 2.1 is 5 %) or bridge type (a factor of 2).
pub(crate) fn default_shunt_tolerance_pct() -> f64 {
    1.0
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct DbcAddress {
    pub(crate) message: String,
    pub(crate) signal: String,
    /// For a J1939 message: the one source address to take it from.
    pub(crate) source_address: Option<u8>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct CanopenAddress {
    pub(crate) node_id: u8,
    pub(crate) pdo: u8,
    pub(crate) byte: usize,
    #[serde(rename = "type")]
    pub(crate) data_type: PdoType,
    #[serde(default)]
    pub(crate) decimal_digits: u8,
    pub(crate) heartbeat_ms: Option<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct J1939Address {
    pub(crate) pgn: u32,
    pub(crate) source_address: Option<u8>,
    pub(crate) spn: Option<u32>,
    pub(crate) start_bit: u64,
    pub(crate) length_bits: u64,
    pub(crate) resolution: f64,
    pub(crate) offset: f64,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct CylinderFile {
    pub(crate) name: String,
    pub(crate) bore_mm: f64,
    pub(crate) rod_mm: f64,
    /// The bore's and the rod's diameter tolerance, `+-mm` (rectangular).
    pub(crate) bore_tolerance_mm: Option<f64>,
    pub(crate) rod_tolerance_mm: Option<f64>,
    pub(crate) head_sensor: String,
    pub(crate) rod_sensor: String,
}
