//! `acq extract` over a recording: one pass finds the holds (or reads the
//! windows file) and the time origin, a second accumulates every sensor in
//! every window; or, for a tensile test, collects force and displacement.

use std::path::Path;

use acq_error::{AcqError, Result};
use acq_io::input::read_csv_records;
use acq_rig::profiles::SensorKind;
use acq_rig::{Rig, Specimen};

use super::holds::{Detection, HoldDetector, HoldOptions, Window};
use super::measured::MeasuredValue;
use super::plausibility::check_window;
use super::stats::{WindowAccumulator, WindowStats};
use super::tensile::{extract_curve, TensileCurve};
use acq_io::shunt_record::ShuntRecord;
use acq_io::zero_record::ZeroRecord;
use acq_metrology::budget::Budget;

use super::uncertainty::{diameter_parts, hold_budget, kn_per_bar, propagated, SessionParts};
use crate::recording::clocks::{offsets_ns, BusOffset};
use crate::recording::{Recording, SampleCounts};
use acq_rig::sensors::Sample;

/// Which windows to summarise.
#[derive(Clone, Debug)]
pub enum WindowChoice {
    /// Find the steady holds of the load.
    Auto(HoldOptions),
    /// `name,start_s,end_s` rows (seconds from the session start).
    File(std::path::PathBuf),
}

/// What `acq extract` (holds) produced.
#[derive(Clone, Debug)]
pub struct HoldsReport {
    pub values: Vec<MeasuredValue>,
    pub windows: Vec<Window>,
    /// The load sensor and what detection found (auto windows only).
    pub load_sensor: String,
    pub detection: Option<Detection>,
    pub t0_ns: i64,
    pub counts: SampleCounts,
    pub clocks: Vec<BusOffset>,
    /// Sensors without a single sample in the whole recording.
    pub never_seen: Vec<String>,
}

impl HoldsReport {
    /// What the user should know beside the values: the sensors never
    /// seen, whose values are empty.
    pub fn notes(&self) -> Vec<String> {
        self.never_seen
            .iter()
            .map(|name| {
                format!("{name}: never seen in the recording; its values are empty and flagged no_samples")
            })
            .collect()
    }
}

/// The rig's load sensor: `name`, else its only force sensor.
pub fn load_sensor(recording: &Recording, name: Option<&str>) -> Result<usize> {
    match name {
        Some(name) => recording.sensor_index(name),
        None => rig_load_sensor(&recording.rig),
    }
}

/// The rig's only force sensor, or what to say instead.
pub fn rig_load_sensor(rig: &Rig) -> Result<usize> {
    let forces: Vec<usize> = (0..rig.sensors.len())
        .filter(|&i| rig.sensors[i].kind == SensorKind::Force)
        .collect();
    match forces.as_slice() {
        [one] => Ok(*one),
        [] => Err(AcqError::Config(
            "the rig has no force sensor to find the holds with; name the load with --load SENSOR or give --windows FILE".into(),
        )),
        several => Err(AcqError::Config(format!(
            "the rig has {} force sensors ({}); say which is the load with --load SENSOR",
            several.len(),
            several
                .iter()
                .map(|&i| rig.sensors[i].name.as_str())
                .collect::<Vec<_>>()
                .join(", ")
        ))),
    }
}

/// Reads a windows file: `name,start_s,end_s` with a header.
pub fn read_windows(path: &Path, t0_ns: i64) -> Result<Vec<Window>> {
    let header = ["name", "start_s", "end_s"];
    let mut windows = Vec::new();
    for (line, record) in read_csv_records(path, &header)? {
        let seconds = |i: usize| -> Result<f64> {
            record[i]
                .parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| {
                    AcqError::Malformed(format!(
                        "{}:{line}: expected {} in seconds, found '{}'",
                        path.display(),
                        header[i],
                        &record[i]
                    ))
                })
        };
        let (start, end) = (seconds(1)?, seconds(2)?);
        if end <= start {
            return Err(AcqError::Malformed(format!(
                "{}:{line}: window '{}' ends ({end} s) before it starts ({start} s)",
                path.display(),
                &record[0]
            )));
        }
        windows.push(Window {
            name: record[0].to_string(),
            start_ns: t0_ns + (start * 1e9).round() as i64,
            end_ns: t0_ns + (end * 1e9).round() as i64,
        });
    }
    if windows.is_empty() {
        return Err(AcqError::Config(format!(
            "{}: no window in the file",
            path.display()
        )));
    }
    Ok(windows)
}

/// The specimen of a tensile test: the rig's `[specimen]` with each number
/// given here instead; both must be positive lengths.
pub fn specimen(
    recording: &Recording,
    diameter_mm: Option<f64>,
    gauge_length_mm: Option<f64>,
) -> Result<Specimen> {
    let specimen = match (recording.rig.specimen, diameter_mm, gauge_length_mm) {
        (_, Some(diameter_mm), Some(gauge_length_mm)) => Specimen {
            diameter_mm,
            gauge_length_mm,
        },
        (Some(rig), diameter_mm, gauge_length_mm) => Specimen {
            diameter_mm: diameter_mm.unwrap_or(rig.diameter_mm),
            gauge_length_mm: gauge_length_mm.unwrap_or(rig.gauge_length_mm),
        },
        (None, _, _) => {
            return Err(AcqError::Config(format!(
                "the rig {} has no [specimen]; add one (diameter_mm, gauge_length_mm) or give --diameter-mm and --gauge-length-mm",
                recording.rig.path.display()
            )))
        }
    };
    if !(specimen.diameter_mm > 0.0 && specimen.gauge_length_mm > 0.0) {
        return Err(AcqError::Config(
            "--diameter-mm and --gauge-length-mm must be positive".into(),
        ));
    }
    Ok(specimen)
}

/// Summarises every sensor in every window (the holds, or the file's).
pub fn extract_holds(
    recording: &Recording,
    choice: &WindowChoice,
    load: Option<&str>,
    clock_overrides_ms: &[(String, f64)],
) -> Result<HoldsReport> {
    let rig = &recording.rig;
    if let WindowChoice::Auto(options) = choice {
        options.check().map_err(AcqError::Config)?;
    }
    let clocks = recording.clock_offsets(clock_overrides_ms)?;
    let offsets = offsets_ns(&clocks);
    let load_index = match choice {
        WindowChoice::Auto(_) => Some(load_sensor(recording, load)?),
        WindowChoice::File(_) => load.map(|n| recording.sensor_index(n)).transpose()?,
    };

    // Pass 1: the time origin and the load's blocks.
    let mut detector = HoldDetector::default();
    let mut first_ns = None;
    let mut counts = SampleCounts::default();
    recording.for_each_sample(&offsets, &mut counts, |sample| {
        first_ns.get_or_insert(sample.time_ns);
        if Some(sample.sensor) == load_index {
            if let Some(value) = sample.value {
                detector.push(sample.time_ns, value);
            }
        }
        Ok(())
    })?;
    let Some(first_ns) = first_ns else {
        return Err(recording.no_rig_sample());
    };
    let t0_ns = recording.session_start_unix_ns().unwrap_or(first_ns);
    let (windows, detection) = match choice {
        WindowChoice::Auto(options) => {
            let detection = detector.detect(options);
            if detection.holds.is_empty() {
                let name = &rig.sensors[load_index.unwrap_or(0)].name;
                return Err(AcqError::Config(format!(
                    "no steady hold of {name} found (range {:.4} {unit}, steady below a std of {:.4} {unit} for {:.1} s after trimming {:.1} s at each end); loosen --steady-std / --min-hold, or give --windows FILE",
                    detection.load_range,
                    detection.steady_std,
                    options.min_hold_ns as f64 / 1e9,
                    options.settle_ns as f64 / 1e9,
                    unit = rig.sensors[load_index.unwrap_or(0)].unit()
                )));
            }
            (detection.holds.clone(), Some(detection))
        }
        WindowChoice::File(path) => (read_windows(path, t0_ns)?, None),
    };

    // Pass 2: every sensor in every window.
    let mut summariser = WindowSummariser::new(rig, &windows)
        .with_session_records(recording.zero.as_ref(), recording.shunt.as_ref());
    let mut second_counts = SampleCounts::default();
    recording.for_each_sample(&offsets, &mut second_counts, |sample| {
        summariser.push(&sample);
        Ok(())
    })?;
    let values = summariser.values(t0_ns);
    let seen = summariser.seen;
    let never_seen = rig
        .sensors
        .iter()
        .zip(&seen)
        .filter(|(_, seen)| !**seen)
        .map(|(s, _)| s.name.clone())
        .collect();
    Ok(HoldsReport {
        values,
        windows,
        load_sensor: load_index
            .map(|i| rig.sensors[i].name.clone())
            .unwrap_or_default(),
        detection,
        t0_ns,
        counts,
        clocks,
        never_seen,
    })
}

/// Every sensor in every window, from samples given in recording order:
/// `acq extract`'s second pass, and the live view's over the samples it
/// keeps, so that both give the same numbers bit for bit.
pub struct WindowSummariser<'a> {
    rig: &'a Rig,
    windows: &'a [Window],
    /// Window-major: `accumulators[w * sensors + s]`.
    accumulators: Vec<WindowAccumulator>,
    /// Sensors that sent at least one sample (a value or a missing one).
    pub seen: Vec<bool>,
    /// Each sensor's parts of its session's zero and shunt check.
    session_parts: Vec<SessionParts>,
}

impl<'a> WindowSummariser<'a> {
    pub fn new(rig: &'a Rig, windows: &'a [Window]) -> Self {
        WindowSummariser {
            rig,
            windows,
            accumulators: windows
                .iter()
                .flat_map(|_| rig.sensors.iter().map(|s| WindowAccumulator::new(s.range)))
                .collect(),
            seen: vec![false; rig.sensors.len()],
            session_parts: vec![SessionParts::default(); rig.sensors.len()],
        }
    }

    /// Each value's budget gains its channel's zero and shunt gain from
    /// the session's records.
    pub fn with_session_records(
        mut self,
        zero: Option<&ZeroRecord>,
        shunt: Option<&ShuntRecord>,
    ) -> Self {
        self.session_parts = SessionParts::of(&self.rig.sensors, zero, shunt);
        // A transducer saturates in what it reads, before the zero is
        // taken off: a zeroed value a little under the range's start is
        // the zero's, not the end of the range.
        if let Some(zero) = zero {
            let sensors = self.rig.sensors.len();
            for (index, accumulator) in self.accumulators.iter_mut().enumerate() {
                let sensor = &self.rig.sensors[index % sensors];
                if let (Some([low, high]), Some(taken)) = (sensor.range, zero.sensor(&sensor.name))
                {
                    let offset = taken.offset();
                    *accumulator = WindowAccumulator::new(Some([low - offset, high - offset]));
                }
            }
        }
        self
    }

    pub fn push(&mut self, sample: &Sample) {
        let width = self.rig.sensors.len();
        self.seen[sample.sensor] = true;
        let Some(value) = sample.value else {
            return;
        };
        for (w, window) in self.windows.iter().enumerate() {
            if (window.start_ns..=window.end_ns).contains(&sample.time_ns) {
                self.accumulators[w * width + sample.sensor].push(sample.time_ns, value);
            }
        }
    }

    /// Every sensor's value in every window, then each cylinder's net force
    /// and loaded-chamber pressure; times in seconds from `t0_ns`.
    pub fn values(&self, t0_ns: i64) -> Vec<MeasuredValue> {
        let rig = self.rig;
        let width = rig.sensors.len();
        let mut values = Vec::new();
        for (w, window) in self.windows.iter().enumerate() {
            let accs = &self.accumulators[w * width..(w + 1) * width];
            let stats: Vec<WindowStats> = accs.iter().map(|a| a.summary()).collect();
            let flags = check_window(rig, accs, &stats);
            let hold = HoldWindow {
                name: &window.name,
                start_s: (window.start_ns - t0_ns) as f64 / 1e9,
                end_s: (window.end_ns - t0_ns) as f64 / 1e9,
            };
            values.extend(hold_values(rig, &hold, &stats, &flags, &self.session_parts));
        }
        values
    }
}

/// A hold's name and its span in session seconds.
pub struct HoldWindow<'a> {
    pub name: &'a str,
    pub start_s: f64,
    pub end_s: f64,
}

/// Every sensor's value in one hold from its statistics (per rig sensor),
/// each with its budget, then each cylinder's net force and loaded-chamber
/// pressure: what `acq extract` writes for the hold.
pub fn hold_values(
    rig: &Rig,
    hold: &HoldWindow<'_>,
    stats: &[WindowStats],
    flags: &[Vec<super::plausibility::Flag>],
    session_parts: &[SessionParts],
) -> Vec<MeasuredValue> {
    let mut values = Vec::new();
    for (i, sensor) in rig.sensors.iter().enumerate() {
        values.push(
            MeasuredValue {
                window: hold.name.to_string(),
                start_s: hold.start_s,
                end_s: hold.end_s,
                quantity: sensor.name.clone(),
                unit: sensor.unit().to_string(),
                stats: stats[i],
                flags: flags[i].iter().map(|f| f.code.clone()).collect(),
                note: flags[i]
                    .iter()
                    .map(|f| f.note.as_str())
                    .collect::<Vec<_>>()
                    .join("; "),
                budget: Budget::default(),
                u_c: None,
                k: None,
            }
            .with_budget(hold_budget(sensor, &stats[i], &session_parts[i])),
        );
    }
    values.extend(cylinder_values(
        rig,
        hold.name,
        hold.start_s,
        hold.end_s,
        stats,
        flags,
        session_parts,
    ));
    values
}

/// Net force and loaded-chamber pressure of each rig cylinder in a window.
fn cylinder_values(
    rig: &Rig,
    window: &str,
    start_s: f64,
    end_s: f64,
    stats: &[WindowStats],
    flags: &[Vec<super::plausibility::Flag>],
    session_parts: &[SessionParts],
) -> Vec<MeasuredValue> {
    let mut values = Vec::new();
    for cylinder in &rig.cylinders {
        let (head, rod) = (&stats[cylinder.head_sensor], &stats[cylinder.rod_sensor]);
        let inherited: Vec<String> = [cylinder.head_sensor, cylinder.rod_sensor]
            .iter()
            .flat_map(|&i| {
                flags[i]
                    .iter()
                    .map(move |f| format!("{}:{}", rig.sensors[i].name, f.code))
            })
            .collect();
        let bore = &cylinder.bore;
        let (head_kn_per_bar, rod_kn_per_bar) = kn_per_bar(cylinder);
        let net = head
            .mean
            .zip(rod.mean)
            .map(|(h, r)| bore.net_force_kn(h, r));
        let quadrature = |a: Option<f64>, b: Option<f64>| {
            a.zip(b)
                .map(|(a, b)| ((head_kn_per_bar * a).powi(2) + (rod_kn_per_bar * b).powi(2)).sqrt())
        };
        let n = head.n.min(rod.n);
        let (head_sensor, rod_sensor) = (
            &rig.sensors[cylinder.head_sensor],
            &rig.sensors[cylinder.rod_sensor],
        );
        let (head_budget, rod_budget) = (
            hold_budget(head_sensor, head, &session_parts[cylinder.head_sensor]),
            hold_budget(rod_sensor, rod, &session_parts[cylinder.rod_sensor]),
        );
        // Both pressures, each through its chamber's area.
        let net_force_budget = Budget {
            contributions: propagated(&head_budget, head_kn_per_bar, &head_sensor.name)
                .chain(propagated(&rod_budget, -rod_kn_per_bar, &rod_sensor.name))
                .chain(
                    head.mean
                        .zip(rod.mean)
                        .into_iter()
                        .flat_map(|(h, r)| diameter_parts(cylinder, h, r)),
                )
                .collect(),
        };
        values.push(
            MeasuredValue {
                window: window.to_string(),
                start_s,
                end_s,
                quantity: net_force_quantity(&cylinder.name),
                unit: "kN".into(),
                stats: WindowStats {
                    n,
                    mean: net,
                    std: quadrature(head.std, rod.std),
                    n_eff: head.n_eff.min(rod.n_eff),
                    lag1_autocorrelation: 0.0,
                    ci95_half_width: quadrature(head.ci95_half_width, rod.ci95_half_width),
                },
                flags: inherited.clone(),
                note: "head area x head pressure - annulus area x rod pressure".into(),
                budget: Budget::default(),
                u_c: None,
                k: None,
            }
            .with_budget(net_force_budget),
        );
        let (loaded, chamber, sensor) = match net {
            Some(force) if force < 0.0 => (*rod, "rod side (cylinder pulls)", cylinder.rod_sensor),
            _ => (*head, "head side (cylinder pushes)", cylinder.head_sensor),
        };
        values.push(
            MeasuredValue {
                window: window.to_string(),
                start_s,
                end_s,
                quantity: loaded_pressure_quantity(&cylinder.name),
                unit: "bar".into(),
                stats: loaded,
                flags: flags[sensor].iter().map(|f| f.code.clone()).collect(),
                note: format!("{chamber}: {}", rig.sensors[sensor].name),
                budget: Budget::default(),
                u_c: None,
                k: None,
            }
            .with_budget(if sensor == cylinder.rod_sensor {
                rod_budget
            } else {
                head_budget
            }),
        );
    }
    values
}

/// The quantity of a cylinder's net force (kN) in a hold.
pub fn net_force_quantity(cylinder: &str) -> String {
    format!("{cylinder}_net_force")
}

/// The quantity of a cylinder's loaded chamber pressure (bar) in a hold.
pub fn loaded_pressure_quantity(cylinder: &str) -> String {
    format!("{cylinder}_loaded_pressure")
}

/// What `acq extract --tensile` produced.
#[derive(Clone, Debug)]
pub struct TensileReport {
    pub curve: TensileCurve,
    pub force_sensor: String,
    pub displacement_sensor: String,
    pub counts: SampleCounts,
}

/// The force-displacement curve of a tensile test.
pub fn extract_tensile(
    recording: &Recording,
    force_name: Option<&str>,
    displacement_name: Option<&str>,
    clock_overrides_ms: &[(String, f64)],
) -> Result<TensileReport> {
    let rig = &recording.rig;
    let force = load_sensor(recording, force_name)?;
    let of_kind = |index: usize, kind: SensorKind, option: &str| -> Result<usize> {
        let sensor = &rig.sensors[index];
        if sensor.kind == kind {
            return Ok(index);
        }
        let fitting: Vec<&str> = rig
            .sensors
            .iter()
            .filter(|s| s.kind == kind)
            .map(|s| s.name.as_str())
            .collect();
        Err(AcqError::Config(format!(
            "{option} {}: it is a {} sensor in {} in the rig {}, not a {} sensor; the rig's {} sensors: {}",
            sensor.name,
            sensor.kind.name(),
            sensor.unit(),
            rig.path.display(),
            kind.name(),
            kind.name(),
            if fitting.is_empty() { "none".to_string() } else { fitting.join(", ") }
        )))
    };
    let force = of_kind(force, SensorKind::Force, "--force")?;
    let displacement = match displacement_name {
        Some(name) => of_kind(recording.sensor_index(name)?, SensorKind::Displacement, "--displacement")?,
        None => rig
            .sensors
            .iter()
            .position(|s| s.kind == SensorKind::Displacement)
            .ok_or_else(|| {
                AcqError::Config("the rig has no displacement sensor (extensometer); name it with --displacement SENSOR".into())
            })?,
    };
    let clocks = recording.clock_offsets(clock_overrides_ms)?;
    let offsets = offsets_ns(&clocks);
    let mut force_samples = Vec::new();
    let mut displacement_samples = Vec::new();
    let mut counts = SampleCounts::default();
    recording.for_each_sample(&offsets, &mut counts, |sample| {
        if let Some(value) = sample.value {
            if sample.sensor == force {
                force_samples.push((sample.time_ns, value));
            } else if sample.sensor == displacement {
                displacement_samples.push((sample.time_ns, value));
            }
        }
        Ok(())
    })?;
    for series in [&mut force_samples, &mut displacement_samples] {
        series.sort_by_key(|(t, _)| *t);
        series.dedup_by_key(|(t, _)| *t);
    }
    let max_gap_ns = 3 * rig.sensors[displacement].period_ns();
    let curve = extract_curve(&force_samples, &displacement_samples, max_gap_ns)
        .map_err(|e| AcqError::Config(format!("{}: {e}", recording.label)))?;
    Ok(TensileReport {
        curve,
        force_sensor: rig.sensors[force].name.clone(),
        displacement_sensor: rig.sensors[displacement].name.clone(),
        counts,
    })
}
