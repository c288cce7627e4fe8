//! The DBC decoder gives exactly what cantools gives for the same DBC and
//! frames (vectors made by tests/golden/make_golden.py at the workspace
//! root, cantools 45.1.0).

use crate::common;

use std::collections::BTreeMap;
use std::path::Path;

use acq_can::dbc::DbcDatabase;
use acq_can::CanId;
use common::same_value;

fn golden(name: &str) -> String {
    std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../tests/golden")
            .join(name),
    )
    .unwrap_or_else(|e| panic!("tests/golden/{name}: {e}"))
}

fn database() -> DbcDatabase {
    let (database, warnings) = DbcDatabase::parse(&golden("golden.dbc"), "golden.dbc").unwrap();
    assert!(warnings.is_empty(), "{warnings:?}");
    database
}

fn can_id(hex: &str, extended: &str) -> CanId {
    let raw = u32::from_str_radix(hex.trim_start_matches("0x"), 16).unwrap();
    if extended == "1" {
        CanId::Extended(raw)
    } else {
        CanId::Standard(raw as u16)
    }
}

fn payload(hex: &str) -> Vec<u8> {
    (0..hex.len())
        .step_by(2)
        .map(|i| u8::from_str_radix(&hex[i..i + 2], 16).unwrap())
        .collect()
}

#[test]
fn every_value_equals_cantools() {
    let database = database();
    let text = golden("cantools_vectors.csv");
    // (id, data) -> signal -> value, in file order of frames.
    let mut frames: BTreeMap<(CanId, String), BTreeMap<String, String>> = BTreeMap::new();
    for line in text.lines().skip(1) {
        let fields: Vec<&str> = line.split(',').collect();
        assert_eq!(fields.len(), 6, "{line}");
        frames
            .entry((can_id(fields[0], fields[1]), fields[2].to_string()))
            .or_default()
            .insert(fields[4].to_string(), fields[5].to_string());
    }
    assert!(frames.len() > 500, "only {} golden frames", frames.len());
    let mut compared = 0;
    for ((id, data), expected) in &frames {
        let message = database
            .message(*id)
            .unwrap_or_else(|| panic!("no message {id}"));
        let mut ours = BTreeMap::new();
        message
            .decode(&payload(data), |i, v| {
                ours.insert(message.signals[i].name.clone(), v);
            })
            .unwrap_or_else(|e| panic!("{id} {data}: {e}"));
        let our_names: Vec<&String> = ours.keys().collect();
        let their_names: Vec<&String> = expected.keys().collect();
        assert_eq!(our_names, their_names, "signals of {id} {data}");
        for (signal, value) in expected {
            assert!(
                same_value(ours[signal], value),
                "{id} {data} {signal}: ours {:?}, cantools {value}",
                ours[signal]
            );
            compared += 1;
        }
    }
    assert!(compared > 3000, "only {compared} values compared");
}

#[test]
fn frames_cantools_refuses_are_refused() {
    let database = database();
    let text = golden("cantools_errors.csv");
    let header: Vec<&str> = text.lines().next().unwrap().split(',').collect();
    let column = |name: &str| header.iter().position(|h| *h == name).unwrap();
    let mut refused = 0;
    for line in text.lines().skip(1) {
        let fields: Vec<&str> = line.split(',').collect();
        let id = can_id(fields[column("can_id")], fields[column("extended")]);
        let message = database.message(id).unwrap();
        assert!(
            message
                .decode(&payload(fields[column("data")]), |_, _| {})
                .is_err(),
            "{line}"
        );
        refused += 1;
    }
    assert!(refused > 0);
}

#[test]
fn value_table_labels_equal_cantools() {
    let database = database();
    let text = golden("cantools_labels.csv");
    let mut checked = 0;
    for line in text.lines().skip(1) {
        let fields: Vec<&str> = line.splitn(4, ',').collect();
        let raw = u32::from_str_radix(fields[0].trim_start_matches("0x"), 16).unwrap();
        // Labels file has no extended column: the id decides by range.
        let message = database
            .messages()
            .iter()
            .find(|m| m.id.raw() == raw)
            .unwrap_or_else(|| panic!("no message 0x{raw:X}"));
        let (_, signal) = message.signal(fields[2]).unwrap();
        assert_eq!(
            signal.label(&payload(fields[1])),
            Some(fields[3].trim_matches('"')),
            "{line}"
        );
        checked += 1;
    }
    assert!(checked > 100);
}
