//! A transducer's record: its certificate (points or a polynomial), its
//! data sheet's accuracy and temperature limits, a strain channel's shunt
//! set-up; read from the rig or from a sensor file by serial, and checked.

use std::collections::HashMap;
use std::path::Path;

use acq_metrology::bridge::{BridgeArm, BridgeType, ShuntCheck, StrainConversion};
use acq_metrology::curve::CalibrationCurve;
use toml::Spanned;

use crate::error::RigFindings;
use crate::file::{SensorFile, ShuntFile};
use crate::lines::line_of;
use crate::profiles::{strain, Conversion, SensorKind};
use crate::record_keys::{AccuracyFile, CalibrationFile, TemperatureFile};
use crate::Transducer;

/// A transducer's certificate and data-sheet limits, as the rig states them.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SensorRecord {
    /// The line through the certificate's points; it is the sensor's
    /// conversion (reading to value) where given.
    pub curve: Option<CalibrationCurve>,
    /// A certificate's polynomial instead, with its stated uncertainty.
    pub polynomial: Option<PolynomialCertificate>,
    pub certificate: Option<Certificate>,
    /// The data sheet's limit, rectangular.
    pub accuracy: Option<Accuracy>,
    /// The smallest step of the value, in the kind's unit.
    pub resolution: Option<f64>,
    /// A strain channel's shunt calibration set-up.
    pub shunt: Option<ShuntSetup>,
    /// How far the rig's temperature may move the value.
    pub temperature: Option<TemperatureEffect>,
    /// A strain channel's gauge factor tolerance, `+-%`: a span error.
    pub gauge_factor_tolerance_pct: Option<f64>,
    /// A strain channel's Young's modulus and its standard uncertainty,
    /// GPa: the stress is the strain times it.
    pub youngs_modulus_gpa: Option<(f64, f64)>,
    /// Which transducer it is, when the record came from a sensor file.
    pub transducer: Option<Transducer>,
}

/// A certificate that states a polynomial (reading to value) and one
/// expanded uncertainty for it over its range.
#[derive(Clone, Debug, PartialEq)]
pub struct PolynomialCertificate {
    /// `c0, c1, ...`: value `= sum c_i r^i`.
    pub coefficients: Vec<f64>,
    /// The stated expanded uncertainty over its `k`.
    pub standard_uncertainty: f64,
}

/// A data sheet's temperature coefficients over the rig's temperatures:
/// the largest departure from the reference temperature bounds the drift.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TemperatureEffect {
    pub zero_pct_fs_per_k: f64,
    pub span_pct_per_k: f64,
    /// `max |T - T_ref|` over the rig's range, K.
    pub largest_departure_k: f64,
}

/// What a strain channel's shunt check needs besides the recorded step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShuntSetup {
    /// The bridge, the shunt and the gauge; its measured step is 0 until
    /// [`ShuntSetup::check`] gives it one.
    pub bridge: ShuntCheck,
    /// The channel's values are stress: MPa per unit strain (`E`).
    pub stress_mpa_per_strain: f64,
    /// The largest `|measured / expected - 1|` corrected, %.
    pub tolerance_pct: f64,
}

impl ShuntSetup {
    /// The check of a measured step of the channel's value (MPa) with its
    /// standard error and degrees of freedom.
    pub fn check(&self, step_mpa: f64, standard_error_mpa: f64, dof: Option<f64>) -> ShuntCheck {
        ShuntCheck {
            measured_strain: step_mpa / self.stress_mpa_per_strain,
            measured_standard_error_strain: standard_error_mpa / self.stress_mpa_per_strain,
            measured_dof: dof,
            ..self.bridge
        }
    }
}

impl SensorRecord {
    /// Whether anything is known beyond the readings' own scatter.
    pub fn is_empty(&self) -> bool {
        self.curve.is_none()
            && self.polynomial.is_none()
            && self.accuracy.is_none()
            && self.resolution.is_none()
            && self.temperature.is_none()
            && self.gauge_factor_tolerance_pct.is_none()
            && self.youngs_modulus_gpa.is_none()
    }
}

/// Where a calibration was made, and until when it holds.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Certificate {
    pub lab: Option<String>,
    pub id: Option<String>,
    /// `YYYY-MM-DD`.
    pub date: Option<String>,
    pub due: Option<String>,
}

/// A data sheet's accuracy limit, `+-` this share.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Accuracy {
    /// Of the full scale (the `range`'s span), %.
    PercentOfFullScale(f64),
    /// Of the reading, %.
    PercentOfReading(f64),
    /// The class's parts as a data sheet states them, each % of full
    /// scale (0 where not stated).
    PartsOfFullScale {
        nonlinearity: f64,
        hysteresis: f64,
        repeatability: f64,
    },
}

/// Each `[[sensor]]` that names a `serial` takes its transducer's record
/// from the sensor file; what each sensor is, by name.
pub(crate) fn take_transducer_records(
    sensors: &mut [Spanned<SensorFile>],
    sensor_file: Option<&Path>,
    findings: &mut RigFindings,
) -> HashMap<String, Transducer> {
    let mut transducers = HashMap::new();
    let mut records = None;
    for spanned in sensors.iter_mut() {
        let line = line_of(findings.text, spanned.span().start);
        let sensor = spanned.get_mut();
        let Some(serial) = sensor.serial.clone() else {
            continue;
        };
        let Some(path) = sensor_file else {
            findings.report(line, format!("sensor '{}': serial = \"{serial}\" needs the rig's sensor file: add sensor_file = \"sensors.toml\" under [rig]", sensor.name));
            continue;
        };
        if let Some((other, _)) = transducers
            .iter()
            .find(|(_, t): &(&String, &Transducer)| t.serial == serial)
        {
            findings.report(line, format!("sensor '{}': serial '{serial}' is sensor '{other}' already; one transducer cannot be two channels", sensor.name));
            continue;
        }
        let loaded = records.get_or_insert_with(|| crate::sensor_file::SensorRecords::load(path));
        let merged = match loaded {
            Ok(records) => records.take(&serial).and_then(|(record, transducer)| {
                merge_record(sensor, record, &transducer.entered_at)?;
                Ok(transducer)
            }),
            Err(message) => {
                findings.report(line, format!("sensor '{}': {message}", sensor.name));
                break;
            }
        };
        match merged {
            Ok(transducer) => {
                transducers.insert(sensor.name.clone(), transducer);
            }
            Err(message) => findings.report(line, format!("sensor '{}': {message}", sensor.name)),
        }
    }
    transducers
}

/// Gives `sensor` every key of a transducer's `record` that the rig
/// leaves out; a key both state is refused (one place says it).
pub(crate) fn merge_record(
    sensor: &mut SensorFile,
    mut record: crate::sensor_file::TransducerRecord,
    entered_at: &str,
) -> Result<(), String> {
    let both = |key: &str| {
        format!("both the rig and the transducer's record ({entered_at}) state {key}; keep one")
    };
    fill(&mut sensor.range, &mut record.range).map_err(|_| both("range"))?;
    fill(&mut sensor.calibration, &mut record.calibration).map_err(|_| both("calibration"))?;
    fill(&mut sensor.accuracy, &mut record.accuracy).map_err(|_| both("accuracy"))?;
    fill(&mut sensor.resolution, &mut record.resolution).map_err(|_| both("resolution"))?;
    fill(&mut sensor.temperature, &mut record.temperature).map_err(|_| both("temperature"))?;
    fill(
        &mut sensor.gauge_factor_tolerance_pct,
        &mut record.gauge_factor_tolerance_pct,
    )
    .map_err(|_| both("gauge_factor_tolerance_pct"))
}

/// Moves `from` into `into` when only `from` holds a value; an error when
/// both do.
pub(crate) fn fill<T>(into: &mut Option<T>, from: &mut Option<T>) -> Result<(), ()> {
    match (into.is_some(), from.is_some()) {
        (true, true) => Err(()),
        (false, true) => {
            *into = from.take();
            Ok(())
        }
        _ => Ok(()),
    }
}

/// A sensor's certificate and data-sheet limits, checked.
pub(crate) fn read_record(sensor: &SensorFile, unit: &str) -> Result<SensorRecord, String> {
    let mut record = SensorRecord::default();
    if let Some(calibration) = &sensor.calibration {
        if sensor.scale.is_some() || sensor.offset.is_some() {
            return Err("give either a certificate's calibration or scale and offset, not both (the certificate is the conversion)".into());
        }
        read_certificate_dates(calibration)?;
        match &calibration.polynomial {
            Some(coefficients) => {
                record.polynomial = Some(read_polynomial(sensor, unit, calibration, coefficients)?)
            }
            None => record.curve = Some(read_points(calibration, unit)?),
        }
        record.certificate = Some(Certificate {
            lab: calibration.lab.clone(),
            id: calibration.certificate.clone(),
            date: calibration.date.clone(),
            due: calibration.due.clone(),
        });
    }
    if let Some(accuracy) = &sensor.accuracy {
        record.accuracy = Some(read_accuracy(sensor, unit, accuracy)?);
    }
    if let Some(shunt) = &sensor.shunt {
        record.shunt = Some(read_shunt(sensor, shunt)?);
    }
    if let Some(temperature) = &sensor.temperature {
        record.temperature = Some(read_temperature(sensor, unit, temperature)?);
    }
    read_strain_uncertainties(sensor, &mut record)?;
    if let Some(step) = sensor.resolution {
        if !(step.is_finite() && step > 0.0) {
            return Err(format!(
                "resolution = {step}: give the value's smallest step in {unit}, above 0"
            ));
        }
        record.resolution = Some(step);
    }
    Ok(record)
}

/// The data sheet's accuracy: one class (a share of full scale or of the
/// reading) or its parts (non-linearity, hysteresis, repeatability, each
/// a share of full scale), not both.
pub(crate) fn read_accuracy(
    sensor: &SensorFile,
    unit: &str,
    accuracy: &AccuracyFile,
) -> Result<Accuracy, String> {
    let parts = [
        accuracy.nonlinearity_pct_fs,
        accuracy.hysteresis_pct_fs,
        accuracy.repeatability_pct_fs,
    ];
    let needs_range = || {
        if sensor.range.is_none() {
            Err(format!(
                "accuracy: a share of full scale needs the sensor's range = [low, high] in {unit}"
            ))
        } else {
            Ok(())
        }
    };
    if parts.iter().any(Option::is_some) {
        if accuracy.percent_of_full_scale.is_some() || accuracy.percent_of_reading.is_some() {
            return Err("accuracy: give the class (percent_of_full_scale or percent_of_reading) or its parts (nonlinearity_pct_fs, hysteresis_pct_fs, repeatability_pct_fs), not both: the class already holds its parts".into());
        }
        if let Some(bad) = parts
            .iter()
            .flatten()
            .find(|p| !(p.is_finite() && **p >= 0.0))
        {
            return Err(format!(
                "accuracy: {bad} %: give each part as a share of at least 0"
            ));
        }
        needs_range()?;
        let [nonlinearity, hysteresis, repeatability] = parts.map(|p| p.unwrap_or(0.0));
        return Ok(Accuracy::PartsOfFullScale {
            nonlinearity,
            hysteresis,
            repeatability,
        });
    }
    match (accuracy.percent_of_full_scale, accuracy.percent_of_reading) {
        (Some(pct), None) if pct.is_finite() && pct > 0.0 => {
            needs_range()?;
            Ok(Accuracy::PercentOfFullScale(pct))
        }
        (None, Some(pct)) if pct.is_finite() && pct > 0.0 => Ok(Accuracy::PercentOfReading(pct)),
        (Some(pct), None) | (None, Some(pct)) => {
            Err(format!("accuracy: {pct} %: give a share above 0"))
        }
        _ => Err("accuracy: give one of percent_of_full_scale or percent_of_reading (or the parts nonlinearity_pct_fs, hysteresis_pct_fs, repeatability_pct_fs)".into()),
    }
}

/// The temperature coefficients, checked: non-negative, a range in order,
/// and a share of full scale only with the sensor's `range`.
pub(crate) fn read_temperature(
    sensor: &SensorFile,
    unit: &str,
    temperature: &TemperatureFile,
) -> Result<TemperatureEffect, String> {
    let [low, high] = temperature.range_c;
    let reference = temperature.reference_c;
    if !(low.is_finite() && high.is_finite() && reference.is_finite() && low <= high) {
        return Err(format!(
            "temperature: range_c = [{low}, {high}] with reference_c = {reference}: give the lowest and highest temperature at the rig, in C, lowest first"
        ));
    }
    for (key, value) in [
        ("zero_pct_fs_per_k", temperature.zero_pct_fs_per_k),
        ("span_pct_per_k", temperature.span_pct_per_k),
    ] {
        if !(value.is_finite() && value >= 0.0) {
            return Err(format!(
                "temperature: {key} = {value}: give the data sheet's coefficient as a limit of at least 0"
            ));
        }
    }
    if temperature.zero_pct_fs_per_k > 0.0 && sensor.range.is_none() {
        return Err(format!(
            "temperature: zero_pct_fs_per_k needs the sensor's range = [low, high] in {unit}"
        ));
    }
    Ok(TemperatureEffect {
        zero_pct_fs_per_k: temperature.zero_pct_fs_per_k,
        span_pct_per_k: temperature.span_pct_per_k,
        largest_departure_k: (low - reference).abs().max((high - reference).abs()),
    })
}

/// A strain channel's gauge factor tolerance and Young's modulus
/// uncertainty, checked.
pub(crate) fn read_strain_uncertainties(
    sensor: &SensorFile,
    record: &mut SensorRecord,
) -> Result<(), String> {
    let strain_only = |key: &str| format!("{key} is a strain channel's (kind = \"strain\")");
    if let Some(pct) = sensor.gauge_factor_tolerance_pct {
        if sensor.kind != SensorKind::Strain {
            return Err(strain_only("gauge_factor_tolerance_pct"));
        }
        if !(0.0..100.0).contains(&pct) {
            return Err(format!(
                "gauge_factor_tolerance_pct = {pct}: give the gauge maker's tolerance in %, at least 0 (foil gauges: about 1)"
            ));
        }
        record.gauge_factor_tolerance_pct = Some(pct);
    }
    if let Some(u) = sensor.youngs_modulus_uncertainty_gpa {
        let (SensorKind::Strain, Some(modulus)) = (sensor.kind, sensor.youngs_modulus_gpa) else {
            return Err(strain_only("youngs_modulus_uncertainty_gpa"));
        };
        if !(u.is_finite() && u >= 0.0 && u < modulus) {
            return Err(format!(
                "youngs_modulus_uncertainty_gpa = {u}: give a standard uncertainty of at least 0 and below the modulus ({modulus} GPa)"
            ));
        }
        record.youngs_modulus_gpa = Some((modulus, u));
    }
    Ok(())
}

/// A certificate's points: their stated uncertainties (standard, or
/// expanded with `k` at `level`), and the line through them.
pub(crate) fn read_points(
    calibration: &CalibrationFile,
    unit: &str,
) -> Result<CalibrationCurve, String> {
    let standard = match (&calibration.uncertainties, calibration.k, calibration.level) {
        (_, Some(_), None) => {
            return Err("calibration: k needs the level of confidence it is for (e.g. level = 0.95)".into())
        }
        (_, None, Some(_)) => {
            return Err("calibration: level needs the coverage factor k the certificate states".into())
        }
        (None, Some(_), Some(_)) => {
            return Err("calibration: k and level are for the points' uncertainties; give uncertainties = [...] too".into())
        }
        (Some(_), Some(k), Some(level)) if !(k.is_finite() && k >= 1.0 && level > 0.0 && level < 1.0) => {
            return Err(format!("calibration: k = {k} at level = {level}: give k of at least 1 and a level between 0 and 1"))
        }
        (Some(u), Some(k), Some(_)) => Some(u.iter().map(|u| u / k).collect::<Vec<f64>>()),
        (Some(u), None, None) => Some(u.clone()),
        (None, None, None) => None,
    };
    let curve = CalibrationCurve::fit(&calibration.points, standard.as_deref())
        .map_err(|e| format!("calibration: {e} ({unit} for values)"))?;
    if !(curve.slope.is_finite() && curve.intercept.is_finite() && curve.residual_std.is_finite()) {
        return Err(format!("calibration: a line through these points overflows (readings or values near 1e308?); give the certificate's readings and values as it states them, in {unit}"));
    }
    if curve.slope == 0.0 {
        return Err("calibration: the points' values do not change with the reading; a sensor needs a slope".into());
    }
    if standard.is_none() && curve.residual_std == 0.0 {
        return Err(format!("calibration: the points lie exactly on a line and state no uncertainties, so the line says nothing of its own uncertainty (u_c would be 0); give uncertainties = [...] in {unit}, as the certificate states them"));
    }
    Ok(curve)
}

/// A certificate's polynomial with its stated expanded uncertainty: finite
/// coefficients of at least a line, and (with the sensor's `range`) a
/// slope of one sign over the readings of the range, so that every value
/// has one reading.
pub(crate) fn read_polynomial(
    sensor: &SensorFile,
    unit: &str,
    calibration: &CalibrationFile,
    coefficients: &[f64],
) -> Result<PolynomialCertificate, String> {
    if !calibration.points.is_empty() || calibration.uncertainties.is_some() {
        return Err(
            "calibration: give the certificate's points or its polynomial, not both".into(),
        );
    }
    if coefficients.len() < 2
        || coefficients.iter().any(|c| !c.is_finite())
        || coefficients[1..].iter().all(|&c| c == 0.0)
    {
        return Err(format!("calibration: polynomial = {coefficients:?}: give finite coefficients c0, c1, ... (value = c0 + c1 r + c2 r^2 ..., r the reading) with a term in r"));
    }
    let (Some(expanded), Some(k), Some(level)) = (
        calibration.expanded_uncertainty,
        calibration.k,
        calibration.level,
    ) else {
        return Err(format!("calibration: a polynomial needs the certificate's expanded_uncertainty (in {unit}) with its k and level"));
    };
    if !(expanded.is_finite()
        && expanded >= 0.0
        && k.is_finite()
        && k >= 1.0
        && level > 0.0
        && level < 1.0)
    {
        return Err(format!("calibration: expanded_uncertainty = {expanded} with k = {k} at level = {level}: give an uncertainty of at least 0, k of at least 1 and a level between 0 and 1"));
    }
    let conversion = Conversion::Polynomial(coefficients.to_vec());
    if let Some([low, high]) = sensor.range {
        let ends = (conversion.invert(low), conversion.invert(high));
        let (Some(from), Some(to)) = ends else {
            return Err(format!("calibration: the polynomial gives no reading for the range's ends {low} and {high} {unit}; check its coefficients"));
        };
        let sign = conversion.slope(from).signum();
        let steps = 200;
        if (0..=steps).any(|i| {
            conversion
                .slope(from + (to - from) * i as f64 / steps as f64)
                .signum()
                != sign
        }) {
            return Err(format!("calibration: the polynomial turns back within the range {low} to {high} {unit}: a value there would have two readings"));
        }
    }
    Ok(PolynomialCertificate {
        coefficients: coefficients.to_vec(),
        standard_uncertainty: expanded / k,
    })
}

/// A certificate's dates: `YYYY-MM-DD`, the due date not before the
/// calibration's.
pub(crate) fn read_certificate_dates(calibration: &CalibrationFile) -> Result<(), String> {
    for (key, date) in [("date", &calibration.date), ("due", &calibration.due)] {
        if let Some(date) = date {
            if !is_date(date) {
                return Err(format!(
                    "calibration: {key} = \"{date}\": give a date that exists, as YYYY-MM-DD"
                ));
            }
        }
    }
    if let (Some(date), Some(due)) = (&calibration.date, &calibration.due) {
        if due < date {
            return Err(format!(
                "calibration: due {due} is before the calibration's date {date}"
            ));
        }
    }
    Ok(())
}

/// A strain channel's shunt set-up, checked: the gauge factor, bridge and
/// Young's modulus come from the sensor's own keys.
pub(crate) fn read_shunt(sensor: &SensorFile, shunt: &ShuntFile) -> Result<ShuntSetup, String> {
    if sensor.kind != SensorKind::Strain {
        return Err("shunt: a shunt check is for a strain channel (kind = \"strain\")".into());
    }
    let (Some(gauge_factor), Some(bridge), Some(youngs_modulus_gpa)) = (
        sensor.gauge_factor,
        sensor.bridge,
        sensor.youngs_modulus_gpa,
    ) else {
        return Err(
            "shunt: the check needs the sensor's gauge_factor, bridge and youngs_modulus_gpa"
                .into(),
        );
    };
    let arm = match shunt.arm {
        1 => BridgeArm::R1,
        2 => BridgeArm::R2,
        3 => BridgeArm::R3,
        4 => BridgeArm::R4,
        other => {
            return Err(format!(
                "shunt: arm = {other}: give the arm the shunt goes across, 1 to 4"
            ))
        }
    };
    let conversion = match shunt.conversion.as_deref() {
        None | Some("linear") => StrainConversion::Linear,
        Some("bridge_law") => StrainConversion::InverseOfBridgeLaw,
        Some(other) => {
            return Err(format!(
                "shunt: conversion = \"{other}\": give \"linear\" (strain = 4 V/V / (GF k)) or \"bridge_law\" (the bridge's exact law inverted)"
            ))
        }
    };
    if !(shunt.tolerance_pct > 0.0 && shunt.tolerance_pct < 100.0) {
        return Err(format!(
            "shunt: tolerance_pct = {}: give how far the step may be off, in % above 0 and below 100",
            shunt.tolerance_pct
        ));
    }
    let setup = ShuntSetup {
        bridge: ShuntCheck {
            bridge: match bridge {
                strain::Bridge::Quarter => BridgeType::Quarter,
                strain::Bridge::Half => BridgeType::HalfBending,
                strain::Bridge::Full => BridgeType::FullBending,
            },
            conversion,
            arm,
            gauge_ohm: shunt.gauge_ohm,
            gauge_tolerance_pct: shunt.gauge_tolerance_pct,
            shunt_ohm: shunt.resistor_ohm,
            shunt_tolerance_pct: shunt.resistor_tolerance_pct,
            gauge_factor,
            measured_strain: 0.0,
            measured_standard_error_strain: 0.0,
            measured_dof: None,
        },
        stress_mpa_per_strain: strain::uniaxial_stress_mpa(1.0, youngs_modulus_gpa),
        tolerance_pct: shunt.tolerance_pct,
    };
    // The expected step with its budget: every input checked here, at
    // the rig's line, rather than when a session is read.
    setup
        .bridge
        .expected_budget()
        .map_err(|e| format!("shunt: {e}"))?;
    Ok(setup)
}

/// `YYYY-MM-DD` with a month 1-12 and a day 1-31 (string order is then
/// date order).
pub(crate) fn is_date(text: &str) -> bool {
    let parts: Vec<&str> = text.split('-').collect();
    let number = |part: &str, digits: usize, range: std::ops::RangeInclusive<u32>| {
        part.len() == digits
            && part.bytes().all(|b| b.is_ascii_digit())
            && part.parse::<u32>().is_ok_and(|n| range.contains(&n))
    };
    if !(parts.len() == 3
        && number(parts[0], 4, 1900..=9999)
        && number(parts[1], 2, 1..=12)
        && number(parts[2], 2, 1..=31))
    {
        return false;
    }
    // The day exists in its month (the Gregorian leap-year rule).
    let (year, month, day): (u32, u32, u32) = (
        parts[0].parse().unwrap_or(0),
        parts[1].parse().unwrap_or(0),
        parts[2].parse().unwrap_or(0),
    );
    let leap = (year % 4 == 0 && year % 100 != 0) || year % 400 == 0;
    let days = match month {
        2 if leap => 29,
        2 => 28,
        4 | 6 | 9 | 11 => 30,
        _ => 31,
    };
    day <= days
}
