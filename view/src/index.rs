//! A recorded session's view kept beside it (`view-index.bin`), so that the
//! next `acq view` opens it without reading the recording again.
//!
//! The file holds a JSON header (what identifies the recording it was made
//! from, the holds, the buses, each sensor's state, the raw frames per id) and then every sensor's
//! buckets as little-endian `f32` pairs (NaN: no sample). It is used only if
//! the recording is the one it was made from (raw files' names and sizes,
//! frame count, start, rig copy, zero and shunt records, acq version); anything else, a damaged file
//! included, is read again from the recording and the index rewritten.

use std::path::Path;

use acq_error::Result;
use acq_io::output::Output;
use acq_io::session::SessionFile;
use serde::{Deserialize, Serialize};

use crate::frames::FrameTable;
use crate::model::{silence_reason, BusView, HoldView, SessionView};
use crate::series::{MinMax, MinMaxSeries};

pub const FILE: &str = "view-index.bin";
const MAGIC: &[u8] = b"ACQ-VIEW-INDEX 2\n";

/// What the index was made from.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Key {
    software: String,
    raw_files: Vec<(String, u64)>,
    frames: u64,
    started_unix_ns: i64,
    rig_sha256: Option<String>,
    /// The zero and shunt records' (`acq zero` and `acq shunt` may change
    /// them after the recording).
    corrections_sha256: Vec<Option<String>>,
}

/// The recording in `dir` as it is now.
pub fn key(dir: &Path, session: &SessionFile) -> Key {
    Key {
        software: format!("acq {}", env!("CARGO_PKG_VERSION")),
        raw_files: session
            .session
            .raw_files
            .iter()
            .map(|name| {
                let bytes = std::fs::metadata(dir.join(name)).map_or(0, |m| m.len());
                (name.clone(), bytes)
            })
            .collect(),
        frames: session.session.frames,
        started_unix_ns: session.session.started_unix_ns,
        rig_sha256: session.rig.as_ref().map(|r| r.file.sha256.clone()),
        corrections_sha256: [
            acq_io::zero_record::ZERO_FILE,
            acq_io::shunt_record::SHUNT_FILE,
        ]
        .iter()
        .map(|name| {
            let path = dir.join(name);
            // Not a FIFO: the page must never wait on one.
            std::fs::metadata(&path)
                .is_ok_and(|m| m.is_file())
                .then(|| std::fs::read(&path).ok())
                .flatten()
                .map(|bytes| acq_io::session::sha256_hex(&bytes))
        })
        .collect(),
    }
}

#[derive(Serialize, Deserialize)]
struct SensorHeader {
    name: String,
    last_value: Option<f64>,
    silent: bool,
    silence_reason: Option<String>,
    first_index: i64,
    buckets: usize,
}

#[derive(Serialize, Deserialize)]
struct Header {
    key: Key,
    bucket_ns: i64,
    elapsed_s: f64,
    load_sensor: Option<String>,
    holds_note: Option<String>,
    buses: Vec<BusView>,
    holds: Vec<HoldView>,
    xy: Option<Vec<(f64, f64)>>,
    sensors: Vec<SensorHeader>,
    frames: FrameTable,
}

/// Writes the view's index into `dir` (whole or not at all).
pub fn save(dir: &Path, key: &Key, view: &SessionView) -> Result<()> {
    let mut payload = Vec::new();
    let sensors = view
        .sensors
        .iter()
        .map(|sensor| {
            let (first_index, buckets) = sensor.series.buckets();
            let count = buckets.len();
            for bucket in buckets {
                let MinMax { min, max } = bucket.unwrap_or(MinMax {
                    min: f32::NAN,
                    max: f32::NAN,
                });
                payload.extend_from_slice(&min.to_le_bytes());
                payload.extend_from_slice(&max.to_le_bytes());
            }
            SensorHeader {
                name: sensor.name.clone(),
                last_value: sensor.last_value,
                silent: sensor.silent,
                silence_reason: sensor.silence_reason.map(str::to_owned),
                first_index,
                buckets: count,
            }
        })
        .collect();
    let header = Header {
        key: key.clone(),
        bucket_ns: view.sensors.first().map_or(1, |s| s.series.bucket_ns()),
        elapsed_s: view.elapsed_s,
        load_sensor: view.load_sensor.clone(),
        holds_note: view.holds_note.clone(),
        buses: view.buses.clone(),
        holds: view.holds.clone(),
        xy: view.xy.as_ref().map(|xy| xy.points.clone()),
        sensors,
        frames: view.frames.clone(),
    };
    let header = serde_json::to_vec(&header).unwrap_or_default();
    let mut bytes = Vec::with_capacity(MAGIC.len() + 8 + header.len() + payload.len());
    bytes.extend_from_slice(MAGIC);
    bytes.extend_from_slice(&(header.len() as u64).to_le_bytes());
    bytes.extend_from_slice(&header);
    bytes.extend_from_slice(&payload);
    // The session's own cache, never an output the user points somewhere:
    // a FIFO or a device at its name would block the page for ever.
    let path = dir.join(FILE);
    if std::fs::symlink_metadata(&path).is_ok_and(|m| !m.is_file()) {
        return Err(acq_error::AcqError::Config(format!(
            "{} is not a regular file (a FIFO, a device or a link?); remove it and the next view keeps an index",
            path.display()
        )));
    }
    Output::write_complete(&path, &bytes)
}

/// The view from `dir`'s index, if there is one made from this recording;
/// `fresh` is the view of the rig's sensors with nothing in it yet.
pub fn load(dir: &Path, key: &Key, fresh: SessionView) -> Option<SessionView> {
    // Only a regular file: a FIFO would block the page for ever.
    let path = dir.join(FILE);
    if !std::fs::metadata(&path).is_ok_and(|m| m.is_file()) {
        return None;
    }
    let bytes = std::fs::read(&path).ok()?;
    let (stored, view) = parse(&bytes, fresh)?;
    (stored == *key).then_some(view)
}

/// An index's bytes: what it was made from, and `fresh` filled from it;
/// `None` for anything that is not a whole index of `fresh`'s sensors.
pub fn parse(bytes: &[u8], mut fresh: SessionView) -> Option<(Key, SessionView)> {
    let rest = bytes.strip_prefix(MAGIC)?;
    let (length, rest) = rest.split_first_chunk::<8>()?;
    let length = usize::try_from(u64::from_le_bytes(*length)).ok()?;
    let header = rest.get(..length)?;
    let mut payload = rest.get(length..)?;
    let header: Header = serde_json::from_slice(header).ok()?;
    if header.sensors.len() != fresh.sensors.len() || header.bucket_ns <= 0 {
        return None;
    }
    for (sensor, stored) in fresh.sensors.iter_mut().zip(header.sensors) {
        if sensor.name != stored.name {
            return None;
        }
        // The span must be far inside i64 nanoseconds (a session is years at most).
        const LIMIT: i64 = 1 << 61;
        let end = stored
            .first_index
            .checked_add(i64::try_from(stored.buckets).ok()?)?
            .checked_mul(header.bucket_ns)?;
        let start = stored.first_index.checked_mul(header.bucket_ns)?;
        if !(-LIMIT..=LIMIT).contains(&start) || !(-LIMIT..=LIMIT).contains(&end) {
            return None;
        }
        let (chunk, after) = payload.split_at_checked(stored.buckets.checked_mul(8)?)?;
        payload = after;
        let buckets = chunk
            .chunks_exact(8)
            .map(|pair| {
                let min = f32::from_le_bytes(pair[..4].try_into().ok()?);
                let max = f32::from_le_bytes(pair[4..].try_into().ok()?);
                (!min.is_nan() && !max.is_nan()).then_some(MinMax { min, max })
            })
            .collect();
        sensor.series = MinMaxSeries::from_buckets(header.bucket_ns, stored.first_index, buckets);
        sensor.last_value = stored.last_value;
        sensor.silent = stored.silent;
        sensor.silence_reason = stored.silence_reason.map(|r| silence_reason(&r));
    }
    if !payload.is_empty() {
        return None;
    }
    fresh.elapsed_s = header.elapsed_s;
    fresh.load_sensor = header.load_sensor;
    fresh.holds_note = header.holds_note;
    fresh.buses = header.buses;
    fresh.holds = header.holds;
    fresh.frames = header.frames.reindexed(fresh.sensors.len())?;
    if let (Some(xy), Some(points)) = (fresh.xy.as_mut(), header.xy) {
        xy.points = points;
    }
    Some((header.key, fresh))
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        /// Any bytes after the magic: no panic, and nothing taken that
        /// does not carry this recording's key.
        #[test]
        fn arbitrary_bytes_never_panic(tail in proptest::collection::vec(any::<u8>(), 0..300)) {
            let dir = tempfile::tempdir().unwrap();
            std::fs::write(dir.path().join(FILE), [MAGIC, &tail].concat()).unwrap();
            let rig_dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("../fixtures/sessions/tensile_p91_20c");
            let session = acq_io::session::read(&rig_dir).unwrap();
            let rig = acq_io::input::load_rig(&rig_dir.join(&session.rig.as_ref().unwrap().file.copy)).unwrap();
            let fresh = SessionView::new("x", &rig, 0, 10_000_000, 10);
            prop_assert!(load(dir.path(), &key(&rig_dir, &session), fresh).is_none());
        }
    }
}
