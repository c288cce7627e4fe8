//! `acq convert`: a log through any pair of the formats acq writes
//! (candump `-L`, ASC, MF4) comes back as the same frames, but for what a
//! format cannot hold, each named here: ASC and MF4 record every frame as
//! received or sent (a frame without a direction comes back received), and
//! ASC gives an error frame no direction (so MF4 then writes it received).

mod common;

use common::{acq, path_arg, stderr, EVERY_KIND_OF_FRAME as SOURCE};

const FORMATS: [&str; 3] = ["log", "asc", "mf4"];

fn convert(from: &std::path::Path, to: &std::path::Path) {
    let output = acq(&["convert", path_arg(from), "-o", path_arg(to)]);
    assert!(output.status.success(), "{}", stderr(&output));
    assert!(stderr(&output).contains("10 frames"), "{}", stderr(&output));
}

#[test]
fn a_log_through_any_pair_of_formats_is_the_same_frames() {
    let dir = tempfile::tempdir().unwrap();
    let source = dir.path().join("source.log");
    std::fs::write(&source, SOURCE).unwrap();
    for first in FORMATS {
        for second in FORMATS {
            let a = dir.path().join(format!("a.{first}"));
            let b = dir.path().join(format!("b.{second}"));
            let back = dir.path().join(format!("back-{first}-{second}.log"));
            convert(&source, &a);
            convert(&a, &b);
            convert(&b, &back);
            let only_candump = first == "log" && second == "log";
            // The format that last wrote the error frame decides its direction.
            let last_not_candump = if second == "log" { first } else { second };
            let expected: String = SOURCE
                .lines()
                .map(|line| {
                    let mut line = line.to_string();
                    if !only_candump && line.ends_with("010#DEADBEEF") {
                        line.push_str(" R");
                    }
                    if last_not_candump == "asc" && line.contains(" 20000080#") {
                        line.truncate(line.len() - " R".len());
                    }
                    line + "\n"
                })
                .collect();
            assert_eq!(
                std::fs::read_to_string(&back).unwrap(),
                expected,
                "{first} -> {second}"
            );
        }
    }
}

#[test]
fn convert_refuses_formats_it_cannot_write() {
    let dir = tempfile::tempdir().unwrap();
    for out in ["x.blf", "x.csv"] {
        let output = acq(&[
            "convert",
            "fixtures/logs/excavator_case1.log",
            "-o",
            path_arg(&dir.path().join(out)),
        ]);
        assert_eq!(output.status.code(), Some(2), "{}", stderr(&output));
        assert!(
            stderr(&output).contains("the format comes from the extension"),
            "{}",
            stderr(&output)
        );
        assert!(!dir.path().join(out).exists());
    }
}

#[test]
fn an_mf4_is_written_whole_or_not_at_all() {
    let dir = tempfile::tempdir().unwrap();
    // A log that turns bad half-way: convert stops at its line, and no
    // MF4 (or .partial) is left.
    let bad = dir.path().join("bad.log");
    std::fs::write(&bad, format!("{SOURCE}(1763719200.007000) can0 12G#00 R\n")).unwrap();
    let out = dir.path().join("out.mf4");
    let output = acq(&["convert", path_arg(&bad), "-o", path_arg(&out)]);
    assert_eq!(output.status.code(), Some(3), "{}", stderr(&output));
    assert!(
        stderr(&output).contains("bad.log:11:"),
        "{}",
        stderr(&output)
    );
    assert!(!out.exists());
    assert!(!dir.path().join("out.mf4.partial").exists());
    // MF4 is detected by content, whatever the name.
    let good = dir.path().join("good.log");
    std::fs::write(&good, SOURCE).unwrap();
    convert(&good, &out);
    let renamed = dir.path().join("recording.bin");
    std::fs::rename(&out, &renamed).unwrap();
    let output = acq(&[
        "decode",
        path_arg(&renamed),
        "--dbc",
        "fixtures/dbc/somat_excavator.dbc",
    ]);
    assert!(output.status.success(), "{}", stderr(&output));
    assert!(
        stderr(&output).contains("frames read 10"),
        "{}",
        stderr(&output)
    );
}
