//! The next test point: of the candidate conditions, the one whose hold is
//! expected to shrink the posterior most.
//!
//! The criterion is the expected information gain of the model linearised
//! at the posterior mean ([`acq_algorithms::next_point`]), which for a Gaussian
//! posterior is Bayesian D-optimality: the log ratio of the posterior's
//! volume before and after. It is exact where the outputs are linear in
//! the parameters over the posterior's width, as the excavator's cylinder
//! forces and stresses are in its masses and nearly so in its lever arms;
//! it needs one Jacobian per candidate (central differences, two model
//! runs per parameter), so a thousand candidates take well under a second,
//! where a sampled (nested Monte-Carlo) gain would need thousands of runs
//! per candidate. Each candidate's noise is the observations' expected
//! standard uncertainty: the median over the holds so far (before the
//! first hold, what the files state). Its input uncertainty is left out:
//! it is the same for every candidate to first order.
//!
//! Where the holds share errors (a transducer's calibration), the part of
//! a new hold's error that is shared is not fresh noise: the shared errors
//! join the parameters as coordinates with their joint posterior
//! ([`super::shared`]), a candidate moves them by its loadings, and only its
//! own error is noise. A repeat of a hold then gains only what its own
//! scatter adds.

use acq_algorithms::next_point::{next_point, Candidate};

use acq_study::posterior::shared_errors::LEAST_OWN_SHARE;

use super::mapping::{HoldReading, Spread};
use super::update::{Posterior, Verdict};
use super::RigStudy;

/// A parameter's 90 % interval now and expected after the next hold.
#[derive(Clone, Debug, PartialEq)]
pub struct Narrowing {
    pub parameter: String,
    pub from_width: f64,
    pub to_width: f64,
}

/// The condition to set next and what it is expected to do.
#[derive(Clone, Debug, PartialEq)]
pub struct NextTestPoint {
    /// The inputs the operator sets, by name.
    pub inputs: Vec<(String, f64)>,
    /// The observations the twin predicts there, at the posterior mean.
    pub predicted: Vec<(String, f64)>,
    /// Per parameter, in the study's order.
    pub narrows: Vec<Narrowing>,
    pub information_nats: f64,
    /// Candidates weighed (those where the twin ran, of the subset).
    pub candidates: usize,
    /// Candidates in the study.
    pub of_candidates: usize,
    /// Whether only a spread subset was weighed, the work being bounded at
    /// [`MAX_RUNS_PER_CHOICE`] twin runs.
    pub bounded: bool,
    /// The parameters the choice did not weigh: in conflict with their
    /// prior, so a hold that narrows them narrows an interval in dispute.
    pub disputed: Vec<String>,
}

impl NextTestPoint {
    /// The parameter it narrows most, relative to its width now, of those
    /// the choice weighed.
    pub fn narrows_most(&self) -> Option<&Narrowing> {
        self.narrows
            .iter()
            .filter(|n| n.from_width > 0.0 && !self.disputed.contains(&n.parameter))
            .min_by(|a, b| (a.to_width / a.from_width).total_cmp(&(b.to_width / b.from_width)))
    }
}

/// A relative step of central differences, of a parameter's prior 90 %
/// interval: small against the posterior's width, large against the
/// twin's rounding.
const STEP_OF_PRIOR_WIDTH: f64 = 1e-3;

/// At most this many twin runs choose one next point (one per candidate
/// at the mean, two per parameter for its Jacobian): about a second of the
/// excavator twin (12 us a run, release build), so the live page's study
/// answers each hold promptly whatever `[candidates]` holds. Beyond it a
/// spread subset of the candidates is weighed ([`spread_subset`]).
pub const MAX_RUNS_PER_CHOICE: usize = 100_000;

/// `wanted` of the indices `0..total`, spread over them by the golden
/// ratio's additive recurrence (low discrepancy, and no stride that could
/// fall in step with one axis of the candidates' grid, as an even stride
/// would with the last axis), in increasing order; all of them when
/// `wanted >= total`.
pub fn spread_subset(total: usize, wanted: usize) -> Vec<usize> {
    if wanted >= total {
        return (0..total).collect();
    }
    const GOLDEN_FRACTION: f64 = 0.618_033_988_749_895;
    let mut picked: Vec<usize> = (0..wanted)
        .map(|i| {
            let fraction = (0.5 + i as f64 * GOLDEN_FRACTION).fract();
            ((fraction * total as f64) as usize).min(total - 1)
        })
        .collect();
    picked.sort_unstable();
    picked.dedup();
    picked
}

impl RigStudy {
    /// Each observation's expected standard uncertainty in a new hold: the
    /// median of the holds so far, else what the files state (a number as
    /// `uncertainty`, and `instrument`, with the rig's sensor records);
    /// `None` when none says.
    pub fn expected_noise(&self, readings: &[HoldReading]) -> Option<Vec<f64>> {
        self.mapping
            .observations
            .iter()
            .enumerate()
            .map(|(k, (_, from))| {
                let mut seen: Vec<f64> = readings
                    .iter()
                    .filter_map(|r| r.observations.get(k).map(|o| o.2))
                    .collect();
                if !seen.is_empty() {
                    seen.sort_by(f64::total_cmp);
                    return Some(seen[seen.len() / 2]);
                }
                let stated = match from.spread {
                    Spread::Stated(u) => u,
                    _ => self.stated_noise.get(k).copied().flatten().unwrap_or(0.0),
                };
                let total = stated.hypot(from.instrument);
                (total > 0.0).then_some(total)
            })
            .collect()
    }

    /// The next test point after `posterior`, with each observation's
    /// expected noise; `None` without candidates.
    pub fn next_point(
        &self,
        posterior: &Posterior,
        noise_sd: &[f64],
    ) -> Result<Option<NextTestPoint>, String> {
        let candidates = &self.candidates;
        if candidates.points.is_empty() {
            return Ok(None);
        }
        let runs_per_candidate = 1 + 2 * posterior.mean.len();
        let weighed_points: Vec<&Vec<f64>> = spread_subset(
            candidates.points.len(),
            (MAX_RUNS_PER_CHOICE / runs_per_candidate).max(1),
        )
        .into_iter()
        .map(|c| &candidates.points[c])
        .collect();
        let fixed: Vec<(String, f64)> = self
            .mapping
            .fixed_inputs()
            .map(|(name, x)| (name.to_string(), x))
            .collect();
        let inputs_of = |point: &[f64]| {
            let mut inputs = fixed.clone();
            inputs.extend(candidates.names.iter().cloned().zip(point.iter().copied()));
            inputs
        };
        // Outer loop over the parameter values, inner over the candidates:
        // the twin keeps the last geometry it built.
        let at = |theta: &[f64]| -> Vec<Option<Vec<f64>>> {
            weighed_points
                .iter()
                .map(|point| self.outputs_at(theta, &inputs_of(point)).ok())
                .collect()
        };
        let centre = at(&posterior.mean);
        let parameters = posterior.mean.len();
        // columns[j][c]: d outputs / d parameter j at candidate c.
        let mut columns: Vec<Vec<Option<Vec<f64>>>> = Vec::with_capacity(parameters);
        for (j, interval) in posterior.parameters.iter().enumerate() {
            let step = STEP_OF_PRIOR_WIDTH * (interval.prior_q95 - interval.prior_q05);
            let mut up = posterior.mean.clone();
            up[j] += step;
            let mut down = posterior.mean.clone();
            down[j] -= step;
            let (above, below) = (at(&up), at(&down));
            columns.push(
                above
                    .into_iter()
                    .zip(below)
                    .map(|(a, b)| {
                        let (a, b) = (a?, b?);
                        Some(
                            a.iter()
                                .zip(&b)
                                .map(|(x, y)| (x - y) / (2.0 * step))
                                .collect(),
                        )
                    })
                    .collect(),
            );
        }
        // The candidates where every run went through.
        let usable: Vec<usize> = (0..weighed_points.len())
            .filter(|&c| centre[c].is_some() && columns.iter().all(|col| col[c].is_some()))
            .collect();
        if usable.is_empty() {
            return Err("the twin runs at no candidate at the posterior mean".into());
        }
        let weighed = weighed_candidates(posterior, noise_sd, &columns, &usable);
        let shared = posterior.shared.as_ref();
        let covariance = shared.map_or(&posterior.covariance, |s| &s.joint_covariance);
        let (interest, disputed) = weighed_parameters(posterior)?;
        let chosen = next_point(covariance, &weighed, &interest).map_err(|e| e.to_string())?;
        let best = usable[chosen.best];
        let gain = &chosen.gains[chosen.best];
        Ok(Some(NextTestPoint {
            inputs: candidates
                .names
                .iter()
                .cloned()
                .zip(weighed_points[best].iter().copied())
                .collect(),
            predicted: self
                .mapping
                .observations
                .iter()
                .map(|(name, _)| name.clone())
                .zip(centre[best].clone().unwrap_or_default())
                .collect(),
            narrows: posterior
                .parameters
                .iter()
                .zip(chosen.sd_before.iter().zip(&gain.sd_after))
                .map(|(interval, (before, after))| {
                    let from_width = interval.q95 - interval.q05;
                    Narrowing {
                        parameter: interval.name.clone(),
                        from_width,
                        to_width: if *before > 0.0 {
                            from_width * after / before
                        } else {
                            from_width
                        },
                    }
                })
                .collect(),
            information_nats: gain.information_nats,
            candidates: usable.len(),
            of_candidates: candidates.points.len(),
            bounded: weighed_points.len() < candidates.points.len(),
            disputed,
        }))
    }
}

/// The parameters the next point is chosen for (their indices: the
/// gain is on their marginal, the errors the holds share being nuisance),
/// and the names of those left out: in conflict with their prior.
fn weighed_parameters(posterior: &Posterior) -> Result<(Vec<usize>, Vec<String>), String> {
    let (disputed, interest): (Vec<_>, Vec<_>) = posterior
        .parameters
        .iter()
        .enumerate()
        .partition(|(_, interval)| matches!(interval.verdict, Verdict::Conflict { .. }));
    if interest.is_empty() {
        return Err("every parameter is in conflict with its prior: a hold would narrow intervals the prior disputes. Check the prior, the twin (geometry, masses) and the transducers (zero, range, certificate) first".into());
    }
    Ok((
        interest.into_iter().map(|(j, _)| j).collect(),
        disputed
            .into_iter()
            .map(|(_, interval)| interval.name.clone())
            .collect(),
    ))
}

/// Each usable candidate (`usable`, indices into `columns[j]`, the
/// outputs' derivatives by parameter `j` there) as the next-point search
/// weighs it: its Jacobian, with the loadings of the errors the holds share
/// as further columns, and only its own error as noise.
fn weighed_candidates(
    posterior: &Posterior,
    noise_sd: &[f64],
    columns: &[Vec<Option<Vec<f64>>>],
    usable: &[usize],
) -> Vec<Candidate> {
    let shared = posterior.shared.as_ref();
    let own_noise_sd: Vec<f64> = noise_sd
        .iter()
        .enumerate()
        .map(|(k, sd)| {
            let shared_variance: f64 = shared
                .and_then(|s| s.loadings.get(k))
                .map_or(0.0, |l| l.iter().map(|e| e * e).sum());
            (sd * sd - shared_variance)
                .max(LEAST_OWN_SHARE * sd * sd)
                .sqrt()
        })
        .collect();
    usable
        .iter()
        .map(|&c| Candidate {
            jacobian: (0..noise_sd.len())
                .map(|k| {
                    let mut row: Vec<f64> = columns
                        .iter()
                        .map(|col| col[c].as_ref().map_or(0.0, |d| d[k]))
                        .collect();
                    if let Some(shared) = shared {
                        row.extend(shared.loadings.get(k).cloned().unwrap_or_default());
                    }
                    row
                })
                .collect(),
            noise_sd: own_noise_sd.clone(),
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::spread_subset;

    /// A subset of a grid (the last axis fastest, as `[candidates]` is
    /// laid out) whose size is a multiple of the last axis's, where an even
    /// stride would take one value of that axis only: every value of every
    /// axis is still reached, each about equally often.
    #[test]
    fn a_spread_subset_reaches_every_value_of_every_axis() {
        let axes = [20usize, 20, 25, 10];
        let total: usize = axes.iter().product();
        let picked = spread_subset(total, total / 10);
        assert!(
            picked.windows(2).all(|w| w[0] < w[1]),
            "increasing, no repeats"
        );
        assert!(
            picked.len() > total / 10 * 95 / 100,
            "{} picked",
            picked.len()
        );
        let mut stride = 1;
        for &size in axes.iter().rev() {
            let mut seen = vec![0usize; size];
            for &index in &picked {
                seen[index / stride % size] += 1;
            }
            let expected = picked.len() as f64 / size as f64;
            for count in &seen {
                // Within 20 % of an equal share (a low-discrepancy sequence
                // keeps it far closer; 20 % catches an axis left out).
                assert!(
                    (*count as f64 - expected).abs() < 0.2 * expected,
                    "axis of {size}: counts {seen:?}"
                );
            }
            stride *= size;
        }
        assert_eq!(spread_subset(7, 100), (0..7).collect::<Vec<_>>());
    }
}
