//! Files into the lake: written in a scratch directory of this process,
//! published by a rename, so a reader (or an ingest killed at any
//! instant) sees a file whole or not at all.

use std::path::{Path, PathBuf};

use acq_error::{AcqError, Result};
use acq_io::session;

use crate::layout::{self, TMP_DIR};

/// This process's directory under `_tmp/`, named by host and process id;
/// removed at the end. Directories of processes of this host that no
/// longer run (a killed ingest) are removed when the next one starts.
pub struct ScratchDir {
    path: PathBuf,
}

impl ScratchDir {
    pub fn new(lake: &Path) -> Result<ScratchDir> {
        let host = layout::partition_value(&session::host_name());
        let root = lake.join(TMP_DIR);
        if let Ok(listing) = std::fs::read_dir(&root) {
            for item in listing.flatten() {
                let name = item.file_name().to_string_lossy().into_owned();
                let pid = name
                    .strip_prefix(&format!("{host}-"))
                    .and_then(|pid| pid.parse::<u32>().ok());
                if pid.is_some_and(|pid| !Path::new(&format!("/proc/{pid}")).exists()) {
                    let _ = std::fs::remove_dir_all(item.path());
                }
            }
        }
        let path = root.join(format!("{host}-{}", std::process::id()));
        acq_io::output::create_dir(&path)?;
        Ok(ScratchDir { path })
    }

    /// Where `relative` is written before it is published.
    pub fn file(&self, relative: &Path) -> PathBuf {
        let flat = relative.to_string_lossy().replace(['/', '='], "_");
        self.path.join(flat)
    }
}

impl Drop for ScratchDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.path);
    }
}

/// Moves the finished `relative` from the scratch directory into its
/// place in the lake (a rename: readers see the old file or the new one,
/// never part of one); returns `relative`.
pub fn publish_file(tmp: &ScratchDir, lake: &Path, relative: &Path) -> Result<PathBuf> {
    prepare_file(tmp, lake, relative)?;
    publish_prepared_file(tmp, lake, relative)
}

/// The first half of [`publish_file`], for a thread of its own: the
/// file's directory in the lake made, its bytes flushed to disk. The
/// ingest's writers do this for their own files as each is finished,
/// side by side, instead of the decoder for all of them at the end.
pub fn prepare_file(tmp: &ScratchDir, lake: &Path, relative: &Path) -> Result<()> {
    let to = lake.join(relative);
    if let Some(parent) = to.parent() {
        acq_io::output::create_dir(parent)?;
    }
    std::fs::File::open(tmp.file(relative))
        .and_then(|f| f.sync_all())
        .map_err(|e| AcqError::io(format!("publishing {}", to.display()), e))
}

/// The second half of [`publish_file`], after [`prepare_file`]: the rename.
pub fn publish_prepared_file(tmp: &ScratchDir, lake: &Path, relative: &Path) -> Result<PathBuf> {
    let to = lake.join(relative);
    std::fs::rename(tmp.file(relative), &to)
        .map_err(|e| AcqError::io(format!("publishing {}", to.display()), e))?;
    Ok(relative.to_path_buf())
}

/// Writes `bytes` to `tmp`, flushes them to disk, and renames `tmp` to `path`.
pub fn publish_bytes(tmp: &Path, path: &Path, bytes: &[u8]) -> Result<()> {
    use std::io::Write;
    let written = std::fs::File::create(tmp)
        .and_then(|mut f| f.write_all(bytes).and_then(|()| f.sync_all()))
        .and_then(|()| std::fs::rename(tmp, path));
    written.map_err(|e| AcqError::io(format!("publishing {}", path.display()), e))
}

/// Removes a published file; one already gone is no error.
pub fn remove_published(path: &Path) -> Result<()> {
    match std::fs::remove_file(path) {
        Err(e) if e.kind() != std::io::ErrorKind::NotFound => {
            Err(AcqError::io(format!("removing {}", path.display()), e))
        }
        _ => Ok(()),
    }
}
