//! `acq record`, `acq replay` and `acq simulate` on a real vcan, against
//! can-utils as the peer. The host kernels here have no CAN, so the checks
//! run in a small VM (tests/vcan-vm); on a host with vcan0..vcan3 they run
//! natively. tests/vcan-vm/acq-checks.sh produces the captures; this test
//! compares them. It never skips: when the VM cannot run, it fails.

mod common;

use std::collections::HashSet;
use std::fs;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::Command;

use acq_drivers::frame::{FD_FLAG_BRS, FD_FLAG_ESI, FD_FLAG_FDF};
use acq_drivers::log::candump::{parse_line, CandumpWriter};
use acq_drivers::{CanId, Frame, FrameKind, IfaceName};
use acq_io::session;

const T0_NS: i64 = 1_763_719_200_000_000_000;
const VARIETY_FRAMES: usize = 2000;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// 2000 frames, 1 ms apart, of every kind the wire carries.
fn variety_log() -> Vec<Frame> {
    let can0 = IfaceName::new("can0").unwrap();
    (0..VARIETY_FRAMES)
        .map(|i| {
            let t = T0_NS + i as i64 * 1_000_000;
            let n = i as u32;
            let bytes: Vec<u8> = (0..64)
                .map(|k| (n as u8).wrapping_mul(31).wrapping_add(k))
                .collect();
            let standard = CanId::Standard((0x100 + n % 0x600) as u16);
            let extended = CanId::Extended(0x1800_0000 | ((n * 7919) % 0x0100_0000));
            match i % 10 {
                0 => Frame::data(t, can0, extended, &bytes[..8]),
                1 => Frame::data(t, can0, standard, &[]),
                2 => Frame::remote(t, can0, standard, (n % 9) as u8),
                3 => Frame::fd(t, can0, standard, FD_FLAG_FDF | FD_FLAG_BRS, &bytes[..12]),
                4 => Frame::fd(t, can0, extended, FD_FLAG_FDF, &bytes[..64]),
                5 => Frame::remote(t, can0, extended, 0),
                6 => Frame::fd(
                    t,
                    can0,
                    standard,
                    FD_FLAG_FDF | FD_FLAG_BRS | FD_FLAG_ESI,
                    &bytes[..48],
                ),
                _ => Frame::data(t, can0, standard, &bytes[..(n % 9) as usize]),
            }
            .unwrap()
        })
        .collect()
}

/// A frame as the wire knows it: id, kind (with FD flags) and bytes.
fn wire(frame: &Frame) -> (CanId, FrameKind, Vec<u8>) {
    (frame.id, frame.kind, frame.payload().to_vec())
}

fn read_log(path: &Path) -> Vec<Frame> {
    let text = fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    text.lines()
        .filter(|l| !l.trim().is_empty())
        .map(|l| {
            parse_line(l.as_bytes())
                .unwrap_or_else(|e| panic!("{}: {l:?}: {e}", path.display()))
                .1
        })
        .collect()
}

fn read_session_frames(dir: &Path) -> Vec<Frame> {
    session::raw_files(dir)
        .unwrap()
        .iter()
        .flat_map(|p| read_log(p))
        .collect()
}

fn prepare_inputs(dir: &Path) {
    let mut writer = CandumpWriter::new(fs::File::create(dir.join("variety.log")).unwrap());
    for frame in variety_log() {
        writer.write_frame(&frame).unwrap();
    }
    writer.flush().unwrap();
    for sub in ["rigs", "dbc", "scenarios"] {
        fs::create_dir_all(dir.join(sub)).unwrap();
    }
    fs::copy(
        root().join("fixtures/rigs/excavator.toml"),
        dir.join("rigs/excavator.toml"),
    )
    .unwrap();
    fs::copy(
        root().join("fixtures/dbc/somat_excavator.dbc"),
        dir.join("dbc/somat_excavator.dbc"),
    )
    .unwrap();
    // The study at the rig and its hidden truth, with the geometry where
    // the study's relative path finds it.
    fs::create_dir_all(dir.join("examples/excavator-rig")).unwrap();
    fs::create_dir_all(dir.join("data/excavator")).unwrap();
    // The example study, lighter: fewer draws and candidates, so that its
    // updates fit the one emulated CPU (the check is the recording's, not
    // the posterior's).
    let study = fs::read_to_string(root().join("examples/excavator-rig/study.toml")).unwrap();
    let lighter = [
        ("draws = 250", "draws = 100"),
        ("chains = 4", "chains = 2"),
        ("steps = 7 }", "steps = 3 }"),
        ("steps = 6 }", "steps = 3 }"),
        ("steps = 5 }", "steps = 3 }"),
    ]
    .iter()
    .fold(study, |text, (from, to)| {
        assert!(text.contains(from), "the example study has {from}");
        text.replace(from, to)
    });
    fs::write(dir.join("examples/excavator-rig/study.toml"), lighter).unwrap();
    // Its hidden truth with shorter holds: the emulated CPU plays the rig
    // late under the flood, and the holds need only be found.
    let truth =
        fs::read_to_string(root().join("examples/excavator-rig/hidden_truth.toml")).unwrap();
    assert!(truth.contains("hold_s = 6.0"));
    fs::write(
        dir.join("examples/excavator-rig/hidden_truth.toml"),
        truth.replace("hold_s = 6.0", "hold_s = 3.0"),
    )
    .unwrap();
    fs::copy(
        root().join("data/excavator/dx55.toml"),
        dir.join("data/excavator/dx55.toml"),
    )
    .unwrap();
    let mut scenario = fs::File::create(dir.join("scenarios/short.toml")).unwrap();
    writeln!(
        scenario,
        "name = \"short\"\n[timeline]\nidle_s = 0.5\nbuild_up_s = 0.5\nhold_s = 2.0\nrelease_s = 0.5\nafter_s = 0.5\n\
         [sensor.arm_head_pressure]\nidle = 10.0\nhold = 193.46\n[sensor.tip_force]\nidle = 0.0\nhold = 40.6"
    )
    .unwrap();
}

/// Runs the checks natively when this host has vcan, else in the VM.
fn run_checks(inputs: &Path, out: &Path) {
    run_guest_script("acq-checks.sh", inputs, out);
}

/// Runs tests/vcan-vm/`script` natively when this host has vcan, else in
/// the VM, with `inputs` as $IN and `out` as $OUT.
fn run_guest_script(script: &str, inputs: &Path, out: &Path) {
    let acq = PathBuf::from(env!("CARGO_BIN_EXE_acq"));
    let script = root().join("tests/vcan-vm").join(script);
    let native = Path::new("/sys/class/net/vcan0").exists();
    let status = if native {
        let path = format!(
            "{}:{}",
            acq.parent().unwrap().display(),
            std::env::var("PATH").unwrap_or_default()
        );
        Command::new("sh")
            .arg(&script)
            .env("OUT", out)
            .env("IN", inputs)
            .env("PATH", path)
            .status()
    } else {
        Command::new(root().join("tests/vcan-vm/run"))
            .arg("--script")
            .arg(&script)
            .arg("--bin")
            .arg(&acq)
            .arg("--file")
            .arg(format!("{}:/in", inputs.display()))
            .arg("--out")
            .arg(out)
            .args(["--timeout", "900"])
            .status()
    }
    .expect("could not start the vcan checks");
    assert!(
        status.success(),
        "the vcan checks failed ({status}); on a host without CAN they need qemu (tests/vcan-vm/README.md)"
    );
}

#[test]
fn record_replay_and_simulate_on_a_real_vcan() {
    let work = tempfile::tempdir().unwrap();
    let inputs = work.path().join("in");
    let out = work.path().join("out");
    fs::create_dir_all(&inputs).unwrap();
    prepare_inputs(&inputs);
    run_checks(&inputs, &out);
    let sent = variety_log();

    // 1. canplayer -> acq record: the same frames, in order, none missing.
    let c1 = out.join("c1");
    let recorded = read_session_frames(&c1);
    assert_eq!(
        recorded.len(),
        VARIETY_FRAMES,
        "acq recorded every frame canplayer sent"
    );
    let want: Vec<_> = sent.iter().map(wire).collect();
    let got: Vec<_> = recorded.iter().map(wire).collect();
    assert_eq!(got, want, "identical ids, flags, data and order");
    assert_eq!(
        fs::read_to_string(out.join("c1.exit")).unwrap().trim(),
        "c1 exit 0"
    );
    let c1_session = session::read(&c1).unwrap();
    assert_eq!(c1_session.session.ended, "signal SIGINT");
    assert_eq!(c1_session.interface[0].timestamp_source, "kernel");
    assert_eq!(c1_session.session.frames as usize, VARIETY_FRAMES);

    // 2. acq replay -> candump -L: the same frames, and the timing held.
    let captured = read_log(&out.join("c2_candump.log"));
    assert_eq!(
        captured.len(),
        VARIETY_FRAMES,
        "candump saw every frame acq replayed"
    );
    let got: Vec<_> = captured.iter().map(wire).collect();
    assert_eq!(got, want);
    let mut errors_us: Vec<f64> = captured
        .windows(2)
        .zip(sent.windows(2))
        .map(|(c, s)| {
            let actual = c[1].timestamp_ns - c[0].timestamp_ns;
            let logged = s[1].timestamp_ns - s[0].timestamp_ns;
            (actual - logged).abs() as f64 / 1e3
        })
        .collect();
    errors_us.sort_by(f64::total_cmp);
    let median = errors_us[errors_us.len() / 2];
    let p99 = errors_us[errors_us.len() * 99 / 100];
    // Each frame's offset from the first, against the log's. A constant
    // shift (a slow first send) is harmless; drift spreads the errors out,
    // so the spread around their median is what an absolute schedule bounds.
    let mut offset_errors_us: Vec<f64> = captured
        .iter()
        .zip(&sent)
        .map(|(c, s)| {
            ((c.timestamp_ns - captured[0].timestamp_ns) - (s.timestamp_ns - sent[0].timestamp_ns))
                as f64
                / 1e3
        })
        .collect();
    offset_errors_us.sort_by(f64::total_cmp);
    let center = offset_errors_us[offset_errors_us.len() / 2];
    let mut spread: Vec<f64> = offset_errors_us
        .iter()
        .map(|e| (e - center).abs())
        .collect();
    spread.sort_by(f64::total_cmp);
    let median_offset_us = spread[spread.len() / 2];
    eprintln!(
        "vcan replay timing (candump's kernel timestamps): inter-frame |error| median {median:.1} us, p99 {p99:.1} us; offset error spread (median |e - median e|) {median_offset_us:.1} us"
    );
    eprintln!(
        "{}",
        fs::read_to_string(out.join("c2_replay.txt"))
            .unwrap_or_default()
            .trim()
    );
    // Loose bounds: the VM emulates its CPU; the 100 us target is measured
    // on the host (BENCHMARKS.md). An absolute schedule cannot drift.
    assert!(median < 2000.0, "median inter-frame error {median} us");
    assert!(
        median_offset_us < 5000.0,
        "the replay drifted: offset error spread {median_offset_us} us"
    );

    // 3. acq simulate -> acq record --rig: every sample the simulator
    // scheduled is recorded, and each sensor's rate is the one the wire
    // carried. The schedule comes from the same simulation written to a
    // file on the host (same seed: the same frames, the same drops); what
    // the wire carried from candump -L run beside the recorder (its kernel
    // timestamps). The guest's CPU is emulated on a shared host, so how
    // closely it keeps the schedule's pace is the host's, not acq's (the
    // host replay's timing is benchmarked, BENCHMARKS.md): it is bounded
    // loosely and printed.
    let c3 = session::read(&out.join("c3")).unwrap();
    assert_eq!(c3.sensor.len(), 28);
    let rig = inputs.join("rigs/excavator.toml");
    let scheduled_log = work.path().join("c3_scheduled.log");
    let simulated = Command::new(env!("CARGO_BIN_EXE_acq"))
        .args(["simulate", "--seed", "11", "--start", "1763719200", "--rig"])
        .arg(&rig)
        .arg("--scenario")
        .arg(inputs.join("scenarios/short.toml"))
        .arg("--output")
        .arg(&scheduled_log)
        .output()
        .unwrap();
    assert!(simulated.status.success(), "{simulated:?}");
    let scheduled = samples_per_sensor(&scheduled_log, &rig);
    let on_the_wire = samples_per_sensor(&out.join("c3_candump.log"), &rig);
    for sensor in &c3.sensor {
        let (scheduled_samples, scheduled_rate_hz) = scheduled[&sensor.name];
        let (wire_samples, wire_rate_hz) = on_the_wire[&sensor.name];
        assert!(
            (scheduled_rate_hz / sensor.expected_rate_hz - 1.0).abs() < 0.01,
            "{}: the simulator schedules {scheduled_rate_hz} Hz, the rig expects {} Hz",
            sensor.name,
            sensor.expected_rate_hz
        );
        assert_eq!(
            (sensor.samples as usize, wire_samples),
            (scheduled_samples, scheduled_samples),
            "{}: (recorded, on the wire) samples, the simulator scheduled {scheduled_samples}",
            sensor.name
        );
        assert!(
            (sensor.observed_rate_hz / wire_rate_hz - 1.0).abs() < 0.01,
            "{}: recorded at {} Hz, candump saw {wire_rate_hz} Hz",
            sensor.name,
            sensor.observed_rate_hz
        );
        assert!(
            // 0.66 has been seen with the host busy; a pacing bug (all at
            // once, or a period off by a factor) lands far outside.
            (0.3..1.1).contains(&(wire_rate_hz / scheduled_rate_hz)),
            "{}: the guest sent at {wire_rate_hz} Hz of {scheduled_rate_hz} Hz",
            sensor.name
        );
    }
    let slowest = c3
        .sensor
        .iter()
        .map(|s| s.observed_rate_hz / s.expected_rate_hz)
        .fold(f64::INFINITY, f64::min);
    eprintln!("vcan simulate: the emulated guest kept {slowest:.3} of the schedule's pace (slowest sensor)");
    let arm = c3
        .sensor
        .iter()
        .find(|s| s.name == "arm_head_pressure")
        .unwrap();
    assert!(
        arm.last_value.is_some_and(|v| (v - 10.0).abs() < 1.0),
        "idle at the end: {:?}",
        arm.last_value
    );
    let status_lines = fs::read_to_string(out.join("c3_status.jsonl")).unwrap();
    let last: serde_json::Value =
        serde_json::from_str(status_lines.lines().last().unwrap()).unwrap();
    assert_eq!(last["sensors"].as_array().unwrap().len(), 28);
    assert!(c3.rig.is_some());

    // 4. Ctrl-C during a flood: what candump saw up to the signal is in raw.log.
    let (c4, before, recorded, missing) = flood_check(&out, "c4");
    eprintln!(
        "flood: candump saw {before} frames before the signal; acq recorded {recorded}, reported {} kernel drops, missing {missing}",
        c4.session.dropped_by_kernel
    );
    assert!(before > 1000, "the flood reached the bus: {before} frames");
    assert!(
        missing <= c4.session.dropped_by_kernel,
        "{missing} frames candump saw before the signal are not in raw.log, and only {} drops were reported",
        c4.session.dropped_by_kernel
    );

    // 7. Both buses busy (a frame every 0.25 ms asked of each) with the
    // live page on and 10 viewers, one stalled, three leaving and three
    // others coming meanwhile: the page never costs a frame.
    let (c7, before, recorded, missing) = flood_check(&out, "c7");
    assert_eq!(
        fs::read_to_string(out.join("c7.exit")).unwrap().trim(),
        "0",
        "{}",
        fs::read_to_string(out.join("c7_stderr.txt")).unwrap_or_default()
    );
    let state: serde_json::Value =
        serde_json::from_str(&fs::read_to_string(out.join("c7_state.json")).unwrap()).unwrap();
    eprintln!(
        "busy buses with the view: candump saw {before} frames before the signal; acq recorded {recorded}, reported {} kernel drops, missing {missing}; \
         the page had {} viewers and did not show {} frames",
        c7.session.dropped_by_kernel,
        state["viewers"],
        state["sessions"][0]["frames_not_shown"]
    );
    assert!(before > 1000, "the flood reached the bus");
    assert!(
        state["viewers"].as_u64().unwrap() >= 10,
        "the viewers were connected: {}",
        state["viewers"]
    );
    assert_eq!(
        (missing, c7.session.dropped_by_kernel),
        (0, 0),
        "frames candump saw before the signal that are not in raw.log, and kernel drops"
    );

    // 8. A study at the rig while both buses are busy: nothing lost, and the
    // posterior was updated during the flood, hold by hold.
    let (c8, before, recorded, missing) = flood_check(&out, "c8");
    let said = fs::read_to_string(out.join("c8_stderr_before_stop.txt")).unwrap_or_default();
    eprintln!(
        "check 8: the virtual rig said: {}; the study's updates so far, every 5 s: {}",
        fs::read_to_string(out.join("c8_simulate.txt")).unwrap_or_default(),
        fs::read_to_string(out.join("c8_progress.txt"))
            .unwrap_or_default()
            .replace('\n', "; ")
    );
    let stderr8 = fs::read_to_string(out.join("c8_stderr.txt")).unwrap_or_default();
    eprintln!(
        "busy buses with a study: candump saw {before} frames before the signal; acq recorded {recorded}, reported {} kernel drops, missing {missing}",
        c8.session.dropped_by_kernel
    );
    assert_eq!(
        fs::read_to_string(out.join("c8.exit")).unwrap().trim(),
        "0",
        "{stderr8}"
    );
    assert!(before > 1000, "the flood reached the bus");
    assert_eq!(
        (missing, c8.session.dropped_by_kernel),
        (0, 0),
        "frames candump saw before the signal that are not in raw.log, and kernel drops; acq said: {stderr8}"
    );
    assert!(
        said.contains("study: after 1 hold(s)"),
        "the study updated while the buses were busy; before the stop it said: {said}\nafter: {stderr8}"
    );
    // The recorder waited for the study to take every hold it found (the
    // flood still on), none of them skipped.
    let study: serde_json::Value =
        serde_json::from_str(&fs::read_to_string(out.join("c8/study.json")).unwrap()).unwrap();
    let used = study["holds_used"].as_u64().unwrap_or(0);
    assert!(
        used >= 2 && study["holds_seen"] == used && study["skipped"] == serde_json::json!([]),
        "{study}"
    );

    // 5. The interface disappears and comes back: reported, recording resumes.
    let c5 = session::read(&out.join("c5")).unwrap();
    let ids: Vec<CanId> = read_session_frames(&out.join("c5"))
        .iter()
        .map(|f| f.id)
        .collect();
    assert_eq!(
        ids.iter()
            .filter(|&&id| id == CanId::Standard(0x123))
            .count(),
        50,
        "frames before the outage"
    );
    assert_eq!(
        ids.iter()
            .filter(|&&id| id == CanId::Standard(0x124))
            .count(),
        50,
        "frames after it"
    );
    let outages = &c5.interface[0].outage;
    assert_eq!(outages.len(), 1, "{outages:?}");
    assert!(
        outages[0].up_unix_ns.is_some(),
        "the interface came back: {outages:?}"
    );

    // 6. A full disk stops the recording cleanly: exit 1, whole lines only, session.toml written.
    let code = fs::read_to_string(out.join("c6.exit")).unwrap();
    assert_eq!(
        code.trim(),
        "1",
        "{}",
        fs::read_to_string(out.join("c6_stderr.txt")).unwrap_or_default()
    );
    let c6 = session::read(&out.join("c6")).unwrap();
    assert!(
        c6.session.ended.starts_with("write failed"),
        "{}",
        c6.session.ended
    );
    let raw = fs::read(out.join("c6/raw.log")).unwrap();
    let stderr6 = fs::read_to_string(out.join("c6_stderr.txt")).unwrap_or_default();
    assert!(
        raw.ends_with(b"\n"),
        "the raw log ({} bytes) ends with a whole line: ...{:?}; {}; stderr: {stderr6}",
        raw.len(),
        String::from_utf8_lossy(&raw[raw.len().saturating_sub(80)..]),
        c6.session.ended
    );
    let frames = read_session_frames(&out.join("c6"));
    assert!(
        frames.len() > 1000,
        "{} frames before the disk filled",
        frames.len()
    );
}

/// A flood check's session `name`: what candump saw (`NAME_candump.log`)
/// up to the stop against `raw.log`: (the session, frames candump saw
/// before the stop, frames recorded, frames of the first not in the second).
fn flood_check(out: &Path, name: &str) -> (session::SessionFile, usize, usize, u64) {
    let recorded_session = session::read(&out.join(name)).unwrap();
    let stop_ns = recorded_session
        .session
        .stop_requested_unix_ns
        .expect("the stop time is recorded");
    let seen = read_log(&out.join(format!("{name}_candump.log")));
    let before: Vec<&Frame> = seen.iter().filter(|f| f.timestamp_ns <= stop_ns).collect();
    let recorded: HashSet<(i64, CanId, Vec<u8>)> = read_session_frames(&out.join(name))
        .iter()
        .map(|f| (f.timestamp_ns, f.id, f.payload().to_vec()))
        .collect();
    let missing = before
        .iter()
        .filter(|f| !recorded.contains(&(f.timestamp_ns, f.id, f.payload().to_vec())))
        .count() as u64;
    (recorded_session, before.len(), recorded.len(), missing)
}

/// Frames in a candump -L capture, per interface.
/// Each sensor's samples and rate ((n - 1) / span) in `log` decoded through
/// `rig` by `acq decode`, from the log's own timestamps.
fn samples_per_sensor(log: &Path, rig: &Path) -> std::collections::HashMap<String, (usize, f64)> {
    let decoded = Command::new(env!("CARGO_BIN_EXE_acq"))
        .arg("decode")
        .arg(log)
        .arg("--rig")
        .arg(rig)
        .output()
        .unwrap();
    assert!(decoded.status.success(), "{decoded:?}");
    let mut times: std::collections::HashMap<String, Vec<f64>> = Default::default();
    for line in String::from_utf8(decoded.stdout).unwrap().lines().skip(1) {
        let mut fields = line.split(',');
        let time_s: f64 = fields.next().unwrap().parse().unwrap();
        let sensor = fields.next().unwrap().to_string();
        times.entry(sensor).or_default().push(time_s);
    }
    times
        .into_iter()
        .map(|(sensor, t)| {
            let span_s = t[t.len() - 1] - t[0];
            let rate_hz = (t.len() - 1) as f64 / span_s;
            (sensor, (t.len(), rate_hz))
        })
        .collect()
}

fn frames_per_iface(path: &Path) -> usize {
    fs::read_to_string(path).unwrap().lines().count()
}

#[test]
fn the_shipped_sessions_replayed_on_a_real_vcan_give_the_expected_calibration() {
    // In the VM: acq demo plays the recorded fixtures onto vcan0/vcan1 and
    // records them again (candump watching); here: the rest of the chain.
    let work = tempfile::tempdir().unwrap();
    let inputs = work.path().join("in");
    let out = work.path().join("out");
    let copy = |from: &str| {
        let status = Command::new("cp")
            .arg("-r")
            .arg(root().join(from))
            .arg(inputs.join(from))
            .status()
            .unwrap();
        assert!(status.success());
    };
    fs::create_dir_all(inputs.join("fixtures")).unwrap();
    fs::create_dir_all(inputs.join("data")).unwrap();
    copy("fixtures/sessions");
    copy("data/excavator");
    run_guest_script("demo-acquire.sh", &inputs, &out);

    // Lossless over a real bus: every frame of each fixture is in the new
    // recording, and candump saw as many frames as acq recorded.
    let mut recorded_total = 0;
    for (name, _) in acq_demo::SHIPPED {
        let original = session::read(&root().join("fixtures/sessions").join(name)).unwrap();
        let again = session::read(&out.join("demo/sessions").join(name)).unwrap();
        assert_eq!(
            again.session.frames, original.session.frames,
            "{name}: frames recorded again over vcan"
        );
        assert_eq!(again.session.dropped_by_kernel, 0, "{name}");
        assert_eq!(again.interface[0].timestamp_source, "kernel", "{name}");
        recorded_total += again.session.frames as usize;
    }
    let dumped = frames_per_iface(&out.join("candump_vcan0.log"))
        + frames_per_iface(&out.join("candump_vcan1.log"));
    assert_eq!(
        dumped, recorded_total,
        "candump and acq saw the same frames"
    );

    // Align, extract, calibrate on the host, and check against the
    // scenarios and the expected results.
    let analysis = work.path().join("analysis");
    let output = common::acq(&[
        "demo",
        "--sessions",
        out.join("demo/sessions").to_str().unwrap(),
        "--out",
        analysis.to_str().unwrap(),
    ]);
    assert!(output.status.success(), "{}", common::stderr(&output));
    common::pipeline::check_demo_output(&analysis, false);
}
