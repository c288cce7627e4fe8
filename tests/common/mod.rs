//! Helpers shared by the integration tests that drive the real binary.
// Each test crate uses a different subset of these.
#![allow(dead_code)]

pub mod browser;
pub mod pipeline;
use std::path::Path;
use std::process::{Command, Output};

pub fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

/// Runs the acq binary from the repository root.
pub fn acq(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_acq"))
        .args(args)
        .current_dir(root())
        .output()
        .unwrap()
}

/// A path as a command-line argument (the test paths are UTF-8).
pub fn path_arg(path: &Path) -> &str {
    path.to_str().unwrap()
}

pub fn stdout(output: &Output) -> String {
    String::from_utf8_lossy(&output.stdout).into_owned()
}

pub fn stderr(output: &Output) -> String {
    String::from_utf8_lossy(&output.stderr).into_owned()
}
