//! `acq align` and `acq extract` on the recorded fixture sessions (real
//! `acq record` sessions of simulated traffic on a vcan), on sessions
//! imported from logger files (`acq import`) and on logs made bad on
//! purpose: the real binary, its files, exit codes and messages.

mod common;

use common::pipeline::scenario_holds;
use common::running::{api_state, url_in, Running};
use common::{acq, root, stderr};
use std::collections::BTreeMap;
use std::path::Path;
use std::process::Output;
use std::time::Duration;

fn path_str(path: &Path) -> &str {
    path.to_str().unwrap()
}

/// `acq COMMAND INPUT --rig RIG -o OUT EXTRA...`
fn run_with_rig(command: &str, input: &str, rig: &str, out: &Path, extra: &[&str]) -> Output {
    let mut args = vec![command, input, "--rig", rig, "-o", path_str(out)];
    args.extend_from_slice(extra);
    acq(&args)
}

/// An aligned CSV: header and rows of cells, comments apart.
struct Table {
    comments: Vec<String>,
    header: Vec<String>,
    rows: Vec<Vec<String>>,
}

impl Table {
    fn read(path: &Path) -> Table {
        let text = std::fs::read_to_string(path).unwrap();
        assert!(
            !text.contains("NaN") && !text.contains("inf"),
            "NaN or inf in {}",
            path.display()
        );
        let mut lines = text.lines();
        let mut comments = Vec::new();
        let header = loop {
            let line = lines.next().expect("header");
            match line.strip_prefix("# ") {
                Some(comment) => comments.push(comment.to_string()),
                None => break line.split(',').map(str::to_string).collect::<Vec<_>>(),
            }
        };
        let rows = lines
            .map(|l| l.split(',').map(str::to_string).collect())
            .collect();
        Table {
            comments,
            header,
            rows,
        }
    }

    fn column(&self, name: &str) -> usize {
        self.header
            .iter()
            .position(|h| h == name)
            .unwrap_or_else(|| panic!("no column {name} in {:?}", self.header))
    }

    /// Values of `sensor` (its `name [unit]` column) with `time_s` in [from, to].
    fn values(&self, heading: &str, from_s: f64, to_s: f64) -> Vec<f64> {
        let (t, c) = (self.column("time_s"), self.column(heading));
        self.rows
            .iter()
            .filter(|r| {
                let time: f64 = r[t].parse().unwrap();
                (from_s..=to_s).contains(&time)
            })
            .filter(|r| !r[c].is_empty())
            .map(|r| r[c].parse().unwrap())
            .collect()
    }
}

fn mean(values: &[f64]) -> f64 {
    values.iter().sum::<f64>() / values.len() as f64
}

/// measured.csv as (window, quantity) -> fields by header name.
fn measured(path: &Path) -> BTreeMap<(String, String), BTreeMap<String, String>> {
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
            let r = r.unwrap();
            let fields: BTreeMap<String, String> = header
                .iter()
                .cloned()
                .zip(r.iter().map(str::to_string))
                .collect();
            (
                (fields["window"].clone(), fields["quantity"].clone()),
                fields,
            )
        })
        .collect()
}

#[test]
fn aligned_holds_equal_the_scenario_values_within_the_noise() {
    let dir = tempfile::tempdir().unwrap();
    for case in ["excavator_case1", "excavator_case2"] {
        let out = dir.path().join(format!("{case}.csv"));
        let session = format!("fixtures/sessions/{case}");
        let output = run_with_rig("align", &session, "fixtures/rigs/excavator.toml", &out, &[]);
        assert!(output.status.success(), "{}", stderr(&output));
        assert!(
            stderr(&output).contains("rows written"),
            "{}",
            stderr(&output)
        );
        let table = Table::read(&out);
        assert!(
            table.comments[0].contains("unix ns"),
            "{:?}",
            table.comments
        );
        assert!(table.comments.iter().any(|c| c.starts_with("gaps:")));
        // 100 Hz from the session start: time_s = row / 100.
        for (i, row) in table.rows.iter().take(50).enumerate() {
            assert_eq!(row[0].parse::<f64>().unwrap(), i as f64 / 100.0);
        }
        // The hold is 3..11 s after the sensors start (scenario timeline);
        // the sensors start about 0.2 s after the session.
        for (sensor, hold) in scenario_holds(case) {
            let unit_column = table
                .header
                .iter()
                .find(|h| h.starts_with(&format!("{sensor} [")))
                .unwrap()
                .clone();
            let values = table.values(&unit_column, 4.5, 10.5);
            assert!(values.len() >= 590, "{sensor}: {} values", values.len());
            let m = mean(&values);
            // Noise std <= 0.4 (scenario): the mean of 600 values is within
            // 0.05 of the truth, plus 0.01 for the transducers' resolution.
            assert!((m - hold).abs() < 0.06, "{case} {sensor}: {m} vs {hold}");
            let gap = table.column(&format!("{sensor}_gap"));
            assert!(table.rows.iter().any(|r| r[gap] == "0"));
        }
    }
}

#[test]
fn extracted_means_match_the_scenario_and_the_faulty_gauge_is_flagged() {
    let dir = tempfile::tempdir().unwrap();
    for case in ["excavator_case1", "excavator_case2"] {
        let out = dir.path().join(format!("{case}.csv"));
        let session = format!("fixtures/sessions/{case}");
        let output = run_with_rig(
            "extract",
            &session,
            "fixtures/rigs/excavator.toml",
            &out,
            &[],
        );
        assert!(output.status.success(), "{}", stderr(&output));
        let values = measured(&out);
        let windows: std::collections::BTreeSet<&String> = values.keys().map(|(w, _)| w).collect();
        assert_eq!(windows.len(), 1, "one hold per case: {windows:?}");
        for (sensor, hold) in scenario_holds(case) {
            let row = &values[&("hold1".to_string(), sensor.clone())];
            let m: f64 = row["mean"].parse().unwrap();
            let low: f64 = row["ci95_low"].parse().unwrap();
            let high: f64 = row["ci95_high"].parse().unwrap();
            let std: f64 = row["std"].parse().unwrap();
            let n: u64 = row["n"].parse().unwrap();
            // 6.4 s of hold at 100 Hz (10 Hz for the inclinometers).
            let rate = if sensor.ends_with("inclination") {
                10.0
            } else {
                100.0
            };
            assert!(n as f64 >= 0.95 * 6.4 * rate, "{case} {sensor}: n = {n}");
            assert!(low < m && m < high);
            // The truth lies within the interval widened by the transducer's
            // resolution (0.01 bar pressure steps) and 2 extra half-widths
            // (about 1 in 10^5 for a correct 95 % interval).
            let half = 0.5 * (high - low);
            assert!(
                (m - hold).abs() < 3.0 * half + 0.006,
                "{case} {sensor}: {m} +- {half} vs {hold} (std {std})"
            );
        }
        let flags = |q: &str| values[&("hold1".to_string(), q.to_string())]["flags"].clone();
        // Published: in Case 2 point 3 read 17.83 MPa while its twin,
        // point 4, read 75.46: the rig's [[pair]] flags both. No other
        // value is flagged (the rig declares no [[row]]).
        let suspects: &[(&str, &str)] = if case == "excavator_case2" {
            &[("sg03", "pair:sg04"), ("sg04", "pair:sg03")]
        } else {
            &[]
        };
        for (sensor, expected) in suspects {
            assert_eq!(flags(sensor), *expected, "{case} {sensor}");
            assert!(
                stderr(&output).contains(&format!("flagged hold1 {sensor}")),
                "{}",
                stderr(&output)
            );
        }
        let flagged = values.values().filter(|v| !v["flags"].is_empty()).count();
        assert_eq!(flagged, suspects.len(), "{case}: only the suspects flagged");
        // Loaded-chamber pressures: the published measured values, on the
        // side the twin's statics load (Case 2 lifts the boom, so its
        // cylinder pulls).
        let expected = match case {
            "excavator_case1" => [
                ("bucket", 116.89, "head side"),
                ("arm", 193.46, "head side"),
                ("boom", 73.35, "head side"),
            ],
            _ => [
                ("bucket", 195.04, "head side"),
                ("arm", 207.54, "head side"),
                ("boom", 216.66, "rod side"),
            ],
        };
        for (cylinder, bar, side) in expected {
            let row = &values[&("hold1".to_string(), format!("{cylinder}_loaded_pressure"))];
            let m: f64 = row["mean"].parse().unwrap();
            assert!((m - bar).abs() < 0.1, "{case} {cylinder}: {m} vs {bar}");
            assert_eq!(row["unit"], "bar");
            assert!(row["note"].starts_with(side), "{row:?}");
        }
    }
}

#[test]
fn tensile_curve_reproduces_the_test_file() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("curve.csv");
    let output = acq(&[
        "extract",
        "--tensile",
        "fixtures/sessions/tensile_p91_20c",
        "--rig",
        "fixtures/rigs/tensile.toml",
        "-o",
        path_str(&out),
    ]);
    assert!(output.status.success(), "{}", stderr(&output));
    assert!(
        stderr(&output).contains("fracture at"),
        "{}",
        stderr(&output)
    );
    let reference_path = root().join("data/tensile/P91_20_2_DF_SS.csv");
    let header_of = |p: &Path| {
        std::fs::read_to_string(p)
            .unwrap()
            .lines()
            .next()
            .unwrap()
            .to_string()
    };
    assert_eq!(
        header_of(&out),
        header_of(&reference_path),
        "columns identical to the test file"
    );
    let read = |p: &Path| -> Vec<Vec<String>> {
        let mut reader = csv::Reader::from_path(p).unwrap();
        reader
            .records()
            .map(|r| r.unwrap().iter().map(str::to_string).collect())
            .collect()
    };
    let curve = read(&out);
    let reference = read(&reference_path);
    let number = |s: &str| s.parse::<f64>().unwrap();
    let (ref_u, ref_f): (Vec<f64>, Vec<f64>) = reference
        .iter()
        .map(|r| (number(&r[0]), number(&r[1])))
        .unzip();
    assert_eq!(curve[0][..2], ["0.0", "0.0"], "starts at the origin");
    // Every point lies on the measured curve, within the simulated noise
    // (force 0.004 kN, extension 0.0005 mm) and the slope times that.
    let interpolate = |u: f64| {
        let i = ref_u
            .windows(2)
            .position(|w| w[0] <= u && u <= w[1])
            .unwrap_or(ref_u.len() - 2);
        let f = (u - ref_u[i]) / (ref_u[i + 1] - ref_u[i]);
        ref_f[i] + f * (ref_f[i + 1] - ref_f[i])
    };
    let mut worst: f64 = 0.0;
    for row in curve.iter().skip(1) {
        let (u, f) = (number(&row[0]), number(&row[1]));
        if u > 0.03 {
            worst = worst.max((f - interpolate(u)).abs());
        }
    }
    assert!(worst < 0.03, "largest force difference {worst} kN");
    // Maximum: 7.4597 kN at 1.32067 mm, not flattened (noise may add ~0.01).
    let max = curve.iter().map(|r| number(&r[1])).fold(0.0, f64::max);
    assert!((max - 7.4597).abs() < 0.02, "max {max}");
    // Trimmed at fracture: the last point is the test's last (2.607 mm, 4.989 kN).
    let last = curve.last().unwrap();
    assert!((number(&last[0]) - 2.607).abs() < 0.005, "{last:?}");
    assert!((number(&last[1]) - 4.989).abs() < 0.03, "{last:?}");
    // True values stop at the maximum, as in the test file.
    let max_row = curve.iter().position(|r| number(&r[1]) == max).unwrap();
    assert!(curve[max_row][4].parse::<f64>().is_ok());
    assert!(curve[max_row + 1][4].is_empty());
    // STRESS = F / (pi 2^2) in MPa; STRAIN = u / 12.5.
    let row = &curve[max_row];
    assert!(
        (number(&row[3]) - number(&row[1]) * 1000.0 / (std::f64::consts::PI * 4.0)).abs() < 1e-9
    );
    assert!((number(&row[2]) - number(&row[0]) / 12.5).abs() < 1e-12);
}

/// The raw log of a fixture session, line by line.
fn session_lines(case: &str) -> Vec<String> {
    std::fs::read_to_string(root().join("fixtures/sessions").join(case).join("raw.log"))
        .unwrap()
        .lines()
        .map(str::to_string)
        .collect()
}

/// Writes `lines` as a log and aligns it with the excavator rig.
fn align_lines<S: AsRef<str>>(dir: &Path, name: &str, lines: &[S]) -> (Output, std::path::PathBuf) {
    let log = dir.join(name);
    let text: String = lines.iter().map(|l| format!("{}\n", l.as_ref())).collect();
    std::fs::write(&log, text).unwrap();
    let out = dir.join(format!("{name}.csv"));
    let output = run_with_rig(
        "align",
        path_str(&log),
        "fixtures/rigs/excavator.toml",
        &out,
        &[],
    );
    assert!(output.status.success(), "{}", stderr(&output));
    (output, out)
}

fn line_time(line: &str) -> f64 {
    line[1..line.find(')').unwrap()].parse().unwrap()
}

fn with_time(line: &str, time: f64) -> String {
    format!("({time:.6}){}", &line[line.find(')').unwrap() + 1..])
}

#[test]
fn a_silent_sensor_is_flagged_not_interpolated() {
    let dir = tempfile::tempdir().unwrap();
    let lines = session_lines("excavator_case1");
    let start = line_time(&lines[0]);
    // Node 0x23 (arm head pressure, COB-ID 1A3) silent from 6 s to 7.5 s.
    let kept: Vec<&String> = lines
        .iter()
        .filter(|l| {
            let t = line_time(l) - start;
            !(l.contains(" 1A3#") && (6.0..7.5).contains(&t))
        })
        .collect();
    let (output, out) = align_lines(dir.path(), "gap.log", &kept);
    let message = stderr(&output);
    assert!(
        message.contains("arm_head_pressure: 1 silence(s) longer than the gap tolerance"),
        "{message}"
    );
    let table = Table::read(&out);
    let (t, v, g) = (
        table.column("time_s"),
        table.column("arm_head_pressure [bar]"),
        table.column("arm_head_pressure_gap"),
    );
    // time_s counts from the log's first sample here, a few ms before
    // the first arm pressure sample: the edges are flagged too.
    let mut flagged = 0;
    for row in &table.rows {
        let time: f64 = row[t].parse::<f64>().unwrap();
        if row[g] == "1" {
            assert!(row[v].is_empty());
            if (1.0..13.0).contains(&time) {
                flagged += 1;
            }
        } else {
            assert!(!row[v].is_empty(), "value without flag at {time}");
        }
    }
    // 1.5 s of silence at 100 rows/s, give or take the edge rows.
    assert!((145..=152).contains(&flagged), "{flagged} flagged rows");
}

#[test]
fn a_log_merged_from_two_recordings_is_reported_and_never_panics() {
    let dir = tempfile::tempdir().unwrap();
    let lines = session_lines("excavator_case1");
    // The same recording twice (time jumps back 14 s), plus duplicated lines.
    let mut merged: Vec<String> = lines.clone();
    merged.extend(lines.iter().take(200).cloned());
    merged.extend(lines.iter().cloned());
    let (output, out) = align_lines(dir.path(), "merged.log", &merged);
    let log = dir.path().join("merged.log");
    let message = stderr(&output);
    assert!(message.contains("went back in time"), "{message}");
    assert!(
        message.contains("a log merged from two recordings?"),
        "{message}"
    );
    let table = Table::read(&out);
    assert!(table.rows.len() > 1000);
    // Extract on the merged log still finds the one hold (the second copy's
    // samples are dropped as going back in time, so they do not count twice).
    let measured_path = dir.path().join("measured.csv");
    let output = run_with_rig(
        "extract",
        path_str(&log),
        "fixtures/rigs/excavator.toml",
        &measured_path,
        &[],
    );
    assert!(output.status.success(), "{}", stderr(&output));
}

#[test]
fn a_sensor_never_seen_and_an_empty_window_are_said_and_left_empty() {
    let dir = tempfile::tempdir().unwrap();
    // The hydraulics bus only: every DAQ sensor (can1) is missing.
    let lines = session_lines("excavator_case1");
    let can0: Vec<&String> = lines.iter().filter(|l| l.contains(" can0 ")).collect();
    let (output, out) = align_lines(dir.path(), "can0.log", &can0);
    // Every DAQ sensor is missing: one line names them all, with the count.
    let said = stderr(&output);
    let line = said
        .lines()
        .find(|l| l.contains("never seen in the recording"))
        .unwrap_or_else(|| panic!("{said}"));
    assert!(
        line.contains("sg09, sg10") && line.contains("sensors): never seen"),
        "{line}"
    );
    assert_eq!(
        said.matches("never seen in the recording").count(),
        1,
        "{said}"
    );
    let table = Table::read(&out);
    let g = table.column("sg09_gap");
    assert!(table.rows.iter().all(|r| r[g] == "1"));

    // A window after the end of the recording, and one inside it.
    let windows = dir.path().join("windows.csv");
    std::fs::write(&windows, "name,start_s,end_s\nlate,100,110\npose,5,9\n").unwrap();
    let measured_path = dir.path().join("measured.csv");
    let output = acq(&[
        "extract",
        "fixtures/sessions/excavator_case1",
        "--rig",
        "fixtures/rigs/excavator.toml",
        "--windows",
        path_str(&windows),
        "-o",
        path_str(&measured_path),
    ]);
    assert!(output.status.success(), "{}", stderr(&output));
    let values = measured(&measured_path);
    let late = &values[&("late".to_string(), "tip_force".to_string())];
    assert_eq!(late["n"], "0");
    assert_eq!(late["mean"], "");
    assert_eq!(late["flags"], "no_samples");
    let pose = &values[&("pose".to_string(), "tip_force".to_string())];
    assert!((pose["mean"].parse::<f64>().unwrap() - 40.6).abs() < 0.05);
    let text = std::fs::read_to_string(&measured_path).unwrap();
    assert!(!text.contains("NaN"));
}

#[test]
fn clock_offset_between_buses_is_estimated_and_removed() {
    let dir = tempfile::tempdir().unwrap();
    // The DAQ bus (can1) stamped by a clock 137.4 ms ahead.
    let lines = session_lines("excavator_case1");
    let shifted: String = lines
        .iter()
        .map(|l| {
            if l.contains(" can1 ") {
                with_time(l, line_time(l) + 0.1374)
            } else {
                l.clone()
            }
        })
        .map(|l| format!("{l}\n"))
        .collect();
    let log = dir.path().join("offset.log");
    std::fs::write(&log, shifted).unwrap();
    let rig_text = std::fs::read_to_string(root().join("fixtures/rigs/excavator.toml"))
        .unwrap()
        .replace("bitrate = 500000\n", "bitrate = 500000\nclock_sync = { signal = \"tip_force\", reference = \"arm_head_pressure\" }\n")
        .replace("\"../dbc/", &format!("\"{}/fixtures/dbc/", root().display()));
    let rig = dir.path().join("rig.toml");
    std::fs::write(&rig, rig_text).unwrap();
    let out = dir.path().join("aligned.csv");
    let output = acq(&[
        "align",
        path_str(&log),
        "--rig",
        path_str(&rig),
        "-o",
        path_str(&out),
    ]);
    assert!(output.status.success(), "{}", stderr(&output));
    let message = stderr(&output);
    let estimate: f64 = message
        .split("clock offset ")
        .nth(1)
        .and_then(|rest| rest.split(" ms").next())
        .unwrap_or_else(|| panic!("no estimate in: {message}"))
        .parse()
        .unwrap();
    assert!(
        (estimate - 137.4).abs() < 2.0,
        "estimated {estimate} ms; {message}"
    );
    assert!(message.contains("confidence high"), "{message}");
    let table = Table::read(&out);
    assert!(table
        .comments
        .iter()
        .any(|c| c.contains("estimated from tip_force against arm_head_pressure")));

    // Given on the command line instead: no estimate, the offset is used.
    let output = acq(&[
        "align",
        path_str(&log),
        "--rig",
        "fixtures/rigs/excavator.toml",
        "--clock-offset",
        "daq=137.4",
        "-o",
        path_str(&out),
    ]);
    assert!(output.status.success(), "{}", stderr(&output));
    assert!(
        stderr(&output).contains("+137.400 ms (given)"),
        "{}",
        stderr(&output)
    );
}

#[test]
fn a_filtered_alignment_keeps_the_hold_level() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("filtered.csv");
    let output = acq(&[
        "align",
        "fixtures/sessions/excavator_case1",
        "--rig",
        "fixtures/rigs/excavator.toml",
        "--filter",
        "2",
        "-o",
        path_str(&out),
    ]);
    assert!(output.status.success(), "{}", stderr(&output));
    let table = Table::read(&out);
    assert!(table
        .comments
        .iter()
        .any(|c| c.contains("zero-phase Gaussian") && c.contains("169.8 ms")));
    let values = table.values("tip_force [kN]", 5.0, 10.0);
    let spread = values.iter().cloned().fold(f64::NEG_INFINITY, f64::max)
        - values.iter().cloned().fold(f64::INFINITY, f64::min);
    // Raw noise 0.08 kN std; at 2 Hz of 100 the filtered spread is far smaller.
    assert!(spread < 0.1, "filtered spread {spread}");
    assert!((mean(&values) - 40.6).abs() < 0.02);
}

/// Runs acq, expecting exit `code` and `message` in stderr.
fn fails_with(args: &[&str], code: i32, message: &str) {
    let output = acq(args);
    assert_eq!(
        output.status.code(),
        Some(code),
        "{args:?}: {}",
        stderr(&output)
    );
    assert!(
        stderr(&output).contains(message),
        "{args:?}: {}",
        stderr(&output)
    );
}

#[test]
fn bad_input_gives_file_line_and_exit_code() {
    let dir = tempfile::tempdir().unwrap();
    let windows = dir.path().join("windows.csv");
    std::fs::write(&windows, "name,start_s,end_s\nhold,5,9\nbad,x,3\n").unwrap();
    let session = "fixtures/sessions/excavator_case1";
    fails_with(
        &["extract", session, "--windows", path_str(&windows)],
        3,
        "windows.csv:3: expected start_s in seconds, found 'x'",
    );
    fails_with(
        &["align", session, "--from", "9", "--to", "3", "-o", "-"],
        2,
        "lies before --from",
    );
    fails_with(
        &["extract", session, "--load", "nothing"],
        2,
        "no sensor 'nothing'",
    );
    fails_with(
        &[
            "align",
            "fixtures/sessions/tensile_p91_20c",
            "--rig",
            "fixtures/rigs/excavator.toml",
            "-o",
            "-",
        ],
        2,
        "give one interface per rig bus",
    );
    fails_with(
        &["align", "no/such/dir", "-o", "-"],
        2,
        "no such session directory or log file",
    );
    fails_with(
        &["align", session, "--max-gap", "0.5x", "-o", "-"],
        2,
        "a number >= 1 followed by x",
    );
    fails_with(
        &["align", session, "--filter", "60", "-o", "-"],
        2,
        "below half of --rate",
    );
    // A failed run leaves no output file that looks complete.
    let out = dir.path().join("never.csv");
    fails_with(
        &[
            "align",
            session,
            "--from",
            "9",
            "--to",
            "3",
            "-o",
            path_str(&out),
        ],
        2,
        "--to",
    );
    assert!(!out.exists());
}

#[test]
fn stuck_and_saturated_channels_are_flagged() {
    let dir = tempfile::tempdir().unwrap();
    // A rig whose sg05 has a declared range it reaches, and a scenario in
    // which sg06 reads without any noise: a float32 that never changes.
    let rig_text = std::fs::read_to_string(root().join("fixtures/rigs/excavator.toml"))
        .unwrap()
        .replace("location = 5\n", "location = 5\nrange = [-24.15, 24.15]\n")
        .replace(
            "\"../dbc/",
            &format!("\"{}/fixtures/dbc/", root().display()),
        );
    let rig = dir.path().join("rig.toml");
    std::fs::write(&rig, rig_text).unwrap();
    let scenario_text =
        std::fs::read_to_string(root().join("fixtures/scenarios/excavator_case1.toml"))
            .unwrap()
            .replace(
                "[sensor.sg06]  # MPa, chosen\nidle = 3.80\nhold = 27.3\nnoise = 0.15",
                "[sensor.sg06]\nidle = 3.80\nhold = 27.3\nnoise = 0.0",
            )
            .replace("relative_noise = 0.002", "relative_noise = 0.0");
    let scenario = dir.path().join("scenario.toml");
    std::fs::write(&scenario, scenario_text).unwrap();
    let log = dir.path().join("sim.log");
    let output = acq(&[
        "simulate",
        "--rig",
        path_str(&rig),
        "--scenario",
        path_str(&scenario),
        "-o",
        path_str(&log),
        "--start",
        "1000",
    ]);
    assert!(output.status.success(), "{}", stderr(&output));
    let measured_path = dir.path().join("measured.csv");
    let output = acq(&[
        "extract",
        path_str(&log),
        "--rig",
        path_str(&rig),
        "-o",
        path_str(&measured_path),
    ]);
    assert!(output.status.success(), "{}", stderr(&output));
    let values = measured(&measured_path);
    let flags = |q: &str| values[&("hold1".to_string(), q.to_string())]["flags"].clone();
    assert_eq!(flags("sg06"), "stuck");
    assert!(flags("sg05").contains("saturated"), "{}", flags("sg05"));
    assert_eq!(flags("sg07"), "");
}

#[test]
fn a_session_is_read_with_its_own_copy_of_the_rig() {
    let dir = tempfile::tempdir().unwrap();
    let measured_path = dir.path().join("measured.csv");
    let output = acq(&[
        "extract",
        "fixtures/sessions/excavator_case2",
        "-o",
        path_str(&measured_path),
    ]);
    assert!(output.status.success(), "{}", stderr(&output));
    let values = measured(&measured_path);
    assert_eq!(
        values[&("hold1".to_string(), "sg03".to_string())]["flags"],
        "pair:sg04"
    );
    let curve = dir.path().join("curve.csv");
    let output = acq(&[
        "extract",
        "--tensile",
        "fixtures/sessions/tensile_p91_20c",
        "-o",
        path_str(&curve),
    ]);
    assert!(output.status.success(), "{}", stderr(&output));
    // A log has no rig of its own.
    let output = acq(&[
        "align",
        "fixtures/sessions/excavator_case1/raw.log",
        "-o",
        "-",
    ]);
    assert_eq!(output.status.code(), Some(2));
    assert!(
        stderr(&output).contains("give one with --rig"),
        "{}",
        stderr(&output)
    );
}

/// A gauge unlike its neighbours in a row the rig declares is flagged, with
/// what to check: Case 1's sg09 read 103.18 MPa (published) between sg08
/// and sg10 at 33.6 and 39.9 MPa (chosen, rising about 3 MPa a gauge along
/// the row). The same gauges without the row are not (the fixture rig
/// declares none: `location` numbers alone say nothing of which gauges are
/// neighbours on the structure).
#[test]
fn a_gauge_unlike_its_neighbours_in_a_declared_row_is_flagged() {
    let dir = tempfile::tempdir().unwrap();
    let rig = std::fs::read_to_string(root().join("fixtures/rigs/excavator.toml"))
        .unwrap()
        .replace(
            "\"../dbc/somat_excavator.dbc\"",
            &format!("{:?}", root().join("fixtures/dbc/somat_excavator.dbc")),
        );
    let with_row = dir.path().join("with_row.toml");
    std::fs::write(
        &with_row,
        format!("{rig}\n[[row]]\nsensors = [\"sg07\", \"sg08\", \"sg09\", \"sg10\", \"sg11\"]\n"),
    )
    .unwrap();
    let out = dir.path().join("measured.csv");
    let output = run_with_rig(
        "extract",
        "fixtures/sessions/excavator_case1",
        path_str(&with_row),
        &out,
        &[],
    );
    assert!(output.status.success(), "{}", stderr(&output));
    let values = measured(&out);
    let flagged: Vec<(&String, &String)> = values
        .iter()
        .filter(|(_, row)| !row["flags"].is_empty())
        .map(|((_, quantity), row)| (quantity, &row["flags"]))
        .collect();
    assert_eq!(flagged.len(), 1, "{flagged:?}");
    assert_eq!(flagged[0].0, "sg09");
    assert_eq!(flagged[0].1, "unlike_neighbours");
    let note = &values[&("hold1".to_string(), "sg09".to_string())]["note"];
    assert!(
        note.contains("sg08") && note.contains("sg10") && note.contains("check the gauge"),
        "{note}"
    );
    // A row of two is a pair's job: refused with the line.
    let two = dir.path().join("two.toml");
    std::fs::write(
        &two,
        format!("{rig}\n[[row]]\nsensors = [\"sg07\", \"sg08\"]\n"),
    )
    .unwrap();
    let output = acq(&["check-rig", path_str(&two)]);
    assert_eq!(output.status.code(), Some(2), "{}", stderr(&output));
    assert!(
        stderr(&output).contains("a row needs three or more"),
        "{}",
        stderr(&output)
    );
}

/// `acq import` as the issue's check states it: a shipped session's log,
/// cut in three, each third converted to MF4, imported in any order with
/// the session's rig, gives a session whose `acq extract` equals the
/// recorded session's value for value (windows count from the first frame,
/// which a log can say; a recorder's start it cannot), whose raw log holds
/// the same frames in the same order, and whose session.toml names each
/// file with its hash.
#[test]
fn logger_files_imported_extract_as_the_recorded_session() {
    let dir = tempfile::tempdir().unwrap();
    let recorded = root().join("fixtures/sessions/excavator_case1");
    let raw = std::fs::read_to_string(recorded.join("raw.log")).unwrap();
    let lines: Vec<&str> = raw.lines().collect();
    let third = lines.len() / 3;
    let mut parts = Vec::new();
    for (index, chunk) in [
        &lines[..third],
        &lines[third..2 * third],
        &lines[2 * third..],
    ]
    .iter()
    .enumerate()
    {
        let text = dir.path().join(format!("part{index}.log"));
        std::fs::write(&text, chunk.join("\n") + "\n").unwrap();
        let mf4 = dir.path().join(format!("0000000{index}.MF4"));
        let converted = acq(&["convert", path_str(&text), "-o", path_str(&mf4)]);
        assert!(converted.status.success(), "{}", stderr(&converted));
        parts.push(mf4);
    }
    let session = dir.path().join("imported");
    let rig = recorded.join("rig/excavator.toml");
    let imported = acq(&[
        "import",
        path_str(&parts[2]),
        path_str(&parts[0]),
        path_str(&parts[1]),
        "--rig",
        path_str(&rig),
        "--out",
        path_str(&session),
    ]);
    assert!(imported.status.success(), "{}", stderr(&imported));
    // The same frames on each bus (MF4 stores each as received). A
    // recorder writes them in arrival order, whose times can step back by
    // a fraction of a millisecond; the merge joins files in time order, so
    // the order may differ where the files meet.
    let imported_raw = std::fs::read_to_string(session.join("raw.log")).unwrap();
    let imported_lines: Vec<&str> = imported_raw
        .lines()
        .map(|line| line.strip_suffix(" R").unwrap_or(line))
        .collect();
    for bus in ["can0", "can1"] {
        let on = |lines: &[&str]| -> Vec<String> {
            let mut on_bus: Vec<String> = lines
                .iter()
                .filter(|line| line.split(' ').nth(1) == Some(bus))
                .map(|line| line.to_string())
                .collect();
            on_bus.sort();
            on_bus
        };
        let (got, want) = (on(&imported_lines), on(&lines));
        assert!(!want.is_empty());
        assert_eq!(got, want, "{bus}");
    }
    assert_eq!(imported_lines.len(), lines.len());
    let extract = |session: &Path, out: &Path| {
        let output = acq(&["extract", path_str(session), "-o", path_str(out)]);
        assert!(output.status.success(), "{}", stderr(&output));
        measured(out)
    };
    let (want, got) = (
        extract(&recorded, &dir.path().join("recorded.csv")),
        extract(&session, &dir.path().join("imported.csv")),
    );
    assert!(want.len() > 20, "{want:?}");
    assert_eq!(values_only(got), values_only(want));
    let toml: toml::Value =
        toml::from_str(&std::fs::read_to_string(session.join("session.toml")).unwrap()).unwrap();
    let sources = toml["source"].as_array().unwrap();
    assert_eq!(sources.len(), 3);
    for (source, part) in sources.iter().zip(&parts) {
        assert_eq!(
            source["path"].as_str(),
            Some(path_str(part)),
            "in time order"
        );
        let (sha, bytes) = acq_io::session::sha256_file(part).unwrap();
        assert_eq!(source["sha256"].as_str(), Some(sha.as_str()));
        assert_eq!(source["bytes"].as_integer(), Some(bytes as i64));
        assert_eq!(source["format"].as_str(), Some("mf4"));
    }
    let notes = toml["session"].get("notes");
    assert!(notes.is_none(), "no gap, no overlap: {notes:?}");
    assert_eq!(
        toml["session"]["frames"].as_integer(),
        Some(lines.len() as i64)
    );
    // The page and the study at the rig take it as the recorded session:
    // the same holds and values on `acq view`'s state, the same posterior
    // from `acq calibrate rig`.
    let recorded_copy = common::copy_session("excavator_case1", &dir.path().join("recorded"));
    let page_holds = |session: &Path| {
        let mut view = Running::start(&["view", path_str(session), "--view", "127.0.0.1:0"]);
        let url = url_in(&view.wait_for("acq: view at", Duration::from_secs(60)));
        api_state(&url)["holds"].clone()
    };
    // (Times count from the first frame: the imported hold starts earlier.)
    let (holds, recorded_holds) = (page_holds(&session), page_holds(&recorded_copy));
    assert_eq!(holds.as_array().map(Vec::len), Some(1), "{holds}");
    assert_eq!(holds[0]["values"], recorded_holds[0]["values"]);
    let length = |hold: &serde_json::Value| {
        hold["end_s"].as_f64().unwrap() - hold["start_s"].as_f64().unwrap()
    };
    assert!((length(&holds[0]) - length(&recorded_holds[0])).abs() < 1e-9);
    let study = |session: &Path, name: &str| {
        let json = dir.path().join(name);
        let output = acq(&[
            "calibrate",
            "rig",
            path_str(session),
            "--study",
            "examples/excavator-rig/study.toml",
            "-o",
            path_str(&json),
        ]);
        assert!(output.status.success(), "{}", stderr(&output));
        let state: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(json).unwrap()).unwrap();
        assert_eq!(state["holds_used"], 1, "{state}");
        state["parameters"].clone()
    };
    assert_eq!(
        study(&session, "imported.json"),
        study(&recorded_copy, "recorded.json")
    );
}

/// What a careless import meets: a gap between split files and an overlap
/// of two files are named, a file given twice is refused, a session is
/// never written over, `--bus` renames an interface, and `--copy-sources`
/// keeps each file byte for byte.
#[test]
fn an_import_names_gaps_and_overlaps_and_refuses_a_file_given_twice() {
    let dir = tempfile::tempdir().unwrap();
    let raw =
        std::fs::read_to_string(root().join("fixtures/sessions/excavator_case1/raw.log")).unwrap();
    let lines: Vec<&str> = raw.lines().collect();
    let n = lines.len();
    let write = |name: &str, chunk: &[&str]| {
        let path = dir.path().join(name);
        std::fs::write(&path, chunk.join("\n") + "\n").unwrap();
        path
    };
    let first = write("first.log", &lines[..n / 3]);
    let last = write("last.log", &lines[2 * n / 3..]);
    let again = write("again.log", &lines[n / 3 - 100..n / 3 + 50]);
    let out = dir.path().join("gap");
    let gap = acq(&[
        "import",
        path_str(&first),
        path_str(&last),
        path_str(&again),
        "--out",
        path_str(&out),
        "--bus",
        "can1=can7",
        "--copy-sources",
    ]);
    assert!(gap.status.success(), "{}", stderr(&gap));
    let told = stderr(&gap);
    assert!(
        told.contains("a gap of") && told.contains("last.log"),
        "{told}"
    );
    assert!(
        told.contains("overlap by") && told.contains("again.log"),
        "{told}"
    );
    let toml = std::fs::read_to_string(out.join("session.toml")).unwrap();
    assert!(toml.contains("\"can1 -> can7\""), "{toml}");
    assert!(
        toml.contains("name = \"can7\"") && !toml.contains("name = \"can1\""),
        "{toml}"
    );
    for name in ["first.log", "last.log", "again.log"] {
        assert_eq!(
            std::fs::read(out.join("sources").join(name)).unwrap(),
            std::fs::read(dir.path().join(name)).unwrap(),
            "{name} kept byte for byte"
        );
    }
    // Over an existing session: refused, the session untouched.
    let before = std::fs::read(out.join("raw.log")).unwrap();
    let over = acq(&["import", path_str(&first), "--out", path_str(&out)]);
    assert_eq!(over.status.code(), Some(2), "{}", stderr(&over));
    assert!(
        stderr(&over).contains("already holds a recording"),
        "{}",
        stderr(&over)
    );
    assert_eq!(std::fs::read(out.join("raw.log")).unwrap(), before);
    let copy = dir.path().join("copy.log");
    std::fs::copy(&first, &copy).unwrap();
    let twice = acq(&[
        "import",
        path_str(&first),
        path_str(&copy),
        "--out",
        path_str(&dir.path().join("twice")),
    ]);
    assert_eq!(twice.status.code(), Some(2), "{}", stderr(&twice));
    assert!(
        stderr(&twice).contains("the same bytes as"),
        "{}",
        stderr(&twice)
    );
    assert!(!dir.path().join("twice").exists());
    let empty = write("empty.log", &[]);
    let nothing = acq(&[
        "import",
        path_str(&empty),
        "--out",
        path_str(&dir.path().join("nothing")),
    ]);
    assert_eq!(nothing.status.code(), Some(3), "{}", stderr(&nothing));
    assert!(
        stderr(&nothing).contains("no CAN frame read"),
        "{}",
        stderr(&nothing)
    );
}

/// The recorded session's values with what only a recorder can know taken
/// out: its windows' times count from when the recorder was started.
fn values_only(
    rows: BTreeMap<(String, String), BTreeMap<String, String>>,
) -> BTreeMap<(String, String), BTreeMap<String, String>> {
    rows.into_iter()
        .map(|(key, mut row)| {
            row.remove("start_s");
            row.remove("end_s");
            (key, row)
        })
        .collect()
}

/// Two loggers, one on each of the rig's buses, that both call their bus
/// `can1` (as loggers with one port do): `--bus FOLDER:can1=can0` keeps
/// them apart, and the session extracts as the recorded one, value for
/// value; a folder that holds none of the files given is refused.
#[test]
fn two_loggers_that_both_log_can1_are_kept_apart_by_their_folders() {
    let dir = tempfile::tempdir().unwrap();
    let recorded = root().join("fixtures/sessions/excavator_case1");
    let raw = std::fs::read_to_string(recorded.join("raw.log")).unwrap();
    // Logger A rode on the hydraulics bus (the rig's can0), logger B on the
    // DAQ bus (can1); each wrote what it saw as its own can1.
    let (a, b) = (dir.path().join("logger_a"), dir.path().join("logger_b"));
    std::fs::create_dir_all(&a).unwrap();
    std::fs::create_dir_all(&b).unwrap();
    let on = |bus: &str| -> String {
        raw.lines()
            .filter(|line| line.split(' ').nth(1) == Some(bus))
            .map(|line| line.replacen(&format!(" {bus} "), " can1 ", 1) + "\n")
            .collect()
    };
    std::fs::write(a.join("hydraulics.log"), on("can0")).unwrap();
    let converted = acq(&[
        "convert",
        path_str(&a.join("hydraulics.log")),
        "-o",
        path_str(&a.join("00000001.MF4")),
    ]);
    assert!(converted.status.success(), "{}", stderr(&converted));
    std::fs::remove_file(a.join("hydraulics.log")).unwrap();
    std::fs::write(b.join("00000001.log"), on("can1")).unwrap();
    let rig = recorded.join("rig/excavator.toml");
    let (file_a, file_b) = (a.join("00000001.MF4"), b.join("00000001.log"));
    let import = |out: &Path, extra: &[&str]| {
        let mut args = vec![
            "import",
            path_str(&file_a),
            path_str(&file_b),
            "--rig",
            path_str(&rig),
            "--out",
            path_str(out),
        ];
        args.extend_from_slice(extra);
        acq(&args)
    };
    let session = dir.path().join("two");
    let imported = import(&session, &["--bus", &format!("{}:can1=can0", a.display())]);
    assert!(imported.status.success(), "{}", stderr(&imported));
    let toml = std::fs::read_to_string(session.join("session.toml")).unwrap();
    assert!(toml.contains("\"can1 -> can0\""), "{toml}");
    let extract = |session: &Path, out: &Path| {
        let output = acq(&["extract", path_str(session), "-o", path_str(out)]);
        assert!(output.status.success(), "{}", stderr(&output));
        measured(out)
    };
    let want = extract(&recorded, &dir.path().join("recorded.csv"));
    assert!(want.len() > 20, "{want:?}");
    assert_eq!(
        values_only(extract(&session, &dir.path().join("two.csv"))),
        values_only(want)
    );
    // Without the mapping both buses' frames are on can1, where the rig
    // has two buses: refused, saying how to map them, nothing left behind.
    let mixed = dir.path().join("mixed");
    let refused = import(&mixed, &[]);
    assert_eq!(refused.status.code(), Some(2), "{}", stderr(&refused));
    let told = stderr(&refused);
    assert!(
        told.contains("frames were on can1") && told.contains("--bus FOLDER:LOGGED=RIG"),
        "{told}"
    );
    assert!(!mixed.join("session.toml").exists() && !mixed.join(".import").exists());
    // A folder that holds none of the files: refused before anything is written.
    let nowhere = dir.path().join("nowhere");
    let refused = import(&nowhere, &["--bus", "logger_c:can1=can0"]);
    assert_eq!(refused.status.code(), Some(2), "{}", stderr(&refused));
    assert!(
        stderr(&refused).contains("'logger_c' is none of the files given"),
        "{}",
        stderr(&refused)
    );
    assert!(!nowhere.exists());
}

/// A rig sensor of a quantity the twins do not read (an engine's speed
/// from a J1939 DBC, its coolant's temperature placed by PGN) comes
/// through a logger's file in its own unit: the hold's mean is the mean of
/// the values sent in the hold, computed here from the frames themselves.
#[test]
fn a_sensor_of_any_quantity_comes_from_logger_files_in_its_own_unit() {
    let dir = tempfile::tempdir().unwrap();
    let recorded = root().join("fixtures/sessions/excavator_case1");
    let raw = std::fs::read_to_string(recorded.join("raw.log")).unwrap();
    let time_of = |line: &str| -> f64 { line[1..line.find(')').unwrap()].parse().unwrap() };
    let lines: Vec<&str> = raw.lines().collect();
    let (first_s, last_s) = (time_of(lines[0]), time_of(lines[lines.len() - 1]));
    // The engine controller (source address 0x00) sends EEC1 every 10 ms at
    // priority 6, where the DBC declares 0xFE at 3; the governor holds
    // 1,500 rpm within 6 rpm (0.125 rpm a bit). ET1 once a second: 85 degC.
    let mut logged: Vec<(f64, String)> =
        lines.iter().map(|l| (time_of(l), l.to_string())).collect();
    let mut speeds: Vec<(f64, f64)> = Vec::new();
    let mut k = 0;
    loop {
        let t = first_s + 0.0013 + 0.01 * k as f64;
        if t > last_s {
            break;
        }
        let since = t - first_s;
        let bits = ((1500.0 + 6.0 * (2.0 * std::f64::consts::PI * 0.7 * since).sin()) / 0.125)
            .round() as u16;
        speeds.push((since, f64::from(bits) * 0.125));
        let [low, high] = bits.to_le_bytes();
        logged.push((
            t,
            format!("({t:.6}) can0 18F00400#F07D7D{low:02X}{high:02X}00F07D"),
        ));
        if k % 100 == 0 {
            logged.push((
                t + 0.0002,
                format!("({:.6}) can0 18FEEE00#7DFFFFFFFFFFFFFF", t + 0.0002),
            ));
        }
        k += 1;
    }
    logged.sort_by(|x, y| x.0.total_cmp(&y.0));
    let log = dir.path().join("00000001.log");
    std::fs::write(
        &log,
        logged
            .iter()
            .map(|(_, l)| format!("{l}\n"))
            .collect::<String>(),
    )
    .unwrap();
    let mf4 = dir.path().join("00000001.MF4");
    let converted = acq(&["convert", path_str(&log), "-o", path_str(&mf4)]);
    assert!(converted.status.success(), "{}", stderr(&converted));
    // The rig as recorded, the engine's DBC on the hydraulics bus, and the
    // two sensors of kind "other".
    let rig_dir = dir.path().join("rig");
    std::fs::create_dir_all(&rig_dir).unwrap();
    for name in ["excavator.toml", "somat_excavator.dbc"] {
        std::fs::copy(recorded.join("rig").join(name), rig_dir.join(name)).unwrap();
    }
    std::fs::copy(
        root().join("fixtures/dbc/j1939_source_fe.dbc"),
        rig_dir.join("engine.dbc"),
    )
    .unwrap();
    let rig = rig_dir.join("excavator.toml");
    let text = std::fs::read_to_string(&rig).unwrap();
    let text = text.replacen(
        "name = \"hydraulics\"\niface = \"can0\"\nbitrate = 250000\n",
        "name = \"hydraulics\"\niface = \"can0\"\nbitrate = 250000\ndbc = [\"engine.dbc\"]\n",
        1,
    );
    assert!(
        text.contains("engine.dbc"),
        "the hydraulics bus as the fixture states it"
    );
    std::fs::write(
        &rig,
        text + r#"
[[sensor]]
name = "engine_speed"
kind = "other"
bus = "hydraulics"
rate_hz = 100
dbc = { message = "EEC1", signal = "EngineSpeed", source_address = 0x00 }

[[sensor]]
name = "coolant_temperature"
kind = "other"
unit = "degC"
bus = "hydraulics"
rate_hz = 1
j1939 = { pgn = 65262, source_address = 0x00, start_bit = 0, length_bits = 8, resolution = 1.0, offset = -40.0 }
"#,
    )
    .unwrap();
    let session = dir.path().join("session");
    let imported = acq(&[
        "import",
        path_str(&mf4),
        "--rig",
        path_str(&rig),
        "--out",
        path_str(&session),
    ]);
    assert!(imported.status.success(), "{}", stderr(&imported));
    let out = dir.path().join("measured.csv");
    let extracted = acq(&["extract", path_str(&session), "-o", path_str(&out)]);
    assert!(extracted.status.success(), "{}", stderr(&extracted));
    let rows = measured(&out);
    let holds: Vec<&String> = rows
        .keys()
        .filter(|(_, q)| q == "engine_speed")
        .map(|(w, _)| w)
        .collect();
    assert!(!holds.is_empty(), "{rows:?}");
    for window in holds {
        let speed = &rows[&(window.clone(), "engine_speed".to_string())];
        assert_eq!(speed["unit"], "rpm");
        let (start, end): (f64, f64) = (
            speed["start_s"].parse().unwrap(),
            speed["end_s"].parse().unwrap(),
        );
        let inside: Vec<f64> = speeds
            .iter()
            .filter(|(t, _)| (start..=end).contains(t))
            .map(|(_, v)| *v)
            .collect();
        let want = inside.iter().sum::<f64>() / inside.len() as f64;
        let got: f64 = speed["mean"].parse().unwrap();
        // A sample more or less at an edge moves the mean by under 0.02 rpm;
        // a window placed 0.1 s off, by over 0.1.
        assert!(
            (got - want).abs() < 0.05,
            "{window}: {got} rpm, the frames say {want}"
        );
        let n: usize = speed["n"].parse().unwrap();
        assert!(
            n.abs_diff(inside.len()) <= 1,
            "{n} against {}",
            inside.len()
        );
        let coolant = &rows[&(window.clone(), "coolant_temperature".to_string())];
        assert_eq!(
            (coolant["unit"].as_str(), coolant["mean"].as_str()),
            ("degC", "85.0")
        );
    }
    // The aligned table names each in its unit.
    let aligned = dir.path().join("aligned.csv");
    let output = acq(&["align", path_str(&session), "-o", path_str(&aligned)]);
    assert!(output.status.success(), "{}", stderr(&output));
    let table = std::fs::read_to_string(&aligned).unwrap();
    assert!(
        table.contains("engine_speed [rpm]") && table.contains("coolant_temperature [degC]"),
        "{}",
        &table[..table.len().min(2000)]
    );
}
