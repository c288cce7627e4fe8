//! The fixed interfaces of a calibration run directory, as a snapshot: the
//! key paths of `summary.json`, the header of `evaluations.csv`, the
//! report's headings and the files the run leaves. Recorded from the code
//! before a refactoring (`ACQ_RECORD_INTERFACES=1`) into
//! `fixtures/expected/interfaces/NAME.txt`, then compared after it: every
//! recorded key, heading and file must still be there (a report may gain
//! sections, a summary keys), and the log's header must be the same.

use std::collections::BTreeSet;
use std::path::Path;

use serde_json::Value;

use super::root;

const SECTIONS: [&str; 4] = [
    "summary.json keys",
    "evaluations.csv header",
    "report.md headings",
    "files",
];

/// The snapshot of run directory `out`; `spec_directory`'s path in a
/// heading is written `SPEC_DIR` so the snapshot does not name a temporary
/// directory.
pub fn snapshot(out: &Path, spec_directory: &Path) -> Vec<(String, Vec<String>)> {
    let summary: Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    let mut keys = BTreeSet::new();
    key_paths("", &summary, &mut keys);
    let log = std::fs::read_to_string(out.join("evaluations.csv")).unwrap();
    let header = log.lines().next().unwrap_or_default().to_string();
    let report = std::fs::read_to_string(out.join("report.md")).unwrap();
    let directory = spec_directory.display().to_string();
    let headings: Vec<String> = report
        .lines()
        .filter(|line| line.starts_with('#'))
        .map(|line| line.replace(&directory, "SPEC_DIR"))
        .collect();
    let mut files: Vec<String> = std::fs::read_dir(out)
        .unwrap()
        .map(|entry| entry.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    files.sort();
    vec![
        (SECTIONS[0].into(), keys.into_iter().collect()),
        (SECTIONS[1].into(), vec![header]),
        (SECTIONS[2].into(), headings),
        (SECTIONS[3].into(), files),
    ]
}

/// Every key path of a JSON value; array items are not descended into
/// (their count is data, not interface).
fn key_paths(prefix: &str, value: &Value, into: &mut BTreeSet<String>) {
    if let Value::Object(map) = value {
        for (key, item) in map {
            let path = if prefix.is_empty() {
                key.clone()
            } else {
                format!("{prefix}.{key}")
            };
            into.insert(path.clone());
            key_paths(&path, item, into);
        }
    }
}

fn render(snapshot: &[(String, Vec<String>)]) -> String {
    let mut text = String::new();
    for (section, lines) in snapshot {
        text.push_str(&format!("[{section}]\n"));
        for line in lines {
            text.push_str(line);
            text.push('\n');
        }
    }
    text
}

fn parse(text: &str) -> Vec<(String, Vec<String>)> {
    let mut sections: Vec<(String, Vec<String>)> = Vec::new();
    for line in text.lines() {
        match line.strip_prefix('[').and_then(|l| l.strip_suffix(']')) {
            Some(section) if SECTIONS.contains(&section) => {
                sections.push((section.to_string(), Vec::new()))
            }
            _ => sections
                .last_mut()
                .expect("a snapshot starts with a section")
                .1
                .push(line.to_string()),
        }
    }
    sections
}

/// Compares run directory `out` with the recorded snapshot `name` (or
/// records it, with `ACQ_RECORD_INTERFACES=1`).
pub fn check(name: &str, out: &Path, spec_directory: &Path) {
    let expected_path = root().join(format!("fixtures/expected/interfaces/{name}.txt"));
    let got = snapshot(out, spec_directory);
    if std::env::var_os("ACQ_RECORD_INTERFACES").is_some() {
        std::fs::create_dir_all(expected_path.parent().unwrap()).unwrap();
        std::fs::write(&expected_path, render(&got)).unwrap();
        return;
    }
    let expected = parse(
        &std::fs::read_to_string(&expected_path).unwrap_or_else(|e| {
            panic!(
                "{}: {e}; record it with ACQ_RECORD_INTERFACES=1",
                expected_path.display()
            )
        }),
    );
    for ((section, expected_lines), (_, got_lines)) in expected.iter().zip(&got) {
        if section == SECTIONS[1] {
            assert_eq!(
                expected_lines, got_lines,
                "{name}: the evaluations.csv header changed"
            );
            continue;
        }
        let missing: Vec<&String> = expected_lines
            .iter()
            .filter(|line| !got_lines.contains(line))
            .collect();
        assert!(
            missing.is_empty(),
            "{name}: {section} lost {missing:?}; now:\n{}",
            got_lines.join("\n")
        );
    }
}
