//! Sensor profiles: the physics between a channel's unit and the engineering
//! quantity a test engineer reads, one module per kind of sensor.
//!
//! Every conversion here is linear, so each sensor compiles into one
//! [`Linear`] map applied after protocol decoding and the rig's own
//! calibration (scale, offset); a certificate's polynomial replaces it
//! ([`Conversion`]).
//!
//! [`linear`] holds what every kind shares (the map and its errors); each kind
//! module uses only it, and [`SensorKind`] here dispatches to the kinds.

pub mod conversion;
pub mod displacement;
pub mod force;
pub mod inclination;
pub mod linear;
pub mod pressure;
pub mod strain;

use serde::{Deserialize, Serialize};

pub use conversion::Conversion;
pub use linear::{Linear, ProfileError};

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
    /// Any other quantity a rig logs beside the twins' inputs (an engine's
    /// speed, an oil temperature, a flow): in the sensor's own unit (its
    /// `unit`, or its DBC signal's), taken as sent after scale and offset.
    /// acq knows no physics of it, so it converts no unit.
    Other,
}

impl SensorKind {
    /// Whether a channel of this kind reads zero with the machine at rest,
    /// so that a zero window may set its offset: released hydraulics read
    /// gauge zero, an unloaded transducer or gauge zero force and strain,
    /// a displacement starts at zero; a machine at rest still stands at an
    /// angle.
    pub fn reads_zero_at_rest(self) -> bool {
        match self {
            SensorKind::Pressure
            | SensorKind::Force
            | SensorKind::Strain
            | SensorKind::Displacement => true,
            SensorKind::Inclination | SensorKind::Other => false,
        }
    }

    pub const ALL: [SensorKind; 6] = [
        SensorKind::Pressure,
        SensorKind::Force,
        SensorKind::Strain,
        SensorKind::Inclination,
        SensorKind::Displacement,
        SensorKind::Other,
    ];

    /// The unit every sensor of this kind outputs; `None` for
    /// [`SensorKind::Other`], whose sensors each name their own.
    pub fn output_unit(self) -> Option<&'static str> {
        match self {
            SensorKind::Pressure => Some(pressure::OUTPUT_UNIT),
            SensorKind::Force => Some(force::OUTPUT_UNIT),
            SensorKind::Strain => Some(strain::OUTPUT_UNIT),
            SensorKind::Inclination => Some(inclination::OUTPUT_UNIT),
            SensorKind::Displacement => Some(displacement::OUTPUT_UNIT),
            SensorKind::Other => None,
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
            SensorKind::Other => &[],
        }
    }

    /// The values a sensor of this kind can physically read, in its output
    /// unit: a gauge pressure is at least -1.01325 bar (vacuum); the upper
    /// limits lie far beyond any test rig, so a value outside is a typo or a
    /// unit mistake, not a measurement.
    pub fn physical_range(self) -> (f64, f64) {
        match self {
            SensorKind::Pressure => (-1.01325, 10_000.0),
            SensorKind::Force => (-1e6, 1e6),
            SensorKind::Strain => (-1e5, 1e5),
            SensorKind::Inclination => (-360.0, 360.0),
            SensorKind::Displacement => (-1e6, 1e6),
            // Nothing is known of an other quantity but that it is a number.
            SensorKind::Other => (-f64::MAX, f64::MAX),
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            SensorKind::Pressure => "pressure",
            SensorKind::Force => "force",
            SensorKind::Strain => "strain",
            SensorKind::Inclination => "inclination",
            SensorKind::Displacement => "displacement",
            SensorKind::Other => "other",
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_unit_error_names_the_kind_and_its_units() {
        type Converter = fn(&str) -> Result<Linear, ProfileError>;
        let converters: [(SensorKind, Converter); 4] = [
            (SensorKind::Pressure, pressure::to_bar),
            (SensorKind::Force, force::to_kilonewton),
            (SensorKind::Inclination, inclination::to_degrees),
            (SensorKind::Displacement, |unit| {
                displacement::to_millimetres(unit, None)
            }),
        ];
        for (kind, convert) in converters {
            let error = convert("furlong").unwrap_err().to_string();
            assert!(error.contains(kind.name()), "{error}");
            assert!(error.contains(&kind.input_units().join(", ")), "{error}");
        }
    }
}
