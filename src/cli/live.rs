//! The command-line glue of the live commands: `record`, `replay`,
//! `simulate` and `session repair`. Each builds its runtime, wires the
//! SocketCAN (or log-file) bus into the library and reports.

use std::path::{Path, PathBuf};
use std::time::{Duration, SystemTime};

use acq_acquire::bus::logfile::LogFileBus;
use acq_acquire::bus::now_ns;
use acq_acquire::bus::socketcan::SocketCanBus;
use acq_acquire::record::status::StatusMode;
use acq_acquire::record::{self, RecordOptions, StopReason};
use acq_acquire::replay::{self, LogFiles, Pacing, Routing};
use acq_acquire::simulate::scenario::Scenario;
use acq_acquire::simulate::Simulation;
use acq_can::IfaceName;
use acq_error::{AcqError, Result};
use acq_io::session;
use clap::{Args, Subcommand};

#[derive(Args, Debug)]
pub struct RecordArgs {
    /// CAN interface to record (repeat for several buses).
    #[arg(long = "iface", required = true, value_name = "IFACE")]
    pub interfaces: Vec<String>,
    /// Rig file: decode live for the status (and --view), copy it into the
    /// session, and leave view-index.bin there for a quick `acq view`.
    #[arg(long, value_name = "RIG.toml")]
    pub rig: Option<PathBuf>,
    /// Session directory [default: sessions/<UTC start time>].
    #[arg(long, value_name = "DIR")]
    pub out: Option<PathBuf>,
    /// Stop after this long (`10s`, `5min`, `1h 30min`).
    #[arg(long, value_parser = parse_duration)]
    pub duration: Option<Duration>,
    /// Start a new raw file past this size (`1GiB`, `500MB`).
    #[arg(long, default_value = "1GiB", value_parser = parse_size)]
    pub max_file_size: u64,
    /// Send CANopen NMT "start all nodes" on the buses with CANopen sensors.
    #[arg(long)]
    pub nmt_start: bool,
    /// No live status (errors and warnings still go to stderr).
    #[arg(long, conflicts_with = "status_json")]
    pub quiet: bool,
    /// Live status as one JSON object per line on stdout.
    #[arg(long)]
    pub status_json: bool,
    /// A study at the rig (needs --rig): every hold becomes a case of the
    /// twin, the posterior is updated after each, and the next test point
    /// is named (on the page with --view, and here). Checked against the
    /// rig before recording starts; its last state is left in the session
    /// as study.json. The file's format: docs/src/study-at-the-rig.md.
    #[arg(long, value_name = "STUDY.toml")]
    pub study: Option<PathBuf>,
    /// Take each channel's zero over the recording's first DURATION (needs
    /// --rig; the machine at rest, hydraulics released): the session keeps
    /// it in zero.toml, and the page, the holds and the study show zeroed
    /// values once the window has closed. The raw frames are untouched.
    #[arg(long, value_name = "DURATION", value_parser = acq_io::input::parse_duration)]
    pub zero_before: Option<Duration>,
    /// With --zero-before: read the zero again over the last DURATION
    /// before the recording ends (the machine at rest again); the drift
    /// between the two enters every budget.
    #[arg(long, value_name = "DURATION", requires = "zero_before", value_parser = acq_io::input::parse_duration)]
    pub zero_after: Option<Duration>,
    // The page (needs --rig: it decodes through it); it stops serving when
    // the recording ends.
    #[command(flatten)]
    pub view: super::view::ViewArgs,
}

#[derive(Args, Debug)]
pub struct ReplayArgs {
    /// The log to play (candump -L, Vector ASC or BLF, ASAM MF4; told by its content).
    #[arg(value_name = "LOG")]
    pub log: PathBuf,
    /// Interface to send on; without it frames go out on the interfaces the log names.
    #[arg(long, value_name = "IFACE")]
    pub iface: Option<String>,
    /// Playback speed factor (2.0 = twice as fast).
    #[arg(long, default_value_t = 1.0)]
    pub speed: f64,
    /// Play the log N times.
    #[arg(long = "loop", default_value_t = 1, value_name = "N")]
    pub passes: usize,
    /// Send as fast as possible, ignoring the log's timing.
    #[arg(long)]
    pub ignore_timestamps: bool,
    /// Send frames logged on LOG_IFACE on BUS_IFACE (repeatable), e.g. can0=vcan0.
    #[arg(long = "map", value_name = "LOG_IFACE=BUS_IFACE", value_parser = parse_mapping)]
    pub map: Vec<(IfaceName, IfaceName)>,
}

#[derive(Args, Debug)]
pub struct SimulateArgs {
    /// The rig whose sensors are simulated.
    #[arg(long, value_name = "RIG.toml")]
    pub rig: PathBuf,
    /// What the sensors read over time. With a [twin] table the holds'
    /// levels come from the excavator twin at a stated (hidden) truth, at
    /// the test points listed (docs/src/study-at-the-rig.md).
    #[arg(long, value_name = "SCENARIO.toml")]
    pub scenario: PathBuf,
    /// Send on these interfaces, in real time: one for all buses, or one per rig bus in order.
    #[arg(
        long = "iface",
        value_name = "IFACE",
        required_unless_present = "output",
        conflicts_with = "output"
    )]
    pub interfaces: Vec<String>,
    /// Write a candump log instead of sending.
    #[arg(short = 'o', long = "output", value_name = "LOG")]
    pub output: Option<PathBuf>,
    /// Random seed: the same seed gives the same traffic.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Start time of a written log, Unix seconds [default: now].
    #[arg(long, value_name = "UNIX_S")]
    pub start: Option<f64>,
}

#[derive(Subcommand, Debug)]
pub enum SessionCommand {
    /// Rebuild session.toml from the raw files after a crash or kill.
    Repair {
        #[arg(value_name = "DIR")]
        dir: PathBuf,
    },
}

/// `10s`, `5min`, `1h 30min`: a positive duration.
fn parse_duration(text: &str) -> std::result::Result<Duration, String> {
    let duration = acq_io::input::parse_duration(text)?;
    if duration.is_zero() {
        return Err(format!("{text:?}: a recording lasts more than 0 s"));
    }
    Ok(duration)
}

/// `1GiB`, `500MB`, `4096`.
pub(super) fn parse_size(text: &str) -> std::result::Result<u64, String> {
    text.trim()
        .parse::<bytesize::ByteSize>()
        .map(|size| size.as_u64())
        .map_err(|e| format!("{text:?} is not a size like 1GiB or 500MB: {e}"))
        .and_then(|size| {
            if size == 0 {
                Err("the size must be > 0".into())
            } else {
                Ok(size)
            }
        })
}

fn parse_iface(text: &str) -> std::result::Result<IfaceName, String> {
    IfaceName::new(text).ok_or_else(|| {
        format!("{text:?} is not an interface name (1-15 characters, no spaces or '/')")
    })
}

fn parse_mapping(text: &str) -> std::result::Result<(IfaceName, IfaceName), String> {
    let (from, to) = text
        .split_once('=')
        .ok_or_else(|| format!("{text:?}: expected LOG_IFACE=BUS_IFACE, e.g. can0=vcan0"))?;
    Ok((parse_iface(from)?, parse_iface(to)?))
}

fn ifaces(names: &[String]) -> Result<Vec<IfaceName>> {
    names
        .iter()
        .map(|n| parse_iface(n).map_err(AcqError::Config))
        .collect()
}

pub fn run_record(args: RecordArgs) -> Result<()> {
    let interfaces = ifaces(&args.interfaces)?;
    let mut notes = Vec::new();
    let rig = match &args.rig {
        None => None,
        Some(path) => {
            let mut rig = acq_io::input::load_rig(path)?;
            // A transducer past its due date is said before the test, not after.
            for line in rig.calibration_status(&super::decode::today()) {
                if line.contains("PAST DUE") {
                    eprintln!("acq: warning: {line}");
                }
            }
            notes.extend(
                rig.assign_interfaces(&interfaces)
                    .map_err(AcqError::Config)?,
            );
            Some(rig)
        }
    };
    let session_dir = args.out.clone().unwrap_or_else(|| {
        Path::new("sessions").join(session::default_dir_name(SystemTime::now()))
    });
    // With a rig, the view's feed decodes along and writes view-index.bin at
    // the end (acq view then opens the session at once). With --view it also
    // serves the page, bound before recording starts: a taken port fails first.
    let view_address = args.view.options().resolve()?;
    if args.zero_before.is_some() && rig.is_none() {
        return Err(AcqError::Config(
            "--zero-before needs --rig RIG.toml: the rig says which channels read zero at rest"
                .into(),
        ));
    }
    if view_address.is_some() && rig.is_none() {
        return Err(AcqError::Config(
            "--view needs --rig RIG.toml: the page shows the rig's sensors".into(),
        ));
    }
    // The study is checked against the rig before anything is recorded:
    // the recording must never be what fails.
    let study = match (&args.study, &rig) {
        (Some(_), None) => {
            return Err(AcqError::Config(
                "--study needs --rig RIG.toml: the study reads the rig's holds".into(),
            ))
        }
        (Some(path), Some(rig)) => Some(super::rig_study::load(path, rig)?),
        (None, _) => None,
    };
    // Ctrl-C is caught from here on, before the page says where it is.
    let stop = super::interrupt::stop_on_signal_or(args.duration);
    let Watchers {
        observer,
        host,
        worker,
        messages,
    } = watchers(&args, rig.as_ref(), &session_dir, study, view_address)?;
    let status = if args.quiet {
        StatusMode::Quiet
    } else if args.status_json {
        StatusMode::Json
    } else {
        StatusMode::Human
    };
    // The zero record is described with the rig's ranges at the end.
    let rig_at_end = rig.clone();
    let options = RecordOptions {
        interfaces,
        rig,
        session_dir,
        max_file_bytes: args.max_file_size,
        nmt_start: args.nmt_start,
        status,
        command_line: std::env::args().collect::<Vec<_>>().join(" "),
        notes,
        observer,
        messages,
    };
    // Two workers: the readers never wait behind a disk write of the writer loop.
    let summary = acq_acquire::runtime(2)?.block_on(record::record(SocketCanBus, options, stop));
    // The study catches up with the last holds before the page stops.
    let last_panel = worker.map(acq_view::StudyWorker::finish);
    if let Some(host) = host {
        host.stop();
    }
    say_how_it_ended(summary?, rig_at_end.as_ref(), status, last_panel.as_ref())
}

/// Who watches a recording besides the terminal: the live page's feed
/// (with a rig), the study at the rig and the page's server.
struct Watchers {
    observer: Option<Box<dyn record::RecordObserver>>,
    host: Option<acq_view::ViewHost>,
    worker: Option<acq_view::StudyWorker>,
    messages: Option<std::sync::Mutex<std::sync::mpsc::Receiver<String>>>,
}

fn watchers(
    args: &RecordArgs,
    rig: Option<&acq_rig::Rig>,
    session_dir: &Path,
    study: Option<std::sync::Arc<acq_workflows::rig_study::RigStudy>>,
    view_address: Option<(std::net::SocketAddr, acq_view::Access)>,
) -> Result<Watchers> {
    let mut observer: Option<Box<dyn record::RecordObserver>> = None;
    let mut host = None;
    let mut worker = None;
    let mut messages = None;
    if let Some(rig) = rig {
        let name = session_dir
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_else(|| "session".into());
        let zero = args
            .zero_before
            .map(|before| super::zero::windows(before, args.zero_after))
            .transpose()?;
        let (feed, shared) = acq_view::live_session(
            &name,
            rig,
            acq_analysis::extract::holds::HoldOptions::default(),
            None,
            Some(session_dir),
            zero,
        );
        observer = Some(Box::new(feed));
        if let Some(study) = study {
            // The study's lines go above the status table, never under it.
            let (say, said) = std::sync::mpsc::channel::<String>();
            let say: Box<dyn Fn(&str) + Send> = if args.quiet || args.status_json {
                Box::new(|line: &str| eprintln!("acq: {line}"))
            } else {
                messages = Some(std::sync::Mutex::new(said));
                Box::new(move |line: &str| {
                    let _ = say.send(line.to_string());
                })
            };
            worker = Some(super::rig_study::start(study, vec![shared.clone()], say));
        }
        if let Some((addr, access)) = view_address {
            let names: Vec<&str> = rig.sensors.iter().map(|s| s.name.as_str()).collect();
            let pages = acq_view::Pages {
                sessions: vec![shared],
                study: worker.as_ref().map(acq_view::StudyWorker::panel),
                layout: args.view.layout(&names)?,
            };
            let started = acq_view::ViewHost::start(addr, access, pages)?;
            eprintln!("acq: view at {} (served while recording)", started.url());
            host = Some(started);
        }
    }
    Ok(Watchers {
        observer,
        host,
        worker,
        messages,
    })
}

/// The session's summary on stderr, and a failed write as the error.
fn say_how_it_ended(
    summary: record::RecordSummary,
    rig: Option<&acq_rig::Rig>,
    status: StatusMode,
    last_panel: Option<&serde_json::Value>,
) -> Result<()> {
    if let Some(panel) = last_panel {
        if let Some(words) = panel["next"]["words"].as_str() {
            eprintln!("acq: study: {words}");
        }
        let path = super::rig_study::write_last(&summary.session_dir, panel)?;
        eprintln!("acq: the study's last state: {}", path.display());
    }
    let info = &summary.session.session;
    if let (Ok(Some(zero)), Some(rig)) = (acq_io::zero_record::read(&summary.session_dir), rig) {
        for line in super::zero::describe(&zero, rig) {
            eprintln!("acq: {line}");
        }
    }
    if status != StatusMode::Quiet {
        eprintln!(
            "acq: session {}: {} frames in {}, {} dropped by the kernel, ended: {}",
            summary.session_dir.display(),
            info.frames,
            info.raw_files.join(", "),
            info.dropped_by_kernel,
            info.ended
        );
    }
    match summary.stop {
        StopReason::WriteFailed(message) => Err(AcqError::io(
            format!("recording to {}", summary.session_dir.display()),
            std::io::Error::other(message),
        )),
        _ => Ok(()),
    }
}

pub fn run_replay(args: ReplayArgs) -> Result<()> {
    if !(args.speed.is_finite() && args.speed > 0.0) {
        return Err(AcqError::Config(format!(
            "--speed {}: expected a number > 0",
            args.speed
        )));
    }
    let routing = Routing {
        map: args.map.clone(),
        default: args
            .iface
            .as_deref()
            .map(parse_iface)
            .transpose()
            .map_err(AcqError::Config)?,
    };
    let pacing = if args.ignore_timestamps {
        Pacing::AsFast
    } else {
        Pacing::timed(args.speed)
    };
    // Opened up front so a missing file fails before anything is sent.
    let mut log = LogFiles::open(vec![args.log.clone()])?;
    let summary = acq_acquire::runtime(1)?.block_on(replay::play(
        &SocketCanBus,
        |pass| log.next_frame(pass),
        &routing,
        pacing,
        args.passes,
    ))?;
    eprintln!("acq: played {}: {summary}", args.log.display());
    Ok(())
}

pub fn run_simulate(args: SimulateArgs) -> Result<()> {
    let rig = acq_io::input::load_rig(&args.rig)?;
    // A scenario with [twin] has its holds computed by the excavator twin
    // at the truth it states (acq_workflows::virtual_rig).
    acq_io::input::note_input(&args.scenario);
    let text =
        std::fs::read_to_string(&args.scenario).map_err(|e| AcqError::open(&args.scenario, e))?;
    let directory = args
        .scenario
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    let quantities = acq_analysis::extract::quantities::RigQuantities::of(&rig);
    let text = acq_workflows::virtual_rig::expand_twin_scenario(&text, directory, &quantities)
        .map_err(|e| AcqError::Config(format!("{}: {e}", args.scenario.display())))?
        .unwrap_or(text);
    let (scenario, curve) = Scenario::parse(&text, &args.scenario)?;
    let start_ns = match args.start {
        Some(seconds) if seconds.is_finite() && seconds >= 0.0 => (seconds * 1e9).round() as i64,
        Some(seconds) => {
            return Err(AcqError::Config(format!(
                "--start {seconds}: expected Unix seconds >= 0"
            )))
        }
        None => now_ns(),
    };
    let mut simulation = Simulation::new(&rig, scenario, curve, args.seed, start_ns)?;
    if !simulation.unspecified_sensors.is_empty() {
        eprintln!(
            "acq: warning: the scenario gives no values for {}; they send 0",
            simulation.unspecified_sensors.join(", ")
        );
    }
    let runtime = acq_acquire::runtime(1)?;
    let summary = if let Some(path) = &args.output {
        // A candump line of a classic frame is about 40 bytes; FD ones are longer.
        let bytes = simulation.expected_frames().saturating_mul(64);
        acq_io::output::refuse_if_disk_too_small(path, bytes, "the simulated log")?;
        let bus = LogFileBus::writing(path)?;
        let summary = runtime.block_on(replay::play(
            &bus,
            |_| Ok(simulation.next_frame()),
            &Routing::default(),
            Pacing::AsFast,
            1,
        ))?;
        bus.flush()
            .map_err(|e| AcqError::io(format!("writing {}", path.display()), e))?;
        summary
    } else {
        let interfaces = ifaces(&args.interfaces)?;
        let routing = Routing::for_rig(&rig, &interfaces)?;
        runtime.block_on(replay::play(
            &SocketCanBus,
            |_| Ok(simulation.next_frame()),
            &routing,
            Pacing::timed(1.0),
            1,
        ))?
    };
    eprintln!("acq: played the simulated rig: {summary}");
    eprintln!(
        "acq: {} frames lost on purpose (devices' drop probability)",
        simulation.frames_dropped
    );
    Ok(())
}

pub fn run_session(command: SessionCommand) -> Result<()> {
    match command {
        SessionCommand::Repair { dir } => {
            let report = session::repair(&dir)?;
            eprintln!(
                "acq: rebuilt {}: {} frames in {} file(s){}",
                dir.join(session::SESSION_FILE).display(),
                report.frames,
                report.files,
                if report.truncated_bytes > 0 {
                    format!(
                        ", cut {} bytes of an unfinished last line",
                        report.truncated_bytes
                    )
                } else {
                    String::new()
                }
            );
            Ok(())
        }
    }
}
