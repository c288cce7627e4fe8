//! Renders an HTML file in a real headless Chromium and reports what a reader
//! would see go wrong: console errors/warnings (failed resource loads, uncaught
//! exceptions, `console.error`/`console.warn`) and whether the page's tables and
//! inline SVGs are actually rendered.
//!
//! Chromium is driven over the DevTools protocol on `--remote-debugging-pipe`
//! (NUL-terminated JSON on fds 3/4), not by scraping its stderr: with
//! `--enable-logging=stderr` every console message is logged as
//! `INFO:CONSOLE` whatever its level, and failed resource loads
//! ("Failed to load resource: net::ERR_FILE_NOT_FOUND") never reach stderr at
//! all. The protocol reports both, with levels. The page is loaded unmodified
//! from its own location (relative links resolve as they would for a user);
//! the measurement runs after the load event through `Runtime.evaluate` and
//! logs nothing.
#![allow(dead_code)]

use serde_json::{json, Value};
use std::io::{BufRead, BufReader, Read, Write};
use std::os::unix::process::CommandExt;
use std::path::{Path, PathBuf};
use std::process::{Child, ChildStdin, Command, Stdio};
use std::sync::mpsc::{self, Receiver, RecvTimeoutError};
use std::time::{Duration, Instant};

/// Upper bound for one whole check: start, load, measure.
const TIMEOUT: Duration = Duration::from_secs(60);

/// What the page looked like in Chromium.
#[derive(Debug, Clone)]
pub struct PageCheck {
    /// Console messages of level error or warning, one line each, e.g.
    /// `error [network] Failed to load resource: net::ERR_FILE_NOT_FOUND (file:///…/missing.png)`,
    /// `error [exception] Uncaught ReferenceError: undefinedFunction is not defined (file:///…:1:65)`,
    /// `warning [console] …`.
    pub console_errors: Vec<String>,
    pub title: String,
    /// Every `<table>` in document order (nested ones included).
    pub tables: Vec<TableCheck>,
    /// Outermost `<svg>` elements rendered with non-zero width and height.
    pub visible_svgs: usize,
}

#[derive(Debug, Clone, PartialEq, Eq)]
pub struct TableCheck {
    /// Non-zero bounding box, `display` not `none`, `visibility` not `hidden`/`collapse`.
    pub visible: bool,
    /// Rows in the table's own `<tbody>`s (the parser adds one around bare `<tr>`s).
    pub body_rows: usize,
    /// Whitespace-collapsed text of the table's first own `<th>`, or "".
    pub first_header: String,
}

/// Runs after the load event. Returns a JSON string; must not log anything.
const MEASURE_JS: &str = r#"(() => {
  const shown = (el) => {
    const r = el.getBoundingClientRect();
    const s = getComputedStyle(el);
    return r.width > 0 && r.height > 0 && s.display !== 'none'
      && s.visibility !== 'hidden' && s.visibility !== 'collapse';
  };
  const text = (el) => el ? el.textContent.replace(/\s+/g, ' ').trim() : '';
  const tables = Array.from(document.querySelectorAll('table')).map((t) => ({
    visible: shown(t),
    body_rows: Array.from(t.tBodies).reduce((n, b) => n + b.rows.length, 0),
    first_header: text(Array.from(t.querySelectorAll('th')).find((th) => th.closest('table') === t)),
  }));
  const svgs = Array.from(document.querySelectorAll('svg'))
    .filter((s) => !(s.parentElement && s.parentElement.closest('svg')));
  return JSON.stringify({
    title: document.title,
    tables,
    visible_svgs: svgs.filter(shown).length,
  });
})()"#;

/// Renders `html_path` in headless Chromium and measures it.
///
/// Err (with how to install it) if no Chromium is on PATH, or if Chromium
/// fails, or takes longer than 60 s (it is then killed).
pub fn check_page(html_path: &Path) -> Result<PageCheck, String> {
    let html = html_path
        .canonicalize()
        .map_err(|e| format!("{}: {e}", html_path.display()))?;
    let url = file_url(&html);
    let binary = find_chromium()?;
    let profile = tempfile::tempdir().map_err(|e| format!("temp dir: {e}"))?;
    let mut browser = Browser::launch(&binary, profile.path(), false)?;
    let result = browser.check(&url);
    browser.shut_down();
    result.map_err(|e| {
        format!(
            "checking {url} in {}: {e}{}",
            binary.display(),
            browser.stderr_tail()
        )
    })
}

/// The Chromium binary: `$ACQ_CHROMIUM`, else the first of the usual names on PATH.
pub fn find_chromium() -> Result<PathBuf, String> {
    if let Some(explicit) = std::env::var_os("ACQ_CHROMIUM") {
        return Ok(PathBuf::from(explicit));
    }
    const NAMES: [&str; 4] = [
        "chromium",
        "chromium-browser",
        "google-chrome",
        "google-chrome-stable",
    ];
    let path = std::env::var_os("PATH").unwrap_or_default();
    for name in NAMES {
        for dir in std::env::split_paths(&path) {
            let candidate = dir.join(name);
            if candidate.is_file() {
                return Ok(candidate);
            }
        }
    }
    Err(format!(
        "no Chromium on PATH (looked for {}; or set ACQ_CHROMIUM). The browser checks need a \
         real one: `apt-get install -y --no-install-recommends chromium` as root \
         (scripts/test does this)",
        NAMES.join(", ")
    ))
}

/// `file://` URL for an absolute path, percent-encoding anything unusual.
fn file_url(path: &Path) -> String {
    use std::os::unix::ffi::OsStrExt;
    let mut url = String::from("file://");
    for &b in path.as_os_str().as_bytes() {
        if b.is_ascii_alphanumeric() || b"/-._~".contains(&b) {
            url.push(b as char);
        } else {
            url.push_str(&format!("%{b:02X}"));
        }
    }
    url
}

/// What the events since navigation said about the page.
struct PageState<'a> {
    url: &'a str,
    console_errors: Vec<String>,
    /// The main frame committed to `url`...
    navigated: bool,
    /// ...and then fired its load event.
    loaded: bool,
}

impl PageState<'_> {
    fn handle(&mut self, event: &Value) {
        collect_console_error(event, &mut self.console_errors);
        match event["method"].as_str() {
            Some("Page.frameNavigated") => {
                let frame = &event["params"]["frame"];
                if frame.get("parentId").is_none() && frame["url"].as_str() == Some(self.url) {
                    self.navigated = true;
                }
            }
            Some("Page.loadEventFired") if self.navigated => self.loaded = true,
            _ => {}
        }
    }
}

enum Event {
    Message(Value),
    Closed(String),
}

struct Browser {
    child: Child,
    to_browser: Option<ChildStdin>,
    from_browser: Receiver<Event>,
    stderr: Receiver<String>,
    stderr_lines: Vec<String>,
    next_id: u64,
    deadline: Instant,
}

impl Browser {
    /// `loopback`: let 127.0.0.1 through (a page acq serves); every other
    /// host stays unreachable.
    fn launch(binary: &Path, profile: &Path, loopback: bool) -> Result<Browser, String> {
        // Chromium reads protocol messages from fd 3 and writes to fd 4. The
        // shell moves our stdin/stdout pipes there; Chromium's own stdout goes
        // to the stderr pipe.
        let mut child = Command::new("sh")
            .arg("-c")
            .arg(r#"exec "$0" "$@" 3<&0 4>&1 1>&2"#)
            .arg(binary)
            .args([
                "--headless",
                "--no-sandbox", // required as root, harmless otherwise
                "--disable-gpu",
                "--remote-debugging-pipe",
                "--no-first-run",
                "--no-default-browser-check",
                "--disable-extensions",
                "--disable-background-networking",
                "--disable-sync",
                "--mute-audio",
                "--window-size=1280,1024",
                // Nothing may come from the network: every host name fails to
                // resolve, immediately, so a non-self-contained page shows up
                // as "Failed to load resource: net::ERR_NAME_NOT_RESOLVED".
            ])
            .arg(if loopback {
                "--host-resolver-rules=MAP * ~NOTFOUND, EXCLUDE 127.0.0.1"
            } else {
                "--host-resolver-rules=MAP * ~NOTFOUND"
            })
            .arg(format!("--user-data-dir={}", profile.display()))
            .arg("about:blank")
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .process_group(0) // so a hung browser is killed with all its children
            .spawn()
            .map_err(|e| format!("starting {}: {e}", binary.display()))?;
        let to_browser = child.stdin.take();
        let mut stdout = child.stdout.take().expect("piped stdout");
        let stderr = child.stderr.take().expect("piped stderr");

        let (tx, from_browser) = mpsc::channel();
        std::thread::spawn(move || {
            let mut buf = Vec::new();
            let mut chunk = [0u8; 64 * 1024];
            loop {
                match stdout.read(&mut chunk) {
                    Ok(0) => {
                        let _ = tx.send(Event::Closed("the browser closed the pipe".into()));
                        return;
                    }
                    Ok(n) => buf.extend_from_slice(&chunk[..n]),
                    Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
                    Err(e) => {
                        let _ = tx.send(Event::Closed(format!("reading the pipe: {e}")));
                        return;
                    }
                }
                while let Some(end) = buf.iter().position(|&b| b == 0) {
                    let message: Vec<u8> = buf.drain(..=end).collect();
                    let event = match serde_json::from_slice(&message[..end]) {
                        Ok(value) => Event::Message(value),
                        Err(e) => Event::Closed(format!("bad protocol message: {e}")),
                    };
                    if tx.send(event).is_err() {
                        return;
                    }
                }
            }
        });
        let (tx, stderr_rx) = mpsc::channel();
        std::thread::spawn(move || {
            for line in BufReader::new(stderr).lines() {
                let Ok(line) = line else { return };
                if tx.send(line).is_err() {
                    return;
                }
            }
        });
        Ok(Browser {
            child,
            to_browser,
            from_browser,
            stderr: stderr_rx,
            stderr_lines: Vec::new(),
            next_id: 0,
            deadline: Instant::now() + TIMEOUT,
        })
    }

    fn send(&mut self, method: &str, params: Value, session: Option<&str>) -> Result<u64, String> {
        self.next_id += 1;
        let mut message = json!({ "id": self.next_id, "method": method, "params": params });
        if let Some(session) = session {
            message["sessionId"] = json!(session);
        }
        let mut bytes = serde_json::to_vec(&message).expect("serialisable");
        bytes.push(0);
        let pipe = self
            .to_browser
            .as_mut()
            .ok_or("pipe to the browser closed")?;
        pipe.write_all(&bytes)
            .and_then(|()| pipe.flush())
            .map_err(|e| format!("sending {method}: {e}"))?;
        Ok(self.next_id)
    }

    fn recv(&mut self) -> Result<Value, String> {
        let left = self.deadline.saturating_duration_since(Instant::now());
        match self.from_browser.recv_timeout(left) {
            Ok(Event::Message(value)) => Ok(value),
            Ok(Event::Closed(why)) => Err(why),
            Err(RecvTimeoutError::Timeout) => Err(format!("no answer within {TIMEOUT:?}")),
            Err(RecvTimeoutError::Disconnected) => Err("the browser closed the pipe".into()),
        }
    }

    /// Sends a command and waits for its answer, handing events to `on_event`.
    fn call(
        &mut self,
        method: &str,
        params: Value,
        session: Option<&str>,
        on_event: &mut dyn FnMut(&Value),
    ) -> Result<Value, String> {
        let id = self.send(method, params, session)?;
        loop {
            let message = self.recv()?;
            if message["id"].as_u64() == Some(id) {
                if let Some(error) = message.get("error") {
                    return Err(format!("{method} failed: {error}"));
                }
                return Ok(message["result"].clone());
            }
            on_event(&message);
        }
    }

    /// Opens `url` in a new tab and waits for its load event: the tab's
    /// session and the console errors so far.
    fn open(&mut self, url: &str) -> Result<(String, Vec<String>), String> {
        let mut ignore = |_: &Value| {};
        let target = self.call(
            "Target.createTarget",
            json!({ "url": "about:blank" }),
            None,
            &mut ignore,
        )?;
        let target_id = target["targetId"].as_str().ok_or("no targetId")?.to_owned();
        let attached = self.call(
            "Target.attachToTarget",
            json!({ "targetId": target_id, "flatten": true }),
            None,
            &mut ignore,
        )?;
        let session = attached["sessionId"]
            .as_str()
            .ok_or("no sessionId")?
            .to_owned();
        // From here on every event may carry a console message.
        let mut page = PageState {
            url,
            console_errors: Vec::new(),
            navigated: false,
            loaded: false,
        };
        for domain in ["Runtime.enable", "Log.enable", "Page.enable"] {
            self.call(domain, json!({}), Some(&session), &mut |e| page.handle(e))?;
        }
        let navigation = self.call(
            "Page.navigate",
            json!({ "url": url }),
            Some(&session),
            &mut |e| page.handle(e),
        )?;
        if let Some(error) = navigation["errorText"].as_str() {
            return Err(format!("navigation to {url} failed: {error}"));
        }
        while !page.loaded {
            let event = self.recv()?;
            page.handle(&event);
        }
        Ok((session, page.console_errors))
    }

    fn check(&mut self, url: &str) -> Result<PageCheck, String> {
        let (session, mut console_errors) = self.open(url)?;
        let session = Some(session.as_str());
        let measured = self.call(
            "Runtime.evaluate",
            json!({ "expression": MEASURE_JS, "returnByValue": true }),
            session,
            &mut |e| collect_console_error(e, &mut console_errors),
        )?;
        if let Some(details) = measured.get("exceptionDetails") {
            return Err(format!("measuring script failed: {details}"));
        }
        let text = measured["result"]["value"]
            .as_str()
            .ok_or("measuring script returned no string")?;
        let seen: Value =
            serde_json::from_str(text).map_err(|e| format!("measurement JSON: {e}"))?;
        let tables = seen["tables"]
            .as_array()
            .ok_or("no tables in measurement")?
            .iter()
            .map(|t| TableCheck {
                visible: t["visible"].as_bool().unwrap_or(false),
                body_rows: t["body_rows"].as_u64().unwrap_or(0) as usize,
                first_header: t["first_header"].as_str().unwrap_or("").to_owned(),
            })
            .collect();
        Ok(PageCheck {
            console_errors,
            title: seen["title"].as_str().unwrap_or("").to_owned(),
            tables,
            visible_svgs: seen["visible_svgs"].as_u64().unwrap_or(0) as usize,
        })
    }

    /// Asks the browser to quit, waits up to 5 s, then kills its process group.
    fn shut_down(&mut self) {
        let _ = self.send("Browser.close", json!({}), None);
        self.to_browser = None;
        let give_up = Instant::now() + Duration::from_secs(5);
        loop {
            match self.child.try_wait() {
                Ok(Some(_)) | Err(_) => break,
                Ok(None) if Instant::now() >= give_up => {
                    self.kill();
                    break;
                }
                Ok(None) => std::thread::sleep(Duration::from_millis(20)),
            }
        }
        // Renderer/GPU children outliving the browser must not keep the
        // profile directory busy.
        self.kill();
    }

    fn kill(&mut self) {
        if let Ok(pgid) = i32::try_from(self.child.id()) {
            let _ = nix::sys::signal::killpg(
                nix::unistd::Pid::from_raw(pgid),
                nix::sys::signal::SIGKILL,
            );
        }
        let _ = self.child.kill();
        let _ = self.child.wait();
    }

    /// The last lines Chromium wrote to stderr, for error messages.
    fn stderr_tail(&mut self) -> String {
        while let Ok(line) = self.stderr.recv_timeout(Duration::from_millis(200)) {
            self.stderr_lines.push(line);
        }
        let start = self.stderr_lines.len().saturating_sub(15);
        if start == self.stderr_lines.len() {
            return String::new();
        }
        format!(
            "\nlast lines of chromium's stderr:\n{}",
            self.stderr_lines[start..].join("\n")
        )
    }
}

impl Drop for Browser {
    fn drop(&mut self) {
        if matches!(self.child.try_wait(), Ok(None)) {
            self.kill();
        }
    }
}

/// Appends one line to `out` if `event` is a console message of level error or
/// warning: `console.error/warn/assert`, an uncaught exception, or a browser
/// log entry (failed resource load, CSP refusal, deprecation, ...).
fn collect_console_error(event: &Value, out: &mut Vec<String>) {
    let params = &event["params"];
    match event["method"].as_str() {
        Some("Runtime.consoleAPICalled") => {
            let level = match params["type"].as_str() {
                Some("error") | Some("assert") => "error",
                Some("warning") => "warning",
                _ => return,
            };
            let args: Vec<String> = params["args"]
                .as_array()
                .into_iter()
                .flatten()
                .map(remote_object)
                .collect();
            let frame = &params["stackTrace"]["callFrames"][0];
            out.push(format!(
                "{level} [console] {}{}",
                args.join(" "),
                location(frame)
            ));
        }
        Some("Runtime.exceptionThrown") => {
            let details = &params["exceptionDetails"];
            let text = details["text"].as_str().unwrap_or("Uncaught");
            let what = details["exception"]["description"]
                .as_str()
                .and_then(|d| d.lines().next())
                .unwrap_or("");
            out.push(
                format!("error [exception] {text} {what}{}", location(details)).replace("  ", " "),
            );
        }
        Some("Log.entryAdded") => {
            let entry = &params["entry"];
            let level = entry["level"].as_str().unwrap_or("");
            if level != "error" && level != "warning" {
                return;
            }
            let source = entry["source"].as_str().unwrap_or("other");
            let text = entry["text"].as_str().unwrap_or("");
            let url = entry["url"]
                .as_str()
                .map(|u| format!(" ({u})"))
                .unwrap_or_default();
            out.push(format!("{level} [{source}] {text}{url}"));
        }
        _ => {}
    }
}

fn remote_object(arg: &Value) -> String {
    if let Some(s) = arg["value"].as_str() {
        return s.to_owned();
    }
    for key in ["value", "unserializableValue", "description"] {
        if let Some(v) = arg.get(key) {
            return v.as_str().map_or_else(|| v.to_string(), str::to_owned);
        }
    }
    arg["type"].as_str().unwrap_or("?").to_owned()
}

/// ` (url:line:column)` from a call frame or exception details (0-based there).
fn location(frame: &Value) -> String {
    match (
        frame["url"].as_str(),
        frame["lineNumber"].as_u64(),
        frame["columnNumber"].as_u64(),
    ) {
        (Some(url), Some(line), Some(column)) if !url.is_empty() => {
            format!(" ({url}:{}:{})", line + 1, column + 1)
        }
        _ => String::new(),
    }
}

/// A page kept open in headless Chromium: a live page is watched over
/// time (scripts evaluated, screenshots taken) while its console messages
/// of level error or warning are collected.
pub struct LivePage {
    browser: Browser,
    session: String,
    console_errors: Vec<String>,
    _profile: tempfile::TempDir,
}

impl LivePage {
    /// Opens `url` and waits for its load event; the whole watch may last
    /// up to `limit`.
    pub fn open(url: &str, limit: Duration) -> Result<LivePage, String> {
        let binary = find_chromium()?;
        let profile = tempfile::tempdir().map_err(|e| format!("temp dir: {e}"))?;
        let mut browser = Browser::launch(&binary, profile.path(), true)?;
        browser.deadline = Instant::now() + limit;
        let (session, console_errors) = browser.open(url)?;
        Ok(LivePage {
            browser,
            session,
            console_errors,
            _profile: profile,
        })
    }

    /// The browser's process id (its renderers and helpers are its
    /// descendants): for a benchmark of its CPU time.
    pub fn browser_pid(&self) -> u32 {
        self.browser.child.id()
    }

    /// Evaluates `expression` in the page; its value as JSON.
    pub fn evaluate(&mut self, expression: &str) -> Result<Value, String> {
        let mut errors = std::mem::take(&mut self.console_errors);
        let result = self.browser.call(
            "Runtime.evaluate",
            json!({ "expression": expression, "returnByValue": true, "awaitPromise": true }),
            Some(&self.session),
            &mut |e| collect_console_error(e, &mut errors),
        );
        self.console_errors = errors;
        let result = result?;
        if let Some(details) = result.get("exceptionDetails") {
            return Err(format!("{expression}: {details}"));
        }
        Ok(result["result"]["value"].clone())
    }

    /// Writes a PNG of the whole page.
    pub fn screenshot(&mut self, path: &Path) -> Result<(), String> {
        let mut errors = std::mem::take(&mut self.console_errors);
        let shot = self.browser.call(
            "Page.captureScreenshot",
            json!({ "format": "png", "captureBeyondViewport": true }),
            Some(&self.session),
            &mut |e| collect_console_error(e, &mut errors),
        );
        self.console_errors = errors;
        let data = shot?["data"]
            .as_str()
            .ok_or("no screenshot data")?
            .to_owned();
        use base64::Engine;
        let bytes = base64::engine::general_purpose::STANDARD
            .decode(data)
            .map_err(|e| format!("screenshot data: {e}"))?;
        std::fs::write(path, bytes).map_err(|e| format!("{}: {e}", path.display()))
    }

    /// A mouse drag with the left button from `from` to `to` (CSS pixels
    /// of the viewport), as a user's hand would make it: press, moves, release.
    pub fn drag(&mut self, from: (f64, f64), to: (f64, f64)) -> Result<(), String> {
        let mut errors = std::mem::take(&mut self.console_errors);
        let mut result = Ok(());
        let steps = 8;
        let mut events = vec![("mousePressed", from, 1)];
        for k in 1..=steps {
            let t = k as f64 / steps as f64;
            let point = (from.0 + (to.0 - from.0) * t, from.1 + (to.1 - from.1) * t);
            events.push(("mouseMoved", point, 1));
        }
        events.push(("mouseReleased", to, 0));
        for (kind, (x, y), buttons) in events {
            let sent = self.browser.call(
                "Input.dispatchMouseEvent",
                json!({ "type": kind, "x": x, "y": y, "button": "left", "buttons": buttons, "clickCount": 1 }),
                Some(&self.session),
                &mut |e| collect_console_error(e, &mut errors),
            );
            if let Err(error) = sent {
                result = Err(error);
                break;
            }
        }
        self.console_errors = errors;
        result
    }

    /// Console errors and warnings so far.
    pub fn console_errors(&self) -> &[String] {
        &self.console_errors
    }

    pub fn close(mut self) {
        self.browser.shut_down();
    }
}
