//! The keys of a transducer's record, as the rig's `[[sensor]]` and a
//! sensor file's `[[transducer]]` both write them: its certificate, its
//! data sheet's accuracy and its temperature coefficients.

use serde::Deserialize;

/// `calibration = { points = [[reading, value], ...], ... }` of a sensor, or
/// `calibration = { polynomial = [c0, c1, ...], expanded_uncertainty, k, level, ... }`.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct CalibrationFile {
    #[serde(default, deserialize_with = "reading_value_pairs")]
    pub(super) points: Vec<[f64; 2]>,
    /// A certificate's polynomial instead of points: `c0, c1, ...`, value
    /// `= sum c_i r^i` for a reading `r`.
    pub(super) polynomial: Option<Vec<f64>>,
    /// The polynomial's expanded uncertainty, in the kind's unit, with `k`
    /// and `level`.
    pub(super) expanded_uncertainty: Option<f64>,
    /// One per point, in the kind's unit: standard uncertainties, or
    /// expanded ones with `k` and `level`.
    pub(super) uncertainties: Option<Vec<f64>>,
    pub(super) k: Option<f64>,
    pub(super) level: Option<f64>,
    pub(super) lab: Option<String>,
    pub(super) certificate: Option<String>,
    /// `YYYY-MM-DD`.
    pub(super) date: Option<String>,
    pub(super) due: Option<String>,
}

/// A certificate's points, each exactly `[reading, value]`: a third number
/// is a mistake (a point's uncertainty goes in `uncertainties`), never
/// silently dropped.
fn reading_value_pairs<'de, D: serde::Deserializer<'de>>(
    deserializer: D,
) -> Result<Vec<[f64; 2]>, D::Error> {
    let points: Vec<Vec<f64>> = Vec::deserialize(deserializer)?;
    points
        .iter()
        .enumerate()
        .map(|(index, point)| match point.as_slice() {
            [reading, value] => Ok([*reading, *value]),
            _ => Err(serde::de::Error::custom(format!(
                "calibration point {} has {} numbers; give each as [reading, value] (a point's uncertainty goes in `uncertainties`)",
                index + 1,
                point.len()
            ))),
        })
        .collect()
}

/// `temperature = { zero_pct_fs_per_k, span_pct_per_k, range_c, reference_c }`.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct TemperatureFile {
    /// The zero's drift, % of full scale per kelvin (needs `range`).
    #[serde(default)]
    pub(super) zero_pct_fs_per_k: f64,
    /// The span's drift, % of the reading per kelvin.
    #[serde(default)]
    pub(super) span_pct_per_k: f64,
    /// The lowest and highest temperature at the rig during a test, C.
    pub(super) range_c: [f64; 2],
    /// The temperature the sensor was calibrated at, C.
    #[serde(default = "room_temperature_c")]
    pub(super) reference_c: f64,
}

/// Data sheets and certificates state their coefficients against 20 C
/// unless they say otherwise.
pub(super) fn room_temperature_c() -> f64 {
    20.0
}

/// `accuracy = { percent_of_full_scale = 0.5 }`, `{ percent_of_reading = 0.2 }`
/// or its parts `{ nonlinearity_pct_fs, hysteresis_pct_fs, repeatability_pct_fs }`.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct AccuracyFile {
    pub(super) percent_of_full_scale: Option<f64>,
    pub(super) percent_of_reading: Option<f64>,
    /// A data sheet that states the class's parts instead, each a share
    /// of full scale.
    pub(super) nonlinearity_pct_fs: Option<f64>,
    pub(super) hysteresis_pct_fs: Option<f64>,
    pub(super) repeatability_pct_fs: Option<f64>,
}
