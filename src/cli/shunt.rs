//! `acq shunt`: a strain channel's recorded shunt step checked against
//! the step its shunt simulates; a session keeps the gain correction.

use std::path::PathBuf;
use std::time::Duration;

use acq_analysis::recording::Recording;
use acq_analysis::shunt::{check_recording, ShuntCheckError};
use acq_error::{AcqError, Result};
use acq_io::shunt_record::{self, SensorShunt, ShuntRecord};
use clap::Args;

#[derive(Args, Debug)]
pub struct ShuntArgs {
    /// A session directory (acq record; the check is kept in it) or a log.
    #[arg(value_name = "SESSION_DIR|LOG")]
    pub input: PathBuf,
    /// Rig file [default: the session's own copy of its rig].
    #[arg(long, value_name = "RIG.toml")]
    pub rig: Option<PathBuf>,
    /// The strain channel checked; its rig sensor states the shunt.
    #[arg(long, value_name = "NAME")]
    pub sensor: String,
    /// Start of the window that holds the switching (session time, `12s`).
    #[arg(long, value_name = "DURATION", value_parser = acq_io::input::parse_duration)]
    pub from: Duration,
    /// End of that window.
    #[arg(long, value_name = "DURATION", value_parser = acq_io::input::parse_duration)]
    pub to: Duration,
    /// Readings this close to the switching are left out (the amplifier's
    /// filter settling).
    #[arg(long, value_name = "DURATION", default_value = "250ms", value_parser = acq_io::input::parse_duration)]
    pub settle: Duration,
}

pub fn run_shunt(args: ShuntArgs) -> Result<()> {
    let (from_s, to_s) = (args.from.as_secs_f64(), args.to.as_secs_f64());
    if to_s <= from_s {
        return Err(AcqError::Config(format!(
            "--from {from_s} s to --to {to_s} s: the window must end after it starts"
        )));
    }
    let recording = Recording::open(&args.input, args.rig.as_deref())?;
    let sensor = recording.sensor_index(&args.sensor)?;
    let settle_ns = i64::try_from(args.settle.as_nanos()).unwrap_or(i64::MAX);
    let check =
        check_recording(&recording, sensor, from_s, to_s, settle_ns).map_err(|e| match e {
            ShuntCheckError::Read(e) => e,
            other => AcqError::Config(other.to_string()),
        })?;
    let tolerance = recording.rig.sensors[sensor]
        .record
        .shunt
        .map_or(0.0, |s| s.tolerance_pct);
    eprintln!("acq: {}", describe(&check, tolerance));
    let Some(session) = &recording.session else {
        eprintln!("acq: a log keeps no record; check the shunt of a session to correct its values");
        return Ok(());
    };
    let mut record = recording.shunt.clone().unwrap_or_else(|| ShuntRecord {
        session_start: acq_io::session::utc_text(session.session.started_unix_ns),
        sensors: Vec::new(),
    });
    record.replace(check);
    shunt_record::write(&args.input, &record).map_err(|e| {
        AcqError::io(
            format!("writing the shunt record into {}", args.input.display()),
            e,
        )
    })?;
    eprintln!(
        "acq: kept in {}; acq extract, align and view now multiply {}'s values by its gain",
        args.input.join(shunt_record::SHUNT_FILE).display(),
        args.sensor
    );
    Ok(())
}

/// One line: the step found, the step expected, the gain.
fn describe(check: &SensorShunt, tolerance_pct: f64) -> String {
    format!(
        "{}: step of {:.4} +- {:.4} at {:.3} s, {:.1} um/m where the shunt simulates {:.1} um/m ({:+.3} %, within the {tolerance_pct} % tolerance): gain {:.5} +- {:.5}",
        check.name,
        check.step,
        check.step_standard_error,
        check.switched_s,
        check.measured_strain * 1e6,
        check.expected_strain * 1e6,
        (check.measured_strain / check.expected_strain - 1.0) * 100.0,
        check.gain,
        check.gain_standard_uncertainty
    )
}
