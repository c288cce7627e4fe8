//! Arguments and runners of the offline commands: `acq align`, `acq extract`.

use std::path::PathBuf;

use acq_analysis::align::run::{align_recording, AlignOptions, GapTolerance, TimePoint};
use acq_analysis::extract::holds::HoldOptions;
use acq_analysis::recording::Recording;
use acq_error::Result;
use acq_io::output::TableOutput;
use acq_rig::Interpolation;
use clap::{Args, ValueEnum};

#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum MethodArg {
    Linear,
    Hold,
    Nearest,
}

impl From<MethodArg> for Interpolation {
    fn from(method: MethodArg) -> Self {
        match method {
            MethodArg::Linear => Interpolation::Linear,
            MethodArg::Hold => Interpolation::Hold,
            MethodArg::Nearest => Interpolation::Nearest,
        }
    }
}

/// `BUS=MS`.
fn parse_clock_offset(text: &str) -> std::result::Result<(String, f64), String> {
    let (bus, ms) = text
        .split_once('=')
        .ok_or_else(|| format!("'{text}': give BUS=MS, e.g. daq=12.5"))?;
    let ms: f64 = ms
        .trim_end_matches("ms")
        .parse()
        .map_err(|_| format!("'{text}': the offset after '=' is a number of milliseconds"))?;
    if !ms.is_finite() {
        return Err(format!("'{text}': the offset must be finite"));
    }
    Ok((bus.to_string(), ms))
}

#[derive(Args, Debug)]
pub struct AlignArgs {
    /// A session directory (acq record or acq import) or a log file (candump -L, Vector ASC or BLF, ASAM MF4).
    #[arg(value_name = "SESSION_DIR|LOG")]
    pub input: PathBuf,
    /// Rig file [default: the session's own copy of its rig].
    #[arg(long, value_name = "RIG.toml")]
    pub rig: Option<PathBuf>,
    /// Rows per second of the common time base.
    #[arg(long, default_value_t = AlignOptions::default().rate_hz)]
    pub rate: f64,
    /// Interpolation for every sensor [default: each sensor's own from the
    /// rig: linear for continuous values, hold for states].
    #[arg(long, value_enum)]
    pub method: Option<MethodArg>,
    /// Silence that counts as a gap: `3x` sample periods, or `50ms`, `0.2s`.
    #[arg(long, default_value_t = AlignOptions::default().max_gap, value_parser = GapTolerance::parse)]
    pub max_gap: GapTolerance,
    /// First row: seconds from the session start, or a UTC time.
    #[arg(long, value_parser = TimePoint::parse)]
    pub from: Option<TimePoint>,
    /// Last row: seconds from the session start, or a UTC time.
    #[arg(long, value_parser = TimePoint::parse)]
    pub to: Option<TimePoint>,
    /// Zero-phase Gaussian low-pass with this -3 dB cut-off, Hz (a step then
    /// rises 10-90 % in 0.34 / cutoff seconds, without overshoot).
    #[arg(long, value_name = "HZ")]
    pub filter: Option<f64>,
    /// A bus's clock minus the reference clock (overrides the rig): BUS=MS.
    #[arg(long = "clock-offset", value_name = "BUS=MS", value_parser = parse_clock_offset)]
    pub clock_offsets: Vec<(String, f64)>,
    /// Output table: CSV, Parquet when the name ends in `.parquet` (time as
    /// a UTC timestamp, units in the column metadata) or MF4 for `.mf4` (a
    /// channel group with units, gaps invalid); `-` writes CSV to stdout.
    #[arg(short = 'o', long = "output", value_name = "aligned.csv")]
    pub output: PathBuf,
}

pub fn run_align(args: AlignArgs) -> Result<()> {
    let recording = Recording::open(&args.input, args.rig.as_deref())?;
    for warning in &recording.rig.warnings {
        eprintln!("acq: warning: {warning}");
    }
    let options = AlignOptions {
        rate_hz: args.rate,
        method: args.method.map(Into::into),
        max_gap: args.max_gap,
        from: args.from,
        to: args.to,
        filter_hz: args.filter,
        clock_offsets_ms: args.clock_offsets,
    };
    options.check()?;
    let to_a_file = args.output.as_os_str() != "-";
    if let Some(bytes) =
        acq_analysis::align::run::expected_output_bytes(&recording, args.rate).filter(|_| to_a_file)
    {
        acq_io::output::refuse_if_disk_too_small(&args.output, bytes, "the aligned table")?;
    }
    let output = TableOutput::create(&args.output)?;
    let summary = align_recording(&recording, &options, output)?;
    // The summary ends "N rows written": to where, unless stdout.
    let to = written_to(&args.output).replacen("; written", "", 1);
    eprintln!("acq: aligned {}: {summary}{to}", recording.label);
    Ok(())
}

/// `; written to PATH` for an output file, nothing for stdout (`-`): the
/// last line of a command names the file it wrote.
fn written_to(output: &std::path::Path) -> String {
    match output.as_os_str() == "-" {
        true => String::new(),
        false => format!("; written to {}", output.display()),
    }
}

/// A duration on the command line (`3s`, `500ms`), ns; shown in seconds.
#[derive(Clone, Copy, Debug)]
pub struct DurationNs(pub i64);

impl std::fmt::Display for DurationNs {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}s", self.0 as f64 / 1e9)
    }
}

fn parse_duration_ns(text: &str) -> std::result::Result<DurationNs, String> {
    // At most MAX_DURATION_S (1e18 ns), so it fits an i64.
    acq_io::input::parse_duration(text).map(|d| DurationNs(d.as_nanos() as i64))
}

#[derive(Args, Debug)]
pub struct ExtractArgs {
    /// A session directory (acq record) or a log file.
    #[arg(value_name = "SESSION_DIR|LOG")]
    pub input: PathBuf,
    /// Rig file [default: the session's own copy of its rig].
    #[arg(long, value_name = "RIG.toml")]
    pub rig: Option<PathBuf>,
    /// A tensile test: write the force-displacement curve instead of holds.
    #[arg(long)]
    pub tensile: bool,
    /// Windows to summarise: `auto` (the steady holds of the load) or a CSV
    /// file with `name,start_s,end_s` (seconds from the session start).
    #[arg(
        long,
        default_value = "auto",
        value_name = "auto|FILE",
        conflicts_with = "tensile"
    )]
    pub windows: String,
    /// The load sensor [default: the rig's only force sensor].
    #[arg(long, value_name = "SENSOR")]
    pub load: Option<String>,
    /// Steady: the load's std over the rolling window is at most this, in
    /// the load's unit [default: 1 % of the load's range].
    #[arg(long, value_name = "VALUE")]
    pub steady_std: Option<f64>,
    /// Rolling window of the steadiness test.
    #[arg(long, default_value_t = DurationNs(HoldOptions::default().window_ns), value_parser = parse_duration_ns)]
    pub steady_window: DurationNs,
    /// Shortest hold kept (after trimming).
    #[arg(long, default_value_t = DurationNs(HoldOptions::default().min_hold_ns), value_parser = parse_duration_ns)]
    pub min_hold: DurationNs,
    /// Trimmed from both ends of a hold.
    #[arg(long, default_value_t = DurationNs(HoldOptions::default().settle_ns), value_parser = parse_duration_ns)]
    pub settle: DurationNs,
    /// Smallest mean load of a hold, as a fraction of the load's range.
    #[arg(long, default_value_t = HoldOptions::default().min_load_fraction)]
    pub min_load: f64,
    /// Tensile: the force sensor [default: the rig's only force sensor].
    #[arg(long, value_name = "SENSOR", requires = "tensile")]
    pub force: Option<String>,
    /// Tensile: the extensometer [default: the rig's first displacement sensor].
    #[arg(long, value_name = "SENSOR", requires = "tensile")]
    pub displacement: Option<String>,
    /// Tensile: bar diameter [default: the rig's [specimen]].
    #[arg(long, value_name = "MM", requires = "tensile")]
    pub diameter_mm: Option<f64>,
    /// Tensile: length the displacement is measured over [default: the rig's [specimen]].
    #[arg(long, value_name = "MM", requires = "tensile")]
    pub gauge_length_mm: Option<f64>,
    /// A bus's clock minus the reference clock (overrides the rig): BUS=MS.
    #[arg(long = "clock-offset", value_name = "BUS=MS", value_parser = parse_clock_offset)]
    pub clock_offsets: Vec<(String, f64)>,
    /// Output table (measured values, or the curve with --tensile): CSV, or
    /// Parquet when the name ends in `.parquet`; `-` is CSV on stdout.
    #[arg(
        short = 'o',
        long = "output",
        value_name = "OUT.csv",
        default_value = "-"
    )]
    pub output: PathBuf,
}

pub fn run_extract(args: ExtractArgs) -> Result<()> {
    use acq_analysis::extract::measured::write_measured;
    use acq_analysis::extract::run::{extract_holds, extract_tensile, specimen, WindowChoice};
    use acq_analysis::extract::tensile::write_curve;

    let recording = Recording::open(&args.input, args.rig.as_deref())?;
    for warning in &recording.rig.warnings {
        eprintln!("acq: warning: {warning}");
    }
    if args.tensile {
        let specimen = specimen(&recording, args.diameter_mm, args.gauge_length_mm)?;
        let report = extract_tensile(
            &recording,
            args.force.as_deref(),
            args.displacement.as_deref(),
            &args.clock_offsets,
        )?;
        write_curve(&args.output, &report.curve, &specimen)?;
        let curve = &report.curve;
        let max = curve.points[curve.max_index];
        eprintln!(
            "acq: tensile curve of {} from {} and {}: {} points; zero {:.4} kN / {:.4} mm; max {:.4} kN at {:.5} mm; {}; {}",
            recording.label,
            report.force_sensor,
            report.displacement_sensor,
            curve.points.len(),
            curve.force_zero_kn,
            curve.displacement_zero_mm,
            max.force_kn,
            max.displacement_mm,
            match curve.fracture_displacement_mm {
                Some(u) => format!("fracture at {u:.5} mm ({} points after it dropped)", curve.after_fracture),
                None => "no fracture found".into(),
            },
            report.counts
        );
        for note in &curve.notes {
            eprintln!("acq: note: {note}");
        }
        return Ok(());
    }
    let choice = if args.windows == "auto" {
        WindowChoice::Auto(HoldOptions {
            window_ns: args.steady_window.0.max(1),
            steady_std: args.steady_std,
            min_hold_ns: args.min_hold.0,
            settle_ns: args.settle.0,
            min_load_fraction: args.min_load,
        })
    } else {
        WindowChoice::File(PathBuf::from(&args.windows))
    };
    let report = extract_holds(
        &recording,
        &choice,
        args.load.as_deref(),
        &args.clock_offsets,
    )?;
    write_measured(&args.output, &report.values)?;
    eprintln!("acq: extracted {}: {}", recording.label, report.counts);
    if let Some(detection) = &report.detection {
        eprintln!(
            "acq: load {}: range {:.4}, steady below a std of {:.4}; {} hold(s)",
            report.load_sensor,
            detection.load_range,
            detection.steady_std,
            report.windows.len()
        );
    }
    for window in &report.windows {
        eprintln!(
            "acq:   {}: {:.2} .. {:.2} s",
            window.name,
            (window.start_ns - report.t0_ns) as f64 / 1e9,
            (window.end_ns - report.t0_ns) as f64 / 1e9
        );
    }
    for clock in &report.clocks {
        if clock.source != acq_analysis::recording::clocks::ClockSource::Reference {
            eprintln!("acq: {clock}");
        }
    }
    for note in report.notes() {
        eprintln!("acq: {note}");
    }
    let flagged: Vec<_> = report
        .values
        .iter()
        .filter(|v| !v.flags.is_empty())
        .collect();
    for value in &flagged {
        eprintln!(
            "acq: flagged {} {}: {} ({})",
            value.window,
            value.quantity,
            value.flags.join(";"),
            value.note
        );
    }
    eprintln!(
        "acq: {} values in {} window(s), {} flagged{}",
        report.values.len(),
        report.windows.len(),
        flagged.len(),
        written_to(&args.output)
    );
    Ok(())
}
