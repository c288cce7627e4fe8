//! `acq view`: the live page over recorded sessions.

use std::path::PathBuf;
use std::sync::{Arc, Mutex};

use acq_error::{AcqError, Result};
use acq_view::layout::Layout;
use acq_view::{open_session, Source, ViewHost, ViewOptions, DEFAULT_ADDRESS};
use clap::Args;

#[derive(Args, Debug)]
pub struct ViewCommandArgs {
    /// Session directories written by acq record (one section each).
    #[arg(value_name = "SESSION_DIR", required = true)]
    pub sessions: Vec<PathBuf>,
    /// A study at the rig over the sessions' holds: the same panel a
    /// recording with --study shows (the holds of several sessions in the
    /// order given).
    #[arg(long, value_name = "STUDY.toml")]
    pub study: Option<PathBuf>,
    #[command(flatten)]
    pub view: ViewArgs,
}

/// `--view [HOST:PORT]` and `--view-remote`, which every command that
/// serves the page shares.
#[derive(Args, Clone, Debug, Default)]
pub struct ViewArgs {
    /// Serve a page of every signal, live, at HOST:PORT (127.0.0.1:8750, on
    /// this machine only, when no address is given). Open the URL printed.
    #[arg(long, value_name = "HOST:PORT", num_args = 0..=1, default_missing_value = DEFAULT_ADDRESS)]
    pub view: Option<String>,
    /// Let --view serve an address other machines can reach. Every request
    /// then needs the random token in the URL printed at start.
    #[arg(long, requires = "view")]
    pub view_remote: bool,
    /// The page's plots as a layout file sets them out (which signals in
    /// which plot; the page's "Save layout" writes one), instead of one
    /// plot per sensor kind.
    #[arg(long, value_name = "LAYOUT.json")]
    pub layout: Option<PathBuf>,
}

impl ViewArgs {
    /// `--layout`'s file, checked against the signals the page shows.
    pub fn layout(&self, known: &[&str]) -> Result<Option<Layout>> {
        let Some(path) = &self.layout else {
            return Ok(None);
        };
        if self.view.is_none() {
            return Err(AcqError::Config(
                "--layout sets out the page of --view; give --view too".into(),
            ));
        }
        let text = acq_io::input::read_text(path).map_err(|e| AcqError::open(path, e))?;
        acq_io::input::note_input(path);
        Layout::parse(&text, known)
            .map(Some)
            .map_err(|e| AcqError::Config(format!("{}: {e}", path.display())))
    }

    pub fn options(&self) -> ViewOptions {
        ViewOptions {
            address: self.view.clone(),
            remote: self.view_remote,
        }
    }
}

pub fn run_view(mut args: ViewCommandArgs) -> Result<()> {
    if args.view.view.is_none() {
        args.view.view = Some(DEFAULT_ADDRESS.into());
    }
    let (addr, access) = args
        .view
        .options()
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
    let worker = match &args.study {
        Some(path) => {
            // The first session's own copy of its rig.
            let rig = acq_analysis::recording::Recording::open_session(&args.sessions[0])?.rig;
            let study = super::rig_study::load(path, &rig)?;
            let say: Box<dyn Fn(&str) + Send> = Box::new(|line: &str| eprintln!("acq: {line}"));
            Some(super::rig_study::start(study, sessions.clone(), say))
        }
        None => None,
    };
    let names: Vec<String> = sessions
        .iter()
        .flat_map(|s| {
            let view = s.lock().unwrap_or_else(|p| p.into_inner());
            view.sensors
                .iter()
                .map(|x| x.name.clone())
                .collect::<Vec<_>>()
        })
        .collect();
    let layout = args
        .view
        .layout(&names.iter().map(String::as_str).collect::<Vec<_>>())?;
    let pages = acq_view::Pages {
        sessions,
        study: worker.as_ref().map(acq_view::StudyWorker::panel),
        layout,
    };
    let host = ViewHost::start(addr, access, pages)?;
    // Listening for Ctrl-C before saying so.
    let stop = super::interrupt::interrupted();
    eprintln!("acq: view at {} (Ctrl-C to stop)", host.url());
    host.serve_until(stop);
    drop(worker);
    Ok(())
}
