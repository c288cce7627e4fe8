//! The uncertainty budget of one value of a sensor as its rig states it
//! (JCGM 100): the certificate's curve at the reading that gives the
//! value, the data sheet's accuracy limit and the resolution, all Type B.
//! A sensor without a record has an empty budget: its only uncertainty
//! is then the readings' scatter in a hold (Type A, `extract`).
//!
//! The certificate's and the accuracy class's errors are the sensor's:
//! the same in every value it gives (every hold, every session), so they
//! are marked shared by the sensor's name and a posterior takes each
//! sensor's as one error. Resolution and scatter are each value's own.

use acq_io::shunt_record::ShuntRecord;
use acq_io::zero_record::{SensorZero, ZeroRecord};
use acq_metrology::budget::{rectangular, resolution, Budget, Contribution};
use acq_rig::{Accuracy, Cylinder, Sensor};

use super::stats::WindowStats;

/// The source names of a sensor's Type B contributions, as the JSON and
/// the report name them.
pub const CALIBRATION_CURVE: &str = "calibration_curve";
pub const ACCURACY_CLASS: &str = "accuracy_class";
pub const RESOLUTION: &str = "resolution";
/// The data sheet's temperature coefficients of zero and span over the
/// rig's temperatures.
pub const TEMPERATURE_ZERO: &str = "temperature_zero";
pub const TEMPERATURE_SPAN: &str = "temperature_span";
/// A strain channel's gauge factor tolerance (a span error).
pub const GAUGE_FACTOR: &str = "gauge_factor";
/// The Young's modulus a strain becomes a stress through.
pub const YOUNGS_MODULUS: &str = "youngs_modulus";
/// A data sheet's parts of its accuracy class, each a share of full scale.
pub const NONLINEARITY: &str = "nonlinearity";
pub const HYSTERESIS: &str = "hysteresis";
pub const REPEATABILITY: &str = "repeatability";
/// The Type A source: the spread of a hold's readings about their mean.
pub const READINGS_SCATTER: &str = "readings_scatter";
/// The zero window's mean, subtracted from every value (Type A).
pub const ZERO: &str = "zero";
/// How far the zero moved between the windows before and after the test.
pub const ZERO_RETURN: &str = "zero_return";

/// One value of a sensor with what its uncertainty is made of.
#[derive(Clone, Debug)]
pub struct ValueBudget {
    pub sensor: String,
    /// The kind's unit.
    pub unit: String,
    pub value: f64,
    /// The channel's reading that gives the value, through the sensor's
    /// conversion (the certificate's line where given).
    pub reading: Option<f64>,
    pub budget: Budget,
}

/// The budget of `value` (in the sensor's unit) of `sensor`.
pub fn value_budget(sensor: &Sensor, value: f64) -> ValueBudget {
    let record = &sensor.record;
    let mut contributions = Vec::new();
    let reading = sensor.conversion.invert(value);
    if let Some(curve) = &record.curve {
        let at = curve.reading_at(value);
        contributions.push(
            Contribution::direct(
                CALIBRATION_CURVE,
                curve.standard_uncertainty_at(at),
                curve.dof,
            )
            .shared_by(&sensor.name),
        );
    }
    if let Some(polynomial) = &record.polynomial {
        // One stated uncertainty over the certificate's range.
        contributions.push(
            Contribution::direct(CALIBRATION_CURVE, polynomial.standard_uncertainty, None)
                .shared_by(&sensor.name),
        );
    }
    if let Some(accuracy) = record.accuracy {
        let span = sensor.range.map_or(0.0, |[low, high]| high - low);
        // The rig's check asks for a range with a share of full scale.
        let of_span = |pct: f64| pct / 100.0 * span;
        // A class is stated even where it is 0 (a reading of 0); a part
        // the data sheet leaves out is not.
        let mut limit = |source: &str, half_width: f64, shared: bool| {
            if half_width > 0.0 || source == ACCURACY_CLASS {
                let part = Contribution::direct(source, rectangular(half_width), None);
                contributions.push(if shared {
                    part.shared_by(&sensor.name)
                } else {
                    part
                });
            }
        };
        match accuracy {
            Accuracy::PercentOfFullScale(pct) => limit(ACCURACY_CLASS, of_span(pct), true),
            Accuracy::PercentOfReading(pct) => {
                limit(ACCURACY_CLASS, pct / 100.0 * value.abs(), true)
            }
            Accuracy::PartsOfFullScale {
                nonlinearity,
                hysteresis,
                repeatability,
            } => {
                // The curve's shape and its loop are the transducer's, the
                // same in every hold; repeatability differs from one
                // approach to the next.
                limit(NONLINEARITY, of_span(nonlinearity), true);
                limit(HYSTERESIS, of_span(hysteresis), true);
                limit(REPEATABILITY, of_span(repeatability), false);
            }
        }
    }
    if let Some(step) = record.resolution {
        contributions.push(Contribution::direct(RESOLUTION, resolution(step), None));
    }
    contributions.extend(span_and_drift(sensor, value));
    ValueBudget {
        sensor: sensor.name.clone(),
        unit: sensor.unit().to_string(),
        value,
        reading,
        budget: Budget { contributions },
    }
}

/// What a session's zero adds to every value of a zeroed channel: the
/// uncertainty of the zero window's mean (Type A, `n_eff - 1` degrees of
/// freedom) and, when the zero was read again after the test, its drift
/// (rectangular, half-width the zero return: the zero may have been
/// anywhere between the two readings when a hold was taken). Both are the
/// same in every hold of the session, so they are shared by
/// `"<sensor> zero of <session start>"`; another session's zero is
/// another error.
pub fn zero_contributions(zero: &SensorZero, session_start: &str) -> Vec<Contribution> {
    let shared = format!("{} zero of {session_start}", zero.name);
    let mut contributions = Vec::new();
    if let Some(u) = zero
        .before
        .std_of_mean()
        .filter(|_| zero.before.n_eff >= 2.0)
    {
        contributions
            .push(Contribution::direct(ZERO, u, Some(zero.before.n_eff - 1.0)).shared_by(&shared));
    }
    if let Some(drift) = zero.zero_return() {
        contributions
            .push(Contribution::direct(ZERO_RETURN, rectangular(drift), None).shared_by(&shared));
    }
    contributions
}

/// A shunt check's gain applied to every value of a channel.
pub const SHUNT_GAIN: &str = "shunt_gain";

/// What a session's own corrections of a channel add to each of its
/// values: its zero's parts and its shunt check's gain.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SessionParts {
    pub zero: Vec<Contribution>,
    pub gain: Option<GainPart>,
}

/// A channel's gain correction: its value and standard uncertainty, and
/// the shared source its error is (the same in every hold of the session).
#[derive(Clone, Debug, PartialEq)]
pub struct GainPart {
    pub gain: f64,
    pub standard_uncertainty: f64,
    pub shared_by: String,
}

impl SessionParts {
    /// Each of `sensors`' parts from the session's zero and shunt records.
    pub fn of(
        sensors: &[Sensor],
        zero: Option<&ZeroRecord>,
        shunt: Option<&ShuntRecord>,
    ) -> Vec<SessionParts> {
        sensors
            .iter()
            .map(|sensor| SessionParts {
                zero: zero
                    .and_then(|r| {
                        Some(zero_contributions(
                            r.sensor(&sensor.name)?,
                            &r.session_start,
                        ))
                    })
                    .unwrap_or_default(),
                gain: shunt.and_then(|r| {
                    let check = r.sensor(&sensor.name)?;
                    Some(GainPart {
                        gain: check.gain,
                        standard_uncertainty: check.gain_standard_uncertainty,
                        shared_by: format!("{} shunt of {}", sensor.name, r.session_start),
                    })
                }),
            })
            .collect()
    }

    /// The contributions to a value `value` (corrected) of the channel: a
    /// value `g v` moves by `v = value / g` per unit of the gain `g`.
    fn contributions(&self, value: f64) -> impl Iterator<Item = Contribution> + '_ {
        let gain = self.gain.as_ref().map(|part| Contribution {
            sensitivity: value / part.gain,
            ..Contribution::direct(SHUNT_GAIN, part.standard_uncertainty, None)
                .shared_by(&part.shared_by)
        });
        self.zero.iter().cloned().chain(gain)
    }
}

/// The sources that scale with the value or the rig's temperature, all
/// the sensor's own in every value it gives: the temperature coefficients
/// of zero (a share of full scale per kelvin) and span (a share of the
/// reading per kelvin) over the largest departure from the reference
/// temperature, the gauge factor's tolerance (the strain, and so the
/// stress, scales as `1 / GF`) and the Young's modulus (the stress is
/// `E eps`). All limits rectangular; the modulus's a standard
/// uncertainty, shared by every gauge on the same modulus (one material).
fn span_and_drift(sensor: &Sensor, value: f64) -> Vec<Contribution> {
    let record = &sensor.record;
    let mut parts = Vec::new();
    if let Some(t) = record.temperature {
        let span = sensor.range.map_or(0.0, |[low, high]| high - low);
        let zero = t.zero_pct_fs_per_k / 100.0 * span * t.largest_departure_k;
        let gain = t.span_pct_per_k / 100.0 * value.abs() * t.largest_departure_k;
        for (source, half_width) in [(TEMPERATURE_ZERO, zero), (TEMPERATURE_SPAN, gain)] {
            if half_width > 0.0 {
                parts.push(
                    Contribution::direct(source, rectangular(half_width), None)
                        .shared_by(&sensor.name),
                );
            }
        }
    }
    if let Some(pct) = record.gauge_factor_tolerance_pct {
        parts.push(
            Contribution::direct(GAUGE_FACTOR, rectangular(pct / 100.0 * value.abs()), None)
                .shared_by(&sensor.name),
        );
    }
    if let Some((modulus, u)) = record.youngs_modulus_gpa {
        parts.push(
            Contribution::direct(YOUNGS_MODULUS, u / modulus * value.abs(), None)
                .shared_by(&format!("Young's modulus of {modulus} GPa")),
        );
    }
    parts
}

/// The budget of a hold's mean of `sensor`: the readings' scatter (Type
/// A: the standard deviation of the mean over the effective sample count,
/// with `n_eff - 1` degrees of freedom), the sensor's Type B sources at
/// the mean and its session's own parts (its zero, [`zero_contributions`],
/// and its shunt check's gain). Empty without a mean.
pub fn hold_budget(sensor: &Sensor, stats: &WindowStats, session: &SessionParts) -> Budget {
    let Some(mean) = stats.mean else {
        return Budget::default();
    };
    let mut contributions = Vec::new();
    if let Some(scatter) = stats.std_of_mean().filter(|_| stats.n_eff >= 2.0) {
        contributions.push(Contribution::direct(
            READINGS_SCATTER,
            scatter,
            Some(stats.n_eff - 1.0),
        ));
    }
    contributions.extend(value_budget(sensor, mean).budget.contributions);
    contributions.extend(session.contributions(mean));
    Budget { contributions }
}

/// `budget`'s contributions as parts of a result that moves by
/// `sensitivity` per unit of its quantity, each named `quantity: source`.
pub fn propagated<'a>(
    budget: &'a Budget,
    sensitivity: f64,
    quantity: &'a str,
) -> impl Iterator<Item = Contribution> + 'a {
    budget.contributions.iter().map(move |c| Contribution {
        source: format!("{quantity}: {}", c.source),
        sensitivity: c.sensitivity * sensitivity,
        ..c.clone()
    })
}

/// The bore's and the rod's diameter tolerances in a net force `F = (p_h -
/// p_r) pi D^2 / 4 + p_r pi d^2 / 4` (bar and mm^2 to kN: 1e-4): `dF/dD =
/// (p_h - p_r) pi D / 2` and `dF/dd = p_r pi d / 2`, each diameter
/// rectangular within its tolerance and the same in every hold.
pub fn diameter_parts(cylinder: &Cylinder, head_bar: f64, rod_bar: f64) -> Vec<Contribution> {
    let kn_per_bar_mm2 = 1e-4;
    let bore = &cylinder.bore;
    let shared = format!("{} cylinder's diameters", cylinder.name);
    [
        (
            "bore diameter",
            cylinder.bore_tolerance_mm,
            (head_bar - rod_bar) * std::f64::consts::PI * bore.bore_diameter_mm / 2.0,
        ),
        (
            "rod diameter",
            cylinder.rod_tolerance_mm,
            rod_bar * std::f64::consts::PI * bore.rod_diameter_mm / 2.0,
        ),
    ]
    .into_iter()
    .filter(|(_, tolerance, _)| *tolerance > 0.0)
    .map(|(source, tolerance, per_mm)| Contribution {
        sensitivity: per_mm * kn_per_bar_mm2,
        ..Contribution::direct(
            &format!("{}: {source}", cylinder.name),
            rectangular(tolerance),
            None,
        )
        .shared_by(&shared)
    })
    .collect()
}

/// kN per bar of the head chamber and of the annulus.
pub fn kn_per_bar(cylinder: &Cylinder) -> (f64, f64) {
    (
        cylinder.bore.head_area_mm2() * 1e-4,
        cylinder.bore.annulus_area_mm2() * 1e-4,
    )
}
