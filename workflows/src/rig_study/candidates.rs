//! `[candidates]`: the conditions an operator can set, by input name, each
//! a list of values or `{ from, to, steps }`; every combination is a
//! candidate test point. Only an input the rig measures in a hold (a
//! pose, a load) can be a condition: a fixed input is the same in every
//! hold, and a parameter is what the holds are to find.
//!
//! A combination the model cannot run at the study's nominal parameters
//! (a pose the linkage does not reach) is dropped; a value no combination
//! can run at is refused, as is a value outside the range the rig file
//! states for the sensor that will measure it.

use std::collections::BTreeMap;

use acq_study::spec::schema::CandidateValues;
use acq_study::spec::SpecProblem;

use super::mapping::HoldMapping;

/// At most this many values of one input, and combinations in all.
pub const MAX_STEPS: usize = 10_000;
pub const MAX_CANDIDATES: usize = 100_000;

const TABLE: &str = "[candidates]";

/// Whether the model runs at a candidate (its inputs by name), or why not.
pub type RunsAt<'a> = dyn Fn(&[(String, f64)]) -> Result<(), String> + 'a;

/// The candidate test points.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Candidates {
    /// The inputs an operator sets, in order.
    pub names: Vec<String>,
    /// Each candidate's values of `names`.
    pub points: Vec<Vec<f64>>,
    /// Combinations dropped because the model does not run there.
    pub dropped: usize,
}

/// The values of one input.
fn values(name: &str, given: &CandidateValues) -> Result<Vec<f64>, SpecProblem> {
    let here = |message: String| SpecProblem::key(TABLE, name, format!("{name}: {message}"));
    let values = match given {
        CandidateValues::List(list) => list.clone(),
        CandidateValues::Range(range) => {
            if !(1..=MAX_STEPS).contains(&range.steps) {
                return Err(here(format!(
                    "steps = {}; give 1 to {MAX_STEPS}",
                    range.steps
                )));
            }
            if range.steps == 1 {
                vec![range.from]
            } else {
                (0..range.steps)
                    .map(|k| {
                        range.from + (range.to - range.from) * k as f64 / (range.steps - 1) as f64
                    })
                    .collect()
            }
        }
    };
    if values.is_empty() {
        return Err(here("no values; give a list or { from, to, steps }".into()));
    }
    if let Some(bad) = values.iter().find(|v| !v.is_finite()) {
        return Err(here(format!("{bad} is not a finite number")));
    }
    if values.len() > MAX_STEPS {
        return Err(here(format!(
            "{} values; give at most {MAX_STEPS}",
            values.len()
        )));
    }
    Ok(values)
}

/// The candidates of `[candidates]` for a study with `mapping` and
/// `parameters` (names), checked: `range_of` gives the range the rig file
/// states for the quantity an input is measured by, and `runs` whether
/// the model runs at a candidate (the inputs by name), or why not.
pub fn candidates(
    given: &BTreeMap<String, CandidateValues>,
    mapping: &HoldMapping,
    parameters: &[String],
    range_of: &dyn Fn(&str) -> Option<[f64; 2]>,
    runs: &RunsAt<'_>,
) -> Result<Candidates, SpecProblem> {
    if given.is_empty() {
        return Ok(Candidates::default());
    }
    let axes = candidate_axes(given, mapping, parameters, range_of)?;
    let total = axes
        .iter()
        .try_fold(1usize, |n, (_, v)| n.checked_mul(v.len()))
        .filter(|&n| n <= MAX_CANDIDATES)
        .ok_or_else(|| {
            SpecProblem::file(format!(
                "[candidates]: more than {MAX_CANDIDATES} combinations; give fewer values"
            ))
        })?;
    let reached = reached_combinations(&axes, total, runs);
    if reached.points.is_empty() {
        return Err(SpecProblem::file(format!(
            "[candidates]: the model runs at none of the {total} candidates; at the first it says: {}",
            reached.why_not.unwrap_or_default()
        )));
    }
    for (((name, values), ran), said) in axes.iter().zip(&reached.ran_at).zip(&reached.said) {
        if let Some(k) = ran.iter().position(|r| !r) {
            return Err(SpecProblem::key(
                TABLE,
                name,
                format!(
                    "{name} = {}: the model runs at no candidate with it (a pose the linkage does not reach, or a load it cannot take); leave it out. The model says of one: {}",
                    values[k],
                    said[k].as_deref().unwrap_or_default()
                ),
            ));
        }
    }
    Ok(Candidates {
        names: axes.iter().map(|(name, _)| name.clone()).collect(),
        points: reached.points,
        dropped: reached.dropped,
    })
}

/// Each measured input's values as `[candidates]` gives them, checked:
/// an input the rig measures (not a parameter), within the range the rig
/// file states, and every measured input given.
fn candidate_axes(
    given: &BTreeMap<String, CandidateValues>,
    mapping: &HoldMapping,
    parameters: &[String],
    range_of: &dyn Fn(&str) -> Option<[f64; 2]>,
) -> Result<Vec<(String, Vec<f64>)>, SpecProblem> {
    let measured: Vec<(&str, &str)> = mapping
        .measured_inputs()
        .map(|(name, from)| (name, from.quantity.as_str()))
        .collect();
    let mut axes: Vec<(String, Vec<f64>)> = Vec::new();
    for (name, values_given) in given {
        let here = |message: String| SpecProblem::key(TABLE, name, format!("{name}: {message}"));
        if parameters.contains(name) {
            return Err(here(
                "a [[parameter]] is what the holds are to find, not a condition to set".into(),
            ));
        }
        let Some(&(_, quantity)) = measured.iter().find(|(input, _)| input == name) else {
            return Err(here(format!(
                "not an input the rig measures in a hold; the conditions are {} (see [holds.inputs])",
                measured
                    .iter()
                    .map(|(input, _)| *input)
                    .collect::<Vec<_>>()
                    .join(", ")
            )));
        };
        let values = values(name, values_given)?;
        if let Some([low, high]) = range_of(quantity) {
            if let Some(bad) = values.iter().find(|v| **v < low || **v > high) {
                return Err(here(format!(
                    "{bad} lies outside the range the rig file states for {quantity} ({low} to {high})"
                )));
            }
        }
        axes.push((name.clone(), values));
    }
    if let Some((missing, _)) = measured
        .iter()
        .find(|(input, _)| !axes.iter().any(|(name, _)| name == input))
    {
        return Err(SpecProblem::key(
            TABLE,
            missing,
            format!(
                "[candidates] sets no values of {missing}, which every hold measures; give its values (a list, or {{ from, to, steps }})"
            ),
        ));
    }
    Ok(axes)
}

/// The combinations of the axes where the model runs, and per value
/// whether it ran at any and what it said where it did not.
struct Reached {
    points: Vec<Vec<f64>>,
    ran_at: Vec<Vec<bool>>,
    said: Vec<Vec<Option<String>>>,
    dropped: usize,
    why_not: Option<String>,
}

/// Every one of the `total` combinations of `axes` (the last axis
/// fastest), run once.
fn reached_combinations(axes: &[(String, Vec<f64>)], total: usize, runs: &RunsAt<'_>) -> Reached {
    let names: Vec<String> = axes.iter().map(|(name, _)| name.clone()).collect();
    let mut reached = Reached {
        points: Vec::with_capacity(total),
        ran_at: axes.iter().map(|(_, v)| vec![false; v.len()]).collect(),
        said: axes.iter().map(|(_, v)| vec![None; v.len()]).collect(),
        dropped: 0,
        why_not: None,
    };
    for index in 0..total {
        let mut rest = index;
        let mut picks = Vec::with_capacity(axes.len());
        for (_, values) in axes.iter().rev() {
            picks.push(rest % values.len());
            rest /= values.len();
        }
        picks.reverse();
        let point: Vec<f64> = picks
            .iter()
            .zip(axes)
            .map(|(&k, (_, values))| values[k])
            .collect();
        let inputs: Vec<(String, f64)> = names.iter().cloned().zip(point.iter().copied()).collect();
        match runs(&inputs) {
            Ok(()) => {
                for (axis, &k) in picks.iter().enumerate() {
                    reached.ran_at[axis][k] = true;
                }
                reached.points.push(point);
            }
            Err(error) => {
                reached.dropped += 1;
                for (axis, &k) in picks.iter().enumerate() {
                    reached.said[axis][k].get_or_insert_with(|| error.clone());
                }
                reached.why_not.get_or_insert(error);
            }
        }
    }
    reached
}
