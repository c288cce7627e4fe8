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

use acq_can::frame::{FD_FLAG_BRS, FD_FLAG_ESI, FD_FLAG_FDF};
use acq_can::log::candump::{parse_line, CandumpWriter};
use acq_can::{CanId, Frame, FrameKind, IfaceName};
use acq_io::session;

const T0_NS: i64 = 1_763_719_200_000_000_000;
const VARIETY_FRAMES: usize = 2000;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// A test's scratch directory (the VM's inputs and outputs): removed when
/// the test passes, kept and named when it fails, so that a failed CI run
/// leaves the guest's captures to read. `ACQ_KEEP_VM_OUTPUT=1` keeps it
/// always.
struct Work(Option<tempfile::TempDir>);

impl Work {
    fn new() -> Work {
        Work(Some(
            tempfile::Builder::new()
                .prefix("acq-vcan-")
                .tempdir()
                .unwrap(),
        ))
    }

    fn path(&self) -> &Path {
        self.0.as_ref().expect("until dropped").path()
    }
}

impl Drop for Work {
    fn drop(&mut self) {
        let dir = self.0.take().expect("dropped once");
        if std::thread::panicking() || std::env::var_os("ACQ_KEEP_VM_OUTPUT").is_some() {
            eprintln!(
                "vcan: the inputs and the guest's captures are kept in {}",
                dir.keep().display()
            );
        }
    }
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
    // Its hidden truth as shipped: 6 s holds, which leave 5 s after the
    // 0.5 s settling at each end, above the 3 s the hold finder keeps at
    // any pace the guest keeps (a late guest only stretches them).
    fs::copy(
        root().join("examples/excavator-rig/hidden_truth.toml"),
        dir.join("examples/excavator-rig/hidden_truth.toml"),
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

/// The longest a guest may run, boot included. With the test profile's
/// binary in the guest (before 2026-11-30) check 8 played the virtual rig
/// at 0.14 of its pace and this test took up to 774 s; with the release
/// build ([`release_acq`]) the same checks took 139 s on the same day. A
/// limit only ends a guest that would pass on a slower host; a hung one
/// ends at it too, later.
const VM_TIMEOUT_S: u32 = 900;

/// Runs tests/vcan-vm/`script` natively when this host has vcan, else in
/// the VM, with `inputs` as $IN and `out` as $OUT.
fn run_guest_script(script: &str, inputs: &Path, out: &Path) {
    let acq = release_acq();
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
            .args(["--timeout", &VM_TIMEOUT_S.to_string()])
            .status()
    }
    .expect("could not start the vcan checks");
    assert!(
        status.success(),
        "the vcan checks failed ({status}); on a host without CAN they need qemu (tests/vcan-vm/README.md)"
    );
}

/// The acq the guest runs: the release build, the one users run. The
/// guest emulates its CPU in software, and the test profile's binary
/// (its drivers and recorder unoptimised) played check 8's virtual rig at
/// 0.14-0.17 of its pace there (2026-11-30), most of this test's time.
/// Built here from the same sources into the same build directory; after
/// the README's `cargo run --release -- demo` it is already up to date.
fn release_acq() -> PathBuf {
    let test_build = PathBuf::from(env!("CARGO_BIN_EXE_acq"));
    // scripts/test builds the tests in the release profile: the binary
    // under test is the release build already.
    if !cfg!(debug_assertions) {
        return test_build;
    }
    let target_dir = test_build
        .parent()
        .and_then(Path::parent)
        .expect("the test binary lives in <target>/<profile>/");
    let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
    let status = Command::new(cargo)
        .args([
            "build",
            "--quiet",
            "--release",
            "--bin",
            "acq",
            "--target-dir",
        ])
        .arg(target_dir)
        .current_dir(root())
        .status()
        .expect("could not run cargo to build the release acq for the guest");
    assert!(
        status.success(),
        "cargo build --release --bin acq failed ({status})"
    );
    target_dir.join("release").join("acq")
}

#[test]
fn record_replay_and_simulate_on_a_real_vcan() {
    let work = Work::new();
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
    // shift (a slow first send) is harmless, and so is a stall of the
    // guest that the schedule catches up on. Drift is what stays: an
    // absolute schedule ends where it started, one of relative sleeps adds
    // every sleep's overshoot and ends behind by all of them. So the drift
    // is the median offset error of the log's last tenth against that of
    // its first tenth.
    let offset_errors_us: Vec<f64> = captured
        .iter()
        .zip(&sent)
        .map(|(c, s)| {
            ((c.timestamp_ns - captured[0].timestamp_ns) - (s.timestamp_ns - sent[0].timestamp_ns))
                as f64
                / 1e3
        })
        .collect();
    let tenth = offset_errors_us.len() / 10;
    let median_of = |errors: &[f64]| {
        let mut sorted = errors.to_vec();
        sorted.sort_by(f64::total_cmp);
        sorted[sorted.len() / 2]
    };
    let drift_us = median_of(&offset_errors_us[offset_errors_us.len() - tenth..])
        - median_of(&offset_errors_us[..tenth]);
    eprintln!(
        "vcan replay timing (candump's kernel timestamps): inter-frame |error| median {median:.1} us, p99 {p99:.1} us; drift (last tenth's median offset error - first tenth's) {drift_us:.1} us"
    );
    eprintln!(
        "{}",
        fs::read_to_string(out.join("c2_replay.txt"))
            .unwrap_or_default()
            .trim()
    );
    // Loose bounds: the VM emulates its CPU; the 100 us target is measured
    // on the host (BENCHMARKS.md). An absolute schedule cannot drift, but a
    // guest that cannot send as fast as the log asks falls behind it: the
    // pace is the log's span over the capture's.
    let replay_pace = (sent[sent.len() - 1].timestamp_ns - sent[0].timestamp_ns) as f64
        / (captured[captured.len() - 1].timestamp_ns - captured[0].timestamp_ns) as f64;
    eprintln!("vcan replay: the guest kept {replay_pace:.4} of the log's pace (floor {REPLAY_PACE_FLOOR})");
    assert!(
        median < 2000.0,
        "{}",
        judged(
            "check 2",
            replay_pace,
            REPLAY_PACE_FLOOR,
            &format!("median inter-frame error {median} us")
        )
    );
    // Drift has a sign. An absolute schedule never sends early, so a
    // frame's offset error is its own lateness less the first frame's:
    // behind (positive) is the fault this checks for, relative sleeps
    // adding up. Ahead (negative) is a late start the schedule caught up
    // on: a guest stalled as it began (seen: -5.1 ms, with the guest at
    // 1.0034 of the log's pace while the host ran other tests), bounded
    // only loosely, so that a schedule run too fast (a scaled clock)
    // still fails.
    assert!(
        drift_us < 5000.0 && drift_us > -50_000.0,
        "{}",
        judged(
            "check 2",
            replay_pace,
            REPLAY_PACE_FLOOR,
            &format!("the replay drifted: its last tenth is {drift_us} us off the schedule against its first")
        )
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
        let pace = wire_rate_hz / scheduled_rate_hz;
        assert!(
            (SIMULATE_PACE_FLOOR..1.1).contains(&pace),
            "{}",
            judged(
                "check 3",
                pace,
                SIMULATE_PACE_FLOOR,
                &format!(
                    "{}: the guest sent at {wire_rate_hz} Hz of the {scheduled_rate_hz} Hz scheduled",
                    sensor.name
                )
            )
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
    assert!(
        missing <= c4.session.dropped_by_kernel,
        "{missing} frames candump saw before the signal are not in raw.log, and only {} drops were reported",
        c4.session.dropped_by_kernel
    );
    flood_was_busy("check 4", before);

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
    flood_was_busy("check 7", before);

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
    assert_eq!(
        (missing, c8.session.dropped_by_kernel),
        (0, 0),
        "frames candump saw before the signal that are not in raw.log, and kernel drops; acq said: {stderr8}"
    );
    flood_was_busy("check 8", before);
    // What the study may be asked depends on the guest's pace: a guest
    // that falls behind the virtual rig's schedule stretches its holds (and
    // sends them in bursts that can split one), and may cut the last one
    // short. So the holds that count are the ones the wire carried whole:
    // `acq calibrate rig` over the recorded session after the fact (it
    // holds every frame candump saw, asserted above), with all the time
    // it needs. The live study must have seen the same holds, used every
    // complete one and skipped the same others for the same reasons; a
    // hold the wire cut short is reported here, not a failure.
    let pace = rig_pace(&inputs, &out, work.path());
    eprintln!("check 8: the guest played the virtual rig at {pace:.3} of the schedule's pace (floor {STUDY_PACE_FLOOR})");
    let offline = offline_study(&inputs, &out.join("c8"), work.path());
    let complete = offline["holds_used"].as_u64().unwrap_or(0);
    assert!(
        complete > 0,
        "{}",
        judged(
            "check 8",
            pace,
            STUDY_PACE_FLOOR,
            &format!("the recording holds no complete hold for the study to take: {offline}")
        )
    );
    assert!(
        said.contains("study: after 1 hold(s)"),
        "{}",
        judged(
            "check 8",
            pace,
            STUDY_PACE_FLOOR,
            &format!("the study did not update while the buses were busy; before the stop it said: {said}\nafter: {stderr8}")
        )
    );
    // The recorder waited for the study to take every hold it found (the
    // flood still on).
    let live: serde_json::Value =
        serde_json::from_str(&fs::read_to_string(out.join("c8/study.json")).unwrap()).unwrap();
    let holds = |panel: &serde_json::Value| {
        (
            panel["holds_seen"].clone(),
            panel["holds_used"].clone(),
            panel["skipped"].clone(),
        )
    };
    assert_eq!(
        holds(&live),
        holds(&offline),
        "(holds seen, used, skipped) by the study during the recording against acq calibrate rig over the recording; acq said: {stderr8}"
    );
    eprintln!(
        "check 8: {} hold(s) on the wire, {complete} complete and all used; cut short by the virtual rig's lateness or the end of the recording (reported, not a failure): {}",
        offline["holds_seen"], offline["skipped"]
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

/// The slowest pace of the guest (the time the schedule spans over the
/// time the guest took to play it) at which check 8 means something: at
/// 0.14 (seen with the host busy) the rig's 33 s took 4 min and every
/// hold was still found, stretched; below 0.1 the virtual rig alone would
/// take more than a third of the 900 s the VM was first given.
const STUDY_PACE_FLOOR: f64 = 0.1;

/// The slowest pace at which check 2's replay timing means something: a
/// guest that keeps a pace p over the 2 s log (the log's span over the
/// capture's) falls behind by (1/p - 1) x 2 s whatever acq does, 90 % of
/// that between the first tenth and the last: inside the 5 ms drift bound
/// only above p = 0.997.
const REPLAY_PACE_FLOOR: f64 = 0.997;

/// The slowest pace at which check 3's rates mean something: a pacing bug
/// (everything at once, or a period off by a factor) lands far outside;
/// 0.66 has been seen with the host busy.
const SIMULATE_PACE_FLOOR: f64 = 0.3;

/// The fewest frames a flood check's generators must have put on the
/// buses before the stop for the check to mean anything: a guest that
/// keeps pace puts 9,000 to 12,000 there in checks 4 and 7 and far more in
/// check 8; 691 have been seen with the host's two cores shared by eight
/// busy processes.
const FLOOD_FLOOR_FRAMES: usize = 1000;

/// A flood check's precondition, asked after what acq answers for (no
/// frame lost, no kernel drop) has passed: the buses were busy.
fn flood_was_busy(check: &str, frames_before_the_stop: usize) {
    assert!(
        frames_before_the_stop >= FLOOD_FLOOR_FRAMES,
        "{check} cannot judge acq on this host: the emulated guest's generators put only \
         {frames_before_the_stop} frames on the buses before the stop, below the {FLOOD_FLOOR_FRAMES} \
         that make a busy bus. The host was too slow (something else loaded its cores); run the \
         VM tests again on a quieter machine. What acq answers for (frames lost, kernel drops) \
         held."
    );
}

/// The words of a failed real-time check: below its pace floor the host
/// was too slow for the check to judge acq, above it acq is at fault.
fn judged(check: &str, pace: f64, floor: f64, what: &str) -> String {
    if pace < floor {
        format!(
            "{check} cannot judge acq on this host: the emulated guest kept {pace:.3} of the schedule's pace, \
             below the {floor} this check needs. The host was too slow (something else loaded its cores); \
             run the VM tests again on a quieter machine. What failed: {what}"
        )
    } else {
        format!("{check}: {what} (the guest kept {pace:.3} of the schedule's pace, above the check's floor {floor}: acq is at fault, not the host)")
    }
}

/// Check 8's pace: the span of the virtual rig's schedule (the same
/// simulation written to a file on the host) over the time the guest took
/// to send it (what `acq simulate` said in the guest).
fn rig_pace(inputs: &Path, out: &Path, work: &Path) -> f64 {
    let scheduled_log = work.join("c8_scheduled.log");
    let simulated = Command::new(env!("CARGO_BIN_EXE_acq"))
        .args(["simulate", "--seed", "8", "--start", "1763719200", "--rig"])
        .arg(inputs.join("rigs/excavator.toml"))
        .arg("--scenario")
        .arg(inputs.join("examples/excavator-rig/hidden_truth.toml"))
        .arg("--output")
        .arg(&scheduled_log)
        .output()
        .unwrap();
    assert!(simulated.status.success(), "{simulated:?}");
    let scheduled = read_log(&scheduled_log);
    let scheduled_s =
        (scheduled[scheduled.len() - 1].timestamp_ns - scheduled[0].timestamp_ns) as f64 / 1e9;
    let said = fs::read_to_string(out.join("c8_simulate.txt")).unwrap_or_default();
    let played_s: f64 = said
        .split_once(" frames in ")
        .and_then(|(_, rest)| rest.split_once(" s"))
        .and_then(|(seconds, _)| seconds.parse().ok())
        .unwrap_or_else(|| {
            panic!("check 8: acq simulate in the guest did not say how long it played: {said}")
        });
    scheduled_s / played_s
}

/// `acq calibrate rig` over a recorded session with check 8's study: its
/// last panel, or one with no hold when the recording holds none.
fn offline_study(inputs: &Path, session: &Path, work: &Path) -> serde_json::Value {
    let panel = work.join("c8_offline_study.json");
    let output = common::acq(&[
        "calibrate",
        "rig",
        session.to_str().unwrap(),
        "--study",
        inputs
            .join("examples/excavator-rig/study.toml")
            .to_str()
            .unwrap(),
        "-o",
        panel.to_str().unwrap(),
    ]);
    let stderr = common::stderr(&output);
    if !output.status.success() && stderr.contains("no steady hold") {
        return serde_json::json!({ "holds_seen": 0, "holds_used": 0, "skipped": [], "why": stderr });
    }
    assert!(
        output.status.success(),
        "acq calibrate rig over check 8's recording: {stderr}"
    );
    serde_json::from_str(&fs::read_to_string(&panel).unwrap()).unwrap()
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
    let work = Work::new();
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
    let mut slowest_pace = f64::INFINITY;
    for (name, _) in acq_demo::SHIPPED {
        let span_s = |dir: &Path| {
            let frames = read_session_frames(dir);
            (frames[frames.len() - 1].timestamp_ns - frames[0].timestamp_ns) as f64 / 1e9
        };
        slowest_pace = slowest_pace.min(
            span_s(&root().join("fixtures/sessions").join(name))
                / span_s(&out.join("demo/sessions").join(name)),
        );
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
    // scenarios and the expected results. What the recordings hold depends
    // on the guest's pace: a guest that replays late stretches the holds
    // and sends in bursts, and the holds found in the new recording are
    // no longer the fixture's (at 0.18 the 8 s hold of case 1 came out as
    // two).
    eprintln!(
        "shipped sessions: the guest replayed them at {slowest_pace:.3} of their pace at the slowest (floor {DEMO_PACE_FLOOR})"
    );
    let analysis = work.path().join("analysis");
    let output = common::acq(&[
        "demo",
        "--sessions",
        out.join("demo/sessions").to_str().unwrap(),
        "--out",
        analysis.to_str().unwrap(),
    ]);
    assert!(
        output.status.success(),
        "{}",
        judged(
            "the shipped sessions' analysis",
            slowest_pace,
            DEMO_PACE_FLOOR,
            &common::stderr(&output)
        )
    );
    let checked =
        std::panic::catch_unwind(|| common::pipeline::check_demo_output(&analysis, false));
    if let Err(failure) = checked {
        let what = failure
            .downcast_ref::<String>()
            .cloned()
            .or_else(|| failure.downcast_ref::<&str>().map(|s| s.to_string()))
            .unwrap_or_default();
        panic!(
            "{}",
            judged(
                "the shipped sessions' analysis",
                slowest_pace,
                DEMO_PACE_FLOOR,
                &what
            )
        );
    }
}

/// The slowest pace (a fixture's span over its new recording's) at which
/// the shipped sessions recorded again in the guest still hold the
/// fixtures' holds. Measured: 1.0 with the host idle or one core busy
/// (five runs), 0.94 beside three busy processes, 0.29 beside eight
/// (passed), 0.18 beside eight and a build (case 1's hold split in two).
const DEMO_PACE_FLOOR: f64 = 0.3;
