//! Wall time of `acq extract` on the shipped sessions (BENCHMARKS.md): the
//! excavator's Case 1 and Case 2 holds with their uncertainty budgets, and
//! the P91 tensile curve (`--tensile`, as the demo extracts it).
//!
//! `cargo build --release && cargo bench --bench extract` times the release
//! binary `target/release/acq extract SESSION -o TMP/m.csv`, best of
//! `ACQ_BENCH_REPS` runs (default 20) per session, one line each.
//!
//! `ACQ_AFTER_BIN=PATH` times another binary instead (a commit's own
//! build, when this tree has edits in progress).
//!
//! With `ACQ_BEFORE_BIN=PATH` (the release binary of an older commit) that
//! binary runs too, alternately with this one in every repetition (which
//! goes first alternates as well): on a shared machine only a ratio measured
//! side by side means anything. The line then gives both times and the ratio
//! after / before. A binary older than the data-sheet keys of the rig's
//! sensors (`accuracy`, `resolution`) refuses the shipped rig copies; it
//! then runs on a copy of the session whose rig files have those lines
//! removed, and the line says so.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::time::Instant;

/// The shipped sessions, and whether each is a tensile test.
const SESSIONS: [(&str, bool); 3] = [
    ("excavator_case1", false),
    ("excavator_case2", false),
    ("tensile_p91_20c", true),
];

/// Rig keys an older binary may not know: the sensors' data sheets.
const DATA_SHEET_KEYS: [&str; 2] = ["accuracy", "resolution"];

fn extract(binary: &Path, session: &Path, tensile: bool, out: &Path) -> Output {
    let mut command = Command::new(binary);
    command.arg("extract");
    if tensile {
        command.arg("--tensile");
    }
    command
        .arg(session)
        .arg("-o")
        .arg(out)
        .output()
        .unwrap_or_else(|e| {
            panic!(
                "{}: {e} (build it first: cargo build --release)",
                binary.display()
            )
        })
}

/// Seconds of one run; panics with the binary's stderr when it fails.
fn timed(binary: &Path, session: &Path, tensile: bool, out: &Path) -> f64 {
    let started = Instant::now();
    let output = extract(binary, session, tensile, out);
    let seconds = started.elapsed().as_secs_f64();
    succeeded(
        &output,
        &format!("{} extract {}", binary.display(), session.display()),
    );
    seconds
}

/// Panics with `what` and the binary's stderr unless it succeeded.
fn succeeded(output: &Output, what: &str) {
    assert!(
        output.status.success(),
        "{what}: {}",
        String::from_utf8_lossy(&output.stderr)
    );
}

/// A copy of `session` whose rig files have no data-sheet lines.
fn without_data_sheets(session: &Path, into: &Path) -> PathBuf {
    let copy = into.join(session.file_name().unwrap());
    copy_dir(session, &copy);
    for entry in std::fs::read_dir(copy.join("rig")).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_some_and(|e| e == "toml") {
            let text = std::fs::read_to_string(&path).unwrap();
            let kept: Vec<&str> = text
                .lines()
                .filter(|line| {
                    let key = line.split('=').next().unwrap_or("").trim();
                    !(line.contains('=') && DATA_SHEET_KEYS.contains(&key))
                })
                .collect();
            std::fs::write(&path, kept.join("\n") + "\n").unwrap();
        }
    }
    copy
}

fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for entry in std::fs::read_dir(from).unwrap() {
        let entry = entry.unwrap();
        let target = to.join(entry.file_name());
        if entry.file_type().unwrap().is_dir() {
            copy_dir(&entry.path(), &target);
        } else {
            std::fs::copy(entry.path(), target).unwrap();
        }
    }
}

/// The session the older binary can read: the shipped one, or a copy
/// without data sheets when it refuses the shipped rig.
fn session_for_before(before: &Path, session: &Path, tensile: bool, tmp: &Path) -> (PathBuf, bool) {
    let out = tmp.join("before-probe.csv");
    if extract(before, session, tensile, &out).status.success() {
        return (session.to_path_buf(), false);
    }
    let copy = without_data_sheets(session, &tmp.join("before-sessions"));
    succeeded(
        &extract(before, &copy, tensile, &out),
        &format!(
            "{} refuses {} even without the data-sheet lines",
            before.display(),
            session.display()
        ),
    );
    (copy, true)
}

fn median(mut values: Vec<f64>) -> f64 {
    values.sort_by(f64::total_cmp);
    values[values.len() / 2]
}

fn best(values: &[f64]) -> f64 {
    values.iter().copied().fold(f64::INFINITY, f64::min)
}

fn main() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let after = std::env::var_os("ACQ_AFTER_BIN")
        .map(PathBuf::from)
        .unwrap_or_else(|| root.join("target/release/acq"));
    let before = std::env::var_os("ACQ_BEFORE_BIN").map(PathBuf::from);
    let reps: usize = std::env::var("ACQ_BENCH_REPS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(20)
        .max(1);
    let tmp = tempfile::tempdir().unwrap();
    let after_csv = tmp.path().join("m.csv");
    let before_csv = tmp.path().join("before-m.csv");
    println!("after: {}", after.display());
    if let Some(before) = &before {
        println!("before: {}", before.display());
    }
    let (mut after_total, mut before_total) = (0.0, 0.0);
    for (name, tensile) in SESSIONS {
        let session = root.join("fixtures/sessions").join(name);
        let flag = if tensile { " --tensile" } else { "" };
        let before_session = before
            .as_ref()
            .map(|b| session_for_before(b, &session, tensile, tmp.path()));
        // One run first (the older binary had its probe run): the binary and the
        // session into the page cache.
        timed(&after, &session, tensile, &after_csv);
        let (mut after_s, mut before_s) = (Vec::new(), Vec::new());
        for rep in 0..reps {
            let mut run_before = || {
                if let (Some(binary), Some((s, _))) = (&before, &before_session) {
                    before_s.push(timed(binary, s, tensile, &before_csv));
                }
            };
            if rep % 2 == 1 {
                run_before();
                after_s.push(timed(&after, &session, tensile, &after_csv));
            } else {
                after_s.push(timed(&after, &session, tensile, &after_csv));
                run_before();
            }
        }
        if !tensile {
            let header = std::fs::read_to_string(&after_csv).unwrap();
            let budgets = header
                .lines()
                .next()
                .unwrap_or("")
                .split(',')
                .any(|c| c == "u_c");
            assert!(budgets, "{name}: the after binary wrote no u_c column");
        }
        after_total += best(&after_s);
        let mut line = format!(
            "acq extract{flag} {name}: after {:.4} s (best of {reps}; median {:.4})",
            best(&after_s),
            median(after_s.clone())
        );
        if let Some((_, stripped)) = &before_session {
            before_total += best(&before_s);
            line += &format!(
                ", before {:.4} s (median {:.4}{}): ratio after/before {:.3} (medians {:.3})",
                best(&before_s),
                median(before_s.clone()),
                if *stripped {
                    "; on a copy whose rig has no accuracy/resolution lines"
                } else {
                    ""
                },
                best(&after_s) / best(&before_s),
                median(after_s.clone()) / median(before_s.clone())
            );
        }
        println!("{line}");
    }
    if before.is_some() {
        println!(
            "all three: after {after_total:.4} s, before {before_total:.4} s (sums of the bests): ratio {:.3}",
            after_total / before_total
        );
    }
}
