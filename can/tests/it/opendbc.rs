//! Conformance over opendbc: for every DBC that cantools loads from the
//! opendbc package, acq loads it too or refuses it (or skips a message of
//! it) for a reason in the table of unsupported features (`dbc` module
//! doc), and every frame decodes to exactly cantools' values.
//!
//! cantools and opendbc live in a scratch virtualenv this test makes
//! (never dependencies of acq); without them the test fails, it never
//! skips. `tests/opendbc/vectors.py` writes the vectors (its docstring
//! describes them).

use crate::common;

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

use acq_can::dbc::{DbcDatabase, PhysicalValue};
use acq_can::CanId;
use common::same_value;

/// What acq does not support, as the `dbc` module doc's table lists it:
/// (the table's feature, a text every refusal or skip for it contains).
const UNSUPPORTED: &[(&str, &str)] = &[
    ("A DBC file with no messages", "no messages (BO_ lines)"),
    // No acq message says this: counted from labels that differ only so.
    (TEXT_ENCODING, "(labels compared)"),
];

/// acq reads DBC text as UTF-8 (Latin-1 when it is not UTF-8), cantools'
/// `load_file` as cp1252: a non-ASCII label differs, and nothing else.
const TEXT_ENCODING: &str = "Non-ASCII text read as cp1252";

/// What cantools makes of UTF-8 `text` by reading its bytes as cp1252
/// (Python's codec with `errors="replace"`: the five bytes cp1252 leaves
/// undefined become U+FFFD).
fn as_cp1252(text: &str) -> String {
    const HIGH: [u32; 32] = [
        0x20AC, 0xFFFD, 0x201A, 0x0192, 0x201E, 0x2026, 0x2020, 0x2021, 0x02C6, 0x2030, 0x0160,
        0x2039, 0x0152, 0xFFFD, 0x017D, 0xFFFD, 0xFFFD, 0x2018, 0x2019, 0x201C, 0x201D, 0x2022,
        0x2013, 0x2014, 0x02DC, 0x2122, 0x0161, 0x203A, 0x0153, 0xFFFD, 0x017E, 0x0178,
    ];
    text.bytes()
        .map(|b| match b {
            0x80..=0x9F => char::from_u32(HIGH[usize::from(b - 0x80)]).unwrap_or('\u{FFFD}'),
            _ => char::from(b),
        })
        .collect()
}

/// The peers' scratch virtualenv with the pinned cantools and opendbc
/// (scripts/python-peers dbc).
fn python() -> PathBuf {
    common::peer_python("dbc")
}

fn payload(hex: &str) -> Vec<u8> {
    (0..hex.len())
        .step_by(2)
        .map(|i| u8::from_str_radix(&hex[i..i + 2], 16).unwrap())
        .collect()
}

/// The table row a refusal or skip message belongs to, if any.
fn feature_of(text: &str) -> Option<&'static str> {
    UNSUPPORTED
        .iter()
        .find(|(_, needle)| text.contains(needle))
        .map(|(feature, _)| *feature)
}

#[derive(Default)]
struct Tally {
    dbcs_cantools: usize,
    dbcs_refused_by_cantools: usize,
    dbcs_acq: usize,
    /// Refused by cantools in strict mode, loaded with strict=False.
    dbcs_lax: usize,
    dbcs_lax_acq: usize,
    /// Frames of lax DBCs cantools cannot unpack (overlapping signals).
    lax_unpackable: usize,
    messages: usize,
    frames: usize,
    refused_frames: usize,
    values: usize,
    labels: usize,
    /// feature -> (DBCs, messages)
    unsupported: BTreeMap<&'static str, (BTreeSet<String>, BTreeSet<String>)>,
    problems: Vec<String>,
}

#[test]
fn acq_decodes_every_opendbc_dbc_as_cantools_does() {
    let started = Instant::now();
    let python = python();
    let out = std::env::temp_dir().join(format!("acq-opendbc-vectors-{}", std::process::id()));
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/opendbc/vectors.py");
    let output = Command::new(&python)
        .arg(&script)
        .arg(&out)
        .output()
        .unwrap();
    assert!(
        output.status.success(),
        "{} failed: {}",
        script.display(),
        String::from_utf8_lossy(&output.stderr)
    );
    let cantools_took = started.elapsed();
    let text = std::fs::read_to_string(out.join("vectors.txt")).unwrap();
    let tally = compare(&text);
    let _ = std::fs::remove_dir_all(&out);

    println!(
        "opendbc: {} DBC files cantools loads ({} it refuses; {} of those with strict=False); acq loads {} (and {}); {} messages, {} frames ({} refused by both), {} values and {} value-table labels equal",
        tally.dbcs_cantools,
        tally.dbcs_refused_by_cantools,
        tally.dbcs_lax,
        tally.dbcs_acq,
        tally.dbcs_lax_acq,
        tally.messages,
        tally.frames,
        tally.refused_frames,
        tally.values,
        tally.labels
    );
    println!(
        "strict=False DBCs: {} frames cantools cannot unpack (overlapping signals), not compared",
        tally.lax_unpackable
    );
    for (feature, (dbcs, messages)) in &tally.unsupported {
        println!(
            "unsupported: {feature}: {} DBC files, {} messages",
            dbcs.len(),
            messages.len()
        );
    }
    check_the_documented_table(&tally);
    println!(
        "took {:.1} s ({:.1} s in cantools)",
        started.elapsed().as_secs_f64(),
        cantools_took.as_secs_f64()
    );
    assert!(
        tally.problems.is_empty(),
        "{} problems:\n{}",
        tally.problems.len(),
        tally.problems.join("\n")
    );
    assert!(tally.dbcs_cantools > 50 && tally.values > 100_000);
}

/// The `dbc` module doc's table says, for each feature, how many opendbc
/// files and messages it affects: those numbers must be the ones counted.
fn check_the_documented_table(tally: &Tally) {
    let doc =
        std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("src/dbc.rs")).unwrap();
    for (feature, _) in UNSUPPORTED {
        let (dbcs, messages) = tally
            .unsupported
            .get(feature)
            .map_or((0, 0), |(dbcs, messages)| (dbcs.len(), messages.len()));
        let row = doc
            .lines()
            .find(|line| line.starts_with(&format!("//! | {feature} |")))
            .unwrap_or_else(|| panic!("src/dbc.rs: no table row for {feature:?}"));
        let counted = format!("{dbcs} files, {messages} messages");
        assert!(
            row.contains(&counted),
            "src/dbc.rs: the row for {feature:?} must say \"{counted}\" (opendbc 0.3.1): {row}"
        );
    }
}

/// Replays vectors.txt against acq.
fn compare(text: &str) -> Tally {
    let mut tally = Tally::default();
    let mut database: Option<DbcDatabase> = None;
    let mut dbc_name = String::new();
    // The current message: (acq's message index, cantools' signal names).
    let mut message: Option<(usize, Vec<String>)> = None;
    let mut message_label = String::new();
    let mut warnings: Vec<String> = Vec::new();
    let mut lax = false;
    let mut lines = text.lines().peekable();
    while let Some(line) = lines.next() {
        let fields: Vec<&str> = line.split('\t').collect();
        match fields[0] {
            "D" => {
                message = None;
                dbc_name = fields[2].to_string();
                let strict = fields[3] == "loaded";
                lax = fields[3] == "lax";
                database = None;
                if !strict {
                    tally.dbcs_refused_by_cantools += 1;
                    if fields[3] == "refused" {
                        // Nothing to compare, but acq must not panic on it.
                        let _ = DbcDatabase::load(Path::new(fields[1]));
                        continue;
                    }
                    // cantools decodes it only with strict=False: its frames
                    // are compared when acq loads it, nothing more.
                    tally.dbcs_lax += 1;
                    if let Ok((loaded, these)) = DbcDatabase::load(Path::new(fields[1])) {
                        tally.dbcs_lax_acq += 1;
                        database = Some(loaded);
                        warnings = these.into_iter().map(|w| w.0).collect();
                    }
                    continue;
                }
                tally.dbcs_cantools += 1;
                match DbcDatabase::load(Path::new(fields[1])) {
                    Ok((loaded, these)) => {
                        tally.dbcs_acq += 1;
                        database = Some(loaded);
                        warnings = these.into_iter().map(|w| w.0).collect();
                    }
                    Err(error) => {
                        database = None;
                        let error = error.to_string();
                        match feature_of(&error) {
                            Some(feature) => {
                                tally
                                    .unsupported
                                    .entry(feature)
                                    .or_default()
                                    .0
                                    .insert(dbc_name.clone());
                            }
                            None => tally
                                .problems
                                .push(format!("{dbc_name}: cantools loads it, acq: {error}")),
                        }
                    }
                }
            }
            "M" => {
                message = None;
                let Some(database) = &database else { continue };
                tally.messages += 1;
                let raw = u32::from_str_radix(fields[1], 16).unwrap();
                let id = if fields[2] == "1" {
                    CanId::Extended(raw)
                } else {
                    CanId::Standard(raw as u16)
                };
                message_label = format!("{dbc_name}: {} ({id})", fields[3]);
                match database.message_index(id) {
                    Some(index) => {
                        message = Some((index, fields[4..].iter().map(|s| s.to_string()).collect()))
                    }
                    // Skipped with a warning: for a reason in the table.
                    None => {
                        let skipped = format!("message {} ({id}) skipped", fields[3]);
                        let why = warnings.iter().find(|w| w.contains(&skipped));
                        match why.and_then(|w| feature_of(w)) {
                            Some(feature) => {
                                let entry = tally.unsupported.entry(feature).or_default();
                                entry.0.insert(dbc_name.clone());
                                entry.1.insert(message_label.clone());
                            }
                            None => tally.problems.push(format!(
                                "{message_label}: cantools has it, acq does not ({})",
                                why.map_or("no warning", |w| w.as_str())
                            )),
                        }
                    }
                }
            }
            "F" | "E" => {
                let (Some(database), Some((index, names))) = (&database, &message) else {
                    continue;
                };
                let codec = &database.messages()[*index];
                let data = payload(fields[1]);
                let mut ours: BTreeMap<&str, PhysicalValue> = BTreeMap::new();
                let result = codec.decode(&data, |i, v| {
                    ours.insert(codec.signals[i].name.as_str(), v);
                });
                if fields[0] == "E" {
                    // With strict=False cantools cannot unpack overlapping
                    // signals at all (bitstruct): nothing to compare.
                    if lax && fields[2].starts_with("unpacking failed") {
                        tally.lax_unpackable += 1;
                        continue;
                    }
                    tally.refused_frames += 1;
                    if result.is_ok() {
                        tally.problems.push(format!(
                            "{message_label} {}: cantools refuses it ({}), acq decodes it",
                            fields[1], fields[2]
                        ));
                    }
                    continue;
                }
                tally.frames += 1;
                if let Err(error) = result {
                    tally.problems.push(format!(
                        "{message_label} {}: cantools decodes it, acq: {error}",
                        fields[1]
                    ));
                    continue;
                }
                // The labels cantools gives this frame (an L record follows
                // the frame when there are any) against acq's.
                let mut their_labels: BTreeMap<usize, &str> = BTreeMap::new();
                if lines.peek().is_some_and(|next| next.starts_with("L\t")) {
                    let record = lines.next().unwrap_or_default();
                    for pair in record.split('\t').skip(1) {
                        let (index, label) = pair.split_once('=').unwrap();
                        their_labels.insert(index.parse().unwrap(), label);
                    }
                }
                for (position, name) in names.iter().enumerate() {
                    let ours = ours
                        .contains_key(name.as_str())
                        .then(|| codec.signal(name))
                        .flatten()
                        .and_then(|(_, signal)| signal.label(&data));
                    let theirs = their_labels.get(&position).copied();
                    let reencoded = ours.map(as_cp1252);
                    if ours == theirs {
                        tally.labels += usize::from(ours.is_some());
                    } else if theirs.is_some() && reencoded.as_deref() == theirs {
                        // The same label, read in another encoding.
                        let entry = tally.unsupported.entry(TEXT_ENCODING).or_default();
                        entry.0.insert(dbc_name.clone());
                        entry.1.insert(message_label.clone());
                    } else {
                        tally.problems.push(format!(
                            "{message_label} {}: {name}: acq's label {ours:?}, cantools' {theirs:?}",
                            fields[1]
                        ));
                    }
                }
                for (name, theirs) in names.iter().zip(&fields[2..]) {
                    match (ours.get(name.as_str()), *theirs) {
                        (None, "-") => {}
                        (Some(value), "-") => tally.problems.push(format!(
                            "{message_label} {}: {name}: acq {value:?}, cantools does not decode it",
                            fields[1]
                        )),
                        (None, theirs) => tally.problems.push(format!(
                            "{message_label} {}: {name}: cantools {theirs}, acq does not decode it",
                            fields[1]
                        )),
                        (Some(value), theirs) => {
                            if same_value(*value, theirs) {
                                tally.values += 1;
                            } else {
                                tally.problems.push(format!(
                                    "{message_label} {}: {name}: acq {value:?}, cantools {theirs}",
                                    fields[1]
                                ));
                            }
                        }
                    }
                }
            }
            // The labels of a frame that was not compared.
            "L" => {}
            other => panic!("vectors.txt: unexpected record {other:?}"),
        }
    }
    tally
}
