//! Sensor profiles: the physics between a channel's unit and the engineering
//! quantity a test engineer reads, one module per kind of sensor.
//!
//! Every conversion here is linear, so each sensor compiles into one
//! [`Linear`] map applied after protocol decoding and the rig's own
//! calibration (scale, offset).

pub mod displacement;
pub mod force;
pub mod inclination;
pub mod pressure;
pub mod strain;

use serde::{Deserialize, Serialize};

/// What a sensor measures, which fixes the unit of its output.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Deserialize, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum SensorKind {
    /// Hydraulic pressure transducer: bar.
    Pressure,
    /// Force transducer amplifier channel: kN.
    Force,
    /// Strain-gauge amplifier channel: uniaxial stress, MPa.
    Strain,
    /// Inclinometer: degrees.
    Inclination,
    /// Displacement / extensometer: mm.
    Displacement,
}

impl SensorKind {
    pub const ALL: [SensorKind; 5] = [
        SensorKind::Pressure,
        SensorKind::Force,
        SensorKind::Strain,
        SensorKind::Inclination,
        SensorKind::Displacement,
    ];

    /// The unit every sensor of this kind outputs.
    pub fn output_unit(self) -> &'static str {
        match self {
            SensorKind::Pressure => pressure::OUTPUT_UNIT,
            SensorKind::Force => force::OUTPUT_UNIT,
            SensorKind::Strain => strain::OUTPUT_UNIT,
            SensorKind::Inclination => inclination::OUTPUT_UNIT,
            SensorKind::Displacement => displacement::OUTPUT_UNIT,
        }
    }

    /// The channel units this kind accepts, for error messages.
    pub fn input_units(self) -> &'static [&'static str] {
        match self {
            SensorKind::Pressure => pressure::INPUT_UNITS,
            SensorKind::Force => force::INPUT_UNITS,
            SensorKind::Strain => strain::INPUT_UNITS,
            SensorKind::Inclination => inclination::INPUT_UNITS,
            SensorKind::Displacement => displacement::INPUT_UNITS,
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            SensorKind::Pressure => "pressure",
            SensorKind::Force => "force",
            SensorKind::Strain => "strain",
            SensorKind::Inclination => "inclination",
            SensorKind::Displacement => "displacement",
        }
    }
}

/// `output = gain * input + offset`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Linear {
    pub gain: f64,
    pub offset: f64,
}

impl Linear {
    pub const IDENTITY: Linear = Linear {
        gain: 1.0,
        offset: 0.0,
    };

    pub fn scale(gain: f64) -> Self {
        Linear { gain, offset: 0.0 }
    }

    #[inline]
    pub fn apply(self, input: f64) -> f64 {
        self.gain * input + self.offset
    }

    /// `self` applied after `first`.
    pub fn after(self, first: Linear) -> Linear {
        Linear {
            gain: self.gain * first.gain,
            offset: self.gain * first.offset + self.offset,
        }
    }

    /// The input that gives `output` (for simulators); `None` if the gain is 0.
    pub fn invert(self, output: f64) -> Option<f64> {
        (self.gain != 0.0).then(|| (output - self.offset) / self.gain)
    }
}

/// A unit the profile does not know, or a missing constant.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum ProfileError {
    #[error("unit '{unit}' is not a {kind} unit (expected one of: {expected})")]
    UnknownUnit {
        unit: String,
        kind: &'static str,
        expected: String,
    },
    #[error("{0}")]
    Invalid(String),
}

pub(crate) fn unknown_unit(unit: &str, kind: SensorKind) -> ProfileError {
    ProfileError::UnknownUnit {
        unit: unit.to_string(),
        kind: kind.name(),
        expected: kind.input_units().join(", "),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn composition_and_inverse() {
        let first = Linear {
            gain: 2.0,
            offset: 1.0,
        };
        let second = Linear {
            gain: 10.0,
            offset: -3.0,
        };
        let both = second.after(first);
        assert_eq!(both.apply(4.0), second.apply(first.apply(4.0)));
        assert_eq!(both.invert(both.apply(4.0)), Some(4.0));
        assert_eq!(Linear::scale(0.0).invert(1.0), None);
    }
}
