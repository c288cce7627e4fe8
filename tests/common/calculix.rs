//! The worked example `examples/calculix-tensile` prepared for a test: a
//! coarse mesh and a synthetic measurement made there (tests/calculix.rs
//! runs it locally, tests/slurm.rs on a real Slurm cluster).

use std::path::{Path, PathBuf};

use serde_json::Value;

use super::{number, root, stderr};

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

/// The tensile study's method (BO of the curve MAPE) found the truth.
pub fn assert_bo_recovers_the_truth(summary: &Value) {
    // The curve has about 50 points with 0.5 % independent noise, so the
    // noise moves the best fit by about 0.5 / sqrt(50) = 0.07 % of the
    // force: tenths of a percent of K and n. Global BO steps alone are
    // limited by the 24-run budget on a 600 MPa x 0.2 box (within 2 % of K
    // and 5 % of n); the local steps, on by default, get to the noise's
    // limit within it, so these bounds are that limit with room: 0.5 % of K
    // and 1 % of n.
    let k = number(summary, &["best_params", "K_mpa"]);
    let n = number(summary, &["best_params", "n"]);
    assert!((k - TRUE_K_MPA).abs() < 0.005 * TRUE_K_MPA, "K = {k} MPa");
    assert!((n - TRUE_N).abs() < 0.01 * TRUE_N, "n = {n}");
    assert_eq!(number(summary, &["failed"]), 0.0);
}

/// The excavator study's method (GP + NSGA-II + TOPSIS on two scalars)
/// found the truth within its own stated uncertainty (`out` is its run
/// directory, with `identifiability.json`).
pub fn assert_moo_recovers_the_truth(summary: &Value, out: &Path) {
    // Two noisy scalars for two parameters: the answer moves with the
    // noise, as far as the study's own identifiability analysis says. The
    // truth must lie within its 99.7 % region (Mahalanobis distance with
    // the reported correlation, chi-square of 2 degrees of freedom: 11.8),
    // and the parameters within a plain 10 % / 25 % of it whatever the
    // analysis says.
    let k = number(summary, &["optimal", "K_mpa"]);
    let n = number(summary, &["optimal", "n"]);
    let identified: Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("identifiability.json")).unwrap())
            .unwrap();
    let sigma_k = number(&identified, &["standard_uncertainty", "K_mpa"]);
    let sigma_n = number(&identified, &["standard_uncertainty", "n"]);
    let rho = number(&identified, &["correlation", "K_mpa", "n"]);
    let (a, b) = ((k - TRUE_K_MPA) / sigma_k, (n - TRUE_N) / sigma_n);
    let distance_squared = (a * a - 2.0 * rho * a * b + b * b) / (1.0 - rho * rho);
    assert!(
        distance_squared < 11.8,
        "K = {k} +- {sigma_k}, n = {n} +- {sigma_n}, rho {rho}: d^2 = {distance_squared}"
    );
    assert!((k - TRUE_K_MPA).abs() < 0.10 * TRUE_K_MPA, "K = {k} MPa");
    assert!((n - TRUE_N).abs() < 0.25 * TRUE_N, "n = {n}");
    // The two measured values are met within their uncertainties.
    assert!(
        number(summary, &["chi_square", "value"]) < 9.0,
        "{summary:#}"
    );
}
