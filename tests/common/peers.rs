//! The Python peers' scratch virtualenvs (tests/peers/venvs/NAME.txt),
//! made by scripts/python-peers: one way for every test and benchmark of
//! the workspace (the root's, acq-can's) to get one.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

/// `scripts/python-peers NAME` of the repository at `repo`, its
/// virtualenvs in `dir`: the virtualenv's python, or what went wrong.
pub fn try_peer_python(repo: &Path, dir: &Path, name: &str) -> Result<PathBuf, String> {
    let made = Command::new(repo.join("scripts/python-peers"))
        .arg(name)
        .env("ACQ_PEERS_DIR", dir)
        .stderr(Stdio::inherit())
        .output()
        .map_err(|e| format!("scripts/python-peers: {e}"))?;
    if !made.status.success() {
        return Err(format!(
            "scripts/python-peers {name} failed (above): pip needs the package registry"
        ));
    }
    Ok(PathBuf::from(String::from_utf8_lossy(&made.stdout).trim()))
}

/// [`try_peer_python`], a test's failure when the virtualenv cannot be
/// made.
pub fn peer_python(repo: &Path, dir: &Path, name: &str) -> PathBuf {
    try_peer_python(repo, dir, name).unwrap_or_else(|e| panic!("{e}"))
}
