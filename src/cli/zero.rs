//! `acq zero`: a recorded session's zero record, taken offline as the
//! recorder takes it live (`acq record --zero-before`), and what it says.

use std::path::PathBuf;
use std::time::Duration;

use acq_analysis::recording::Recording;
use acq_analysis::zero::{take, ZeroWindows};
use acq_error::{AcqError, Result};
use acq_io::zero_record::{self, ZeroRecord};
use acq_rig::Rig;
use clap::Args;

#[derive(Args, Debug)]
pub struct ZeroArgs {
    /// A session directory written by acq record.
    #[arg(value_name = "SESSION_DIR")]
    pub session: PathBuf,
    /// The rest state before the test: the session's first DURATION (`3s`).
    #[arg(long, value_name = "DURATION", value_parser = acq_io::input::parse_duration)]
    pub before: Duration,
    /// The rest state after the test: the last DURATION before the last
    /// sample. The zero's drift between the two enters every budget.
    #[arg(long, value_name = "DURATION", value_parser = acq_io::input::parse_duration)]
    pub after: Option<Duration>,
}

/// The zero windows of `--before` / `--after` (and of `acq record`'s
/// `--zero-before` / `--zero-after`).
pub fn windows(before: Duration, after: Option<Duration>) -> Result<ZeroWindows> {
    ZeroWindows::new(before.as_secs_f64(), after.map(|d| d.as_secs_f64())).map_err(AcqError::Config)
}

pub fn run_zero(args: ZeroArgs) -> Result<()> {
    if !args.session.is_dir() {
        return Err(AcqError::Config(format!(
            "{}: give a session directory written by acq record; a zero is kept beside the recording",
            args.session.display()
        )));
    }
    let windows = windows(args.before, args.after)?;
    let recording = Recording::open_session(&args.session)?;
    let taken = take(&recording, windows, "acq zero")?;
    rest_windows(&args, &taken)?;
    if taken.record.sensors.is_empty() {
        return Err(AcqError::Config(format!(
            "{}: no channel to zero sent a value in the first {:?} ({}); a channel is zeroed when its rig sensor reads zero at rest (zero_at_rest)",
            recording.label, args.before, taken.counts
        )));
    }
    zero_record::write(&args.session, &taken.record).map_err(|e| {
        AcqError::io(
            format!("writing the zero record into {}", args.session.display()),
            e,
        )
    })?;
    for line in describe(&taken.record, &recording.rig) {
        eprintln!("acq: {line}");
    }
    for name in &taken.missing {
        eprintln!("acq: warning: {name}: no value in the zero window; it is not zeroed");
    }
    eprintln!(
        "acq: zero record written to {}; acq extract, align and view now give zeroed values",
        args.session.join(zero_record::ZERO_FILE).display()
    );
    Ok(())
}

/// A zero window is a rest inside the recording, or nothing is written: a
/// window past the recording's end, windows that overlap, a window that
/// reaches into a hold, and a channel that moves in a window are refused,
/// each named, with the window to use.
fn rest_windows(args: &ZeroArgs, taken: &acq_analysis::zero::TakenZero) -> Result<()> {
    let recorded_s = taken.recorded_s;
    let before_s = args.before.as_secs_f64();
    let after_s = args.after.map(|a| a.as_secs_f64());
    if before_s >= recorded_s {
        return Err(AcqError::Config(format!(
            "--before {before_s} s: the recording is {recorded_s:.1} s long, so the window would be the whole test; give the rest before the load, e.g. --before {:.1}s",
            (recorded_s / 10.0).max(0.1)
        )));
    }
    if let Some(after_s) = after_s {
        if before_s + after_s > recorded_s {
            return Err(AcqError::Config(format!(
                "--before {before_s} s and --after {after_s} s overlap in a recording {recorded_s:.1} s long: the windows are the rests before and after the test, which lies between them"
            )));
        }
    }
    // A window inside a hold is steady and no rest: the load's start and
    // end bound the windows.
    let (before_at_most, after_at_most) = windows_at_rest(taken);
    if let Some((hold, load_on_s, _)) = taken.holds_s.first() {
        if before_s > *load_on_s {
            return Err(AcqError::Config(format!(
                "--before {before_s} s reaches into {hold}, under load from {load_on_s:.1} s: a zero there takes the load for zero; {before_at_most}"
            )));
        }
    }
    if let (Some(after_s), Some((hold, _, load_off_s))) = (after_s, taken.holds_s.last()) {
        if recorded_s - after_s < *load_off_s {
            return Err(AcqError::Config(format!(
                "--after {after_s} s reaches back into {hold}, under load until {load_off_s:.1} s of {recorded_s:.1}: a zero there takes the load for zero; {after_at_most}"
            )));
        }
    }
    if !taken.not_at_rest.is_empty() {
        return Err(AcqError::Config(format!(
            "no zero written: the window is no rest for {} channel(s):\n  {}\n{before_at_most}; {after_at_most}",
            taken.not_at_rest.len(),
            acq_analysis::zero::shown_lines(&taken.not_at_rest)
        )));
    }
    Ok(())
}

/// What to give instead, for the before and the after window: a window
/// that ends (starts) with a margin before the load leaves its rest level
/// (after it is back), where the load channel says when.
fn windows_at_rest(taken: &acq_analysis::zero::TakenZero) -> (String, String) {
    // Half the rest: the load's 100 ms means say where it moved, not
    // where a slow ramp began.
    // A recording that starts (ends) in a hold has its level there: the
    // hold bounds the rest too.
    let first_load_on_s = taken.holds_s.first().map(|(_, on_s, _)| *on_s);
    let last_load_off_s = taken.holds_s.last().map(|(_, _, off_s)| *off_s);
    let moves_s = match (taken.load_moves_s, first_load_on_s, last_load_off_s) {
        (Some((rises_s, settles_s)), on_s, off_s) => Some((
            on_s.map_or(rises_s, |on_s| rises_s.min(on_s)),
            off_s.map_or(settles_s, |off_s| settles_s.max(off_s)),
        )),
        (None, Some(on_s), Some(off_s)) => Some((on_s, off_s)),
        _ => None,
    };
    match moves_s {
        Some((rises_s, settles_s)) => {
            let before = match rises_s / 2.0 {
                s if s >= 0.1 => format!(
                    "give --before {s:.1}s at most (the load leaves its rest at {rises_s:.1} s)"
                ),
                _ => "the recording starts under load: no rest before the test; zero from the rest after it with --after, or in another recording".into(),
            };
            let rest_after_s = taken.recorded_s - settles_s;
            let after = match rest_after_s / 2.0 {
                s if s >= 0.1 => format!(
                    "give --after {s:.1}s at most (the load is back at rest from {settles_s:.1} s of {:.1})",
                    taken.recorded_s
                ),
                _ => "the recording ends under load: no rest after the test".into(),
            };
            (before, after)
        }
        None => (
            "give a shorter --before that ends before the load is applied".into(),
            "a shorter --after that starts after it is removed".into(),
        ),
    }
}

/// A line per zeroed channel: its zero, its zero return, and a warning
/// where the channel was plainly not at rest (a zero beyond 2 % of its
/// range).
pub fn describe(record: &ZeroRecord, rig: &Rig) -> Vec<String> {
    let mut lines = vec![format!(
        "zero of {} channels, taken by {} over the first {} s{}",
        record.sensors.len(),
        record.taken_by,
        record.before_s,
        record
            .after_s
            .map(|s| format!(" and the last {s} s"))
            .unwrap_or_default()
    )];
    for zero in &record.sensors {
        let unit = &zero.unit;
        let mut line = format!(
            "  {}: zero {:.4} {unit} +- {:.4} ({} samples)",
            zero.name,
            zero.offset(),
            zero.before.std_of_mean().unwrap_or(0.0),
            zero.before.samples
        );
        if let Some(drift) = zero.zero_return() {
            line.push_str(&format!(", zero return {drift:+.4} {unit}"));
        }
        let range = rig
            .sensor(&zero.name)
            .and_then(|(_, s)| s.range)
            .map(|[low, high]| high - low);
        if let Some(span) = range {
            if zero.offset().abs() > 0.02 * span {
                line.push_str(&format!(
                    "; WARNING: {:.1} % of its range: was it at rest? Take the zero again over a rest state",
                    100.0 * zero.offset().abs() / span
                ));
            }
        }
        lines.push(line);
    }
    lines
}
