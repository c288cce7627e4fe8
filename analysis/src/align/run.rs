//! `acq align`: a recording through the clock offsets, the aligner and
//! (optionally) the filter into the aligned CSV, with a summary that names
//! every problem met.

use std::fmt::Write as _;

use acq_error::{AcqError, Result};
use acq_io::output::TableOutput;
use acq_io::session::utc_text;
use acq_rig::{Interpolation, Rig};

use super::filter::{GaussianFilter, RISE_TIME_TIMES_CUTOFF};
use super::table::{Column, CsvTable, Mf4AlignedTable, ParquetAlignedTable};
use super::{Aligner, ChannelSpec, ChannelStats, GridSpec, RowSink};
use crate::recording::clocks::{offsets_ns, BusOffset, ClockSource};
use crate::recording::{Recording, SampleCounts};

/// A duration in seconds (see [`acq_io::input::parse_duration`]).
pub fn parse_duration_s(text: &str) -> std::result::Result<f64, String> {
    acq_io::input::parse_duration(text).map(|d| d.as_secs_f64())
}

/// About how many bytes the aligned CSV of `recording` takes at `rate_hz`
/// (one row per grid step over the session's recorded span, each value and
/// its gap flag about a dozen bytes), when the session says how long it
/// ran; `None` for a bare log.
pub fn expected_output_bytes(recording: &Recording, rate_hz: f64) -> Option<u64> {
    let info = &recording.session.as_ref()?.session;
    let span_s = (info.stopped_unix_ns? - info.started_unix_ns) as f64 * 1e-9;
    let columns = recording.rig.sensors.len() as f64;
    let bytes = span_s.max(0.0) * rate_hz * (16.0 + 12.0 * columns);
    bytes.is_finite().then_some(bytes as u64)
}

/// How long a sensor may be silent before the silence is a gap.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum GapTolerance {
    /// Multiples of the sensor's nominal period (the rig's `rate_hz`).
    Periods(f64),
    /// One duration for every sensor, ns.
    Fixed(i64),
}

impl GapTolerance {
    /// `3x` (periods) or a duration (`50ms`, `0.2s`).
    pub fn parse(text: &str) -> std::result::Result<Self, String> {
        let text = text.trim();
        if let Some(periods) = text.strip_suffix('x') {
            return match periods.parse::<f64>() {
                Ok(p) if p >= 1.0 && p.is_finite() => Ok(GapTolerance::Periods(p)),
                _ => Err(format!(
                    "'{text}': a gap tolerance in periods is a number >= 1 followed by x, e.g. 3x"
                )),
            };
        }
        let seconds = parse_duration_s(text)?;
        if seconds > 0.0 && seconds.is_finite() {
            Ok(GapTolerance::Fixed((seconds * 1e9).round() as i64))
        } else {
            Err(format!("'{text}': the gap tolerance must be positive"))
        }
    }

    pub fn for_rate(&self, rate_hz: f64) -> i64 {
        match *self {
            GapTolerance::Periods(p) => (p * 1e9 / rate_hz).round() as i64,
            GapTolerance::Fixed(ns) => ns,
        }
    }
}

/// As [`GapTolerance::parse`] reads it: `3x`, or seconds (`0.05s`).
impl std::fmt::Display for GapTolerance {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match *self {
            GapTolerance::Periods(periods) => write!(f, "{periods}x"),
            GapTolerance::Fixed(ns) => write!(f, "{}s", ns as f64 / 1e9),
        }
    }
}

impl Default for GapTolerance {
    fn default() -> Self {
        GapTolerance::Periods(3.0)
    }
}

/// A point in the recording: seconds from its start, or a UTC time.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum TimePoint {
    FromStartS(f64),
    UnixNs(i64),
}

impl TimePoint {
    /// `12.5` (seconds from the start) or `2026-11-21T20:33:55Z`.
    pub fn parse(text: &str) -> std::result::Result<Self, String> {
        if let Ok(seconds) = text.trim().parse::<f64>() {
            if seconds.is_finite() {
                return Ok(TimePoint::FromStartS(seconds));
            }
        }
        let time = humantime::parse_rfc3339_weak(text.trim()).map_err(|_| {
            format!("'{text}': give seconds from the session start (12.5) or a UTC time (2026-11-21T20:33:55Z)")
        })?;
        let ns = time
            .duration_since(std::time::UNIX_EPOCH)
            .map_err(|_| format!("'{text}' lies before 1970"))?
            .as_nanos();
        Ok(TimePoint::UnixNs(ns as i64))
    }

    fn offset_from(&self, t0_ns: i64) -> i64 {
        match *self {
            TimePoint::FromStartS(s) => (s * 1e9).round() as i64,
            TimePoint::UnixNs(ns) => ns - t0_ns,
        }
    }
}

/// What `acq align` is asked to do.
#[derive(Clone, Debug)]
pub struct AlignOptions {
    pub rate_hz: f64,
    /// One interpolation for every sensor instead of each sensor's own.
    pub method: Option<Interpolation>,
    pub max_gap: GapTolerance,
    pub from: Option<TimePoint>,
    pub to: Option<TimePoint>,
    /// Zero-phase low-pass cut-off, Hz.
    pub filter_hz: Option<f64>,
    /// `(bus name, offset ms)` overriding the rig.
    pub clock_offsets_ms: Vec<(String, f64)>,
}

impl AlignOptions {
    /// Refuses a rate or a filter that cannot make a table.
    pub fn check(&self) -> Result<()> {
        if !(self.rate_hz > 0.0 && self.rate_hz.is_finite() && self.rate_hz <= 1e6) {
            return Err(AcqError::Config(format!(
                "--rate must be a positive number of rows per second up to 1e6, got {}",
                self.rate_hz
            )));
        }
        if let Some(cutoff) = self.filter_hz {
            if !(cutoff > 0.0 && cutoff < self.rate_hz / 2.0) {
                return Err(AcqError::Config(format!(
                    "--filter {cutoff}: the cut-off must be above 0 and below half of --rate ({} Hz)",
                    self.rate_hz / 2.0
                )));
            }
        }
        Ok(())
    }
}

impl Default for AlignOptions {
    fn default() -> Self {
        AlignOptions {
            rate_hz: 100.0,
            method: None,
            max_gap: GapTolerance::default(),
            from: None,
            to: None,
            filter_hz: None,
            clock_offsets_ms: Vec::new(),
        }
    }
}

/// How every sensor is read, from the rig and the options.
pub fn channel_specs(
    rig: &Rig,
    method: Option<Interpolation>,
    max_gap: GapTolerance,
) -> Vec<ChannelSpec> {
    rig.sensors
        .iter()
        .map(|sensor| ChannelSpec {
            interpolation: method.unwrap_or(sensor.interpolation),
            max_gap_ns: max_gap.for_rate(sensor.rate_hz),
        })
        .collect()
}

/// What an align run saw.
#[derive(Clone, Debug)]
pub struct AlignSummary {
    pub counts: SampleCounts,
    pub sensors: Vec<String>,
    pub channels: Vec<ChannelStats>,
    pub clocks: Vec<BusOffset>,
    pub rows: u64,
    /// Time of `time_s = 0`, unix ns.
    pub t0_unix_ns: Option<i64>,
    pub notes: Vec<String>,
}

impl AlignSummary {
    /// One line per problem, in words.
    pub fn problems(&self) -> Vec<String> {
        let mut findings: Vec<(&str, String)> = Vec::new();
        for (name, stats) in self.sensors.iter().zip(&self.channels) {
            let mut say = |finding: String| findings.push((name.as_str(), finding));
            if stats.samples == 0 {
                say("never seen in the recording; its column is empty and flagged (is the sensor wired and in the rig as sent?)".into());
                continue;
            }
            if stats.backwards > 0 {
                say(format!(
                    "{} sample(s) went back in time (by up to {:.3} s) and were dropped; a log merged from two recordings? Sort it by time or align the parts separately",
                    stats.backwards,
                    stats.largest_step_back_ns as f64 / 1e9
                ));
            }
            if stats.duplicates > 0 {
                say(format!("{} sample(s) with the same time as the one before were dropped (duplicated frames?)", stats.duplicates));
            }
            if stats.late > 0 {
                say(format!("{} sample(s) arrived after their rows were written (more than the lateness out of order); they filled only later rows", stats.late));
            }
            if stats.gaps > 0 {
                say(format!(
                    "{} silence(s) longer than the gap tolerance (longest {:.3} s); flagged, not interpolated",
                    stats.gaps,
                    stats.longest_gap_ns as f64 / 1e9
                ));
            }
        }
        grouped(findings)
    }
}

impl std::fmt::Display for AlignSummary {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}; {} rows written", self.counts, self.rows)?;
        for clock in &self.clocks {
            if clock.source != ClockSource::Reference {
                write!(f, "\n  {clock}")?;
            }
        }
        for problem in self.problems() {
            write!(f, "\n  {problem}")?;
        }
        Ok(())
    }
}

/// Aligns `recording` into `output`: a CSV, Parquet or MF4 table.
pub fn align_recording(
    recording: &Recording,
    options: &AlignOptions,
    output: TableOutput,
) -> Result<AlignSummary> {
    options.check()?;
    let rig = &recording.rig;
    let clocks = recording.clock_offsets(&options.clock_offsets_ms)?;
    let offsets = offsets_ns(&clocks);
    let specs = channel_specs(rig, options.method, options.max_gap);
    let largest_offset = offsets.iter().map(|o| o.abs()).max().unwrap_or(0);
    let columns: Vec<Column> = rig
        .sensors
        .iter()
        .map(|s| Column {
            name: s.name.clone(),
            unit: s.unit().to_string(),
        })
        .collect();

    // The grid starts at the session's start, or at a log's first sample.
    let mut counts = SampleCounts::default();
    let mut aligner: Option<Aligner<Box<dyn RowSink<Error = AcqError>>>> = None;
    let mut output = Some(output);
    let session_start = recording.session_start_unix_ns();
    let mut t0 = None;
    let build = |t0_ns: i64,
                 output: TableOutput|
     -> Result<Aligner<Box<dyn RowSink<Error = AcqError>>>> {
        let from = options.from.map(|p| p.offset_from(t0_ns));
        let to = options.to.map(|p| p.offset_from(t0_ns));
        if let (Some(from), Some(to)) = (from, to) {
            if to < from {
                return Err(AcqError::Config(format!(
                    "--to ({:.3} s) lies before --from ({:.3} s)",
                    to as f64 / 1e9,
                    from as f64 / 1e9
                )));
            }
        }
        let mut grid = GridSpec {
            t0_ns,
            rate_hz: options.rate_hz,
            first_row: 0,
            last_row: None,
            lateness_ns: 500_000_000 + 2 * largest_offset,
        };
        if let Some(from) = from {
            grid.first_row = grid.row_at_or_after(t0_ns + from.max(0));
        }
        if let Some(to) = to {
            let after = grid.row_at_or_after(t0_ns + to.max(0));
            grid.last_row = Some(if grid.time_ns(after) == t0_ns + to.max(0) {
                after
            } else {
                after.saturating_sub(1)
            });
        }
        let comments = header_comments(recording, options, &clocks, t0_ns, session_start.is_some());
        let table = table_of(output, recording, &comments, &columns, grid)?;
        let sink: Box<dyn RowSink<Error = AcqError>> = match options.filter_hz {
            Some(cutoff) => Box::new(
                GaussianFilter::new(table, cutoff, options.rate_hz).map_err(AcqError::Config)?,
            ),
            None => table,
        };
        Ok(Aligner::new(grid, &specs, sink))
    };
    if let Some(start) = session_start {
        aligner = Some(build(start, output.take().expect("output"))?);
        t0 = Some(start);
    }
    recording.for_each_sample(&offsets, &mut counts, |sample| {
        let engine = match &mut aligner {
            Some(engine) => engine,
            None => {
                t0 = Some(sample.time_ns);
                aligner.insert(build(sample.time_ns, output.take().expect("output"))?)
            }
        };
        engine.push(sample.sensor, sample.time_ns, sample.value)
    })?;
    let Some(engine) = aligner else {
        return Err(recording.no_rig_sample());
    };
    let (sink, channels) = engine.finish()?;
    let rows = channels
        .first()
        .map_or(0, |c| c.rows_with_value + c.rows_without_value);
    drop(sink);
    Ok(AlignSummary {
        counts,
        sensors: rig.sensors.iter().map(|s| s.name.clone()).collect(),
        channels,
        clocks,
        rows,
        t0_unix_ns: t0,
        notes: recording.notes.clone(),
    })
}

/// The table the aligned rows go to, by the output's kind.
fn table_of(
    output: TableOutput,
    recording: &Recording,
    comments: &[String],
    columns: &[Column],
    grid: GridSpec,
) -> Result<Box<dyn RowSink<Error = AcqError>>> {
    Ok(match output {
        TableOutput::Csv(output) => {
            Box::new(CsvTable::new(output, comments, columns, grid.rate_hz)?)
        }
        TableOutput::Parquet(output) => {
            Box::new(ParquetAlignedTable::new(output, comments, columns, grid)?)
        }
        TableOutput::Arrow(sink) => Box::new(ParquetAlignedTable::to_arrow(
            sink, comments, columns, grid,
        )?),
        TableOutput::Mf4(file) => Box::new(Mf4AlignedTable::new(
            file,
            format!("{} (aligned)", recording.label),
            comments,
            columns,
            grid,
        )?),
    })
}

fn header_comments(
    recording: &Recording,
    options: &AlignOptions,
    clocks: &[BusOffset],
    t0_ns: i64,
    is_session: bool,
) -> Vec<String> {
    let mut lines = Vec::new();
    let origin = if is_session {
        "session start"
    } else {
        "first sample"
    };
    lines.push(format!(
        "acq align {} ({} {}, unix ns {t0_ns})",
        recording.label,
        origin,
        utc_text(t0_ns)
    ));
    lines.push(format!(
        "rig: {} ({})",
        recording.rig.name,
        recording.rig.path.display()
    ));
    lines.push(format!(
        "time_s: seconds from the {origin} on the reference clock; grid {} Hz",
        options.rate_hz
    ));
    let method = match options.method {
        Some(m) => format!("{} for every sensor", m.name()),
        None => "each sensor's own (rig `interpolation`, default linear)".into(),
    };
    lines.push(format!("interpolation: {method}"));
    let gap = match options.max_gap {
        GapTolerance::Periods(p) => format!("{p} sample periods"),
        GapTolerance::Fixed(ns) => format!("{} s", ns as f64 / 1e9),
    };
    lines.push(format!("gaps: a sensor silent longer than {gap} has no value there (empty cell, <sensor>_gap = 1); nothing before its first sample or after its last"));
    for clock in clocks {
        lines.push(format!("clock: {clock}"));
    }
    match options.filter_hz {
        None => lines.push("filter: none".into()),
        Some(fc) => {
            let mut text = String::new();
            let _ = write!(
                text,
                "filter: zero-phase Gaussian low-pass, -3 dB at {fc} Hz; a step rises 10-90 % in {:.1} ms, starting {:.1} ms before it, without overshoot",
                RISE_TIME_TIMES_CUTOFF / fc * 1e3,
                RISE_TIME_TIMES_CUTOFF / fc * 1e3 / 2.0
            );
            lines.push(text);
        }
    }
    for note in &recording.notes {
        lines.push(format!("note: {note}"));
    }
    lines
}

/// Findings of many sensors, one line per distinct finding: the sensors
/// that share it named together with their count (24 gauges silent at
/// once are one line, not 24), in the order first seen.
fn grouped(findings: Vec<(&str, String)>) -> Vec<String> {
    let mut groups: Vec<(Vec<&str>, String)> = Vec::new();
    for (name, finding) in findings {
        match groups.iter_mut().find(|(_, f)| *f == finding) {
            Some((names, _)) => names.push(name),
            None => groups.push((vec![name], finding)),
        }
    }
    groups
        .into_iter()
        .map(|(names, finding)| match names.len() {
            1 => format!("{}: {finding}", names[0]),
            n => format!("{} ({n} sensors): {finding}", names.join(", ")),
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::grouped;

    #[test]
    fn sensors_with_the_same_finding_share_one_line() {
        let silent = "1 silence(s) longer than the gap tolerance (longest 2.000 s)".to_string();
        let lines = grouped(vec![
            ("sg01", silent.clone()),
            ("load", "3 sample(s) dropped".into()),
            ("sg02", silent.clone()),
            ("sg03", silent.clone()),
        ]);
        assert_eq!(
            lines,
            vec![
                format!("sg01, sg02, sg03 (3 sensors): {silent}"),
                "load: 3 sample(s) dropped".to_string()
            ]
        );
    }
}
