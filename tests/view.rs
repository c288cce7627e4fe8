//! The live page (`--view`), checked as its users meet it: `acq demo --view`
//! watched in a real headless Chromium while it replays the shipped sessions
//! (plots move, holds shaded as they end, a stopped sensor shown SILENT, no
//! console error), its holds against `acq extract`'s, and the doors that
//! must stay shut (other hosts, tokens, POST, hostile names).
//! Screenshots are kept in target/test-artefacts/view/.

mod common;

use std::os::unix::fs::FileTypeExt;

use std::io::{Read, Write};
use std::net::TcpStream;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use acq_analysis::recording::{Recording, SampleCounts};
use common::browser::LivePage;
use common::running::{url_in, Running};
use common::{acq, copy_session, path_arg, root, stderr};
use serde_json::Value;

fn artefacts() -> PathBuf {
    let dir = root().join("target/test-artefacts/view");
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// One HTTP/1.1 request; (status, headers, body).
fn http(addr: &str, method: &str, path: &str, host: Option<&str>) -> (u16, String, String) {
    let mut stream = TcpStream::connect(addr).unwrap();
    stream
        .set_read_timeout(Some(Duration::from_secs(10)))
        .unwrap();
    write!(
        stream,
        "{method} {path} HTTP/1.1\r\nHost: {}\r\nConnection: close\r\nContent-Length: 0\r\n\r\n",
        host.unwrap_or(addr)
    )
    .unwrap();
    let mut response = String::new();
    stream.read_to_string(&mut response).unwrap();
    let (head, body) = response.split_once("\r\n\r\n").unwrap_or((&response, ""));
    let status = head
        .split_whitespace()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(0);
    (status, head.to_string(), body.to_string())
}

fn host_of(url: &str) -> String {
    url.trim_start_matches("http://")
        .split('/')
        .next()
        .unwrap()
        .to_string()
}

/// When the load left the hold's plateau: the first sample after the
/// window whose load is off the window's mean by more than 1 % of the
/// load's range (the scale of the steady rule), seconds from session start.
fn release_s(session: &Path, load: &str, end_s: f64, mean: f64) -> f64 {
    let recording = Recording::open(session, None).unwrap();
    let index = recording.sensor_index(load).unwrap();
    let t0 = recording.session_start_unix_ns().unwrap();
    let mut series = Vec::new();
    let zero = vec![0; recording.rig.buses.len()];
    recording
        .for_each_sample(&zero, &mut SampleCounts::default(), |s| {
            if let (true, Some(v)) = (s.sensor == index, s.value) {
                series.push(((s.time_ns - t0) as f64 / 1e9, v));
            }
            Ok(())
        })
        .unwrap();
    let (lo, hi) = series
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), (_, v)| {
            (lo.min(*v), hi.max(*v))
        });
    series
        .iter()
        .find(|(t, v)| *t > end_s && (v - mean).abs() > 0.01 * (hi - lo))
        .map(|(t, _)| *t)
        .expect("the load leaves the hold")
}

/// What the page has drawn, from its own record (`window.acqView`).
const WATCH_JS: &str = r#"JSON.stringify({
  legendBlank: window.acqView.sessions.flatMap((s) => s.groups.flatMap((g) => {
    const rows = g.plot.root.querySelectorAll('.u-legend tr.u-series');
    return g.plot.series.map((x, k) => [k, x.label]).filter(([k]) => k > 0
      && g.plot.data[k].some((v) => v != null)
      && rows[k] && rows[k].querySelector('.u-value').textContent.trim() === '--').map(([, label]) => label);
  })),
  sharedColours: window.acqView.sessions.flatMap((s) => s.groups.filter((g) => {
    const strokes = g.plot.series.slice(1).map((x, i) => (typeof x.stroke === 'function' ? x.stroke(g.plot, i + 1) : x.stroke));
    return new Set(strokes).size !== strokes.length;
  }).map((g) => g.group)),
  xyTicks: window.acqView.sessions.map((s) => s.xyTicks || null),
  lastX: window.acqView.lastX,
  holds: window.acqView.holdsShown,
  silent: Array.from(document.querySelectorAll('tr.silent')).map((r) => r.textContent),
  updates: window.acqView.updates,
  changedBytes: document.querySelectorAll('table.frames span.changed').length,
  frameRows: Array.from(document.querySelectorAll('section.session')).map((s) => s.querySelectorAll('table.frames > tbody > tr').length),
  errors: window.acqView.errors,
  now: Date.now(),
})"#;

/// Case 1's load plot with case 2 overlaid: its labels, when each
/// session's tip force first passes 20 kN (case 2 on case 1's plot and on
/// its own), the shift, both first holds' starts, and case 2's overlaid tip
/// force in the middle of case 1's first hold with the mean of case 2's.
const OVERLAY_JS: &str = r#"JSON.stringify((() => {
  const [s, o] = window.acqView.sessions;
  const g = s.groups[1];
  const u = g.plot;
  const riseOf = (plot, k) => { const i = plot.data[k].findIndex((v) => v != null && v > 20); return i < 0 ? null : plot.data[0][i]; };
  const overlaid = 1 + g.members.length;
  const mid = (s.holds[0].start_s + s.holds[0].end_s) / 2;
  let nearest = null;
  u.data[0].forEach((t, i) => { const v = u.data[overlaid][i]; if (v != null && (nearest === null || Math.abs(t - mid) < Math.abs(u.data[0][nearest] - mid))) nearest = i; });
  return {
    labels: u.series.slice(1).map((x) => x.label),
    overlaid_rise: riseOf(u, overlaid),
    other_rise: riseOf(o.groups[1].plot, 1),
    loaded: !!(s.overlay && s.overlay.columns),
    shift: s.overlay && s.overlay.shift,
    hold_starts: [s.holds[0].start_s, o.holds[0].start_s],
    overlaid_mid_hold: nearest === null ? null : u.data[overlaid][nearest],
    other_hold_mean: o.holds[0].values.find((v) => v.quantity === 'tip_force').mean,
  };
})())"#;

#[test]
fn demo_view_in_chromium_plots_live_shades_holds_and_matches_extract() {
    let out = tempfile::tempdir().unwrap();
    let out_dir = out.path().join("demo");
    let mut demo = Running::start(&["demo", "--out", path_arg(&out_dir), "--view", "127.0.0.1:0"]);
    let url = url_in(&demo.wait_for("watch the replay live", Duration::from_secs(60)));
    let addr = host_of(&url);
    let mut page = LivePage::open(&url, Duration::from_secs(240)).expect("the page opens");
    let shots = artefacts();

    let mut first_last_x: Option<Value> = None;
    let mut moved = false;
    let mut silent_seen: Vec<String> = Vec::new();
    let mut shot_live = false;
    let mut zoomed = None;
    let mut changed_bytes_seen = 0;
    let started = Instant::now();
    while !demo.has_said("the page stays up") {
        assert!(
            started.elapsed() < Duration::from_secs(200),
            "the demo did not finish; stderr:\n{}",
            demo.seen.join("\n")
        );
        let seen: Value =
            serde_json::from_str(page.evaluate(WATCH_JS).unwrap().as_str().unwrap()).unwrap();
        let last_x = seen["lastX"].clone();
        changed_bytes_seen = changed_bytes_seen.max(seen["changedBytes"].as_u64().unwrap());
        match &first_last_x {
            None if last_x
                .as_array()
                .is_some_and(|a| a.iter().all(Value::is_number)) =>
            {
                first_last_x = Some(last_x.clone())
            }
            Some(first) => {
                let advanced = |k: usize| {
                    last_x[k].as_f64().unwrap_or(0.0) > first[k].as_f64().unwrap_or(0.0) + 1.0
                };
                moved |= (0..3).all(advanced);
            }
            None => {}
        }
        if !shot_live && started.elapsed() > Duration::from_secs(8) {
            page.screenshot(&shots.join("demo-live.png")).unwrap();
            shot_live = true;
            zoomed = Some(pause_and_zoom(&mut page, &addr));
        }
        if silent_seen.is_empty() {
            if let Some(rows) = seen["silent"].as_array().filter(|r| !r.is_empty()) {
                silent_seen = rows.iter().map(|r| r.to_string()).collect();
                page.screenshot(&shots.join("demo-silent.png")).unwrap();
            }
        }
        std::thread::sleep(Duration::from_millis(250));
    }
    page.screenshot(&shots.join("demo-done.png")).unwrap();
    let seen: Value =
        serde_json::from_str(page.evaluate(WATCH_JS).unwrap().as_str().unwrap()).unwrap();
    assert_eq!(
        page.console_errors(),
        &[] as &[String],
        "the page logged errors"
    );
    assert_eq!(seen["errors"], Value::Array(vec![]));
    // Every signal with data in view gives its value in the legend (the
    // newest, with the cursor off the chart), no two signals of a chart
    // share a colour (18 gauges in one), and the force-displacement plot
    // has ticks on both axes.
    assert_eq!(seen["legendBlank"], Value::Array(vec![]), "legend values");
    assert_eq!(seen["sharedColours"], Value::Array(vec![]), "colours");
    let ticks = seen["xyTicks"]
        .as_array()
        .unwrap()
        .iter()
        .find(|t| !t.is_null())
        .expect("the tensile session's XY plot was drawn");
    for axis in ["x", "y"] {
        assert!(ticks[axis].as_array().unwrap().len() >= 3, "{ticks}");
    }
    assert!(
        moved,
        "the plots' last points did not move: {first_last_x:?} -> {}",
        seen["lastX"]
    );
    let (range, frames_then) = zoomed.expect("the page was zoomed");
    let still: Value = serde_json::from_str(
        page.evaluate("JSON.stringify(window.acqView.sessions[0].range)")
            .unwrap()
            .as_str()
            .unwrap(),
    )
    .unwrap();
    assert_eq!(
        still, range,
        "a paused, zoomed chart stays where the user put it"
    );
    let frames_now = frames_of(&addr);
    assert!(
        frames_now > frames_then,
        "the recording went on while the page was paused: {frames_then} -> {frames_now}"
    );
    assert!(
        silent_seen.iter().any(|r| r.contains("SILENT")),
        "no sensor was shown SILENT when its session's replay stopped"
    );

    // The live holds against acq extract on the recorded sessions (what the
    // demo wrote with the library's extract, the same as `acq extract`).
    let (status, _, body) = http(&addr, "GET", "/api/state", None);
    assert_eq!(status, 200);
    let state: Value = serde_json::from_str(&body).unwrap();
    // Once the replay has ended, each session says how it ended, its
    // buses are recorded ones, and no sensor is called silent for the bus
    // going quiet (only one that stopped before the others, as acq view
    // has it); the tensile pull is a curve, not a hold.
    for session in state["sessions"].as_array().unwrap() {
        assert!(session["ended"].is_string(), "{session}");
        assert_eq!(session["live"], false, "{session}");
    }
    for bus in state["buses"].as_array().unwrap() {
        assert_eq!(bus["state"], "recorded", "{bus}");
    }
    for sensor in state["sensors"].as_array().unwrap() {
        assert!(
            sensor["silent"] == false || sensor["silence_reason"] != "heartbeat lost",
            "{sensor}"
        );
    }
    // The raw frames beside the signals: every frame of a session is in
    // its trace's counts, every sensor's id is in it with the sensor's
    // name, and the page lists one row per id (bytes changing while live).
    assert!(
        changed_bytes_seen > 0,
        "no payload byte was shown changing live"
    );
    let (status, _, body) = http(&addr, "GET", "/api/frames", None);
    assert_eq!(status, 200);
    let traced: Value = serde_json::from_str(&body).unwrap();
    for (k, session) in state["sessions"].as_array().unwrap().iter().enumerate() {
        let name = &session["name"];
        assert_eq!(session["frames_not_shown"], 0, "{session}");
        let rows: Vec<&Value> = traced["frames"]
            .as_array()
            .unwrap()
            .iter()
            .filter(|f| &f["session"] == name)
            .collect();
        let traced: u64 = rows.iter().map(|f| f["count"].as_u64().unwrap()).sum();
        let recorded: u64 = state["buses"]
            .as_array()
            .unwrap()
            .iter()
            .filter(|b| &b["session"] == name)
            .map(|b| b["frames"].as_u64().unwrap())
            .sum();
        assert_eq!(
            traced, recorded,
            "{name}: frames in the trace against the recording"
        );
        for sensor in state["sensors"]
            .as_array()
            .unwrap()
            .iter()
            .filter(|x| &x["session"] == name)
        {
            assert!(
                rows.iter()
                    .any(|f| f["signals"].as_array().unwrap().contains(&sensor["name"])),
                "{name}: {} is on no id of the trace",
                sensor["name"]
            );
        }
        assert_eq!(
            seen["frameRows"][k].as_u64(),
            Some(rows.len() as u64),
            "{name}: rows on the page"
        );
    }
    let tensile = state["sessions"]
        .as_array()
        .unwrap()
        .iter()
        .find(|s| s["name"] == "tensile_p91_20c")
        .unwrap();
    assert!(
        tensile["holds_note"]
            .as_str()
            .unwrap()
            .starts_with("a tensile test"),
        "{tensile}"
    );
    assert!(state["holds"]
        .as_array()
        .unwrap()
        .iter()
        .all(|h| h["session"] != "tensile_p91_20c"));
    let shown = seen["holds"].as_array().unwrap().clone();
    for name in ["excavator_case1", "excavator_case2"] {
        let live: Vec<&Value> = state["holds"]
            .as_array()
            .unwrap()
            .iter()
            .filter(|h| h["session"] == name)
            .collect();
        let measured = std::fs::read_to_string(out_dir.join(name).join("measured.csv")).unwrap();
        let rows: Vec<Vec<&str>> = measured
            .lines()
            .skip(1)
            .map(|l| l.split(',').collect())
            .collect();
        let windows: std::collections::BTreeSet<&str> = rows.iter().map(|r| r[0]).collect();
        assert_eq!(live.len(), windows.len(), "{name}: hold count");
        for hold in &live {
            let hold_name = hold["name"].as_str().unwrap();
            let row_of = |quantity: &str| {
                rows.iter()
                    .find(|r| r[0] == hold_name && r[3] == quantity)
                    .unwrap_or_else(|| panic!("{name}: no {hold_name} {quantity} in measured.csv"))
            };
            let first = row_of("tip_force");
            // The CSV keeps 9 decimals of a second.
            for (key, column) in [("start_s", 1), ("end_s", 2)] {
                let offline: f64 = first[column].parse().unwrap();
                let live_s = hold[key].as_f64().unwrap();
                assert!(
                    (live_s - offline).abs() < 1e-9,
                    "{name} {hold_name} {key}: live {live_s} offline {offline}"
                );
            }
            for value in hold["values"].as_array().unwrap() {
                let row = row_of(value["quantity"].as_str().unwrap());
                let offline: f64 = row[5].parse().unwrap();
                assert_eq!(
                    value["mean"].as_f64().unwrap(),
                    offline,
                    "{name} {hold_name} {}: live mean against acq extract",
                    value["quantity"]
                );
                assert_eq!(value["n"].as_u64().unwrap(), row[7].parse::<u64>().unwrap());
            }
            // Shaded within 1 s of the operator releasing the load.
            let started_unix_s = state["sessions"]
                .as_array()
                .unwrap()
                .iter()
                .find(|s| s["name"] == name)
                .unwrap()["started_unix_s"]
                .as_f64()
                .unwrap();
            let end_s = hold["end_s"].as_f64().unwrap();
            let mean = hold["values"]
                .as_array()
                .unwrap()
                .iter()
                .find(|v| v["quantity"] == "tip_force")
                .unwrap()["mean"]
                .as_f64()
                .unwrap();
            let release = release_s(
                &out_dir.join("sessions").join(name),
                "tip_force",
                end_s,
                mean,
            );
            let drawn = shown
                .iter()
                .find(|h| h["session"] == name && h["end_s"].as_f64() == Some(end_s))
                .unwrap_or_else(|| panic!("{name}: {hold_name} never shaded on the page"));
            let drawn_s = drawn["shown_ms"].as_f64().unwrap() / 1e3 - started_unix_s;
            eprintln!(
                "{name} {hold_name}: window ends {end_s:.3} s, load released {release:.3} s, shaded {drawn_s:.3} s"
            );
            assert!(
                drawn_s - release <= 1.0,
                "{name} {hold_name}: shaded {:.3} s after the load was released",
                drawn_s - release
            );
        }
    }
    page.close();
    assert_eq!(demo.interrupt(), 0, "Ctrl-C ends the demo's page cleanly");

    // The recorder's feed left each session's index: `acq view` opens it
    // without reading the recording, and it is the page the recording gives.
    for name in ["excavator_case1", "excavator_case2", "tensile_p91_20c"] {
        let dir = out_dir.join("sessions").join(name);
        let (indexed, source) = acq_view::open_session(&dir, name).unwrap();
        assert_eq!(source, acq_view::Source::Index, "{name}");
        std::fs::remove_file(dir.join(acq_view::index::FILE)).unwrap();
        let (read, source) = acq_view::open_session(&dir, name).unwrap();
        assert_eq!(source, acq_view::Source::Recording(Ok(())));
        assert_eq!(
            look(&indexed),
            look(&read),
            "{name}: the recorder's index against the recording"
        );
    }
}

/// The page while a recording is live, when acq stops serving (killed,
/// as a crash would): a banner says the connection is lost and what that
/// means, and the header says it too.
#[test]
fn a_lost_connection_is_said_in_a_banner() {
    let out = tempfile::tempdir().unwrap();
    let out_dir = out.path().join("demo");
    let mut demo = Running::start(&["demo", "--out", path_arg(&out_dir), "--view", "127.0.0.1:0"]);
    let url = url_in(&demo.wait_for("watch the replay live", Duration::from_secs(60)));
    let mut page = LivePage::open(&url, Duration::from_secs(60)).expect("the page opens");
    let state = |page: &mut LivePage| -> Value {
        let js = "JSON.stringify({ updates: window.acqView.updates, \
                  banner: document.getElementById('banner').hidden ? null : document.getElementById('banner').textContent, \
                  header: document.getElementById('connection').className })";
        serde_json::from_str(page.evaluate(js).unwrap().as_str().unwrap()).unwrap()
    };
    let deadline = Instant::now() + Duration::from_secs(60);
    while state(&mut page)["updates"].as_u64().unwrap_or(0) == 0 {
        assert!(Instant::now() < deadline, "no live update reached the page");
        std::thread::sleep(Duration::from_millis(200));
    }
    assert_eq!(
        state(&mut page)["banner"],
        Value::Null,
        "a banner while live"
    );
    drop(demo);
    let deadline = Instant::now() + Duration::from_secs(30);
    let lost = loop {
        let now = state(&mut page);
        if now["banner"].is_string() {
            break now;
        }
        assert!(
            Instant::now() < deadline,
            "no banner after acq stopped: {now}"
        );
        std::thread::sleep(Duration::from_millis(200));
    };
    assert!(
        lost["banner"]
            .as_str()
            .unwrap()
            .starts_with("Connection to acq lost"),
        "{lost}"
    );
    assert_eq!(lost["header"], "down", "{lost}");
    page.screenshot(&artefacts().join("connection-lost.png"))
        .unwrap();
}

/// Everything the page reads of a session.
fn look(view: &acq_view::model::SessionView) -> (String, String, String, String, String, String) {
    (
        view.series_json(0.0, 30.0, 700),
        serde_json::to_string(&view.holds_json(None)).unwrap(),
        serde_json::to_string(&view.sensors_json(None)).unwrap(),
        serde_json::to_string(&view.buses_json(None)).unwrap(),
        view.xy_json().to_string(),
        serde_json::to_string(&view.frames_json(None)).unwrap(),
    )
}

/// Frames recorded so far on the page's first bus.
fn frames_of(addr: &str) -> u64 {
    let (_, _, body) = http(addr, "GET", "/api/state", None);
    let state: Value = serde_json::from_str(&body).unwrap();
    state["buses"][0]["frames"].as_u64().unwrap()
}

/// Pauses the first session and drags across the middle third of its first
/// chart: the session stops following and shows the span dragged over, read
/// again from the server. Its range and the frames recorded at that moment.
fn pause_and_zoom(page: &mut LivePage, addr: &str) -> (Value, u64) {
    page.evaluate("document.querySelector('section[data-session=\"0\"] .controls button').click()")
        .unwrap();
    let box_of: Value = serde_json::from_str(
        page.evaluate(
            "JSON.stringify((() => { const r = document.querySelector('section[data-session=\"0\"] .u-over').getBoundingClientRect(); \
             return [r.left, r.top, r.width, r.height]; })())",
        )
        .unwrap()
        .as_str()
        .unwrap(),
    )
    .unwrap();
    let [left, top, width, height] = [0, 1, 2, 3].map(|k| box_of[k].as_f64().unwrap());
    let y = top + height / 2.0;
    page.drag((left + width / 3.0, y), (left + 2.0 * width / 3.0, y))
        .unwrap();
    std::thread::sleep(Duration::from_millis(600));
    let after: Value = serde_json::from_str(
        page.evaluate(
            "JSON.stringify({follow: window.acqView.sessions[0].follow, range: window.acqView.sessions[0].range, \
             mode: document.querySelector('section[data-session=\"0\"] .mode').textContent, \
             zoomed: window.acqView.sessions[0].zoomColumns !== null})",
        )
        .unwrap()
        .as_str()
        .unwrap(),
    )
    .unwrap();
    assert_eq!(after["follow"], false, "{after}");
    assert_eq!(after["zoomed"], true, "the span was read again: {after}");
    assert!(
        after["mode"].as_str().unwrap().contains("paused"),
        "{after}"
    );
    let range = after["range"].as_array().unwrap();
    let span = range[1].as_f64().unwrap() - range[0].as_f64().unwrap();
    // A third of the 60 s window the chart showed.
    assert!((15.0..25.0).contains(&span), "zoomed to {span} s: {after}");
    (after["range"].clone(), frames_of(addr))
}

/// A copy of the shipped tensile session whose rig names a sensor with
/// markup and a style end tag (a rig refuses quotes in sensor names: they
/// are CSV columns), in a directory whose name has markup and quotes.
fn hostile_session(parent: &Path) -> (PathBuf, &'static str) {
    const HOSTILE: &str = "<script>alert(1)</script></style><b>&amp;";
    let dir = copy_session(
        "tensile_p91_20c",
        &parent.join("<img src=x onerror=alert(2)>\"'"),
    );
    for entry in std::fs::read_dir(dir.join("rig")).unwrap() {
        let path = entry.unwrap().path();
        let text = std::fs::read_to_string(&path).unwrap();
        let text = text.replace("name = \"load\"", &format!("name = \"load{HOSTILE}\""));
        std::fs::write(&path, text).unwrap();
    }
    (dir, HOSTILE)
}

#[test]
fn the_page_only_reads_escapes_names_and_keeps_strangers_out() {
    let temp = tempfile::tempdir().unwrap();
    let (session, hostile) = hostile_session(temp.path());

    // Another machine's address without the flag: refused before anything.
    let output = common::acq(&["view", path_arg(&session), "--view", "0.0.0.0:0"]);
    assert_eq!(output.status.code(), Some(2), "{}", common::stderr(&output));
    assert!(common::stderr(&output).contains("--view-remote"));

    // Loopback: no token, but only for the address served.
    let mut local = Running::start(&["view", path_arg(&session), "--view", "127.0.0.1:0"]);
    let url = url_in(&local.wait_for("view at", Duration::from_secs(30)));
    let addr = host_of(&url);
    let (status, head, page) = http(&addr, "GET", "/", None);
    assert_eq!(status, 200);
    let csp = head
        .lines()
        .find(|l| {
            l.to_ascii_lowercase()
                .starts_with("content-security-policy")
        })
        .expect("a CSP header");
    assert!(
        csp.contains("script-src 'self'") && !csp.contains("unsafe-inline"),
        "{csp}"
    );
    assert!(
        !page.contains("<script>alert") && !page.contains("<img src=x"),
        "{page}"
    );
    assert!(
        page.contains("&lt;img src=x onerror=alert(2)&gt;&quot;&#39;"),
        "{page}"
    );
    let (status, _, state) = http(&addr, "GET", "/api/state", None);
    assert_eq!(status, 200);
    let state: Value = serde_json::from_str(&state).unwrap();
    assert_eq!(state["sensors"][0]["name"], format!("load{hostile}"));
    assert_eq!(
        http(&addr, "POST", "/api/state", None).0,
        405,
        "the API only reads"
    );
    assert_eq!(http(&addr, "DELETE", "/", None).0, 405);
    assert_eq!(
        http(&addr, "GET", "/api/state", Some("attacker.example:80")).0,
        403,
        "a page elsewhere (DNS rebinding) is refused"
    );
    // An absolute-form request line (a proxy's) is refused even with the
    // right Host header.
    let absolute = format!("http://{addr}/api/state");
    let (status, _, body) = http(&addr, "GET", &absolute, None);
    assert_eq!(status, 400, "{body}");
    assert!(body.contains("no proxy"), "{body}");
    // Clients that never finish their headers are closed once the header
    // timeout has passed, and the page still answers meanwhile.
    let slow: Vec<TcpStream> = (0..30)
        .map(|_| {
            let mut stream = TcpStream::connect(&addr).unwrap();
            write!(stream, "GET / HTTP/1.1\r\nHost: {addr}\r\nX-Slow: ").unwrap();
            stream
        })
        .collect();
    assert_eq!(http(&addr, "GET", "/api/state", None).0, 200);
    std::thread::sleep(acq_view::server::HEADER_READ_TIMEOUT + Duration::from_secs(2));
    for mut stream in slow {
        stream
            .set_read_timeout(Some(Duration::from_secs(5)))
            .unwrap();
        let mut answer = Vec::new();
        let read = stream.read_to_end(&mut answer);
        assert!(
            read.is_ok()
                || read
                    .as_ref()
                    .is_err_and(|e| e.kind() == std::io::ErrorKind::ConnectionReset),
            "a slow client is still held after the header timeout: {read:?}"
        );
    }

    // In Chromium the names are text: no script of theirs runs, nothing is
    // refused by the policy, and the name reads as it is.
    let mut page = LivePage::open(&url, Duration::from_secs(60)).unwrap();
    std::thread::sleep(Duration::from_millis(800));
    let shown = page
        .evaluate(
            "JSON.stringify({cells: Array.from(document.querySelectorAll('table.sensors td')).map((c) => c.textContent), \
             scripts: document.scripts.length, images: document.images.length, title: document.title})",
        )
        .unwrap();
    let shown: Value = serde_json::from_str(shown.as_str().unwrap()).unwrap();
    page.screenshot(&artefacts().join("hostile-names.png"))
        .unwrap();
    assert_eq!(page.console_errors(), &[] as &[String]);
    assert!(
        shown["cells"]
            .as_array()
            .unwrap()
            .iter()
            .any(|c| c.as_str() == Some(&format!("load{hostile}"))),
        "{shown}"
    );
    assert_eq!(shown["scripts"], 2, "only the page's own two scripts");
    assert_eq!(shown["images"], 0);
    page.close();
    assert_eq!(local.interrupt(), 0);

    // Another address with the flag: every request needs the token.
    let mut remote = Running::start(&[
        "view",
        path_arg(&session),
        "--view",
        "0.0.0.0:0",
        "--view-remote",
    ]);
    let url = url_in(&remote.wait_for("view at", Duration::from_secs(30)));
    let token = url
        .split("token=")
        .nth(1)
        .expect("a token in the URL")
        .to_string();
    assert_eq!(token.len(), 32);
    let port = host_of(&url).rsplit(':').next().unwrap().to_string();
    let addr = format!("127.0.0.1:{port}");
    assert_eq!(http(&addr, "GET", "/api/state", None).0, 401);
    assert_eq!(
        http(
            &addr,
            "GET",
            "/api/state?token=0123456789abcdef0123456789abcdef",
            None
        )
        .0,
        401
    );
    assert_eq!(http(&addr, "GET", "/app.js", None).0, 401);
    assert_eq!(
        http(&addr, "GET", &format!("/api/state?token={token}"), None).0,
        200
    );
    assert_eq!(
        http(&addr, "POST", &format!("/api/state?token={token}"), None).0,
        405
    );
    assert_eq!(remote.interrupt(), 0);
}

#[test]
fn a_session_opens_again_from_its_index_and_a_damaged_index_is_rebuilt() {
    let temp = tempfile::tempdir().unwrap();
    let dir = copy_session("excavator_case1", &temp.path().join("case1"));
    let (first, source) = acq_view::open_session(&dir, "case1").unwrap();
    assert_eq!(source, acq_view::Source::Recording(Ok(())));
    let (again, source) = acq_view::open_session(&dir, "case1").unwrap();
    assert_eq!(source, acq_view::Source::Index);
    assert_eq!(look(&again), look(&first), "the index gives the same page");
    assert_eq!(first.holds.len(), 1);

    // Damaged in every way a cut or a stray write can: read from the recording again.
    let index = dir.join(acq_view::index::FILE);
    let bytes = std::fs::read(&index).unwrap();
    for damaged in [
        bytes[..bytes.len() - 3].to_vec(),
        bytes[..40].to_vec(),
        [bytes.clone(), vec![0]].concat(),
        b"not an index".to_vec(),
    ] {
        std::fs::write(&index, &damaged).unwrap();
        let (view, source) = acq_view::open_session(&dir, "case1").unwrap();
        assert_eq!(source, acq_view::Source::Recording(Ok(())));
        assert_eq!(look(&view), look(&first));
    }
    // A recording that grew (another raw file size): not the index's.
    let raw = dir.join("raw.log");
    let mut log = std::fs::read(&raw).unwrap();
    let last_line = log[..log.len() - 1]
        .iter()
        .rposition(|&b| b == b'\n')
        .unwrap();
    log.truncate(last_line + 1);
    std::fs::write(&raw, &log).unwrap();
    let (_, source) = acq_view::open_session(&dir, "case1").unwrap();
    assert_eq!(source, acq_view::Source::Recording(Ok(())));
    // A FIFO at the index's name (careless input, round four): never
    // waited on, neither read nor written; the page opens from the
    // recording and says why no index was kept.
    std::fs::remove_file(&index).unwrap();
    let made = std::process::Command::new("mkfifo")
        .arg(&index)
        .status()
        .unwrap();
    assert!(made.success());
    let (view, source) = acq_view::open_session(&dir, "case1").unwrap();
    assert_eq!(view.holds.len(), 1);
    match source {
        acq_view::Source::Recording(Err(why)) => {
            assert!(why.contains("not a regular file"), "{why}")
        }
        other => panic!("{other:?}"),
    }
    assert!(std::fs::symlink_metadata(&index)
        .unwrap()
        .file_type()
        .is_fifo());
}

/// Ctrl-C the moment the page says where it is stops it cleanly: acq
/// listens for the signal before it says so, never after (a signal in
/// between would kill it with no exit code, the page half stopped).
#[test]
fn ctrl_c_as_soon_as_the_page_is_announced_stops_it_cleanly() {
    let temp = tempfile::tempdir().unwrap();
    let session = copy_session("excavator_case1", &temp.path().join("case1"));
    for attempt in 0..12 {
        let mut page = Running::start(&["view", path_arg(&session), "--view", "127.0.0.1:0"]);
        page.wait_for("view at", Duration::from_secs(30));
        assert_eq!(page.interrupt(), 0, "attempt {attempt}");
    }
}

#[test]
fn view_arguments_that_cannot_work_are_refused_with_the_fix() {
    let temp = tempfile::tempdir().unwrap();
    let refused = |args: &[&str], code: i32, says: &str| {
        let output = common::acq(args);
        assert_eq!(
            output.status.code(),
            Some(code),
            "{args:?}: {}",
            common::stderr(&output)
        );
        assert!(
            common::stderr(&output).contains(says),
            "{args:?}: {}",
            common::stderr(&output)
        );
    };
    // No rig: nothing to show (refused before any interface is opened).
    refused(
        &["record", "--iface", "vcan0", "--view"],
        2,
        "--view needs --rig",
    );
    refused(
        &["view", path_arg(temp.path())],
        2,
        "not a session directory",
    );
    refused(
        &[
            "view",
            "fixtures/sessions/tensile_p91_20c",
            "--view",
            "nonsense",
        ],
        2,
        "expected HOST:PORT",
    );
    // A port another program holds.
    let holder = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let taken = holder.local_addr().unwrap().to_string();
    let session = copy_session("tensile_p91_20c", &temp.path().join("tensile"));
    refused(
        &["view", path_arg(&session), "--view", &taken],
        1,
        "give another port",
    );
}

/// The page's plots as the user sets them out: a layout file puts chosen
/// signals of different kinds in one plot, a signal added on the page
/// appears in its plot, "Save layout" gives a file that sets out the same
/// page when loaded again, and "Export CSV" gives the window in view. A
/// layout naming a signal no session has is refused before serving.
#[test]
fn a_layout_sets_the_plots_and_the_page_saves_it_again() {
    let temp = tempfile::tempdir().unwrap();
    let session = copy_session("excavator_case1", &temp.path().join("case1"));
    let other = copy_session("excavator_case2", &temp.path().join("case2"));
    let layout = temp.path().join("layout.json");
    std::fs::write(
        &layout,
        r#"{"format": 1, "plots": [
            {"title": "boom, hydraulics and steel", "signals": ["boom_head_pressure", "sg09"]},
            {"title": "load", "signals": ["tip_force"]},
            {"title": "boom pressure against tip force", "xy": ["tip_force", "boom_head_pressure"]}]}"#,
    )
    .unwrap();
    let plots_js = "JSON.stringify(window.acqView.sessions.length ? window.acqView.sessions[0].groups.map((g) => [g.group, g.plot.series.slice(1).map((x) => x.label)]).concat(window.acqView.sessions[0].xyPlots.map((p) => [p.title, [window.acqView.sessions[0].sensors[p.x].name, window.acqView.sessions[0].sensors[p.y].name]])) : null)";
    let open = |layout: &Path| {
        let mut view = Running::start(&[
            "view",
            path_arg(&session),
            path_arg(&other),
            "--view",
            "127.0.0.1:0",
            "--layout",
            path_arg(layout),
        ]);
        let url = url_in(&view.wait_for("view at", Duration::from_secs(60)));
        let mut page = LivePage::open(&url, Duration::from_secs(60)).expect("the page opens");
        let started = Instant::now();
        let plots = loop {
            let plots: Value =
                serde_json::from_str(page.evaluate(plots_js).unwrap().as_str().unwrap()).unwrap();
            if !plots.is_null() {
                break plots;
            }
            assert!(
                started.elapsed() < Duration::from_secs(30),
                "the page never built its plots"
            );
            std::thread::sleep(Duration::from_millis(100));
        };
        (view, page, plots)
    };
    let (view, mut page, plots) = open(&layout);
    assert_eq!(
        plots,
        serde_json::json!([
            ["boom, hydraulics and steel", ["boom_head_pressure", "sg09"]],
            ["load", ["tip_force"]],
            [
                "boom pressure against tip force",
                ["tip_force", "boom_head_pressure"]
            ]
        ])
    );
    // The XY plot: a point per time column both signals have, with ticks
    // on both axes, reaching the hold's 40.6 kN.
    let started = Instant::now();
    let xy = loop {
        let xy: Value = serde_json::from_str(
            page.evaluate("JSON.stringify(window.acqView.sessions[0].xyPlots.map((p) => ({ points: p.points, ticks: p.ticks })))")
                .unwrap()
                .as_str()
                .unwrap(),
        )
        .unwrap();
        if xy[0]["points"].as_u64().unwrap_or(0) > 0 || started.elapsed() > Duration::from_secs(20)
        {
            break xy;
        }
        std::thread::sleep(Duration::from_millis(100));
    };
    assert!(xy[0]["points"].as_u64().unwrap() > 100, "{xy}");
    let x_ticks = xy[0]["ticks"]["x"].as_array().unwrap();
    assert!(
        x_ticks.len() >= 3 && xy[0]["ticks"]["y"].as_array().unwrap().len() >= 3,
        "{xy}"
    );
    assert!(x_ticks.last().unwrap().as_f64().unwrap() >= 40.0, "{xy}");
    // A signal added through the plot's own "add a signal" list.
    page.evaluate(
        "(() => { const g = window.acqView.sessions[0].groups[1]; const k = window.acqView.sessions[0].sensors.findIndex((x) => x.name === 'arm_inclination'); g.add.value = String(k); g.add.dispatchEvent(new Event('change')); })()",
    )
    .unwrap();
    let plots: Value =
        serde_json::from_str(page.evaluate(plots_js).unwrap().as_str().unwrap()).unwrap();
    assert_eq!(
        plots[1],
        serde_json::json!(["load", ["tip_force", "arm_inclination"]])
    );
    // A click on a plot places cursor A where it was clicked; A and B read
    // out each signal and their difference: the tip force while idle (0.5 s,
    // about 0) and in the hold (7 s, 40.6 kN in this case).
    let rect: Value = serde_json::from_str(
        page.evaluate("JSON.stringify(window.acqView.sessions[0].groups[1].plot.over.getBoundingClientRect())")
            .unwrap()
            .as_str()
            .unwrap(),
    )
    .unwrap();
    let at = (
        rect["x"].as_f64().unwrap() + 0.5 * rect["width"].as_f64().unwrap(),
        rect["y"].as_f64().unwrap() + 0.5 * rect["height"].as_f64().unwrap(),
    );
    let plot_top = |page: &mut LivePage| {
        page.evaluate("window.acqView.sessions[0].groups[0].plot.over.getBoundingClientRect().y")
            .unwrap()
            .as_f64()
            .unwrap()
    };
    let top_before = plot_top(&mut page);
    page.drag(at, at).unwrap();
    let placed: Value = serde_json::from_str(
        page.evaluate("JSON.stringify(window.acqView.sessions[0].cursors)")
            .unwrap()
            .as_str()
            .unwrap(),
    )
    .unwrap();
    assert_eq!(
        placed.as_array().map(Vec::len),
        Some(1),
        "a click places A: {placed}"
    );
    page.evaluate("window.acqView.setCursors(0, [0.5, 7.0])")
        .unwrap();
    // The cursors' table's row of a signal: name, unit, A (, B, B - A).
    let cursor_row = |page: &mut LivePage, signal: &str| -> Value {
        let rows: Value = serde_json::from_str(
            page.evaluate("JSON.stringify(Array.from(document.querySelectorAll('section[data-session=\"0\"] table.cursor-values tr')).map((r) => Array.from(r.children).map((c) => c.textContent)))")
                .unwrap()
                .as_str()
                .unwrap(),
        )
        .unwrap();
        rows.as_array()
            .unwrap()
            .iter()
            .find(|r| r[0] == signal)
            .cloned()
            .unwrap_or_else(|| panic!("{rows}"))
    };
    let force = cursor_row(&mut page, "tip_force");
    let number = |v: &Value| v.as_str().unwrap().parse::<f64>().unwrap();
    let (a, b, difference) = (number(&force[2]), number(&force[3]), number(&force[4]));
    assert!(a.abs() < 1.0 && (b - 40.6).abs() < 1.0, "{force}");
    assert!((difference - (b - a)).abs() < 2e-3, "{force}");
    // The values' table is below the plots: placing A and B moves no plot
    // (above them, it pushed them down and a second click missed).
    assert_eq!(plot_top(&mut page), top_before, "the plots stay put");
    // A double click resets the plot's y span and places no cursor.
    page.evaluate("window.acqView.setY(0, 1, [1, 2])").unwrap();
    let after_double_click = page
        .evaluate(
            "(() => { const g = window.acqView.sessions[0].groups[1]; const r = g.plot.over.getBoundingClientRect(); \
             const at = { clientX: r.x + r.width / 4, clientY: r.y + r.height / 2, bubbles: true }; \
             for (const [kind, detail] of [['click', 1], ['click', 2], ['dblclick', 2]]) g.plot.over.dispatchEvent(new MouseEvent(kind, { ...at, detail })); \
             return JSON.stringify([window.acqView.sessions[0].cursors, g.y]); })()",
        )
        .unwrap();
    assert_eq!(
        after_double_click.as_str().unwrap(),
        "[[0.5,7],null]",
        "cursors as before, y following the data again"
    );
    // A plot's PNG is on white, with its title and legend below the plot.
    let png = page
        .evaluate(
            "(async () => { const img = new Image(); img.src = window.acqView.plotPng(0, 1); await img.decode(); \
             const c = document.createElement('canvas'); c.width = img.width; c.height = img.height; \
             const x = c.getContext('2d', { willReadFrequently: true }); x.drawImage(img, 0, 0); \
             return JSON.stringify([img.height - window.acqView.sessions[0].groups[1].plot.ctx.canvas.height, \
               Array.from(x.getImageData(1, 1, 1, 1).data), Array.from(x.getImageData(1, img.height - 2, 1, 1).data)]); })()",
        )
        .unwrap();
    let png: Value = serde_json::from_str(png.as_str().unwrap()).unwrap();
    assert!(
        png[0].as_f64().unwrap() > 40.0,
        "room for the title and legend: {png}"
    );
    assert_eq!(
        png[1],
        serde_json::json!([255, 255, 255, 255]),
        "opaque white: {png}"
    );
    assert_eq!(
        png[2],
        serde_json::json!([255, 255, 255, 255]),
        "opaque white: {png}"
    );
    // Zoomed in to a fifth of a second, the 10 Hz inclination still reads
    // at a cursor between its samples (the page's columns are far
    // narrower than its period there).
    // The range's promise settles once its data is drawn: a y span or a
    // cursor set next works on it, not on the range before.
    let drawn_span = page
        .evaluate("window.acqView.showRange(0, [7.0, 7.2]).then(() => { const xs = window.acqView.sessions[0].groups[0].plot.data[0]; return JSON.stringify([xs[0], xs[xs.length - 1]]); })")
        .unwrap();
    let drawn_span: Vec<f64> = serde_json::from_str(drawn_span.as_str().unwrap()).unwrap();
    assert!(
        drawn_span[0] > 6.9 && drawn_span[1] < 7.3,
        "the zoomed data is drawn when the range's promise settles: {drawn_span:?}"
    );
    page.evaluate("window.acqView.setCursors(0, [7.13])")
        .unwrap();
    let inclination = cursor_row(&mut page, "arm_inclination");
    let degrees = number(&inclination[2]);
    assert!((-50.0..50.0).contains(&degrees), "{inclination}");
    page.evaluate("window.acqView.showWhole(0)").unwrap();
    // A y span chosen on a plot holds through redraws until cleared.
    let y_of = |page: &mut LivePage| -> Vec<f64> {
        serde_json::from_str::<Vec<f64>>(
            page.evaluate("JSON.stringify([window.acqView.sessions[0].groups[0].plot.scales.y.min, window.acqView.sessions[0].groups[0].plot.scales.y.max])")
                .unwrap()
                .as_str()
                .unwrap(),
        )
        .unwrap()
    };
    page.evaluate("window.acqView.setY(0, 0, [60, 80])")
        .unwrap();
    page.evaluate("window.acqView.setCursors(0, [0.5, 7.0])")
        .unwrap();
    assert_eq!(y_of(&mut page), vec![60.0, 80.0]);
    // Shift + wheel pans it: down a tenth of its span per notch up.
    page.evaluate("window.acqView.sessions[0].groups[0].plot.over.dispatchEvent(new WheelEvent('wheel', { deltaY: -100, shiftKey: true, bubbles: true, cancelable: true }))")
        .unwrap();
    assert_eq!(y_of(&mut page), vec![62.0, 82.0]);
    page.evaluate("window.acqView.setY(0, 0, null)").unwrap();
    let auto = y_of(&mut page);
    assert!(
        auto[0] < 10.0 && auto[1] > 100.0,
        "back to the data's span: {auto:?}"
    );
    page.screenshot(&artefacts().join("layout-cursors-xy.png"))
        .unwrap();
    let csv = page.evaluate("window.acqView.exportCsv(0)").unwrap();
    let csv = csv.as_str().unwrap();
    let mut lines = csv.lines();
    assert_eq!(
        lines.next().unwrap(),
        "time_s,boom_head_pressure_min [bar],boom_head_pressure_max [bar],sg09_min [MPa],sg09_max [MPa],tip_force_min [kN],tip_force_max [kN],arm_inclination_min [deg],arm_inclination_max [deg]"
    );
    let rows: Vec<Vec<f64>> = lines
        .map(|l| {
            l.split(',')
                .map(|c| c.parse().unwrap_or(f64::NAN))
                .collect()
        })
        .collect();
    assert!(rows.len() > 100, "{} rows", rows.len());
    assert!(rows.windows(2).all(|w| w[0][0] < w[1][0]), "time rises");
    // Every signal has a value in every row from its first sample on (a
    // 10 Hz inclination too, between its samples): the recording has no
    // gap.
    for column in 1..rows[0].len() {
        let first = rows.iter().position(|r| r[column].is_finite());
        let first = first.unwrap_or_else(|| panic!("column {column} is empty"));
        let empty = rows[first..]
            .iter()
            .filter(|r| !r[column].is_finite())
            .count();
        assert_eq!(
            empty, 0,
            "column {column}: {empty} empty cells after the first value"
        );
    }
    // sg09 holds at 103 MPa in its hold: the export carries the values.
    assert!(
        rows.iter().any(|r| (r[3] - 103.18).abs() < 1.0),
        "no sg09 hold value"
    );
    // Another session overlaid: case 2's signals of the same names, dashed
    // in case 1's plots, each at its time plus the shift.
    page.evaluate("window.acqView.setOverlay(0, 1, 2.5)")
        .unwrap();
    // Drawn at the browser's next animation frame: wait for it.
    let overlay_drawn = |page: &mut LivePage, done: &dyn Fn(&Value) -> bool| {
        let started = Instant::now();
        loop {
            let overlay: Value =
                serde_json::from_str(page.evaluate(OVERLAY_JS).unwrap().as_str().unwrap()).unwrap();
            if done(&overlay) {
                return overlay;
            }
            assert!(
                started.elapsed() < Duration::from_secs(20),
                "never drawn: {overlay}"
            );
            std::thread::sleep(Duration::from_millis(100));
        }
    };
    let overlay = overlay_drawn(&mut page, &|o| o["overlaid_rise"].is_number());
    assert!(
        overlay["labels"]
            .as_array()
            .unwrap()
            .contains(&Value::from("tip_force (case2, +2.500 s)")),
        "{overlay}"
    );
    let rise = |key: &str| {
        overlay[key]
            .as_f64()
            .unwrap_or_else(|| panic!("{key}: {overlay}"))
    };
    assert!(
        (rise("overlaid_rise") - rise("other_rise") - 2.5).abs() < 0.1,
        "case 2's load rises 2.5 s later on case 1's plot: {overlay}"
    );
    // "Align first holds" shifts case 2 by the difference of the first
    // holds' starts: in the middle of case 1's hold, case 2 is in its own
    // hold (its tip force within 2 % of that hold's mean).
    page.evaluate(
        "(() => { const section = document.querySelector('section[data-session=\"0\"]'); const pick = section.querySelector('select.overlay'); pick.value = '1'; pick.dispatchEvent(new Event('change')); Array.from(section.querySelectorAll('button')).find((b) => b.textContent === 'Align first holds').click(); })()",
    )
    .unwrap();
    let aligned = overlay_drawn(&mut page, &|o| {
        o["shift"] != 2.5 && o["overlaid_mid_hold"].is_number()
    });
    let expected =
        aligned["hold_starts"][0].as_f64().unwrap() - aligned["hold_starts"][1].as_f64().unwrap();
    assert!(
        (aligned["shift"].as_f64().unwrap() - expected).abs() < 1e-3,
        "{aligned}"
    );
    let (in_hold, mean) = (
        aligned["overlaid_mid_hold"].as_f64().unwrap(),
        aligned["other_hold_mean"].as_f64().unwrap(),
    );
    assert!((in_hold - mean).abs() < 0.02 * mean, "{aligned}");
    page.screenshot(&artefacts().join("overlay.png")).unwrap();
    page.evaluate("window.acqView.setOverlay(0, null, 0)")
        .unwrap();
    let saved = page.evaluate("window.acqView.layoutJson(0)").unwrap();
    // A layout loaded later replaces the plots, as --layout sets them at
    // start; what is no layout says so.
    let replaced = page
        .evaluate("window.acqView.applyLayout(0, { format: 1, plots: [{ title: 'just the force', signals: ['tip_force'] }] }); \
                   JSON.stringify([window.acqView.sessions[0].groups.map((g) => [g.group, g.members.length]), window.acqView.sessions[0].xyPlots.length])")
        .unwrap();
    assert_eq!(replaced.as_str().unwrap(), r#"[[["just the force",1]],0]"#);
    let refused = page
        .evaluate("window.acqView.applyLayout(0, { signals: [] }); document.getElementById('banner').textContent")
        .unwrap();
    assert!(
        refused.as_str().unwrap().contains("not a layout file"),
        "{refused}"
    );
    assert_eq!(page.console_errors(), &[] as &[String]);
    page.close();
    assert_eq!(view.interrupt(), 0);

    let again = temp.path().join("saved.json");
    std::fs::write(&again, saved.as_str().unwrap()).unwrap();
    let (view, page, reloaded) = open(&again);
    assert_eq!(reloaded, plots, "the saved layout sets out the same page");
    page.close();
    assert_eq!(view.interrupt(), 0);

    std::fs::write(
        &layout,
        r#"{"format": 1, "plots": [{"title": "x", "signals": ["sg99"]}]}"#,
    )
    .unwrap();
    let output = acq(&[
        "view",
        path_arg(&session),
        "--view",
        "127.0.0.1:0",
        "--layout",
        path_arg(&layout),
    ]);
    assert_eq!(output.status.code(), Some(2));
    assert!(
        stderr(&output).contains("no session has a signal \"sg99\""),
        "{}",
        stderr(&output)
    );
}
