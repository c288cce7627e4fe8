//! The view of a recorded session: one pass fills every series, and the
//! holds and their values are `acq extract`'s own (its defaults). The
//! result is kept beside the session ([`crate::index`]) for the next time.

use std::path::Path;

use acq_analysis::extract::holds::HoldOptions;
use acq_analysis::extract::live::LiveHold;
use acq_analysis::extract::run::{extract_holds, WindowChoice};
use acq_analysis::recording::clocks::offsets_ns;
use acq_analysis::recording::{Recording, SampleCounts};
use acq_drivers::rig::Rig;
use acq_io::error::{AcqError, Result};
use acq_io::session::SessionFile;

use acq_acquire::record::live::SILENCE_PERIODS;

use crate::index;
use crate::live::LIVE_BUCKET_NS;
use crate::model::{BusView, SessionView};

/// A recorded session's series are cut into at most this many buckets
/// (each 10 ms or longer): about 1.5 MB per sensor, whatever its length.
pub const MAX_BUCKETS: i64 = 1 << 17;

/// Why a recorded sensor is silent.
pub const NEVER_SEEN: &str = "never seen";
pub const STOPPED_EARLY: &str = "stopped before the end of the session";

/// Where a recorded session's view came from.
#[derive(Clone, Debug, PartialEq)]
pub enum Source {
    /// Its index, made by an earlier `acq view`.
    Index,
    /// The recording; the index could be written (`Ok`) or not (why).
    Recording(std::result::Result<(), String>),
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

/// Reads the session in `dir` into a view named `name`, from its index
/// when it has one made from this recording.
pub fn open_session(dir: &Path, name: &str) -> Result<(SessionView, Source)> {
    let recording = Recording::open(dir, None)?;
    let Some(session) = recording.session.clone() else {
        return Err(AcqError::Config(format!(
            "{}: not a session directory (acq record writes one)",
            dir.display()
        )));
    };
    let (t0, duration_ns) = session_span(&session);
    let bucket_ns = LIVE_BUCKET_NS.max((duration_ns + MAX_BUCKETS - 1) / MAX_BUCKETS);
    let buckets = (duration_ns / bucket_ns + 2) as usize;
    let mut view = SessionView::new(name, &recording.rig, t0, bucket_ns, buckets);
    let key = index::key(dir, &session);
    if let Some(indexed) = index::load(dir, &key, view.clone()) {
        return Ok((indexed, Source::Index));
    }
    let offsets = offsets_ns(&recording.clock_offsets(&[])?);
    let mut counts = SampleCounts::default();
    let mut last_sample_ns: Vec<Option<i64>> = vec![None; recording.rig.sensors.len()];
    recording.for_each_sample(&offsets, &mut counts, |sample| {
        view.push(sample.sensor, sample.time_ns, sample.value);
        last_sample_ns[sample.sensor] = Some(sample.time_ns);
        Ok(())
    })?;
    finish_recorded(&mut view, &recording.rig, &session, &last_sample_ns);
    match extract_holds(
        &recording,
        &WindowChoice::Auto(HoldOptions::default()),
        None,
        &[],
    ) {
        Ok(report) => {
            view.load_sensor = Some(report.load_sensor.clone());
            let holds: Vec<LiveHold> = report
                .windows
                .iter()
                .map(|window| LiveHold {
                    window: window.clone(),
                    start_s: (window.start_ns - report.t0_ns) as f64 / 1e9,
                    end_s: (window.end_ns - report.t0_ns) as f64 / 1e9,
                    values: Some(
                        report
                            .values
                            .iter()
                            .filter(|v| v.window == window.name)
                            .cloned()
                            .collect(),
                    ),
                })
                .collect();
            view.set_holds(&holds);
        }
        Err(error) => view.holds_note = Some(format!("no holds: {error}")),
    }
    let saved = index::save(dir, &key, &view).map_err(|e| e.to_string());
    Ok((view, Source::Recording(saved)))
}
