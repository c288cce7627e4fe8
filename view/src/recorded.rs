//! The view of a recorded session: one pass fills every series, and the
//! holds and their values are `acq extract`'s own (its defaults). The
//! result is kept beside the session ([`crate::index`]) for the next time.

use std::path::Path;

use acq_analysis::extract::holds::HoldOptions;
use acq_analysis::extract::live::LiveHold;
use acq_analysis::extract::run::{extract_holds, WindowChoice};
use acq_analysis::recording::clocks::offsets_ns;
use acq_analysis::recording::{Recording, RecordingEvent, SampleCounts};
use acq_error::{AcqError, Result};

use crate::frames::FrameTable;
use crate::index;
use crate::model::{finish_recorded, session_span, SessionView, TENSILE_NOTE};
use crate::series::{BUCKET_NS, WHOLE_SPAN_BUCKETS};

/// Where a recorded session's view came from.
#[derive(Clone, Debug, PartialEq)]
pub enum Source {
    /// Its index, made by an earlier `acq view`.
    Index,
    /// The recording; the index could be written (`Ok`) or not (why).
    Recording(std::result::Result<(), String>),
}

/// Reads the session in `dir` into a view named `name`, from its index
/// when it has one made from this recording.
pub fn open_session(dir: &Path, name: &str) -> Result<(SessionView, Source)> {
    if !dir.join(acq_io::session::SESSION_FILE).is_file() {
        return Err(AcqError::Config(format!(
            "{}: not a session directory (no {}); give a directory acq record wrote",
            dir.display(),
            acq_io::session::SESSION_FILE
        )));
    }
    let recording = Recording::open(dir, None)?;
    let Some(session) = recording.session.clone() else {
        return Err(AcqError::Config(format!(
            "{}: not a session directory (acq record writes one)",
            dir.display()
        )));
    };
    let (t0, duration_ns) = session_span(&session);
    let bucket_ns = BUCKET_NS.max((duration_ns + WHOLE_SPAN_BUCKETS - 1) / WHOLE_SPAN_BUCKETS);
    let buckets = (duration_ns / bucket_ns + 2) as usize;
    let mut view = SessionView::new(name, &recording.rig, t0, bucket_ns, buckets);
    let key = index::key(dir, &session);
    if let Some(mut indexed) = index::load(dir, &key, view.clone()) {
        indexed.ended = Some(session.session.ended.clone());
        return Ok((indexed, Source::Index));
    }
    let offsets = offsets_ns(&recording.clock_offsets(&[])?);
    let mut counts = SampleCounts::default();
    let mut last_sample_ns: Vec<Option<i64>> = vec![None; recording.rig.sensors.len()];
    let mut frame_sensors = Vec::new();
    let mut table = FrameTable::default();
    recording.for_each_event(&offsets, &mut counts, |event| {
        match event {
            RecordingEvent::Sample(sample) => {
                view.push(sample.sensor, sample.time_ns, sample.value);
                last_sample_ns[sample.sensor] = Some(sample.time_ns);
                frame_sensors.push(sample.sensor);
            }
            RecordingEvent::Frame(frame, used) => {
                let time_s = (frame.timestamp_ns - t0) as f64 / 1e9;
                table.see(frame, time_s, used, &frame_sensors);
                frame_sensors.clear();
            }
        }
        Ok(())
    })?;
    view.frames = table;
    finish_recorded(&mut view, &recording.rig, &session, &last_sample_ns);
    if view.xy.is_some() {
        view.holds_note = Some(TENSILE_NOTE.into());
        let saved = index::save(dir, &key, &view).map_err(|e| e.to_string());
        return Ok((view, Source::Recording(saved)));
    }
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
