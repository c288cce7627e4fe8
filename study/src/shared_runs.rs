//! The model runs of one evaluation of a study's simulator: cases whose
//! model inputs are the same share one run.

use super::study::Measured;
use super::study::{append_notes, CurveSlopes, Model, ModelRun, Role, Study};

/// The model runs of one evaluation. Cases whose model inputs are the
/// same (two cases reading different outputs of one test, as the
/// CalculiX bar's hardening and neck do) share one run that returns
/// every output either asks for: a run is a function of its inputs, and
/// a second one would cost as much as the first (a fine FE mesh's run
/// twice over) for the same numbers.
pub(crate) struct SharedRuns<'s> {
    /// Each distinct input set: its inputs, the scalars and curves its
    /// cases ask for (each name once), and its run once made.
    runs: Vec<SharedRun<'s>>,
    /// By the study's case index: its run and what it asks of it.
    cases: Vec<Option<CaseAsks<'s>>>,
    /// Runs are made with the curves' slopes ([`Model::run_with_slopes`]).
    pub(crate) with_slopes: bool,
}

/// A case's run (an index into [`SharedRuns::runs`]) and its scalar and
/// curve outputs, in its observations' order.
#[derive(Clone)]
struct CaseAsks<'s> {
    run: usize,
    scalars: Vec<&'s str>,
    curves: Vec<&'s str>,
}

/// A case's scalars and curves, taken from its (shared) run, and each
/// curve's slopes when the run gave them.
pub(crate) type CaseOutputs<'r> = (
    Vec<f64>,
    Vec<&'r [(f64, f64)]>,
    Vec<Option<&'r CurveSlopes>>,
);

struct SharedRun<'s> {
    inputs: Vec<(String, f64)>,
    scalars: Vec<&'s str>,
    curves: Vec<&'s str>,
    run: Option<Result<ModelRun, String>>,
    /// Each of `curves`' slopes (empty: none given).
    slopes: Vec<CurveSlopes>,
}

impl<'s> SharedRuns<'s> {
    pub(crate) fn new(study: &'s Study, role: Role, values: &[f64]) -> Self {
        let mut shared = SharedRuns {
            runs: Vec::new(),
            cases: vec![None; study.cases.len()],
            with_slopes: false,
        };
        for (index, case) in study.cases_with(role).filter(|(_, case)| !case.priors) {
            let named = |curve: bool| -> Vec<&'s str> {
                case.observations
                    .iter()
                    .filter(|o| matches!(o.measured, Measured::Curve { .. }) == curve)
                    .map(|o| o.output.as_str())
                    .collect()
            };
            let (scalars, curves) = (named(false), named(true));
            let inputs = study.inputs_of(index, values);
            let at = match shared.runs.iter().position(|r| r.inputs == inputs) {
                Some(at) => at,
                None => {
                    shared.runs.push(SharedRun {
                        inputs,
                        scalars: Vec::new(),
                        curves: Vec::new(),
                        run: None,
                        slopes: Vec::new(),
                    });
                    shared.runs.len() - 1
                }
            };
            let run = &mut shared.runs[at];
            for (union, asked) in [(&mut run.scalars, &scalars), (&mut run.curves, &curves)] {
                for name in asked {
                    if !union.contains(name) {
                        union.push(name);
                    }
                }
            }
            shared.cases[index] = Some(CaseAsks {
                run: at,
                scalars,
                curves,
            });
        }
        shared
    }

    /// Case `index`'s scalars and curves, from its run (made now if it is
    /// the first case of its inputs, its notes appended to `notes`).
    pub(crate) fn outputs_of(
        &mut self,
        index: usize,
        model: &dyn Model,
        notes: &mut [String],
    ) -> Result<CaseOutputs<'_>, String> {
        let Some(Some(asks)) = self.cases.get(index) else {
            return Err(format!("case {index} has no run"));
        };
        let run = &mut self.runs[asks.run];
        if run.run.is_none() {
            if self.with_slopes {
                // A model that gives slopes runs inside acq: no notes.
                match model.run_with_slopes(&run.inputs, &run.scalars, &run.curves) {
                    Ok((made, slopes)) => {
                        run.run = Some(Ok(made));
                        run.slopes = slopes;
                    }
                    Err(reason) => run.run = Some(Err(reason)),
                }
            } else {
                let (made, run_notes) = model.run_noted(&run.inputs, &run.scalars, &run.curves);
                append_notes(notes, run_notes);
                run.run = Some(made);
            }
        }
        let made = match &run.run {
            Some(Ok(made)) => made,
            Some(Err(reason)) => return Err(reason.clone()),
            None => return Err(format!("case {index}'s run was not made")),
        };
        // Where each asked name is in the run's outputs; a run that
        // returned fewer than asked ends the case's list there.
        let positions = |union: &[&str], asked: &[&str]| -> Vec<usize> {
            asked
                .iter()
                .filter_map(|name| union.iter().position(|n| n == name))
                .collect()
        };
        let case_scalars = positions(&run.scalars, &asks.scalars)
            .into_iter()
            .map_while(|i| made.scalars.get(i).copied())
            .collect();
        let curve_positions = positions(&run.curves, &asks.curves);
        let case_curves = curve_positions
            .iter()
            .map_while(|&i| made.curves.get(i).map(Vec::as_slice))
            .collect();
        let case_slopes = curve_positions.iter().map(|&i| run.slopes.get(i)).collect();
        Ok((case_scalars, case_curves, case_slopes))
    }
}
