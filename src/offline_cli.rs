//! Arguments and runners of the offline commands: `acq align`, `acq extract`.

use std::path::PathBuf;

use acq_drivers::rig::Interpolation;
use clap::{Args, ValueEnum};

use crate::align::run::{align_recording, AlignOptions, GapTolerance, TimePoint};
use crate::error::{AcqError, Result};
use crate::output::Output;
use crate::recording::Recording;

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
    /// A session directory (acq record) or a log file (candump -L, ASC).
    #[arg(value_name = "SESSION_DIR|LOG")]
    pub input: PathBuf,
    /// Rig file [default: the session's own copy of its rig].
    #[arg(long, value_name = "RIG.toml")]
    pub rig: Option<PathBuf>,
    /// Rows per second of the common time base.
    #[arg(long, default_value_t = 100.0)]
    pub rate: f64,
    /// Interpolation for every sensor [default: each sensor's own from the
    /// rig: linear for continuous values, hold for states].
    #[arg(long, value_enum)]
    pub method: Option<MethodArg>,
    /// Silence that counts as a gap: `3x` sample periods, or `50ms`, `0.2s`.
    #[arg(long, default_value = "3x", value_parser = GapTolerance::parse)]
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
    /// Output CSV; `-` writes to stdout.
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
    if let Some(cutoff) = options.filter_hz {
        if !(cutoff > 0.0 && cutoff < options.rate_hz / 2.0) {
            return Err(AcqError::Config(format!(
                "--filter {cutoff}: the cut-off must be above 0 and below half of --rate ({} Hz)",
                options.rate_hz / 2.0
            )));
        }
    }
    let output = Output::create_complete_only(&args.output)?;
    let summary = align_recording(&recording, &options, output)?;
    eprintln!("acq: aligned {}: {summary}", recording.label);
    Ok(())
}
