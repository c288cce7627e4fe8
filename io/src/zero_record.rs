//! A session's zero record (`zero.toml`): what each channel read at rest
//! before the test (its offset) and, optionally, after it (the zero
//! return). The raw frames are never touched: every reader of the session
//! subtracts the offset from the decoded values.
//!
//! Written by `acq zero` (offline) and `acq record --zero-before` (live);
//! read by everything that opens the session.

use std::io;
use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::session::{read_toml_file, write_toml_file};
use acq_error::Result;

pub const ZERO_FILE: &str = "zero.toml";

/// Every zeroed channel of one session.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ZeroRecord {
    /// The command that took it, for the reader.
    pub taken_by: String,
    /// The session's start (UTC): a zero is one session's, and a budget
    /// names its errors by it.
    pub session_start: String,
    /// The before window's length, s (from the session's start).
    pub before_s: f64,
    /// The after window's length, s (up to the last sample), if taken.
    pub after_s: Option<f64>,
    #[serde(rename = "sensor", default)]
    pub sensors: Vec<SensorZero>,
}

/// One channel's zero.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SensorZero {
    pub name: String,
    /// The sensor kind's unit, in which every number here is.
    pub unit: String,
    pub before: ZeroReading,
    pub after: Option<ZeroReading>,
}

/// A channel's readings over one zero window.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ZeroReading {
    /// Session seconds.
    pub from_s: f64,
    pub to_s: f64,
    pub samples: u64,
    pub mean: f64,
    /// Sample standard deviation; absent with fewer than two samples.
    pub std: Option<f64>,
    /// The sample count corrected for lag-1 autocorrelation.
    pub n_eff: f64,
}

impl ZeroReading {
    /// The standard uncertainty of the window's mean: `std / sqrt(n_eff)`.
    pub fn std_of_mean(&self) -> Option<f64> {
        Some(self.std? / self.n_eff.max(1.0).sqrt())
    }
}

impl SensorZero {
    /// What is subtracted from every value of the channel.
    pub fn offset(&self) -> f64 {
        self.before.mean
    }

    /// How far the zero moved during the test: after minus before.
    pub fn zero_return(&self) -> Option<f64> {
        self.after.map(|after| after.mean - self.before.mean)
    }
}

impl ZeroRecord {
    pub fn sensor(&self, name: &str) -> Option<&SensorZero> {
        self.sensors.iter().find(|s| s.name == name)
    }
}

/// Writes the record into the session directory atomically and durably.
pub fn write(dir: &Path, record: &ZeroRecord) -> io::Result<()> {
    write_toml_file(
        dir,
        ZERO_FILE,
        "# Written by acq; each value the session gives is its reading minus `before.mean`.\n",
        record,
    )
}

/// Reads the session's record; `None` when there is none.
pub fn read(dir: &Path) -> Result<Option<ZeroRecord>> {
    read_toml_file(
        dir,
        ZERO_FILE,
        "remove it and zero the session again with acq zero",
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_record_reads_back_as_written() {
        let dir = tempfile::tempdir().unwrap();
        assert_eq!(read(dir.path()).unwrap(), None);
        let reading = |mean| ZeroReading {
            from_s: 0.0,
            to_s: 3.0,
            samples: 300,
            mean,
            std: Some(0.05),
            n_eff: 280.0,
        };
        let record = ZeroRecord {
            taken_by: "acq zero".into(),
            session_start: "2026-11-29T04:00:00.000Z".into(),
            before_s: 3.0,
            after_s: Some(3.0),
            sensors: vec![SensorZero {
                name: "boom_head_pressure".into(),
                unit: "bar".into(),
                before: reading(0.35),
                after: Some(reading(0.1 + 0.2 + 0.08)),
            }],
        };
        write(dir.path(), &record).unwrap();
        let back = read(dir.path()).unwrap().unwrap();
        assert_eq!(back, record);
        let zero = back.sensor("boom_head_pressure").unwrap();
        assert_eq!(zero.offset(), 0.35);
        assert!((zero.zero_return().unwrap() - 0.03).abs() < 1e-12);
    }

    #[test]
    fn a_broken_record_says_how_to_mend_it() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join(ZERO_FILE), "before_s = [").unwrap();
        let message = read(dir.path()).unwrap_err().to_string();
        assert!(
            message.contains("zero.toml") && message.contains("acq zero"),
            "{message}"
        );
    }
}
