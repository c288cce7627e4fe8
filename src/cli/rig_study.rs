//! `--study STUDY.toml` on `acq record` and `acq view`: a study at the rig
//! (`acq_workflows::rig_study`) fed the page's holds (`acq_view::study`).
//! Glue only: the view knows nothing of calibration, the study nothing of
//! the page.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use acq_analysis::extract::measured::MeasuredValue;
use acq_analysis::extract::quantities::RigQuantities;
use acq_error::{AcqError, Result};
use acq_rig::Rig;
use acq_view::{SharedSession, StudyWorker};
use acq_workflows::rig_study::tracker::Tracker;
use acq_workflows::rig_study::RigStudy;
use serde_json::Value;

/// The file a finished `acq record --study` leaves in the session: the
/// study's last panel, as `/api/state` showed it.
pub const STUDY_FILE: &str = "study.json";

/// Reads and checks the study against the rig: refused here, before
/// anything is recorded.
pub fn load(path: &Path, rig: &Rig) -> Result<Arc<RigStudy>> {
    let study = RigStudy::load(path, &RigQuantities::of(rig)).map_err(AcqError::from)?;
    eprintln!(
        "acq: study {}: {} parameter(s), {} observation(s) per hold, {} candidate test point(s){}",
        path.display(),
        study.parameters.len(),
        study.mapping.observations.len(),
        study.candidates.points.len(),
        if study.candidates.dropped > 0 {
            format!(
                " ({} combinations out of the machine's reach left out)",
                study.candidates.dropped
            )
        } else {
            String::new()
        }
    );
    Ok(Arc::new(study))
}

/// Starts the study over `sessions`; its lines go to `say`. The panel
/// before any hold (the prior and the first point to run) is said at once.
pub fn start(
    study: Arc<RigStudy>,
    sessions: Vec<SharedSession>,
    say: Box<dyn Fn(&str) + Send>,
) -> StudyWorker {
    let mut tracker = Tracker::new(study);
    for line in tracker.panel().words {
        say(&line);
    }
    let study = move |holds: &[(String, Vec<MeasuredValue>)],
                      publish: &mut dyn FnMut(Value, &[String])| {
        tracker.update_json(holds, publish)
    };
    StudyWorker::start(Box::new(study), sessions, say)
}

/// Writes the last panel into the session directory.
pub fn write_last(session_dir: &Path, panel: &Value) -> Result<PathBuf> {
    let path = session_dir.join(STUDY_FILE);
    let text = serde_json::to_string_pretty(panel)
        .map_err(|e| AcqError::Config(format!("the study's panel: {e}")))?;
    acq_io::output::Output::write_complete(&path, text.as_bytes())?;
    Ok(path)
}
