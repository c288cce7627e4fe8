//! The raw frames beside the decoded signals: one row per bus, CAN id and
//! frame kind, as a fixed-position trace shows them (CANalyzer's trace
//! window, `cansniffer`): the newest payload, how many came, how often, and
//! which of the rig's signals it carries. An id no sensor of the rig is on
//! is listed too: that is where a sensor on the wrong id shows itself.

use std::collections::HashMap;

use acq_can::{Frame, FrameKind, IfaceName};
use acq_rig::sensors::FrameUse;
use serde::{Deserialize, Serialize};
use serde_json::{json, Value};

/// Rows kept; frames of ids beyond it are only counted (a bus of random
/// ids must not grow the page without bound).
pub const MAX_ROWS: usize = 2_048;

/// One bus, id and kind: what the trace shows of it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FrameRow {
    pub bus: String,
    /// The id's bits (29 for an extended id, 11 for a standard one).
    pub id: u32,
    pub extended: bool,
    /// `data`, `FD`, `remote` or `error`.
    pub kind: String,
    pub count: u64,
    /// Session time of the first and the newest frame (s).
    pub first_s: f64,
    pub last_s: f64,
    /// The time between the newest two frames (s).
    pub last_gap_s: Option<f64>,
    /// The newest frame's payload.
    pub data: Vec<u8>,
    /// What the newest frame was to the rig (see [`use_words`]).
    pub used: String,
    /// The rig's sensors (indices) a frame of this id gave a value of.
    pub sensors: Vec<usize>,
}

/// Every id seen, in the order first seen.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct FrameTable {
    rows: Vec<FrameRow>,
    /// Frames of ids past [`MAX_ROWS`].
    pub frames_not_listed: u64,
    #[serde(skip)]
    index: HashMap<(IfaceName, u32, u8), usize>,
}

/// What a frame was to the rig, as the trace says it.
pub fn use_words(used: FrameUse) -> &'static str {
    match used {
        FrameUse::Decoded => "decoded",
        FrameUse::Protocol => "protocol",
        FrameUse::Unknown => "no sensor of the rig",
        FrameUse::Undecodable => "does not match its message",
        FrameUse::NotData => "not data",
    }
}

fn kind_of(frame: &Frame) -> (u8, &'static str) {
    match frame.kind {
        FrameKind::Data { .. } => (0, "data"),
        FrameKind::Fd { .. } => (1, "FD"),
        FrameKind::Remote { .. } => (2, "remote"),
        FrameKind::Error { .. } => (3, "error"),
    }
}

impl FrameTable {
    /// One frame at `time_s` (session time), after its samples were
    /// decoded: `sensors` are those it gave a value of.
    pub fn see(&mut self, frame: &Frame, time_s: f64, used: FrameUse, sensors: &[usize]) {
        let (kind_code, kind) = kind_of(frame);
        let key = (frame.iface, frame.id.raw(), kind_code);
        let row = match self.index.get(&key) {
            Some(&row) => &mut self.rows[row],
            None => {
                if self.rows.len() >= MAX_ROWS {
                    self.frames_not_listed += 1;
                    return;
                }
                self.index.insert(key, self.rows.len());
                self.rows.push(FrameRow {
                    bus: frame.iface.as_str().to_string(),
                    id: frame.id.raw(),
                    extended: frame.id.is_extended(),
                    kind: kind.to_string(),
                    count: 0,
                    first_s: time_s,
                    last_s: time_s,
                    last_gap_s: None,
                    data: Vec::new(),
                    used: String::new(),
                    sensors: Vec::new(),
                });
                self.rows.last_mut().expect("pushed")
            }
        };
        if row.count > 0 {
            row.last_gap_s = Some(time_s - row.last_s);
        }
        row.count += 1;
        row.last_s = time_s;
        row.data.clear();
        row.data.extend_from_slice(frame.payload());
        if row.used != use_words(used) {
            row.used = use_words(used).to_string();
        }
        for &sensor in sensors {
            if let Err(at) = row.sensors.binary_search(&sensor) {
                row.sensors.insert(at, sensor);
            }
        }
    }

    pub fn rows(&self) -> &[FrameRow] {
        &self.rows
    }

    /// A table read back from an index: its lookup rebuilt.
    pub fn reindexed(mut self, sensor_count: usize) -> Option<Self> {
        self.index.clear();
        for (k, row) in self.rows.iter().enumerate() {
            let iface = IfaceName::new(&row.bus)?;
            let kind = ["data", "FD", "remote", "error"]
                .iter()
                .position(|&name| name == row.kind)? as u8;
            if row.sensors.iter().any(|&s| s >= sensor_count) || row.data.len() > 64 {
                return None;
            }
            self.index.insert((iface, row.id, kind), k);
        }
        (self.rows.len() <= MAX_ROWS).then_some(self)
    }

    /// The rows as the page lists them, by bus and id; each with its
    /// rate over its span, its payload in hex and its signals' names.
    pub fn json(&self, rig_sensor_names: &[String], session: Option<&str>) -> Vec<Value> {
        let mut order: Vec<&FrameRow> = self.rows.iter().collect();
        order.sort_by(|a, b| (&a.bus, a.id, &a.kind).cmp(&(&b.bus, b.id, &b.kind)));
        order
            .into_iter()
            .map(|row| {
                let span_s = row.last_s - row.first_s;
                let rate_hz =
                    (row.count > 1 && span_s > 0.0).then(|| (row.count - 1) as f64 / span_s);
                let id = if row.extended {
                    format!("{:08X}", row.id)
                } else {
                    format!("{:03X}", row.id)
                };
                let data: Vec<String> = row.data.iter().map(|b| format!("{b:02X}")).collect();
                let signals: Vec<&str> = row
                    .sensors
                    .iter()
                    .filter_map(|&s| rig_sensor_names.get(s).map(String::as_str))
                    .collect();
                let mut object = json!({
                    "bus": row.bus,
                    "id": id,
                    "kind": row.kind,
                    "count": row.count,
                    "rate_hz": rate_hz,
                    "last_s": row.last_s,
                    "last_gap_s": row.last_gap_s,
                    "dlc": row.data.len(),
                    "data": data.join(" "),
                    "used": row.used,
                    "signals": signals,
                });
                if let Some(session) = session {
                    object["session"] = json!(session);
                }
                object
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use acq_can::CanId;

    fn frame(iface: &str, id: u16, t_ns: i64, data: &[u8]) -> Frame {
        Frame::data(
            t_ns,
            IfaceName::new(iface).unwrap(),
            CanId::standard(id).unwrap(),
            data,
        )
        .unwrap()
    }

    /// Rows by bus and id; the newest payload, the count, the rate over
    /// the span (9 gaps of 10 ms: 100 Hz) and the signals merged.
    #[test]
    fn a_row_per_bus_and_id_with_its_newest_payload_and_rate() {
        let mut table = FrameTable::default();
        for k in 0..10 {
            let t = k as f64 * 0.01;
            table.see(
                &frame("can1", 0x181, 0, &[k as u8, 2]),
                t,
                FrameUse::Decoded,
                &[1 + k % 2],
            );
            table.see(&frame("can0", 0x700, 0, &[5]), t, FrameUse::Protocol, &[]);
        }
        table.see(&frame("can0", 0x181, 0, &[]), 0.5, FrameUse::Unknown, &[]);
        let names: Vec<String> = ["a", "b", "c"].iter().map(|s| s.to_string()).collect();
        let rows = table.json(&names, None);
        let ids: Vec<String> = rows
            .iter()
            .map(|r| {
                format!(
                    "{} {}",
                    r["bus"].as_str().unwrap(),
                    r["id"].as_str().unwrap()
                )
            })
            .collect();
        assert_eq!(ids, ["can0 181", "can0 700", "can1 181"]);
        let row = &rows[2];
        assert_eq!(row["count"], 10);
        assert_eq!(row["data"], "09 02");
        assert_eq!(row["signals"], json!(["b", "c"]));
        assert!((row["rate_hz"].as_f64().unwrap() - 100.0).abs() < 1e-9);
        assert!((row["last_gap_s"].as_f64().unwrap() - 0.01).abs() < 1e-12);
        assert_eq!(rows[0]["used"], "no sensor of the rig");
        assert_eq!(rows[0]["rate_hz"], Value::Null);
    }

    /// Past MAX_ROWS ids, frames are counted, not listed.
    #[test]
    fn ids_past_the_limit_are_counted_not_listed() {
        let mut table = FrameTable::default();
        for id in 0..(MAX_ROWS as u16 + 5) {
            let bus = if id < 0x800 { "can0" } else { "can1" };
            table.see(&frame(bus, id % 0x800, 0, &[]), 0.0, FrameUse::Unknown, &[]);
        }
        assert_eq!(table.rows().len(), MAX_ROWS);
        assert_eq!(table.frames_not_listed, 5);
    }
}
