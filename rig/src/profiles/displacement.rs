//! Displacement channels: LVDTs and clip-on strain-gauge extensometers, mm.
//!
//! A strain-gauge extensometer reports its bridge output in mV/V; its
//! calibration sheet gives the travel per mV/V (`mm_per_mv_per_v`).

use super::linear::{unknown_unit, Linear, ProfileError};

pub const OUTPUT_UNIT: &str = "mm";
pub const INPUT_UNITS: &[&str] = &["mm", "um", "m", "mV/V"];

/// Conversion from the channel's unit to mm; `mm_per_mv_per_v` is needed
/// for a bridge-output channel.
pub fn to_millimetres(unit: &str, mm_per_mv_per_v: Option<f64>) -> Result<Linear, ProfileError> {
    let gain = match unit {
        "mm" => 1.0,
        "um" => 1e-3,
        "m" => 1e3,
        "mV/V" => {
            let sensitivity = mm_per_mv_per_v.ok_or_else(|| {
                ProfileError::Invalid(
                    "an extensometer in mV/V needs mm_per_mv_per_v from its calibration sheet"
                        .into(),
                )
            })?;
            if !(sensitivity.is_finite() && sensitivity != 0.0) {
                return Err(ProfileError::Invalid(format!(
                    "mm_per_mv_per_v must be a non-zero number, got {sensitivity}"
                )));
            }
            sensitivity
        }
        _ => return Err(unknown_unit(unit, "displacement", INPUT_UNITS)),
    };
    Ok(Linear::scale(gain))
}

#[cfg(test)]
mod tests {
    #[test]
    fn extensometer_bridge_output() {
        // 2.5 mm travel at 2 mV/V full scale: 1.25 mm per mV/V.
        assert_eq!(
            super::to_millimetres("mV/V", Some(1.25))
                .unwrap()
                .apply(0.8),
            1.0
        );
        assert!(super::to_millimetres("mV/V", None).is_err());
        assert_eq!(
            super::to_millimetres("um", None).unwrap().apply(250.0),
            0.25
        );
    }
}
