//! The fixed interfaces of every kind of calibration run, compared with
//! the snapshots recorded before the study pipeline was put in order
//! (`fixtures/expected/interfaces/`, see `common/interfaces.rs`): each
//! preset, an external study by each method, the built-in twin through a
//! spec, and a study with a curve. The CalculiX example's runs are checked
//! in `tests/calculix.rs`, where they run anyway.
//!
//! With `ACQ_INTERFACE_RUNS=DIR` the run directories are kept in `DIR`,
//! so two builds' numbers can be compared file for file.

mod common;

use std::path::{Path, PathBuf};

use common::{acq, interfaces, parabola_study, path_arg, root, stderr};

/// Where run `name` goes: a kept directory, or one in `scratch`.
fn run_directory(scratch: &Path, name: &str) -> PathBuf {
    match std::env::var_os("ACQ_INTERFACE_RUNS") {
        Some(kept) => {
            let out = PathBuf::from(kept).join(name);
            let _ = std::fs::remove_dir_all(&out);
            std::fs::create_dir_all(out.parent().unwrap()).unwrap();
            out
        }
        None => scratch.join(name),
    }
}

fn succeed(args: &[&str]) {
    let output = acq(args);
    assert!(output.status.success(), "{args:?}: {}", stderr(&output));
}

#[test]
fn the_excavator_preset_keeps_its_interfaces() {
    let scratch = tempfile::tempdir().unwrap();
    let out = run_directory(scratch.path(), "excavator-preset");
    succeed(&[
        "calibrate",
        "excavator",
        "--case",
        "data/excavator/case1.toml",
        "--out",
        path_arg(&out),
        "--training",
        "10",
        "--test-runs",
        "5",
        "--population",
        "40",
        "--generations",
        "10",
    ]);
    interfaces::check("excavator-preset", &out, root());
}

#[test]
fn the_gtn_preset_keeps_its_interfaces() {
    let scratch = tempfile::tempdir().unwrap();
    let out = run_directory(scratch.path(), "gtn-preset");
    succeed(&[
        "calibrate",
        "gtn",
        "--test",
        "data/tensile/P91_20_2_DF_SS.csv",
        "--out",
        path_arg(&out),
        "--mesh",
        "3x15",
        "--max-evals",
        "14",
        "--target-mape",
        "0",
    ]);
    interfaces::check("gtn-preset", &out, root());
}

/// The toy solver of `fixtures/external` with `search` as its `[search]`.
fn toy_study(name: &str, search: &str) {
    let scratch = tempfile::tempdir().unwrap();
    let spec_directory = scratch.path().join("spec");
    std::fs::create_dir(&spec_directory).unwrap();
    std::fs::copy(
        root().join("fixtures/external/solver.sh"),
        spec_directory.join("solver.sh"),
    )
    .unwrap();
    let spec = std::fs::read_to_string(root().join("fixtures/external/spec.toml")).unwrap();
    let head = spec.split("[search]").next().unwrap();
    let spec_path = spec_directory.join("spec.toml");
    std::fs::write(&spec_path, format!("{head}[search]\n{search}")).unwrap();
    let out = run_directory(scratch.path(), name);
    succeed(&[
        "calibrate",
        "external",
        "--spec",
        path_arg(&spec_path),
        "--out",
        path_arg(&out),
    ]);
    interfaces::check(name, &out, &spec_directory);
}

#[test]
fn an_external_bo_study_keeps_its_interfaces() {
    toy_study(
        "external-bo",
        "start = \"lhs\"\nstart_runs = 8\nmax_evals = 14\nloss = \"mean\"\n",
    );
}

#[test]
fn an_external_surrogate_moo_study_keeps_its_interfaces() {
    toy_study(
        "external-moo",
        "method = \"surrogate-moo\"\ntraining_runs = 8\ntest_runs = 4\npopulation = 20\ngenerations = 10\n",
    );
}

#[test]
fn an_external_least_squares_study_keeps_its_interfaces() {
    toy_study(
        "external-least-squares",
        "method = \"least-squares\"\nmax_evals = 12\n",
    );
}

#[test]
fn the_built_in_twin_through_a_spec_keeps_its_interfaces() {
    // Two cases with measured pressures, one to validate, and a geometry
    // number calibrated (so the run leaves geometry.toml).
    let scratch = tempfile::tempdir().unwrap();
    let spec_directory = scratch.path().join("spec");
    std::fs::create_dir(&spec_directory).unwrap();
    let spec = r#"model = "excavator"

[[parameter]]
name = "bucket.mass_kg"
lower = 100.0
upper = 250.0

[[parameter]]
name = "force_angle_deg"
case = "case1"
lower = -15.0
upper = -5.0

[search]
method = "least-squares"
max_evals = 20

[[case]]
name = "case1"
inputs = { bucket_stroke_mm = 121.0, arm_stroke_mm = 210.0, boom_stroke_mm = 467.0, force_kN = 40.6 }
measured = { "pressure_bar.bucket" = 70.0, "pressure_bar.arm" = 98.0, "pressure_bar.boom" = 85.0 }

[[case]]
name = "raised"
role = "validate"
inputs = { bucket_stroke_mm = 250.0, arm_stroke_mm = 120.0, boom_stroke_mm = 600.0, force_angle_deg = -20.0, force_kN = 40.6 }
measured = { "pressure_bar.boom" = 90.0 }
"#;
    let spec_path = spec_directory.join("twin.toml");
    std::fs::write(&spec_path, spec).unwrap();
    let out = run_directory(scratch.path(), "external-excavator");
    succeed(&[
        "calibrate",
        "external",
        "--spec",
        path_arg(&spec_path),
        "--out",
        path_arg(&out),
    ]);
    interfaces::check("external-excavator", &out, &spec_directory);
}

#[test]
fn an_external_study_of_a_curve_keeps_its_interfaces() {
    // common::parabola_study: y = a x^2 against a measured 2 x^2.
    let scratch = tempfile::tempdir().unwrap();
    let spec_directory = scratch.path().join("spec");
    std::fs::create_dir(&spec_directory).unwrap();
    let spec_path = parabola_study(
        &spec_directory,
        "start_runs = 4\nmax_evals = 8\ntarget_loss_pct = 0\n",
    );
    let out = run_directory(scratch.path(), "external-curve");
    succeed(&[
        "calibrate",
        "external",
        "--spec",
        path_arg(&spec_path),
        "--out",
        path_arg(&out),
    ]);
    interfaces::check("external-curve", &out, &spec_directory);
}
