//! `acq mesh-study --spec SPEC --out DIR` on a solver whose outputs have
//! closed forms: a power law `phi0 + a h^p` (its order, extrapolated value
//! and GCI are known exactly), values that oscillate and values that
//! diverge as the elements shrink (named, with no silent number), the
//! least-squares form over more than three sizes, and a calibration of the
//! same spec, which runs at one size; and the built-in excavator twin,
//! whose frames' element length is the size, against a finer run kept out.
//!
//! Tolerances: the solver prints 17 significant digits, so the values are
//! exact to 1e-16; the order comes from differences of values about 1e-2
//! apart, which keeps about 13 digits: 1e-9 relative leaves a margin of
//! ten thousand.

mod common;

use std::path::{Path, PathBuf};

use common::{acq, path_arg, stderr};
use serde_json::Value;

/// kind 1: `1.5 + 0.3 h^1.8`; kind 2: 5.0, 5.2, 4.6 at h = 0.1, 0.2,
/// 0.4 (oscillating); kind 3: `3 + 1/h` (growing as h shrinks). The
/// parameter `k` scales nothing: the study runs at its nominal value.
const SOLVER: &str = r#"awk -v h="$1" -v kind="$2" -v k="$3" 'BEGIN {
  if (kind == 1) phi = 1.5 + 0.3 * h ^ 1.8;
  if (kind == 2) { if (h < 0.15) phi = 5.0; else if (h < 0.3) phi = 5.2; else phi = 4.6 }
  if (kind == 3) phi = 3 + 1 / h;
  printf "{\"phi\": %.17g, \"k_seen\": %.17g}\n", phi, k
}' > out.json
"#;

fn spec(dir: &Path, sizes: &str, command_mesh: &str) -> PathBuf {
    std::fs::write(dir.join("solver.sh"), SOLVER).unwrap();
    let spec = dir.join("spec.toml");
    std::fs::write(
        &spec,
        format!(
            r#"command = ["sh", "solver.sh", "{command_mesh}", "{{kind}}", "{{k}}"]
output_file = "out.json"
parallel = 2

[[parameter]]
name = "k"
lower = 1.0
upper = 3.0

[[case]]
name = "power"
inputs = {{ kind = 1 }}
measured = {{ phi = 1.5 }}

[[case]]
name = "oscillating"
inputs = {{ kind = 2 }}
measured = {{ phi = 5.0 }}

[[case]]
name = "diverging"
inputs = {{ kind = 3 }}
measured = {{ phi = 3.0 }}

[search]
start_runs = 3
max_evals = 3

[mesh_study]
sizes = {sizes}
"#
        ),
    )
    .unwrap();
    spec
}

fn mesh_study(spec: &Path, out: &Path) -> Value {
    let run = common::run_mesh_study(spec, out, &[]);
    assert!(run.status.success(), "{}", stderr(&run));
    let text = std::fs::read_to_string(out.join("summary.json")).unwrap();
    serde_json::from_str(&text).unwrap()
}

fn close(ours: f64, exact: f64) -> bool {
    (ours - exact).abs() <= 1e-9 * exact.abs().max(1e-300)
}

#[test]
fn a_power_law_gives_its_order_limit_and_gci_and_other_behaviour_is_named() {
    let dir = tempfile::tempdir().unwrap();
    let summary = mesh_study(
        &spec(dir.path(), "[0.4, 0.2, 0.1]", "{mesh}"),
        &dir.path().join("run"),
    );
    let study = &summary["mesh_study"];
    let power = &study["power/phi"];
    for key in [
        "sizes",
        "values",
        "order",
        "extrapolated",
        "e_a_pct",
        "e_ext_pct",
        "gci_fine_pct",
        "convergence",
    ] {
        assert!(power.get(key).is_some(), "no {key} in {power}");
    }
    assert_eq!(
        power["sizes"],
        serde_json::json!([0.4, 0.2, 0.1]),
        "the spec's order"
    );
    assert_eq!(power["convergence"], "monotonic");
    let phi = |h: f64| 1.5 + 0.3 * h.powf(1.8);
    let number = |v: &Value| v.as_f64().unwrap();
    assert!(close(number(&power["order"]), 1.8), "{power}");
    assert!(close(number(&power["extrapolated"]), 1.5), "{power}");
    // Closed forms: e_a = |phi(0.1) - phi(0.2)| / phi(0.1); the GCI
    // 1.25 e_a / (2^1.8 - 1) = 1.25 * 0.3 * 0.1^1.8 / phi(0.1); e_ext
    // = 0.3 * 0.1^1.8 / 1.5.
    let e_a = 100.0 * (phi(0.2) - phi(0.1)) / phi(0.1);
    assert!(close(number(&power["e_a_pct"]), e_a));
    assert!(close(
        number(&power["gci_fine_pct"]),
        125.0 * 0.3 * 0.1f64.powf(1.8) / phi(0.1)
    ));
    assert!(close(
        number(&power["e_ext_pct"]),
        100.0 * 0.3 * 0.1f64.powf(1.8) / 1.5
    ));

    assert_eq!(study["oscillating/phi"]["convergence"], "oscillatory");
    let diverging = &study["diverging/phi"];
    assert_eq!(diverging["convergence"], "divergent");
    for key in ["order", "extrapolated", "gci_fine_pct"] {
        assert!(
            diverging[key].is_null(),
            "a divergent study has no {key}: {diverging}"
        );
    }
    assert!(diverging["note"].as_str().unwrap().contains("diverge"));
    // The runs were at the parameter's nominal value, the middle of 1..3.
    assert_eq!(summary["at"]["k"], 2.0);
    let report = std::fs::read_to_string(dir.path().join("run/report.md")).unwrap();
    assert!(
        report.contains("mesh_study_1.svg") && dir.path().join("run/mesh_study_1.svg").exists()
    );
    // The HTML report, as every run writes it: the table and the plots in it.
    let html = std::fs::read_to_string(dir.path().join("run/report.html")).unwrap();
    assert!(
        html.contains("<table>") && html.contains("<svg") && html.contains("oscillatory"),
        "{html}"
    );
}

#[test]
fn more_sizes_are_fitted_by_least_squares_to_the_same_closed_form() {
    let dir = tempfile::tempdir().unwrap();
    let summary = mesh_study(
        &spec(dir.path(), "[0.5, 0.35, 0.25, 0.18, 0.12]", "{mesh}"),
        &dir.path().join("run"),
    );
    let power = &summary["mesh_study"]["power/phi"];
    assert_eq!(power["convergence"], "monotonic");
    // The fit is exact on exact data, found by a one-dimensional search
    // over the order: 1e-6.
    assert!(
        (power["order"].as_f64().unwrap() - 1.8).abs() < 1e-6,
        "{power}"
    );
    assert!(
        (power["extrapolated"].as_f64().unwrap() - 1.5).abs() < 1e-9,
        "{power}"
    );
    assert!(power["note"].as_str().unwrap().contains("least squares"));
}

#[test]
fn a_spec_without_mesh_where_it_needs_it_is_refused_with_what_to_add() {
    let dir = tempfile::tempdir().unwrap();
    let without = spec(dir.path(), "[0.4, 0.2, 0.1]", "0.1");
    let run = acq(&[
        "mesh-study",
        "--spec",
        path_arg(&without),
        "--out",
        path_arg(&dir.path().join("a")),
    ]);
    assert_eq!(run.status.code(), Some(2));
    assert!(
        stderr(&run).contains("needs {mesh} in the command"),
        "{}",
        stderr(&run)
    );
    let two = spec(dir.path(), "[0.4, 0.2]", "{mesh}");
    let run = acq(&[
        "mesh-study",
        "--spec",
        path_arg(&two),
        "--out",
        path_arg(&dir.path().join("b")),
    ]);
    assert_eq!(run.status.code(), Some(2));
    assert!(stderr(&run).contains("at least three"), "{}", stderr(&run));
}

#[test]
fn a_calibration_of_the_spec_runs_every_case_at_the_smallest_size() {
    let dir = tempfile::tempdir().unwrap();
    let spec = spec(dir.path(), "[0.4, 0.2, 0.1]", "{mesh}");
    let out = dir.path().join("calibration");
    let run = common::calibrate_external(&spec, &out, &[]);
    assert!(run.status.success(), "{}", stderr(&run));
    let runs: Vec<_> = std::fs::read_dir(out.join("runs"))
        .unwrap()
        .flatten()
        .collect();
    assert!(!runs.is_empty());
    for run in runs {
        let params: Value =
            serde_json::from_str(&std::fs::read_to_string(run.path().join("params.json")).unwrap())
                .unwrap();
        assert_eq!(params["mesh"], 0.1, "{params}");
    }
}

/// The spring of examples/validation with a discretisation error of
/// `2 % (h / 0.1)^2` on both deflections: at the finest size 0.1 the error
/// is 2 % of the exact value, which is what Richardson extrapolation finds
/// and what u_num (the GCI without its safety factor) is.
const SPRING_WITH_MESH: &str = r#"awk -v k="$1" -v d="$2" -v f1="$3" -v f2="$4" -v s="$5" -v h="$6" 'BEGIN {
    e = 1 + 0.02 * (h / 0.1) ^ 2
    printf "{\"u_low_mm\": %.17g, \"u_high_mm\": %.17g}\n", (f1 / k + d + s * f1 * f1) * e, (f2 / k + d + s * f2 * f2) * e
}' > out.json
"#;

#[test]
fn a_validation_takes_u_num_from_the_mesh_study_of_its_own_spec() {
    let dir = tempfile::tempdir().unwrap();
    let example = common::root().join("examples/validation/spec.toml");
    let text = std::fs::read_to_string(example).unwrap();
    let text = text
        .replace(
            r#"command = ["sh", "spring.sh", "{k_kn_per_mm}", "{offset_mm}", "{f_low_kn}", "{f_high_kn}", "{softening_per_kn}"]"#,
            r#"command = ["sh", "spring_mesh.sh", "{k_kn_per_mm}", "{offset_mm}", "{f_low_kn}", "{f_high_kn}", "{softening_per_kn}", "{mesh}"]"#,
        )
        .replace(r#"copy_files = ["spring.sh"]"#, r#"copy_files = ["spring_mesh.sh"]"#);
    assert!(
        text.contains("spring_mesh.sh\", \"{k_kn"),
        "the example's command changed"
    );
    std::fs::write(dir.path().join("spring_mesh.sh"), SPRING_WITH_MESH).unwrap();
    let spec = dir.path().join("spec.toml");
    std::fs::write(
        &spec,
        format!("{text}\n[mesh_study]\nsizes = [0.4, 0.2, 0.1]\nat = {{ k_kn_per_mm = 2.0 }}\n"),
    )
    .unwrap();
    let summary = mesh_study(&spec, &dir.path().join("mesh"));
    let c_low = &summary["mesh_study"]["C/u_low_mm"];
    assert_eq!(c_low["convergence"], "monotonic");
    // At k = 2, the offset's nominal 0 and case C's inputs: exact
    // 20 / 2 + 0.1 + 0.002 * 400 = 10.9 mm, and 2 % of it at h = 0.1.
    let u_num = c_low["u_num"].as_f64().unwrap();
    assert!(close(u_num, 0.02 * 10.9), "{c_low}");
    assert!(
        close(c_low["extrapolated"].as_f64().unwrap(), 10.9),
        "{c_low}"
    );

    // The validation names the mesh study; its V&V 20 table takes that u_num.
    // The example states its u_num by hand; the mesh study replaces it.
    let typed = "numerical_uncertainty = { u_low_mm = 0.005, u_high_mm = 0.01 }";
    let text = std::fs::read_to_string(&spec).unwrap();
    assert!(text.contains(typed), "the example's u_num line changed");
    let with_posterior = text
        .replace(typed, "")
        .replace("[posterior]\n", "[posterior]\nmesh_study = \"mesh\"\n");
    std::fs::write(&spec, with_posterior).unwrap();
    let out = dir.path().join("calibration");
    let run = common::calibrate_external(&spec, &out, &[]);
    assert!(run.status.success(), "{}", stderr(&run));
    let report = std::fs::read_to_string(out.join("report.md")).unwrap();
    let cells = common::validation_row(&report, "C", "u_low_mm");
    assert_eq!(cells[5], "0.2180", "u_num 0.218 mm: {cells:?}");
    assert!(cells[6].contains("mesh study"), "{cells:?}");
}

/// A curve `y = (1 + x)(1 + 0.3 h^1.8)` on x = 0 .. 2: the mean over any
/// part of x is `(1 + x_mid)(1 + 0.3 h^1.8)`, so every part has order 1.8
/// and extrapolates to `1 + x_mid` (the interpolant is linear between
/// nodes, so the part means are exact).
#[test]
fn a_curve_is_compared_part_by_part_and_each_part_has_its_closed_form() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("solver.sh"),
        r#"awk -v h="$1" 'BEGIN {
  e = 1 + 0.3 * h ^ 1.8
  printf "{\"phi\": %.17g}\n", 1.5 * e > "out.json"
  print "x,y" > "curve.csv"
  for (i = 0; i <= 40; i++) { x = i / 20; printf "%.17g,%.17g\n", x, (1 + x) * e > "curve.csv" }
}'
"#,
    )
    .unwrap();
    std::fs::write(dir.path().join("measured.csv"), "x,y\n0,1\n1,2\n2,3\n").unwrap();
    let spec = dir.path().join("spec.toml");
    std::fs::write(
        &spec,
        r#"command = ["sh", "solver.sh", "{mesh}", "{k}"]
output_file = "out.json"

[[parameter]]
name = "k"
lower = 1.0
upper = 3.0

[[output]]
name = "phi"
measured = 1.5

[[curve]]
name = "line"
file = "curve.csv"
x = "x"
y = "y"
measured_file = "measured.csv"
measured_x = "x"
measured_y = "y"

[search]
start_runs = 3
max_evals = 3

[mesh_study]
sizes = [0.4, 0.2, 0.1]
"#,
    )
    .unwrap();
    let out = dir.path().join("mesh");
    let summary = mesh_study(&spec, &out);
    let parts = summary["mesh_study_curves"]["line"]["parts"]
        .as_array()
        .unwrap_or_else(|| panic!("{summary:#}"));
    assert_eq!(parts.len(), 10);
    let mut previous_to = 0.0;
    for part in parts {
        let (from, to) = (
            part["x_from"].as_f64().unwrap(),
            part["x_to"].as_f64().unwrap(),
        );
        assert!((from - previous_to).abs() < 1e-12 && to > from, "{part}");
        previous_to = to;
        assert_eq!(part["convergence"], "monotonic", "{part}");
        assert!(close(part["order"].as_f64().unwrap(), 1.8), "{part}");
        let exact = 1.0 + 0.5 * (from + to);
        assert!(
            close(part["extrapolated"].as_f64().unwrap(), exact),
            "{part}"
        );
    }
    assert!((previous_to - 2.0).abs() < 1e-12);
    let report = std::fs::read_to_string(out.join("report.md")).unwrap();
    assert!(report.contains("## Curve line, part by part"), "{report}");
    assert!(out.join("mesh_study_curve_1.svg").exists());
}

/// The excavator twin's gauge stress at Case 1's nominal pose (the strokes
/// 121, 210, 467 mm, 40.6 kN at -10 deg) with the shipped geometry,
/// its frames' elements at most `element_length_m` long, through
/// `acq twin excavator`.
fn excavator_gauge_stress_mpa(dir: &Path, element_length_m: f64, gauge: usize) -> f64 {
    let shipped = std::fs::read_to_string(common::root().join("data/excavator/dx55.toml")).unwrap();
    assert_eq!(shipped.matches("element_length_m = 0.15\n").count(), 2);
    let geometry = dir.join(format!("geometry-{element_length_m}.toml"));
    std::fs::write(
        &geometry,
        shipped.replace(
            "element_length_m = 0.15\n",
            &format!("element_length_m = {element_length_m:?}\n"),
        ),
    )
    .unwrap();
    let case = common::root().join("data/excavator/case1.toml");
    let run = acq(&[
        "twin",
        "excavator",
        "--case",
        path_arg(&case),
        "--geometry",
        path_arg(&geometry),
        "--json",
    ]);
    assert!(run.status.success(), "{}", stderr(&run));
    let value: Value = serde_json::from_slice(&run.stdout).unwrap();
    value["gauge_stress_MPa"][gauge].as_f64().unwrap()
}

#[test]
fn the_excavator_frames_element_length_is_a_mesh_study_checked_by_a_finer_run() {
    // The frames are beams whose own weight is lumped at their nodes, so
    // the gauge stresses converge as the elements shrink (first order).
    // Checked against a run kept out of the study, elements 8 times finer
    // than its finest: it lies inside the finest size's GCI band, and
    // nearer the extrapolated value than the finest size's.
    let dir = tempfile::tempdir().unwrap();
    let spec = dir.path().join("spec.toml");
    std::fs::write(
        &spec,
        r#"model = "excavator"

[[parameter]]
name = "force_kN"
lower = 30.0
upper = 50.0

[[case]]
name = "case1"
inputs = { bucket_stroke_mm = 121.0, arm_stroke_mm = 210.0, boom_stroke_mm = 467.0, force_angle_deg = -10.0 }
measured = { "gauge_stress_MPa[0]" = -5.0, "gauge_stress_MPa[14]" = -21.0, "pressure_bar.boom" = 57.0 }

[mesh_study]
sizes = [0.3, 0.15, 0.075]
at = { force_kN = 40.6 }
"#,
    )
    .unwrap();
    let summary = mesh_study(&spec, &dir.path().join("mesh"));
    for (gauge, key) in [
        (0, "case1/gauge_stress_MPa[0]"),
        (14, "case1/gauge_stress_MPa[14]"),
    ] {
        let entry = &summary["mesh_study"][key];
        assert_eq!(entry["convergence"], "monotonic", "{key}: {entry}");
        let values: Vec<f64> = entry["values"]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_f64().unwrap())
            .collect();
        let finest = values[2];
        // The study ran what the twin's own command gives at that size.
        let same = excavator_gauge_stress_mpa(dir.path(), 0.075, gauge);
        assert!(
            (same - finest).abs() < 1e-9 * finest.abs(),
            "{key}: {same} vs {finest}"
        );
        let kept_out = excavator_gauge_stress_mpa(dir.path(), 0.009375, gauge);
        let band = entry["gci_fine_pct"].as_f64().unwrap() / 100.0 * finest.abs();
        let extrapolated = entry["extrapolated"].as_f64().unwrap();
        assert!(
            (kept_out - finest).abs() <= band,
            "{key}: 0.009375 m gives {kept_out}, outside {finest} +- {band}"
        );
        assert!(
            (kept_out - extrapolated).abs() < (kept_out - finest).abs(),
            "{key}: extrapolated {extrapolated}, finest {finest}, finer run {kept_out}"
        );
    }
    assert_eq!(
        summary["mesh_study"]["case1/pressure_bar.boom"]["convergence"],
        "monotonic"
    );
}

/// The published Dataset 1 test and its parameters (reference table).
const DATASET_1: &str = "data/tensile/P91_20_2_DF_SS.csv";
const PUBLISHED_DATASET_1: [(&str, f64); 8] = [
    ("q1", 1.332),
    ("q2", 0.9952),
    ("q3", 2.295),
    ("epsN", 0.29),
    ("sN", 0.1671),
    ("fN", 0.03869),
    ("f0", 0.00137),
    ("m", 534.1),
];

/// A spec of the built-in GTN twin set up from Dataset 1: `parameters`
/// ([[parameter]] tables), the case's inputs (the published values of
/// the rest, and `extra_inputs`), its `measured` table and `tail`.
fn gtn_spec(
    dir: &Path,
    parameters: &str,
    extra_inputs: &str,
    measured: &str,
    tail: &str,
) -> PathBuf {
    let test = common::root().join(DATASET_1);
    let mut inputs: Vec<String> = PUBLISHED_DATASET_1
        .iter()
        .filter(|(name, _)| !parameters.contains(&format!("name = \"{name}\"")))
        .map(|(name, value)| format!("{name} = {value}"))
        .collect();
    inputs.extend(
        extra_inputs
            .split(',')
            .map(str::trim)
            .filter(|s| !s.is_empty())
            .map(String::from),
    );
    let spec = dir.join("gtn.toml");
    std::fs::write(
        &spec,
        format!(
            "model = \"gtn\"\ntest = {test:?}\n\n{parameters}\n[[case]]\nname = \"dataset1\"\ninputs = {{ {} }}\nmeasured = {{ {measured} }}\n\n{tail}",
            inputs.join(", ")
        ),
    )
    .unwrap();
    spec
}

/// `acq mesh-study` of the built-in GTN twin: the same runs as `acq twin
/// gtn --convergence` (the numbers agree to 1e-12: one twin, two ways in),
/// logged and resumed like a solver's. With coalescence the bar breaks,
/// and where it breaks is an output of its own.
#[test]
fn the_gtn_twin_in_a_spec_runs_its_mesh_study_through_the_study_and_resumes() {
    let dir = tempfile::tempdir().unwrap();
    let spec = gtn_spec(
        dir.path(),
        "[[parameter]]\nname = \"q1\"\nlower = 0.9\nupper = 1.6\nnominal = 1.332\n",
        "fc = 0.02, fF = 0.15",
        &format!(
            "force_displacement = {{ file = {:?}, x = \"DISPLACEMENT\", y = \"FORCE\" }}, max_force_kn = 7.4, displacement_at_max_force_mm = 1.25, fracture_mm = 2.0",
            common::root().join(DATASET_1)
        ),
        "[mesh_study]\nsizes = [0.8, 0.5, 0.3]\n",
    );
    let out = dir.path().join("mesh");
    let summary = mesh_study(&spec, &out);
    let published: Vec<String> = PUBLISHED_DATASET_1
        .iter()
        .map(|(name, value)| format!("{name}={value}"))
        .collect();
    let twin_out = dir.path().join("twin");
    let twin = acq(&[
        "twin",
        "gtn",
        "--test",
        DATASET_1,
        "--param",
        &format!("{},fc=0.02,fF=0.15", published.join(",")),
        "--convergence",
        "0.8,0.5,0.3",
        "--out",
        path_arg(&twin_out),
    ]);
    assert!(twin.status.success(), "{}", stderr(&twin));
    let by_twin: Value =
        serde_json::from_str(&std::fs::read_to_string(twin_out.join("summary.json")).unwrap())
            .unwrap();
    for (ours, theirs) in [
        ("dataset1/max_force_kn", "max_force_kn"),
        ("dataset1/fracture_mm", "fracture_mm"),
    ] {
        let values = |summary: &Value, key: &str| -> Vec<f64> {
            summary["mesh_study"][key]["values"]
                .as_array()
                .unwrap_or_else(|| panic!("{key}: {summary}"))
                .iter()
                .map(|v| v.as_f64().unwrap())
                .collect()
        };
        let (a, b) = (values(&summary, ours), values(&by_twin, theirs));
        assert_eq!(a.len(), 3);
        for (x, y) in a.iter().zip(&b) {
            assert!((x - y).abs() <= 1e-12 * y.abs(), "{ours}: {a:?} vs {b:?}");
        }
    }
    // The peak's displacement lies between the output points around it
    // (0.01 mm apart), near the test's maximum at 1.32 mm.
    let peak = &summary["mesh_study"]["dataset1/displacement_at_max_force_mm"]["values"];
    for value in peak.as_array().unwrap() {
        let mm = value.as_f64().unwrap();
        assert!((1.0..1.5).contains(&mm), "{peak}");
    }
    assert!(
        summary["mesh_study_curves"]["dataset1/force_displacement"]["parts"]
            .as_array()
            .is_some_and(|parts| parts.len() > 2),
        "{summary}"
    );
    // The report's numbers keep four significant figures however small
    // (the force's u_num is about 2e-4 kN), and the plots name the unit.
    let report = std::fs::read_to_string(out.join("report.md")).unwrap();
    let row = report
        .lines()
        .find(|l| l.starts_with("| dataset1/max_force_kn |"))
        .unwrap_or_else(|| panic!("{report}"));
    let printed: f64 = row
        .trim_end_matches(" |")
        .rsplit("| ")
        .next()
        .unwrap()
        .parse()
        .unwrap();
    let u_num = summary["mesh_study"]["dataset1/max_force_kn"]["u_num"]
        .as_f64()
        .unwrap();
    assert!((printed - u_num).abs() <= 5e-4 * u_num, "{row} vs {u_num}");
    let plot = std::fs::read_to_string(out.join("mesh_study_1.svg")).unwrap();
    assert!(plot.contains("element size [mm]"), "{plot}");
    // Resumed: every run comes from the log, and the study is the same.
    let again = common::run_mesh_study(&spec, &out, &["--resume"]);
    assert!(again.status.success(), "{}", stderr(&again));
    assert!(
        stderr(&again).contains("3 from the log"),
        "{}",
        stderr(&again)
    );
    let resumed: Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    assert_eq!(resumed["mesh_study"], summary["mesh_study"]);
}

/// `acq calibrate external` on the built-in GTN twin: a curve the twin
/// made at fN = 0.06 (0.8 mm elements, the others published) is found
/// again from the published box, to 0.001 (the box is 0.06 wide).
#[test]
fn the_gtn_twin_in_a_spec_is_calibrated_like_a_solver() {
    let dir = tempfile::tempdir().unwrap();
    let measured = dir.path().join("synthetic.csv");
    let published: Vec<String> = PUBLISHED_DATASET_1
        .iter()
        .map(|(name, value)| match *name {
            "fN" => "fN=0.06".to_string(),
            _ => format!("{name}={value}"),
        })
        .collect();
    let made = acq(&[
        "twin",
        "gtn",
        "--test",
        DATASET_1,
        "--param",
        &published.join(","),
        "--element-mm",
        "0.8",
        "-o",
        path_arg(&measured),
    ]);
    assert!(made.status.success(), "{}", stderr(&made));
    let spec = gtn_spec(
        dir.path(),
        "[[parameter]]\nname = \"fN\"\nlower = 0.03\nupper = 0.09\n",
        "mesh = 0.8",
        "force_displacement = { file = \"synthetic.csv\", x = \"DISPLACEMENT\", y = \"FORCE\" }",
        "[search]\nmethod = \"bo\"\nstart_runs = 4\nmax_evals = 12\n",
    );
    let summary = common::external_summary(&spec, &dir.path().join("run"), &[]);
    let found = summary["best_params"]["fN"].as_f64().unwrap();
    assert!((found - 0.06).abs() < 1e-3, "{summary}");
}

/// What belongs to `model = "gtn"` is refused elsewhere, and what it needs
/// is asked for.
#[test]
fn a_gtn_spec_says_what_it_needs() {
    let dir = tempfile::tempdir().unwrap();
    for (text, expected) in [
        ("model = \"gtn\"\n", "needs test = "),
        (
            "test = \"t.csv\"\ncommand = [\"true\"]\n",
            "test belongs to model = \"gtn\"",
        ),
        (
            "model = \"gtn\"\ntest = \"t.csv\"\ncommand = [\"true\"]\n",
            "leave out command",
        ),
    ] {
        let spec = dir.path().join("spec.toml");
        std::fs::write(
            &spec,
            format!("{text}\n[[parameter]]\nname = \"q1\"\nlower = 1\nupper = 2\n\n[[output]]\nname = \"max_force_kn\"\nmeasured = 7.4\n"),
        )
        .unwrap();
        let run = common::calibrate_external(&spec, &dir.path().join("run"), &[]);
        assert_eq!(run.status.code(), Some(2), "{text}: {}", stderr(&run));
        assert!(stderr(&run).contains(expected), "{text}: {}", stderr(&run));
    }
    // The shipped example with a misspelt output (kN for kn) and a value
    // out of its physical range: each refused before any run, naming the
    // case and what the twin takes (the rest of the example must load for
    // the refusal to reach them).
    // The example's paths are relative to it: here they are made absolute.
    let data = common::root().join("data/tensile");
    let shipped = std::fs::read_to_string(common::root().join("examples/gtn-mesh/spec.toml"))
        .unwrap()
        .replace("../../data/tensile", data.to_str().unwrap());
    let at_line = shipped
        .lines()
        .find(|l| l.starts_with("at = "))
        .unwrap()
        .to_string();
    for (edits, expected) in [
        (
            vec![("max_force_kn = 7.43", "max_force_kN = 7.43")],
            "case dataset1: the GTN twin gives no scalar \"max_force_kN\"; it gives max_force_kn",
        ),
        // fN's nominal (the middle of its box) a volume fraction above 1,
        // refused before its first run.
        (
            vec![
                ("lower = 0.03\nupper = 0.09", "lower = 1.5\nupper = 2.0"),
                (at_line.as_str(), ""),
            ],
            "case dataset1: nucleated void volume fraction fN must be finite, >= 0 and below 1, got 1.75",
        ),
    ] {
        let mut text = shipped.clone();
        for (from, to) in edits {
            assert!(text.contains(from), "{from}");
            text = text.replacen(from, to, 1);
        }
        let spec = dir.path().join("example.toml");
        std::fs::write(&spec, text).unwrap();
        let out = dir.path().join("refused");
        let run = common::run_mesh_study(&spec, &out, &[]);
        assert_eq!(run.status.code(), Some(2), "{}", stderr(&run));
        assert!(stderr(&run).contains(expected), "{}", stderr(&run));
        assert!(!out.exists(), "a refused spec leaves no run directory");
    }
}

/// Careless input, round four: a mesh study that cannot say anything is
/// refused. Sizes at which every run fails (1e308: the solver's value
/// overflows to `inf`) end with exit 2, naming how many runs gave a value,
/// where an all-null summary came with exit 0; a `calibrate_at` that is
/// none of the sizes (no u_num there), more sizes than runs are worth, and
/// an `--out` that holds the spec are refused before any run.
#[test]
fn a_mesh_study_that_can_say_nothing_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let overflowing = spec(dir.path(), "[1e308, 1e307, 1e306]", "{mesh}");
    let run = common::run_mesh_study(&overflowing, &dir.path().join("overflow"), &[]);
    assert_eq!(run.status.code(), Some(2), "{}", stderr(&run));
    assert!(
        stderr(&run).contains("0 of 3 runs gave a value"),
        "{}",
        stderr(&run)
    );

    let refused = |sizes: &str, extra: &str, out: &Path, expected: &str| {
        let spec = spec(dir.path(), sizes, "{mesh}");
        let text = std::fs::read_to_string(&spec).unwrap() + extra;
        std::fs::write(&spec, text).unwrap();
        let run = common::run_mesh_study(&spec, out, &[]);
        assert_eq!(
            run.status.code(),
            Some(2),
            "{sizes} {extra}: {}",
            stderr(&run)
        );
        assert!(
            stderr(&run).contains(expected),
            "{sizes} {extra}: {}",
            stderr(&run)
        );
        assert!(!out.join("evaluations.csv").exists(), "no run");
    };
    refused(
        "[0.4, 0.2, 0.1]",
        "calibrate_at = 0.3\n",
        &dir.path().join("between"),
        "calibrate_at = 0.3 is none of the sizes",
    );
    let many: Vec<String> = (1..=21).map(|i| format!("{}", 0.01 * i as f64)).collect();
    refused(
        &format!("[{}]", many.join(", ")),
        "",
        &dir.path().join("many"),
        "21 sizes: give at most 20",
    );
    refused("[0.4, 0.2, 0.1]", "", dir.path(), "it holds the spec");
}
