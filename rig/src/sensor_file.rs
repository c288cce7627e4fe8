//! A sensor file: each transducer's record entered once, keyed by its
//! serial number, and shared by every rig that names the serial. A rig
//! points at it with `[rig] sensor_file = "sensors.toml"` (relative to the
//! rig) and a `[[sensor]]` takes a transducer's record with `serial =
//! "..."`:
//!
//! ```toml
//! [[transducer]]
//! serial = "P8AP-1234567"
//! maker = "HBK"
//! model = "P8AP 500 bar"
//! range = [0.0, 500.0]
//! accuracy = { percent_of_full_scale = 0.3 }
//! resolution = 0.01
//! calibration = { points = [[...], ...], lab = "...", certificate = "...", date = "...", due = "..." }
//! temperature = { zero_pct_fs_per_k = 0.015, span_pct_per_k = 0.01, range_c = [5.0, 40.0] }
//! ```
//!
//! A key the rig states itself and the transducer states too is refused:
//! one place says it.

use std::path::{Path, PathBuf};

use serde::Deserialize;
use toml::Spanned;

use super::lines::line_of;
use super::record_keys::{AccuracyFile, CalibrationFile, TemperatureFile};

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SensorRecordsFile {
    #[serde(default, rename = "transducer")]
    transducers: Vec<Spanned<TransducerFile>>,
}

/// One transducer's entry: who it is and its record.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct TransducerFile {
    serial: String,
    maker: Option<String>,
    model: Option<String>,
    #[serde(flatten)]
    record: TransducerRecord,
}

/// The keys of a transducer's record a rig's sensor takes from it.
#[derive(Deserialize)]
pub(super) struct TransducerRecord {
    pub(super) range: Option<[f64; 2]>,
    pub(super) calibration: Option<CalibrationFile>,
    pub(super) accuracy: Option<AccuracyFile>,
    pub(super) resolution: Option<f64>,
    pub(super) temperature: Option<TemperatureFile>,
    pub(super) gauge_factor_tolerance_pct: Option<f64>,
}

/// Far more than the records of every transducer a lab owns.
pub const MAX_SENSOR_FILE_BYTES: u64 = 16 << 20;

/// Which transducer a sensor is, as its record names it.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Transducer {
    pub serial: String,
    pub maker: Option<String>,
    pub model: Option<String>,
    /// The sensor file and the line of its `[[transducer]]`.
    pub entered_at: String,
}

/// A sensor file, read.
pub(super) struct SensorRecords {
    path: PathBuf,
    entries: Vec<(usize, TransducerFile)>,
}

impl SensorRecords {
    /// Reads `path`: each problem as a message with the file and line.
    pub(super) fn load(path: &Path) -> Result<SensorRecords, String> {
        // A FIFO or a device would block or never end: a sensor file is a
        // regular file of a size a person writes.
        match std::fs::metadata(path) {
            Ok(meta) if !meta.is_file() => {
                return Err(format!(
                    "sensor_file: {} is not a regular file; give the sensor file's path relative to the rig",
                    path.display()
                ))
            }
            Ok(meta) if meta.len() > MAX_SENSOR_FILE_BYTES => {
                return Err(format!(
                    "sensor_file: {} holds {} bytes; a sensor file of more than {MAX_SENSOR_FILE_BYTES} bytes is not one",
                    path.display(),
                    meta.len()
                ))
            }
            _ => {}
        }
        let text = std::fs::read_to_string(path).map_err(|e| {
            format!(
                "sensor_file: cannot read {}: {e}; give the path of the sensor file relative to the rig",
                path.display()
            )
        })?;
        let file: SensorRecordsFile = toml::from_str(&text).map_err(|e| {
            let line = e.span().map_or(1, |s| line_of(&text, s.start));
            format!("{}:{line}: {}", path.display(), e.message().trim())
        })?;
        let mut entries: Vec<(usize, TransducerFile)> = Vec::new();
        for spanned in file.transducers {
            let line = line_of(&text, spanned.span().start);
            let entry = spanned.into_inner();
            if let Some((first, _)) = entries.iter().find(|(_, e)| e.serial == entry.serial) {
                return Err(format!(
                    "{}:{line}: serial '{}' is entered twice (first at line {first}); a transducer has one record",
                    path.display(),
                    entry.serial
                ));
            }
            entries.push((line, entry));
        }
        Ok(SensorRecords {
            path: path.to_path_buf(),
            entries,
        })
    }

    /// The record of the transducer `serial`, taken out of the file (a
    /// transducer is one channel of a rig), and who it is.
    pub(super) fn take(&mut self, serial: &str) -> Result<(TransducerRecord, Transducer), String> {
        let path = self.path.display().to_string();
        let Some(index) = self.entries.iter().position(|(_, e)| e.serial == serial) else {
            let known: Vec<&str> = self
                .entries
                .iter()
                .map(|(_, e)| e.serial.as_str())
                .collect();
            return Err(format!(
                "serial '{serial}' is not in {path} (serials there: {}); enter its record there or correct the serial",
                if known.is_empty() { "none".to_string() } else { known.join(", ") }
            ));
        };
        let (line, entry) = self.entries.swap_remove(index);
        Ok((
            entry.record,
            Transducer {
                serial: entry.serial,
                maker: entry.maker,
                model: entry.model,
                entered_at: format!("{path}:{line}"),
            },
        ))
    }
}
