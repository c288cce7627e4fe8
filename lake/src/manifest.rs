//! The lake's manifest: one JSON entry per source under `_manifest/`, named
//! by the source's id, written to the scratch directory and published by a
//! rename once every file of the source is in place.
//!
//! One file per source rather than one file for the lake: ingests of
//! disjoint sources (the jobs of an array) never write the same file, and
//! an entry is replaced whole or not at all.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use acq_error::{AcqError, Result};
use serde::{Deserialize, Serialize};

use crate::layout::MANIFEST_DIR;
use crate::publish::{publish_bytes, ScratchDir};

/// The version of the files' columns an entry's files have, and of its
/// content hash: a source ingested by an acq that wrote other columns or
/// hashed otherwise is ingested again. 2: BLAKE3, where 1 was SHA-256.
pub const FORMAT: u32 = 2;

/// What a source was and what it became.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Entry {
    /// [`FORMAT`] when its files were written.
    #[serde(default)]
    pub format: u32,
    /// The source as ingested: its absolute path.
    pub source: PathBuf,
    /// `session` (a directory acq record or acq import wrote) or `log`.
    pub kind: String,
    /// BLAKE3 of its content ([`content_hash`]): a log's bytes; a
    /// session's session.toml and raw logs, in order. Empty in an entry of
    /// format 1, which held SHA-256 under another name.
    #[serde(default)]
    pub blake3: String,
    pub bytes: u64,
    /// The rig that decoded it, and the BLAKE3 of the rig file.
    pub rig: PathBuf,
    #[serde(default)]
    pub rig_blake3: String,
    pub device: String,
    /// The `--bus LOGGED=RIG` pairs a log was decoded with.
    #[serde(default)]
    pub buses: Vec<String>,
    /// The `session` column of its rows: a session's directory name, a
    /// log's file name.
    pub session: String,
    pub ingested_utc: String,
    pub samples: u64,
    /// Samples that came more than the reorder window after a later one
    /// (written where they came: their file is then not sorted by time).
    pub out_of_order: u64,
    /// Every file it became, relative to the lake.
    pub files: Vec<PathBuf>,
    /// What was left out, and why (no holds: no load sensor, ...).
    pub notes: Vec<String>,
}

/// A source's id: the first 16 hex digits of the SHA-256 of its absolute
/// path. Stable while the file changes, so a changed file replaces its
/// own files.
pub fn source_id(absolute: &Path) -> String {
    acq_io::session::sha256_hex(absolute.as_os_str().as_encoded_bytes())[..16].to_string()
}

/// The BLAKE3 of the files' bytes one after another (hex) and their
/// length: a source's content. BLAKE3 rather than SHA-256 because a new
/// source is hashed while it is decoded and written, on the cores those
/// need: 4.4 GB/s on one core of the bench machine against 1.2 GB/s for
/// SHA-256 with the CPU's SHA instructions (2026-12-06, a 163 MB MF4).
pub fn content_hash(paths: &[&Path]) -> std::io::Result<(String, u64)> {
    let mut hasher = blake3::Hasher::new();
    let mut bytes = 0u64;
    for path in paths {
        let before = hasher.count();
        hasher.update_reader(std::fs::File::open(path)?)?;
        bytes += hasher.count() - before;
    }
    Ok((hasher.finalize().to_hex().to_string(), bytes))
}

/// The entry of source `id`, if the lake has one.
pub fn read(lake: &Path, id: &str) -> Result<Option<Entry>> {
    let path = lake.join(MANIFEST_DIR).join(format!("{id}.json"));
    let text = match std::fs::read_to_string(&path) {
        Ok(text) => text,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(e) => return Err(AcqError::io(format!("reading {}", path.display()), e)),
    };
    serde_json::from_str(&text).map(Some).map_err(|e| {
        AcqError::Config(format!(
            "{}: not a manifest entry acq wrote ({e}); remove it and ingest its source again",
            path.display()
        ))
    })
}

/// Every entry of the lake, by source id.
pub fn read_all(lake: &Path) -> Result<BTreeMap<String, Entry>> {
    let dir = lake.join(MANIFEST_DIR);
    let mut entries = BTreeMap::new();
    let listing = match std::fs::read_dir(&dir) {
        Ok(listing) => listing,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(entries),
        Err(e) => return Err(AcqError::io(format!("listing {}", dir.display()), e)),
    };
    for item in listing {
        let item = item.map_err(|e| AcqError::io(format!("listing {}", dir.display()), e))?;
        let name = item.file_name().to_string_lossy().into_owned();
        if let Some(id) = name.strip_suffix(".json") {
            if let Some(entry) = read(lake, id)? {
                entries.insert(id.to_string(), entry);
            }
        }
    }
    Ok(entries)
}

/// Publishes `entry` as source `id`'s: written to the scratch directory,
/// flushed to disk, then renamed over the old entry.
pub fn publish(lake: &Path, scratch: &ScratchDir, id: &str, entry: &Entry) -> Result<()> {
    let text = serde_json::to_string_pretty(entry)
        .map_err(|e| AcqError::Config(format!("manifest entry of {id}: {e}")))?;
    let name = format!("{id}.json");
    let path = lake.join(MANIFEST_DIR).join(&name);
    publish_bytes(&scratch.file(Path::new(&name)), &path, text.as_bytes())
}
