//! Zero and tare: a rest state before the test (and optionally after it)
//! sets each channel's offset, without touching the raw frames.
//!
//! [`ZeroTaker`] is fed the decoded samples in recording order, live (the
//! recorder's view thread) or offline ([`take`] over a session); both feed
//! it the same samples in the same order, so both give the same record bit
//! for bit. [`Zeroing`] subtracts a record's offsets from samples; a
//! [`crate::recording::Recording`] applies its session's record to every
//! sample it gives, so `extract`, `align` and the view all see zeroed values.
//!
//! Times are on the reference clock with only the rig's given clock
//! offsets removed: the live side cannot estimate offsets, and a zero window
//! is seconds long where clock offsets are milliseconds.

use std::collections::VecDeque;

use acq_error::Result;
use acq_io::zero_record::{SensorZero, ZeroReading, ZeroRecord};
use acq_rig::sensors::Sample;
use acq_rig::Rig;

use crate::extract::holds::{HoldDetector, HoldOptions};
use crate::extract::stats::WindowAccumulator;
use crate::recording::clocks::given_offsets_ns;
pub use crate::recording::zeroing::Zeroing;
use crate::recording::{Recording, SampleCounts};

/// How long past the before window's end a late frame (another bus, a
/// slow device) is still taken into it: far more than buses drift apart,
/// and the live view waits this long before it shows zeroed values.
pub const LATE_FRAME_GRACE_NS: i64 = 1_000_000_000;

/// The zero windows to take: the first `before_ns` of the session and,
/// optionally, the last `after_ns` before its last sample.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ZeroWindows {
    pub before_ns: i64,
    pub after_ns: Option<i64>,
}

impl ZeroWindows {
    /// Windows of at least one sample period; a message otherwise.
    pub fn new(before_s: f64, after_s: Option<f64>) -> std::result::Result<Self, String> {
        let to_ns = |what: &str, s: f64| {
            if s.is_finite() && s > 0.0 && s < 3600.0 {
                Ok((s * 1e9).round() as i64)
            } else {
                Err(format!(
                    "the {what} zero window must be between 0 and 1 h long, got {s} s"
                ))
            }
        };
        Ok(ZeroWindows {
            before_ns: to_ns("before", before_s)?,
            after_ns: after_s.map(|s| to_ns("after", s)).transpose()?,
        })
    }
}

/// A window's samples in four quarters of its time, as running means and
/// spreads. At rest each quarter has the channel's noise and the quarters'
/// means agree to a fraction of it; a load applied anywhere in the window
/// (a ramp across it, or a rise in its last quarter) moves a quarter's mean
/// by many times the quietest quarter's noise.
#[derive(Clone, Copy, Debug)]
struct Quarters {
    from_ns: i64,
    length_ns: i64,
    /// (n, mean, sum of squared deviations) per quarter.
    parts: [(f64, f64, f64); 4],
}

/// A quarter whose mean lies further than this many times the noise at
/// rest from the first quarter's is no rest: for white noise the quarters'
/// means differ by a few standard errors, far under one noise.
const MOVED_TIMES_NOISE: f64 = 5.0;

impl Quarters {
    fn new(from_ns: i64, length_ns: i64) -> Self {
        Quarters {
            from_ns,
            length_ns: length_ns.max(1),
            parts: [(0.0, 0.0, 0.0); 4],
        }
    }

    fn push(&mut self, time_ns: i64, value: f64) {
        let quarter = ((time_ns - self.from_ns).max(0) as i128 * 4 / self.length_ns as i128)
            .clamp(0, 3) as usize;
        let (n, mean, m2) = &mut self.parts[quarter];
        *n += 1.0;
        let delta = value - *mean;
        *mean += delta / *n;
        *m2 += delta * (value - *mean);
    }

    /// (how far a quarter's mean lies from the first's, the noise at rest),
    /// in the value's unit; `None` unless every quarter has 3 samples.
    fn moved_and_noise(&self) -> Option<(f64, f64)> {
        if self.parts.iter().any(|(n, _, _)| *n < 3.0) {
            return None;
        }
        let stds: Vec<f64> = self
            .parts
            .iter()
            .map(|(n, _, m2)| (m2 / (n - 1.0)).sqrt())
            .collect();
        // The quietest quarter is the rest; a floor of a quarter of the
        // typical one keeps a quantised channel that reads one value for
        // a while from having no noise at all.
        let typical = stds.iter().sum::<f64>() / 4.0;
        let noise = stds
            .iter()
            .cloned()
            .fold(f64::INFINITY, f64::min)
            .max(typical / 4.0);
        let first = self.parts[0].1;
        let moved = self.parts[1..]
            .iter()
            .map(|(_, mean, _)| (mean - first).abs())
            .fold(0.0, f64::max);
        Some((moved, noise))
    }

    /// A line saying the channel was not at rest, or `None`.
    fn not_at_rest(&self, name: &str, unit: &str, window: &str) -> Option<String> {
        let (moved, noise) = self.moved_and_noise()?;
        (moved > MOVED_TIMES_NOISE * noise && moved > 0.0).then(|| {
            format!(
                "{name}: not at rest in the {window}: its mean moves by {moved:.4} {unit} within it, {:.0} times its noise at rest ({noise:.4} {unit}); a zero there would take part of the load for zero",
                if noise > 0.0 { moved / noise } else { f64::INFINITY }
            )
        })
    }
}

/// One zeroed channel's readings so far.
struct Channel {
    before: WindowAccumulator,
    before_quarters: Quarters,
    /// The samples of the last `after_ns` (time, value), for the after window.
    tail: VecDeque<(i64, f64)>,
}

/// Takes the zero of every channel that reads zero at rest.
pub struct ZeroTaker {
    rig: Rig,
    windows: ZeroWindows,
    offsets_ns: Vec<i64>,
    /// The session's start (unix ns): the before window begins here.
    t0_ns: i64,
    /// Per rig sensor; `None` for a channel not zeroed.
    channels: Vec<Option<Channel>>,
    latest_ns: Option<i64>,
    before_closed: bool,
}

impl ZeroTaker {
    pub fn new(rig: &Rig, windows: ZeroWindows, t0_ns: i64) -> Self {
        ZeroTaker {
            rig: rig.clone(),
            windows,
            offsets_ns: given_offsets_ns(rig),
            t0_ns,
            channels: rig
                .sensors
                .iter()
                .map(|s| {
                    s.zero_at_rest.then(|| Channel {
                        before: WindowAccumulator::new(None),
                        before_quarters: Quarters::new(t0_ns, windows.before_ns),
                        tail: VecDeque::new(),
                    })
                })
                .collect(),
            latest_ns: None,
            before_closed: false,
        }
    }

    pub fn rig(&self) -> &Rig {
        &self.rig
    }

    fn before_end_ns(&self) -> i64 {
        self.t0_ns + self.windows.before_ns
    }

    /// One decoded sample, on its bus's clock (the rig's given offset is
    /// removed here).
    pub fn push(&mut self, sample: &Sample) {
        let bus = self.rig.sensors[sample.sensor].bus;
        let time_ns = sample.time_ns - self.offsets_ns.get(bus).copied().unwrap_or(0);
        let latest = self.latest_ns.map_or(time_ns, |t| t.max(time_ns));
        self.latest_ns = Some(latest);
        if latest >= self.before_end_ns() + LATE_FRAME_GRACE_NS {
            self.before_closed = true;
        }
        let before = self.t0_ns..self.before_end_ns();
        let (Some(channel), Some(value)) = (&mut self.channels[sample.sensor], sample.value) else {
            return;
        };
        if !self.before_closed && before.contains(&time_ns) {
            channel.before.push(time_ns, value);
            channel.before_quarters.push(time_ns, value);
        }
        if let Some(after_ns) = self.windows.after_ns {
            channel.tail.push_back((time_ns, value));
            while channel
                .tail
                .front()
                .is_some_and(|(t, _)| *t < latest - after_ns)
            {
                channel.tail.pop_front();
            }
        }
    }

    /// The channels that were not at rest in a zero window, a line each
    /// (what moved, by how much against its scatter).
    pub fn not_at_rest(&self) -> Vec<String> {
        let mut lines = self.not_at_rest_before();
        lines.extend(self.not_at_rest_after());
        lines
    }

    /// [`ZeroTaker::not_at_rest`] in the before window only: what a
    /// recorder can tell as soon as the window closes.
    pub fn not_at_rest_before(&self) -> Vec<String> {
        let mut lines = Vec::new();
        for (sensor, channel) in self.rig.sensors.iter().zip(&self.channels) {
            let Some(channel) = channel else { continue };
            lines.extend(channel.before_quarters.not_at_rest(
                &sensor.name,
                sensor.unit(),
                "before window",
            ));
        }
        lines
    }

    /// [`ZeroTaker::not_at_rest`] in the after window only (the latest
    /// samples).
    pub fn not_at_rest_after(&self) -> Vec<String> {
        let mut lines = Vec::new();
        for (sensor, channel) in self.rig.sensors.iter().zip(&self.channels) {
            let Some(channel) = channel else { continue };
            if let (Some(after_ns), Some(latest)) = (self.windows.after_ns, self.latest_ns) {
                let mut after = Quarters::new(latest - after_ns, after_ns);
                for &(t, value) in channel.tail.iter().filter(|(t, _)| *t >= latest - after_ns) {
                    after.push(t, value);
                }
                lines.extend(after.not_at_rest(&sensor.name, sensor.unit(), "after window"));
            }
        }
        lines
    }

    /// How long the recording ran, seconds from the session's start to its
    /// latest sample.
    pub fn recorded_s(&self) -> f64 {
        self.latest_ns
            .map_or(0.0, |latest| (latest - self.t0_ns) as f64 / 1e9)
    }

    /// Whether the before window is complete: the offsets are known.
    pub fn before_closed(&self) -> bool {
        self.before_closed
    }

    /// The record as it stands: the before window (complete or not), and
    /// the after window up to the latest sample when one is asked for.
    pub fn record(&self, taken_by: &str) -> ZeroRecord {
        let seconds = |ns: i64| (ns - self.t0_ns) as f64 / 1e9;
        let latest = self.latest_ns.unwrap_or(self.t0_ns);
        let sensors = self
            .rig
            .sensors
            .iter()
            .zip(&self.channels)
            .filter_map(|(sensor, channel)| {
                let channel = channel.as_ref()?;
                let before = reading(
                    &channel.before,
                    seconds(self.t0_ns),
                    seconds(self.before_end_ns()),
                )?;
                let after = self.windows.after_ns.and_then(|after_ns| {
                    let mut accumulator = WindowAccumulator::new(None);
                    for &(t, value) in channel.tail.iter().filter(|(t, _)| *t >= latest - after_ns)
                    {
                        accumulator.push(t, value);
                    }
                    reading(&accumulator, seconds(latest - after_ns), seconds(latest))
                });
                Some(SensorZero {
                    name: sensor.name.clone(),
                    unit: sensor.unit().to_string(),
                    before,
                    after,
                })
            })
            .collect();
        ZeroRecord {
            taken_by: taken_by.to_string(),
            session_start: acq_io::session::utc_text(self.t0_ns),
            before_s: self.windows.before_ns as f64 / 1e9,
            after_s: self.windows.after_ns.map(|ns| ns as f64 / 1e9),
            sensors,
        }
    }

    /// The channels that should have been zeroed but sent no value in the
    /// before window.
    pub fn missing(&self) -> Vec<String> {
        self.rig
            .sensors
            .iter()
            .zip(&self.channels)
            .filter(|(_, c)| c.as_ref().is_some_and(|c| c.before.n() == 0))
            .map(|(s, _)| s.name.clone())
            .collect()
    }
}

/// The first eight of `lines` (channels not at rest), indented under a
/// message, and how many more.
pub fn shown_lines(lines: &[String]) -> String {
    let mut shown = lines
        .iter()
        .take(8)
        .cloned()
        .collect::<Vec<_>>()
        .join("\n  ");
    if lines.len() > 8 {
        shown.push_str(&format!("\n  ... and {} more", lines.len() - 8));
    }
    shown
}

fn reading(accumulator: &WindowAccumulator, from_s: f64, to_s: f64) -> Option<ZeroReading> {
    let stats = accumulator.summary();
    Some(ZeroReading {
        from_s,
        to_s,
        samples: stats.n,
        mean: stats.mean?,
        std: stats.std,
        n_eff: stats.n_eff,
    })
}

/// What [`take`] found.
pub struct TakenZero {
    pub record: ZeroRecord,
    /// Channels to zero that sent no value in the before window.
    pub missing: Vec<String>,
    /// Channels that moved in a window: no rest, a line each.
    pub not_at_rest: Vec<String>,
    /// How long the recording ran, s.
    pub recorded_s: f64,
    pub counts: SampleCounts,
    /// The holds of the rig's load (its only force sensor), found as
    /// `acq extract` finds them: name, and where the load is on, s from
    /// the session's start (the steady part and the settling trimmed off
    /// it). Empty without a load sensor or a hold.
    pub holds_s: Vec<(String, f64, f64)>,
    /// Where that load leaves its level at the start, and where it is
    /// back at its level at the end, s from the session's start (its
    /// 100 ms means more than 1 % of its range away).
    pub load_moves_s: Option<(f64, f64)>,
}

/// Takes the zero of a recorded session offline, from its raw values (any
/// zero it already has is not applied), exactly as the recorder takes it
/// live.
pub fn take(recording: &Recording, windows: ZeroWindows, taken_by: &str) -> Result<TakenZero> {
    let t0_ns = recording.session_start_unix_ns().ok_or_else(|| {
        acq_error::AcqError::Config(format!(
            "{}: a zero window starts at the session's start; give a session directory written by acq record",
            recording.label
        ))
    })?;
    let mut taker = ZeroTaker::new(&recording.rig, windows, t0_ns);
    let mut counts = SampleCounts::default();
    let raw = vec![0; recording.rig.buses.len()];
    // The holds too: a window inside one is steady, and no rest.
    let load = crate::extract::run::rig_load_sensor(&recording.rig).ok();
    let mut detector = HoldDetector::default();
    recording.for_each_raw_sample(&raw, &mut counts, |sample| {
        taker.push(&sample);
        if let (true, Some(value)) = (Some(sample.sensor) == load, sample.value) {
            detector.push(sample.time_ns, value);
        }
        Ok(())
    })?;
    let options = HoldOptions::default();
    let seconds = |ns: i64| (ns - t0_ns) as f64 / 1e9;
    let detection = detector.detect(&options);
    let load_moves_s = load
        .and_then(|_| detector.load_departures(detection.steady_std))
        .map(|(rises, settles)| (seconds(rises), seconds(settles)));
    let holds_s = match load {
        Some(_) => detection.holds,
        None => Vec::new(),
    }
    .into_iter()
    .map(|hold| {
        let load_on = seconds(hold.start_ns - options.settle_ns);
        (hold.name, load_on, seconds(hold.end_ns + options.settle_ns))
    })
    .collect();
    Ok(TakenZero {
        record: taker.record(taken_by),
        missing: taker.missing(),
        not_at_rest: taker.not_at_rest(),
        recorded_s: taker.recorded_s(),
        counts,
        holds_s,
        load_moves_s,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_window_must_have_a_length() {
        assert!(ZeroWindows::new(0.0, None).is_err());
        assert!(ZeroWindows::new(3.0, Some(-1.0)).is_err());
        assert!(ZeroWindows::new(f64::NAN, None).is_err());
        assert_eq!(
            ZeroWindows::new(3.0, Some(0.5)).unwrap(),
            ZeroWindows {
                before_ns: 3_000_000_000,
                after_ns: Some(500_000_000)
            }
        );
    }
}
