//! The live page's costs on the host, in-process bus, four buses at
//! 2,000 frames/s each (`fixtures/rigs/bench_four_buses.toml`, every fourth
//! frame of its simulation), recorded with live decode:
//!
//! 1. CPU: the recorder with the page and two viewers (`curl -N` reading
//!    the event stream, separate processes) against the recorder alone, the
//!    same traffic, in the same run. Target: the page under 10 % of one core.
//! 2. Latency, frame on the bus to point in the viewer: bus 0's force frames
//!    carry their send time as the value; a viewer in this process reads the
//!    event stream and notes when each value first arrives. For every
//!    millisecond of sent traffic, the wait until an update held it; the
//!    median (target under 250 ms; a browser adds one animation frame).
//!
//! 3. `acq view` of a long session: one hour at 8,000 frames/s (bus 0 of
//!    the same rig, 19 sensors, 28.8 M frames, 1.3 GB) written as a session;
//!    opened once from the recording (which writes its index) and again from
//!    the index (target under 2 s); then a zoom into 10 s and the whole hour
//!    at 1,000 columns, which read only the buckets held.
//!
//! 4. The page in a real browser (headless Chromium, as `tests/view.rs`
//!    drives it): 30 signals in 6 plots (a layout file's), live at 8,000
//!    frames/s. Frame to pixel: the page notes, at the animation frame that
//!    draws it, the newest marker value on screen; for every millisecond of
//!    sent traffic, the wait until a drawn frame held it (target: median
//!    under 250 ms). The browser's CPU: every process of its tree, user and
//!    system time from /proc over the window (target: under 25 % of one
//!    core). The recorder must still record every frame sent.
//!
//! `cargo bench --bench view` (ACQ_BENCH_SECONDS sets each window, default
//! 10; ACQ_BENCH_VIEW_HOURS the long session, default 1;
//! ACQ_BENCH_BROWSER_SECONDS the browser's, default 30;
//! ACQ_BENCH_VIEW_ONLY=browser runs the fourth case alone).

#[path = "../tests/common/browser.rs"]
mod browser;
mod common;

use std::io::{BufRead, BufReader, Write};
use std::net::TcpStream;
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::sync::{Arc, Mutex};
use std::thread;
use std::time::Instant;

use acq_acquire::record::RecordObserver;
use acq_acquire::simulate::scenario::Scenario;
use acq_acquire::simulate::Simulation;
use acq_analysis::extract::holds::HoldOptions;
use acq_rig::Rig;
use common::{four_bus_rig, record_while_producing};

/// (arrival s, newest marker value) of each update a viewer read.
type Arrivals = Arc<Mutex<Vec<(f64, f64)>>>;

/// Reads the event stream; (arrival s since `epoch`, newest marker value).
fn probe(url: &str, epoch: Instant, arrivals: Arrivals) {
    let host = url
        .trim_start_matches("http://")
        .trim_end_matches('/')
        .to_string();
    thread::spawn(move || {
        let mut stream = TcpStream::connect(&host).unwrap();
        write!(
            stream,
            "GET /api/events HTTP/1.1\r\nHost: {host}\r\nAccept: text/event-stream\r\n\r\n"
        )
        .unwrap();
        for line in BufReader::new(stream).lines() {
            let Ok(line) = line else { return };
            let Some(data) = line.strip_prefix("data: ") else {
                continue;
            };
            let at = epoch.elapsed().as_secs_f64();
            let Ok(update) = serde_json::from_str::<serde_json::Value>(data) else {
                continue;
            };
            let newest = update["tails"][0]["series"][0]
                .as_array()
                .and_then(|columns| columns.last())
                .and_then(|column| column[2].as_f64());
            if let Some(value) = newest {
                arrivals.lock().unwrap().push((at, value));
            }
        }
    });
}

/// The page's live session of the bench rig, holds on bus 0's force.
fn bench_session(rig: &Rig) -> (acq_view::LiveFeed, acq_view::SharedSession) {
    acq_view::live_session(
        "bench",
        rig,
        HoldOptions::default(),
        Some("tip_force_0"),
        None,
        None,
    )
}

struct Run {
    cpu_share: f64,
    frames: u64,
}

fn record_run(seconds: f64, view: bool, viewers: usize, arrivals: Option<Arrivals>) -> Run {
    let rig = four_bus_rig();
    let epoch = Instant::now();
    let mut observer: Option<Box<dyn RecordObserver>> = None;
    let mut host = None;
    let mut clients: Vec<Child> = Vec::new();
    if view {
        let (feed, shared) = bench_session(&rig);
        observer = Some(Box::new(feed));
        let address = "127.0.0.1:0".parse().unwrap();
        let access = acq_view::access_for(address, false).unwrap();
        let started = acq_view::ViewHost::start(address, access, vec![shared]).unwrap();
        let url = started.url().to_string();
        for _ in 0..viewers {
            clients.push(
                Command::new("curl")
                    .args(["-sN", "-o", "/dev/null", &format!("{url}api/events")])
                    .stdout(Stdio::null())
                    .stderr(Stdio::null())
                    .spawn()
                    .expect("curl for the viewers"),
            );
        }
        if let Some(arrivals) = arrivals {
            probe(&url, epoch, arrivals);
        }
        host = Some(started);
    }
    let (cpu_share, sent) = record_while_producing(&rig, observer, seconds, 4, Some(epoch));
    if let Some(host) = host {
        host.stop();
    }
    for mut client in clients {
        let _ = client.kill();
        let _ = client.wait();
    }
    Run {
        cpu_share,
        frames: sent,
    }
}

/// Writes a session of `hours` of bus 0 of the four-bus rig at 8,000
/// frames/s into `dir` (raw.log, its rig, session.toml).
fn long_session(dir: &Path, hours: f64) -> u64 {
    use acq_io::session::{self, CopiedFile, RigCopy, SessionFile, SessionInfo};
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(root.join("fixtures/rigs/bench_four_buses.toml")).unwrap();
    // The header, bus daq0 and its sensors.
    let mut rig_text = String::new();
    for (k, block) in text.split("\n[[").enumerate() {
        let keep = k == 0
            || block.starts_with("bus]]\nname = \"daq0\"")
            || block.contains("bus = \"daq0\"");
        if keep {
            if k > 0 {
                rig_text.push_str("\n[[");
            }
            rig_text.push_str(block);
        }
    }
    let rig_text = rig_text.replace("../dbc/somat_excavator.dbc", "somat_excavator.dbc");
    std::fs::create_dir_all(dir.join("rig")).unwrap();
    std::fs::write(dir.join("rig/bench.toml"), &rig_text).unwrap();
    let dbc = std::fs::read(root.join("fixtures/dbc/somat_excavator.dbc")).unwrap();
    std::fs::write(dir.join("rig/somat_excavator.dbc"), &dbc).unwrap();
    let rig = Rig::load(&dir.join("rig/bench.toml")).unwrap();
    let total_s = hours * 3600.0;
    let scenario_path = dir.join("scenario.toml");
    std::fs::write(
        &scenario_path,
        format!(
            "name = \"long\"\n[timeline]\nidle_s = 60.0\nbuild_up_s = 30.0\nhold_s = {}\nrelease_s = 30.0\nafter_s = 60.0\n\
             [sensor.tip_force_0]\nidle = 0.0\nhold = 40.6\nnoise = 0.08\n[sensor.sg01_0]\nidle = 2.0\nhold = 11.5\nnoise = 0.15\n",
            total_s - 180.0
        ),
    )
    .unwrap();
    let (scenario, curve) = Scenario::load(&scenario_path).unwrap();
    let start_ns = 1_800_000_000_000_000_000;
    let mut simulation = Simulation::new(&rig, scenario, curve, 1, start_ns).unwrap();
    let mut out = std::io::BufWriter::with_capacity(
        1 << 20,
        std::fs::File::create(dir.join("raw.log")).unwrap(),
    );
    let mut line = Vec::with_capacity(128);
    let mut frames = 0u64;
    while let Some(frame) = simulation.next_frame() {
        line.clear();
        acq_can::log::candump::push_line(&mut line, &frame).unwrap();
        out.write_all(&line).unwrap();
        frames += 1;
    }
    out.flush().unwrap();
    let sha = |bytes: &[u8]| session::sha256_hex(bytes);
    let file = SessionFile {
        session: SessionInfo {
            format_version: session::FORMAT_VERSION,
            software: "bench".into(),
            started_unix_ns: start_ns,
            started_utc: session::utc_text(start_ns),
            ended: "bench".into(),
            raw_files: vec!["raw.log".into()],
            ..Default::default()
        },
        interface: Vec::new(),
        rig: Some(RigCopy {
            name: rig.name.clone(),
            file: CopiedFile {
                source: "bench".into(),
                copy: "rig/bench.toml".into(),
                sha256: sha(rig_text.as_bytes()),
                copy_sha256: None,
            },
            dbc: vec![CopiedFile {
                source: "bench".into(),
                copy: "rig/somat_excavator.dbc".into(),
                sha256: sha(&dbc),
                copy_sha256: None,
            }],
            sensor_file: None,
        }),
        source: Vec::new(),
        sensor: Vec::new(),
    };
    session::write(dir, &file).unwrap();
    session::repair(dir).unwrap();
    frames
}

fn long_session_open(hours: f64) {
    let dir = tempfile::tempdir().unwrap();
    let session = dir.path().join("long");
    let started = Instant::now();
    let frames = long_session(&session, hours);
    let bytes = std::fs::metadata(session.join("raw.log")).unwrap().len();
    println!(
        "long session: {frames} frames, {:.2} GB written in {:.1} s",
        bytes as f64 / 1e9,
        started.elapsed().as_secs_f64()
    );
    let started = Instant::now();
    let (first, source) = acq_view::open_session(&session, "long").unwrap();
    let first_s = started.elapsed().as_secs_f64();
    assert_eq!(source, acq_view::Source::Recording(Ok(())));
    let index_bytes = std::fs::metadata(session.join(acq_view::index::FILE))
        .unwrap()
        .len();
    let mut again_s = Vec::new();
    let mut view = None;
    for _ in 0..3 {
        let started = Instant::now();
        let (opened, source) = acq_view::open_session(&session, "long").unwrap();
        again_s.push(started.elapsed().as_secs_f64());
        assert_eq!(source, acq_view::Source::Index);
        view = Some(opened);
    }
    let view = view.unwrap();
    assert_eq!(view.holds.len(), first.holds.len());
    let (from, to) = view.span_s().unwrap();
    let started = Instant::now();
    let middle = (from + to) / 2.0;
    let zoom = view.series_json(middle, middle + 10.0, 1000);
    let zoom_ms = started.elapsed().as_secs_f64() * 1e3;
    let started = Instant::now();
    let whole = view.series_json(from, to, 1000);
    let whole_ms = started.elapsed().as_secs_f64() * 1e3;
    again_s.sort_by(f64::total_cmp);
    println!(
        "acq view of {hours} h at 8,000 frames/s: first open (from the recording, index written, {:.0} MB) {first_s:.1} s; \
         again from the index {:.2} s (median of 3); zoom to 10 s at 1,000 columns {zoom_ms:.1} ms ({} kB), the whole session {whole_ms:.1} ms ({} kB); {} hold(s)",
        index_bytes as f64 / 1e6,
        again_s[1],
        zoom.len() / 1000,
        whole.len() / 1000,
        view.holds.len()
    );
}

/// For every millisecond of sent traffic (marker values, s), the wait (s)
/// until the first arrival that held it; `arrivals` are (arrival s, newest
/// marker value) on the marker's clock.
fn waits_per_ms(arrivals: &[(f64, f64)]) -> Vec<f64> {
    let (first, last) = (arrivals[0].1, arrivals[arrivals.len() - 1].1);
    let mut waits: Vec<f64> = Vec::new();
    let mut s = first;
    let mut k = 0;
    while s < last {
        while k < arrivals.len() && arrivals[k].1 < s {
            k += 1;
        }
        if k < arrivals.len() {
            waits.push(arrivals[k].0 - s);
        }
        s += 0.001;
    }
    waits
}

/// User and system CPU seconds of process `root` and of each descendant,
/// by kind (Chromium's `--type=`: renderer, gpu-process, utility; the
/// browser process itself), from /proc (in USER_HZ ticks: 100 a second on
/// Linux, whatever the kernel's HZ).
fn tree_cpu_seconds(root: u32) -> std::collections::BTreeMap<String, f64> {
    let mut processes: Vec<(u32, u32, f64)> = Vec::new();
    for entry in std::fs::read_dir("/proc").unwrap().flatten() {
        let Ok(pid) = entry.file_name().to_string_lossy().parse::<u32>() else {
            continue;
        };
        let Ok(stat) = std::fs::read_to_string(entry.path().join("stat")) else {
            continue;
        };
        // After "pid (name) ": state, ppid, ... utime and stime are the
        // 14th and 15th fields of the whole line.
        let Some(rest) = stat.rfind(')').map(|i| &stat[i + 1..]) else {
            continue;
        };
        let fields: Vec<&str> = rest.split_whitespace().collect();
        if fields.len() < 13 {
            continue;
        }
        let number = |k: usize| fields[k].parse::<f64>().unwrap_or(0.0);
        let ppid = fields[1].parse().unwrap_or(0);
        processes.push((pid, ppid, (number(11) + number(12)) / 100.0));
    }
    let mut tree = vec![root];
    let mut k = 0;
    while k < tree.len() {
        let parent = tree[k];
        for &(pid, ppid, _) in &processes {
            if ppid == parent && !tree.contains(&pid) {
                tree.push(pid);
            }
        }
        k += 1;
    }
    let mut by_kind = std::collections::BTreeMap::new();
    for &(pid, _, seconds) in processes.iter().filter(|(pid, ..)| tree.contains(pid)) {
        let command = std::fs::read(format!("/proc/{pid}/cmdline")).unwrap_or_default();
        let kind = String::from_utf8_lossy(&command)
            .split(['\0', ' '])
            .find_map(|a| a.strip_prefix("--type=").map(str::to_owned))
            .unwrap_or_else(|| "browser".into());
        *by_kind.entry(kind).or_insert(0.0) += seconds;
    }
    by_kind
}

/// The fourth case, the page in headless Chromium: the first 30 sensors of the four-bus
/// rig in 6 plots of 5, live at 8,000 frames/s.
fn browser_run(seconds: f64) {
    let rig = four_bus_rig();
    let epoch = Instant::now();
    let epoch_unix_s = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .unwrap()
        .as_secs_f64()
        - epoch.elapsed().as_secs_f64();
    let (feed, shared) = bench_session(&rig);
    let names: Vec<&str> = rig.sensors.iter().map(|s| s.name.as_str()).collect();
    let plots: Vec<serde_json::Value> = names[..30]
        .chunks(5)
        .enumerate()
        .map(|(k, signals)| serde_json::json!({"title": format!("plot {}", k + 1), "signals": signals}))
        .collect();
    let layout_text = serde_json::json!({"format": 1, "plots": plots}).to_string();
    let layout = acq_view::layout::Layout::parse(&layout_text, &names).unwrap();
    let address = "127.0.0.1:0".parse().unwrap();
    let access = acq_view::access_for(address, false).unwrap();
    let pages = acq_view::Pages {
        sessions: vec![shared.clone()],
        study: None,
        layout: Some(layout),
    };
    let host = acq_view::ViewHost::start(address, access, pages).unwrap();
    let limit = std::time::Duration::from_secs_f64(seconds + 120.0);
    let mut page = browser::LivePage::open(host.url(), limit).expect("Chromium opens the page");
    let started = Instant::now();
    let built = loop {
        let built = page
            .evaluate("window.acqView.sessions.length ? window.acqView.sessions[0].groups.map((g) => g.members.length).join(',') : ''")
            .unwrap();
        if built != "" || started.elapsed().as_secs() > 30 {
            break built;
        }
        thread::sleep(std::time::Duration::from_millis(100));
    };
    assert_eq!(built, "5,5,5,5,5,5", "6 plots of 5 signals");
    page.evaluate("window.acqView.watch = 'tip_force_0'")
        .unwrap();
    let pid = page.browser_pid();
    let window_s = seconds - 3.0;
    let browser_cpu = thread::spawn(move || {
        thread::sleep(std::time::Duration::from_secs(2));
        let (cpu0, wall0) = (tree_cpu_seconds(pid), Instant::now());
        thread::sleep(std::time::Duration::from_secs_f64(window_s));
        let wall = wall0.elapsed().as_secs_f64();
        tree_cpu_seconds(pid)
            .into_iter()
            .map(|(kind, seconds)| {
                (
                    kind.clone(),
                    (seconds - cpu0.get(&kind).unwrap_or(&0.0)) / wall,
                )
            })
            .collect::<Vec<(String, f64)>>()
    });
    let (recorder_share, sent) =
        record_while_producing(&rig, Some(Box::new(feed)), seconds, 4, Some(epoch));
    let shares = browser_cpu.join().unwrap();
    let browser_share: f64 = shares.iter().map(|(_, share)| share).sum();
    let by_kind: Vec<String> = shares
        .iter()
        .map(|(kind, share)| format!("{kind} {:.1} %", 100.0 * share))
        .collect();
    let log: Vec<(f64, f64)> = serde_json::from_str(
        page.evaluate("JSON.stringify(window.acqView.drawLog)")
            .unwrap()
            .as_str()
            .unwrap(),
    )
    .unwrap();
    assert_eq!(
        page.console_errors(),
        &[] as &[String],
        "the page logged errors"
    );
    page.close();
    host.stop();
    let not_shown = shared.lock().unwrap().frames_not_shown;
    let drawn: Vec<(f64, f64)> = log
        .iter()
        .map(|&(unix_ms, value)| (unix_ms / 1e3 - epoch_unix_s, value))
        .collect();
    let mut waits = waits_per_ms(&drawn);
    waits.sort_by(f64::total_cmp);
    println!(
        "the page in headless Chromium, 30 signals in 6 plots, 4 buses x 2,000 frames/s ({sent} frames in {seconds:.0} s, every one recorded; {not_shown} not shown): \
         frame on the bus to pixel median {:.0} ms, p95 {:.0} ms, max {:.0} ms ({} draws, {} ms of traffic); \
         the browser's processes {:.1} % of one core over {window_s:.0} s ({}); the recorder with the page {:.1} %",
        1e3 * waits[waits.len() / 2],
        1e3 * waits[waits.len() * 95 / 100],
        1e3 * waits[waits.len() - 1],
        drawn.len(),
        waits.len(),
        100.0 * browser_share,
        by_kind.join(", "),
        100.0 * recorder_share,
    );
}

fn main() {
    let hours: f64 = std::env::var("ACQ_BENCH_VIEW_HOURS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(1.0);
    let seconds: f64 = std::env::var("ACQ_BENCH_SECONDS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(10.0);

    let browser_seconds: f64 = std::env::var("ACQ_BENCH_BROWSER_SECONDS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(30.0);
    if std::env::var("ACQ_BENCH_VIEW_ONLY").as_deref() == Ok("browser") {
        browser_run(browser_seconds.max(10.0));
        return;
    }
    // 1. CPU, alternating so that the machine's drift hits both alike.
    let (mut alone, mut with_view) = (Vec::new(), Vec::new());
    for _ in 0..2 {
        alone.push(record_run(seconds, false, 0, None));
        with_view.push(record_run(seconds, true, 2, None));
    }
    let mean = |runs: &[Run]| runs.iter().map(|r| r.cpu_share).sum::<f64>() / runs.len() as f64;
    let frames = with_view.iter().map(|r| r.frames).sum::<u64>() / with_view.len() as u64;
    println!(
        "4 buses x 2,000 frames/s ({frames} frames in {seconds:.0} s per run, 2 runs each): \
         recorder alone {:.2} % of one core, with the page and 2 viewers {:.2} %: the page costs {:.2} % of one core",
        100.0 * mean(&alone),
        100.0 * mean(&with_view),
        100.0 * (mean(&with_view) - mean(&alone))
    );

    // 2. Latency.
    let arrivals = Arc::new(Mutex::new(Vec::new()));
    record_run(seconds, true, 1, Some(arrivals.clone()));
    let arrivals = arrivals.lock().unwrap().clone();
    let mut waits = waits_per_ms(&arrivals);
    waits.sort_by(f64::total_cmp);
    println!(
        "frame on the bus to point in a viewer: median {:.0} ms, p95 {:.0} ms, max {:.0} ms ({} updates, {} ms of traffic)",
        1e3 * waits[waits.len() / 2],
        1e3 * waits[waits.len() * 95 / 100],
        1e3 * waits[waits.len() - 1],
        arrivals.len(),
        waits.len()
    );

    // 3. A long recorded session.
    long_session_open(hours);

    // 4. The page in a browser.
    browser_run(browser_seconds.max(10.0));
}
