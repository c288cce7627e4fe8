//! A session's shunt checks (`shunt.toml`): for each strain channel
//! checked, the step its shunt gave, the step it should give, and the
//! gain correction every reader then multiplies its values by (after the
//! zero). Written by `acq shunt`; the raw frames are never touched.

use std::io;
use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::session::{read_toml_file, write_toml_file};
use acq_error::Result;

pub const SHUNT_FILE: &str = "shunt.toml";

#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ShuntRecord {
    /// The session's start (UTC): a budget names the correction's error by it.
    pub session_start: String,
    #[serde(rename = "sensor", default)]
    pub sensors: Vec<SensorShunt>,
}

/// One channel's shunt check.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SensorShunt {
    pub name: String,
    /// The window searched for the step, session seconds.
    pub from_s: f64,
    pub to_s: f64,
    /// When the shunt was switched, session seconds.
    pub switched_s: f64,
    /// The channel's step (its unit, MPa for a strain channel), with its
    /// standard error and degrees of freedom (`None`: infinite).
    pub step: f64,
    pub step_standard_error: f64,
    pub step_dof: Option<f64>,
    /// The step in strain, and what the shunt simulates (m/m).
    pub measured_strain: f64,
    pub expected_strain: f64,
    /// `expected / measured`: every value of the channel is multiplied by it.
    pub gain: f64,
    /// The gain's standard uncertainty.
    pub gain_standard_uncertainty: f64,
}

impl ShuntRecord {
    pub fn sensor(&self, name: &str) -> Option<&SensorShunt> {
        self.sensors.iter().find(|s| s.name == name)
    }

    /// Keeps `check` in place of the channel's earlier one.
    pub fn replace(&mut self, check: SensorShunt) {
        self.sensors.retain(|s| s.name != check.name);
        self.sensors.push(check);
    }
}

/// Writes the record into the session directory atomically and durably.
pub fn write(dir: &Path, record: &ShuntRecord) -> io::Result<()> {
    write_toml_file(
        dir,
        SHUNT_FILE,
        "# Written by acq shunt; each value of a channel here is multiplied by its `gain`.\n",
        record,
    )
}

/// Reads the session's record; `None` when there is none.
pub fn read(dir: &Path) -> Result<Option<ShuntRecord>> {
    read_toml_file(
        dir,
        SHUNT_FILE,
        "remove it and check the shunts again with acq shunt",
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_record_reads_back_and_a_new_check_replaces_the_old() {
        let dir = tempfile::tempdir().unwrap();
        assert_eq!(read(dir.path()).unwrap(), None);
        let check = |gain| SensorShunt {
            name: "sg01".into(),
            from_s: 2.0,
            to_s: 6.0,
            switched_s: 4.0,
            step: -366.0,
            step_standard_error: 0.05,
            step_dof: Some(300.0),
            measured_strain: -0.001743,
            expected_strain: -0.001747,
            gain,
            gain_standard_uncertainty: 0.0006,
        };
        let mut record = ShuntRecord {
            session_start: "2026-11-29T04:00:00.000000Z".into(),
            sensors: vec![check(1.002)],
        };
        record.replace(check(1.003));
        assert_eq!(record.sensors.len(), 1);
        write(dir.path(), &record).unwrap();
        assert_eq!(read(dir.path()).unwrap().unwrap(), record);
    }
}
