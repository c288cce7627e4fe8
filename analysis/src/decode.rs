//! `acq decode`: logs -> one CSV row per decoded value.
//!
//! Two routes: through DBC files (every signal of every known message) and
//! through a rig (each sensor in its own protocol). Both stream: memory does
//! not grow with the log. The DBC route is the throughput-critical one, so
//! every row's constant part (`,0x123,Message,Signal,` and `,unit\n`) is
//! built once per signal and a row costs four `memcpy`s and a float format.

use std::io::Write;

use acq_drivers::canopen::HeartbeatEvent;
use acq_drivers::dbc::{push_shortest_f64, DbcDatabase, FrameDecodeError};
use acq_drivers::rig::Rig;
use acq_drivers::sensors::{FrameUse, SensorDecoder, SensorEvent};
use acq_drivers::FrameKind;
use acq_io::error::Result;
use acq_io::input::{for_each_record, BadLines, LogInput, ScanCounts};
use acq_io::output::{csv_field, Output};

/// The fixed header of the DBC route.
pub const DBC_HEADER: &str = "time_s,iface,can_id,message,signal,value,unit";

/// What a decode run saw; printed to stderr as the summary.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct DecodeSummary {
    pub scan: ScanCounts,
    /// Frames with at least one value written.
    pub decoded: u64,
    /// Data frames whose id no DBC (or sensor) knows.
    pub unknown: u64,
    /// Frames shorter than their message, or with an undefined multiplexer value.
    pub undecodable: u64,
    pub error_frames: u64,
    pub remote_frames: u64,
    pub rows: u64,
}

impl DecodeSummary {
    /// Frames and lines that could not be used.
    pub fn bad(&self) -> u64 {
        self.scan.malformed_lines + self.undecodable
    }
}

impl std::fmt::Display for DecodeSummary {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "frames read {}, decoded {}, unknown {}, bad {} ({} malformed lines, {} frames not matching their message), error frames {}, remote frames {}; {} values written",
            self.scan.frames,
            self.decoded,
            self.unknown,
            self.bad(),
            self.scan.malformed_lines,
            self.undecodable,
            self.error_frames,
            self.remote_frames,
            self.rows
        )
    }
}

/// Row pieces of one signal that do not change from frame to frame.
struct SignalRow {
    /// `,0x123,Message,Signal,`
    middle: Vec<u8>,
    /// `,unit\n`
    tail: Vec<u8>,
}

/// Options of the DBC route.
#[derive(Clone, Copy, Debug)]
pub struct DbcDecodeOptions {
    pub bad_lines: BadLines,
    /// Append a `label` column with the value-table label.
    pub labels: bool,
}

/// Decodes every frame of `inputs` through `database` into `output`.
pub fn decode_with_dbc(
    inputs: &mut [LogInput],
    database: &DbcDatabase,
    options: DbcDecodeOptions,
    output: &mut Output,
) -> Result<DecodeSummary> {
    let rows: Vec<Vec<SignalRow>> = database
        .messages()
        .iter()
        .map(|message| {
            message
                .signals
                .iter()
                .map(|signal| SignalRow {
                    middle: format!(
                        ",{},{},{},",
                        message.id,
                        csv_field(&message.name),
                        csv_field(&signal.name)
                    )
                    .into_bytes(),
                    tail: format!(",{}", csv_field(&signal.unit)).into_bytes(),
                })
                .collect()
        })
        .collect();

    output.buffer.extend_from_slice(DBC_HEADER.as_bytes());
    if options.labels {
        output.buffer.extend_from_slice(b",label");
    }
    output.buffer.push(b'\n');

    let mut summary = DecodeSummary::default();
    for_each_record(inputs, options.bad_lines, &mut summary.scan, |_, record| {
        let frame = &record.frame;
        match frame.kind {
            FrameKind::Error { .. } => summary.error_frames += 1,
            FrameKind::Remote { .. } => summary.remote_frames += 1,
            FrameKind::Data { .. } | FrameKind::Fd { .. } => {
                let Some(index) = database.message_index(frame.id) else {
                    summary.unknown += 1;
                    return Ok(());
                };
                let message = &database.messages()[index];
                let message_rows = &rows[index];
                let payload = frame.payload();
                let buffer = &mut output.buffer;
                let mut written = 0u64;
                let result = message.decode(payload, |signal, value| {
                    let row = &message_rows[signal];
                    buffer.extend_from_slice(record.timestamp_text.as_bytes());
                    buffer.push(b',');
                    buffer.extend_from_slice(frame.iface.as_str().as_bytes());
                    buffer.extend_from_slice(&row.middle);
                    value.push_shortest(buffer);
                    buffer.extend_from_slice(&row.tail);
                    if options.labels {
                        buffer.push(b',');
                        if let Some(label) = message.signals[signal].label(payload) {
                            buffer.extend_from_slice(csv_field(label).as_bytes());
                        }
                    }
                    buffer.push(b'\n');
                    written += 1;
                });
                match result {
                    Ok(()) => {
                        summary.decoded += 1;
                        summary.rows += written;
                    }
                    // Refused before anything was written.
                    Err(
                        FrameDecodeError::Short { .. }
                        | FrameDecodeError::UnknownMultiplexerValue(_),
                    ) => {
                        summary.undecodable += 1;
                    }
                }
                output.maybe_flush()?;
            }
        }
        Ok(())
    })?;
    Ok(summary)
}

/// Prints the summary line to stderr.
pub fn report(summary: &DecodeSummary) {
    let _ = writeln!(std::io::stderr(), "acq decode: {summary}");
}

/// The fixed header of the rig route.
pub const RIG_HEADER: &str = "time_s,sensor,value,unit";

/// Decodes every frame of `inputs` through the rig's sensors into `output`.
/// A missing sample (J1939 "not available"/"error") is a row with an empty
/// value; CANopen heartbeat changes and losses are reported on stderr.
pub fn decode_with_rig(
    inputs: &mut [LogInput],
    rig: &Rig,
    bad_lines: BadLines,
    output: &mut Output,
) -> Result<DecodeSummary> {
    let mut decoder = SensorDecoder::new(rig);
    // Constant row parts: `,sensor,` and `,unit\n`.
    let rows: Vec<(Vec<u8>, Vec<u8>)> = rig
        .sensors
        .iter()
        .map(|s| {
            (
                format!(",{},", s.name).into_bytes(),
                format!(",{}\n", s.unit()).into_bytes(),
            )
        })
        .collect();
    output.buffer.extend_from_slice(RIG_HEADER.as_bytes());
    output.buffer.push(b'\n');
    let mut summary = DecodeSummary::default();
    let mut last_time_ns = None;
    let mut heartbeats: Vec<(usize, HeartbeatEvent)> = Vec::new();
    for_each_record(inputs, bad_lines, &mut summary.scan, |_, record| {
        let buffer = &mut output.buffer;
        last_time_ns = Some(record.frame.timestamp_ns);
        let used = decoder.decode(&record.frame, |event| match event {
            SensorEvent::Sample(sample) => {
                let (middle, tail) = &rows[sample.sensor];
                buffer.extend_from_slice(record.timestamp_text.as_bytes());
                buffer.extend_from_slice(middle);
                if let Some(value) = sample.value {
                    push_shortest_f64(buffer, value);
                }
                buffer.extend_from_slice(tail);
                summary.rows += 1;
            }
            SensorEvent::Heartbeat { bus, event } => heartbeats.push((bus, event)),
        });
        match used {
            FrameUse::Decoded => summary.decoded += 1,
            FrameUse::Unknown => summary.unknown += 1,
            FrameUse::Undecodable => summary.undecodable += 1,
            FrameUse::Protocol => {}
            FrameUse::NotData => match record.frame.kind {
                FrameKind::Error { .. } => summary.error_frames += 1,
                _ => summary.remote_frames += 1,
            },
        }
        output.maybe_flush()
    })?;
    if let Some(end) = last_time_ns {
        decoder.check_heartbeats(end, |event| {
            if let SensorEvent::Heartbeat { bus, event } = event {
                heartbeats.push((bus, event));
            }
        });
    }
    for (bus, event) in heartbeats {
        eprintln!(
            "acq decode: {}",
            describe_heartbeat(rig, &decoder, bus, event)
        );
    }
    Ok(summary)
}

fn describe_heartbeat(
    rig: &Rig,
    decoder: &SensorDecoder<'_>,
    bus: usize,
    event: HeartbeatEvent,
) -> String {
    let sensors_on = |node: u8| {
        let names: Vec<&str> = decoder
            .node_sensors(bus, node)
            .map(|i| rig.sensors[i].name.as_str())
            .collect();
        names.join(", ")
    };
    let seconds = |ns: i64| ns as f64 / 1e9;
    match event {
        HeartbeatEvent::StateChanged {
            node,
            state,
            time_ns,
        } => {
            format!(
                "{:.6}: CANopen node 0x{node:02X} ({}) is {state:?}",
                seconds(time_ns),
                sensors_on(node)
            )
        }
        HeartbeatEvent::Lost {
            node,
            last_seen_ns,
            time_ns,
        } => format!(
            "{:.6}: CANopen node 0x{node:02X} ({}) LOST: no heartbeat since {}",
            seconds(time_ns),
            sensors_on(node),
            last_seen_ns
                .map(|t| format!("{:.6}", seconds(t)))
                .unwrap_or_else(|| "the start".into())
        ),
    }
}
