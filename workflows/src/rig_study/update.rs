//! The holds so far as a study, and its posterior.
//!
//! Each hold is a fit case: its measured inputs at their means, each
//! observation at its mean with its standard uncertainty (and, for an
//! emulated model, the emulator's error at runs it has not seen and its
//! own standard deviation at the hold, at the nominal parameters). An input's own
//! uncertainty (a pose read by inclinometers, a load by a transducer) is
//! carried into the observations to first order: each observation's
//! variance gains `((y(u + s) - y(u - s)) / 2)^2` per measured input `u`
//! with standard uncertainty `s`, the model run at the parameters' nominal
//! values (so that a hold's case is the same whenever it is read).
//!
//! A parameter's verdict sets its posterior 90 % interval against its
//! prior's (the 5 % and 95 % quantiles of the prior within the bounds):
//! **identified** when the
//! holds have at least halved it, else **confounded** with the parameter
//! it is most correlated with when |correlation| > 0.9 (the holds pin down
//! a combination of the two), else **weak**. These are the thresholds of
//! the search's identifiability analysis.
//!
//! Two things come before any of those. A parameter whose chains have not
//! converged (R-hat at least 1.01 or too few effective draws) gets **not
//! converged** and no verdict: its interval is not yet the posterior's. And
//! a **conflict** is named, not read as knowledge: the posterior's median
//! outside the prior's 90 % interval (the holds and the prior disagree), or
//! an interval that does not overlap the one before the last hold (that hold
//! and the earlier ones disagree). Either points at the model, the prior or
//! a transducer, which the words say. A parameter identified before the
//! last hold and not after it is **weak** with why (the interval widened,
//! from what to what): a verdict never flips unexplained.

use std::time::Instant;

use acq_algorithms::mcmc::{quantile, Marginal};
use acq_algorithms::next_point::draws_moments;

use super::mapping::HoldReading;
use super::shared::SharedErrorsPosterior;
use super::RigStudy;
use acq_study::posterior::likelihood::coordinates_of;
use acq_study::posterior::sequential::{sample_sequentially, WarmStart};
use acq_study::posterior::{ESS_PER_CHAIN, RHAT_LIMIT};
use acq_study::study::{Case, LossKind, Measured, Observation, Residuals, Role, Study};

/// Holds that narrow a parameter's interval to this share of its prior's
/// have identified it.
pub const IDENTIFIED_WIDTH_RATIO: f64 = 0.5;
/// A pair this correlated is pinned down only as a combination.
pub const CONFOUNDED_CORRELATION: f64 = 0.9;

/// What the holds say of a parameter.
#[derive(Clone, Debug, PartialEq)]
pub enum Verdict {
    /// No hold yet: the prior.
    Prior,
    Identified,
    Weak,
    /// Pinned down only together with `with`.
    Confounded {
        with: String,
        correlation: f64,
    },
    /// Its chains have not converged: no verdict yet.
    NotConverged {
        rhat: f64,
        ess_bulk: f64,
    },
    /// The holds disagree with the prior or with each other: why, in words.
    Conflict {
        why: String,
    },
    /// Identified after the holds before, weak (or confounded) now: the
    /// last hold widened its interval; why, in words, so that the verdict
    /// does not flip unexplained.
    Loosened {
        why: String,
    },
}

impl Verdict {
    pub fn word(&self) -> &'static str {
        match self {
            Verdict::Prior => "prior only",
            Verdict::Identified => "identified",
            Verdict::Weak => "weak",
            Verdict::Confounded { .. } => "confounded",
            Verdict::NotConverged { .. } => "not converged",
            Verdict::Conflict { .. } => "conflict",
            Verdict::Loosened { .. } => "weak",
        }
    }

    /// What it means and what to check, where a word is not enough.
    pub fn why(&self) -> Option<String> {
        match self {
            Verdict::NotConverged { rhat, ess_bulk } => Some(format!(
                "its chains have not converged (R-hat {rhat:.3}, bulk ESS {ess_bulk:.0}): no verdict until they do; raise [posterior] draws"
            )),
            Verdict::Conflict { why } | Verdict::Loosened { why } => Some(why.clone()),
            _ => None,
        }
    }
}

/// One parameter's interval now and its prior's.
#[derive(Clone, Debug, PartialEq)]
pub struct ParameterInterval {
    pub name: String,
    pub mean: f64,
    pub sd: f64,
    pub q05: f64,
    pub q95: f64,
    pub prior_q05: f64,
    pub prior_q95: f64,
    pub verdict: Verdict,
    /// How well the chains estimate it (`None` for the prior).
    pub chains: Option<ChainQuality>,
}

/// One parameter's chain diagnostics, as ArviZ's `summary` gives them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ChainQuality {
    /// Rank-normalised split R-hat.
    pub rhat: f64,
    pub ess_bulk: f64,
    pub ess_tail: f64,
}

impl ParameterInterval {
    /// The 90 % interval's width over the prior's.
    pub fn width_ratio(&self) -> f64 {
        (self.q95 - self.q05) / (self.prior_q95 - self.prior_q05)
    }
}

/// The posterior after some holds.
#[derive(Clone, Debug, PartialEq)]
pub struct Posterior {
    pub holds_used: usize,
    pub parameters: Vec<ParameterInterval>,
    pub mean: Vec<f64>,
    pub covariance: Vec<Vec<f64>>,
    /// How it was sampled, in words.
    pub how: String,
    pub wall_s: f64,
    /// Where the update after the next hold starts (`None`: the prior's
    /// full warmup).
    pub next_start: Option<WarmStart>,
    /// The errors the holds share, jointly with the parameters (`None`
    /// when they share none, and for the prior).
    pub shared: Option<SharedErrorsPosterior>,
}

impl Posterior {
    /// How far the holds have shrunk the prior: the geometric mean over the
    /// parameters of the 90 % interval's width over the prior's (1 for the
    /// prior; 0.5 when each interval is, on average, half its prior's).
    pub fn shrinkage(&self) -> f64 {
        let logs: Vec<f64> = self
            .parameters
            .iter()
            .map(|p| p.width_ratio().ln())
            .collect();
        (logs.iter().sum::<f64>() / logs.len().max(1) as f64).exp()
    }
}

impl RigStudy {
    /// Each parameter's prior 90 % interval and standard deviation
    /// ([`acq_study::posterior::likelihood::Coordinate::prior_interval`]).
    fn prior_intervals(&self) -> Vec<(f64, f64, f64)> {
        coordinates_of(&self.parameters)
            .iter()
            .map(|c| {
                let prior = c.prior_interval();
                (prior.q05, prior.q95, prior.sd)
            })
            .collect()
    }

    /// The prior as a posterior of no hold.
    pub fn prior(&self) -> Posterior {
        let intervals = self.prior_intervals();
        let mean = self.nominal();
        let n = mean.len();
        Posterior {
            holds_used: 0,
            parameters: self
                .parameters
                .iter()
                .zip(&intervals)
                .zip(&mean)
                .map(|((p, &(q05, q95, sd)), &mean)| ParameterInterval {
                    name: p.search.name.clone(),
                    mean,
                    sd,
                    q05,
                    q95,
                    prior_q05: q05,
                    prior_q95: q95,
                    verdict: Verdict::Prior,
                    chains: None,
                })
                .collect(),
            covariance: (0..n)
                .map(|i| {
                    (0..n)
                        .map(|j| if i == j { intervals[i].2.powi(2) } else { 0.0 })
                        .collect()
                })
                .collect(),
            mean,
            how: "the prior".into(),
            wall_s: 0.0,
            next_start: None,
            shared: None,
        }
    }

    /// The study of `readings`, one fit case each, with the inputs'
    /// uncertainty carried into the observations'.
    pub fn study_of(&self, readings: &[HoldReading]) -> Study {
        let nominal = self.nominal();
        let cases: Vec<Case> = readings
            .iter()
            .map(|reading| {
                let inputs: Vec<(String, f64)> = reading
                    .inputs
                    .iter()
                    .map(|(name, value, _)| (name.clone(), *value))
                    .collect();
                // An emulated model's error: at runs it has not seen, and
                // its own doubt at this hold's conditions (large where its
                // runs did not reach), at the nominal parameters.
                let own = self.own_error_at(&nominal, &inputs);
                let mut variance: Vec<f64> = reading
                    .observations
                    .iter()
                    .zip(&self.model_error_sd)
                    .zip(&own)
                    .map(|(((_, _, sd), model), own)| sd * sd + model * model + own * own)
                    .collect();
                for (k, (_, _, sd)) in reading.inputs.iter().enumerate() {
                    if *sd <= 0.0 {
                        continue;
                    }
                    let moved = |by: f64| {
                        let mut moved = inputs.clone();
                        moved[k].1 += by;
                        self.outputs_at(&nominal, &moved).ok()
                    };
                    let slope = match (moved(*sd), moved(-*sd)) {
                        (Some(up), Some(down)) => Some((up, down, 2.0)),
                        (Some(up), None) => self
                            .outputs_at(&nominal, &inputs)
                            .ok()
                            .map(|at| (up, at, 1.0)),
                        (None, Some(down)) => self
                            .outputs_at(&nominal, &inputs)
                            .ok()
                            .map(|at| (at, down, 1.0)),
                        (None, None) => None,
                    };
                    if let Some((up, down, steps)) = slope {
                        for (v, (a, b)) in variance.iter_mut().zip(up.iter().zip(&down)) {
                            *v += ((a - b) / steps).powi(2);
                        }
                    }
                }
                Case {
                    name: reading.name.clone(),
                    role: Role::Fit,
                    inputs,
                    observations: reading
                        .observations
                        .iter()
                        .zip(&variance)
                        .enumerate()
                        .map(|(k, ((output, value, _), variance))| Observation {
                            name: output.clone(),
                            output: output.clone(),
                            measured: Measured::Scalar {
                                value: *value,
                                uncertainty: Some(variance.sqrt()),
                            },
                            weight: 1.0,
                            source: format!("hold {}", reading.name),
                            shared: reading.shared.get(k).cloned().unwrap_or_default(),
                        })
                        .collect(),
                    priors: false,
                }
            })
            .collect();
        let mut study = Study {
            parameters: self.parameters.clone(),
            cases,
            named_cases: true,
            residuals: Residuals::Normalised,
            loss: LossKind::Squares,
        };
        if let Some(priors) = Case::priors(&study.parameters) {
            study.cases.push(priors);
        }
        study
    }

    /// The posterior after `readings` (the prior without any), sampled
    /// from `last`, the posterior before the last of them
    /// ([`sample_sequentially`]).
    pub fn posterior(
        &self,
        readings: &[HoldReading],
        last: &Posterior,
    ) -> Result<Posterior, String> {
        if readings.is_empty() {
            return Ok(self.prior());
        }
        let start = Instant::now();
        let study = self.study_of(readings);
        let update = sample_sequentially(
            &study,
            self.model(),
            &self.settings,
            &self.nominal(),
            last.next_start.as_ref(),
        )
        .map_err(|e| e.to_string())?;
        let chains = update.chains;
        let marginals = chains.summaries();
        let pooled: Vec<Vec<f64>> = chains.pooled().cloned().collect();
        let (mean, covariance) = draws_moments(&pooled)
            .ok_or("the posterior has fewer than two draws; raise [posterior] draws")?;
        let intervals = self.prior_intervals();
        let parameters = self
            .parameters
            .iter()
            .enumerate()
            .map(|(j, p)| {
                let mut column: Vec<f64> = pooled.iter().map(|d| d[j]).collect();
                column.sort_by(f64::total_cmp);
                let (prior_q05, prior_q95, _) = intervals[j];
                let mut interval = ParameterInterval {
                    name: p.search.name.clone(),
                    mean: mean[j],
                    sd: covariance[j][j].sqrt(),
                    q05: quantile(&column, 0.05),
                    q95: quantile(&column, 0.95),
                    prior_q05,
                    prior_q95,
                    verdict: Verdict::Weak,
                    chains: Some(ChainQuality {
                        rhat: marginals[j].rhat,
                        ess_bulk: marginals[j].ess_bulk,
                        ess_tail: marginals[j].ess_tail,
                    }),
                };
                let median = quantile(&column, 0.5);
                interval.verdict = match (
                    not_converged(&marginals[j], self.settings.chains),
                    conflict(&interval, median, last.parameters.get(j), readings.len()),
                ) {
                    (Some(unconverged), _) => unconverged,
                    (None, Some(conflict)) => conflict,
                    (None, None) => loosened(
                        verdict(&interval, j, &covariance, &self.parameters),
                        &interval,
                        last.parameters.get(j),
                        readings.len(),
                    ),
                };
                interval
            })
            .collect();
        Ok(Posterior {
            holds_used: readings.len(),
            parameters,
            mean,
            covariance,
            how: update.how,
            shared: self.shared_errors_posterior(&study, &pooled),
            wall_s: start.elapsed().as_secs_f64(),
            next_start: Some(update.next),
        })
    }
}

/// `NotConverged` when the parameter's chains have not (R-hat at least
/// [`RHAT_LIMIT`] or a bulk ESS under [`ESS_PER_CHAIN`] per chain).
fn not_converged(marginal: &Marginal, chains: usize) -> Option<Verdict> {
    let rhat_ok = marginal.rhat < RHAT_LIMIT || chains < 2;
    let ess_ok = marginal.ess_bulk >= ESS_PER_CHAIN * chains as f64;
    (!(rhat_ok && ess_ok)).then_some(Verdict::NotConverged {
        rhat: marginal.rhat,
        ess_bulk: marginal.ess_bulk,
    })
}

/// A conflict the interval shows after `holds` holds: its median outside
/// the prior's 90 % interval, or no overlap with `before` (the interval
/// before the last hold).
fn conflict(
    interval: &ParameterInterval,
    median: f64,
    before: Option<&ParameterInterval>,
    holds: usize,
) -> Option<Verdict> {
    let range = |a: f64, b: f64| format!("{}..{}", significant(a), significant(b));
    if !(interval.prior_q05..=interval.prior_q95).contains(&median) {
        return Some(Verdict::Conflict {
            why: format!(
                "the holds put it at {} (90 %), outside its prior's 90 % interval {}: the data and the prior disagree. Check the prior, the twin (geometry, masses) and the transducers (zero, range, certificate)",
                range(interval.q05, interval.q95),
                range(interval.prior_q05, interval.prior_q95)
            ),
        });
    }
    let before = before.filter(|b| b.verdict != Verdict::Prior)?;
    (interval.q95 < before.q05 || interval.q05 > before.q95).then(|| Verdict::Conflict {
        why: format!(
            "its 90 % interval jumped from {} after {} hold(s) to {} after hold {holds}, without overlap: that hold and the earlier ones disagree. Check its sensors (flags, zero) and the twin at its pose",
            range(before.q05, before.q95),
            holds - 1,
            range(interval.q05, interval.q95)
        ),
    })
}

/// `now`, or, for a parameter identified before the last hold and not
/// now, [`Verdict::Loosened`] with why.
fn loosened(
    now: Verdict,
    interval: &ParameterInterval,
    before: Option<&ParameterInterval>,
    holds: usize,
) -> Verdict {
    let Some(before) = before.filter(|b| b.verdict == Verdict::Identified) else {
        return now;
    };
    if now == Verdict::Identified {
        return now;
    }
    let range = |a: f64, b: f64| format!("{}..{}", significant(a), significant(b));
    Verdict::Loosened {
        why: format!(
            "identified after {} ({}), its 90 % interval widened to {} with hold {holds}, past half its prior's{}: that hold adds little on it or pulls it a little elsewhere; the verdict is the interval's now",
            acq_report::number::count(holds - 1, "hold"),
            range(before.q05, before.q95),
            range(interval.q05, interval.q95),
            match &now {
                Verdict::Confounded { with, .. } => format!(" (and confounded with {with})"),
                _ => String::new(),
            }
        ),
    }
}

/// A number to four significant figures, for words.
pub(super) fn significant(x: f64) -> String {
    acq_report::number::significant(x, 4)
}

/// The verdict of parameter `j` with `interval`.
fn verdict(
    interval: &ParameterInterval,
    j: usize,
    covariance: &[Vec<f64>],
    parameters: &[acq_study::study::StudyParameter],
) -> Verdict {
    if interval.width_ratio() <= IDENTIFIED_WIDTH_RATIO {
        return Verdict::Identified;
    }
    let correlation = |k: usize| covariance[j][k] / (covariance[j][j] * covariance[k][k]).sqrt();
    let strongest = (0..covariance.len())
        .filter(|&k| k != j)
        .map(|k| (k, correlation(k)))
        .filter(|(_, rho)| rho.is_finite())
        .max_by(|a, b| a.1.abs().total_cmp(&b.1.abs()));
    match strongest {
        Some((k, rho)) if rho.abs() > CONFOUNDED_CORRELATION => Verdict::Confounded {
            with: parameters[k].search.name.clone(),
            correlation: rho,
        },
        _ => Verdict::Weak,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn interval(q05: f64, q95: f64, verdict: Verdict) -> ParameterInterval {
        ParameterInterval {
            name: "boom.attached_mass_kg".into(),
            mean: (q05 + q95) / 2.0,
            sd: (q95 - q05) / 3.29,
            q05,
            q95,
            prior_q05: 0.0,
            prior_q95: 100.0,
            verdict,
            chains: None,
        }
    }

    #[test]
    fn an_identified_parameter_that_widens_says_why_and_one_that_stays_does_not() {
        let before = interval(40.0, 80.0, Verdict::Identified);
        let now = interval(30.0, 85.0, Verdict::Weak);
        let verdict = loosened(Verdict::Weak, &now, Some(&before), 2);
        assert_eq!(verdict.word(), "weak");
        let why = verdict.why().expect("a flip says why");
        assert!(why.contains("after 1 hold (40.00..80.00)"), "{why}");
        assert!(why.contains("widened to 30.00..85.00 with hold 2"), "{why}");
        // Weak before and now, or identified both times: nothing to explain.
        let weak_before = interval(30.0, 85.0, Verdict::Weak);
        assert_eq!(
            loosened(Verdict::Weak, &now, Some(&weak_before), 2),
            Verdict::Weak
        );
        assert_eq!(
            loosened(Verdict::Identified, &before, Some(&before), 2),
            Verdict::Identified
        );
        assert_eq!(loosened(Verdict::Weak, &now, None, 1), Verdict::Weak);
    }
}
