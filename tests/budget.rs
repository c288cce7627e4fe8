//! `acq budget`: the uncertainty budget of one value of a sensor from its
//! rig's certificate and data sheet, checked against JCGM 100's worked
//! example H.3 and against the GUM's formulas evaluated here by hand.

mod common;
use common::{acq, path_arg, stderr, stdout};
use std::path::{Path, PathBuf};

/// A one-sensor rig (a CANopen pressure transducer) with `record` added
/// under its `[[sensor]]`.
fn rig_with(dir: &Path, record: &str) -> PathBuf {
    let path = dir.join("rig.toml");
    std::fs::write(
        &path,
        format!(
            "[rig]\nname = \"budget test\"\n\n[[bus]]\nname = \"hydraulics\"\niface = \"can0\"\nbitrate = 250000\n\n[[sensor]]\nname = \"p\"\nkind = \"pressure\"\nrate_hz = 100\ncanopen = {{ node_id = 0x25, pdo = 1, byte = 0, type = \"int32\", decimal_digits = 2 }}\n{record}\n"
        ),
    )
    .unwrap();
    path
}

fn budget_json(rig: &Path, at: f64) -> serde_json::Value {
    let output = acq(&[
        "budget",
        path_arg(rig),
        "--sensor",
        "p",
        "--at",
        &at.to_string(),
        "--json",
    ]);
    assert!(output.status.success(), "{}", stderr(&output));
    serde_json::from_str(&stdout(&output)).unwrap()
}

/// JCGM 100:2008 H.3, table H.6 (thermometer readings t_k and the
/// corrections b_k), here as a sensor's points (t_k, t_k + b_k): the
/// reference's value at each reading.
use acq_metrology::curve::JCGM_100_H3 as H3;

#[test]
fn jcgm_100_h3_as_a_sensors_certificate_gives_the_published_curve_uncertainty() {
    let dir = tempfile::tempdir().unwrap();
    let points: Vec<String> = H3
        .iter()
        .map(|[t, b]| format!("[{t}, {}]", t + b))
        .collect();
    let rig = rig_with(
        dir.path(),
        &format!("calibration = {{ points = [{}] }}", points.join(", ")),
    );
    // The value at a reading of 30 C: 30 + b(30) = 30 - 0.1494 (H.3).
    let json = budget_json(&rig, 30.0 - 0.1494);
    let curve = &json["contributions"]["calibration_curve"];
    // H.3 gives u(b(30)) = 0.0041 C with 11 - 2 = 9 degrees of freedom.
    // Tolerance: half the published last digit.
    let u = curve["u"].as_f64().unwrap();
    assert!((u - 0.0041).abs() <= 0.00005, "u = {u}");
    assert_eq!(curve["dof"].as_f64(), Some(9.0));
    assert_eq!(json["dof"].as_f64(), Some(9.0));
    // Student's t at 9 degrees of freedom, 95 %: 2.262 (any t table).
    let k = json["k"].as_f64().unwrap();
    assert!((k - 2.262).abs() < 5e-4, "k = {k}");
    let (u_c, u95) = (json["u_c"].as_f64().unwrap(), json["U95"].as_f64().unwrap());
    assert!((u_c - u).abs() < 1e-15 && (u95 - k * u_c).abs() < 1e-12);
}

#[test]
fn a_certificate_an_accuracy_class_and_a_resolution_combine_as_the_gum_says() {
    let rig = common::root().join("examples/measurement-chain/rig.toml");
    let output = acq(&[
        "budget",
        path_arg(&rig),
        "--sensor",
        "boom_head_pressure",
        "--at",
        "150",
        "--json",
    ]);
    assert!(output.status.success(), "{}", stderr(&output));
    let json: serde_json::Value = serde_json::from_str(&stdout(&output)).unwrap();
    // By hand: five points with expanded uncertainty 0.2 bar at k = 2, so
    // u_i = 0.1 bar each; the line's uncertainty at reading x is
    // u_i sqrt(1/n + (x - mean)^2 / Sxx).
    let readings = [0.12, 100.35, 200.41, 300.30, 400.02];
    let values = [0.0, 100.0, 200.0, 300.0, 400.0];
    let n = readings.len() as f64;
    let mean_x = readings.iter().sum::<f64>() / n;
    let mean_y = values.iter().sum::<f64>() / n;
    let sxx: f64 = readings.iter().map(|x| (x - mean_x).powi(2)).sum();
    let sxy: f64 = readings
        .iter()
        .zip(values)
        .map(|(x, y)| (x - mean_x) * (y - mean_y))
        .sum();
    let slope = sxy / sxx;
    let reading_at_150 = mean_x + (150.0 - mean_y) / slope;
    let curve = 0.1 * (1.0 / n + (reading_at_150 - mean_x).powi(2) / sxx).sqrt();
    // +-0.5 % of 400 bar, rectangular; a 0.01 bar step, q / sqrt(12).
    let accuracy = 0.005 * 400.0 / 3f64.sqrt();
    let resolution = 0.01 / 12f64.sqrt();
    let u_c = (curve.powi(2) + accuracy.powi(2) + resolution.powi(2)).sqrt();
    let got = |path: &[&str]| path.iter().fold(&json, |v, key| &v[key]).as_f64().unwrap();
    for (what, expected, actual) in [
        (
            "curve",
            curve,
            got(&["contributions", "calibration_curve", "u"]),
        ),
        (
            "accuracy",
            accuracy,
            got(&["contributions", "accuracy_class", "u"]),
        ),
        (
            "resolution",
            resolution,
            got(&["contributions", "resolution", "u"]),
        ),
        ("u_c", u_c, got(&["u_c"])),
    ] {
        assert!(
            (actual - expected).abs() < 1e-12 * expected.max(1.0),
            "{what}: {actual} vs {expected}"
        );
    }
    // Every source is Type B with infinite degrees of freedom: k is the
    // normal distribution's.
    assert!(json["dof"].is_null());
    assert!((got(&["k"]) - 1.959_964).abs() < 1e-6);
    assert_eq!(json["unit"], "bar");
    assert_eq!(json["sensor"], "boom_head_pressure");
    // The table says the same, with each source's share of the variance.
    let table = acq(&[
        "budget",
        path_arg(&rig),
        "--sensor",
        "boom_head_pressure",
        "--at",
        "150",
    ]);
    let text = stdout(&table);
    assert!(
        text.contains("accuracy_class") && text.contains("99.8%"),
        "{text}"
    );
}

#[test]
fn a_sensor_without_a_record_has_an_empty_budget_and_says_so() {
    let dir = tempfile::tempdir().unwrap();
    let rig = rig_with(dir.path(), "");
    let json = budget_json(&rig, 10.0);
    assert_eq!(json["u_c"].as_f64(), Some(0.0));
    assert_eq!(json["contributions"], serde_json::json!({}));
    let text = stdout(&acq(&[
        "budget",
        path_arg(&rig),
        "--sensor",
        "p",
        "--at",
        "10",
    ]));
    assert!(text.contains("the readings' scatter only"), "{text}");
}

#[test]
fn a_bad_record_is_refused_with_its_line_and_what_to_fix() {
    let dir = tempfile::tempdir().unwrap();
    for (record, expected) in [
        ("calibration = { points = [[0.0, 0.0], [2.0, 2.0], [1.0, 1.0]] }", "point 3 ([1, 1]) breaks that order"),
        ("calibration = { points = [[0.0, 0.0], [1.0, 1.0]] }", "2 calibration point(s); a line needs at least 3"),
        ("calibration = { points = [[0.0, 0.0], [1.0, 1.0]], uncertainties = [0.1, 0.1], k = 2.0 }", "k needs the level of confidence"),
        ("calibration = { points = [[0.0, 0.0], [1.0, 1.0]], uncertainties = [0.1, -0.1] }", "uncertainty of calibration point 2 is -0.1"),
        ("calibration = { points = [[0.0, 0.0], [1.0, 1.0], [2.0, 2.0]], date = \"2026-05-01\", due = \"2025-05-01\" }", "due 2025-05-01 is before the calibration's date 2026-05-01"),
        ("calibration = { points = [[0.0, 0.0], [1.0, 1.0], [2.0, 2.0]], date = \"1.5.2026\" }", "give a date that exists, as YYYY-MM-DD"),
        ("calibration = { points = [[0.0, 0.0], [1.0, 1.0], [2.0, 2.0]], date = \"2026-02-30\" }", "date = \"2026-02-30\": give a date that exists"),
        ("calibration = { points = [[0.0, 0.0], [1.0, 1.0], [2.0, 2.0]], date = \"2024-02-28\", due = \"2025-02-29\" }", "due = \"2025-02-29\": give a date that exists"),
        ("calibration = { points = [[0.0, 0.0, 0.0], [1.0, 1.0, 0.1], [2.0, 2.0, 0.1]] }", "calibration point 1 has 3 numbers; give each as [reading, value]"),
        ("calibration = { points = [[0.0, 0.0], [1.0, 1.0], [2.0, 2.0]] }", "lie exactly on a line and state no uncertainties"),
        ("calibration = { points = [[-1e308, -1e308], [0.0, 0.0], [1e308, 1e308]], uncertainties = [0.1, 0.1, 0.1] }", "a line through these points overflows"),
        ("accuracy = { percent_of_full_scale = 0.5 }", "needs the sensor's range"),
        ("accuracy = { percent_of_reading = -1.0 }", "give a share above 0"),
        ("resolution = 0.0", "resolution = 0"),
        ("scale = 2.0\ncalibration = { points = [[0.0, 0.0], [1.0, 1.0], [2.0, 2.0]] }", "either a certificate's calibration or scale"),
        ("shunt = { resistor_ohm = 100000.0, gauge_ohm = 350.0 }", "a shunt check is for a strain channel"),
    ] {
        let rig = rig_with(dir.path(), record);
        let output = acq(&["budget", path_arg(&rig), "--sensor", "p", "--at", "1"]);
        let message = stderr(&output);
        assert_eq!(output.status.code(), Some(2), "{record}: {message}");
        assert!(message.contains(expected), "{record}: {message}");
        // The sensor's line in the rig file, or the record's own (line 14)
        // where the file's syntax already names it.
        assert!(
            message.contains("line 9") || message.contains(":9:") || message.contains("rig.toml:14:"),
            "{record}: {message}"
        );
    }
    let rig = rig_with(dir.path(), "");
    let output = acq(&["budget", path_arg(&rig), "--sensor", "q", "--at", "1"]);
    assert_eq!(output.status.code(), Some(2));
    assert!(stderr(&output).contains("no sensor 'q' (sensors: p)"));
}

/// `acq extract`'s rows as maps from column to text.
fn measured_rows(path: &Path) -> Vec<std::collections::HashMap<String, String>> {
    let mut reader = csv::Reader::from_path(path).unwrap();
    let header: Vec<String> = reader
        .headers()
        .unwrap()
        .iter()
        .map(str::to_string)
        .collect();
    reader
        .records()
        .map(|r| {
            header
                .iter()
                .cloned()
                .zip(r.unwrap().iter().map(str::to_string))
                .collect()
        })
        .collect()
}

/// `acq extract` of `session` through a copy of its rig with `records`
/// (sensor name, the keys to add under its `[[sensor]]`): the rows.
fn extract_with_records(
    session: &Path,
    records: &[(&str, &str)],
) -> Vec<std::collections::HashMap<String, String>> {
    // The shipped rig without its data sheets' records, then `records`.
    let mut rig_text: String = std::fs::read_to_string(session.join("rig/excavator.toml"))
        .unwrap()
        .lines()
        .filter(|line| {
            !["range = ", "accuracy = ", "resolution = "]
                .iter()
                .any(|key| line.starts_with(key))
        })
        .map(|line| format!("{line}\n"))
        .collect();
    for (sensor, keys) in records {
        let name = format!("name = \"{sensor}\"\n");
        assert!(rig_text.contains(&name), "{sensor}");
        rig_text = rig_text.replace(&name, &format!("{name}{keys}\n"));
    }
    let rig = session.join("rig/with-records.toml");
    std::fs::write(&rig, rig_text).unwrap();
    let measured = session.join("with-records.csv");
    let output = acq(&[
        "extract",
        path_arg(session),
        "--rig",
        path_arg(&rig),
        "-o",
        path_arg(&measured),
    ]);
    assert!(output.status.success(), "{}", stderr(&output));
    measured_rows(&measured)
}

/// The row of `quantity` in the window `hold1`.
fn hold1<'a>(
    rows: &'a [std::collections::HashMap<String, String>],
    quantity: &str,
) -> &'a std::collections::HashMap<String, String> {
    rows.iter()
        .find(|r| r["window"] == "hold1" && r["quantity"] == quantity)
        .unwrap_or_else(|| panic!("hold1 {quantity}"))
}

fn number_in(row: &std::collections::HashMap<String, String>, column: &str) -> f64 {
    row[column]
        .parse()
        .unwrap_or_else(|_| panic!("{column}: {:?}", row[column]))
}

#[test]
fn extract_writes_each_holds_budget_and_a_record_adds_to_the_scatter() {
    let dir = tempfile::tempdir().unwrap();
    let session = common::copy_session("excavator_case1", &dir.path().join("case1"));
    let rows = extract_with_records(&session, &[]);
    let row = |window: &str, quantity: &str| {
        rows.iter()
            .find(|r| r["window"] == window && r["quantity"] == quantity)
            .unwrap_or_else(|| panic!("{window} {quantity}"))
            .clone()
    };
    // No sensor of the bare rig has a record: the scatter is the whole
    // budget, so U95 is the Student-t interval's half-width computed by
    // the statistics on their own.
    for r in rows
        .iter()
        .filter(|r| !r["u_c"].is_empty() && !r["quantity"].ends_with("net_force"))
    {
        let half = 0.5 * (number_in(r, "ci95_high") - number_in(r, "ci95_low"));
        let u95 = number_in(r, "U95");
        assert!(
            (u95 - half).abs() <= 1e-9 * half.max(1e-12),
            "{}: {u95} vs {half}",
            r["quantity"]
        );
        let u_a = number_in(r, "std") / number_in(r, "n_eff").sqrt();
        assert!((number_in(r, "u_c") - u_a).abs() <= 1e-12 * u_a.max(1e-12));
    }
    // The arm's net force: both pressures through their areas (bore 90,
    // rod 55 mm; kN per bar = area mm^2 x 0.1 / 1000).
    let (head, rod, net) = (
        row("hold1", "arm_head_pressure"),
        row("hold1", "arm_rod_pressure"),
        row("hold1", "arm_net_force"),
    );
    let head_kn_per_bar = std::f64::consts::PI / 4.0 * 90f64.powi(2) * 1e-4;
    let rod_kn_per_bar = std::f64::consts::PI / 4.0 * (90f64.powi(2) - 55f64.powi(2)) * 1e-4;
    let expected = ((head_kn_per_bar * number_in(&head, "u_c")).powi(2)
        + (rod_kn_per_bar * number_in(&rod, "u_c")).powi(2))
    .sqrt();
    let u_net = number_in(&net, "u_c");
    assert!(
        (u_net - expected).abs() <= 1e-9 * expected,
        "{u_net} vs {expected}"
    );

    // The same session with the arm's head transducer's data sheet: +-0.5 %
    // of 400 bar (rectangular) and a 0.01 bar step join its scatter.
    let again = extract_with_records(
        &session,
        &[(
            "arm_head_pressure",
            "range = [0.0, 400.0]\naccuracy = { percent_of_full_scale = 0.5 }\nresolution = 0.01",
        )],
    );
    let head_again = hold1(&again, "arm_head_pressure");
    let u_a = number_in(&head, "u_c");
    let type_b = ((0.005 * 400.0) / 3f64.sqrt()).powi(2) + (0.01 / 12f64.sqrt()).powi(2);
    let u_c = number_in(head_again, "u_c");
    assert!((u_c - (u_a * u_a + type_b).sqrt()).abs() < 1e-12, "{u_c}");
    // Welch-Satterthwaite: the scatter's n_eff - 1 degrees of freedom
    // weigh by (u_A / u_c)^4, so k is the normal's to a part in 1e9.
    let dof = (u_c / u_a).powi(4) * (number_in(&head, "n_eff") - 1.0);
    assert!(dof > 1e9, "{dof}");
    assert!((number_in(head_again, "k") - 1.959_964).abs() < 1e-6);
    // The loaded-chamber pressure is that transducer's value, with its budget.
    let loaded = hold1(&again, "arm_loaded_pressure");
    assert_eq!(loaded["u_c"], head_again["u_c"]);
    // Its data sheet's part is the transducer's own error, the same in
    // every hold: written as shared by it (the accuracy class alone; the
    // resolution is each reading's own).
    let shared = shared_effect(head_again, "arm_head_pressure");
    assert!(
        (shared - 0.005 * 400.0 / 3f64.sqrt()).abs() < 1e-12,
        "{shared}"
    );
    assert!(head["shared"].is_empty(), "{}", head["shared"]);
    // The net force shares both chambers' errors, the rod's with a minus
    // (net = head area x head pressure - annulus area x rod pressure).
    let again_rows = extract_with_records(
        &session,
        &[
            (
                "arm_head_pressure",
                "range = [0.0, 400.0]\naccuracy = { percent_of_full_scale = 0.5 }",
            ),
            (
                "arm_rod_pressure",
                "range = [0.0, 400.0]\naccuracy = { percent_of_full_scale = 0.5 }",
            ),
        ],
    );
    let net = hold1(&again_rows, "arm_net_force");
    let accuracy_bar = 0.005 * 400.0 / 3f64.sqrt();
    assert!(
        (shared_effect(net, "arm_head_pressure") - head_kn_per_bar * accuracy_bar).abs() < 1e-12
    );
    assert!((shared_effect(net, "arm_rod_pressure") + rod_kn_per_bar * accuracy_bar).abs() < 1e-12);
}

/// The effect of `sensor`'s shared error on a row's value (its `shared`
/// column: `sensor=effect;...`).
fn shared_effect(row: &std::collections::HashMap<String, String>, sensor: &str) -> f64 {
    row["shared"]
        .split(';')
        .find_map(|part| part.strip_prefix(&format!("{sensor}=")))
        .unwrap_or_else(|| panic!("{sensor} not in {:?}", row["shared"]))
        .parse()
        .unwrap()
}

/// GTC, pinned: the GUM Tree Calculator of the Measurement Standards
/// Laboratory of New Zealand.
#[test]
fn a_net_forces_budget_agrees_with_the_gum_tree_calculator() {
    let dir = tempfile::tempdir().unwrap();
    let session = common::copy_session("excavator_case1", &dir.path().join("case1"));
    // The arm's head transducer with a certificate that states no point
    // uncertainties (its line's scatter, 3 degrees of freedom), its rod
    // transducer with an accuracy class: a budget whose effective degrees
    // of freedom are few, so Welch-Satterthwaite is tested, not skipped.
    let points = [
        [0.0, 0.3],
        [100.0, 100.1],
        [200.0, 199.6],
        [300.0, 300.4],
        [400.0, 399.9],
    ];
    let points_toml: Vec<String> = points.iter().map(|[r, v]| format!("[{r}, {v}]")).collect();
    let calibration = format!("calibration = {{ points = [{}] }}", points_toml.join(", "));
    let rows = extract_with_records(
        &session,
        &[
            ("arm_head_pressure", calibration.as_str()),
            (
                "arm_rod_pressure",
                "range = [0.0, 400.0]\naccuracy = { percent_of_full_scale = 0.05 }",
            ),
        ],
    );
    let row = |quantity: &str| {
        rows.iter()
            .find(|r| r["window"] == "hold1" && r["quantity"] == quantity)
            .unwrap()
            .clone()
    };
    let (head, rod, net) = (
        row("arm_head_pressure"),
        row("arm_rod_pressure"),
        row("arm_net_force"),
    );
    let hold = |r: &std::collections::HashMap<String, String>| {
        serde_json::json!({
            "mean": number_in(r, "mean"),
            "std": number_in(r, "std"),
            "n_eff": number_in(r, "n_eff"),
        })
    };
    let mut rod_hold = hold(&rod);
    rod_hold["accuracy_half_width"] = serde_json::json!(0.0005 * 400.0);
    // Bore 90 mm, rod 55 mm: kN per bar of each chamber.
    let input = serde_json::json!({
        "curve_points": points,
        "head": hold(&head),
        "rod": rod_hold,
        "head_kn_per_bar": std::f64::consts::PI / 4.0 * 90f64.powi(2) * 1e-4,
        "rod_kn_per_bar": std::f64::consts::PI / 4.0 * (90f64.powi(2) - 55f64.powi(2)) * 1e-4,
    });
    let input_path = dir.path().join("gtc-input.json");
    std::fs::write(&input_path, input.to_string()).unwrap();
    let python = common::scratch_python("gtc");
    let peer = std::process::Command::new(python)
        .arg(common::root().join("tests/peers/gtc_net_force.py"))
        .arg(&input_path)
        .output()
        .unwrap();
    assert!(
        peer.status.success(),
        "{}",
        String::from_utf8_lossy(&peer.stderr)
    );
    let gtc: serde_json::Value = serde_json::from_slice(&peer.stdout).unwrap();
    // u_c within 1 % and the degrees of freedom within 1: what a budget
    // reported to two significant digits needs.
    // acq's file holds k, not the degrees of freedom: k within the t
    // quantiles at GTC's dof - 1 and dof + 1 is the same statement.
    let (u_acq, u_gtc) = (number_in(&net, "u_c"), gtc["u_c"].as_f64().unwrap());
    assert!(
        (u_acq - u_gtc).abs() <= 0.01 * u_gtc,
        "u_c: acq {u_acq}, GTC {u_gtc}"
    );
    let dof = gtc["dof"].as_f64().unwrap();
    eprintln!(
        "net force: acq u_c {u_acq} kN, k {}; GTC u_c {u_gtc} kN, {dof} degrees of freedom, k {}",
        number_in(&net, "k"),
        gtc["k"]
    );
    assert!(
        dof > 2.0 && dof < 100.0,
        "a budget with few degrees of freedom: {dof}"
    );
    let k_acq = number_in(&net, "k");
    let t = |dof: f64| acq_metrology::budget::coverage_factor(Some(dof), 0.95);
    assert!(
        t(dof + 1.0) <= k_acq && k_acq <= t(dof - 1.0),
        "k: acq {k_acq}, GTC {} at {dof} degrees of freedom",
        gtc["k"]
    );
}

#[test]
fn check_rig_states_each_certificate_and_flags_one_past_its_due_date() {
    let dir = tempfile::tempdir().unwrap();
    let rig = rig_with(
        dir.path(),
        "calibration = { points = [[0.0, 0.0], [1.0, 1.0], [2.0, 2.0]], uncertainties = [0.1, 0.1, 0.1], certificate = \"C-1\", lab = \"a lab\", date = \"2019-01-10\", due = \"2020-01-10\" }",
    );
    let output = acq(&["check-rig", path_arg(&rig)]);
    assert!(output.status.success(), "{}", stderr(&output));
    let text = stdout(&output);
    assert!(
        text.contains("sensor 'p': PAST DUE: its calibration was due on 2020-01-10"),
        "{text}"
    );
    let current = rig_with(
        dir.path(),
        "calibration = { points = [[0.0, 0.0], [1.0, 1.0], [2.0, 2.0]], uncertainties = [0.1, 0.1, 0.1], certificate = \"C-2\", lab = \"a lab\", date = \"2026-01-10\", due = \"9999-01-10\" }",
    );
    let text = stdout(&acq(&["check-rig", path_arg(&current)]));
    assert!(
        text.contains(
            "sensor 'p': certificate C-2 of a lab, calibrated 2026-01-10, due 9999-01-10"
        ),
        "{text}"
    );
    let none = rig_with(dir.path(), "");
    let text = stdout(&acq(&["check-rig", path_arg(&none)]));
    assert!(
        text.contains("sensor 'p': no certificate: its uncertainty is the readings' scatter only"),
        "{text}"
    );
    // A rig of bare channels is one line, not one per sensor.
    let shipped = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/rigs/excavator.toml");
    let text = stdout(&acq(&["check-rig", path_arg(&shipped)]));
    let calibration: Vec<&str> = text
        .lines()
        .skip_while(|line| !line.starts_with("calibration (today"))
        .skip(1)
        .collect();
    assert_eq!(calibration.len(), 2, "{text}");
    assert!(
        calibration.iter().any(|line| line.contains(" sensors ('")
            && line.ends_with("no certificate: their data sheets' accuracy and resolution only")),
        "{text}"
    );
    assert!(
        calibration.iter().any(|line| line.contains(" sensors ('")
            && line.ends_with("no certificate: their uncertainty is the readings' scatter only")),
        "{text}"
    );
}

/// A rest state, a hold and a rest state again, on the excavator rig: the
/// pressures and the strain read an offset at rest (a transducer's zero
/// error), the inclinations their angle; each value at the hold is the
/// rest value plus the load's.
const RESTING_SCENARIO: &str = r#"
name = "zeroed"
[timeline]
idle_s = 2.0
build_up_s = 1.0
hold_s = 6.0
release_s = 1.0
after_s = 2.0
[sensor.boom_head_pressure]
idle = 0.6
hold = 80.6
noise = 0.2
[sensor.boom_rod_pressure]
idle = -0.3
hold = 4.7
noise = 0.05
[sensor.tip_force]
idle = 0.25
hold = 40.25
noise = 0.08
[sensor.sg01]
idle = 1.5
hold = 11.5
noise = 0.15
[sensor.boom_inclination]
idle = 12.0
hold = 12.0
noise = 0.02
"#;

/// Records `RESTING_SCENARIO` on the in-process bus as `acq record --rig
/// --zero-before 1.5s --zero-after 1.5s` does, into `session_dir`.
fn record_zeroed_live(session_dir: &Path) {
    record_zeroed_live_in(session_dir, 1.5, Some(1.5), 1.0);
}

/// The same with `--zero-before BEFORE_S [--zero-after AFTER_S]`, played
/// `speed` times as fast (the recording's times are the scenario's divided
/// by `speed`).
fn record_zeroed_live_in(session_dir: &Path, before_s: f64, after_s: Option<f64>, speed: f64) {
    use acq_acquire::replay::Routing;
    use acq_acquire::simulate::scenario::Scenario;
    use acq_acquire::simulate::Simulation;

    let (bus, interfaces) = common::memory_recorder::memory_bus(&["zero0", "zero1"]);
    let root = common::root();
    let mut rig = acq_io::input::load_rig(&root.join("fixtures/rigs/excavator.toml")).unwrap();
    let notes = rig.assign_interfaces(&interfaces).unwrap();
    let windows = acq_analysis::zero::ZeroWindows::new(before_s, after_s).unwrap();
    let (feed, _shared) = acq_view::live_session(
        "zeroed",
        &rig,
        acq_analysis::extract::holds::HoldOptions::default(),
        None,
        Some(session_dir),
        Some(windows),
    );
    let recorder = common::memory_recorder::MemoryRecorder::start(
        &bus,
        &rig,
        &interfaces,
        notes,
        session_dir,
        Box::new(feed),
        "acq record --zero-before 1.5s --zero-after 1.5s",
    );
    let (scenario, curve) = Scenario::parse(RESTING_SCENARIO, Path::new("zeroed.toml")).unwrap();
    let mut simulation =
        Simulation::new(&rig, scenario, curve, 5, acq_acquire::bus::now_ns()).unwrap();
    let routing = Routing::for_rig(&rig, &interfaces).unwrap();
    recorder.play_live_at(&bus, &routing, &mut simulation, speed);
    recorder.stop();
}

/// A live zero window that is no rest is not taken (wrong success: the
/// load's start taken for the transducers' offsets): `RESTING_SCENARIO`'s
/// load builds up from 2 s and is released from 9 s to 10 s of 12 s,
/// played twice as fast (1 s, 4.5 s to 5 s of 6 s recorded). A 1.5 s
/// before window runs into the build-up: no zero record (so every command
/// reads the values as read). A 0.75 s before window is a rest, a 1.5 s after window runs into
/// the release: the zero is the before window's alone.
#[test]
fn a_live_zero_window_that_is_no_rest_is_not_taken() {
    let temp = tempfile::tempdir().unwrap();
    let into_the_load = temp.path().join("into_the_load");
    record_zeroed_live_in(&into_the_load, 1.5, None, 2.0);
    assert!(
        acq_io::zero_record::read(&into_the_load).unwrap().is_none(),
        "a zero was written from a window that runs into the load"
    );

    let into_the_release = temp.path().join("into_the_release");
    record_zeroed_live_in(&into_the_release, 0.75, Some(1.5), 2.0);
    let record = acq_io::zero_record::read(&into_the_release)
        .unwrap()
        .expect("the before window is a rest");
    assert_eq!(record.after_s, None);
    assert!(!record.sensors.is_empty());
    assert!(record.sensors.iter().all(|sensor| sensor.after.is_none()));
}

/// The issue's check: a recording zeroed live equals the same recording
/// zeroed offline, value for value. The recorder's view thread takes the
/// zero from the samples as they arrive; `acq zero` takes it from a copy of
/// the session without its record. The records are equal bit for bit
/// (only who took them differs), and so are the two sessions' extracts.
/// The zeroed values are then checked against the physics the scenario
/// states: a hold's pressure is its rest value plus the load's (80 bar on
/// boom_head_pressure over a 0.6 bar zero), so the zeroed hold must read
/// 80 bar within the noise (std 0.2 bar over some 400 samples, and the
/// zero's over 150: 0.1 bar is more than five standard errors); the
/// inclination, which reads its angle at rest, is not zeroed.
#[test]
fn a_recording_zeroed_live_equals_the_same_recording_zeroed_offline() {
    let temp = tempfile::tempdir().unwrap();
    let live = temp.path().join("live");
    record_zeroed_live(&live);
    let live_record = acq_io::zero_record::read(&live)
        .unwrap()
        .expect("the recorder wrote zero.toml");
    assert_eq!(live_record.taken_by, "acq record --zero-before");

    let offline = temp.path().join("offline");
    std::fs::create_dir(&offline).unwrap();
    for entry in std::fs::read_dir(&live).unwrap() {
        let entry = entry.unwrap();
        let name = entry.file_name();
        if name == "zero.toml" || name == "view-index.bin" {
            continue;
        }
        if entry.file_type().unwrap().is_dir() {
            let to = offline.join(&name);
            std::fs::create_dir(&to).unwrap();
            for inner in std::fs::read_dir(entry.path()).unwrap() {
                let inner = inner.unwrap();
                std::fs::copy(inner.path(), to.join(inner.file_name())).unwrap();
            }
        } else {
            std::fs::copy(entry.path(), offline.join(&name)).unwrap();
        }
    }
    let extracted = |session: &Path, name: &str| {
        let csv = temp.path().join(name);
        let output = acq(&["extract", path_arg(session), "-o", path_arg(&csv)]);
        assert!(output.status.success(), "{}", stderr(&output));
        std::fs::read_to_string(&csv).unwrap()
    };
    extracted(&offline, "unzeroed.csv");
    let output = acq(&[
        "zero",
        path_arg(&offline),
        "--before",
        "1.5s",
        "--after",
        "1.5s",
    ]);
    assert!(output.status.success(), "{}", stderr(&output));
    let said = stderr(&output);
    assert!(said.contains("boom_head_pressure: zero "), "{said}");
    let offline_record = acq_io::zero_record::read(&offline).unwrap().unwrap();
    // The rest value, 0.6 bar, within four standard errors of a 1.5 s mean.
    let boom_zero = offline_record.sensor("boom_head_pressure").unwrap();
    assert!(
        (boom_zero.offset() - 0.6).abs() < 4.0 * boom_zero.before.std_of_mean().unwrap(),
        "{boom_zero:?}"
    );
    assert_eq!(offline_record.taken_by, "acq zero");
    assert_eq!(
        acq_io::zero_record::ZeroRecord {
            taken_by: String::new(),
            ..live_record.clone()
        },
        acq_io::zero_record::ZeroRecord {
            taken_by: String::new(),
            ..offline_record
        }
    );

    let (live_csv, offline_csv) = (
        extracted(&live, "live.csv"),
        extracted(&offline, "offline.csv"),
    );
    assert_eq!(
        live_csv, offline_csv,
        "the two zeroed sessions extract differently"
    );

    let rows = measured_rows(&temp.path().join("live.csv"));
    let hold = |quantity: &str| {
        rows.iter()
            .find(|r| r["quantity"] == quantity)
            .unwrap_or_else(|| panic!("no {quantity} in {rows:?}"))
    };
    let zero_of = |name: &str| live_record.sensor(name).map(|z| z.offset());
    for (quantity, load, tolerance) in [
        ("boom_head_pressure", 80.0, 0.1),
        ("boom_rod_pressure", 5.0, 0.05),
        ("tip_force", 40.0, 0.05),
        ("sg01", 10.0, 0.1),
    ] {
        let mean = number_in(hold(quantity), "mean");
        assert!(
            (mean - load).abs() < tolerance,
            "{quantity}: zeroed hold {mean}, the load alone is {load} (zero {:?})",
            zero_of(quantity)
        );
        assert!(
            hold(quantity)["shared"].contains("zero of"),
            "{:?}",
            hold(quantity)
        );
    }
    assert_eq!(
        zero_of("boom_inclination"),
        None,
        "an inclination is not zeroed"
    );
    assert!((number_in(hold("boom_inclination"), "mean") - 12.0).abs() < 0.05);
    // The zero's two parts add to the budget in quadrature: the mean of
    // the zero window (its std of the mean) and the zero return (a
    // rectangle of that half-width). The data sheet's accuracy of a
    // pressure is a share of full scale, the same at any value, so the
    // unzeroed hold's u_c holds every other part.
    let zero = live_record.sensor("boom_head_pressure").unwrap();
    let drift = zero.zero_return().expect("a zero after the test");
    assert!(drift.abs() < 0.1, "{zero:?}");
    let unzeroed = measured_rows(&temp.path().join("unzeroed.csv"));
    let unzeroed_hold = unzeroed
        .iter()
        .find(|r| r["quantity"] == "boom_head_pressure")
        .unwrap();
    let expected = (number_in(unzeroed_hold, "u_c").powi(2)
        + zero.before.std_of_mean().unwrap().powi(2)
        + drift.powi(2) / 3.0)
        .sqrt();
    let u_c = number_in(hold("boom_head_pressure"), "u_c");
    assert!(
        (u_c - expected).abs() < 1e-6 * expected,
        "u_c {u_c}, expected {expected}"
    );
    assert!(
        (number_in(unzeroed_hold, "mean")
            - number_in(hold("boom_head_pressure"), "mean")
            - zero.offset())
        .abs()
            < 1e-9
    );
}

/// `acq zero` refuses what it cannot zero, with what to give instead:
/// a log (a zero is kept beside a session), a window of no length, and it
/// names a channel that was plainly not at rest in its window.
#[test]
fn acq_zero_refuses_a_log_and_an_empty_window_and_names_a_channel_not_at_rest() {
    let log = common::root().join("fixtures/sessions/excavator_case1/raw.log");
    let output = acq(&["zero", path_arg(&log), "--before", "1s"]);
    assert_eq!(output.status.code(), Some(2), "{}", stderr(&output));
    assert!(
        stderr(&output).contains("give a session directory"),
        "{}",
        stderr(&output)
    );

    let temp = tempfile::tempdir().unwrap();
    let session = common::copy_session("excavator_case1", &temp.path().join("case1"));
    let output = acq(&["zero", path_arg(&session), "--before", "0s"]);
    assert_eq!(output.status.code(), Some(2), "{}", stderr(&output));
    assert!(
        stderr(&output).contains("zero window"),
        "{}",
        stderr(&output)
    );
    // The shipped session idles with the engine running: the boom's head
    // chamber holds 20 bar, 3.3 % of its 600 bar range. Zeroing it is a
    // mistake acq names.
    let output = acq(&["zero", path_arg(&session), "--before", "0.8s"]);
    assert!(output.status.success(), "{}", stderr(&output));
    let said = stderr(&output);
    let boom = said
        .lines()
        .find(|l| l.contains("boom_head_pressure: zero"))
        .unwrap_or_else(|| panic!("{said}"));
    assert!(
        boom.contains("WARNING") && boom.contains("was it at rest?"),
        "{boom}"
    );
    let bucket = said
        .lines()
        .find(|l| l.contains("bucket_rod_pressure: zero"))
        .unwrap();
    assert!(
        !bucket.contains("WARNING"),
        "5 bar of 600 is within 2 %: {bucket}"
    );
}

/// The excavator rig with a shunt on gauge sg01's quarter bridge: 350 ohm
/// gauge (+-0.3 %), 100 kohm shunt (+-0.1 %), gauge factor 2.0, across arm 1.
fn rig_with_shunt(dir: &Path) -> PathBuf {
    let root = common::root();
    let text = std::fs::read_to_string(root.join("fixtures/rigs/excavator.toml"))
        .unwrap()
        .replace(
            "\"../dbc/somat_excavator.dbc\"",
            &format!("{:?}", root.join("fixtures/dbc/somat_excavator.dbc")),
        )
        .replace(
            "dbc = { message = \"DAQ_SG_01_02\", signal = \"SG01\" }",
            "dbc = { message = \"DAQ_SG_01_02\", signal = \"SG01\" }\ngauge_factor = 2.0\nbridge = \"quarter\"\nshunt = { resistor_ohm = 100000.0, resistor_tolerance_pct = 0.1, gauge_ohm = 350.0, gauge_tolerance_pct = 0.3 }",
        );
    let path = dir.join("rig.toml");
    std::fs::write(&path, text).unwrap();
    path
}

/// The stress a 100 kohm shunt across a 350 ohm quarter-bridge arm shows
/// on a linear channel (gauge factor 2, E = 210 GPa), from the closed form
/// `eps = x / ((1 + x/2) GF)` with `x = -R_g / (R_g + R_s)` (Vishay TN-514's
/// simulated strain with the quarter bridge's non-linearity): -366.86 MPa.
fn shunt_stress_mpa() -> f64 {
    let x = -350.0 / (350.0 + 100_000.0);
    x / ((1.0 + x / 2.0) * 2.0) * 210e3
}

/// A session whose sg01 reads 0 at rest, then the shunt's step times
/// `channel_gain` (a span error of the channel), with the tip loaded
/// meanwhile so that extract finds the hold.
fn shunt_session(dir: &Path, rig: &Path, channel_gain: f64) -> PathBuf {
    let scenario = dir.join("shunt.toml");
    std::fs::write(
        &scenario,
        format!(
            "name = \"shunt\"\n[timeline]\nidle_s = 3.0\nbuild_up_s = 0.02\nhold_s = 6.0\nrelease_s = 0.02\nafter_s = 1.0\n\
             [sensor.sg01]\nidle = 0.0\nhold = {}\nnoise = 0.3\n[sensor.tip_force]\nidle = 0.0\nhold = 40.0\nnoise = 0.05\n",
            shunt_stress_mpa() * channel_gain
        ),
    )
    .unwrap();
    let session = dir.join("session");
    std::fs::create_dir_all(&session).unwrap();
    let output = acq(&[
        "simulate",
        "--rig",
        path_arg(rig),
        "--scenario",
        path_arg(&scenario),
        "-o",
        path_arg(&session.join("raw.log")),
        "--start",
        "1800000000",
    ]);
    assert!(output.status.success(), "{}", stderr(&output));
    let output = acq(&["session", "repair", path_arg(&session)]);
    assert!(output.status.success(), "{}", stderr(&output));
    session
}

/// `acq shunt`: the channel's gain is 0.4 % high; the recorded step against
/// the closed-form one gives a gain of 1/1.004 (within 5e-4: the step's
/// standard error over some 300 readings a side is about 1e-4 of it), and
/// every value extract then gives is corrected: the hold reads the shunt's
/// stress within 0.1 MPa, with the gain's uncertainty shared by the
/// session's holds. A 3 % error is refused with both steps; a window with
/// no step says so.
#[test]
fn a_shunt_step_corrects_the_gain_and_a_faulty_one_is_refused_with_its_numbers() {
    let temp = tempfile::tempdir().unwrap();
    let rig = rig_with_shunt(temp.path());
    let session = shunt_session(temp.path(), &rig, 1.004);
    let shunt = |session: &Path, from: &str, to: &str| {
        acq(&[
            "shunt",
            path_arg(session),
            "--rig",
            path_arg(&rig),
            "--sensor",
            "sg01",
            "--from",
            from,
            "--to",
            to,
        ])
    };
    // A hard link to the rig standing at the record's temporary name is
    // never written through (data lost, round four): the rig is kept.
    let rig_text = std::fs::read(&rig).unwrap();
    std::fs::hard_link(&rig, session.join(".shunt.toml.tmp")).unwrap();
    let output = shunt(&session, "1s", "6s");
    assert!(output.status.success(), "{}", stderr(&output));
    assert!(std::fs::read(&rig).unwrap() == rig_text, "the rig kept");
    let record = acq_io::shunt_record::read(&session).unwrap().unwrap();
    let check = record.sensor("sg01").unwrap();
    assert!((check.gain - 1.0 / 1.004).abs() < 5e-4, "{check:?}");
    assert!((check.switched_s - 3.0).abs() < 0.1, "{check:?}");
    assert!(
        check.gain_standard_uncertainty > 0.0017 && check.gain_standard_uncertainty < 0.0020,
        "{check:?}"
    );

    let csv = temp.path().join("measured.csv");
    let output = acq(&[
        "extract",
        path_arg(&session),
        "--rig",
        path_arg(&rig),
        "-o",
        path_arg(&csv),
    ]);
    assert!(output.status.success(), "{}", stderr(&output));
    let rows = measured_rows(&csv);
    let sg01 = rows.iter().find(|r| r["quantity"] == "sg01").unwrap();
    let mean = number_in(sg01, "mean");
    assert!(
        (mean - shunt_stress_mpa()).abs() < 0.1,
        "{mean} against {}",
        shunt_stress_mpa()
    );
    assert!(sg01["shared"].contains("sg01 shunt of"), "{sg01:?}");
    // The gain's part is u_gain times the uncorrected value.
    assert!(number_in(sg01, "u_c") > check.gain_standard_uncertainty * mean.abs() / check.gain);

    let output = shunt(&session, "0.5s", "2.5s");
    assert_eq!(output.status.code(), Some(2), "{}", stderr(&output));
    assert!(stderr(&output).contains("no step"), "{}", stderr(&output));

    let faulty_dir = temp.path().join("faulty");
    std::fs::create_dir(&faulty_dir).unwrap();
    let faulty = shunt_session(&faulty_dir, &rig, 1.03);
    let output = shunt(&faulty, "1s", "6s");
    assert_eq!(output.status.code(), Some(2), "{}", stderr(&output));
    let said = stderr(&output);
    assert!(
        said.contains("-1799.")
            && said.contains("-1746.9")
            && said.contains("beyond the 1 % tolerance"),
        "{said}"
    );
    assert!(!faulty.join("shunt.toml").exists());
}

/// A strain gauge's own sources, against the GUM's formulas by hand at
/// 200 MPa: a gauge factor of +-1 % (a span error, rectangular: 200 x
/// 0.01 / sqrt 3), a modulus of 210 +- 4 GPa (standard: the stress is
/// E eps, so 200 x 4 / 210), and a data sheet's zero drift of 0.02 % of
/// its 1000 MPa span and span drift of 0.01 % of the reading per kelvin
/// over 5-35 C against a 20 C calibration (15 K at most, rectangular).
#[test]
fn a_gauges_span_errors_and_temperature_drift_are_its_own_and_scale_as_the_gum_says() {
    let dir = tempfile::tempdir().unwrap();
    let rig = dir.path().join("rig.toml");
    std::fs::write(
        &rig,
        "[rig]\nname = \"gauge\"\n\n[[bus]]\nname = \"daq\"\niface = \"can0\"\n\n[[sensor]]\nname = \"sg\"\nkind = \"strain\"\nunit = \"um/m\"\nrate_hz = 100\nyoungs_modulus_gpa = 210.0\nyoungs_modulus_uncertainty_gpa = 4.0\ngauge_factor_tolerance_pct = 1.0\nrange = [-500.0, 500.0]\ntemperature = { zero_pct_fs_per_k = 0.02, span_pct_per_k = 0.01, range_c = [5.0, 35.0] }\ncanopen = { node_id = 0x25, pdo = 1, byte = 0, type = \"int32\" }\n",
    )
    .unwrap();
    let output = acq(&[
        "budget",
        path_arg(&rig),
        "--sensor",
        "sg",
        "--at",
        "200",
        "--json",
    ]);
    assert!(output.status.success(), "{}", stderr(&output));
    let json: serde_json::Value = serde_json::from_str(&stdout(&output)).unwrap();
    let u = |source: &str| {
        json["contributions"][source]["u"]
            .as_f64()
            .unwrap_or(f64::NAN)
    };
    let expected = [
        ("gauge_factor", 200.0 * 0.01 / 3f64.sqrt()),
        ("youngs_modulus", 200.0 * 4.0 / 210.0),
        ("temperature_zero", 0.0002 * 1000.0 * 15.0 / 3f64.sqrt()),
        ("temperature_span", 0.0001 * 200.0 * 15.0 / 3f64.sqrt()),
    ];
    for (source, by_hand) in expected {
        assert!(
            (u(source) - by_hand).abs() < 1e-12 * by_hand,
            "{source}: {} vs {by_hand}",
            u(source)
        );
    }
    let u_c = expected.iter().map(|(_, u)| u * u).sum::<f64>().sqrt();
    assert!((json["u_c"].as_f64().unwrap() - u_c).abs() < 1e-12 * u_c);

    // Each key is refused where it means nothing, with the sensor's line.
    for (bad, says) in [
        (
            "gauge_factor_tolerance_pct = -1.0",
            "gauge_factor_tolerance_pct = -1",
        ),
        (
            "temperature = { zero_pct_fs_per_k = 0.02, range_c = [35.0, 5.0] }",
            "lowest first",
        ),
    ] {
        let text = std::fs::read_to_string(&rig)
            .unwrap()
            .replace("gauge_factor_tolerance_pct = 1.0\n", "")
            .replace("temperature = { zero_pct_fs_per_k = 0.02, span_pct_per_k = 0.01, range_c = [5.0, 35.0] }\n", "")
            .replace("rate_hz = 100\n", &format!("rate_hz = 100\n{bad}\n"));
        let bad_rig = dir.path().join("bad.toml");
        std::fs::write(&bad_rig, text).unwrap();
        let output = acq(&["check-rig", path_arg(&bad_rig)]);
        assert_eq!(output.status.code(), Some(2), "{bad}: {}", stderr(&output));
        assert!(
            stderr(&output).contains(says) && stderr(&output).contains(":8"),
            "{bad}: {}",
            stderr(&output)
        );
    }
}

/// A cylinder's bore and rod tolerances enter its net force as the
/// derivative of `F = (p_h - p_r) pi D^2 / 4 + p_r pi d^2 / 4` says, on the
/// shipped Case 1 session with its rig's boom cylinder stated +-0.05 mm
/// (bore 100 mm) and +-0.03 mm (rod 60 mm): the net force's variance grows
/// by exactly those two parts, computed here from the hold's means.
#[test]
fn a_cylinders_diameter_tolerances_enter_its_net_force_as_the_derivative_says() {
    let temp = tempfile::tempdir().unwrap();
    let session = common::copy_session("excavator_case1", &temp.path().join("case1"));
    let plain = temp.path().join("plain.csv");
    let output = acq(&["extract", path_arg(&session), "-o", path_arg(&plain)]);
    assert!(output.status.success(), "{}", stderr(&output));
    let rig_copy = std::fs::read_dir(session.join("rig"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .find(|p| p.extension().is_some_and(|e| e == "toml"))
        .unwrap();
    let text = std::fs::read_to_string(&rig_copy).unwrap();
    let stated = text.replacen(
        "name = \"boom\"\n",
        "name = \"boom\"\nbore_tolerance_mm = 0.05\nrod_tolerance_mm = 0.03\n",
        1,
    );
    assert_ne!(stated, text, "the rig copy names its boom cylinder");
    // Beside the copy: its DBC paths are local to the session's rig folder.
    let tolerant_rig = session.join("rig/tolerant.toml");
    std::fs::write(&tolerant_rig, &stated).unwrap();
    let tolerant = temp.path().join("tolerant.csv");
    let output = acq(&[
        "extract",
        path_arg(&session),
        "--rig",
        path_arg(&tolerant_rig),
        "-o",
        path_arg(&tolerant),
    ]);
    assert!(output.status.success(), "{}", stderr(&output));
    let row = |path: &Path, quantity: &str| {
        measured_rows(path)
            .into_iter()
            .find(|r| r["quantity"] == quantity)
            .unwrap()
    };
    let (head, rod) = (
        number_in(&row(&plain, "boom_head_pressure"), "mean"),
        number_in(&row(&plain, "boom_rod_pressure"), "mean"),
    );
    let pi = std::f64::consts::PI;
    let bore_part = 1e-4 * (head - rod) * pi * 100.0 / 2.0 * 0.05 / 3f64.sqrt();
    let rod_part = 1e-4 * rod * pi * 60.0 / 2.0 * 0.03 / 3f64.sqrt();
    let (before, after) = (
        number_in(&row(&plain, "boom_net_force"), "u_c"),
        number_in(&row(&tolerant, "boom_net_force"), "u_c"),
    );
    let expected = (before.powi(2) + bore_part.powi(2) + rod_part.powi(2)).sqrt();
    assert!(
        (after - expected).abs() < 1e-9 * expected,
        "u_c {after}, by hand {expected}"
    );
    assert!(row(&tolerant, "boom_net_force")["shared"].contains("boom cylinder's diameters"));
}

/// A sensor file's mistakes are refused with the rig's line (or the
/// file's) and what to do: a serial not in the file, a key stated in both
/// places, a serial with no sensor file, one serial entered twice, one
/// transducer named by two channels.
#[test]
fn a_sensor_files_mistakes_are_refused_with_their_line_and_what_to_do() {
    let dir = tempfile::tempdir().unwrap();
    let entry = "[[transducer]]\nserial = \"A1\"\nrange = [0.0, 400.0]\naccuracy = { percent_of_full_scale = 0.5 }\n";
    let sensor = |name: &str, node: u8, extra: &str| {
        format!("[[sensor]]\nname = \"{name}\"\nkind = \"pressure\"\nrate_hz = 100\ncanopen = {{ node_id = {node}, pdo = 1, byte = 0, type = \"int32\" }}\n{extra}\n")
    };
    let head = "[rig]\nname = \"records\"\nsensor_file = \"sensors.toml\"\n\n[[bus]]\nname = \"h\"\niface = \"can0\"\n\n";
    for (sensors_text, rig_text, says) in [
        (
            entry.to_string(),
            format!("{head}{}", sensor("p", 1, "serial = \"B2\"")),
            "serial 'B2' is not in",
        ),
        (
            entry.to_string(),
            format!(
                "{head}{}",
                sensor(
                    "p",
                    1,
                    "serial = \"A1\"\nresolution = 0.1\naccuracy = { percent_of_reading = 1.0 }"
                )
            ),
            "both the rig and the transducer's record",
        ),
        (
            entry.to_string(),
            format!(
                "[[bus]]\nname = \"h\"\niface = \"can0\"\n\n{}",
                sensor("p", 1, "serial = \"A1\"")
            ),
            "needs the rig's sensor file",
        ),
        (
            format!("{entry}{entry}"),
            format!("{head}{}", sensor("p", 1, "serial = \"A1\"")),
            "entered twice (first at line 1)",
        ),
        (
            entry.to_string(),
            format!(
                "{head}{}{}",
                sensor("p", 1, "serial = \"A1\""),
                sensor("q", 2, "serial = \"A1\"")
            ),
            "serial 'A1' is sensor 'p' already",
        ),
    ] {
        std::fs::write(dir.path().join("sensors.toml"), &sensors_text).unwrap();
        let rig = dir.path().join("rig.toml");
        std::fs::write(&rig, &rig_text).unwrap();
        let output = acq(&["check-rig", path_arg(&rig)]);
        let message = stderr(&output);
        assert_eq!(output.status.code(), Some(2), "{says}: {message}");
        assert!(message.contains(says), "{says}: {message}");
        assert!(message.contains("rig.toml:"), "the rig's line: {message}");
    }
}

/// A certificate that states a polynomial: the value is the polynomial
/// of the reading (here v = 0.05 + 1.002 r + 2e-5 r^2, so 150.8 bar reads
/// 150 exactly: the quadratic's root), its expanded uncertainty 0.3 bar
/// at k = 2 is the curve's 0.15 bar everywhere; points beside it, or no
/// uncertainty, are refused.
#[test]
fn a_polynomial_certificate_converts_and_states_its_uncertainty() {
    let dir = tempfile::tempdir().unwrap();
    let certificate = "range = [0.0, 400.0]\ncalibration = { polynomial = [0.05, 1.002, 2e-5], expanded_uncertainty = 0.3, k = 2.0, level = 0.95, certificate = \"P-1\" }";
    let rig = rig_with(dir.path(), certificate);
    let json = budget_json(&rig, 150.8);
    assert!(
        (json["contributions"]["calibration_curve"]["u"]
            .as_f64()
            .unwrap()
            - 0.15)
            .abs()
            < 1e-15
    );
    let table = acq(&["budget", path_arg(&rig), "--sensor", "p", "--at", "150.8"]);
    assert!(
        stdout(&table).contains("(channel reading 150)")
            || stdout(&table).contains("(channel reading 150.000000)"),
        "{}",
        stdout(&table)
    );
    for (record, says) in [
        ("range = [0.0, 400.0]\ncalibration = { polynomial = [0.05, 1.002], points = [[0.0, 0.0], [1.0, 1.0], [2.0, 2.0]], expanded_uncertainty = 0.3, k = 2.0, level = 0.95 }", "points or its polynomial, not both"),
        ("calibration = { polynomial = [0.05, 1.002] }", "needs the certificate's expanded_uncertainty"),
        ("range = [0.0, 400.0]\ncalibration = { polynomial = [0.0, 1.0, -0.002], expanded_uncertainty = 0.3, k = 2.0, level = 0.95 }", "the polynomial"),
        ("calibration = { polynomial = [5.0], expanded_uncertainty = 0.3, k = 2.0, level = 0.95 }", "with a term in r"),
    ] {
        let rig = rig_with(dir.path(), record);
        let output = acq(&["check-rig", path_arg(&rig)]);
        assert_eq!(output.status.code(), Some(2), "{record}: {}", stderr(&output));
        assert!(stderr(&output).contains(says), "{record}: {}", stderr(&output));
    }
}

/// `acq budget --cylinder --monte-carlo`: the net force's budget checked by
/// Monte Carlo (JCGM 101). On the shipped rig each chamber's transducer is
/// +-0.5 % of 600 bar, rectangular, so the force's error is the sum of two
/// rectangles of half-widths a = 3 bar x the head area and b = 3 bar x the
/// annulus: a trapezoid, whose 97.5 % quantile is `a + b - sqrt(0.2 a b)`
/// in closed form (valid for b > 0.05 a). The law's u_c is exact for a
/// linear model and Monte Carlo agrees with it (within 0.3 %, some five of
/// its standard errors at 1e6 draws); the 95 % interval is the trapezoid's
/// (within 0.5 %: its quantile's standard error is about 0.1 %), 4.5 %
/// narrower than k u_c, which assumes a normal result.
#[test]
fn a_net_forces_monte_carlo_interval_is_the_trapezoids_in_closed_form() {
    let rig = common::root().join("fixtures/rigs/excavator.toml");
    let output = acq(&[
        "budget",
        path_arg(&rig),
        "--cylinder",
        "boom",
        "--head",
        "100",
        "--rod",
        "5",
        "--monte-carlo",
        "1000000",
        "--json",
    ]);
    assert!(output.status.success(), "{}", stderr(&output));
    let json: serde_json::Value = serde_json::from_str(&stdout(&output)).unwrap();
    assert_eq!(json["sensor"], "boom_net_force");
    let pi = std::f64::consts::PI;
    let (head_area, annulus) = (
        pi * 100.0f64.powi(2) / 4.0,
        pi * (100.0f64.powi(2) - 60.0f64.powi(2)) / 4.0,
    );
    let (a, b) = (3.0 * head_area * 1e-4, 3.0 * annulus * 1e-4);
    let value = 1e-4 * (100.0 * head_area - 5.0 * annulus);
    assert!((json["value"].as_f64().unwrap() - value).abs() < 1e-9);
    let u_c = json["u_c"].as_f64().unwrap();
    // The rectangles' variances, and the resolutions' (0.01 bar steps).
    let by_hand = ((a * a + b * b) / 3.0
        + ((head_area * 1e-4).powi(2) + (annulus * 1e-4).powi(2)) * 0.01f64.powi(2) / 12.0)
        .sqrt();
    assert!(
        (u_c - by_hand).abs() < 1e-12 * by_hand,
        "{u_c} vs {by_hand}"
    );
    let mc = &json["monte_carlo"];
    let mc_u = mc["u"].as_f64().unwrap();
    assert!(
        (mc_u / u_c - 1.0).abs() < 0.003,
        "Monte Carlo u {mc_u} against the law's {u_c}"
    );
    let interval = mc["interval_95"].as_array().unwrap();
    let half = (interval[1].as_f64().unwrap() - interval[0].as_f64().unwrap()) / 2.0;
    let trapezoid = a + b - (0.2 * a * b).sqrt();
    assert!(
        (half / trapezoid - 1.0).abs() < 0.005,
        "half-width {half} against the trapezoid's {trapezoid}"
    );
    assert!(half < 0.97 * json["U95"].as_f64().unwrap());
}

/// A data sheet that states its accuracy class's parts: non-linearity
/// 0.2 %, hysteresis 0.1 % and repeatability 0.05 % of a 400 bar span,
/// each rectangular; the first two are the transducer's in every hold,
/// repeatability each reading's own. Stating the class beside its parts is
/// refused (it would count them twice).
#[test]
fn a_data_sheets_parts_of_its_class_are_each_a_source() {
    let dir = tempfile::tempdir().unwrap();
    let rig = rig_with(
        dir.path(),
        "range = [0.0, 400.0]\naccuracy = { nonlinearity_pct_fs = 0.2, hysteresis_pct_fs = 0.1, repeatability_pct_fs = 0.05 }",
    );
    let json = budget_json(&rig, 150.0);
    for (source, pct) in [
        ("nonlinearity", 0.2),
        ("hysteresis", 0.1),
        ("repeatability", 0.05),
    ] {
        let by_hand = pct / 100.0 * 400.0 / 3f64.sqrt();
        let u = json["contributions"][source]["u"].as_f64().unwrap();
        assert!((u - by_hand).abs() < 1e-12, "{source}: {u} vs {by_hand}");
    }
    assert!(json["contributions"]["accuracy_class"].is_null());
    let both = rig_with(
        dir.path(),
        "range = [0.0, 400.0]\naccuracy = { percent_of_full_scale = 0.5, nonlinearity_pct_fs = 0.2 }",
    );
    let output = acq(&["check-rig", path_arg(&both)]);
    assert_eq!(output.status.code(), Some(2), "{}", stderr(&output));
    assert!(stderr(&output).contains("not both"), "{}", stderr(&output));
}

/// Wrong successes, round four: a budget is a number or an error. A value
/// past what a certificate's polynomial reaches (`[0, 2, -0.01]` peaks at
/// 100 bar), and a value so large that the budget overflows (a sensor with
/// no range, a cylinder whose sensors have none), are refused with exit 2,
/// where a budget of `"u_c": null` was printed with exit 0.
#[test]
fn a_budget_is_a_number_or_an_error() {
    let dir = tempfile::tempdir().unwrap();
    let rig = rig_with(
        dir.path(),
        "calibration = { polynomial = [0.0, 2.0, -0.01], expanded_uncertainty = 0.2, k = 2.0, level = 0.95 }",
    );
    let budget = |rig: &Path, args: &[&str]| {
        let mut all = vec!["budget", path_arg(rig)];
        all.extend_from_slice(args);
        acq(&all)
    };
    let reached = budget(&rig, &["--sensor", "p", "--at", "50"]);
    assert!(reached.status.success(), "{}", stderr(&reached));
    let past = budget(&rig, &["--sensor", "p", "--at", "150"]);
    assert_eq!(past.status.code(), Some(2), "{}", stderr(&past));
    assert!(
        stderr(&past).contains("no reading gives 150 bar"),
        "{}",
        stderr(&past)
    );

    let second = "\n[[sensor]]\nname = \"r\"\nkind = \"pressure\"\nrate_hz = 100\ncanopen = { node_id = 0x26, pdo = 1, byte = 0, type = \"int32\", decimal_digits = 2 }\naccuracy = { percent_of_reading = 0.5 }\n\n[[cylinder]]\nname = \"boom\"\nbore_mm = 100\nrod_mm = 60\nhead_sensor = \"p\"\nrod_sensor = \"r\"\n";
    let rig = rig_with(
        dir.path(),
        &format!("accuracy = {{ percent_of_reading = 0.5 }}\n{second}"),
    );
    for args in [
        vec!["--sensor", "p", "--at", "1e308"],
        vec!["--cylinder", "boom", "--head", "1e300", "--rod", "0"],
    ] {
        let output = budget(&rig, &args);
        let told = stderr(&output);
        assert_eq!(output.status.code(), Some(2), "{args:?}: {told}");
        assert!(
            told.contains("is not a number") && told.contains("e30"),
            "{args:?}: {told}"
        );
        assert!(stdout(&output).is_empty(), "{args:?}");
    }
    let fine = budget(
        &rig,
        &[
            "--cylinder",
            "boom",
            "--head",
            "100",
            "--rod",
            "20",
            "--json",
        ],
    );
    assert!(fine.status.success(), "{}", stderr(&fine));
    assert!(!stdout(&fine).contains("\"u_c\":null"), "{}", stdout(&fine));
    // A sensor with nothing on record: its budget is 0, never "-0".
    let bare = budget(
        &common::root().join("fixtures/rigs/excavator.toml"),
        &["--sensor", "sg09", "--at", "50", "--json"],
    );
    assert!(bare.status.success(), "{}", stderr(&bare));
    let json = stdout(&bare);
    assert!(
        json.contains("\"u_c\":0.0") && !json.contains("-0.0"),
        "{json}"
    );
}

/// The number before `s at most` in an `acq zero` message: the window it
/// advises.
fn advised_window(told: &str, flag: &str) -> String {
    let from = told.find(&format!("give {flag} ")).expect(told) + flag.len() + 6;
    told[from..].split("s at most").next().unwrap().to_string() + "s"
}

/// A window inside a hold is steady, so the quarters cannot see it: a
/// before window that reaches into case 1's hold (under load from 3.5 s)
/// and an after window that reaches back into it are refused by the hold,
/// and the window each message advises is taken. A recording that starts
/// under load (logger files from the middle of the hold, imported) has no
/// rest before the test, and says so.
#[test]
fn a_zero_window_that_reaches_into_a_hold_is_refused_with_one_that_works() {
    let temp = tempfile::tempdir().unwrap();
    let session = common::copy_session("excavator_case1", temp.path());
    let zero = |session: &Path, args: &[&str]| {
        let mut all = vec!["zero", path_arg(session)];
        all.extend_from_slice(args);
        let output = acq(&all);
        let told = stderr(&output);
        (output.status.code(), told)
    };
    let (code, told) = zero(&session, &["--before", "5s"]);
    assert_eq!(code, Some(2), "{told}");
    assert!(told.contains("--before 5 s reaches into hold1"), "{told}");
    let before = advised_window(&told, "--before");
    let (code, told) = zero(&session, &["--before", "0.5s", "--after", "5s"]);
    assert_eq!(code, Some(2), "{told}");
    assert!(
        told.contains("--after 5 s reaches back into hold1"),
        "{told}"
    );
    assert!(!session.join("zero.toml").exists());
    let after = advised_window(&told, "--after");
    let (code, told) = zero(&session, &["--before", &before, "--after", &after]);
    assert_eq!(code, Some(0), "--before {before} --after {after}: {told}");

    let raw = std::fs::read_to_string(session.join("raw.log")).unwrap();
    let time = |line: &str| -> f64 { line[1..line.find(')').unwrap()].parse().unwrap() };
    let first = time(raw.lines().next().unwrap());
    let under_load: String = raw
        .lines()
        .filter(|line| time(line) >= first + 5.0)
        .map(|line| format!("{line}\n"))
        .collect();
    let log = temp.path().join("from_the_hold.log");
    std::fs::write(&log, under_load).unwrap();
    let imported = temp.path().join("imported");
    let rig = session.join("rig/excavator.toml");
    let output = acq(&[
        "import",
        path_arg(&log),
        "--rig",
        path_arg(&rig),
        "--out",
        path_arg(&imported),
    ]);
    assert!(output.status.success(), "{}", stderr(&output));
    let (code, told) = zero(&imported, &["--before", "1s"]);
    assert_eq!(code, Some(2), "{told}");
    assert!(told.contains("the recording starts under load"), "{told}");
    assert!(!imported.join("zero.toml").exists());
}

/// Wrong successes, round four: a zero window is a rest inside the
/// recording or nothing is written. A window longer than the recording
/// (the "zero" was the whole test's mean), windows before and after that
/// overlap, and a window that runs into the load ramp (the rod pressure
/// climbs by hundreds of bar where it scatters by a fraction of one) are
/// refused, each named; a zeroed value a little under its range's start is
/// the zero's, and no longer flagged "saturated".
#[test]
fn a_zero_window_is_a_rest_inside_the_recording_or_it_is_refused() {
    let temp = tempfile::tempdir().unwrap();
    let session = common::copy_session("excavator_case2", temp.path());
    let zero = |args: &[&str]| {
        let mut all = vec!["zero", path_arg(&session)];
        all.extend_from_slice(args);
        acq(&all)
    };
    for (args, expected) in [
        (vec!["--before", "30s"], "the recording is 14.3 s long"),
        (
            vec!["--before", "1s", "--after", "30s"],
            "overlap in a recording 14.3 s long",
        ),
        (vec!["--before", "10s", "--after", "10s"], "overlap"),
        (
            vec!["--before", "3s"],
            "boom_rod_pressure: not at rest in the before window",
        ),
    ] {
        let output = zero(&args);
        let told = stderr(&output);
        assert_eq!(output.status.code(), Some(2), "{args:?}: {told}");
        assert!(told.contains(expected), "{args:?}: {told}");
        assert!(
            !session.join("zero.toml").exists(),
            "{args:?}: nothing written"
        );
    }
    // The rest before the ramp: taken. Its rod pressures, about 5 bar at
    // rest, read a few tenths of a bar once zeroed: inside what the zero
    // moved, not at the end of the range [0, 600] bar.
    let rest = zero(&["--before", "0.5s"]);
    assert!(rest.status.success(), "{}", stderr(&rest));
    let out = temp.path().join("measured.csv");
    let extracted = acq(&["extract", path_arg(&session), "-o", path_arg(&out)]);
    assert!(extracted.status.success(), "{}", stderr(&extracted));
    let rows = measured_rows(&out);
    let bucket_rod = rows
        .iter()
        .find(|row| row["quantity"] == "bucket_rod_pressure")
        .unwrap();
    let mean: f64 = bucket_rod["mean"].parse().unwrap();
    assert!(mean.abs() < 0.6, "{bucket_rod:?}");
    assert!(!bucket_rod["flags"].contains("saturated"), "{bucket_rod:?}");
    // A tensile test loads from its second second: its first 3 s hold the
    // start of the rise (a zero of 1.3 kN once taken), refused; its first
    // second is a rest.
    let tensile = common::copy_session("tensile_p91_20c", &temp.path().join("tensile"));
    let rising = acq(&["zero", path_arg(&tensile), "--before", "3s"]);
    assert_eq!(rising.status.code(), Some(2), "{}", stderr(&rising));
    assert!(
        stderr(&rising).contains("load: not at rest in the before window"),
        "{}",
        stderr(&rising)
    );
    let resting = acq(&["zero", path_arg(&tensile), "--before", "1s"]);
    assert!(resting.status.success(), "{}", stderr(&resting));
}
