//! Helpers shared by the integration tests that drive the real binary.
// Each test crate uses a different subset of these.
#![allow(dead_code)]

pub mod browser;
pub mod calculix;
pub mod coverage;
pub mod interfaces;
pub mod memory_recorder;
pub mod pages;
pub mod peers;
pub mod pipeline;
pub mod report;
pub mod rig_emulator;
pub mod running;
pub mod slurm;
pub mod toy;
use std::path::{Path, PathBuf};
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
    on_spec(&["calibrate", "external"], spec, out, extra)
}

/// Runs `acq mesh-study --spec SPEC --out OUT` plus `extra`.
pub fn run_mesh_study(spec: &Path, out: &Path, extra: &[&str]) -> Output {
    on_spec(&["mesh-study"], spec, out, extra)
}

/// Runs `acq COMMAND --spec SPEC --out OUT` plus `extra`.
fn on_spec(command: &[&str], spec: &Path, out: &Path, extra: &[&str]) -> Output {
    let mut args = command.to_vec();
    args.extend(["--spec", path_arg(spec), "--out", path_arg(out)]);
    args.extend_from_slice(extra);
    acq(&args)
}

/// Runs a study that must succeed; its `summary.json`.
pub fn external_summary(spec: &Path, out: &Path, extra: &[&str]) -> serde_json::Value {
    let output = calibrate_external(spec, out, extra);
    assert!(output.status.success(), "{}", stderr(&output));
    // Its last line is the HTML report's path; the answer comes before:
    // the parameters, with their medians and 90 % intervals when a
    // posterior was sampled, then the chains' convergence.
    let said = String::from_utf8_lossy(&output.stdout);
    let last = said.lines().last().unwrap_or_default();
    assert!(
        last.starts_with("report: ") && last.ends_with("report.html"),
        "last line: {last}"
    );
    let answer = said
        .lines()
        .find(|line| line.starts_with("calibrated"))
        .unwrap_or_else(|| panic!("no calibrated line in:\n{said}"));
    if out.join("posterior.csv").exists() {
        assert!(
            answer.contains("posterior median [90 % interval]") && answer.contains(" .. "),
            "{answer}"
        );
        assert!(said.contains("\nconvergence: "), "{said}");
    }
    serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap()
}

/// A study with a closed form in `dir`: the model's curve is y = a x^2 on
/// x = 0.5 .. 5 (`curve.sh`, awk), the measured one 2 x^2 at the same x
/// (`test.csv`). A not-a-knot spline reproduces a parabola exactly, so at
/// every grid point the relative error is |2 - a| / 2: the curve MAPE is
/// 50 |2 - a| %. `search` is the spec's `[search]` table; returns the spec.
pub fn parabola_study(dir: &Path, search: &str) -> PathBuf {
    let mut measured = String::from("DISPLACEMENT,FORCE\n");
    for i in 1..=10 {
        let x = 0.5 * f64::from(i);
        measured.push_str(&format!("{x},{}\n", 2.0 * x * x));
    }
    std::fs::write(dir.join("test.csv"), measured).unwrap();
    std::fs::write(
        dir.join("curve.sh"),
        "awk -v a=\"$1\" 'BEGIN { print \"u_mm,f_kn\"; for (i = 1; i <= 10; i++) { x = 0.5 * i; printf \"%.17g,%.17g\\n\", x, a * x * x } }' > curve.csv\n",
    )
    .unwrap();
    let spec = dir.join("spec.toml");
    std::fs::write(
        &spec,
        format!(
            r#"command = ["sh", "curve.sh", "{{a}}"]
parallel = 1

[[parameter]]
name = "a"
lower = 1.0
upper = 3.0

[[curve]]
name = "force_displacement"
file = "curve.csv"
x = "u_mm"
y = "f_kn"
measured_file = "test.csv"
measured_x = "DISPLACEMENT"
measured_y = "FORCE"

[search]
{search}"#
        ),
    )
    .unwrap();
    spec
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

/// A candump log with every kind of frame the log formats carry: classic
/// 11- and 29-bit data (0-8 bytes), remote frames, CAN FD with bit-rate
/// switch and error state (flags with FDF, as current kernels log them),
/// an error frame, on two channels, received, sent and without a
/// direction, with microsecond times.
pub const EVERY_KIND_OF_FRAME: &str = "\
(1763719200.000100) can0 123#11223344 R
(1763719200.000250) can1 1ABCDEF0#0102030405060708 T
(1763719200.001000) can0 7FF# R
(1763719200.002000) can0 0C0#R R
(1763719200.002500) can1 18FEF100#R5 R
(1763719200.003000) can0 321##5AABBCCDDEEFF001122334455 R
(1763719200.003500) can1 1F334455##700112233445566778899AABBCCDDEEFF00112233445566778899AABBCCDDEEFF00112233445566778899AABBCCDDEEFF R
(1763719200.004000) can0 20000080#0000000000000000 R
(1763719200.005000) can1 010#DEADBEEF T
(1763719200.006000) can0 010#DEADBEEF
";

/// The Python of the peers' scratch virtualenv `name`
/// (tests/peers/venvs/NAME.txt), made by scripts/python-peers if it is not
/// ready: under cargo's `CARGO_TARGET_TMPDIR`, where scripts/test made them
/// all while the workspace compiled. The reference tools (python-can,
/// pyarrow, asammdf, ...) live there, never in acq's dependencies; without
/// them a test fails.
pub fn scratch_python(name: &str) -> PathBuf {
    peers::peer_python(root(), Path::new(env!("CARGO_TARGET_TMPDIR")), name)
}

/// A copy of a shipped session in `dir` (acq view writes its index into a
/// session; the shipped ones stay as they are).
pub fn copy_session(name: &str, dir: &Path) -> std::path::PathBuf {
    let source = root().join("fixtures/sessions").join(name);
    std::fs::create_dir_all(dir.join("rig")).unwrap();
    for (from, to) in [
        (source.clone(), dir.to_path_buf()),
        (source.join("rig"), dir.join("rig")),
    ] {
        for entry in std::fs::read_dir(&from).unwrap() {
            let entry = entry.unwrap();
            if entry.path().is_file() {
                std::fs::copy(entry.path(), to.join(entry.file_name())).unwrap();
            }
        }
    }
    dir.to_path_buf()
}

/// The published GTN search box (tensile-gtn.md); m's upper bound comes
/// from the test (800 MPa for data/tensile/P91_20_2_DF_SS.csv).
pub const GTN_BOUNDS: [(&str, f64, f64); 8] = [
    ("q1", 0.9, 1.6),
    ("q2", 0.9, 1.1),
    ("q3", 0.81, 2.56),
    ("epsN", 0.25, 0.40),
    ("sN", 0.10, 0.20),
    ("fN", 0.03, 0.09),
    ("f0", 0.0013, 0.0015),
    ("m", 0.0, 800.0),
];

/// The cells of a report's V&V 20 row for `case` and `output`: case,
/// output, S, D, E, u_num, u_num from, u_input, u_D, u_val, model error,
/// V&V 20's verdict, the posterior's.
pub fn validation_row(report: &str, case: &str, output: &str) -> Vec<String> {
    let section = report
        .split("Validation (ASME V&V 20)")
        .nth(1)
        .unwrap_or_else(|| panic!("no V&V 20 section in\n{report}"));
    let row = section
        .lines()
        .find(|l| l.starts_with(&format!("| {case} | {output} |")))
        .unwrap_or_else(|| panic!("no V&V 20 row for {case}/{output} in\n{section}"));
    row.trim_matches('|')
        .split('|')
        .map(|cell| cell.trim().to_string())
        .collect()
}
