//! Shunt calibration of a strain channel from a recorded step: the
//! amplifier switches a known resistor across one arm of the bridge, the
//! channel steps, and the step against the one the shunt simulates
//! (`acq_metrology::bridge`) gives a gain correction with its budget.
//!
//! The step is found in a window the user gives (the shunt switched once
//! in it) as the single change point that leaves the least squared
//! deviation on both sides; the readings within a settling time of the
//! switching are left out.

use acq_io::shunt_record::SensorShunt;
use acq_metrology::bridge::ShuntError;
use acq_rig::Rig;

use crate::extract::stats::{WindowAccumulator, WindowStats};
use crate::recording::{Recording, SampleCounts};

/// The fewest readings on each side of the step.
pub const MIN_SIDE_SAMPLES: u64 = 5;
/// A step must stand this many standard deviations of the readings above
/// their noise on either side.
pub const STEP_OVER_NOISE: f64 = 5.0;

/// A step found in a channel's readings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Step {
    /// Halfway between the last reading before it and the first after, ns.
    pub switched_ns: i64,
    pub before: WindowStats,
    pub after: WindowStats,
    /// `after - before`, in the channel's unit.
    pub step: f64,
    pub standard_error: f64,
    /// Welch-Satterthwaite; `None` when a side has no scatter.
    pub dof: Option<f64>,
}

/// Why no step was found; each message says what to change.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum StepError {
    #[error(
        "only {0} readings in the window; give a window of a few seconds around the switching"
    )]
    TooFewReadings(usize),
    #[error("no step: the largest change in the window is {step:.4} against readings that scatter by {noise:.4}; give the window in which the shunt was switched")]
    NoStep { step: f64, noise: f64 },
    #[error("only {0} readings on one side of the step once the settling time is left out; widen the window or shorten --settle")]
    ShortSide(u64),
    #[error("a side of the step is not steady (a std of {noise:.4} against a step of {step:.4}): the window holds more than one switching, or the load moved; give a window with the shunt switched once and the structure at rest")]
    NotSteady { step: f64, noise: f64 },
}

/// The step in `readings` (time ns, value), in time order.
pub fn find_step(readings: &[(i64, f64)], settle_ns: i64) -> Result<Step, StepError> {
    let n = readings.len();
    if n < 2 * MIN_SIDE_SAMPLES as usize {
        return Err(StepError::TooFewReadings(n));
    }
    // Shifted by the first value, the prefix sums keep their precision.
    let shift = readings[0].1;
    let mut sum = vec![0.0; n + 1];
    let mut sum_sq = vec![0.0; n + 1];
    for (i, &(_, v)) in readings.iter().enumerate() {
        let x = v - shift;
        sum[i + 1] = sum[i] + x;
        sum_sq[i + 1] = sum_sq[i] + x * x;
    }
    let deviation = |a: usize, b: usize| {
        let (s, count) = (sum[b] - sum[a], (b - a) as f64);
        sum_sq[b] - sum_sq[a] - s * s / count
    };
    // Only splits that leave enough readings on both sides past the
    // settling time.
    let times: Vec<i64> = readings.iter().map(|(t, _)| *t).collect();
    let min_side = MIN_SIDE_SAMPLES as usize;
    let split = (1..n)
        .filter(|&k| {
            times.partition_point(|&t| t < times[k] - settle_ns) >= min_side
                && n - times.partition_point(|&t| t <= times[k - 1] + settle_ns) >= min_side
        })
        .min_by(|&a, &b| {
            let cost = |k| deviation(0, k) + deviation(k, n);
            cost(a).total_cmp(&cost(b))
        })
        .ok_or(StepError::ShortSide(0))?;
    let switched_ns = readings[split - 1].0 + (readings[split].0 - readings[split - 1].0) / 2;
    let (mut before, mut after) = (WindowAccumulator::new(None), WindowAccumulator::new(None));
    for &(t, v) in readings {
        if t < switched_ns - settle_ns {
            before.push(t, v);
        } else if t > switched_ns + settle_ns {
            after.push(t, v);
        }
    }
    let shortest = before.n().min(after.n());
    if shortest < MIN_SIDE_SAMPLES {
        return Err(StepError::ShortSide(shortest));
    }
    let (before, after) = (before.summary(), after.summary());
    let (Some(mean_before), Some(mean_after)) = (before.mean, after.mean) else {
        return Err(StepError::ShortSide(0));
    };
    let step = mean_after - mean_before;
    let noise = before.std.unwrap_or(0.0).max(after.std.unwrap_or(0.0));
    if step.abs() <= STEP_OVER_NOISE * noise {
        // A split that explains most of the readings' spread found a
        // change, but not one clean step; one that explains little found
        // noise.
        let explained = 1.0 - (deviation(0, split) + deviation(split, n)) / deviation(0, n);
        return Err(if explained > 0.5 {
            StepError::NotSteady { step, noise }
        } else {
            StepError::NoStep { step, noise }
        });
    }
    let (sem_before, sem_after) = (
        before.std_of_mean().unwrap_or(0.0),
        after.std_of_mean().unwrap_or(0.0),
    );
    let standard_error = sem_before.hypot(sem_after);
    let dof = (standard_error > 0.0).then(|| {
        standard_error.powi(4)
            / (sem_before.powi(4) / (before.n_eff - 1.0).max(1.0)
                + sem_after.powi(4) / (after.n_eff - 1.0).max(1.0))
    });
    Ok(Step {
        switched_ns,
        before,
        after,
        step,
        standard_error,
        dof,
    })
}

/// Why a shunt check of a recording has no result.
#[derive(Debug, thiserror::Error)]
pub enum ShuntCheckError {
    #[error("sensor '{0}' has no shunt = {{ resistor_ohm, gauge_ohm, ... }} in the rig; add it under its [[sensor]]")]
    NoSetUp(String),
    #[error("{sensor} between {from_s} s and {to_s} s: {error}")]
    Step {
        sensor: String,
        from_s: f64,
        to_s: f64,
        error: StepError,
    },
    #[error("{sensor}: {error}")]
    Refused { sensor: String, error: ShuntError },
    #[error(transparent)]
    Read(#[from] acq_error::AcqError),
}

/// The shunt check of `sensor` over session seconds `from_s..to_s` of a
/// recording, on the channel's values as sent (neither zero nor an earlier
/// gain applied: the step is the channel's own).
pub fn check_recording(
    recording: &Recording,
    sensor: usize,
    from_s: f64,
    to_s: f64,
    settle_ns: i64,
) -> Result<SensorShunt, ShuntCheckError> {
    let rig: &Rig = &recording.rig;
    let name = rig.sensors[sensor].name.clone();
    let setup = rig.sensors[sensor]
        .record
        .shunt
        .ok_or_else(|| ShuntCheckError::NoSetUp(name.clone()))?;
    let mut t0_ns = recording.session_start_unix_ns();
    let mut readings = Vec::new();
    let mut counts = SampleCounts::default();
    let offsets = crate::recording::clocks::given_offsets_ns(rig);
    recording.for_each_raw_sample(&offsets, &mut counts, |sample| {
        let t0 = *t0_ns.get_or_insert(sample.time_ns);
        let seconds = (sample.time_ns - t0) as f64 / 1e9;
        if let (true, Some(value)) = (sample.sensor == sensor, sample.value) {
            if (from_s..=to_s).contains(&seconds) {
                readings.push((sample.time_ns, value));
            }
        }
        Ok(())
    })?;
    readings.sort_by_key(|(t, _)| *t);
    let step = find_step(&readings, settle_ns).map_err(|error| ShuntCheckError::Step {
        sensor: name.clone(),
        from_s,
        to_s,
        error,
    })?;
    let check = setup.check(step.step, step.standard_error, step.dof);
    let refused = |error: ShuntError| ShuntCheckError::Refused {
        sensor: name.clone(),
        error,
    };
    let correction = check
        .gain_correction(setup.tolerance_pct)
        .map_err(refused)?;
    let expected_strain = check.expected_strain().map_err(|e| refused(e.into()))?;
    let t0 = t0_ns.unwrap_or(0);
    Ok(SensorShunt {
        name,
        from_s,
        to_s,
        switched_s: (step.switched_ns - t0) as f64 / 1e9,
        step: step.step,
        step_standard_error: step.standard_error,
        step_dof: step.dof,
        measured_strain: check.measured_strain,
        expected_strain,
        gain: correction.factor,
        gain_standard_uncertainty: correction.standard_uncertainty,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A step of 10 at 2 s in readings at 100 Hz with a deterministic
    /// alternating noise of +-0.1: found at the switching, the sides'
    /// means exact, the standard error that of two sides of alternating
    /// readings.
    #[test]
    fn a_clean_step_is_found_where_it_was_switched() {
        let readings: Vec<(i64, f64)> = (0..400)
            .map(|i| {
                let t = i as i64 * 10_000_000;
                let noise = if i % 2 == 0 { 0.1 } else { -0.1 };
                (
                    t,
                    if t < 2_000_000_000 {
                        noise
                    } else {
                        10.0 + noise
                    },
                )
            })
            .collect();
        let step = find_step(&readings, 100_000_000).unwrap();
        assert_eq!(step.switched_ns, 1_995_000_000);
        assert!((step.step - 10.0).abs() < 0.01, "{step:?}");
        assert!(step.standard_error < 0.02, "{step:?}");
    }

    #[test]
    fn noise_alone_is_no_step_and_two_switchings_are_not_one() {
        let noise = |i: usize| ((i * 7919) % 13) as f64 / 13.0 - 0.5;
        let flat: Vec<(i64, f64)> = (0..300)
            .map(|i| (i as i64 * 10_000_000, noise(i)))
            .collect();
        assert!(matches!(
            find_step(&flat, 50_000_000),
            Err(StepError::NoStep { .. })
        ));
        // On at 1 s, off at 1.2 s, on again at 2 s: one side is not steady.
        let twice: Vec<(i64, f64)> = (0..300)
            .map(|i| {
                let t = i as i64 * 10_000_000;
                let on = (1_000_000_000..1_200_000_000).contains(&t) || t >= 2_000_000_000;
                (t, noise(i) * 0.01 + if on { 50.0 } else { 0.0 })
            })
            .collect();
        let found = find_step(&twice, 50_000_000);
        assert!(
            matches!(found, Err(StepError::NotSteady { .. })),
            "{found:?}"
        );
        assert!(matches!(
            find_step(&flat[..6], 0),
            Err(StepError::TooFewReadings(6))
        ));
    }
}
