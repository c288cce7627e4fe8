//! `acq decode` and `acq check-rig` driven as a user drives them: the real
//! binary, the shipped fixtures, exit codes and messages.

mod common;
// The guide's command lines and quoted outputs against the program.
#[path = "cli/guide.rs"]
mod guide;
use common::{acq, root, stderr, stdout};
use std::io::Write;
use std::path::PathBuf;
use std::process::{Command, Stdio};

fn fixture(path: &str) -> PathBuf {
    root().join("fixtures").join(path)
}

/// Rows of `time_s,sensor,value,unit` for one sensor: (time text, value text).
fn sensor_rows(csv: &str, sensor: &str) -> Vec<(String, String)> {
    csv.lines()
        .skip(1)
        .map(|l| l.split(',').collect::<Vec<_>>())
        .filter(|f| f[1] == sensor)
        .map(|f| (f[0].to_string(), f[2].to_string()))
        .collect()
}

fn assert_close(actual: &str, expected: f64, tolerance: f64, what: &str) {
    let value: f64 = actual
        .parse()
        .unwrap_or_else(|_| panic!("{what}: '{actual}' is not a number"));
    assert!(
        (value - expected).abs() <= tolerance,
        "{what}: {value} vs {expected} (tolerance {tolerance})"
    );
}

#[test]
fn dbc_route_has_the_fixed_header_and_columns() {
    let output = acq(&[
        "decode",
        "fixtures/logs/excavator_case1.log",
        "--dbc",
        "fixtures/dbc/somat_excavator.dbc",
    ]);
    assert!(output.status.success(), "{}", stderr(&output));
    let csv = stdout(&output);
    let mut lines = csv.lines();
    assert_eq!(
        lines.next(),
        Some("time_s,iface,can_id,message,signal,value,unit")
    );
    let first = lines.next().unwrap();
    assert_eq!(
        first,
        "1763719200.001050,can1,0x300,DAQ_Force,TipForce,40.599998474121094,kN"
    );
    assert!(
        csv.contains("\n1763719200.001050,can1,0x300,DAQ_Force,ForceStatus,0,\n"),
        "{csv}"
    );
    assert!(csv.contains(",can1,0x314,DAQ_SG_09_10,SG09,491.3333435058594,um/m\n"));
    // 3 cycles x (2 + 18) signals.
    assert_eq!(csv.lines().count(), 1 + 3 * 20);
    let summary = stderr(&output);
    assert!(
        summary.contains("frames read 60, decoded 30, unknown 29, bad 0"),
        "{summary}"
    );
    assert!(summary.contains("error frames 1"), "{summary}");
}

#[test]
fn labels_column_on_request() {
    let output = acq(&[
        "decode",
        "fixtures/logs/excavator_case1.log",
        "--dbc",
        "fixtures/dbc/somat_excavator.dbc",
        "--labels",
    ]);
    let csv = stdout(&output);
    assert!(csv.starts_with("time_s,iface,can_id,message,signal,value,unit,label\n"));
    assert!(csv.contains(",ForceStatus,0,,ok\n"), "{csv}");
}

#[test]
fn rig_route_gives_hand_checked_engineering_values() {
    let output = acq(&[
        "decode",
        "fixtures/logs/excavator_case1.log",
        "--rig",
        "fixtures/rigs/excavator.toml",
    ]);
    assert!(output.status.success(), "{}", stderr(&output));
    let csv = stdout(&output);
    assert!(csv.starts_with("time_s,sensor,value,unit\n"));
    // Case-1 measured pressures (bar), sent with 0.01 bar resolution: exact.
    for (sensor, bar) in [
        ("bucket_head_pressure", "116.89"),
        ("arm_head_pressure", "193.46"),
        ("boom_head_pressure", "73.35"),
    ] {
        let rows = sensor_rows(&csv, sensor);
        assert_eq!(rows.len(), 3, "{sensor}");
        assert!(rows.iter().all(|(_, v)| v == bar), "{sensor}: {rows:?}");
        assert!(csv.contains(&format!(",{sensor},{bar},bar\n")));
    }
    // Tooth load 40.6 kN and gauge stresses, sent as float32 (7 digits).
    assert_close(
        &sensor_rows(&csv, "tip_force")[0].1,
        40.6,
        1e-5,
        "tip_force",
    );
    assert_close(&sensor_rows(&csv, "sg09")[0].1, 103.18, 1e-4, "sg09 MPa");
    assert_close(&sensor_rows(&csv, "sg03")[0].1, 17.83, 1e-4, "sg03 MPa");
    assert_close(&sensor_rows(&csv, "sg04")[0].1, 75.46, 1e-4, "sg04 MPa");
    // Inclinometers: 1/32768 deg resolution.
    assert_close(
        &sensor_rows(&csv, "boom_inclination")[0].1,
        12.03,
        1.0 / 32768.0,
        "boom",
    );
    assert_eq!(sensor_rows(&csv, "bucket_inclination")[0].1, "-74.25");
    // The arm slope sensor's "not available" is an empty value, never a number.
    let arm = sensor_rows(&csv, "arm_inclination");
    assert_eq!(arm.len(), 2);
    assert_eq!(arm[0].1, "-42.5");
    assert_eq!(arm[1], ("1763719200.021700".to_string(), String::new()));
    assert!(csv.contains("\n1763719200.021700,arm_inclination,,deg\n"));
    let notes = stderr(&output);
    assert!(
        notes.contains("CANopen node 0x25 (boom_head_pressure) is Operational"),
        "{notes}"
    );
    assert!(
        notes.contains("unknown 1"),
        "the SYNC frame is not a sensor: {notes}"
    );
}

#[test]
fn tensile_fixture_decodes_to_the_p91_curve_start() {
    let output = acq(&[
        "decode",
        "fixtures/logs/tensile_p91_start.log",
        "--rig",
        "fixtures/rigs/tensile.toml",
    ]);
    assert!(output.status.success(), "{}", stderr(&output));
    let csv = stdout(&output);
    let load = sensor_rows(&csv, "load");
    let extension = sensor_rows(&csv, "extension");
    // First rows of P91_20_2_DF_SS.csv, at the controller's resolution (10 N, 1.25 nm).
    for (i, (mm, kn)) in [
        (0.0, 0.0),
        (0.01352, 3.048853771),
        (0.014603333, 3.38232208),
        (0.01677, 4.054363011),
    ]
    .iter()
    .enumerate()
    {
        assert_close(&load[i].1, *kn, 0.5e-5, "load kN");
        assert_close(&extension[i].1, *mm, 1e-6, "extension mm");
    }
    assert_close(
        &sensor_rows(&csv, "crosshead")[1].1,
        0.027,
        1e-12,
        "crosshead mm",
    );
}

#[test]
fn stdin_and_output_file() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out.csv");
    let mut child = Command::new(env!("CARGO_BIN_EXE_acq"))
        .args([
            "decode",
            "-",
            "--dbc",
            "fixtures/dbc/tensile_frame.dbc",
            "-o",
            out.to_str().unwrap(),
        ])
        .current_dir(root())
        .stdin(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    child
        .stdin
        .take()
        .unwrap()
        .write_all(&std::fs::read(fixture("logs/tensile_p91_start.log")).unwrap())
        .unwrap();
    let output = child.wait_with_output().unwrap();
    assert!(output.status.success(), "{}", stderr(&output));
    let csv = std::fs::read_to_string(out).unwrap();
    assert!(
        csv.contains("1763719200.020000,can0,0x200,LoadFrame,LoadCell,3.0488500000000003,kN\n"),
        "{csv}"
    );
    assert!(
        csv.contains("1763719200.020000,can0,0x200,LoadFrame,Extensometer,0.010816,mV/V\n"),
        "{csv}"
    );
}

#[test]
fn malformed_line_stops_with_file_line_and_exit_3_unless_skipped() {
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("broken.log");
    std::fs::write(&log, "(1.000000) can0 200#0000000000000000\n(2.000000) can0 200#00112\n(3.000000) can0 200#0000000000000000\n").unwrap();
    let log = log.to_str().unwrap();
    let output = acq(&["decode", log, "--dbc", "fixtures/dbc/tensile_frame.dbc"]);
    assert_eq!(output.status.code(), Some(3));
    let message = stderr(&output);
    assert!(
        message.contains(&format!("{log}:2: expected an even number of hex digits")),
        "{message}"
    );
    // What came before the bad line is still written.
    assert!(stdout(&output).contains("1.000000,can0,0x200,LoadFrame,LoadCell,0,kN"));

    let output = acq(&[
        "decode",
        log,
        "--dbc",
        "fixtures/dbc/tensile_frame.dbc",
        "--skip-bad",
    ]);
    assert_eq!(output.status.code(), Some(0), "{}", stderr(&output));
    assert!(stdout(&output).contains("3.000000,can0,0x200"));
    assert!(
        stderr(&output).contains("bad 1 (1 malformed lines"),
        "{}",
        stderr(&output)
    );
}

#[test]
fn configuration_errors_exit_2_and_say_what_to_fix() {
    let output = acq(&[
        "decode",
        "fixtures/logs/tensile_p91_start.log",
        "--dbc",
        "no/such.dbc",
    ]);
    assert_eq!(output.status.code(), Some(2));
    assert!(
        stderr(&output).contains("no/such.dbc"),
        "{}",
        stderr(&output)
    );

    let output = acq(&[
        "decode",
        "no/such.log",
        "--dbc",
        "fixtures/dbc/tensile_frame.dbc",
    ]);
    assert_eq!(output.status.code(), Some(2));
    assert!(
        stderr(&output).contains("cannot open no/such.log"),
        "{}",
        stderr(&output)
    );

    let output = acq(&["decode", "fixtures/logs/tensile_p91_start.log"]);
    assert_eq!(
        output.status.code(),
        Some(2),
        "neither --dbc nor --rig is a usage error"
    );

    let output = acq(&[
        "decode",
        "-",
        "-",
        "--dbc",
        "fixtures/dbc/tensile_frame.dbc",
    ]);
    assert_eq!(output.status.code(), Some(2));
}

#[test]
fn check_rig_explains_every_problem_with_its_line() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::copy(
        fixture("dbc/tensile_frame.dbc"),
        dir.path().join("frame.dbc"),
    )
    .unwrap();
    let rig = dir.path().join("bad.toml");
    std::fs::write(
        &rig,
        r#"[[bus]]
name = "frame"
iface = "can0"
dbc = ["frame.dbc", "missing.dbc"]

[[sensor]]
name = "load"
kind = "force"
rate_hz = 0
dbc = { message = "LoadFrame", signal = "LoadCel" }

[[sensor]]
name = "p1"
kind = "pressure"
rate_hz = 100
canopen = { node_id = 1, pdo = 1, byte = 0, type = "int16" }

[[sensor]]
name = "p2"
kind = "pressure"
rate_hz = 100
canopen = { node_id = 1, pdo = 1, byte = 1, type = "int16" }

[[sensor]]
name = "gauge"
kind = "strain"
rate_hz = 100
unit = "mV/V"
youngs_modulus_gpa = 210
dbc = { message = "LoadFrame", signal = "Extensometer" }
"#,
    )
    .unwrap();
    let output = acq(&["check-rig", rig.to_str().unwrap()]);
    assert_eq!(output.status.code(), Some(2));
    let message = stderr(&output);
    for needle in [
        "bad.toml:1: bus 'frame': DBC file",
        "missing.dbc not found",
        "bad.toml:6: sensor 'load': rate_hz must be a number of samples per second above 0",
        "bad.toml:6: sensor 'load': unknown signal 'LoadCel' in DBC message 'LoadFrame' (signals: LoadCell, Extensometer)",
        "bad.toml:18: sensor 'p2' reads the same value as sensor 'p1' (line 12)",
        "bad.toml:24: sensor 'gauge': a mV/V channel needs gauge_factor",
    ] {
        assert!(message.contains(needle), "missing '{needle}' in:\n{message}");
    }

    std::fs::write(
        &rig,
        "[[sensor]]\nname = \"x\"\nkind = \"presure\"\nrate_hz = 1\n",
    )
    .unwrap();
    let output = acq(&["check-rig", rig.to_str().unwrap()]);
    assert_eq!(output.status.code(), Some(2));
    assert!(
        stderr(&output).contains("bad.toml:3: unknown variant `presure`"),
        "{}",
        stderr(&output)
    );

    let output = acq(&["check-rig", "fixtures/rigs/excavator.toml"]);
    assert!(output.status.success(), "{}", stderr(&output));
    assert!(stdout(&output).contains("28 sensors"));
}

#[test]
fn asc_log_decodes_to_the_same_samples_as_the_candump_log() {
    let decode = |log: &str| {
        let output = acq(&["decode", log, "--rig", "fixtures/rigs/excavator.toml"]);
        assert!(output.status.success(), "{log}: {}", stderr(&output));
        stdout(&output)
    };
    let candump = decode("fixtures/logs/excavator_case1.log");
    let asc = decode("fixtures/logs/excavator_case1.asc");
    let rows = |csv: &str| -> Vec<(f64, String)> {
        csv.lines()
            .skip(1)
            .map(|l| {
                let (time, rest) = l.split_once(',').unwrap();
                (time.parse().unwrap(), rest.to_string())
            })
            .collect()
    };
    let (candump, asc) = (rows(&candump), rows(&asc));
    assert_eq!(candump.len(), 79);
    assert_eq!(candump.len(), asc.len());
    for (c, a) in candump.iter().zip(&asc) {
        assert_eq!(c.1, a.1);
        // ASC times count from the `date` header, 2025-11-21 10:00:00.
        assert!((c.0 - 1_763_719_200.0 - a.0).abs() < 1e-6, "{c:?} vs {a:?}");
    }
}

#[test]
fn record_on_a_missing_interface_says_how_to_create_it() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("session");
    let output = acq(&[
        "record",
        "--iface",
        "vcan97",
        "--out",
        out.to_str().unwrap(),
        "--duration",
        "1s",
    ]);
    assert_eq!(output.status.code(), Some(2), "{}", stderr(&output));
    let message = stderr(&output);
    assert!(message.contains("vcan97 does not exist"), "{message}");
    assert!(
        message.contains("sudo ip link add dev vcan97 type vcan"),
        "{message}"
    );
    assert!(!out.exists(), "a failed start leaves no session directory");
}

#[test]
fn record_and_replay_refuse_bad_arguments() {
    let output = acq(&["record", "--iface", "vcan0", "--max-file-size", "lots"]);
    assert_eq!(output.status.code(), Some(2));
    assert!(
        stderr(&output).contains("not a size like 1GiB"),
        "{}",
        stderr(&output)
    );
    let output = acq(&["replay", "missing.log", "--iface", "vcan0"]);
    assert_eq!(output.status.code(), Some(2));
    assert!(
        stderr(&output).contains("cannot open missing.log"),
        "{}",
        stderr(&output)
    );
    let output = acq(&[
        "replay",
        "fixtures/logs/excavator_case1.log",
        "--map",
        "can0",
    ]);
    assert_eq!(output.status.code(), Some(2));
    assert!(
        stderr(&output).contains("expected LOG_IFACE=BUS_IFACE"),
        "{}",
        stderr(&output)
    );
}

#[test]
fn simulate_to_a_log_is_deterministic_and_decodes_to_the_scenario() {
    let dir = tempfile::tempdir().unwrap();
    let run = |name: &str, seed: &str| {
        let path = dir.path().join(name);
        let output = acq(&[
            "simulate",
            "--rig",
            "fixtures/rigs/excavator.toml",
            "--scenario",
            "fixtures/scenarios/excavator_case1.toml",
            "-o",
            path.to_str().unwrap(),
            "--seed",
            seed,
            "--start",
            "1763719200",
        ]);
        assert!(output.status.success(), "{}", stderr(&output));
        std::fs::read_to_string(path).unwrap()
    };
    let first = run("a.log", "5");
    assert_eq!(first, run("b.log", "5"), "same seed, same traffic");
    assert_ne!(first, run("c.log", "6"), "another seed, other noise");
    // Boot-up then heartbeats from each CANopen node.
    assert!(first.contains(" can0 721#00\n") && first.contains(" can0 721#05\n"));
    let decoded = acq(&[
        "decode",
        dir.path().join("a.log").to_str().unwrap(),
        "--rig",
        "fixtures/rigs/excavator.toml",
    ]);
    assert!(decoded.status.success(), "{}", stderr(&decoded));
    let csv = stdout(&decoded);
    // The hold is 3..11 s after the start: its mean is the scenario's value
    // within 4 standard errors (noise 0.4 bar, about 800 samples).
    for (sensor, hold, noise) in [
        ("arm_head_pressure", 193.46, 0.4),
        ("sg09", 103.18, 0.15),
        ("tip_force", 40.6, 0.08),
    ] {
        let values: Vec<f64> = sensor_rows(&csv, sensor)
            .iter()
            .filter(|(t, _)| {
                let t: f64 = t.parse::<f64>().unwrap() - 1763719200.0;
                (3.2..10.8).contains(&t)
            })
            .map(|(_, v)| v.parse().unwrap())
            .collect();
        assert!(values.len() > 700, "{sensor}: {} samples", values.len());
        let mean = values.iter().sum::<f64>() / values.len() as f64;
        let tolerance = 4.0 * noise / (values.len() as f64).sqrt();
        assert!(
            (mean - hold).abs() < tolerance,
            "{sensor}: mean {mean} vs {hold} +- {tolerance}"
        );
    }
}

#[test]
fn a_scenario_of_several_holds_gives_acq_extract_each_hold_at_its_levels() {
    let dir = tempfile::tempdir().unwrap();
    // Three loads, the middle one the largest, the last the shortest; the
    // pressure follows the load, the inclinometers hold their pose.
    let text = simulate_and_extract(
        dir.path(),
        r#"name = "three holds"
[timeline]
idle_s = 1.0
build_up_s = 1.5
hold_s = 6.0
release_s = 1.5
after_s = 2.0
[sensor.tip_force]
idle = 0.0
hold = 30.0
noise = 0.08
[sensor.arm_head_pressure]
idle = 10.0
hold = 150.0
noise = 0.4
[sensor.boom_inclination]
idle = 12.0
[[hold]]
level = { tip_force = 20.0, arm_head_pressure = 100.0 }
[[hold]]
level = { tip_force = 40.6, arm_head_pressure = 193.46 }
[[hold]]
hold_s = 5.5
level = { tip_force = 30.0 }
"#,
    );
    let mean = |window: &str, quantity: &str| measured_mean(&text, window, quantity);
    // The timeline: idle 1 s, then per hold 1.5 s up, the hold, 1.5 s down
    // and 2 s idle: steady over 2.5-8.5, 13.5-19.5 and 24.5-30 s.
    let windows: Vec<(f64, f64)> = ["hold1", "hold2", "hold3"]
        .iter()
        .map(|w| {
            let row: Vec<&str> = text
                .lines()
                .find(|l| l.starts_with(&format!("{w},")))
                .unwrap_or_else(|| panic!("no {w} in\n{text}"))
                .split(',')
                .collect();
            (row[1].parse().unwrap(), row[2].parse().unwrap())
        })
        .collect();
    assert!(!text.contains("hold4,"), "{text}");
    for ((start, end), (from, to)) in windows.iter().zip([(2.5, 8.5), (13.5, 19.5), (24.5, 30.0)]) {
        assert!(
            *start >= from && *end <= to && end - start >= 3.0,
            "{start}-{end} in {from}-{to}"
        );
    }
    for (window, force, pressure) in [
        ("hold1", 20.0, 100.0),
        ("hold2", 40.6, 193.46),
        // Not named in the third hold: the sensor's `hold`.
        ("hold3", 30.0, 150.0),
    ] {
        assert!((mean(window, "tip_force") - force).abs() < 0.05, "{window}");
        assert!(
            (mean(window, "arm_head_pressure") - pressure).abs() < 0.2,
            "{window}"
        );
        assert!(
            (mean(window, "boom_inclination") - 12.0).abs() < 0.05,
            "{window}"
        );
    }

    // A hold that names a sensor the rig does not have is refused, naming it.
    let scenario = dir.path().join("bad.toml");
    std::fs::write(
        &scenario,
        "name = \"x\"\n[[hold]]\nlevel = { no_such_sensor = 1.0 }\n",
    )
    .unwrap();
    let output = acq(&[
        "simulate",
        "--rig",
        "fixtures/rigs/excavator.toml",
        "--scenario",
        scenario.to_str().unwrap(),
        "-o",
        dir.path().join("bad.log").to_str().unwrap(),
    ]);
    assert_eq!(output.status.code(), Some(2));
    assert!(
        stderr(&output).contains("no_such_sensor"),
        "{}",
        stderr(&output)
    );
}

/// The excavator twin drives the virtual rig (`[twin]` in the scenario:
/// examples/excavator-rig/hidden_truth.toml): at each test point the levels
/// it computes at the hidden truth go through the rig's devices (CANopen
/// 0.01 bar, J1939 slope, DBC floats) and `acq extract` reads them back:
/// inclinations, gauge stresses, the tip force, and net cylinder forces
/// equal to the twin's axial forces at the truth.
#[test]
fn the_excavator_twin_drives_the_virtual_rig_and_acq_extract_reads_its_levels() {
    use acq_twins::excavator::geometry::GeometryTemplate;
    use acq_twins::excavator::inclinations::Inclinations;
    use acq_twins::excavator::{CylinderName, Excavator, Inputs};

    let scenario = std::fs::read_to_string("examples/excavator-rig/hidden_truth.toml").unwrap();
    let twin: toml::Table = toml::from_str(&scenario).unwrap();
    let twin = twin["twin"].as_table().unwrap();
    let truth: Vec<(String, f64)> = twin["truth"]
        .as_table()
        .unwrap()
        .iter()
        .map(|(k, v)| (k.clone(), v.as_float().unwrap()))
        .collect();
    let truth: Vec<(&str, f64)> = truth.iter().map(|(k, v)| (k.as_str(), *v)).collect();
    let geometry =
        GeometryTemplate::parse(&std::fs::read_to_string("data/excavator/dx55.toml").unwrap())
            .unwrap()
            .with(&truth)
            .unwrap();
    let excavator = Excavator::new(geometry.clone()).unwrap();

    let dir = tempfile::tempdir().unwrap();
    let text = simulate_and_extract_file(
        dir.path(),
        std::path::Path::new("examples/excavator-rig/hidden_truth.toml"),
    );
    let mean = |window: &str, quantity: &str| measured_mean(&text, window, quantity);
    let points = twin["point"].as_array().unwrap();
    for (k, point) in points.iter().enumerate() {
        let window = format!("hold{}", k + 1);
        let value = |key: &str| point[key].as_float().unwrap();
        let inclinations = Inclinations {
            boom_deg: value("boom_inclination_deg"),
            arm_deg: value("arm_inclination_deg"),
            bucket_deg: value("bucket_inclination_deg"),
        };
        // The pose and load read back within the devices' resolution and
        // the noise averaged over the hold.
        for (name, level) in [
            ("boom_inclination", inclinations.boom_deg),
            ("arm_inclination", inclinations.arm_deg),
            ("bucket_inclination", inclinations.bucket_deg),
            ("tip_force", value("force_kN")),
        ] {
            let got = mean(&window, name);
            assert!(
                (got - level).abs() < 0.02,
                "{window} {name}: {got} vs {level}"
            );
        }
        let evaluation = excavator
            .evaluate(&Inputs {
                strokes: inclinations.strokes(&geometry).unwrap(),
                tip_force_kn: value("force_kN"),
                tip_force_angle_deg: -10.0,
            })
            .unwrap();
        for gauge in &evaluation.gauges {
            let got = mean(&window, &format!("sg{:02}", gauge.point));
            assert!(
                (got - gauge.stress_mpa).abs() < 0.1,
                "{window} point {}: {got} MPa, the twin's {} MPa",
                gauge.point,
                gauge.stress_mpa
            );
        }
        for cylinder in CylinderName::ALL {
            let got = mean(&window, &format!("{cylinder}_net_force"));
            let truth = evaluation.cylinder(cylinder).axial_force_kn;
            assert!(
                (got - truth).abs() < 0.005 * truth.abs().max(1.0),
                "{window} {cylinder}: net force {got} kN, the twin's {truth} kN"
            );
        }
    }
}

/// `acq simulate` of the excavator rig on `scenario` (TOML text) to a log,
/// then `acq extract` of it: the measured-values CSV.
fn simulate_and_extract(dir: &std::path::Path, scenario: &str) -> String {
    let path = dir.join("scenario.toml");
    std::fs::write(&path, scenario).unwrap();
    simulate_and_extract_file(dir, &path)
}

/// [`simulate_and_extract`] of a scenario file.
fn simulate_and_extract_file(dir: &std::path::Path, scenario: &std::path::Path) -> String {
    let log = dir.join("simulated.log");
    let output = acq(&[
        "simulate",
        "--rig",
        "fixtures/rigs/excavator.toml",
        "--scenario",
        scenario.to_str().unwrap(),
        "-o",
        log.to_str().unwrap(),
        "--start",
        "1763719200",
    ]);
    assert!(output.status.success(), "{}", stderr(&output));
    let measured = dir.join("measured.csv");
    let output = acq(&[
        "extract",
        log.to_str().unwrap(),
        "--rig",
        "fixtures/rigs/excavator.toml",
        "-o",
        measured.to_str().unwrap(),
    ]);
    assert!(output.status.success(), "{}", stderr(&output));
    std::fs::read_to_string(&measured).unwrap()
}

/// The mean of `quantity` in `window` of a measured-values CSV.
fn measured_mean(text: &str, window: &str, quantity: &str) -> f64 {
    text.lines()
        .map(|l| l.split(',').collect::<Vec<_>>())
        .find(|r| r[0] == window && r[3] == quantity)
        .unwrap_or_else(|| panic!("no {window} {quantity} in\n{text}"))[5]
        .parse()
        .unwrap()
}
