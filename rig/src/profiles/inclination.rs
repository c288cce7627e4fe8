//! Inclinometers (slope sensors on boom, arm and bucket): angle in degrees.

use super::linear::{unknown_unit, Linear, ProfileError};

pub const OUTPUT_UNIT: &str = "deg";
pub const INPUT_UNITS: &[&str] = &["deg", "rad", "mrad"];

/// Conversion from the sensor's unit to degrees.
pub fn to_degrees(unit: &str) -> Result<Linear, ProfileError> {
    let gain = match unit {
        "deg" => 1.0,
        "rad" => 180.0 / std::f64::consts::PI,
        "mrad" => 0.18 / std::f64::consts::PI,
        _ => return Err(unknown_unit(unit, "inclination", INPUT_UNITS)),
    };
    Ok(Linear::scale(gain))
}

#[cfg(test)]
mod tests {
    #[test]
    fn radians_to_degrees() {
        let degrees = super::to_degrees("rad")
            .unwrap()
            .apply(std::f64::consts::FRAC_PI_2);
        assert!((degrees - 90.0).abs() < 1e-12);
        assert!(super::to_degrees("grad").is_err());
    }
}
