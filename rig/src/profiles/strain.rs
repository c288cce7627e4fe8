//! Strain-gauge amplifier channels: bridge output or strain -> uniaxial stress.
//!
//! An amplifier reports either the bridge's relative output (mV/V) or strain
//! it already computed (um/m). From the bridge output, strain follows from
//! the gauge factor k and the number of active arms:
//! `strain = (4 / n_active) * (V_out / V_exc) / k` (the linearised Wheatstone
//! relation amplifiers use; its error for a quarter bridge is about
//! `k * strain / 2`, 0.1 % at 1000 um/m). A uniaxial gauge on a member in
//! uniaxial stress gives `stress = E * strain`.

use super::linear::{unknown_unit, Linear, ProfileError};

pub const OUTPUT_UNIT: &str = "MPa";
pub const INPUT_UNITS: &[&str] = &["um/m", "m/m", "mV/V"];

/// Wheatstone bridge configuration: how many arms are active gauges.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Deserialize, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Bridge {
    /// One active gauge.
    Quarter,
    /// Two active gauges (e.g. top and bottom flange in bending).
    Half,
    /// Four active gauges.
    Full,
}

impl Bridge {
    /// Strain per unit of relative bridge output (V/V), per unit gauge factor.
    fn arm_factor(self) -> f64 {
        match self {
            Bridge::Quarter => 4.0,
            Bridge::Half => 2.0,
            Bridge::Full => 1.0,
        }
    }
}

/// Strain from the relative bridge output in mV/V.
pub fn strain_from_bridge_output(output_mv_per_v: f64, gauge_factor: f64, bridge: Bridge) -> f64 {
    bridge.arm_factor() * output_mv_per_v * 1e-3 / gauge_factor
}

/// Uniaxial stress, MPa, from strain (m/m) and Young's modulus in GPa.
pub fn uniaxial_stress_mpa(strain: f64, youngs_modulus_gpa: f64) -> f64 {
    strain * youngs_modulus_gpa * 1e3
}

/// How a strain channel is set up.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StrainChannel {
    pub youngs_modulus_gpa: f64,
    /// Needed only for a channel in mV/V.
    pub gauge_factor: Option<f64>,
    pub bridge: Option<Bridge>,
}

/// Conversion from the channel's unit to stress in MPa.
pub fn to_stress_mpa(unit: &str, channel: StrainChannel) -> Result<Linear, ProfileError> {
    if !(channel.youngs_modulus_gpa > 0.0 && channel.youngs_modulus_gpa.is_finite()) {
        return Err(ProfileError::Invalid(format!(
            "youngs_modulus_gpa must be positive (steel: 210), got {}",
            channel.youngs_modulus_gpa
        )));
    }
    let strain_per_unit = match unit {
        "um/m" => 1e-6,
        "m/m" => 1.0,
        "mV/V" => {
            let gauge_factor = channel.gauge_factor.ok_or_else(|| {
                ProfileError::Invalid(
                    "a mV/V channel needs gauge_factor (foil gauges: about 2.0)".into(),
                )
            })?;
            if !(gauge_factor > 0.0 && gauge_factor.is_finite()) {
                return Err(ProfileError::Invalid(format!(
                    "gauge_factor must be positive, got {gauge_factor}"
                )));
            }
            let bridge = channel.bridge.ok_or_else(|| {
                ProfileError::Invalid(
                    "a mV/V channel needs bridge = \"quarter\", \"half\" or \"full\"".into(),
                )
            })?;
            strain_from_bridge_output(1.0, gauge_factor, bridge)
        }
        _ => return Err(unknown_unit(unit, "strain", INPUT_UNITS)),
    };
    Ok(Linear::scale(uniaxial_stress_mpa(
        strain_per_unit,
        channel.youngs_modulus_gpa,
    )))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn steel(gauge_factor: Option<f64>, bridge: Option<Bridge>) -> StrainChannel {
        StrainChannel {
            youngs_modulus_gpa: 210.0,
            gauge_factor,
            bridge,
        }
    }

    #[test]
    fn microstrain_to_stress() {
        // 491.33 um/m on SWS490A (E = 210 GPa) is 103.18 MPa (gauge 9, Case 1).
        let stress = to_stress_mpa("um/m", steel(None, None))
            .unwrap()
            .apply(491.333_333);
        assert!((stress - 103.18).abs() < 1e-4, "{stress}");
    }

    #[test]
    fn bridge_output_to_stress() {
        // Quarter bridge, k = 2: 1 mV/V is 2000 um/m -> 420 MPa.
        let quarter = to_stress_mpa("mV/V", steel(Some(2.0), Some(Bridge::Quarter))).unwrap();
        assert!((quarter.apply(1.0) - 420.0).abs() < 1e-9);
        let half = to_stress_mpa("mV/V", steel(Some(2.0), Some(Bridge::Half))).unwrap();
        assert!((half.apply(1.0) - 210.0).abs() < 1e-9);
        let full = to_stress_mpa("mV/V", steel(Some(2.0), Some(Bridge::Full))).unwrap();
        assert!((full.apply(1.0) - 105.0).abs() < 1e-9);
        assert!(to_stress_mpa("mV/V", steel(None, Some(Bridge::Full))).is_err());
        assert!(to_stress_mpa("mV/V", steel(Some(2.0), None)).is_err());
    }

    #[test]
    fn linearisation_error_is_as_documented() {
        // Exact quarter bridge: Vr = k e / 4 / (1 + k e / 2).
        let (k, strain) = (2.0, 1000e-6);
        let relative_output = k * strain / 4.0 / (1.0 + k * strain / 2.0);
        let linear = strain_from_bridge_output(relative_output * 1e3, k, Bridge::Quarter);
        let error = (strain - linear) / strain;
        assert!((error - k * strain / 2.0).abs() < 1e-6, "{error}");
    }
}
