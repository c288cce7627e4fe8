//! The worked example `examples/calculix-tensile` prepared for a test: a
//! coarse mesh and a synthetic measurement made there (tests/calculix.rs
//! runs it locally, tests/slurm.rs on a real Slurm cluster).

use std::path::{Path, PathBuf};

use serde_json::Value;

use super::{root, stderr};

/// The truth the synthetic test is made at, and its noise.
pub const TRUE_K_MPA: f64 = 1000.0;
pub const TRUE_N: f64 = 0.12;
/// Coarse, but the neck still forms (the example's README compares meshes).
pub const TEST_MESH: &str = "3x15";

pub fn require(program: &str, package: &str) {
    let found = std::process::Command::new("sh")
        .args(["-c", &format!("command -v {program}")])
        .output()
        .is_ok_and(|o| o.status.success());
    assert!(
        found,
        "{program} is not installed; these tests run a real FE solver. Install it with \
         `apt-get install {package}` (scripts/test does)"
    );
}

pub fn example() -> PathBuf {
    root().join("examples/calculix-tensile")
}

/// The example copied into `dir` at the test mesh, with a synthetic test
/// made there by the model at the truth plus 0.5 % noise; returns what the
/// generator wrote (truth, measured scalars, their uncertainties).
pub fn example_at_test_mesh(dir: &Path) -> Value {
    require("ccx", "calculix-ccx");
    require("python3", "python3");
    std::fs::copy(example().join("tensile.py"), dir.join("tensile.py")).unwrap();
    let made = std::process::Command::new("python3")
        .current_dir(dir)
        .args([
            "tensile.py",
            "measured",
            "--K",
            &TRUE_K_MPA.to_string(),
            "--n",
            &TRUE_N.to_string(),
            "--noise",
            "0.005",
            "--seed",
            "7",
            "--mesh",
            TEST_MESH,
            "-o",
            "measured.csv",
        ])
        .output()
        .unwrap();
    assert!(made.status.success(), "{}", stderr(&made));
    let measured: Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("measured.json")).unwrap()).unwrap();
    for spec in ["spec-bo.toml", "spec-moo.toml"] {
        let mut text = std::fs::read_to_string(example().join(spec))
            .unwrap()
            .replace("\"6x30\"", &format!("\"{TEST_MESH}\""));
        // The shipped measured values belong to the shipped mesh: put this
        // mesh's in their place.
        let mut lines: Vec<String> = Vec::new();
        let mut output = None;
        for line in text.lines() {
            let mut line = line.to_string();
            if let Some(name) = line.strip_prefix("name = ") {
                output = Some(name.trim_matches('"').to_string());
            }
            for key in ["measured", "uncertainty"] {
                let table = if key == "measured" {
                    "measured"
                } else {
                    "uncertainty"
                };
                if line.starts_with(&format!("{key} = ")) {
                    let name = output.as_deref().unwrap();
                    line = format!("{key} = {:?}", measured[table][name].as_f64().unwrap());
                }
            }
            lines.push(line);
        }
        text = lines.join("\n") + "\n";
        std::fs::write(dir.join(spec), text).unwrap();
    }
    measured
}
