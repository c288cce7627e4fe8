//! `acq extract`'s holds, run as a stream while a session is recorded.
//!
//! The rule is the batch one ([`HoldDetector::detect`] over the load's
//! 100 ms blocks so far), so after the last sample the live holds are the
//! offline ones. A hold is reported once it is closed for good: the first
//! unsteady block after it and the blocks its rolling window reaches are
//! complete. Its values come from [`WindowSummariser`] over the samples kept
//! here, in the order they arrived (the order `raw.log` holds them), so they
//! equal `acq extract`'s bit for bit.
//!
//! Two things make the batch rule non-causal, and both are said, not hidden:
//! the default steady threshold is 1 % of the load's range so far, so a later,
//! larger load can widen or add an earlier hold (it is then re-reported,
//! `revision` counts them); and the samples are kept for [`KEPT_NS`] only, so
//! a hold revised after that has its window but no values
//! ([`LiveHold::values`] is `None`: `acq extract` has them).

use std::collections::VecDeque;

use acq_error::Result;
use acq_io::zero_record::ZeroRecord;
use acq_rig::sensors::Sample;
use acq_rig::Rig;

use super::holds::{HoldDetector, HoldOptions, Window, BLOCK_NS};
use super::measured::MeasuredValue;
use super::run::{rig_load_sensor, WindowSummariser};
use crate::recording::clocks::given_offsets_ns;

/// How long decoded samples are kept for the values of a hold: a hold
/// longer than this, or revised after this, has no live values.
pub const KEPT_NS: i64 = 300_000_000_000;

/// One hold as the stream knows it now.
#[derive(Clone, Debug, PartialEq)]
pub struct LiveHold {
    pub window: Window,
    /// Session seconds (from the session's start).
    pub start_s: f64,
    pub end_s: f64,
    /// Every sensor's and cylinder's value, as `acq extract` writes them;
    /// `None` when the samples of the window are no longer kept.
    pub values: Option<Vec<MeasuredValue>>,
}

/// The stream: push every decoded sample, call [`LiveHoldStream::update`]
/// now and then, and [`LiveHoldStream::finish`] after the last sample.
pub struct LiveHoldStream {
    rig: Rig,
    load: usize,
    options: HoldOptions,
    /// Each bus's clock offset given in the rig (an estimated one is 0
    /// live: estimating it needs the recording).
    offsets_ns: Vec<i64>,
    t0_ns: i64,
    detector: HoldDetector,
    kept: VecDeque<Sample>,
    /// The latest load sample time: blocks before it are complete.
    latest_load_ns: Option<i64>,
    holds: Vec<LiveHold>,
    /// How many times a reported hold changed or vanished.
    pub revisions: u64,
    /// The session's zero, once taken: its parts enter every budget.
    zero: Option<ZeroRecord>,
}

impl LiveHoldStream {
    /// `load`: the load sensor's name, else the rig's only force sensor.
    /// `t0_ns`: the session's start (unix ns), the origin of session seconds.
    pub fn new(rig: &Rig, load: Option<&str>, options: HoldOptions, t0_ns: i64) -> Result<Self> {
        options.check().map_err(acq_error::AcqError::Config)?;
        let load = match load {
            Some(name) => rig.sensor(name).map(|(i, _)| i).ok_or_else(|| {
                acq_error::AcqError::Config(format!("the rig has no sensor '{name}'"))
            })?,
            None => rig_load_sensor(rig)?,
        };
        let offsets_ns = given_offsets_ns(rig);
        Ok(LiveHoldStream {
            rig: rig.clone(),
            load,
            options,
            offsets_ns,
            t0_ns,
            detector: HoldDetector::default(),
            kept: VecDeque::new(),
            latest_load_ns: None,
            holds: Vec::new(),
            revisions: 0,
            zero: None,
        })
    }

    /// The session's zero record (the caller pushes zeroed samples): the
    /// holds' budgets carry its parts as `acq extract`'s do. A record that
    /// changes (the zero after the test, read at the end) makes every hold
    /// be summarised again.
    pub fn set_zero(&mut self, record: ZeroRecord) {
        if self.zero.as_ref().is_some_and(|known| *known != record) {
            self.holds.clear();
        }
        self.zero = Some(record);
    }

    pub fn load_sensor(&self) -> &str {
        &self.rig.sensors[self.load].name
    }

    /// One decoded sample, on its bus's clock (the offset is removed here).
    pub fn push(&mut self, mut sample: Sample) {
        let bus = self.rig.sensors[sample.sensor].bus;
        sample.time_ns -= self.offsets_ns.get(bus).copied().unwrap_or(0);
        if sample.sensor == self.load {
            if let Some(value) = sample.value {
                self.detector.push(sample.time_ns, value);
                self.latest_load_ns = Some(
                    self.latest_load_ns
                        .map_or(sample.time_ns, |t| t.max(sample.time_ns)),
                );
            }
        }
        let horizon = sample.time_ns - KEPT_NS;
        while self.kept.front().is_some_and(|s| s.time_ns < horizon) {
            self.kept.pop_front();
        }
        self.kept.push_back(sample);
    }

    /// Re-runs detection over the blocks so far; true when the holds changed.
    pub fn update(&mut self) -> bool {
        let Some(latest) = self.latest_load_ns else {
            return false;
        };
        // A steady run that ended at block i is final once block i + half
        // (the last its rolling window reaches) is complete.
        let half_ns = ((self.options.window_ns / BLOCK_NS).max(1) / 2) * BLOCK_NS;
        let closed_before = latest - half_ns - BLOCK_NS - self.options.settle_ns;
        self.refresh(|window| window.end_ns <= closed_before)
    }

    /// After the last sample: every hold, the one still open included.
    pub fn finish(&mut self) -> bool {
        self.refresh(|_| true)
    }

    pub fn holds(&self) -> &[LiveHold] {
        &self.holds
    }

    fn refresh(&mut self, closed: impl Fn(&Window) -> bool) -> bool {
        let detection = self.detector.detect(&self.options);
        let windows: Vec<Window> = detection.holds.into_iter().filter(|w| closed(w)).collect();
        if windows.len() == self.holds.len()
            && windows.iter().zip(&self.holds).all(|(w, h)| *w == h.window)
        {
            return false;
        }
        let revised = self
            .holds
            .iter()
            .filter(|h| !windows.contains(&h.window))
            .count();
        self.revisions += revised as u64;
        let oldest_kept = self.kept.front().map_or(i64::MAX, |s| s.time_ns);
        let mut holds = Vec::with_capacity(windows.len());
        for window in windows {
            if let Some(known) = self.holds.iter().find(|h| h.window == window) {
                holds.push(known.clone());
                continue;
            }
            let values = (window.start_ns >= oldest_kept).then(|| {
                let one = std::slice::from_ref(&window);
                let mut summariser = WindowSummariser::new(&self.rig, one)
                    .with_session_records(self.zero.as_ref(), None);
                for sample in &self.kept {
                    summariser.push(sample);
                }
                summariser.values(self.t0_ns)
            });
            holds.push(LiveHold {
                start_s: (window.start_ns - self.t0_ns) as f64 / 1e9,
                end_s: (window.end_ns - self.t0_ns) as f64 / 1e9,
                window,
                values,
            });
        }
        self.holds = holds;
        true
    }
}
