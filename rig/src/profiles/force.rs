//! Force transducer amplifier channels (load cells, the force at the bucket tooth).

use super::linear::{unknown_unit, Linear, ProfileError};

pub const OUTPUT_UNIT: &str = "kN";
pub const INPUT_UNITS: &[&str] = &["kN", "N", "MN", "lbf"];

/// Conversion from the channel's unit to kN.
pub fn to_kilonewton(unit: &str) -> Result<Linear, ProfileError> {
    let gain = match unit {
        "kN" => 1.0,
        "N" => 1e-3,
        "MN" => 1e3,
        // 1 lbf = 4.4482216152605 N (exact by definition).
        "lbf" => 4.448_221_615_260_5e-3,
        _ => return Err(unknown_unit(unit, "force", INPUT_UNITS)),
    };
    Ok(Linear::scale(gain))
}

#[cfg(test)]
mod tests {
    #[test]
    fn units_convert_to_kn() {
        assert_eq!(super::to_kilonewton("N").unwrap().apply(40_600.0), 40.6);
        assert!(super::to_kilonewton("kgf").is_err());
    }
}
