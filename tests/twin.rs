//! `acq twin excavator`, `acq twin gtn` and `acq sensitivity excavator` from the outside,
//! exactly as their documented interfaces fix them.

mod common;

use common::{acq, stderr, stdout};

#[test]
fn twin_json_has_the_fixed_shape_and_reproduces_the_pose() {
    let output = acq(&[
        "twin",
        "excavator",
        "--case",
        "data/excavator/case1.toml",
        "--json",
    ]);
    assert!(output.status.success(), "{}", stderr(&output));
    let value: serde_json::Value = serde_json::from_str(&stdout(&output)).unwrap();
    let keys: Vec<&str> = value
        .as_object()
        .unwrap()
        .keys()
        .map(|k| k.as_str())
        .collect();
    assert_eq!(
        keys,
        [
            "cylinder_force_kN",
            "gauge_stress_MPa",
            "max_von_mises_MPa",
            "points",
            "pressure_bar"
        ]
    );
    for point in ["A", "B", "G", "J"] {
        assert_eq!(value["points"][point].as_array().unwrap().len(), 2);
    }
    let b = &value["points"]["B"];
    assert!(
        (b[0].as_f64().unwrap() - 2.937).abs() < 0.005
            && (b[1].as_f64().unwrap() - 0.626).abs() < 0.005
    );
    for cylinder in ["bucket", "arm", "boom"] {
        assert!(value["pressure_bar"][cylinder].as_f64().unwrap() > 0.0);
        assert!(value["cylinder_force_kN"][cylinder].is_f64());
    }
    assert_eq!(value["gauge_stress_MPa"].as_array().unwrap().len(), 18);
    assert!(value["max_von_mises_MPa"]["boom"].as_f64().unwrap() > 0.0);
}

#[test]
fn flags_override_the_case_nominal() {
    let run = |extra: &[&str]| {
        let mut args = vec![
            "twin",
            "excavator",
            "--case",
            "data/excavator/case1.toml",
            "--json",
        ];
        args.extend_from_slice(extra);
        let output = acq(&args);
        assert!(output.status.success(), "{}", stderr(&output));
        serde_json::from_str::<serde_json::Value>(&stdout(&output)).unwrap()
    };
    let nominal = run(&[]);
    let explicit = run(&[
        "--bucket-stroke",
        "121",
        "--arm-stroke",
        "210",
        "--boom-stroke",
        "467",
        "--force",
        "40.6",
        "--angle",
        "-10",
    ]);
    assert_eq!(
        nominal, explicit,
        "the case's nominal is the middle of each bound"
    );
    let unloaded = run(&["--force", "0"]);
    assert!(unloaded["pressure_bar"]["arm"].as_f64() < nominal["pressure_bar"]["arm"].as_f64());
    let raised = run(&["--boom-stroke", "600"]);
    assert!(raised["points"]["B"][1].as_f64() > nominal["points"]["B"][1].as_f64());
}

#[test]
fn unreachable_strokes_and_bad_case_files_exit_2_with_the_reason() {
    let output = acq(&[
        "twin",
        "excavator",
        "--case",
        "data/excavator/case1.toml",
        "--arm-stroke",
        "2000",
    ]);
    assert_eq!(output.status.code(), Some(2));
    assert!(
        stderr(&output).contains("arm cylinder stroke 2000 mm is outside its range"),
        "{}",
        stderr(&output)
    );

    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("bad.toml");
    std::fs::write(&bad, "name = \"x\"\nforce_kN = \"forty\"\n").unwrap();
    let output = acq(&["twin", "excavator", "--case", bad.to_str().unwrap()]);
    assert_eq!(output.status.code(), Some(2));
    let message = stderr(&output);
    assert!(
        message.contains("bad.toml") && message.contains("line 2"),
        "{message}"
    );
}

#[test]
fn the_human_report_compares_with_the_measurements() {
    let output = acq(&["twin", "excavator", "--case", "data/excavator/case2.toml"]);
    assert!(output.status.success(), "{}", stderr(&output));
    let text = stdout(&output);
    assert!(
        text.contains("measured bar") && text.contains("195.04"),
        "{text}"
    );
    assert!(text.contains("max von Mises"), "{text}");
}

#[test]
fn sensitivity_writes_the_table_and_the_plot() {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("case1.csv");
    let output = acq(&[
        "sensitivity",
        "excavator",
        "--case",
        "data/excavator/case1.toml",
        "--points",
        "5",
        "-o",
        csv.to_str().unwrap(),
    ]);
    assert!(output.status.success(), "{}", stderr(&output));
    let table = std::fs::read_to_string(&csv).unwrap();
    let mut lines = table.lines();
    let header = lines.next().unwrap();
    assert!(header.starts_with(
        "factor,factor_unit,value,bucket_pressure_bar,arm_pressure_bar,boom_pressure_bar"
    ));
    assert_eq!(header.split(',').count(), 3 + 5 + 18 + 1);
    let rows: Vec<&str> = lines.collect();
    assert_eq!(rows.len(), 4 * 5);
    assert!(
        rows[0].starts_with("bucket_stroke_mm,mm,116,"),
        "{}",
        rows[0]
    );
    assert!(
        rows[19].starts_with("force_angle_deg,deg,-5,"),
        "{}",
        rows[19]
    );
    assert!(rows.iter().all(|r| r.ends_with(',')), "no run failed");
    let svg = std::fs::read_to_string(csv.with_extension("svg")).unwrap();
    assert!(svg.starts_with("<svg") && svg.contains("measured 193.46 bar"));
    // The printed summary: the tip-load angle moves the arm pressure most.
    let summary = stdout(&output);
    let swing = |input: &str| -> f64 {
        let line = summary.lines().find(|l| l.starts_with(input)).unwrap();
        line.split_whitespace().nth(2).unwrap().parse().unwrap()
    };
    assert!(
        swing("force_angle_deg") > swing("arm_stroke_mm"),
        "{summary}"
    );
}

const DATASET_1: &str = "data/tensile/P91_20_2_DF_SS.csv";
const PUBLISHED_DATASET_1: &str =
    "q1=1.332,q2=0.9952,q3=2.295,epsN=0.29,sN=0.1671,fN=0.03869,f0=0.00137,m=534.1";

/// `acq twin gtn --test TEST --param PARAM` plus `extra`.
fn gtn(test: &str, param: &str, extra: &[&str]) -> std::process::Output {
    let mut args = vec!["twin", "gtn", "--test", test, "--param", param];
    args.extend_from_slice(extra);
    acq(&args)
}

#[test]
fn gtn_json_has_exactly_the_fixed_keys_and_a_finite_mape() {
    let output = gtn(DATASET_1, PUBLISHED_DATASET_1, &["--json"]);
    assert!(output.status.success(), "{}", stderr(&output));
    let value: serde_json::Value = serde_json::from_str(stdout(&output).trim()).unwrap();
    let object = value.as_object().unwrap();
    let mut keys: Vec<&str> = object.keys().map(String::as_str).collect();
    keys.sort_unstable();
    assert_eq!(keys, ["failed_early", "mape", "points", "wall_s"]);
    let mape = object["mape"].as_f64().unwrap();
    // Not tuned to the published 1.563 %. 2.72 % with the Cauchy stress in
    // the yield function and the unshifted flow curve; the Kirchhoff stress
    // gave 3.2 % and a flow curve shifted to start at Rp0.2 6.1 %, so the
    // bound catches either mistake.
    assert!(mape > 0.0 && mape < 3.0, "MAPE {mape}");
    assert_eq!(object["failed_early"], false);
    // 0.01 mm output interval to the test's last point, 2.607 mm.
    assert_eq!(object["points"], 262);
    assert!(object["wall_s"].as_f64().unwrap() > 0.0);
}

#[test]
fn gtn_curve_file_starts_at_the_origin_and_peaks_near_the_test() {
    let dir = tempfile::tempdir().unwrap();
    let curve = dir.path().join("curve.csv");
    let output = gtn(
        DATASET_1,
        PUBLISHED_DATASET_1,
        &["-o", curve.to_str().unwrap()],
    );
    assert!(output.status.success(), "{}", stderr(&output));
    let report = stdout(&output);
    assert!(report.contains("MAPE"), "{report}");
    // The published per-part variant: before and after the test's maximum.
    let split = report
        .lines()
        .find(|l| l.contains("up to the test's maximum force at 1.32067 mm"))
        .unwrap_or_else(|| panic!("no split line in\n{report}"));
    let before: f64 = split.split_whitespace().next().unwrap().parse().unwrap();
    assert!(before > 0.0 && before < 1.0, "{split}");
    let text = std::fs::read_to_string(&curve).unwrap();
    let mut lines = text.lines();
    assert_eq!(
        lines.next(),
        Some("DISPLACEMENT,FORCE,NECK_DIAMETER,FAILED_POINTS")
    );
    let rows: Vec<Vec<f64>> = lines
        .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
        .collect();
    assert_eq!(rows[0][0], 0.0);
    assert_eq!(rows[0][1], 0.0);
    let peak = rows.iter().map(|r| r[1]).fold(0.0, f64::max);
    // The test's maximum is 7.4597 kN; the flow curve comes from the test,
    // so the twin's peak must be close (damage lowers it a little).
    assert!((peak - 7.4597).abs() < 0.15, "peak {peak}");
    // The neck thins monotonically.
    assert!(rows.windows(2).all(|w| w[1][2] <= w[0][2] + 1e-12));
}

#[test]
fn gtn_parameters_out_of_range_exit_2_naming_the_parameter() {
    for (change, expected) in [
        (("q1=1.332", "q1=0"), "q1"),
        (("f0=0.00137", "f0=1"), "f0"),
        (("sN=0.1671", "sN=0"), "sN"),
        (("m=534.1", "m=-1"), "m"),
        (("fN=0.03869", "fN=-0.1"), "fN"),
        (("q2=0.9952,", ""), "missing parameter(s): q2"),
        (("m=534.1", "m=534.1,k=2"), "unknown parameter `k`"),
    ] {
        let param = PUBLISHED_DATASET_1.replace(change.0, change.1);
        let output = gtn(DATASET_1, &param, &["--json"]);
        assert_eq!(
            output.status.code(),
            Some(2),
            "{param}: {}",
            stderr(&output)
        );
        let message = stderr(&output);
        assert!(message.contains(expected), "{param}: {message}");
        assert!(stdout(&output).is_empty());
    }
}

#[test]
fn gtn_malformed_test_file_exits_3_with_the_line() {
    let dir = tempfile::tempdir().unwrap();
    let test = dir.path().join("bad.csv");
    std::fs::write(&test, "DISPLACEMENT,FORCE\n0,0\n0.1,abc\n").unwrap();
    let output = gtn(test.to_str().unwrap(), PUBLISHED_DATASET_1, &[]);
    assert_eq!(output.status.code(), Some(3), "{}", stderr(&output));
    assert!(stderr(&output).contains("bad.csv:3"), "{}", stderr(&output));
}

#[test]
fn gtn_with_an_explicit_flow_curve_runs_without_a_test_and_refuses_bad_input() {
    let dir = tempfile::tempdir().unwrap();
    let write = |name: &str, text: &str| {
        let path = dir.path().join(name);
        std::fs::write(&path, text).unwrap();
        path.display().to_string()
    };
    // Linear hardening from 400 MPa: the bar yields near F = 400 MPa x
    // 12.566 mm^2 = 5.0 kN (less the 0.1 % imperfection's section) and
    // hardens a little by 0.3 mm.
    let flow = write(
        "flow.csv",
        "PLASTIC_STRAIN,TRUE_STRESS_MPA\n0,400\n0.5,600\n",
    );
    let damage_off = "q1=1.5,q2=1,q3=2.25,epsN=0.3,sN=0.1,fN=0,f0=0,m=400";
    let output = acq(&[
        "twin",
        "gtn",
        "--flow-curve",
        &flow,
        "--param",
        damage_off,
        "--end-mm",
        "0.3",
        "--mesh",
        "2x6",
        "--json",
    ]);
    assert!(output.status.success(), "{}", stderr(&output));
    let json: serde_json::Value = serde_json::from_str(&stdout(&output)).unwrap();
    assert!(json["mape"].is_null(), "{json}");
    let peak = json["max_force_kn"].as_f64().unwrap();
    let yield_kn = 400.0 * std::f64::consts::PI * 4.0 / 1000.0;
    assert!(peak > yield_kn * 0.99 && peak < yield_kn * 1.1, "{json}");

    let refused = |args: &[&str], code: i32, wanted: &[&str]| {
        let mut all = vec!["twin", "gtn", "--param", damage_off];
        all.extend_from_slice(args);
        let output = acq(&all);
        let message = stderr(&output);
        assert_eq!(output.status.code(), Some(code), "{args:?}: {message}");
        for part in wanted {
            assert!(
                message.contains(part),
                "{args:?}: {part:?} not in {message}"
            );
        }
    };
    let no_column = write("no_column.csv", "STRAIN,STRESS\n0,400\n");
    refused(
        &["--flow-curve", &no_column, "--end-mm", "0.3"],
        3,
        &["no_column.csv", "PLASTIC_STRAIN"],
    );
    let late_start = write(
        "late.csv",
        "PLASTIC_STRAIN,TRUE_STRESS_MPA\n0.1,400\n0.5,600\n",
    );
    refused(
        &["--flow-curve", &late_start, "--end-mm", "0.3"],
        3,
        &["late.csv"],
    );
    refused(&["--flow-curve", &flow], 2, &["--end-mm"]);
    refused(
        &[
            "--flow-curve",
            &flow,
            "--end-mm",
            "0.3",
            "--imperfection",
            "0.7",
        ],
        2,
        &["--imperfection"],
    );
    refused(&["--flow-curve", &flow, "--end-mm", "40"], 2, &["--end-mm"]);
}

#[test]
fn gtn_mesh_convergence_runs_each_size_and_overlays_the_curves() {
    let dir = tempfile::tempdir().unwrap();
    let svg = dir.path().join("convergence.svg");
    let fracture = format!("{PUBLISHED_DATASET_1},fc=0.02,fF=0.15");
    let output = gtn(
        DATASET_1,
        &fracture,
        &[
            "--convergence",
            "0.4,0.8",
            "--svg",
            svg.to_str().unwrap(),
            "--json",
        ],
    );
    assert!(output.status.success(), "{}", stderr(&output));
    let value: serde_json::Value = serde_json::from_str(stdout(&output).trim()).unwrap();
    let sizes = value.as_array().unwrap();
    // Coarsest first; the radius (2 mm) over the size, rounded.
    assert_eq!(sizes.len(), 2);
    assert_eq!(sizes[0]["element_mm"], 0.8);
    assert_eq!(sizes[0]["radial_elements"], 3);
    assert_eq!(sizes[1]["radial_elements"], 5);
    for size in sizes {
        let mape = size["mape"].as_f64().unwrap();
        assert!(mape.is_finite() && mape > 0.0, "{size}");
        // With coalescence the bar breaks before the test's last point (2.6 mm).
        let broke = size["fracture_mm"].as_f64().unwrap();
        assert!(broke > 1.3 && broke < 2.6, "{size}");
        let max_force = size["max_force_kn"].as_f64().unwrap();
        assert!((max_force - 7.46).abs() < 0.3, "{size}");
    }
    let plot = std::fs::read_to_string(&svg).unwrap();
    assert!(plot.contains("0.8 mm elements") && plot.contains("0.4 mm elements"));

    // A size the bar cannot be meshed at is refused before any run.
    let output = gtn(DATASET_1, PUBLISHED_DATASET_1, &["--convergence", "0.4,5"]);
    assert_eq!(output.status.code(), Some(2), "{}", stderr(&output));
    assert!(
        stderr(&output).contains("--convergence 5"),
        "{}",
        stderr(&output)
    );
}

/// The curve part by part: before the maximum force (about 1.3 mm) the
/// bar hardens uniformly and every element size gives the same force
/// (GCI under 0.01 %); after it the softening localises in one band of
/// elements, and the last part's force depends on their size (a GCI
/// above 1 %, or no convergence at all).
///
/// With `--out` the same study is written as `acq mesh-study` writes one:
/// summary.json's `mesh_study` (every scalar, in the fixed keys) and
/// `mesh_study_curves`, with the numbers the text gives.
#[test]
fn gtn_mesh_convergence_compares_the_curve_part_by_part() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("mesh");
    let output = gtn(
        DATASET_1,
        PUBLISHED_DATASET_1,
        &[
            "--convergence",
            "0.8,0.5,0.3",
            "--out",
            out.to_str().unwrap(),
        ],
    );
    assert!(output.status.success(), "{}", stderr(&output));
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    let studies = summary["mesh_study"].as_object().unwrap();
    let mut keys: Vec<&str> = studies.keys().map(String::as_str).collect();
    keys.sort_unstable();
    // The bar holds to the test's end: no fracture_mm.
    assert_eq!(keys, ["mape_pct", "max_force_kn"]);
    for (key, entry) in studies {
        let mut fields: Vec<&str> = entry
            .as_object()
            .unwrap()
            .keys()
            .map(String::as_str)
            .collect();
        fields.sort_unstable();
        for fixed in [
            "convergence",
            "e_a_pct",
            "e_ext_pct",
            "extrapolated",
            "gci_fine_pct",
            "order",
            "sizes",
            "values",
        ] {
            assert!(fields.contains(&fixed), "{key}: {fields:?}");
        }
        assert_eq!(entry["sizes"], serde_json::json!([0.8, 0.5, 0.3]), "{key}");
    }
    assert_eq!(summary["at"]["q1"], 1.332);
    let curve_parts = summary["mesh_study_curves"]["force_displacement"]["parts"]
        .as_array()
        .unwrap();
    assert_eq!(curve_parts.len(), 10);
    let report = std::fs::read_to_string(out.join("report.md")).unwrap();
    assert!(report.contains("## Curve force_displacement, part by part"));
    // One table of every output, before the first plot (a plot between
    // rows would end the table and leave the rest as literal text).
    let first_plot = report.find("![").unwrap();
    for key in ["| max_force_kn |", "| mape_pct |"] {
        assert!(report[..first_plot].contains(key), "{key} in {report}");
    }
    let text = stdout(&output);
    let parts: Vec<&str> = text
        .lines()
        .skip_while(|l| !l.starts_with("the force curve part by part"))
        .skip(1)
        .take_while(|l| l.starts_with("  "))
        .collect();
    assert_eq!(parts.len(), 10, "{text}");
    let gci = |line: &str| -> Option<f64> {
        line.split("GCI_fine ")
            .nth(1)?
            .split(' ')
            .next()?
            .parse()
            .ok()
    };
    for line in &parts[..4] {
        assert!(gci(line).is_some_and(|g| g < 0.01), "{line}");
    }
    let last = parts[9];
    assert!(
        last.contains("divergent") || gci(last).is_some_and(|g| g > 1.0),
        "{last}"
    );
    // The file and the text say the same.
    for (line, part) in parts.iter().zip(curve_parts) {
        match part["gci_fine_pct"].as_f64() {
            // The text rounds to three decimals.
            Some(g) => assert!(
                gci(line).is_some_and(|t| (t - g).abs() <= 0.000_5 + 1e-9),
                "{line} vs {g}"
            ),
            None => assert!(gci(line).is_none(), "{line} vs {part}"),
        }
    }
}
