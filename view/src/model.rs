//! What the page shows of one session: every sensor's series and last
//! value, each bus's counters, the holds with their measured values, and a
//! force-displacement curve when the rig has both.
//!
//! A live recording and a recorded session fill the same model; the server
//! only reads it.

use acq_acquire::record::live::SILENCE_PERIODS;
use acq_analysis::extract::live::LiveHold;
use acq_analysis::extract::measured::MeasuredValue;
use acq_io::session::SessionFile;
use acq_rig::profiles::SensorKind;
use acq_rig::Rig;
use serde::Serialize;
use serde_json::{json, Value};

use crate::frames::FrameTable;
use crate::series::{Column, MinMaxSeries};

/// What the page says instead of holds on a tensile test: its result is
/// a curve, and the pull is no steady hold.
pub const TENSILE_NOTE: &str =
    "a tensile test: its result is the force-displacement curve (the XY plot; acq extract --tensile), not holds";

/// Why a recorded sensor is silent.
pub const NEVER_SEEN: &str = "never seen";
pub const STOPPED_EARLY: &str = "stopped before the end of the session";

/// The page's words for a silence read back from an index.
pub fn silence_reason(text: &str) -> &'static str {
    match text {
        NEVER_SEEN => NEVER_SEEN,
        STOPPED_EARLY => STOPPED_EARLY,
        _ => "silent",
    }
}

/// Force-displacement points kept for the XY plot; past it every other one
/// is dropped (the curve keeps its shape, memory stays fixed).
const XY_POINTS: usize = 4_000;

/// One sensor as the page knows it.
#[derive(Clone, Debug)]
pub struct SensorView {
    pub name: String,
    pub unit: String,
    pub expected_rate_hz: f64,
    /// Sensors of one kind and unit share a chart.
    pub group: String,
    pub series: MinMaxSeries,
    pub last_value: Option<f64>,
    pub silent: bool,
    pub silence_reason: Option<&'static str>,
}

/// One bus's counters, as the terminal status shows them.
#[derive(Clone, Debug, Default, Serialize, serde::Deserialize)]
pub struct BusView {
    pub iface: String,
    pub state: String,
    pub frames_per_s: f64,
    pub frames: u64,
    pub kernel_drops: u64,
    pub error_frames: u64,
}

/// A hold on the page: its span and what `acq extract` would write for it.
#[derive(Clone, Debug, Serialize, serde::Deserialize)]
pub struct HoldView {
    pub index: usize,
    pub name: String,
    pub start_s: f64,
    pub end_s: f64,
    pub values: Option<Vec<MeasuredValue>>,
}

/// A force-displacement curve, thinned by two whenever it is full.
#[derive(Clone, Debug)]
pub struct XyCurve {
    pub force: usize,
    pub displacement: usize,
    pub points: Vec<(f64, f64)>,
    stride: usize,
    skipped: usize,
    last_force: Option<f64>,
}

/// One session: the recording going on, or one read from disk.
#[derive(Clone, Debug)]
pub struct SessionView {
    pub name: String,
    pub started_unix_ns: i64,
    /// Still recording (the page follows the newest data).
    pub live: bool,
    pub elapsed_s: f64,
    pub sensors: Vec<SensorView>,
    pub buses: Vec<BusView>,
    pub holds: Vec<HoldView>,
    /// Counts changes of `holds` (updates send them only when it moved).
    pub holds_version: u64,
    pub load_sensor: Option<String>,
    pub xy: Option<XyCurve>,
    /// Frames the view could not take in (the recorder had them all).
    pub frames_not_shown: u64,
    /// Why the session has no holds, if it has none (e.g. no load sensor).
    pub holds_note: Option<String>,
    /// How the recording ended, once it has (session.toml's `ended`:
    /// `signal SIGINT`, `duration reached`, ...).
    pub ended: Option<String>,
    /// The raw frames per bus and id (a live one: as of the view's last
    /// look, every 100 ms).
    pub frames: FrameTable,
}

impl SessionView {
    /// `bucket_ns` and `buckets`: the series' resolution and how many
    /// buckets each keeps.
    pub fn new(
        name: &str,
        rig: &Rig,
        started_unix_ns: i64,
        bucket_ns: i64,
        buckets: usize,
    ) -> Self {
        let sensors = rig
            .sensors
            .iter()
            .map(|s| SensorView {
                name: s.name.clone(),
                unit: s.unit().to_string(),
                expected_rate_hz: s.rate_hz,
                group: format!("{} ({})", s.kind.name(), s.unit()),
                series: MinMaxSeries::new(bucket_ns, buckets),
                last_value: None,
                silent: false,
                silence_reason: None,
            })
            .collect();
        let of_kind = |kind| {
            let found: Vec<usize> = (0..rig.sensors.len())
                .filter(|&i| rig.sensors[i].kind == kind)
                .collect();
            (found.len() == 1).then(|| found[0])
        };
        // The displacement a tensile curve is drawn over: the first one, as
        // `acq extract --tensile` takes it.
        let displacement = rig
            .sensors
            .iter()
            .position(|s| s.kind == SensorKind::Displacement);
        let xy = of_kind(SensorKind::Force)
            .zip(displacement)
            .map(|(force, displacement)| XyCurve {
                force,
                displacement,
                points: Vec::new(),
                stride: 1,
                skipped: 0,
                last_force: None,
            });
        SessionView {
            name: name.to_string(),
            started_unix_ns,
            live: false,
            elapsed_s: 0.0,
            sensors,
            buses: Vec::new(),
            holds: Vec::new(),
            holds_version: 0,
            load_sensor: None,
            xy,
            frames_not_shown: 0,
            holds_note: None,
            ended: None,
            frames: FrameTable::default(),
        }
    }

    /// One decoded sample, its time on the session's clock (unix ns).
    pub fn push(&mut self, sensor: usize, time_ns: i64, value: Option<f64>) {
        let Some(view) = self.sensors.get_mut(sensor) else {
            return;
        };
        view.last_value = value;
        let Some(value) = value else {
            return;
        };
        view.series.push(time_ns - self.started_unix_ns, value);
        if let Some(xy) = &mut self.xy {
            if sensor == xy.force {
                xy.last_force = Some(value);
            } else if sensor == xy.displacement {
                if let Some(force) = xy.last_force {
                    xy.push(value, force);
                }
            }
        }
    }

    pub fn set_holds(&mut self, holds: &[LiveHold]) {
        self.holds_version += 1;
        self.holds = holds
            .iter()
            .enumerate()
            .map(|(index, hold)| HoldView {
                index: index + 1,
                name: hold.window.name.clone(),
                start_s: hold.start_s,
                end_s: hold.end_s,
                values: hold.values.clone(),
            })
            .collect();
    }

    /// The sensors as `/api/state` lists them.
    pub fn sensors_json(&self, session: Option<&str>) -> Vec<Value> {
        self.sensors
            .iter()
            .map(|s| {
                let mut object = json!({
                    "name": s.name,
                    "unit": s.unit,
                    "expected_rate_hz": s.expected_rate_hz,
                    "group": s.group,
                    "last_value": s.last_value,
                    "silent": s.silent,
                    "silence_reason": s.silence_reason,
                });
                if let Some(session) = session {
                    object["session"] = json!(session);
                }
                object
            })
            .collect()
    }

    pub fn buses_json(&self, session: Option<&str>) -> Vec<Value> {
        self.buses
            .iter()
            .map(|b| {
                let mut object = json!(b);
                if let Some(session) = session {
                    object["session"] = json!(session);
                }
                object
            })
            .collect()
    }

    pub fn holds_json(&self, session: Option<&str>) -> Vec<Value> {
        self.holds
            .iter()
            .map(|h| {
                let values = h.values.as_ref().map(|values| {
                    values
                        .iter()
                        .map(|v| {
                            json!({
                                "quantity": v.quantity,
                                "unit": v.unit,
                                "mean": v.stats.mean,
                                "std": v.stats.std,
                                "ci95_half_width": v.stats.ci95_half_width,
                                "n": v.stats.n,
                                "flags": v.flags,
                            })
                        })
                        .collect::<Vec<_>>()
                });
                let mut object = json!({
                    "index": h.index,
                    "name": h.name,
                    "start_s": h.start_s,
                    "end_s": h.end_s,
                    "values": values,
                });
                if let Some(session) = session {
                    object["session"] = json!(session);
                }
                object
            })
            .collect()
    }

    /// The raw frames as `/api/state` lists them.
    pub fn frames_json(&self, session: Option<&str>) -> Vec<Value> {
        let names: Vec<String> = self.sensors.iter().map(|s| s.name.clone()).collect();
        self.frames.json(&names, session)
    }

    /// The span of the data, session seconds.
    pub fn span_s(&self) -> Option<(f64, f64)> {
        self.sensors
            .iter()
            .filter_map(|s| s.series.span_ns())
            .fold(None, |acc: Option<(i64, i64)>, (a, b)| {
                Some(acc.map_or((a, b), |(lo, hi)| (lo.min(a), hi.max(b))))
            })
            .map(|(a, b)| (a as f64 / 1e9, b as f64 / 1e9))
    }

    /// Each sensor's columns over `[from_s, to_s)` as JSON text:
    /// `[[[t_s, min, max], ...], ...]`, one array per sensor. Written by hand
    /// so that single-precision values print as short as they are.
    pub fn series_json(&self, from_s: f64, to_s: f64, columns: usize) -> String {
        let (from, to) = ((from_s * 1e9) as i64, (to_s * 1e9) as i64);
        let mut out = String::from("[");
        for (i, sensor) in self.sensors.iter().enumerate() {
            if i > 0 {
                out.push(',');
            }
            write_columns(&sensor.series.columns(from, to, columns), &mut out);
        }
        out.push(']');
        out
    }

    pub fn xy_json(&self) -> Value {
        match &self.xy {
            None => Value::Null,
            Some(xy) => json!({
                "x": self.sensors[xy.displacement].name,
                "x_unit": self.sensors[xy.displacement].unit,
                "y": self.sensors[xy.force].name,
                "y_unit": self.sensors[xy.force].unit,
                "points": xy.points.iter().map(|(x, y)| [*x, *y]).collect::<Vec<_>>(),
            }),
        }
    }
}

fn write_columns(columns: &[Column], out: &mut String) {
    let mut numbers = ryu::Buffer::new();
    out.push('[');
    for (k, column) in columns.iter().enumerate() {
        if k > 0 {
            out.push(',');
        }
        out.push('[');
        out.push_str(numbers.format_finite(column.start_ns as f64 / 1e9));
        out.push(',');
        out.push_str(numbers.format_finite(column.extremes.min));
        out.push(',');
        out.push_str(numbers.format_finite(column.extremes.max));
        out.push(']');
    }
    out.push(']');
}

impl XyCurve {
    fn push(&mut self, x: f64, y: f64) {
        self.skipped += 1;
        if self.skipped < self.stride {
            return;
        }
        self.skipped = 0;
        self.points.push((x, y));
        if self.points.len() >= XY_POINTS {
            let mut keep = false;
            self.points.retain(|_| {
                keep = !keep;
                keep
            });
            self.stride *= 2;
        }
    }
}

/// The session's start (unix ns) and length (ns, at least 1): to its last
/// frame, else to its stop.
pub fn session_span(session: &SessionFile) -> (i64, i64) {
    let info = &session.session;
    let t0 = info.started_unix_ns;
    let last_ns = session
        .interface
        .iter()
        .filter_map(|i| i.last_frame_unix_ns)
        .max()
        .or(info.stopped_unix_ns)
        .unwrap_or(t0);
    (t0, (last_ns - t0).max(1))
}

/// What the page says of a session once every sample is in: its length,
/// each bus's counts and mean rate, and which sensors were silent at its
/// last sample (as the recorder judges it: none within 3 periods; a sensor
/// that stopped before the others did, or never sent).
pub fn finish_recorded(
    view: &mut SessionView,
    rig: &Rig,
    session: &SessionFile,
    last_sample_ns: &[Option<i64>],
) {
    let (t0, duration_ns) = session_span(session);
    let duration_s = duration_ns as f64 / 1e9;
    view.live = false;
    view.elapsed_s = duration_s;
    view.ended = Some(session.session.ended.clone());
    let end_ns = last_sample_ns.iter().flatten().copied().max().unwrap_or(t0);
    for ((sensor, rig_sensor), last) in view
        .sensors
        .iter_mut()
        .zip(&rig.sensors)
        .zip(last_sample_ns)
    {
        let (silent, reason) = match last {
            None => (true, NEVER_SEEN),
            Some(t) if end_ns - t > SILENCE_PERIODS * rig_sensor.period_ns() => {
                (true, STOPPED_EARLY)
            }
            Some(_) => (false, ""),
        };
        sensor.silent = silent;
        sensor.silence_reason = silent.then_some(reason);
    }
    view.buses = session
        .interface
        .iter()
        .map(|i| BusView {
            iface: i.name.clone(),
            state: "recorded".into(),
            frames_per_s: (i.frames as f64 / duration_s * 10.0).round() / 10.0,
            frames: i.frames,
            kernel_drops: i.dropped_by_kernel,
            error_frames: i.error_frames,
        })
        .collect();
}
