//! `-o X.mf4` on decode and align: signals as MF4 channel groups with
//! units, read by asammdf (the reference MDF library most test engineers'
//! tools build on). Every value asammdf reads equals the CSV acq writes for
//! the same command, at the same instant to the nanosecond; a missing value
//! (an aligned gap, a device's "not available") is an invalid sample.
//! asammdf lives in a scratch virtualenv (tests/mf4_output/dump.py).

mod common;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Command;

use common::{acq, path_arg, stderr};

/// asammdf's channels: (group, channel) -> (unit, [(time ns, value)]).
type Channels = BTreeMap<(String, String), (String, Vec<(i64, Option<f64>)>)>;

fn asammdf_view(python: &Path, mf4: &Path) -> (String, Channels) {
    let output = Command::new(python)
        .arg(common::root().join("tests/mf4_output/dump.py"))
        .arg(mf4)
        .output()
        .unwrap();
    assert!(output.status.success(), "{}", stderr(&output));
    let text = String::from_utf8_lossy(&output.stdout);
    let mut lines = text.lines();
    let head: serde_json::Value = serde_json::from_str(lines.next().unwrap()).unwrap();
    let mut channels = Channels::new();
    for line in lines {
        let channel: serde_json::Value = serde_json::from_str(line).unwrap();
        let times = channel["time_ns"].as_array().unwrap();
        let values = channel["values"].as_array().unwrap();
        channels.insert(
            (
                channel["group"].as_str().unwrap().to_string(),
                channel["channel"].as_str().unwrap().to_string(),
            ),
            (
                channel["unit"].as_str().unwrap().to_string(),
                times
                    .iter()
                    .zip(values)
                    .map(|(t, v)| (t.as_i64().unwrap(), v.as_f64()))
                    .collect(),
            ),
        );
    }
    (head["comment"].as_str().unwrap_or("").to_string(), channels)
}

/// `acq ARGS -o NAME.csv` and `-o NAME.mf4`.
fn both(dir: &Path, name: &str, args: &[&str]) -> (String, PathBuf) {
    let mut written = Vec::new();
    for extension in ["csv", "mf4"] {
        let path = dir.join(format!("{name}.{extension}"));
        let mut full = args.to_vec();
        full.extend(["-o", path_arg(&path)]);
        let output = acq(&full);
        assert!(output.status.success(), "{full:?}: {}", stderr(&output));
        assert!(!dir.join(format!("{name}.{extension}.partial")).exists());
        written.push(path);
    }
    (
        std::fs::read_to_string(&written[0]).unwrap(),
        written.pop().unwrap(),
    )
}

fn ns_of_seconds(text: &str) -> i64 {
    let (whole, fraction) = text.split_once('.').unwrap_or((text, ""));
    let digits = format!("{fraction:0<9}");
    whole.parse::<i64>().unwrap() * 1_000_000_000 + digits[..9].parse::<i64>().unwrap()
}

#[test]
fn mf4_signals_equal_the_csv_in_asammdf() {
    let python = common::scratch_python("can-logs");
    let dir = tempfile::tempdir().unwrap();
    let dir = dir.path();
    let log = "fixtures/logs/excavator_case1.log";

    // decode --rig: a group per sensor, one record per sample.
    let (csv, mf4) = both(
        dir,
        "rig",
        &["decode", log, "--rig", "fixtures/rigs/excavator.toml"],
    );
    let (_, channels) = asammdf_view(&python, &mf4);
    let mut expected: Channels = Channels::new();
    for line in csv.lines().skip(1) {
        let cells: Vec<&str> = line.split(',').collect();
        let entry = expected
            .entry((cells[1].to_string(), cells[1].to_string()))
            .or_insert_with(|| (cells[3].to_string(), Vec::new()));
        entry
            .1
            .push((ns_of_seconds(cells[0]), cells[2].parse::<f64>().ok()));
    }
    for (key, (unit, samples)) in &expected {
        let (their_unit, theirs) = &channels[key];
        assert_eq!(unit, their_unit, "{key:?}");
        assert_eq!(samples, theirs, "{key:?}");
    }
    assert!(expected.len() > 10);

    // decode --dbc: a group per message, a channel per signal.
    let (csv, mf4) = both(
        dir,
        "dbc",
        &["decode", log, "--dbc", "fixtures/dbc/somat_excavator.dbc"],
    );
    let (_, channels) = asammdf_view(&python, &mf4);
    let mut compared = 0;
    let mut positions: BTreeMap<(String, String), usize> = BTreeMap::new();
    for line in csv.lines().skip(1) {
        let cells: Vec<&str> = line.split(',').collect();
        let key = (cells[3].to_string(), cells[4].to_string());
        let (unit, samples) = &channels[&key];
        assert_eq!(unit, cells[6], "{key:?}");
        let position = positions.entry(key.clone()).or_default();
        let value: f64 = cells[5].parse().unwrap();
        assert_eq!(
            samples[*position],
            (ns_of_seconds(cells[0]), Some(value)),
            "{key:?}"
        );
        *position += 1;
        compared += 1;
    }
    for (key, count) in &positions {
        assert_eq!(channels[key].1.len(), *count, "{key:?}");
    }
    assert!(compared > 50);

    // align: one group; a gap is an invalid sample; values bit for bit.
    let (csv, mf4) = both(
        dir,
        "aligned",
        &["align", "fixtures/sessions/excavator_case1"],
    );
    let (comment, channels) = asammdf_view(&python, &mf4);
    assert!(comment.contains("session start"), "{comment}");
    let mut rows = csv.lines().filter(|l| !l.starts_with('#'));
    let header: Vec<&str> = rows.next().unwrap().split(',').collect();
    let rows: Vec<Vec<&str>> = rows.map(|l| l.split(',').collect()).collect();
    let mut gaps = 0;
    for (column, heading) in header.iter().enumerate().skip(1).step_by(2) {
        let (name, unit) = heading.trim_end_matches(']').split_once(" [").unwrap();
        let (their_unit, samples) = &channels[&("aligned".to_string(), name.to_string())];
        assert_eq!(unit, their_unit);
        assert_eq!(samples.len(), rows.len());
        let first_ns = samples[0].0;
        for (row, (time_ns, value)) in rows.iter().zip(samples) {
            // Relative to the first row, to the nanosecond.
            assert_eq!(
                time_ns - first_ns,
                ns_of_seconds(row[0]) - ns_of_seconds(rows[0][0]),
                "{name}"
            );
            let expected = row[column].parse::<f64>().ok();
            assert_eq!(expected.is_none(), row[column + 1] == "1");
            assert_eq!(
                value.map(f64::to_bits),
                expected.map(f64::to_bits),
                "{name} at {}",
                row[0]
            );
            gaps += usize::from(value.is_none());
        }
    }
    assert!(gaps > 0, "the session's start has gaps");
}

#[test]
fn extract_refuses_mf4_and_says_what_to_write() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("measured.mf4");
    let output = acq(&[
        "extract",
        "fixtures/sessions/excavator_case2",
        "-o",
        path_arg(&out),
    ]);
    assert_eq!(output.status.code(), Some(2), "{}", stderr(&output));
    assert!(
        stderr(&output).contains(".csv or .parquet"),
        "{}",
        stderr(&output)
    );
    assert!(!out.exists());
}

/// A J1939 DBC states each message from one source address (0xFE here);
/// the log carries others (0x00 and 0x21) at priorities 3 and 6. acq's
/// decode of the logger's MF4 matches by PGN, as asammdf's
/// `extract_bus_logging` does, and equals it value for value and instant
/// for instant, each source address apart; as MF4, each frame's source
/// address is a channel beside its values.
#[test]
fn a_j1939_dbc_decodes_an_mf4_log_by_pgn_as_asammdf_does() {
    let python = common::scratch_python("can-logs");
    let dir = tempfile::tempdir().unwrap();
    let dbc = common::root().join("fixtures/dbc/j1939_source_fe.dbc");
    // Engine speed from two ECUs (0x00 at 800 rpm up, 0x21 at 1500 rpm
    // down), mostly at priority 3, every fifth at 6; vehicle speed from
    // 0x00. Whole 8-byte frames (asammdf pads a shorter one with zeros,
    // cantools and acq refuse it).
    let mut log = String::new();
    for k in 0..60u32 {
        let time = format!("1700000000.{:06}", 10_000 * k);
        let priority = if k % 5 == 0 { 6 } else { 3 };
        let (source, rpm) = if k % 3 == 0 {
            (0x21, 1500 - 5 * k)
        } else {
            (0x00, 800 + 20 * k)
        };
        let raw = rpm * 8;
        let id = (priority << 26) | (0xF004 << 8) | source;
        log += &format!(
            "({time}) can0 {id:08X}#000000{:02X}{:02X}000000\n",
            raw & 0xFF,
            raw >> 8
        );
        let speed = (10 * 256 + 128 * k) & 0xFFFF;
        log += &format!(
            "(1700000000.{:06}) can0 18FEF100#00{:02X}{:02X}0000000000\n",
            10_000 * k + 5_000,
            speed & 0xFF,
            speed >> 8
        );
    }
    let candump = dir.path().join("frames.log");
    std::fs::write(&candump, log).unwrap();
    let mf4 = dir.path().join("frames.mf4");
    let converted = acq(&["convert", path_arg(&candump), "-o", path_arg(&mf4)]);
    assert!(converted.status.success(), "{}", stderr(&converted));
    let decode_into = |out: &Path| {
        let decoded = acq(&[
            "decode",
            path_arg(&mf4),
            "--dbc",
            path_arg(&dbc),
            "-o",
            path_arg(out),
        ]);
        assert!(decoded.status.success(), "{}", stderr(&decoded));
    };
    let csv = dir.path().join("decoded.csv");
    decode_into(&csv);

    // acq's rows: (signal, source address) -> [(s from the first frame, value)].
    type Series = BTreeMap<(String, u32), Vec<(f64, f64)>>;
    let mut ours = Series::new();
    let text = std::fs::read_to_string(&csv).unwrap();
    let mut first = None;
    for line in text.lines().skip(1) {
        let cells: Vec<&str> = line.split(',').collect();
        let time: f64 = cells[0].parse().unwrap();
        let first = *first.get_or_insert(time);
        let id = u32::from_str_radix(cells[2].trim_start_matches("0x"), 16).unwrap();
        ours.entry((cells[4].to_string(), id & 0xFF))
            .or_default()
            .push((time - first, cells[5].parse().unwrap()));
    }
    let output = Command::new(&python)
        .arg(common::root().join("tests/mf4_output/j1939.py"))
        .arg(&mf4)
        .arg(&dbc)
        .output()
        .unwrap();
    assert!(output.status.success(), "{}", stderr(&output));
    let mut theirs = Series::new();
    for line in String::from_utf8_lossy(&output.stdout).lines() {
        let series: serde_json::Value = serde_json::from_str(line).unwrap();
        let times: Vec<f64> = serde_json::from_value(series["times_s"].clone()).unwrap();
        let values: Vec<f64> = serde_json::from_value(series["values"].clone()).unwrap();
        theirs.insert(
            (
                series["signal"].as_str().unwrap().to_string(),
                series["source_address"].as_u64().unwrap() as u32,
            ),
            times.into_iter().zip(values).collect(),
        );
    }
    let keys = |s: &Series| s.keys().cloned().collect::<Vec<_>>();
    assert_eq!(
        keys(&ours),
        vec![
            ("EngineSpeed".to_string(), 0x00),
            ("EngineSpeed".to_string(), 0x21),
            ("WheelBasedVehicleSpeed".to_string(), 0x00)
        ]
    );
    assert_eq!(keys(&ours), keys(&theirs));
    for (key, series) in &ours {
        let other = &theirs[key];
        assert_eq!(series.len(), other.len(), "{key:?}");
        for ((t, v), (their_t, their_v)) in series.iter().zip(other) {
            // asammdf's times of python-can's layout carry float rounding.
            assert!(
                (t - their_t).abs() < 1e-5,
                "{key:?}: {t} s against {their_t} s"
            );
            assert_eq!(v, their_v, "{key:?} at {t} s");
        }
    }
    // As MF4, each J1939 message's group holds its frames' source address
    // beside the values: in asammdf, the two ECUs' engine speeds are told
    // apart by it, record for record as in the CSV.
    let signals_mf4 = dir.path().join("decoded.mf4");
    decode_into(&signals_mf4);
    let (_, channels) = asammdf_view(&python, &signals_mf4);
    let channel = |group: &str, name: &str| -> Vec<f64> {
        let (_, samples) = &channels[&(group.to_string(), name.to_string())];
        samples.iter().map(|(_, value)| value.unwrap()).collect()
    };
    for (group, signal) in [("EEC1", "EngineSpeed"), ("CCVS1", "WheelBasedVehicleSpeed")] {
        let sources = channel(group, "source_address");
        let values = channel(group, signal);
        let mut by_source = Series::new();
        for (source, value) in sources.iter().zip(&values) {
            by_source
                .entry((signal.to_string(), *source as u32))
                .or_default()
                .push((0.0, *value));
        }
        for ((name, source), series) in &by_source {
            let csv_values: Vec<f64> = ours[&(name.clone(), *source)]
                .iter()
                .map(|(_, v)| *v)
                .collect();
            let mf4_values: Vec<f64> = series.iter().map(|(_, v)| *v).collect();
            assert_eq!(mf4_values, csv_values, "{group}.{name} from {source:#04X}");
        }
        let csv_count: usize = ours
            .iter()
            .filter(|((name, _), _)| name == signal)
            .map(|(_, series)| series.len())
            .sum();
        assert_eq!(values.len(), csv_count, "{group}");
    }
    // Asked for exact ids, nothing of this log is the DBC's.
    let exact = acq(&[
        "decode",
        path_arg(&mf4),
        "--dbc",
        path_arg(&dbc),
        "--exact-ids",
    ]);
    assert!(exact.status.success(), "{}", stderr(&exact));
    assert_eq!(
        String::from_utf8_lossy(&exact.stdout).lines().count(),
        1,
        "only the header"
    );
}
