//! The page's server (axum on acq's tokio runtime). It only reads: every
//! route is a GET of the page, its scripts, or JSON of the sessions' models.
//!
//! - Loopback by default; another address only when the caller allows it,
//!   and then every request must carry the random token printed at start.
//! - The Host header must name the address served (a page elsewhere cannot
//!   reach a loopback view through DNS rebinding).
//! - A Content-Security-Policy allows scripts and styles from the server only;
//!   the page inserts every name as text, never as HTML.
//! - Updates go out as server-sent events from one broadcast ring: a viewer
//!   that does not read falls behind and is told how many it missed; the
//!   sender never waits and the ring's size bounds the memory.

use std::collections::HashMap;
use std::convert::Infallible;
use std::io::Read;
use std::net::SocketAddr;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Arc;
use std::time::Duration;

use axum::extract::{Query, Request, State};
use axum::http::{header, HeaderValue, StatusCode};
use axum::middleware::{self, Next};
use axum::response::sse::{Event, KeepAlive, Sse};
use axum::response::{IntoResponse, Response};
use axum::routing::get;
use axum::Router;
use serde_json::{json, Value};
use tokio::sync::{broadcast, oneshot};

use acq_error::{AcqError, Result};

use crate::live::SharedSession;
use crate::page;
use crate::study_worker::SharedStudy;

/// Updates are published this often.
const PUBLISH_PERIOD: Duration = Duration::from_millis(100);
/// Updates a viewer may be behind before it loses some (10 s).
const RING: usize = 100;
/// Each update re-sends this much of the newest data (late samples).
const TAIL_OVERLAP_S: f64 = 0.5;
/// Live columns: 50 ms, 1,200 over a minute.
const LIVE_COLUMN_S: f64 = 0.05;
/// Widest plot a request may ask for, in columns.
const MAX_COLUMNS: usize = 8_192;
/// After a stop, open event streams get this long to end.
const SHUTDOWN_GRACE: Duration = Duration::from_secs(2);

/// Who may use the page.
#[derive(Clone, Debug)]
pub struct Access {
    /// Required on every request (`?token=`), for a non-loopback address.
    pub token: Option<String>,
    /// Host headers accepted; `None`: any (a non-loopback address).
    pub hosts: Option<Vec<String>>,
}

/// `HOST:PORT` to serve on. A non-loopback address is refused unless
/// `remote` (the user's explicit flag), and then needs a token.
pub fn access_for(addr: SocketAddr, remote: bool) -> Result<Access> {
    if addr.ip().to_canonical().is_loopback() {
        return Ok(Access {
            token: None,
            hosts: Some(loopback_hosts(addr)),
        });
    }
    if !remote {
        return Err(AcqError::Config(format!(
            "--view {addr}: not a loopback address; other machines could read the rig's data. \
             Add --view-remote to serve it there (every request then needs the token printed at start), \
             or use 127.0.0.1:PORT"
        )));
    }
    Ok(Access {
        token: Some(random_token()?),
        hosts: None,
    })
}

/// The Host headers a browser sends for a loopback address.
fn loopback_hosts(addr: SocketAddr) -> Vec<String> {
    let port = addr.port();
    vec![
        format!("127.0.0.1:{port}"),
        format!("localhost:{port}"),
        format!("[::1]:{port}"),
        addr.to_string(),
    ]
}

/// 128 random bits from the kernel, as hex.
fn random_token() -> Result<String> {
    let mut bytes = [0u8; 16];
    std::fs::File::open("/dev/urandom")
        .and_then(|mut f| f.read_exact(&mut bytes))
        .map_err(|e| AcqError::io("reading /dev/urandom for the view's token", e))?;
    Ok(bytes.iter().map(|b| format!("{b:02x}")).collect())
}

/// `HOST:PORT` as given on the command line.
pub fn parse_address(text: &str) -> Result<SocketAddr> {
    use std::net::ToSocketAddrs;
    let mut addresses = text.to_socket_addrs().map_err(|e| {
        AcqError::Config(format!(
            "--view {text}: expected HOST:PORT, e.g. 127.0.0.1:8750 ({e})"
        ))
    })?;
    // An IPv4 address written as IPv6 (`[::ffff:127.0.0.1]`) is that IPv4
    // address: loopback where it is.
    addresses
        .next()
        .map(|a| SocketAddr::new(a.ip().to_canonical(), a.port()))
        .ok_or_else(|| AcqError::Config(format!("--view {text}: the host resolves to no address")))
}

#[derive(Clone)]
struct App {
    sessions: Arc<Vec<SharedSession>>,
    study: Option<SharedStudy>,
    layout: Arc<Option<crate::layout::Layout>>,
    access: Arc<Access>,
    updates: broadcast::Sender<Arc<str>>,
    viewers: Arc<AtomicUsize>,
    /// Becomes true when the server stops: event streams end.
    closing: tokio::sync::watch::Receiver<bool>,
}

/// A running page server.
pub struct ViewServer {
    url: String,
    closing: tokio::sync::watch::Sender<bool>,
    stop: Option<oneshot::Sender<()>>,
    task: tokio::task::JoinHandle<()>,
    publisher: tokio::task::JoinHandle<()>,
}

impl ViewServer {
    /// The address to open, token included.
    pub fn url(&self) -> &str {
        &self.url
    }

    /// Stops serving: event streams end, connections close.
    pub async fn stop(mut self) {
        self.publisher.abort();
        let _ = self.publisher.await;
        let _ = self.closing.send(true);
        if let Some(stop) = self.stop.take() {
            let _ = stop.send(());
        }
        if tokio::time::timeout(SHUTDOWN_GRACE, &mut self.task)
            .await
            .is_err()
        {
            self.task.abort();
        }
    }

    /// Serves until the task ends (it does not on its own).
    pub async fn wait(self) {
        let _ = self.task.await;
    }
}

/// Binds `addr` and serves the sessions' page on the current runtime.
/// What a page shows: the sessions, and a study's panel when one runs.
pub struct Pages {
    pub sessions: Vec<SharedSession>,
    pub study: Option<SharedStudy>,
    /// The plots as a layout file sets them out, else one per sensor kind.
    pub layout: Option<crate::layout::Layout>,
}

impl From<Vec<SharedSession>> for Pages {
    fn from(sessions: Vec<SharedSession>) -> Self {
        Pages {
            sessions,
            study: None,
            layout: None,
        }
    }
}

pub async fn serve(
    addr: SocketAddr,
    access: Access,
    pages: impl Into<Pages>,
) -> Result<ViewServer> {
    let Pages {
        sessions,
        study,
        layout,
    } = pages.into();
    let listener = tokio::net::TcpListener::bind(addr).await.map_err(|e| {
        let hint = match e.kind() {
            std::io::ErrorKind::AddrInUse => {
                "; another program serves there: give another port with --view HOST:PORT"
            }
            std::io::ErrorKind::AddrNotAvailable => {
                "; this machine has no such address: give one of its own, or 127.0.0.1"
            }
            _ => "",
        };
        AcqError::io(format!("serving the view on {addr}{hint}"), e)
    })?;
    let bound = listener
        .local_addr()
        .map_err(|e| AcqError::io(format!("serving the view on {addr}"), e))?;
    let mut access = access;
    if let Some(hosts) = &mut access.hosts {
        // Port 0 asks for any free port: accept the one bound.
        hosts.extend(loopback_hosts(bound));
    }
    let url = match &access.token {
        Some(token) => format!("http://{bound}/?token={token}"),
        None => format!("http://{bound}/"),
    };
    let (updates, _) = broadcast::channel(RING);
    let (closing, closing_rx) = tokio::sync::watch::channel(false);
    let app = App {
        closing: closing_rx,
        sessions: Arc::new(sessions),
        study,
        layout: Arc::new(layout),
        access: Arc::new(access),
        updates,
        viewers: Arc::new(AtomicUsize::new(0)),
    };
    let publisher = tokio::spawn(publish(app.clone()));
    let router = Router::new()
        .route("/", get(page_html))
        .route(
            "/app.js",
            get(|| async { asset(page::APP_JS, "text/javascript") }),
        )
        .route(
            "/app.css",
            get(|| async { asset(page::APP_CSS, "text/css") }),
        )
        .route(
            "/uplot.js",
            get(|| async { asset(page::UPLOT_JS, "text/javascript") }),
        )
        .route(
            "/uplot.css",
            get(|| async { asset(page::UPLOT_CSS, "text/css") }),
        )
        .route(
            "/uplot-license.txt",
            get(|| async { asset(page::UPLOT_LICENSE, "text/plain; charset=utf-8") }),
        )
        .route("/api/state", get(state))
        .route("/api/series", get(series))
        .route("/api/xy", get(xy))
        .route("/api/frames", get(frames))
        .route("/api/events", get(events))
        .layer(middleware::from_fn_with_state(app.clone(), guard))
        .with_state(app);
    let (stop, stopped) = oneshot::channel::<()>();
    let task = tokio::spawn(accept_until(listener, router, stopped));
    Ok(ViewServer {
        url,
        closing,
        stop: Some(stop),
        task,
        publisher,
    })
}

/// How long a client may take to send a request's headers: a browser
/// sends them at once; a client that dribbles them holds a connection
/// (and its memory) until this passes, then it is closed.
pub const HEADER_READ_TIMEOUT: std::time::Duration = std::time::Duration::from_secs(10);

/// Accepts connections until `stopped`, each served by hyper's HTTP/1
/// with [`HEADER_READ_TIMEOUT`]; on stop every connection finishes its
/// answer and closes.
async fn accept_until(
    listener: tokio::net::TcpListener,
    router: Router,
    mut stopped: oneshot::Receiver<()>,
) {
    use hyper_util::rt::{TokioIo, TokioTimer};
    use hyper_util::service::TowerToHyperService;
    let (shutdown, _) = tokio::sync::watch::channel(());
    loop {
        let stream = tokio::select! {
            accepted = listener.accept() => match accepted {
                Ok((stream, _)) => stream,
                // Out of file descriptors and the like: wait, go on.
                Err(_) => {
                    tokio::time::sleep(std::time::Duration::from_millis(50)).await;
                    continue;
                }
            },
            _ = &mut stopped => break,
        };
        let service = TowerToHyperService::new(router.clone());
        let mut shutting = shutdown.subscribe();
        tokio::spawn(async move {
            let mut http = hyper::server::conn::http1::Builder::new();
            http.timer(TokioTimer::new())
                .header_read_timeout(HEADER_READ_TIMEOUT);
            let connection = http.serve_connection(TokioIo::new(stream), service);
            tokio::pin!(connection);
            tokio::select! {
                _ = connection.as_mut() => {}
                _ = shutting.changed() => {
                    connection.as_mut().graceful_shutdown();
                    let _ = connection.await;
                }
            }
        });
    }
    let _ = shutdown.send(());
}

/// Host and token checks, and the headers every answer carries.
async fn guard(State(app): State<App>, request: Request, next: Next) -> Response {
    // `GET http://host/ HTTP/1.1` is a request to a proxy: this server is
    // none, and the absolute URI would sidestep the Host check's meaning.
    if request.uri().scheme().is_some() || request.uri().authority().is_some() {
        return refuse(
            StatusCode::BAD_REQUEST,
            "this view is no proxy: ask for a path (GET /), not an absolute URI",
        );
    }
    if let Some(hosts) = &app.access.hosts {
        let host = request
            .headers()
            .get(header::HOST)
            .and_then(|h| h.to_str().ok())
            .unwrap_or("");
        if !hosts.iter().any(|h| h == host) {
            return refuse(
                StatusCode::FORBIDDEN,
                "this view answers only on the address it serves",
            );
        }
    }
    if let Some(token) = &app.access.token {
        let given = request
            .uri()
            .query()
            .and_then(|q| q.split('&').find_map(|pair| pair.strip_prefix("token=")));
        if !given.is_some_and(|given| same_secret(given, token)) {
            return refuse(
                StatusCode::UNAUTHORIZED,
                "a token is needed: open the URL acq printed at start",
            );
        }
    }
    let mut response = next.run(request).await;
    let headers = response.headers_mut();
    headers.insert(
        header::CONTENT_SECURITY_POLICY,
        HeaderValue::from_static(
            "default-src 'none'; script-src 'self'; style-src 'self'; img-src 'self' data:; \
             connect-src 'self'; base-uri 'none'; form-action 'none'; frame-ancestors 'none'",
        ),
    );
    headers.insert(
        header::X_CONTENT_TYPE_OPTIONS,
        HeaderValue::from_static("nosniff"),
    );
    headers.insert(
        header::REFERRER_POLICY,
        HeaderValue::from_static("no-referrer"),
    );
    headers.insert(header::CACHE_CONTROL, HeaderValue::from_static("no-store"));
    response
}

/// Equal, in a time that does not depend on where the texts differ.
fn same_secret(given: &str, secret: &str) -> bool {
    given.len() == secret.len()
        && given
            .bytes()
            .zip(secret.bytes())
            .fold(0u8, |differs, (a, b)| differs | (a ^ b))
            == 0
}

fn refuse(status: StatusCode, message: &'static str) -> Response {
    (
        status,
        [(header::CONTENT_TYPE, "text/plain; charset=utf-8")],
        message,
    )
        .into_response()
}

fn asset(body: &'static str, content_type: &'static str) -> Response {
    ([(header::CONTENT_TYPE, content_type)], body).into_response()
}

async fn page_html(State(app): State<App>) -> Response {
    let names: Vec<String> = app.sessions.iter().map(|s| lock(s).name.clone()).collect();
    let html = page::html(&names, app.access.token.as_deref());
    ([(header::CONTENT_TYPE, "text/html; charset=utf-8")], html).into_response()
}

fn lock(session: &SharedSession) -> std::sync::MutexGuard<'_, crate::model::SessionView> {
    session.lock().unwrap_or_else(|p| p.into_inner())
}

/// The whole state: `/api/state`, and the `state` of every update; the
/// holds (the bulk of it: every hold's values) only when `with_holds`.
fn state_json(app: &App, with_holds: bool) -> Value {
    let several = app.sessions.len() > 1;
    let (mut sessions, mut sensors, mut buses, mut holds) = (vec![], vec![], vec![], vec![]);
    for shared in app.sessions.iter() {
        let view = lock(shared);
        let tag = several.then_some(view.name.as_str());
        sessions.push(json!({
            "name": view.name,
            "started_unix_s": view.started_unix_ns as f64 / 1e9,
            "live": view.live,
            "elapsed_s": view.elapsed_s,
            "span_s": view.span_s(),
            "load_sensor": view.load_sensor,
            "holds_note": view.holds_note,
            "frames_not_shown": view.frames_not_shown,
            "has_xy": view.xy.is_some(),
            "ended": view.ended,
            "frames_not_listed": view.frames.frames_not_listed,
        }));
        sensors.extend(view.sensors_json(tag));
        buses.extend(view.buses_json(tag));
        if with_holds {
            holds.extend(view.holds_json(tag));
        }
    }
    let mut state = json!({
        "sessions": sessions,
        "sensors": sensors,
        "buses": buses,
        "viewers": app.viewers.load(Ordering::Relaxed),
        "layout": *app.layout,
    });
    if with_holds {
        state["holds"] = Value::Array(holds);
    }
    // A study's panel: what the holds pin down now and the next test point.
    state["study"] = match &app.study {
        Some(study) => {
            let panel = study.lock().unwrap_or_else(|p| p.into_inner());
            let mut json = panel.json.clone();
            if let Value::Object(object) = &mut json {
                object.insert("updating".into(), Value::Bool(panel.updating));
            }
            json
        }
        None => Value::Null,
    };
    state
}

async fn state(State(app): State<App>) -> Response {
    axum::Json(state_json(&app, true)).into_response()
}

fn session_of<'a>(app: &'a App, query: &HashMap<String, String>) -> Option<&'a SharedSession> {
    let index = query
        .get("session")
        .map_or(Some(0), |s| s.parse::<usize>().ok())?;
    app.sessions.get(index)
}

fn number(query: &HashMap<String, String>, key: &str) -> Option<f64> {
    query
        .get(key)
        .and_then(|v| v.parse::<f64>().ok())
        .filter(|v| v.is_finite())
}

/// `?session=I&from=S&to=S&px=N`: every sensor's columns over the span.
async fn series(State(app): State<App>, Query(query): Query<HashMap<String, String>>) -> Response {
    let Some(shared) = session_of(&app, &query) else {
        return refuse(StatusCode::NOT_FOUND, "no such session");
    };
    let view = lock(shared);
    let span = view.span_s().unwrap_or((0.0, 0.0));
    let from = number(&query, "from").unwrap_or(span.0);
    let to = number(&query, "to").unwrap_or(span.1);
    let columns = number(&query, "px").map_or(1_000, |p| p.clamp(1.0, MAX_COLUMNS as f64) as usize);
    let body = format!(
        "{{\"from_s\":{},\"to_s\":{},\"series\":{}}}",
        json!(from),
        json!(to),
        view.series_json(from, to, columns)
    );
    ([(header::CONTENT_TYPE, "application/json")], body).into_response()
}

async fn xy(State(app): State<App>, Query(query): Query<HashMap<String, String>>) -> Response {
    match session_of(&app, &query) {
        Some(shared) => axum::Json(lock(shared).xy_json()).into_response(),
        None => refuse(StatusCode::NOT_FOUND, "no such session"),
    }
}

/// The raw frames of every session, one row per bus and id: asked for by
/// a page that shows them (once a second while the trace is open), never
/// pushed with every update (a bus of random ids has 2,048 rows, and ten
/// viewers on a busy rig would carry them ten times a second).
async fn frames(State(app): State<App>) -> Response {
    let several = app.sessions.len() > 1;
    let mut rows = Vec::new();
    for shared in app.sessions.iter() {
        let view = lock(shared);
        rows.extend(view.frames_json(several.then_some(view.name.as_str())));
    }
    axum::Json(json!({ "frames": rows })).into_response()
}

/// Counts a viewer while its event stream lives.
struct ViewerCount(Arc<AtomicUsize>);

impl Drop for ViewerCount {
    fn drop(&mut self) {
        self.0.fetch_sub(1, Ordering::Relaxed);
    }
}

async fn events(State(app): State<App>) -> Response {
    app.viewers.fetch_add(1, Ordering::Relaxed);
    let count = ViewerCount(app.viewers.clone());
    let receiver = app.updates.subscribe();
    let closing = app.closing.clone();
    let stream = futures_util::stream::unfold(
        (receiver, closing, count),
        |(mut receiver, mut closing, count)| async move {
            let received = tokio::select! {
                received = receiver.recv() => received,
                _ = closing.wait_for(|closed| *closed) => return None,
            };
            let event = match received {
                Ok(update) => Event::default().event("update").data(&*update),
                Err(broadcast::error::RecvError::Lagged(missed)) => {
                    Event::default().event("lost").data(missed.to_string())
                }
                Err(broadcast::error::RecvError::Closed) => return None,
            };
            Some((Ok::<_, Infallible>(event), (receiver, closing, count)))
        },
    );
    Sse::new(stream)
        .keep_alive(KeepAlive::default())
        .into_response()
}

/// Every period: the state and each live session's newest columns, once
/// for all viewers.
async fn publish(app: App) {
    let mut tick = tokio::time::interval(PUBLISH_PERIOD);
    tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Skip);
    let mut sequence: u64 = 0;
    let mut holds_sent: Vec<u64> = Vec::new();
    loop {
        tick.tick().await;
        if app.updates.receiver_count() == 0 {
            continue;
        }
        sequence += 1;
        // Holds go out when they changed, and every 5 s for a viewer that
        // came in between (it read them from /api/state anyway).
        let versions: Vec<u64> = app.sessions.iter().map(|s| lock(s).holds_version).collect();
        let with_holds = versions != holds_sent || sequence % 50 == 0;
        holds_sent = versions;
        let tails: Vec<String> = app
            .sessions
            .iter()
            .map(|shared| {
                let view = lock(shared);
                let span = view.span_s().filter(|_| view.live);
                let Some((_, end)) = span else {
                    return "null".to_string();
                };
                let from = ((end - TAIL_OVERLAP_S) / LIVE_COLUMN_S).floor() * LIVE_COLUMN_S;
                let columns = ((end - from) / LIVE_COLUMN_S).ceil().max(1.0) as usize;
                let series = view.series_json(from, from + columns as f64 * LIVE_COLUMN_S, columns);
                format!("{{\"from_s\":{},\"series\":{series}}}", json!(from))
            })
            .collect();
        let update = format!(
            "{{\"sequence\":{sequence},\"state\":{},\"tails\":[{}]}}",
            state_json(&app, with_holds),
            tails.join(",")
        );
        let _ = app.updates.send(Arc::from(update));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An IPv4 loopback written as IPv6 is loopback: served without a
    /// token, bound as the IPv4 address it is.
    #[test]
    fn an_ipv4_mapped_loopback_is_loopback() {
        let addr = parse_address("[::ffff:127.0.0.1]:0").unwrap();
        assert_eq!(addr, "127.0.0.1:0".parse().unwrap());
        let access = access_for(addr, false).unwrap();
        assert!(access.token.is_none());
        assert!(access_for("[::ffff:192.0.2.1]:0".parse().unwrap(), false).is_err());
    }
}
