//! What a preset or a model adds to the one summary and the one report of
//! a study ([`super::summary`], [`super::report`]): its own title, a
//! section of its own, the keys its published summary names differently,
//! and the files it leaves besides (a calibrated geometry, a material
//! block). Everything else every study has is written once, for all.

use acq_error::Result;
use acq_report::document::Document;
use serde_json::{Map, Value};

use super::method::RunSettings;
use super::outcome::StudyOutcome;
use super::run_directory::RunDirectory;
use super::study::Study;

/// A study's additions to its summary and report; every method has a
/// default that adds nothing.
pub trait Extras {
    /// The report's first heading and its HTML page title.
    fn title(&self, settings: &RunSettings<'_>) -> (String, String) {
        (
            format!("Calibration with {}", settings.title),
            "Calibration study".into(),
        )
    }

    /// The heading of a common section, where this kind of study has
    /// published it under a name of its own [default: `common`].
    fn heading(&self, _section: Section, common: String) -> String {
        common
    }

    /// Sections (or paragraphs) right after the sentence on the search:
    /// what this kind of study shows first.
    fn sections(
        &self,
        _study: &Study,
        _outcome: &StudyOutcome,
        _report: &mut Document,
    ) -> Result<()> {
        Ok(())
    }

    /// The `summary.json` this kind of study publishes: the common keys
    /// [default], or its own fixed set of keys, built from them or named
    /// its own way.
    fn summary(
        &self,
        _study: &Study,
        _outcome: &StudyOutcome,
        common: Map<String, Value>,
    ) -> Map<String, Value> {
        common
    }

    /// Files the study leaves besides the common ones.
    fn files(
        &self,
        _study: &Study,
        _outcome: &StudyOutcome,
        _directory: &RunDirectory,
    ) -> Result<()> {
        Ok(())
    }

    /// The line printed on stdout at the end [default: the loss and the
    /// run count].
    fn closing_line(&self, _study: &Study, _outcome: &StudyOutcome) -> Option<String> {
        None
    }
}

/// The common sections a study may name its own way.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Section {
    /// The calibrated parameters against their ranges.
    Parameters,
    /// The surrogates' RMSE on the test runs (surrogate-MOO).
    Surrogates,
    /// The distinct good parameter sets (Bayesian optimisation).
    Candidates,
}

/// A study with nothing of its own: a user's solver.
pub struct NoExtras;

impl Extras for NoExtras {}
