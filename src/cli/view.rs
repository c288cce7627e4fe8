//! `acq view`: the live page over recorded sessions.

use std::path::PathBuf;
use std::sync::{Arc, Mutex};

use acq_io::error::{AcqError, Result};
use acq_view::{open_session, Source, ViewArgs, ViewHost, DEFAULT_ADDRESS};
use clap::Args;

#[derive(Args, Debug)]
pub struct ViewCommandArgs {
    /// Session directories written by acq record (one section each).
    #[arg(value_name = "SESSION_DIR", required = true)]
    pub sessions: Vec<PathBuf>,
    #[command(flatten)]
    pub view: ViewArgs,
}

pub fn run_view(mut args: ViewCommandArgs) -> Result<()> {
    if args.view.view.is_none() {
        args.view.view = Some(DEFAULT_ADDRESS.into());
    }
    let (addr, access) = args
        .view
        .resolve()?
        .ok_or_else(|| AcqError::Config("--view: an address is needed".into()))?;
    let mut sessions = Vec::new();
    for dir in &args.sessions {
        let name = dir
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_else(|| dir.display().to_string());
        let started = std::time::Instant::now();
        let (view, source) = open_session(dir, &name)?;
        let how = match source {
            Source::Index => format!("from its {}", acq_view::index::FILE),
            Source::Recording(Ok(())) => {
                format!(
                    "from the recording; {} written for the next time",
                    acq_view::index::FILE
                )
            }
            Source::Recording(Err(why)) => {
                format!(
                    "from the recording ({} not written: {why})",
                    acq_view::index::FILE
                )
            }
        };
        eprintln!(
            "acq: {}: {} sensors, {} hold(s), read in {:.2} s {how}",
            dir.display(),
            view.sensors.len(),
            view.holds.len(),
            started.elapsed().as_secs_f64()
        );
        sessions.push(Arc::new(Mutex::new(view)));
    }
    let host = ViewHost::start(addr, access, sessions)?;
    eprintln!("acq: view at {} (Ctrl-C to stop)", host.url());
    host.serve_until_interrupted();
    Ok(())
}
