//! The scenario file of `acq simulate`: what the virtual rig's sensors read
//! over time, and how imperfect the devices are.
//!
//! ```toml
//! name = "excavator case 1"
//! [timeline]            # seconds: idle, load build-up, steady hold, release, idle
//! idle_s = 2.0
//! build_up_s = 3.0
//! hold_s = 10.0
//! release_s = 3.0
//! after_s = 2.0
//! [devices]             # defaults shown
//! clock_ppm = 50.0      # each device's clock error, drawn in +-clock_ppm
//! jitter_us = 100.0     # standard deviation of each frame's timing jitter
//! drop_probability = 0.001
//! relative_noise = 0.002  # noise std as a fraction of the sensor's largest value
//! [sensor.boom_head_pressure]
//! idle = 20.0           # value before the build-up and after the release
//! hold = 73.35          # value during the hold
//! noise = 0.3           # std in the sensor's unit (instead of relative_noise)
//! ```
//! Several holds, one after the other, each a build-up from idle, its own
//! hold and a release back to idle followed by `after_s` of idle: a
//! `[[hold]]` per hold, its length (`hold_s`, default the timeline's) and
//! the levels it differs in (a sensor it does not name reads its `hold`):
//! ```toml
//! [[hold]]
//! hold_s = 8.0
//! level = { tip_force = 20.0, boom_head_pressure = 55.0 }
//! [[hold]]
//! level = { tip_force = 40.6, boom_head_pressure = 73.35 }
//! ```
//! A measured test can drive sensors instead (`[curve]`: a CSV whose
//! `x_column` advances at `x_per_s` from `start_s`; a sensor with
//! `column = "FORCE"` follows that column, interpolated in x; after the
//! last point it keeps the last value, or reads `after_end` when given).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use acq_error::{AcqError, Result};
use serde::Deserialize;

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Scenario {
    pub name: String,
    #[serde(default)]
    pub description: Option<String>,
    #[serde(default)]
    pub timeline: Timeline,
    #[serde(default)]
    pub devices: Devices,
    #[serde(default)]
    pub curve: Option<CurveSpec>,
    #[serde(default)]
    pub sensor: BTreeMap<String, SensorScenario>,
    /// The holds, in order; none: one hold of the timeline's.
    #[serde(default)]
    pub hold: Vec<HoldSpec>,
}

/// One hold of several: how long, and the levels it sets.
#[derive(Clone, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HoldSpec {
    pub hold_s: Option<f64>,
    #[serde(default)]
    pub level: BTreeMap<String, f64>,
}

#[derive(Clone, Copy, Debug, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Timeline {
    pub idle_s: f64,
    pub build_up_s: f64,
    pub hold_s: f64,
    pub release_s: f64,
    pub after_s: f64,
}

impl Default for Timeline {
    fn default() -> Self {
        Timeline {
            idle_s: 1.0,
            build_up_s: 2.0,
            hold_s: 5.0,
            release_s: 2.0,
            after_s: 1.0,
        }
    }
}

impl Timeline {
    pub fn total_s(&self) -> f64 {
        self.idle_s + self.build_up_s + self.hold_s + self.release_s + self.after_s
    }

    /// 0 at idle, 1 during the hold, a smooth (half-cosine) ramp between.
    pub fn load_fraction(&self, t_s: f64) -> f64 {
        let ramp = |x: f64| 0.5 - 0.5 * (std::f64::consts::PI * x.clamp(0.0, 1.0)).cos();
        let hold_start = self.idle_s + self.build_up_s;
        let hold_end = hold_start + self.hold_s;
        if t_s < self.idle_s {
            0.0
        } else if t_s < hold_start {
            ramp((t_s - self.idle_s) / self.build_up_s.max(1e-9))
        } else if t_s < hold_end {
            1.0
        } else {
            1.0 - ramp((t_s - hold_end) / self.release_s.max(1e-9))
        }
    }

    /// The steady hold, (start, end) in seconds.
    pub fn hold_window_s(&self) -> (f64, f64) {
        let start = self.idle_s + self.build_up_s;
        (start, start + self.hold_s)
    }
}

#[derive(Clone, Copy, Debug, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Devices {
    pub clock_ppm: f64,
    pub jitter_us: f64,
    pub drop_probability: f64,
    pub relative_noise: f64,
}

impl Default for Devices {
    fn default() -> Self {
        Devices {
            clock_ppm: 50.0,
            jitter_us: 100.0,
            drop_probability: 0.001,
            relative_noise: 0.002,
        }
    }
}

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CurveSpec {
    pub file: PathBuf,
    pub x_column: String,
    pub x_per_s: f64,
    #[serde(default)]
    pub start_s: f64,
    #[serde(default = "default_after_s")]
    pub after_s: f64,
}

fn default_after_s() -> f64 {
    1.0
}

#[derive(Clone, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SensorScenario {
    pub idle: Option<f64>,
    pub hold: Option<f64>,
    pub column: Option<String>,
    /// Curve mode: the value after the curve's last point (0 for a load
    /// that drops at fracture); default: the last value.
    pub after_end: Option<f64>,
    pub noise: Option<f64>,
}

/// A measured curve loaded from its CSV: x and the named columns.
#[derive(Clone, Debug)]
pub struct Curve {
    pub x: Vec<f64>,
    pub columns: BTreeMap<String, Vec<f64>>,
    pub x_per_s: f64,
    pub start_s: f64,
    pub after_s: f64,
}

impl Curve {
    /// Column `name` at time `t_s`: linear in x, the first value before the
    /// start, the last after the end.
    pub fn value(&self, name: &str, t_s: f64) -> Option<f64> {
        let y = self.columns.get(name)?;
        let x = (t_s - self.start_s) * self.x_per_s;
        if x <= self.x[0] {
            return Some(y[0]);
        }
        let last = self.x.len() - 1;
        if x >= self.x[last] {
            return Some(y[last]);
        }
        // x is not monotonic in every test file (extensometer noise); take
        // the first segment that brackets it.
        let i = self
            .x
            .windows(2)
            .position(|w| w[0] <= x && x <= w[1])
            .unwrap_or(last - 1);
        let (x0, x1) = (self.x[i], self.x[i + 1]);
        let f = if x1 > x0 { (x - x0) / (x1 - x0) } else { 0.0 };
        Some(y[i] + f * (y[i + 1] - y[i]))
    }

    /// Whether `t_s` lies after the curve's last point.
    pub fn is_past_end(&self, t_s: f64) -> bool {
        let last = self.x.last().copied().unwrap_or(0.0);
        (t_s - self.start_s) * self.x_per_s > last
    }

    pub fn duration_s(&self) -> f64 {
        let span = self.x.last().copied().unwrap_or(0.0) - self.x[0].min(0.0);
        self.start_s + span / self.x_per_s + self.after_s
    }
}

impl Scenario {
    /// How many holds: the `[[hold]]`s, or the timeline's one.
    pub fn hold_count(&self) -> usize {
        self.hold.len().max(1)
    }

    /// Each hold's length, s.
    fn hold_lengths_s(&self) -> Vec<f64> {
        if self.hold.is_empty() {
            return vec![self.timeline.hold_s];
        }
        self.hold
            .iter()
            .map(|h| h.hold_s.unwrap_or(self.timeline.hold_s))
            .collect()
    }

    /// Each steady hold, (start, end) in seconds.
    pub fn hold_windows_s(&self) -> Vec<(f64, f64)> {
        let t = &self.timeline;
        let mut start = t.idle_s;
        self.hold_lengths_s()
            .into_iter()
            .map(|hold_s| {
                let window = (start + t.build_up_s, start + t.build_up_s + hold_s);
                start = window.1 + t.release_s + t.after_s;
                window
            })
            .collect()
    }

    /// The whole timeline, s.
    pub fn total_s(&self) -> f64 {
        let t = &self.timeline;
        t.idle_s
            + self
                .hold_lengths_s()
                .iter()
                .map(|hold_s| t.build_up_s + hold_s + t.release_s + t.after_s)
                .sum::<f64>()
    }

    /// Which hold's load `t_s` lies in (its build-up, hold or release), and
    /// how far up: 0 at idle, 1 during the hold, a half-cosine ramp between.
    pub fn load_fraction(&self, t_s: f64) -> (usize, f64) {
        let t = &self.timeline;
        for (k, (start, end)) in self.hold_windows_s().into_iter().enumerate() {
            let one = Timeline {
                idle_s: start - t.build_up_s,
                build_up_s: t.build_up_s,
                hold_s: end - start,
                release_s: t.release_s,
                after_s: 0.0,
            };
            if t_s < end + t.release_s {
                return (k, one.load_fraction(t_s));
            }
        }
        (self.hold_count() - 1, 0.0)
    }
}

/// The longest simulation, s: beyond it a timeline is a typo (and `-o`
/// would fill the disk).
pub const MAX_DURATION_S: f64 = 86_400.0;

impl Scenario {
    pub fn load(path: &Path) -> Result<(Scenario, Option<Curve>)> {
        acq_io::input::note_input(path);
        let text = std::fs::read_to_string(path).map_err(|e| AcqError::open(path, e))?;
        Scenario::parse(&text, path)
    }

    /// A scenario's text, read as the file at `path` (its curve's CSV is
    /// relative to it, and errors name it).
    pub fn parse(text: &str, path: &Path) -> Result<(Scenario, Option<Curve>)> {
        let scenario: Scenario = toml::from_str(text)
            .map_err(|e| AcqError::Config(format!("{}: {e}", path.display())))?;
        let bad = |what: String| AcqError::Config(format!("{}: {what}", path.display()));
        for (name, value) in [
            ("devices.clock_ppm", scenario.devices.clock_ppm),
            ("devices.jitter_us", scenario.devices.jitter_us),
            ("devices.relative_noise", scenario.devices.relative_noise),
            ("timeline.idle_s", scenario.timeline.idle_s),
            ("timeline.build_up_s", scenario.timeline.build_up_s),
            ("timeline.hold_s", scenario.timeline.hold_s),
            ("timeline.release_s", scenario.timeline.release_s),
            ("timeline.after_s", scenario.timeline.after_s),
        ] {
            if !(value.is_finite() && value >= 0.0) {
                return Err(bad(format!(
                    "{name} = {value}: expected a finite number >= 0"
                )));
            }
        }
        for (k, hold) in scenario.hold.iter().enumerate() {
            let n = k + 1;
            if hold.hold_s.is_some_and(|v| !(v.is_finite() && v >= 0.0)) {
                return Err(bad(format!(
                    "hold {n}: hold_s = {}: expected a finite number >= 0",
                    hold.hold_s.unwrap_or_default()
                )));
            }
            for (sensor, value) in &hold.level {
                if !value.is_finite() {
                    return Err(bad(format!(
                        "hold {n}: level.{sensor} = {value}: expected a finite number"
                    )));
                }
                if scenario
                    .sensor
                    .get(sensor)
                    .is_some_and(|s| s.column.is_some())
                {
                    return Err(bad(format!(
                        "hold {n}: level.{sensor}: that sensor follows the curve's column; a hold cannot set it"
                    )));
                }
            }
        }
        let total_s = scenario.total_s();
        if total_s > MAX_DURATION_S {
            return Err(bad(format!(
                "the timeline lasts {total_s} s; a simulation lasts at most {MAX_DURATION_S} s (a day): split a longer one"
            )));
        }
        if !(0.0..1.0).contains(&scenario.devices.drop_probability) {
            return Err(bad("devices.drop_probability: expected 0 <= p < 1".into()));
        }
        for (name, sensor) in &scenario.sensor {
            match (&sensor.column, sensor.idle.or(sensor.hold)) {
                (Some(_), Some(_)) => {
                    return Err(bad(format!(
                        "sensor.{name}: give either `column` or `idle`/`hold`, not both"
                    )))
                }
                (Some(_), None) if scenario.curve.is_none() => {
                    return Err(bad(format!(
                        "sensor.{name}: `column` needs a [curve] section"
                    )))
                }
                _ => {}
            }
            for (what, value) in [
                ("idle", sensor.idle),
                ("hold", sensor.hold),
                ("after_end", sensor.after_end),
            ] {
                if value.is_some_and(|v| !v.is_finite()) {
                    return Err(bad(format!(
                        "sensor.{name}.{what} = {}: expected a finite number",
                        value.unwrap_or_default()
                    )));
                }
            }
            if sensor.noise.is_some_and(|n| !(n.is_finite() && n >= 0.0)) {
                return Err(bad(format!(
                    "sensor.{name}.noise: expected a finite number >= 0"
                )));
            }
        }
        let curve = match &scenario.curve {
            None => None,
            Some(spec) => {
                let base = path.parent().unwrap_or(Path::new("."));
                Some(load_curve(spec, &base.join(&spec.file), &scenario)?)
            }
        };
        Ok((scenario, curve))
    }
}

fn load_curve(spec: &CurveSpec, path: &Path, scenario: &Scenario) -> Result<Curve> {
    if !(spec.x_per_s.is_finite() && spec.x_per_s > 0.0) {
        return Err(AcqError::Config(format!(
            "curve.x_per_s = {}: expected > 0",
            spec.x_per_s
        )));
    }
    let mut reader = csv::Reader::from_path(path)
        .map_err(|e| AcqError::Config(format!("{}: {e}", path.display())))?;
    let headers = reader
        .headers()
        .map_err(|e| AcqError::Malformed(format!("{}: {e}", path.display())))?
        .clone();
    let index = |name: &str| {
        headers
            .iter()
            .position(|h| h.trim() == name)
            .ok_or_else(|| {
                AcqError::Config(format!(
                    "{}: no column {name:?}; the columns are: {}",
                    path.display(),
                    headers.iter().collect::<Vec<_>>().join(", ")
                ))
            })
    };
    let x_index = index(&spec.x_column)?;
    let mut wanted: Vec<(String, usize)> = Vec::new();
    for sensor in scenario.sensor.values() {
        if let Some(column) = &sensor.column {
            if !wanted.iter().any(|(c, _)| c == column) {
                wanted.push((column.clone(), index(column)?));
            }
        }
    }
    let mut x = Vec::new();
    let mut columns: BTreeMap<String, Vec<f64>> = wanted
        .iter()
        .map(|(c, _)| (c.clone(), Vec::new()))
        .collect();
    for (row, record) in reader.records().enumerate() {
        let line = row + 2;
        let record =
            record.map_err(|e| AcqError::Malformed(format!("{}:{line}: {e}", path.display())))?;
        let number = |i: usize, name: &str| -> Result<f64> {
            record
                .get(i)
                .and_then(|v| v.trim().parse::<f64>().ok())
                .filter(|v| v.is_finite())
                .ok_or_else(|| {
                    AcqError::Malformed(format!(
                        "{}:{line}: column {name}: expected a number",
                        path.display()
                    ))
                })
        };
        x.push(number(x_index, &spec.x_column)?);
        for (name, i) in &wanted {
            let value = number(*i, name)?;
            if let Some(column) = columns.get_mut(name) {
                column.push(value);
            }
        }
    }
    if x.len() < 2 {
        return Err(AcqError::Malformed(format!(
            "{}: needs at least 2 rows",
            path.display()
        )));
    }
    let curve = Curve {
        x,
        columns,
        x_per_s: spec.x_per_s,
        start_s: spec.start_s,
        after_s: spec.after_s,
    };
    let duration_s = curve.duration_s();
    if !(duration_s.is_finite()
        && duration_s <= MAX_DURATION_S
        && spec.start_s >= 0.0
        && spec.after_s >= 0.0)
    {
        return Err(AcqError::Config(format!(
            "{}: the curve plays for {duration_s} s (start_s {}, after_s {}); give start_s, after_s >= 0 and at most {MAX_DURATION_S} s (a day) in all",
            path.display(),
            spec.start_s,
            spec.after_s
        )));
    }
    Ok(curve)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn load_fraction_is_a_smooth_trapezoid() {
        let t = Timeline {
            idle_s: 1.0,
            build_up_s: 2.0,
            hold_s: 3.0,
            release_s: 2.0,
            after_s: 1.0,
        };
        assert_eq!(t.load_fraction(0.5), 0.0);
        assert!((t.load_fraction(2.0) - 0.5).abs() < 1e-12);
        assert_eq!(t.load_fraction(4.0), 1.0);
        assert!((t.load_fraction(7.0) - 0.5).abs() < 1e-12);
        assert_eq!(t.load_fraction(8.5), 0.0);
        assert_eq!(t.total_s(), 9.0);
        assert_eq!(t.hold_window_s(), (3.0, 6.0));
    }
}
