//! `acq lake ingest`: a campaign of the shipped session and logger files of
//! our own making (three machines, four days, a logger's file split in two,
//! candump, ASC and MF4 by acq, BLF and MF4 by python-can and asammdf), read back by pyarrow, Polars and DuckDB
//! (tests/parquet/lake.py), each sample of each source once, against `acq
//! decode` of the same file; run again, changed by one byte, and killed
//! mid-source.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Command;

use crate::common::{acq, path_arg, root, stderr};

fn rig() -> PathBuf {
    root().join("fixtures/rigs/excavator.toml")
}

/// `acq simulate` of a shipped scenario (its hold `hold_s` long) into a
/// candump log starting at `start_unix_s`.
fn simulated(dir: &Path, scenario: &str, hold_s: f64, start_unix_s: u64, name: &str) -> PathBuf {
    let text = std::fs::read_to_string(root().join("fixtures/scenarios").join(scenario)).unwrap();
    let text = text.replace("hold_s = 8.0", &format!("hold_s = {hold_s}"));
    let scenario = dir.join(format!("{name}.scenario.toml"));
    std::fs::write(&scenario, text).unwrap();
    let log = dir.join(format!("{name}.log"));
    let start = start_unix_s.to_string();
    let output = acq(&[
        "simulate",
        "--rig",
        path_arg(&rig()),
        "--scenario",
        path_arg(&scenario),
        "-o",
        path_arg(&log),
        "--start",
        &start,
    ]);
    assert!(output.status.success(), "{}", stderr(&output));
    log
}

fn ingest(lake: &Path, device: Option<&str>, inputs: &[&Path]) -> String {
    let rig = rig();
    let mut args = vec!["lake", "ingest"];
    args.extend(inputs.iter().map(|p| path_arg(p)));
    args.extend(["--rig", path_arg(&rig), "--lake", path_arg(lake)]);
    if let Some(device) = device {
        args.extend(["--device", device]);
    }
    let output = acq(&args);
    assert!(output.status.success(), "{args:?}: {}", stderr(&output));
    stderr(&output)
}

/// `acq decode --rig` of `log`: rows and value sum per sensor.
fn decoded(log: &Path) -> BTreeMap<String, (u64, f64)> {
    let output = acq(&["decode", path_arg(log), "--rig", path_arg(&rig())]);
    assert!(output.status.success(), "{}", stderr(&output));
    let mut per_sensor: BTreeMap<String, (u64, f64)> = BTreeMap::new();
    for line in String::from_utf8_lossy(&output.stdout).lines().skip(1) {
        let fields: Vec<&str> = line.split(',').collect();
        let slot = per_sensor.entry(fields[1].to_string()).or_default();
        slot.0 += 1;
        slot.1 += fields[2].parse::<f64>().unwrap_or(0.0);
    }
    per_sensor
}

/// What the three engines read (tests/parquet/lake.py), and DuckDB's rows
/// for each of `queries`.
fn engines(lake: &Path, queries: &[&str]) -> serde_json::Value {
    let output = Command::new(crate::common::scratch_python("lake"))
        .arg(root().join("tests/parquet/lake.py"))
        .arg(lake)
        .args(queries)
        .output()
        .unwrap();
    assert!(output.status.success(), "{}", stderr(&output));
    serde_json::from_slice(&output.stdout).unwrap()
}

/// (device, source, sensor) -> (rows, sum), as one engine read them.
type Counts = BTreeMap<(String, String, String), (u64, f64)>;

fn counts(engine: &serde_json::Value) -> Counts {
    engine["samples"]
        .as_array()
        .unwrap()
        .iter()
        .map(|row| {
            let text = |i: usize| row[i].as_str().unwrap().to_string();
            (
                (text(0), text(1), text(2)),
                (row[3].as_u64().unwrap(), row[4].as_f64().unwrap()),
            )
        })
        .collect()
}

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-9 * a.abs().max(b.abs()).max(1.0)
}

/// Every engine reads every sample of every source once (as `acq decode`
/// decodes it), in files sorted by time, and the same holds and measured
/// values.
fn check_lake(lake: &Path, sources: &[(&str, &Path, &Path)]) -> Counts {
    let read = engines(lake, &[]);
    assert_eq!(
        read["unsorted_files"],
        serde_json::json!([]),
        "files not sorted by time"
    );
    assert_eq!(
        read["spark_refuses"],
        serde_json::json!([]),
        "files Spark's Parquet reader refuses"
    );
    let reference = counts(&read["pyarrow"]);
    for engine in ["polars", "duckdb"] {
        let other = counts(&read[engine]);
        assert_eq!(
            other.keys().collect::<Vec<_>>(),
            reference.keys().collect::<Vec<_>>(),
            "{engine}"
        );
        for (key, (rows, sum)) in &other {
            let (ref_rows, ref_sum) = reference[key];
            assert!(
                *rows == ref_rows && close(*sum, ref_sum),
                "{engine} {key:?}: {rows} {sum} against pyarrow's {ref_rows} {ref_sum}"
            );
        }
        for table in ["holds", "measured"] {
            assert_eq!(
                read[engine][table], read["pyarrow"][table],
                "{engine}: {table}"
            );
        }
    }
    let mut expected = 0;
    for (device, source, log) in sources {
        let source = std::fs::canonicalize(source).unwrap().display().to_string();
        for (sensor, (rows, sum)) in decoded(log) {
            let key = (device.to_string(), source.clone(), sensor.clone());
            let (got_rows, got_sum) = reference
                .get(&key)
                .copied()
                .unwrap_or_else(|| panic!("{key:?} is not in the lake"));
            assert!(got_rows == rows && close(got_sum, sum), "{key:?}: the lake has {got_rows} rows summing to {got_sum}, acq decode {rows} summing to {sum}");
            expected += 1;
        }
    }
    assert_eq!(
        reference.len(),
        expected,
        "the lake holds sources or sensors it was not given"
    );
    reference
}

/// Every published file of the lake and its length and modification time.
fn published(lake: &Path) -> BTreeMap<PathBuf, (u64, std::time::SystemTime)> {
    let mut files = BTreeMap::new();
    let mut dirs = vec![lake.to_path_buf()];
    while let Some(dir) = dirs.pop() {
        for item in std::fs::read_dir(&dir).unwrap().flatten() {
            let path = item.path();
            let meta = item.metadata().unwrap();
            if meta.is_dir() {
                if !path.ends_with("_tmp") {
                    dirs.push(path);
                }
            } else {
                files.insert(path, (meta.len(), meta.modified().unwrap()));
            }
        }
    }
    files
}

#[test]
fn a_campaign_is_in_the_lake_once_however_often_it_is_ingested() {
    let dir = tempfile::tempdir().unwrap();
    let dir = dir.path();
    let lake = dir.join("lake");
    // Machine 1: the shipped session (2026-11-21), and a logger's day
    // (2026-10-05) split into two files at a line, as loggers split.
    let session = root().join("fixtures/sessions/excavator_case1");
    let day = simulated(dir, "excavator_case1.toml", 8.0, 1_791_187_200, "day");
    let text = std::fs::read_to_string(&day).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    let (first, second) = lines.split_at(lines.len() / 2);
    let part1 = dir.join("00000001.log");
    let part2 = dir.join("00000002.log");
    std::fs::write(&part1, first.join("\n") + "\n").unwrap();
    std::fs::write(&part2, second.join("\n") + "\n").unwrap();
    // Machine 2: two days of Case 2, as ASC and as MF4.
    let case2_a = simulated(dir, "excavator_case2.toml", 8.0, 1_791_273_600, "case2_a");
    let case2_b = simulated(dir, "excavator_case2.toml", 6.0, 1_791_360_000, "case2_b");
    let asc = dir.join("case2_a.asc");
    let mf4 = dir.join("case2_b.mf4");
    for (from, to) in [(&case2_a, &asc), (&case2_b, &mf4)] {
        let output = acq(&["convert", path_arg(from), "-o", path_arg(to)]);
        assert!(output.status.success(), "{}", stderr(&output));
    }
    // Machine 3: Case 1 later that day, in files other programs wrote:
    // BLF by python-can, MF4 by python-can through asammdf.
    let case1_c = simulated(dir, "excavator_case1.toml", 4.0, 1_791_367_200, "case1_c");
    let blf = dir.join("case1_c.blf");
    let mf4_by_asammdf = dir.join("case1_c.mf4");
    for (format, to) in [("blf", &blf), ("mf4", &mf4_by_asammdf)] {
        let output = Command::new(crate::common::scratch_python("lake"))
            .arg(root().join("tests/python_can/frames.py"))
            .args([format, path_arg(&case1_c), path_arg(to)])
            .output()
            .unwrap();
        assert!(output.status.success(), "{format}: {}", stderr(&output));
    }
    let said = ingest(&lake, Some("machine1"), &[&session, &part1, &part2]);
    assert_eq!(said.matches(": ingested: ").count(), 3, "{said}");
    ingest(&lake, Some("machine2"), &[&asc, &mf4]);
    ingest(&lake, Some("machine3"), &[&blf, &mf4_by_asammdf]);
    let raw = session.join("raw.log");
    let sources: Vec<(&str, &Path, &Path)> = vec![
        ("machine1", &session, &raw),
        ("machine1", &part1, &part1),
        ("machine1", &part2, &part2),
        ("machine2", &asc, &case2_a),
        ("machine2", &mf4, &case2_b),
        ("machine3", &blf, &case1_c),
        ("machine3", &mf4_by_asammdf, &case1_c),
    ];
    let first_counts = check_lake(&lake, &sources);
    let dates: std::collections::BTreeSet<String> = published(&lake)
        .keys()
        .filter_map(|p| {
            p.to_str()?
                .split("date=")
                .nth(1)?
                .get(..10)
                .map(str::to_string)
        })
        .collect();
    assert_eq!(dates.len(), 4, "four days: {dates:?}");

    // Again: nothing is written.
    let before = published(&lake);
    let said = ingest(&lake, Some("machine1"), &[&session, &part1, &part2]);
    assert_eq!(
        said.matches("unchanged since its ingest, skipped").count(),
        3,
        "{said}"
    );
    assert_eq!(published(&lake), before, "a second ingest changed the lake");

    // One byte of one file changed: that file is ingested again, in place.
    let mut text = std::fs::read_to_string(&part2).unwrap();
    let at = text.find('#').unwrap() + 1;
    let digit = if &text[at..=at] == "0" { "1" } else { "0" };
    text.replace_range(at..=at, digit);
    std::fs::write(&part2, text).unwrap();
    let said = ingest(&lake, Some("machine1"), &[&session, &part1, &part2]);
    assert_eq!(
        said.matches("ingested again, its earlier files replaced")
            .count(),
        1,
        "{said}"
    );
    assert_eq!(
        said.matches("unchanged since its ingest").count(),
        2,
        "{said}"
    );
    let after = check_lake(&lake, &sources);
    assert_eq!(after.len(), first_counts.len());
    let moved: Vec<_> = after
        .iter()
        .filter(|(k, v)| first_counts[k] != **v)
        .map(|(k, _)| k)
        .collect();
    assert!(
        !moved.is_empty() && moved.iter().all(|k| k.1.ends_with("00000002.log")),
        "{moved:?}"
    );

    // An entry as an acq of the manifest's first format wrote it (its
    // content's SHA-256, no BLAKE3): its source is ingested again, to the
    // same rows, and the others stay as they are.
    let entries: Vec<PathBuf> = std::fs::read_dir(lake.join("_manifest"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    let part1_entry = entries
        .iter()
        .find(|p| std::fs::read_to_string(p).unwrap().contains("00000001.log"))
        .unwrap();
    let mut old: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(part1_entry).unwrap()).unwrap();
    let fields = old.as_object_mut().unwrap();
    assert!(
        fields["blake3"].as_str().is_some_and(|h| h.len() == 64),
        "{fields:?}"
    );
    fields.insert("format".into(), 1.into());
    for (new, was) in [("blake3", "sha256"), ("rig_blake3", "rig_sha256")] {
        fields.remove(new);
        fields.insert(was.into(), "0".repeat(64).into());
    }
    std::fs::write(part1_entry, serde_json::to_string_pretty(&old).unwrap()).unwrap();
    let said = ingest(&lake, Some("machine1"), &[&session, &part1, &part2]);
    assert_eq!(said.matches("ingested again").count(), 1, "{said}");
    assert_eq!(
        said.matches("unchanged since its ingest").count(),
        2,
        "{said}"
    );
    assert_eq!(check_lake(&lake, &sources), after);
}

/// SIGKILL in the middle of a long source: every file the lake shows is
/// whole, the killed source has no entry, and the next ingest ends in the
/// lake a run without the kill gives.
#[test]
fn a_killed_ingest_leaves_whole_files_and_the_next_one_completes_it() {
    let dir = tempfile::tempdir().unwrap();
    let dir = dir.path();
    let short = simulated(dir, "excavator_case1.toml", 8.0, 1_791_187_200, "short");
    // Long enough that its decode (about 1 s of a 2-core machine's time in
    // a release build) is far from done when the kill comes.
    let long = simulated(dir, "excavator_case1.toml", 2400.0, 1_791_273_600, "long");
    let lake = dir.join("lake");
    let mut child = Command::new(env!("CARGO_BIN_EXE_acq"))
        .args([
            "lake",
            "ingest",
            path_arg(&short),
            path_arg(&long),
            "--rig",
            path_arg(&rig()),
            "--lake",
            path_arg(&lake),
        ])
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    // Killed once the short log is published, while the long one is decoded.
    let started = std::time::Instant::now();
    let entry = |lake: &Path| std::fs::read_dir(lake.join("_manifest")).map_or(0, |d| d.count());
    while entry(&lake) == 0 {
        assert!(
            started.elapsed().as_secs() < 60,
            "the short log was never published"
        );
        assert!(
            child.try_wait().unwrap().is_none(),
            "the ingest ended before it could be killed"
        );
        std::thread::sleep(std::time::Duration::from_millis(5));
    }
    // The long log's decode under way: a 300 ms wait let a faster ingest
    // publish its files before the kill.
    std::thread::sleep(std::time::Duration::from_millis(50));
    assert!(
        child.try_wait().unwrap().is_none(),
        "the long log was ingested before the kill; make it longer"
    );
    child.kill().unwrap();
    child.wait().unwrap();
    assert_eq!(entry(&lake), 1, "only the short log's entry");
    // Every published file reads whole; the long log's are still in _tmp.
    let read = engines(&lake, &[]);
    let sources: std::collections::BTreeSet<String> = counts(&read["pyarrow"])
        .keys()
        .map(|k| k.1.clone())
        .collect();
    assert_eq!(sources.len(), 1, "{sources:?}");

    let said = ingest(&lake, None, &[&short, &long]);
    assert!(
        said.contains("unchanged since its ingest") && said.contains(": ingested: "),
        "{said}"
    );
    assert!(
        std::fs::read_dir(lake.join("_tmp"))
            .unwrap()
            .next()
            .is_none(),
        "the killed ingest's scratch files are gone"
    );
    let clean = dir.join("clean");
    ingest(&clean, None, &[&short, &long]);
    let files = |lake: &Path| -> Vec<(PathBuf, u64)> {
        published(lake)
            .into_iter()
            .filter(|(p, _)| !p.to_string_lossy().contains("_manifest"))
            .map(|(p, (len, _))| (p.strip_prefix(lake).unwrap().to_path_buf(), len))
            .collect()
    };
    assert_eq!(
        files(&lake),
        files(&clean),
        "the completed lake differs from a clean ingest"
    );
}

/// Two cells agree: equal text, or numbers equal to 1e-9 (engines sum in
/// different orders).
fn same_cell(a: &str, b: &str) -> bool {
    match (a.parse::<f64>(), b.parse::<f64>()) {
        (Ok(x), Ok(y)) => close(x, y),
        _ => a == b,
    }
}

/// A CSV's rows after its header, split at commas (no cell of these
/// holds one).
fn csv_rows(text: &str) -> Vec<Vec<String>> {
    text.lines()
        .skip(1)
        .map(|l| l.split(',').map(str::to_string).collect())
        .collect()
}

/// `acq lake query` gives DuckDB's rows for the same SQL, row for row; `acq
/// lake extract` of one session gives `acq extract`'s values of it, and of
/// two sessions a table that `acq calibrate excavator` takes as it takes
/// one session's, with the same result.
#[test]
fn query_and_extract_agree_with_duckdb_and_acq_extract() {
    let dir = tempfile::tempdir().unwrap();
    let dir = dir.path();
    let lake = dir.join("lake");
    let case1 = root().join("fixtures/sessions/excavator_case1");
    let case2 = root().join("fixtures/sessions/excavator_case2");
    ingest(&lake, None, &[&case1, &case2]);
    let queries = [
        "SELECT sensor, count(*) AS n, sum(value) AS total FROM samples GROUP BY sensor ORDER BY sensor",
        "SELECT session, value FROM samples WHERE sensor = 'tip_force' AND value > 20 ORDER BY session, time",
        "SELECT session, hold, start_s, end_s FROM holds ORDER BY session",
        "SELECT session, quantity, mean, \"U95\" FROM measured WHERE quantity LIKE '%loaded_pressure' ORDER BY session, quantity",
    ];
    let duckdb = engines(&lake, &queries)["queries"].clone();
    for (index, sql) in queries.iter().enumerate() {
        let output = acq(&["lake", "query", path_arg(&lake), sql]);
        assert!(output.status.success(), "{sql}: {}", stderr(&output));
        let ours = csv_rows(&String::from_utf8_lossy(&output.stdout));
        let theirs: Vec<Vec<String>> = serde_json::from_value(duckdb[index].clone()).unwrap();
        assert!(!ours.is_empty(), "{sql}: no rows");
        assert_eq!(ours.len(), theirs.len(), "{sql}");
        for (a, b) in ours.iter().zip(&theirs) {
            assert!(
                a.len() == b.len() && a.iter().zip(b).all(|(x, y)| same_cell(x, y)),
                "{sql}: acq {a:?}, DuckDB {b:?}"
            );
        }
    }

    let write = |args: &[&str]| {
        let output = acq(args);
        assert!(output.status.success(), "{args:?}: {}", stderr(&output));
    };
    let (one, plain) = (dir.join("one.csv"), dir.join("plain.csv"));
    write(&[
        "lake",
        "extract",
        path_arg(&lake),
        "--where",
        "session = 'excavator_case1'",
        "-o",
        path_arg(&one),
    ]);
    write(&["extract", path_arg(&case1), "-o", path_arg(&plain)]);
    let read = |p: &Path| csv_rows(&std::fs::read_to_string(p).unwrap());
    let (ours, theirs) = (read(&one), read(&plain));
    assert_eq!(ours.len(), theirs.len());
    for (a, b) in ours.iter().zip(&theirs) {
        assert_eq!(a[0], "excavator_case1");
        assert!(
            a.len() == b.len() + 1 && a[1..].iter().zip(b).all(|(x, y)| same_cell(x, y)),
            "lake extract {a:?}, acq extract {b:?}"
        );
    }

    // Both sessions in one file, the second's hold chosen by its name.
    let (both, plain2) = (dir.join("both.csv"), dir.join("plain2.csv"));
    write(&["lake", "extract", path_arg(&lake), "-o", path_arg(&both)]);
    write(&["extract", path_arg(&case2), "-o", path_arg(&plain2)]);
    assert_eq!(read(&both).len(), ours.len() + read(&plain2).len());
    let case = root().join("data/excavator/case2.toml");
    let (run_lake, run_plain) = (dir.join("run_lake"), dir.join("run_plain"));
    write(&[
        "calibrate",
        "excavator",
        "--case",
        path_arg(&case),
        "--measured",
        path_arg(&both),
        "--window",
        "excavator_case2/hold1",
        "--out",
        path_arg(&run_lake),
    ]);
    write(&[
        "calibrate",
        "excavator",
        "--case",
        path_arg(&case),
        "--measured",
        path_arg(&plain2),
        "--out",
        path_arg(&run_plain),
    ]);
    let optimal = |run: &Path| -> serde_json::Value {
        let summary: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(run.join("summary.json")).unwrap())
                .unwrap();
        summary["optimal"].clone()
    };
    assert_eq!(
        optimal(&run_lake),
        optimal(&run_plain),
        "a calibration on the lake's table differs"
    );
}

/// A logger that names its channels otherwise (`can5` and `can6` for the
/// rig's `can0` and `can1`): without `--bus` nothing of it decodes and the
/// ingest says so; with `--bus can5=can0 --bus can6=can1` every sample is
/// in the lake as `acq decode` gives the log with the rig's names; another
/// mapping ingests it again; a pair naming no bus of the rig is refused.
#[test]
fn a_logger_s_own_channel_names_are_mapped_to_the_rig_s_buses() {
    let dir = tempfile::tempdir().unwrap();
    let dir = dir.path();
    let original = simulated(dir, "excavator_case1.toml", 4.0, 1_791_187_200, "original");
    let text = std::fs::read_to_string(&original).unwrap();
    let logged = dir.join("logger.log");
    std::fs::write(
        &logged,
        text.replace(" can0 ", " can5 ").replace(" can1 ", " can6 "),
    )
    .unwrap();
    let lake = dir.join("lake");
    let rig = rig();
    let run = |extra: &[&str]| {
        let mut args = vec!["lake", "ingest", path_arg(&logged)];
        args.extend(["--rig", path_arg(&rig), "--lake", path_arg(&lake)]);
        args.extend(extra);
        acq(&args)
    };
    let without = run(&[]);
    assert_eq!(without.status.code(), Some(2), "{}", stderr(&without));
    assert!(
        stderr(&without).contains("no sample of any rig sensor"),
        "{}",
        stderr(&without)
    );

    let with = run(&["--bus", "can5=can0", "--bus", "can6=can1"]);
    assert!(with.status.success(), "{}", stderr(&with));
    let query = acq(&[
        "lake",
        "query",
        path_arg(&lake),
        "SELECT sensor, count(*) AS n, sum(value) AS s FROM samples GROUP BY sensor ORDER BY sensor",
    ]);
    assert!(query.status.success(), "{}", stderr(&query));
    let in_lake: BTreeMap<String, (u64, f64)> = String::from_utf8_lossy(&query.stdout)
        .lines()
        .skip(1)
        .map(|line| {
            let fields: Vec<&str> = line.split(',').collect();
            (
                fields[0].to_string(),
                (fields[1].parse().unwrap(), fields[2].parse().unwrap_or(0.0)),
            )
        })
        .collect();
    let expected = decoded(&original);
    assert_eq!(
        in_lake.keys().collect::<Vec<_>>(),
        expected.keys().collect::<Vec<_>>()
    );
    for (sensor, (rows, sum)) in &expected {
        let (got_rows, got_sum) = in_lake[sensor];
        assert!(
            got_rows == *rows && close(got_sum, *sum),
            "{sensor}: {got_rows} {got_sum} against {rows} {sum}"
        );
    }
    // The same mapping again: skipped; the buses swapped: ingested again.
    let again = run(&["--bus", "can5=can0", "--bus", "can6=can1"]);
    assert!(
        stderr(&again).contains("unchanged since its ingest"),
        "{}",
        stderr(&again)
    );
    let swapped = run(&["--bus", "can6=can0", "--bus", "can5=can1"]);
    assert!(
        stderr(&swapped).contains("not ingested") || stderr(&swapped).contains("ingested again"),
        "{}",
        stderr(&swapped)
    );
    let wrong = run(&["--bus", "can5=can9"]);
    assert_eq!(wrong.status.code(), Some(2));
    assert!(
        stderr(&wrong).contains("--bus can5=can9: the rig has no bus on can9"),
        "{}",
        stderr(&wrong)
    );
}

/// Two loggers that both log a `can1`, and it is not the same bus: logger
/// A's wiring has the rig's buses swapped (its `can1` is the rig's `can0`,
/// its `can0` the rig's `can1`), logger B names them as the rig does. With
/// the swap scoped to A's folder (given relative to where acq runs, the
/// logs by absolute path) each log's samples are in the lake as `acq
/// decode` gives its original; a mapping changed for B ingests B again and
/// leaves A alone; a scope that is no file, or holds none of the logs, is
/// refused before anything is written.
#[test]
fn two_loggers_that_both_log_can1_stay_apart_with_scoped_buses() {
    let dir = tempfile::tempdir().unwrap();
    let dir = dir.path();
    let original_a = simulated(dir, "excavator_case1.toml", 3.0, 1_791_187_200, "a");
    let original_b = simulated(dir, "excavator_case1.toml", 3.0, 1_791_190_800, "b");
    for folder in ["logger_a", "logger_b", "logger_c"] {
        std::fs::create_dir(dir.join(folder)).unwrap();
    }
    let log_a = dir.join("logger_a/day1.log");
    let swapped = std::fs::read_to_string(&original_a)
        .unwrap()
        .replace(" can0 ", " swap ")
        .replace(" can1 ", " can0 ")
        .replace(" swap ", " can1 ");
    std::fs::write(&log_a, swapped).unwrap();
    let log_b = dir.join("logger_b/day1.log");
    std::fs::copy(&original_b, &log_b).unwrap();
    let lake = dir.join("lake");
    let run = |buses: &[&str]| {
        let mut command = Command::new(env!("CARGO_BIN_EXE_acq"));
        command.current_dir(dir);
        command.args(["lake", "ingest", path_arg(&log_a), path_arg(&log_b)]);
        command.args(["--rig", path_arg(&rig()), "--lake", path_arg(&lake)]);
        for bus in buses {
            command.args(["--bus", bus]);
        }
        command.output().unwrap()
    };
    let scoped = ["logger_a:can1=can0", "logger_a:can0=can1"];
    let first = run(&scoped);
    assert!(first.status.success(), "{}", stderr(&first));

    let query = acq(&[
        "lake",
        "query",
        path_arg(&lake),
        "SELECT source_file, sensor, count(*) AS n, sum(value) AS s FROM samples \
         GROUP BY source_file, sensor ORDER BY source_file, sensor",
    ]);
    assert!(query.status.success(), "{}", stderr(&query));
    let mut in_lake: BTreeMap<&str, BTreeMap<String, (u64, f64)>> = BTreeMap::new();
    let text = String::from_utf8_lossy(&query.stdout);
    for line in text.lines().skip(1) {
        let fields: Vec<&str> = line.split(',').collect();
        let logger = if fields[0].contains("logger_a") {
            "a"
        } else if fields[0].contains("logger_b") {
            "b"
        } else {
            panic!("a source of neither logger: {line}")
        };
        in_lake.entry(logger).or_default().insert(
            fields[1].to_string(),
            (fields[2].parse().unwrap(), fields[3].parse().unwrap_or(0.0)),
        );
    }
    for (logger, original) in [("a", &original_a), ("b", &original_b)] {
        let expected = decoded(original);
        let got = &in_lake[logger];
        assert_eq!(
            got.keys().collect::<Vec<_>>(),
            expected.keys().collect::<Vec<_>>(),
            "logger {logger}"
        );
        for (sensor, (rows, sum)) in &expected {
            let (got_rows, got_sum) = got[sensor];
            assert!(
                got_rows == *rows && close(got_sum, *sum),
                "logger {logger}, {sensor}: {got_rows} {got_sum} against {rows} {sum}"
            );
        }
    }

    // B's mapping changed (its can1 named as itself, which moves nothing):
    // B again, A unchanged.
    let changed = run(&[scoped[0], scoped[1], "logger_b:can1=can1"]);
    assert!(changed.status.success(), "{}", stderr(&changed));
    let told = stderr(&changed);
    let line_of = |logger: &str| {
        told.lines()
            .find(|line| line.contains(logger))
            .unwrap_or_else(|| panic!("nothing said of {logger}: {told}"))
            .to_string()
    };
    assert!(
        line_of("logger_a").contains("unchanged since its ingest"),
        "{told}"
    );
    assert!(line_of("logger_b").contains("ingested again"), "{told}");

    for (bus, says) in [
        ("logger_x:can1=can0", "--bus logger_x:can1=can0: logger_x"),
        ("logger_c:can1=can0", "is none of the files given"),
        ("logger_a:can1=can9", "the rig has no bus on can9"),
    ] {
        let refused = run(&[bus]);
        assert_eq!(
            refused.status.code(),
            Some(2),
            "{bus}: {}",
            stderr(&refused)
        );
        assert!(
            stderr(&refused).contains(says),
            "{bus}: {}",
            stderr(&refused)
        );
    }
    let fresh = dir.join("fresh");
    let refused = {
        let mut command = Command::new(env!("CARGO_BIN_EXE_acq"));
        command.current_dir(dir);
        command.args([
            "lake",
            "ingest",
            path_arg(&log_a),
            "--rig",
            path_arg(&rig()),
        ]);
        command.args(["--lake", path_arg(&fresh), "--bus", "logger_c:can1=can0"]);
        command.output().unwrap()
    };
    assert_eq!(refused.status.code(), Some(2), "{}", stderr(&refused));
    assert!(!fresh.exists(), "a refused ingest made its lake");
}
