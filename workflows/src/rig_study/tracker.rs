//! Hold by hold: the posterior after each hold so far, the next test
//! point, and what the page (`study` in `/api/state`) and the terminal
//! show of them.
//!
//! The holds come in order, every one so far each time; a hold already
//! seen with the same values keeps its step, and a changed one (the live
//! detector revises a hold when a larger load comes) drops the steps from
//! it on. So the panel after the last hold is the same whether the holds
//! came one by one while recording or all at once from a recorded session.

use std::sync::Arc;

use acq_analysis::extract::measured::MeasuredValue;
use serde_json::{json, Map, Value};

use super::mapping::HoldReading;
use super::next::{NextTestPoint, MAX_RUNS_PER_CHOICE};
use super::update::{significant, Posterior, Verdict};
use super::RigStudy;

/// One hold's step.
struct Step {
    /// The hold's name and its values' means, bit for bit.
    key: (String, Vec<u64>),
    reading: Result<HoldReading, String>,
    /// After this hold (the last usable one's when it was not used).
    posterior: Result<Posterior, String>,
    next: Result<Option<NextTestPoint>, String>,
}

/// The study's state as the page and the terminal show it.
#[derive(Clone, Debug)]
pub struct Panel {
    pub json: Value,
    /// Lines for the terminal.
    pub words: Vec<String>,
}

/// The steps so far of one study.
pub struct Tracker {
    study: Arc<RigStudy>,
    steps: Vec<Step>,
    prior: Posterior,
    next_before: Result<Option<NextTestPoint>, String>,
}

fn key_of(name: &str, values: &[MeasuredValue]) -> (String, Vec<u64>) {
    (
        name.to_string(),
        values
            .iter()
            .map(|v| v.stats.mean.map_or(u64::MAX, f64::to_bits))
            .collect(),
    )
}

impl Tracker {
    pub fn new(study: Arc<RigStudy>) -> Tracker {
        let prior = study.prior();
        let next_before = match study.expected_noise(&[]) {
            Some(noise) => study.next_point(&prior, &noise),
            None => Ok(None),
        };
        Tracker {
            study,
            steps: Vec::new(),
            prior,
            next_before,
        }
    }

    /// Brings the steps up to `holds` (every hold so far, in order, by
    /// name with its values), one hold at a time, calling `publish` after
    /// each new step.
    pub fn update(
        &mut self,
        holds: &[(String, Vec<MeasuredValue>)],
        publish: &mut dyn FnMut(&Panel),
    ) {
        let kept = self
            .steps
            .iter()
            .zip(holds)
            .take_while(|(step, (name, values))| step.key == key_of(name, values))
            .count();
        self.steps.truncate(kept);
        for (name, values) in &holds[kept..] {
            let last_mean = self
                .steps
                .iter()
                .rev()
                .find_map(|s| s.posterior.as_ref().ok())
                .unwrap_or(&self.prior)
                .mean
                .clone();
            // A hold the model cannot run at (an emulator asked past the
            // conditions its runs covered) is skipped with the reason, not
            // left to fail every update after it.
            let reading = self.study.mapping.read(name, values).and_then(|reading| {
                let inputs: Vec<(String, f64)> = reading
                    .inputs
                    .iter()
                    .map(|(name, value, _)| (name.clone(), *value))
                    .collect();
                match self.study.outputs_at(&last_mean, &inputs) {
                    Ok(_) => Ok(reading),
                    Err(e) => Err(format!("the model does not run at this hold: {e}")),
                }
            });
            let mut readings: Vec<HoldReading> = self.readings().cloned().collect();
            let (posterior, next) = match &reading {
                Ok(reading) => {
                    readings.push(reading.clone());
                    let last = self
                        .steps
                        .iter()
                        .rev()
                        .find_map(|s| s.posterior.as_ref().ok())
                        .unwrap_or(&self.prior);
                    let posterior = self.study.posterior(&readings, last);
                    let next = match (&posterior, self.study.expected_noise(&readings)) {
                        (Ok(posterior), Some(noise)) => self.study.next_point(posterior, &noise),
                        (Ok(_), None) => Ok(None),
                        (Err(e), _) => Err(e.clone()),
                    };
                    (posterior, next)
                }
                Err(_) => match self.steps.last() {
                    Some(last) => (last.posterior.clone(), last.next.clone()),
                    None => (Ok(self.prior.clone()), self.next_before.clone()),
                },
            };
            self.steps.push(Step {
                key: key_of(name, values),
                reading,
                posterior,
                next,
            });
            publish(&self.panel());
        }
    }

    /// [`Tracker::update`], each panel published as its JSON and lines.
    pub fn update_json(
        &mut self,
        holds: &[(String, Vec<MeasuredValue>)],
        publish: &mut dyn FnMut(Value, &[String]),
    ) {
        self.update(holds, &mut |panel| {
            publish(panel.json.clone(), &panel.words)
        });
    }

    fn readings(&self) -> impl Iterator<Item = &HoldReading> {
        self.steps.iter().filter_map(|s| s.reading.as_ref().ok())
    }

    /// The latest posterior (the prior before any hold) or why it failed.
    pub fn posterior(&self) -> Result<&Posterior, &str> {
        match self.steps.last() {
            Some(step) => step.posterior.as_ref().map_err(String::as_str),
            None => Ok(&self.prior),
        }
    }

    /// The latest next test point.
    pub fn next(&self) -> Result<Option<&NextTestPoint>, &str> {
        let next = self.steps.last().map_or(&self.next_before, |s| &s.next);
        next.as_ref().map(Option::as_ref).map_err(String::as_str)
    }

    /// The holds not used, each with why, and each used hold's intervals.
    fn skipped_and_history(&self) -> (Vec<Value>, Vec<Value>) {
        let skipped: Vec<Value> = self
            .steps
            .iter()
            .filter_map(|s| {
                s.reading
                    .as_ref()
                    .err()
                    .map(|why| json!({ "hold": s.key.0, "why": why }))
            })
            .collect();
        let history: Vec<Value> = self
            .steps
            .iter()
            .filter(|s| s.reading.is_ok())
            .filter_map(|s| {
                let posterior = s.posterior.as_ref().ok()?;
                let parameters: Map<String, Value> = posterior
                    .parameters
                    .iter()
                    .map(|p| {
                        (
                            p.name.clone(),
                            json!({ "mean": p.mean, "q05": p.q05, "q95": p.q95 }),
                        )
                    })
                    .collect();
                Some(json!({
                    "hold": s.key.0,
                    "holds_used": posterior.holds_used,
                    "parameters": parameters,
                }))
            })
            .collect();
        (skipped, history)
    }

    /// The panel now.
    pub fn panel(&self) -> Panel {
        let (skipped, history) = self.skipped_and_history();
        let mut words = Vec::new();
        let mut json = json!({
            "file": self.study.path.display().to_string(),
            "holds_seen": self.steps.len(),
            "holds_used": 0,
            "skipped": skipped,
            "history": history,
            "order": self.study.parameters.iter().map(|p| p.search.name.clone()).collect::<Vec<_>>(),
            "parameters": {},
            "next": null,
            "error": null,
        });
        match self.posterior() {
            Ok(posterior) => {
                json["holds_used"] = json!(posterior.holds_used);
                json["shrinkage"] = json!(posterior.shrinkage());
                json["wall_s"] = json!(posterior.wall_s);
                json["how"] = json!(posterior.how);
                let (parameters, said) = parameters_of(posterior);
                json["parameters"] = Value::Object(parameters);
                words.push(format!(
                    "study: after {} hold(s): {}",
                    posterior.holds_used,
                    said.join("; ")
                ));
            }
            Err(error) => {
                json["error"] = json!(error);
                words.push(format!("study: the posterior failed: {error}"));
            }
        }
        if let Some(step) = self.steps.last() {
            if let Err(why) = &step.reading {
                words.push(format!("study: {} not used: {why}", step.key.0));
            }
        }
        match self.next() {
            Ok(Some(next)) => {
                let sentence = next_words(next);
                words.push(format!("study: {sentence}"));
                json["next"] = json!({
                    "inputs": next.inputs.iter().map(|(k, v)| (k.clone(), json!(v))).collect::<Map<_, _>>(),
                    "narrows": next.narrows.iter().map(|n| (n.parameter.clone(), json!({ "from_width": n.from_width, "to_width": n.to_width }))).collect::<Map<_, _>>(),
                    "predicted": next.predicted.iter().map(|(k, v)| (k.clone(), json!(v))).collect::<Map<_, _>>(),
                    "information_nats": next.information_nats,
                    "candidates": next.candidates,
                    "of_candidates": next.of_candidates,
                    "disputed": next.disputed,
                    "words": sentence,
                });
            }
            Ok(None) => {}
            Err(error) => {
                words.push(format!("study: no next point: {error}"));
                json["next_error"] = json!(error);
            }
        }
        Panel { json, words }
    }
}

/// The next point in words: what to set, and what it narrows.
pub fn next_words(next: &NextTestPoint) -> String {
    let set: Vec<String> = next
        .inputs
        .iter()
        .map(|(name, value)| format!("{name} = {}", significant(*value)))
        .collect();
    let mut sentence = format!("next: set {}", set.join(", "));
    if let Some(most) = next.narrows_most() {
        sentence.push_str(&format!(
            "; it should narrow {} from {} to {} (90 % interval width)",
            most.parameter,
            significant(most.from_width),
            significant(most.to_width)
        ));
    }
    if !next.disputed.is_empty() {
        let each = if next.disputed.len() > 1 { "each " } else { "" };
        sentence.push_str(&format!(
            "; not weighed: {} ({each}in conflict with its prior: a hold would narrow an interval in dispute)",
            next.disputed.join(", ")
        ));
    }
    if next.bounded {
        sentence.push_str(&format!(
            " (chosen from {} of the {} candidates, spread over them: a choice is bounded at {} twin runs; give fewer [candidates] to weigh them all)",
            next.candidates, next.of_candidates, MAX_RUNS_PER_CHOICE
        ));
    }
    sentence
}

/// Each parameter's interval and verdict for the page, and in words.
fn parameters_of(posterior: &Posterior) -> (Map<String, Value>, Vec<String>) {
    let mut parameters = Map::new();
    let mut said = Vec::new();
    for p in &posterior.parameters {
        let confounded = match &p.verdict {
            Verdict::Confounded { with, correlation } => {
                json!({ "with": with, "correlation": correlation })
            }
            _ => Value::Null,
        };
        parameters.insert(
            p.name.clone(),
            json!({
                "mean": p.mean,
                "sd": p.sd,
                "q05": p.q05,
                "q95": p.q95,
                "prior_q05": p.prior_q05,
                "prior_q95": p.prior_q95,
                "verdict": p.verdict.word(),
                // NaN (not computable) is written as null.
                "rhat": p.chains.map(|c| c.rhat),
                "ess_bulk": p.chains.map(|c| c.ess_bulk),
                "ess_tail": p.chains.map(|c| c.ess_tail),
                "confounded": confounded,
                "why": p.verdict.why(),
            }),
        );
        let with = match (&p.verdict, p.verdict.why()) {
            (Verdict::Confounded { with, .. }, _) => format!(" with {with}"),
            (_, Some(why)) => format!(": {why}"),
            _ => String::new(),
        };
        said.push(format!(
            "{} {} [{}, {}] {}{with}",
            p.name,
            significant(p.mean),
            significant(p.q05),
            significant(p.q95),
            p.verdict.word()
        ));
    }
    (parameters, said)
}
