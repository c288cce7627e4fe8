//! `acq calibrate rig SESSION_DIR... --study STUDY.toml [--next]`: the
//! study at the rig over recorded sessions, without the page. The holds are
//! `acq extract`'s (its default rule, every session's in the order given);
//! the posterior is updated hold by hold as at the rig, and `--next` prints
//! the test point to run next.

use std::path::PathBuf;
use std::sync::Arc;

use acq_analysis::extract::holds::HoldOptions;
use acq_analysis::extract::measured::MeasuredValue;
use acq_analysis::extract::quantities::RigQuantities;
use acq_analysis::extract::run::{extract_holds, WindowChoice};
use acq_analysis::recording::Recording;
use acq_error::{AcqError, Result};

use super::tracker::{next_words, Tracker};
use super::RigStudy;

#[derive(Clone, Debug)]
pub struct CalibrateRigOptions {
    /// Session directories written by acq record (their holds, in order).
    pub sessions: Vec<PathBuf>,
    /// The study at the rig (docs/src/study-at-the-rig.md).
    pub study: PathBuf,
    /// Print the test point to run next: the candidate expected to narrow
    /// the posterior most.
    pub next: bool,
    /// Write the study's last state (what the page shows as `study`) as JSON.
    pub output: Option<PathBuf>,
}

pub fn run(args: CalibrateRigOptions) -> Result<()> {
    let several = args.sessions.len() > 1;
    let mut holds: Vec<(String, Vec<MeasuredValue>)> = Vec::new();
    let mut quantities = None;
    for dir in &args.sessions {
        let recording = Recording::open_session(dir)?;
        let report = extract_holds(
            &recording,
            &WindowChoice::Auto(HoldOptions::default()),
            None,
            &[],
        )?;
        let session = dir
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_else(|| dir.display().to_string());
        for window in &report.windows {
            let values: Vec<MeasuredValue> = report
                .values
                .iter()
                .filter(|v| v.window == window.name)
                .cloned()
                .collect();
            let name = if several {
                format!("{session}/{}", window.name)
            } else {
                window.name.clone()
            };
            holds.push((name, values));
        }
        quantities.get_or_insert_with(|| RigQuantities::of(&recording.rig));
    }
    let Some(quantities) = quantities else {
        return Err(AcqError::Config(
            "give at least one session directory written by acq record".into(),
        ));
    };
    let study = Arc::new(RigStudy::load(&args.study, &quantities).map_err(AcqError::from)?);
    if args.next && study.candidates.points.is_empty() {
        return Err(no_candidates(&args));
    }
    eprintln!(
        "acq: {} hold(s) in {} session(s); the study updates after each",
        holds.len(),
        args.sessions.len()
    );
    let mut tracker = Tracker::new(study.clone());
    // Progress on stderr, a short line a hold; the answer on stdout.
    tracker.update(&holds, &mut |panel| {
        let verdicts: Vec<String> = panel_parameters(&panel.json)
            .map(|(name, p)| format!("{name} {}", p["verdict"].as_str().unwrap_or("?")))
            .collect();
        eprintln!(
            "acq: study after {} hold(s): {}",
            panel.json["holds_used"],
            verdicts.join(", ")
        );
    });
    let panel = tracker.panel();
    for line in answer_lines(&study, &panel.json) {
        println!("{line}");
    }
    if args.next {
        match tracker.next() {
            Ok(Some(next)) => println!("{}", next_words(next)),
            Ok(None) => return Err(no_candidates(&args)),
            Err(error) => return Err(AcqError::Config(format!("no next point: {error}"))),
        }
    }
    if let Some(path) = &args.output {
        let text = serde_json::to_string_pretty(&panel.json)
            .map_err(|e| AcqError::Config(format!("the study's state: {e}")))?;
        acq_io::output::Output::write_complete(path, text.as_bytes())?;
        println!("state: {}", path.display());
    }
    Ok(())
}

/// The panel's parameters, in the study's order.
fn panel_parameters(panel: &serde_json::Value) -> impl Iterator<Item = (&str, &serde_json::Value)> {
    let parameters = &panel["parameters"];
    panel["order"]
        .as_array()
        .into_iter()
        .flatten()
        .filter_map(move |name| {
            let name = name.as_str()?;
            Some((name, parameters.get(name)?))
        })
}

/// What the study found, a short line a parameter: its mean and 90 %
/// interval, its verdict with why, and the bound of its range it presses
/// against (an interval within 1 % of the range's width from a bound).
fn answer_lines(study: &RigStudy, panel: &serde_json::Value) -> Vec<String> {
    use acq_report::number::significant;
    let mut lines = vec![format!(
        "study {}: after {} of {} hold(s)",
        study.path.display(),
        panel["holds_used"],
        panel["holds_seen"]
    )];
    if let Some(error) = panel["error"].as_str() {
        lines.push(format!("  the posterior failed: {error}"));
    }
    for (name, p) in panel_parameters(panel) {
        let number = |key: &str| p[key].as_f64().unwrap_or(f64::NAN);
        let (q05, q95) = (number("q05"), number("q95"));
        let bound = study
            .parameters
            .iter()
            .find(|s| s.search.name == name)
            .and_then(|s| {
                [q05, q95]
                    .into_iter()
                    .filter_map(|end| s.search.bound_reached(end))
                    .next()
                    .map(|side| {
                        let at = if side == "upper bound" {
                            s.search.upper
                        } else {
                            s.search.lower
                        };
                        format!(", on its {side} {}", significant(at, 4))
                    })
            })
            .unwrap_or_default();
        let why = p["why"]
            .as_str()
            .map(|why| format!(": {why}"))
            .unwrap_or_default();
        lines.push(format!(
            "  {name} = {} [{} .. {}] {}{bound}{why}",
            significant(number("mean"), 4),
            significant(q05, 4),
            significant(q95, 4),
            p["verdict"].as_str().unwrap_or("?"),
        ));
    }
    // The chains in one line, as `acq calibrate` says them: the worst
    // R-hat and the least ESS over the parameters (none for the prior).
    let worst = |key: &str, pick: fn(f64, f64) -> f64| {
        panel_parameters(panel)
            .filter_map(|(_, p)| p[key].as_f64())
            .reduce(pick)
    };
    if let (Some(rhat), Some(bulk), Some(tail)) = (
        worst("rhat", f64::max),
        worst("ess_bulk", f64::min),
        worst("ess_tail", f64::min),
    ) {
        lines.push(format!(
            "  chains: R-hat {rhat:.3} at most, bulk ESS {bulk:.0} and tail ESS {tail:.0} at least"
        ));
    }
    lines
}

fn no_candidates(args: &CalibrateRigOptions) -> AcqError {
    AcqError::Config(format!(
        "{}: no [candidates]: give the conditions the operator can set to name a next point",
        args.study.display()
    ))
}
