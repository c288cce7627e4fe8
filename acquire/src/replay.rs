//! `acq replay`: a log back onto a bus, with the original inter-frame timing
//! held to an absolute schedule.
//!
//! Frame i is due at `start + (t_i - t_0) / speed`; each wait is computed
//! from that deadline, never from the previous send, so sleep overshoot
//! does not accumulate over an hour of replay. The wait sleeps to just
//! before the deadline and polls the clock the last few microseconds; the timing
//! error of every frame is measured and reported.

use std::collections::HashMap;
use std::fmt;
use std::path::PathBuf;
use std::time::{Duration, Instant};

use acq_can::{Frame, IfaceName};
use acq_error::{AcqError, Result};
use acq_io::input::{open_log, LogInput};
use acq_rig::Rig;

use crate::bus::{Bus, BusError, FrameSink};

/// Which interface each frame goes out on.
#[derive(Clone, Debug, Default)]
pub struct Routing {
    /// `--map LOG_IFACE=BUS_IFACE`.
    pub map: Vec<(IfaceName, IfaceName)>,
    /// `--iface`: where frames of unmapped interfaces go. Without it and
    /// without a map, frames go out on the interface the log names.
    pub default: Option<IfaceName>,
}

impl Routing {
    /// A rig's buses onto `interfaces`: all onto one, or one each in the
    /// rig's order.
    pub fn for_rig(rig: &Rig, interfaces: &[IfaceName]) -> Result<Routing> {
        match interfaces.len() {
            1 => Ok(Routing {
                map: Vec::new(),
                default: Some(interfaces[0]),
            }),
            n if n == rig.buses.len() => Ok(Routing {
                map: rig
                    .buses
                    .iter()
                    .map(|b| b.iface)
                    .zip(interfaces.iter().copied())
                    .collect(),
                default: None,
            }),
            n => Err(AcqError::Config(format!(
                "{n} interfaces given for a rig with {} buses: give one, or one per bus in order",
                rig.buses.len()
            ))),
        }
    }

    pub fn route(&self, from: IfaceName) -> Option<IfaceName> {
        if let Some((_, to)) = self.map.iter().find(|(f, _)| *f == from) {
            return Some(*to);
        }
        match self.default {
            Some(to) => Some(to),
            None if self.map.is_empty() => Some(from),
            None => None,
        }
    }
}

/// When frames go out.
#[derive(Clone, Copy, Debug)]
pub enum Pacing {
    /// The log's timing divided by `speed` (2.0 = twice as fast), from the
    /// first frame sent at once or, with an `anchor`, on a schedule fixed
    /// in advance.
    Timed { speed: f64, anchor: Option<Anchor> },
    /// As fast as the bus takes them (`--ignore-timestamps`).
    AsFast,
}

/// A replay's schedule fixed in advance: the log's instant `log_unix_ns`
/// plays at the wall time `wall_unix_ns` (a recording's start played at a
/// new recording's start, so that every frame lands at the same offset from
/// the session's start as in the log).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Anchor {
    pub log_unix_ns: i64,
    pub wall_unix_ns: i64,
}

impl Pacing {
    /// The log's timing at `speed`, its first frame sent at once.
    pub fn timed(speed: f64) -> Pacing {
        Pacing::Timed {
            speed,
            anchor: None,
        }
    }
}

/// Where a replay's schedule stands: the wall time, monotonic and Unix, of
/// the log time `log_ns` (counted from the first frame of the first pass).
#[derive(Clone, Copy)]
struct Schedule {
    start: Instant,
    start_unix_ns: i64,
    log_ns: i64,
}

impl Schedule {
    /// The schedule on which `first_log_unix_ns`, the log's first frame,
    /// plays now, or as `anchor` says.
    fn new(anchor: Option<Anchor>, first_log_unix_ns: i64) -> Schedule {
        let now = Instant::now();
        let now_unix_ns = crate::bus::now_ns();
        let Some(anchor) = anchor else {
            return Schedule {
                start: now,
                start_unix_ns: now_unix_ns,
                log_ns: 0,
            };
        };
        let ahead_ns = anchor.wall_unix_ns - now_unix_ns;
        let start = if ahead_ns >= 0 {
            now + Duration::from_nanos(ahead_ns as u64)
        } else {
            now.checked_sub(Duration::from_nanos(ahead_ns.unsigned_abs()))
                .unwrap_or(now)
        };
        Schedule {
            start,
            start_unix_ns: anchor.wall_unix_ns,
            log_ns: anchor.log_unix_ns - first_log_unix_ns,
        }
    }
}

/// What a replay did.
#[derive(Clone, Debug, Default)]
pub struct PlaySummary {
    pub frames_sent: u64,
    pub error_frames_skipped: u64,
    pub unrouted_skipped: u64,
    pub timing: TimingStats,
    pub elapsed: Duration,
}

impl fmt::Display for PlaySummary {
    /// One line of counts, and one of timing errors when the replay was timed.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{} frames in {:.3} s",
            self.frames_sent,
            self.elapsed.as_secs_f64()
        )?;
        if self.error_frames_skipped > 0 {
            write!(f, ", {} error frames skipped", self.error_frames_skipped)?;
        }
        if self.unrouted_skipped > 0 {
            write!(
                f,
                ", {} frames of unmapped interfaces skipped",
                self.unrouted_skipped
            )?;
        }
        if let (Some((median, p99, max)), Some((late_median, late_p99, _))) =
            (self.timing.interval_error_us(), self.timing.lateness_us())
        {
            write!(
                f,
                "\ninter-frame timing error |actual - logged|: median {median:.1} us, p99 {p99:.1} us, max {max:.1} us; send lateness median {late_median:.1} us, p99 {late_p99:.1} us"
            )?;
        }
        Ok(())
    }
}

/// Logs played as one stream, file after file (a session's raw files), from
/// the first file again at each new pass. Every file is opened when its turn
/// comes; the first at once, so a missing log fails before anything is sent.
pub struct LogFiles {
    paths: Vec<PathBuf>,
    pass: usize,
    index: usize,
    current: LogInput,
}

impl LogFiles {
    pub fn open(paths: Vec<PathBuf>) -> Result<Self> {
        let first = paths
            .first()
            .ok_or_else(|| AcqError::Config("no log to play".into()))?;
        let current = open_log(first)?;
        Ok(LogFiles {
            paths,
            pass: 0,
            index: 0,
            current,
        })
    }

    /// The next frame of `pass` (0-based); `None` at the end of the pass.
    pub fn next_frame(&mut self, pass: usize) -> Result<Option<Frame>> {
        if pass != self.pass {
            self.pass = pass;
            self.index = 0;
            self.current = open_log(&self.paths[0])?;
        }
        loop {
            if let Some(frame) = self.current.next_frame()? {
                return Ok(Some(frame));
            }
            if self.index + 1 >= self.paths.len() {
                return Ok(None);
            }
            self.index += 1;
            self.current = open_log(&self.paths[self.index])?;
        }
    }
}

/// Timing errors of a timed replay: lateness of each send against its
/// deadline, and the error of each inter-frame interval against the log's.
#[derive(Clone, Debug, Default)]
pub struct TimingStats {
    lateness_ns: Vec<i64>,
    interval_error_ns: Vec<i64>,
}

impl TimingStats {
    pub fn is_empty(&self) -> bool {
        self.lateness_ns.is_empty()
    }

    /// (median, 99th percentile, maximum) of |inter-frame interval error|, µs.
    pub fn interval_error_us(&self) -> Option<(f64, f64, f64)> {
        percentiles(&self.interval_error_ns)
    }

    /// The earliest send relative to its deadline, ns (never negative:
    /// the player waits until the deadline has passed).
    pub fn earliest_send_ns(&self) -> Option<i64> {
        self.lateness_ns.iter().copied().min()
    }

    /// (median, 99th percentile, maximum) of send lateness, µs.
    pub fn lateness_us(&self) -> Option<(f64, f64, f64)> {
        percentiles(&self.lateness_ns)
    }
}

fn percentiles(values_ns: &[i64]) -> Option<(f64, f64, f64)> {
    if values_ns.is_empty() {
        return None;
    }
    let mut sorted: Vec<u64> = values_ns.iter().map(|v| v.unsigned_abs()).collect();
    sorted.sort_unstable();
    let at = |q: f64| sorted[((sorted.len() - 1) as f64 * q).round() as usize] as f64 / 1e3;
    Some((at(0.5), at(0.99), at(1.0)))
}

/// Waits until `deadline` precisely: sleeps to just before it, then polls.
///
/// Blocks the thread on purpose: the player runs alone on its runtime, and
/// a tokio timer (1 ms granularity) could not hold 100 µs.
fn wait_until(deadline: Instant) {
    const SPIN: Duration = Duration::from_micros(60);
    loop {
        let now = Instant::now();
        if now >= deadline {
            return;
        }
        let remaining = deadline - now;
        if remaining > SPIN {
            std::thread::sleep(remaining - SPIN);
        } else {
            // Yield rather than spin: on a one-CPU machine the process we
            // feed (a recorder, candump) must get to run between frames.
            std::thread::yield_now();
        }
    }
}

/// Plays `frames` onto `bus`; `frames` yields `Ok(None)` at the end of one
/// pass and is asked again for each of `passes` passes.
pub async fn play<B: Bus>(
    bus: &B,
    mut next_frame: impl FnMut(usize) -> Result<Option<Frame>>,
    routing: &Routing,
    pacing: Pacing,
    passes: usize,
) -> Result<PlaySummary> {
    // Timer slack 1 µs instead of 50: sleeps end when asked (Linux only; best effort).
    let _ = nix::sys::prctl::set_timerslack(1_000);
    let mut sinks: HashMap<IfaceName, B::Sink> = HashMap::new();
    let mut summary = PlaySummary::default();
    let started = Instant::now();
    let mut schedule: Option<Schedule> = None;
    let mut pass_offset_ns: i64 = 0;
    let mut previous: Option<(Instant, i64)> = None;
    for pass in 0..passes.max(1) {
        let mut last_in_pass: Option<i64> = None;
        let mut first_in_pass: Option<i64> = None;
        while let Some(frame) = next_frame(pass)? {
            if frame.is_error() {
                summary.error_frames_skipped += 1;
                continue;
            }
            let Some(out) = routing.route(frame.iface) else {
                summary.unrouted_skipped += 1;
                continue;
            };
            first_in_pass.get_or_insert(frame.timestamp_ns);
            last_in_pass = Some(frame.timestamp_ns);
            // Passes follow each other without a gap, keeping each pass's own timing.
            let log_ns = frame.timestamp_ns - first_in_pass.unwrap_or(0) + pass_offset_ns;
            // Opened before the wait: opening a socket must not make its first frame late.
            let sink = match sinks.get_mut(&out) {
                Some(sink) => sink,
                None => {
                    let sink = bus
                        .open_sink(out)
                        .map_err(|e| AcqError::Config(e.to_string()))?;
                    sinks.entry(out).or_insert(sink)
                }
            };
            let Pacing::Timed { speed, anchor } = pacing else {
                send(sink, &frame, None).await?;
                summary.frames_sent += 1;
                continue;
            };
            let at = *schedule.get_or_insert_with(|| Schedule::new(anchor, frame.timestamp_ns));
            let offset_ns = ((log_ns - at.log_ns).max(0) as f64 / speed).round() as u64;
            let deadline = at.start + Duration::from_nanos(offset_ns);
            wait_until(deadline);
            let sent_at = Instant::now();
            summary
                .timing
                .lateness_ns
                .push(signed_ns(sent_at, deadline));
            if let Some((previous_at, previous_deadline_ns)) = previous {
                let actual = signed_ns(sent_at, previous_at);
                let wanted = offset_ns as i64 - previous_deadline_ns;
                summary.timing.interval_error_ns.push(actual - wanted);
            }
            previous = Some((sent_at, offset_ns as i64));
            send(sink, &frame, Some(at.start_unix_ns + offset_ns as i64)).await?;
            summary.frames_sent += 1;
        }
        if let (Some(first), Some(last)) = (first_in_pass, last_in_pass) {
            pass_offset_ns += last - first;
        }
    }
    summary.elapsed = started.elapsed();
    Ok(summary)
}

/// Sends `frame` on `sink`, at the wire time its schedule gave it if any.
async fn send<S: FrameSink>(sink: &mut S, frame: &Frame, wire_unix_ns: Option<i64>) -> Result<()> {
    let sent = match wire_unix_ns {
        Some(at) => sink.send_at(frame, at).await,
        None => sink.send(frame).await,
    };
    sent.map_err(|e| match e {
        BusError::Io { iface, source } => AcqError::io(format!("sending on {iface}"), source),
        other => AcqError::Config(other.to_string()),
    })
}

fn signed_ns(a: Instant, b: Instant) -> i64 {
    if a >= b {
        (a - b).as_nanos() as i64
    } else {
        -((b - a).as_nanos() as i64)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn name(s: &str) -> IfaceName {
        IfaceName::new(s).unwrap()
    }

    #[test]
    fn routing_follows_canplayer() {
        let plain = Routing::default();
        assert_eq!(plain.route(name("can0")), Some(name("can0")));
        let mapped = Routing {
            map: vec![(name("can0"), name("vcan1"))],
            default: None,
        };
        assert_eq!(mapped.route(name("can0")), Some(name("vcan1")));
        assert_eq!(
            mapped.route(name("can1")),
            None,
            "unassigned interfaces are skipped"
        );
        let both = Routing {
            map: vec![(name("can0"), name("vcan1"))],
            default: Some(name("vcan0")),
        };
        assert_eq!(both.route(name("can1")), Some(name("vcan0")));
    }

    #[test]
    fn percentiles_of_absolute_errors() {
        let stats = TimingStats {
            lateness_ns: vec![1_000, -3_000, 2_000],
            interval_error_ns: vec![],
        };
        assert_eq!(stats.lateness_us(), Some((2.0, 3.0, 3.0)));
        assert_eq!(stats.interval_error_us(), None);
    }
}
