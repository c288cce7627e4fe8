//! The live status: a table redrawn in place about twice a second on a
//! terminal, one JSON object per line for machines (`--status-json`), or
//! nothing (`--quiet`).

use std::fmt::Write as _;
use std::io::{self, IsTerminal, Write};

use serde::Serialize;

/// How the recorder reports while it runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StatusMode {
    /// A table on stderr: redrawn in place on a terminal, every 10 s otherwise.
    Human,
    /// One JSON object per line on stdout.
    Json,
    Quiet,
}

/// One status snapshot.
#[derive(Clone, Debug, Serialize)]
pub struct Status {
    pub elapsed_s: f64,
    pub session_dir: String,
    pub frames: u64,
    pub bytes_written: u64,
    pub buses: Vec<BusStatus>,
    pub sensors: Vec<SensorStatus>,
}

#[derive(Clone, Debug, Serialize)]
pub struct BusStatus {
    pub iface: String,
    /// `up`, or `down` while the interface is gone.
    pub state: &'static str,
    pub frames_per_s: f64,
    pub frames: u64,
    pub dropped_by_kernel: u64,
    pub error_frames: u64,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub last_error: Option<String>,
}

#[derive(Clone, Debug, Serialize)]
pub struct SensorStatus {
    pub name: String,
    pub value: Option<f64>,
    pub unit: String,
    pub age_s: Option<f64>,
    pub silent: bool,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub reason: Option<&'static str>,
}

/// Draws statuses in the chosen mode.
pub struct StatusDisplay {
    mode: StatusMode,
    terminal: bool,
    lines_drawn: usize,
    last_plain_s: f64,
}

const RED: &str = "\x1b[1;31m";
const RESET: &str = "\x1b[0m";

impl StatusDisplay {
    pub fn new(mode: StatusMode) -> Self {
        StatusDisplay {
            mode,
            terminal: io::stderr().is_terminal(),
            lines_drawn: 0,
            last_plain_s: f64::NEG_INFINITY,
        }
    }

    pub fn show(&mut self, status: &Status) {
        match self.mode {
            StatusMode::Quiet => {}
            StatusMode::Json => {
                if let Ok(line) = serde_json::to_string(status) {
                    let mut out = io::stdout().lock();
                    let _ = writeln!(out, "{line}");
                    let _ = out.flush();
                }
            }
            StatusMode::Human if self.terminal => {
                let text = render(status, true);
                let mut err = io::stderr().lock();
                if self.lines_drawn > 0 {
                    // Back to the top of the previous table, then clear below.
                    let _ = write!(err, "\x1b[{}A\x1b[J", self.lines_drawn);
                }
                let _ = err.write_all(text.as_bytes());
                let _ = err.flush();
                self.lines_drawn = text.lines().count();
            }
            StatusMode::Human => {
                if status.elapsed_s - self.last_plain_s >= 10.0 {
                    self.last_plain_s = status.elapsed_s;
                    let _ = io::stderr().write_all(render(status, false).as_bytes());
                }
            }
        }
    }

    /// A one-off message that must not be overdrawn by the next table.
    pub fn message(&mut self, text: &str) {
        if self.mode == StatusMode::Quiet {
            eprintln!("acq: {text}");
            return;
        }
        if self.mode == StatusMode::Human && self.terminal && self.lines_drawn > 0 {
            eprint!("\x1b[{}A\x1b[J", self.lines_drawn);
            self.lines_drawn = 0;
        }
        eprintln!("acq: {text}");
    }
}

/// The status table as text; `color` highlights silent sensors and faults.
pub fn render(status: &Status, color: bool) -> String {
    let (red, reset) = if color { (RED, RESET) } else { ("", "") };
    let mut text = String::new();
    let _ = writeln!(
        text,
        "acq record  {}  {}  {} frames  {:.1} MB",
        clock(status.elapsed_s),
        status.session_dir,
        status.frames,
        status.bytes_written as f64 / 1e6
    );
    let _ = writeln!(
        text,
        "  {:<10} {:<5} {:>9} {:>11} {:>8} {:>7}",
        "bus", "state", "frames/s", "frames", "dropped", "errors"
    );
    for bus in &status.buses {
        let faulty = bus.state != "up" || bus.dropped_by_kernel > 0 || bus.error_frames > 0;
        let (on, off) = if faulty { (red, reset) } else { ("", "") };
        let _ = write!(
            text,
            "{on}  {:<10} {:<5} {:>9.1} {:>11} {:>8} {:>7}{off}",
            bus.iface,
            bus.state,
            bus.frames_per_s,
            bus.frames,
            bus.dropped_by_kernel,
            bus.error_frames
        );
        if let Some(error) = &bus.last_error {
            let _ = write!(text, "  last: {error}");
        }
        text.push('\n');
    }
    if !status.sensors.is_empty() {
        let silent = status.sensors.iter().filter(|s| s.silent).count();
        let _ = writeln!(
            text,
            "  {:<24} {:>12} {:<6} {}",
            "sensor",
            "value",
            "unit",
            if silent > 0 {
                format!("{red}{silent} SILENT{reset}")
            } else {
                "all alive".to_owned()
            }
        );
        for sensor in &status.sensors {
            let value = sensor.value.map_or_else(|| "-".to_owned(), format_value);
            let age = sensor
                .age_s
                .map_or_else(|| "-".to_owned(), |a| format!("{a:.2} s ago"));
            if sensor.silent {
                let _ = writeln!(
                    text,
                    "{red}  {:<24} {:>12} {:<6} SILENT: {} (last {age}){reset}",
                    sensor.name,
                    value,
                    sensor.unit,
                    sensor.reason.unwrap_or("")
                );
            } else {
                let _ = writeln!(
                    text,
                    "  {:<24} {:>12} {:<6} {age}",
                    sensor.name, value, sensor.unit
                );
            }
        }
    }
    text
}

fn format_value(value: f64) -> String {
    if value.abs() >= 1e6 || (value != 0.0 && value.abs() < 1e-3) {
        format!("{value:.4e}")
    } else {
        format!("{value:.3}")
    }
}

fn clock(seconds: f64) -> String {
    let total = seconds.max(0.0) as u64;
    format!(
        "{:02}:{:02}:{:02}",
        total / 3600,
        total / 60 % 60,
        total % 60
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn silent_sensors_are_marked() {
        let status = Status {
            elapsed_s: 83.0,
            session_dir: "sessions/x".into(),
            frames: 10,
            bytes_written: 2_000_000,
            buses: vec![BusStatus {
                iface: "vcan0".into(),
                state: "down",
                frames_per_s: 0.0,
                frames: 10,
                dropped_by_kernel: 0,
                error_frames: 0,
                last_error: None,
            }],
            sensors: vec![
                SensorStatus {
                    name: "boom_head_pressure".into(),
                    value: Some(116.89),
                    unit: "bar".to_string(),
                    age_s: Some(0.01),
                    silent: false,
                    reason: None,
                },
                SensorStatus {
                    name: "sg09".into(),
                    value: None,
                    unit: "MPa".to_string(),
                    age_s: None,
                    silent: true,
                    reason: Some("never seen"),
                },
            ],
        };
        let text = render(&status, false);
        assert!(text.starts_with("acq record  00:01:23"), "{text}");
        assert!(text.contains("1 SILENT"), "{text}");
        assert!(
            text.contains("sg09") && text.contains("SILENT: never seen"),
            "{text}"
        );
        assert!(text.contains("116.890"), "{text}");
        let colored = render(&status, true);
        assert!(
            colored.contains(RED),
            "a down bus and a silent sensor are highlighted"
        );
        let json = serde_json::to_string(&status).unwrap();
        assert!(
            json.contains("\"silent\":true") && json.contains("\"state\":\"down\""),
            "{json}"
        );
    }
}
