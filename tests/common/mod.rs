//! Helpers shared by the integration tests that drive the real binary.
// Each test crate uses a different subset of these.
#![allow(dead_code)]

pub mod browser;
pub mod calculix;
pub mod pipeline;
pub mod slurm;
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

/// Runs `acq calibrate external --spec SPEC --out OUT` plus `extra`.
pub fn calibrate_external(spec: &Path, out: &Path, extra: &[&str]) -> Output {
    let mut args = vec![
        "calibrate",
        "external",
        "--spec",
        path_arg(spec),
        "--out",
        path_arg(out),
    ];
    args.extend_from_slice(extra);
    acq(&args)
}

/// Runs a study that must succeed; its `summary.json`.
pub fn external_summary(spec: &Path, out: &Path, extra: &[&str]) -> serde_json::Value {
    let output = calibrate_external(spec, out, extra);
    assert!(output.status.success(), "{}", stderr(&output));
    serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap()
}

/// The number at a key path of a JSON value (panics naming the path).
pub fn number(value: &serde_json::Value, path: &[&str]) -> f64 {
    let mut v = value;
    for key in path {
        v = &v[*key];
    }
    v.as_f64()
        .unwrap_or_else(|| panic!("no number at {path:?} in {value:#}"))
}
