//! The posterior density of a study: the prior of its parameters times the
//! likelihood of its fit cases' measured values.
//!
//! - **Prior**: uniform over each parameter's bounds (log-uniform for a
//!   parameter searched on a log scale), times a normal density where the
//!   parameter states `prior = { value, uncertainty }`.
//! - **Likelihood**: each measured scalar is the model's value plus
//!   normal error of its stated standard uncertainty. Where a study states
//!   none, the error is `noise %` of the measured value, with `noise`
//!   log-uniform over 0.1-100 % (no transducer in a rig is better than
//!   0.1 %, and none is off by more than its value).
//! - **Discrepancy** (Kennedy and O'Hagan 2001): each model output may
//!   have an additive error, the same in every case or varying over the
//!   cases' inputs ([`super::discrepancy`]).
//!
//! **The scales are integrated out, not sampled.** A noise or discrepancy
//! scale sampled with the parameters makes a funnel (small scales allow
//! only parameters that fit exactly), where a random walk stalls. Each is
//! one-dimensional given the parameters, so the likelihood integrates it
//! by the midpoint rule in its logarithm (spectrally accurate for a smooth
//! peak once the nodes are closer than its width; the node counts below
//! keep them so), and [`StudyPosterior::draw_scales`] draws it afterwards
//! from its conditional at each kept draw: together an exact draw of the
//! joint posterior.
//!
//! Weights are a search's preference, not a statement about the
//! measurement: the likelihood ignores them. The study's `prior` case (its
//! priors as observations, for a search's MAP estimate) is not used: the
//! prior is the prior.

use std::f64::consts::PI;

use acq_algorithms::evaluation::Scale;
use acq_algorithms::mcmc::Support;
use acq_analysis::loss::curve::{test_scatter_by_part, CurveMapeOptions};
use acq_analysis::loss::metrics::{measured_scatter_by_part, points_of, CurveMetric};
use nalgebra::{DMatrix, DVector};
use rand::RngExt;
use rand_distr::{Distribution, StandardNormal};

use super::super::study::{Measured, Observation, Role, Study, StudyParameter};
pub use super::curve_parts::CurveParts;
use super::curve_parts::{correlation_node, curve_log_density, CURVE_CORRELATIONS};
use super::discrepancy::{
    DrawnDiscrepancy, Form, GpDiscrepancy, OutputDiscrepancy, DISCREPANCY_RANGE, DISCREPANCY_SCALE,
    LENGTH_RANGE,
};
use super::scale_grid::{log_sum_exp, ScaleGrid};
use super::settings::Discrepancy;
use super::shared_errors::{loadings_of, ErrorCovariance, LEAST_OWN_SHARE};

/// The lower and upper relative size of the measurement noise when a study
/// states no uncertainty, %.
pub const NOISE_RANGE_PCT: [f64; 2] = [0.1, 100.0];
/// The range of a curve's error factor: from a tenth of what white
/// measurement noise explains to ten thousand times it.
pub const CURVE_FACTOR_RANGE: [f64; 2] = [0.1, 1e4];

/// The posterior of a study: a density over its parameters (the search
/// vector), with the noise and discrepancy scales integrated out.
#[derive(Clone, Debug)]
pub struct StudyPosterior {
    /// The sampled coordinates: the study's parameters.
    pub coordinates: Vec<Coordinate>,
    /// The fit observations the likelihood reads, in the fit simulator's
    /// output order (the index of each into those outputs).
    pub observations: Vec<FitObservation>,
    /// Whether some value states no uncertainty: the relative noise.
    pub noise: bool,
    /// The outputs with a discrepancy.
    pub outputs: Vec<OutputDiscrepancy>,
    /// The measured curves, each read as its parts.
    pub curves: Vec<CurveParts>,
    /// The sources of errors observations share (a transducer each).
    pub shared_sources: Vec<String>,
    /// The scalar observations outside every discrepancy's output, and
    /// their loadings on the errors they share ([`shared_errors`]).
    ///
    /// [`shared_errors`]: super::shared_errors
    ungrouped: Vec<usize>,
    ungrouped_loadings: DMatrix<f64>,
    /// The midpoint rule of the noise's integral.
    noise_grid: ScaleGrid,
}

/// One coordinate of the posterior.
#[derive(Clone, Debug)]
pub struct Coordinate {
    /// Its column in `posterior.csv`.
    pub name: String,
    pub support: Support,
    /// Uniform in the logarithm rather than the value.
    pub log_uniform: bool,
    /// A normal prior `(value, sd)` on top of the bounds.
    pub normal: Option<(f64, f64)>,
}

/// A prior's 90 % interval (its 5 % and 95 % quantiles) and standard
/// deviation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PriorInterval {
    pub q05: f64,
    pub q95: f64,
    pub sd: f64,
}

/// The grid [`Coordinate::prior_interval`] integrates the prior on.
const PRIOR_GRID: usize = 4001;

impl Coordinate {
    /// The quantiles and standard deviation of its prior density (uniform
    /// within the bounds, in the logarithm for a log-uniform one, times the
    /// normal prior when given), by the trapezoid rule on a grid of
    /// [`PRIOR_GRID`] points; NaN without bounds.
    pub fn prior_interval(&self) -> PriorInterval {
        let Support::Interval { lower, upper } = self.support else {
            return PriorInterval {
                q05: f64::NAN,
                q95: f64::NAN,
                sd: f64::NAN,
            };
        };
        let density = |x: f64| {
            let uniform = if self.log_uniform { 1.0 / x } else { 1.0 };
            let normal = self
                .normal
                .map_or(1.0, |(value, sd)| (-0.5 * ((x - value) / sd).powi(2)).exp());
            uniform * normal
        };
        let step = (upper - lower) / (PRIOR_GRID - 1) as f64;
        let xs: Vec<f64> = (0..PRIOR_GRID).map(|k| lower + step * k as f64).collect();
        let ps: Vec<f64> = xs.iter().map(|&x| density(x)).collect();
        // The trapezoid rule's cumulative mass, normalised.
        let mut cumulative = vec![0.0; PRIOR_GRID];
        for k in 1..PRIOR_GRID {
            cumulative[k] = cumulative[k - 1] + 0.5 * (ps[k] + ps[k - 1]) * step;
        }
        let total = cumulative[PRIOR_GRID - 1];
        let quantile_at = |q: f64| {
            let target = q * total;
            let k = cumulative
                .partition_point(|&c| c < target)
                .clamp(1, PRIOR_GRID - 1);
            let (c0, c1) = (cumulative[k - 1], cumulative[k]);
            let t = if c1 > c0 {
                (target - c0) / (c1 - c0)
            } else {
                0.0
            };
            xs[k - 1] + t * step
        };
        let mean = xs.iter().zip(&ps).map(|(x, p)| x * p).sum::<f64>() / ps.iter().sum::<f64>();
        let variance = xs
            .iter()
            .zip(&ps)
            .map(|(x, p)| (x - mean).powi(2) * p)
            .sum::<f64>()
            / ps.iter().sum::<f64>();
        PriorInterval {
            q05: quantile_at(0.05),
            q95: quantile_at(0.95),
            sd: variance.sqrt(),
        }
    }
}

/// A measured scalar the likelihood reads.
#[derive(Clone, Debug)]
pub struct FitObservation {
    /// Its index among the fit simulator's outputs.
    pub output_index: usize,
    /// `case/name` or `name`.
    pub key: String,
    /// The name of its case.
    pub case: String,
    /// The model output it is compared with.
    pub output: String,
    pub measured: f64,
    /// Its standard uncertainty; `None`: the relative noise, or its
    /// curve's noise.
    pub uncertainty: Option<f64>,
    /// The curve (index into [`StudyPosterior::curves`]) this is a part of.
    pub curve: Option<usize>,
    /// The errors it shares with other observations: `(source, effect)`,
    /// the source an index into [`StudyPosterior::shared_sources`], the
    /// effect `c u` (signed, part of `uncertainty`).
    pub shared: Vec<(usize, f64)>,
}

/// The scales drawn at one posterior draw, and each output's discrepancy
/// given them.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Scales {
    pub noise_pct: Option<f64>,
    /// Each curve's error factor, and the correlation of neighbouring
    /// parts' errors.
    pub curve_factor: Vec<f64>,
    pub curve_correlation: Vec<f64>,
    /// Each output's discrepancy (of [`StudyPosterior::outputs`]).
    pub discrepancy: Vec<DrawnDiscrepancy>,
}

impl StudyPosterior {
    /// The posterior of `study`'s fit cases, read from the outputs of a fit
    /// simulator [`StudySimulator::with_curve_parts`]`(curve_parts)`: each
    /// measured curve as its `curve_parts` signed errors (0 when the study
    /// has no curve).
    ///
    /// [`StudySimulator::with_curve_parts`]: crate::simulator::StudySimulator::with_curve_parts
    pub fn new(
        study: &Study,
        discrepancy: Discrepancy,
        curve_parts: usize,
    ) -> Result<Self, String> {
        let read = read_observations(study, curve_parts)?;
        let (observations, mut curves) = (read.observations, read.curves);
        if observations.is_empty() {
            return Err("the fit cases measure nothing the posterior can read".into());
        }
        for curve in &mut curves {
            // Log-uniform: the density of the logarithm is flat.
            let nodes = scale_nodes(CURVE_FACTOR_RANGE, curve.parts.len());
            curve.set_factor_prior(CURVE_FACTOR_RANGE, nodes);
        }
        let outputs = if discrepancy == Discrepancy::None {
            Vec::new()
        } else {
            output_discrepancies(study, discrepancy, &observations)?
        };
        let own_errors = observations
            .iter()
            .enumerate()
            .filter(|(i, o)| {
                o.curve.is_none() && !outputs.iter().any(|d| d.observations.contains(i))
            })
            .map(|(i, _)| i)
            .collect::<Vec<_>>();
        check_shared_within_groups(&observations, &read.shared_sources, &outputs, &own_errors)?;
        let shared: Vec<Vec<(usize, f64)>> =
            observations.iter().map(|o| o.shared.clone()).collect();
        let relative = observations
            .iter()
            .filter(|o| o.uncertainty.is_none() && o.curve.is_none())
            .count();
        Ok(StudyPosterior {
            coordinates: coordinates_of(&study.parameters),
            curves,
            noise: relative > 0,
            // Log-uniform: the density of the logarithm is flat.
            noise_grid: ScaleGrid::new(
                NOISE_RANGE_PCT,
                scale_nodes(NOISE_RANGE_PCT, relative),
                |x| 1.0 / x,
            ),
            ungrouped_loadings: loadings_of(&own_errors, &shared),
            ungrouped: own_errors,
            shared_sources: read.shared_sources,
            observations,
            outputs,
        })
    }

    pub fn support(&self) -> Vec<Support> {
        self.coordinates.iter().map(|c| c.support).collect()
    }

    /// The columns of `posterior.csv` after the parameters: the scales
    /// drawn at each draw.
    pub fn scale_names(&self) -> Vec<String> {
        let mut names = Vec::new();
        if self.noise {
            names.push("measurement_noise_pct".to_string());
        }
        names.extend(self.curves.iter().flat_map(|c| {
            [
                format!("curve_error_factor.{}", c.key),
                format!("curve_error_correlation.{}", c.key),
            ]
        }));
        names.extend(
            self.outputs
                .iter()
                .map(|o| format!("discrepancy_sd.{}", o.output)),
        );
        names.extend(
            self.outputs
                .iter()
                .filter(|o| matches!(o.form, Form::Gp(_)))
                .map(|o| format!("discrepancy_length.{}", o.output)),
        );
        names
    }

    /// Where each scale of [`StudyPosterior::scale_names`] may lie.
    pub fn scale_supports(&self) -> Vec<Support> {
        let interval = |[lower, upper]: [f64; 2]| Support::Interval { lower, upper };
        let mut supports = Vec::new();
        if self.noise {
            supports.push(interval(NOISE_RANGE_PCT));
        }
        supports.extend(
            self.curves
                .iter()
                .flat_map(|_| [interval(CURVE_FACTOR_RANGE), interval([0.0, 0.98])]),
        );
        supports.extend(self.outputs.iter().map(|o| interval(o.tau_range)));
        supports.extend(
            self.outputs
                .iter()
                .filter(|o| matches!(o.form, Form::Gp(_)))
                .map(|_| interval(LENGTH_RANGE)),
        );
        supports
    }

    /// The log prior density of `point` (up to a constant); `-inf`
    /// outside the bounds.
    pub fn log_prior(&self, point: &[f64]) -> f64 {
        let mut log_prior = 0.0;
        for (coordinate, &x) in self.coordinates.iter().zip(point) {
            if let Support::Interval { lower, upper } = coordinate.support {
                if !(lower..=upper).contains(&x) {
                    return f64::NEG_INFINITY;
                }
            }
            if coordinate.log_uniform {
                log_prior -= x.ln();
            }
            if let Some((value, sd)) = coordinate.normal {
                log_prior -= 0.5 * ((x - value) / sd).powi(2);
            }
        }
        log_prior
    }

    /// Each observation's residual `measured - model` at the fit
    /// simulator's `outputs`.
    fn residuals(&self, outputs: &[f64]) -> Vec<f64> {
        self.observations
            .iter()
            .map(|o| o.measured - outputs.get(o.output_index).copied().unwrap_or(f64::NAN))
            .collect()
    }

    /// Each observation's error variance without discrepancy, at a noise
    /// of `noise_pct`, plus the emulator's variance of the model's value
    /// (`emulator`, one per observation; empty for the model itself).
    fn variances(&self, noise_pct: Option<f64>, emulator: &[f64]) -> Vec<f64> {
        self.observations
            .iter()
            .enumerate()
            .map(|(i, o)| {
                let measurement = match (o.uncertainty, o.curve) {
                    (Some(_), _) => own_variance(o),
                    // A curve's part: its curve's noise, added by the caller.
                    (None, Some(_)) => 0.0,
                    (None, None) => (noise_pct.unwrap_or(0.0) / 100.0 * o.measured).powi(2),
                };
                measurement + emulator.get(i).copied().unwrap_or(0.0)
            })
            .collect()
    }

    /// The log likelihood of the fit simulator's `outputs` (with the
    /// emulator's variance of each observation's value, or none), the
    /// scales integrated out (every normalising term kept, so it weighs
    /// them right).
    pub fn log_likelihood(&self, outputs: &[f64], emulator: &[f64]) -> f64 {
        let residuals = self.residuals(outputs);
        if residuals.iter().any(|r| !r.is_finite()) {
            return f64::NEG_INFINITY;
        }
        let scalars = if self.noise {
            self.noise_grid.log_integral(|noise| {
                self.log_likelihood_at_noise(&residuals, Some(noise), emulator)
            })
        } else {
            self.log_likelihood_at_noise(&residuals, None, emulator)
        };
        let value = scalars
            + self
                .curves
                .iter()
                .map(|curve| {
                    let by_correlation = curve.by_correlation(&residuals, emulator);
                    log_sum_exp(&by_correlation) - (CURVE_CORRELATIONS as f64).ln()
                })
                .sum::<f64>();
        if value.is_nan() {
            f64::NEG_INFINITY
        } else {
            value
        }
    }

    /// The log likelihood at one noise, each discrepancy scale integrated out.
    fn log_likelihood_at_noise(
        &self,
        residuals: &[f64],
        noise_pct: Option<f64>,
        emulator: &[f64],
    ) -> f64 {
        let variances = self.variances(noise_pct, emulator);
        let mut total: f64 = self
            .outputs
            .iter()
            .map(|output| output.log_density(residuals, &variances))
            .sum();
        if self.ungrouped_loadings.ncols() == 0 {
            for &i in &self.ungrouped {
                let (r, v) = (residuals[i], variances[i]);
                total -= 0.5 * (r * r / v + v.ln() + (2.0 * PI).ln());
            }
        } else {
            let n = self.ungrouped.len();
            let own = DVector::from_iterator(n, self.ungrouped.iter().map(|&i| variances[i]));
            total += match ErrorCovariance::new(own, &self.ungrouped_loadings) {
                Some(errors) => errors.log_density(&DVector::from_iterator(
                    n,
                    self.ungrouped.iter().map(|&i| residuals[i]),
                )),
                None => f64::NEG_INFINITY,
            };
        }
        total
    }

    /// Draws the noise and each discrepancy scale from their conditional
    /// at the fit simulator's `outputs` (a node by its weight, then a
    /// uniform place in its cell), and each output's discrepancy given them.
    pub fn draw_scales(
        &self,
        outputs: &[f64],
        emulator: &[f64],
        rng: &mut impl rand::Rng,
    ) -> Scales {
        let residuals = self.residuals(outputs);
        let noise_pct = self.noise.then(|| {
            self.noise_grid.draw(
                |noise| self.log_likelihood_at_noise(&residuals, Some(noise), emulator),
                rng,
            )
        });
        let (curve_factor, curve_correlation) = self
            .curves
            .iter()
            .map(|curve| {
                // The correlation from its marginal, then the factor given it.
                let by_correlation = curve.by_correlation(&residuals, emulator);
                let top = by_correlation
                    .iter()
                    .copied()
                    .fold(f64::NEG_INFINITY, f64::max);
                let weights: Vec<f64> = by_correlation.iter().map(|t| (t - top).exp()).collect();
                let mut pick = rng.random::<f64>() * weights.iter().sum::<f64>();
                let mut index = weights.len() - 1;
                for (k, w) in weights.iter().enumerate() {
                    if pick < *w {
                        index = k;
                        break;
                    }
                    pick -= w;
                }
                let correlation = correlation_node(index);
                let factor = curve.grid.draw(
                    |factor| curve_log_density(curve, &residuals, emulator, factor, correlation),
                    rng,
                );
                (factor, correlation)
            })
            .unzip();
        let variances = self.variances(noise_pct, emulator);
        let discrepancy = self
            .outputs
            .iter()
            .map(|output| output.draw(&residuals, &variances, rng))
            .collect();
        Scales {
            noise_pct,
            curve_factor,
            curve_correlation,
            discrepancy,
        }
    }

    /// The standard deviation of observation `i`'s measurement error at
    /// the scales `scales` (a curve part's: its curve's noise).
    pub fn observation_sd(&self, i: usize, scales: &Scales) -> f64 {
        let o = &self.observations[i];
        match (o.uncertainty, o.curve) {
            (Some(u), _) => u,
            (None, Some(c)) => {
                let curve = &self.curves[c];
                // A repeated last part (a short test) has the last part's.
                let part = curve
                    .parts
                    .iter()
                    .position(|&p| p == i)
                    .unwrap_or(curve.parts.len() - 1);
                scales.curve_factor.get(c).copied().unwrap_or(f64::NAN) * curve.scatter_pct[part]
            }
            (None, None) => scales.noise_pct.unwrap_or(0.0) / 100.0 * o.measured.abs(),
        }
    }

    /// The standard deviation of a new measurement's error of a value
    /// measured as `measured` with `uncertainty`, at a noise of `noise_pct`.
    pub fn measurement_sd(
        &self,
        noise_pct: Option<f64>,
        measured: f64,
        uncertainty: Option<f64>,
    ) -> f64 {
        match uncertainty {
            Some(u) => u,
            None => noise_pct.unwrap_or(0.0) / 100.0 * measured.abs(),
        }
    }
}

/// A study's fit observations as the likelihood reads them.
struct ReadObservations {
    observations: Vec<FitObservation>,
    curves: Vec<CurveParts>,
    /// The shared error sources, in the order they first appear.
    shared_sources: Vec<String>,
}

/// The sampled coordinates: a study's parameters with their priors.
pub fn coordinates_of(parameters: &[StudyParameter]) -> Vec<Coordinate> {
    parameters
        .iter()
        .map(|p| {
            let search = &p.search;
            Coordinate {
                name: search.name.clone(),
                support: Support::Interval {
                    lower: search.lower,
                    upper: search.upper,
                },
                log_uniform: search.scale == Scale::Log,
                normal: p.prior.map(|prior| (prior.value, prior.uncertainty)),
            }
        })
        .collect()
}

/// Midpoint-rule nodes of a log-uniform scale over `range` read by `count`
/// values: closer than the peak's width in the logarithm (the likelihood
/// of m values in one scale peaks with a width of about 1 / sqrt(2 m)).
fn scale_nodes(range: [f64; 2], count: usize) -> usize {
    let width = 1.0 / (2.0 * count.max(1) as f64).sqrt();
    (((range[1] / range[0]).ln() / width).ceil() as usize).max(32)
}

/// Every fit scalar, and each fit curve as its `curve_parts` parts (which
/// follow the scalars in the fit outputs, curve after curve).
fn read_observations(study: &Study, curve_parts: usize) -> Result<ReadObservations, String> {
    let mut read = ReadObservations {
        observations: Vec::new(),
        curves: Vec::new(),
        shared_sources: Vec::new(),
    };
    let fit_observations = study.observations(Role::Fit);
    let observed = fit_observations.len();
    for (output_index, (case, observation)) in fit_observations.into_iter().enumerate() {
        if case.priors {
            continue;
        }
        let key = study.key(case, observation);
        match &observation.measured {
            Measured::Scalar { value, uncertainty } => {
                if uncertainty.is_none() && *value == 0.0 {
                    return Err(format!(
                        "{key}: the measured value is 0 and states no uncertainty, so its error has no scale; give it an uncertainty"
                    ));
                }
                let shared = shared_of(&key, observation, *uncertainty, &mut read.shared_sources)?;
                read.observations.push(FitObservation {
                    output_index,
                    key,
                    case: case.name.clone(),
                    output: observation.output.clone(),
                    measured: *value,
                    uncertainty: *uncertainty,
                    curve: None,
                    shared,
                });
            }
            Measured::Curve { points, metric, .. } => {
                if curve_parts == 0 {
                    return Err(format!(
                        "{key}: the posterior reads a curve by its parts; the fit outputs have none"
                    ));
                }
                let first = observed + read.curves.len() * curve_parts;
                let curve = curve_parts_of_observation(
                    &mut read,
                    (&key, &case.name, &observation.output),
                    points,
                    *metric,
                    (first, curve_parts),
                )?;
                read.curves.push(curve);
            }
        }
    }
    Ok(read)
}

/// `observation`'s shared errors as `(source index, effect)`, each source
/// added to `sources` when new; refused where they take more than its
/// stated uncertainty or it states none.
fn shared_of(
    key: &str,
    observation: &Observation,
    uncertainty: Option<f64>,
    sources: &mut Vec<String>,
) -> Result<Vec<(usize, f64)>, String> {
    if observation.shared.is_empty() {
        return Ok(Vec::new());
    }
    let Some(u) = uncertainty else {
        return Err(format!(
            "{key}: errors shared with other values but no uncertainty stated; the shared errors are parts of it"
        ));
    };
    let shared_variance: f64 = observation.shared.iter().map(|s| s.effect * s.effect).sum();
    if !(shared_variance.is_finite() && shared_variance <= u * u * (1.0 + 1e-9)) {
        return Err(format!(
            "{key}: its shared errors ({:.4e} combined) exceed its uncertainty {u:.4e}; they are parts of it",
            shared_variance.sqrt()
        ));
    }
    Ok(observation
        .shared
        .iter()
        .map(|s| {
            let index = match sources.iter().position(|t| *t == s.source) {
                Some(index) => index,
                None => {
                    sources.push(s.source.clone());
                    sources.len() - 1
                }
            };
            (index, s.effect)
        })
        .collect())
}

/// A measured curve's parts as observations (appended to `read`), and the
/// curve that reads them; `first` is the first part's output index.
fn curve_parts_of_observation(
    read: &mut ReadObservations,
    (key, case, output): (&str, &str, &str),
    points: &[(f64, f64)],
    metric: CurveMetric,
    (first, curve_parts): (usize, usize),
) -> Result<CurveParts, String> {
    let mut parts = Vec::with_capacity(curve_parts);
    for part in 0..curve_parts {
        parts.push(read.observations.len());
        read.observations.push(FitObservation {
            output_index: first + part,
            key: format!("{key}.part{:02}", part + 1),
            case: case.to_string(),
            output: format!("{output}.part{:02}", part + 1),
            measured: 0.0,
            uncertainty: None,
            curve: Some(read.curves.len()),
            shared: Vec::new(),
        });
    }
    let mut scatter_pct = if metric == CurveMetric::Mape {
        test_scatter_by_part(points, CurveMapeOptions::default(), curve_parts)
            .map_err(|e| format!("{key}: {e}"))?
    } else {
        measured_scatter_by_part(&points_of(points), curve_parts)
            .map_err(|e| format!("{key}: {e}"))?
    };
    if metric == CurveMetric::Mape {
        // A test with fewer grid points than parts: the simulator's last
        // part repeats to fill its outputs, and the likelihood reads it
        // once (a repeat would count one point's error many times over).
        parts.truncate(scatter_pct.len().max(1));
    }
    let last = scatter_pct.last().copied().unwrap_or(1.0);
    scatter_pct.resize(parts.len(), last);
    Ok(CurveParts::new(key.to_string(), parts, scatter_pct, metric))
}

/// Each model output's discrepancy over its scalar observations (a
/// curve's parts carry their own noise, which takes up the model's error
/// along it too).
fn output_discrepancies(
    study: &Study,
    discrepancy: Discrepancy,
    observations: &[FitObservation],
) -> Result<Vec<OutputDiscrepancy>, String> {
    let mut outputs: Vec<OutputDiscrepancy> = Vec::new();
    for (index, observation) in observations
        .iter()
        .enumerate()
        .filter(|(_, o)| o.curve.is_none())
    {
        match outputs.iter_mut().find(|o| o.output == observation.output) {
            Some(output) => output.observations.push(index),
            None => outputs.push(OutputDiscrepancy {
                output: observation.output.clone(),
                observations: vec![index],
                tau_range: [0.0; 2],
                tau_grid: ScaleGrid::new([1.0, 2.0], 1, |_| 1.0),
                form: Form::Constant,
                loadings: DMatrix::zeros(0, 0),
            }),
        }
    }
    let shared: Vec<Vec<(usize, f64)>> = observations.iter().map(|o| o.shared.clone()).collect();
    for output in &mut outputs {
        output.loadings = loadings_of(&output.observations, &shared);
        let size = output
            .observations
            .iter()
            .map(|&i| observations[i].measured.abs())
            .sum::<f64>()
            / output.observations.len() as f64;
        let largest_uncertainty = output
            .observations
            .iter()
            .filter_map(|&i| observations[i].uncertainty)
            .fold(0.0f64, f64::max);
        let size = size.max(10.0 * largest_uncertainty);
        if !(size > 0.0 && size.is_finite()) {
            return Err(format!(
                "{}: measured as 0 without an uncertainty, so its discrepancy has no scale; give it an uncertainty",
                output.output
            ));
        }
        output.tau_range = DISCREPANCY_RANGE.map(|r| r * size);
        let half_cauchy_scale = DISCREPANCY_SCALE * size;
        output.tau_grid = ScaleGrid::new(
            output.tau_range,
            scale_nodes(output.tau_range, output.observations.len()),
            |tau| 1.0 / (1.0 + (tau / half_cauchy_scale).powi(2)),
        );
        if discrepancy == Discrepancy::Gp {
            let mut gp = gp_sites(study, output, observations)?;
            let stated: Option<Vec<f64>> = output
                .observations
                .iter()
                .map(|&i| {
                    observations[i]
                        .uncertainty
                        .map(|_| own_variance(&observations[i]))
                })
                .collect();
            if let Some(variances) = stated {
                gp.fix_variances(variances, &output.loadings, &output.tau_grid);
            }
            output.form = Form::Gp(Box::new(gp));
        }
    }
    Ok(outputs)
}

/// Each shared source lies in one group the likelihood integrates as one
/// (an output's discrepancy, or the values without one): a transducer
/// shared by two outputs with a discrepancy each would couple their
/// scales, which are integrated one output at a time.
fn check_shared_within_groups(
    observations: &[FitObservation],
    sources: &[String],
    outputs: &[OutputDiscrepancy],
    ungrouped: &[usize],
) -> Result<(), String> {
    for (source_index, source) in sources.iter().enumerate() {
        let groups: Vec<&str> = outputs
            .iter()
            .map(|o| (o.output.as_str(), o.observations.as_slice()))
            .chain(std::iter::once(("values without a discrepancy", ungrouped)))
            .filter(|(_, members)| {
                members.iter().any(|&i| {
                    observations[i]
                        .shared
                        .iter()
                        .any(|(s, _)| *s == source_index)
                })
            })
            .map(|(name, _)| name)
            .collect();
        if groups.len() > 1 {
            return Err(format!(
                "{source}'s error is shared by {}: with a discrepancy each output needs its own sensors; use discrepancy = \"none\", or the readings' scatter alone (\"{}\") for one of them",
                groups.join(" and "),
                crate::study::SCATTER_OF_MEAN
            ));
        }
    }
    Ok(())
}

/// An observation's own error variance: its stated uncertainty's square
/// less the parts it shares (at least [`LEAST_OWN_SHARE`] of it).
fn own_variance(observation: &FitObservation) -> f64 {
    let u2 = observation.uncertainty.map_or(0.0, |u| u * u);
    let shared: f64 = observation.shared.iter().map(|(_, e)| e * e).sum();
    (u2 - shared).max(LEAST_OWN_SHARE * u2)
}

/// A `gp` discrepancy's sites: every case, fit and validate, that
/// measures `output`'s model output, by its fixed inputs.
fn gp_sites(
    study: &Study,
    output: &OutputDiscrepancy,
    observations: &[FitObservation],
) -> Result<GpDiscrepancy, String> {
    let mut sites: Vec<(String, Vec<(String, f64)>)> = Vec::new();
    for role in [Role::Fit, Role::Validate] {
        for (_, case) in study.cases_with(role) {
            let measures = case.observations.iter().any(|o| {
                o.output == output.output && matches!(o.measured, Measured::Scalar { .. })
            });
            if !case.priors && measures && !sites.iter().any(|(name, _)| *name == case.name) {
                sites.push((case.name.clone(), case.inputs.clone()));
            }
        }
    }
    let observation_sites = output
        .observations
        .iter()
        .map(|&i| {
            sites
                .iter()
                .position(|(name, _)| *name == observations[i].case)
                .unwrap_or(0)
        })
        .collect();
    GpDiscrepancy::new(sites, observation_sites).map_err(|e| {
        format!(
            "[posterior] discrepancy = \"gp\" for {}: {e}",
            output.output
        )
    })
}

/// A standard normal draw.
pub fn standard_normal(rng: &mut impl rand::Rng) -> f64 {
    Distribution::<f64>::sample(&StandardNormal, rng)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::study::{Case, LossKind, Observation, Residuals, StudyParameter};
    use acq_algorithms::evaluation::Parameter;
    use rand::SeedableRng;

    fn study(values: &[(f64, Option<f64>)]) -> Study {
        let observation = |i: usize, (value, uncertainty): (f64, Option<f64>)| Observation {
            name: format!("y{i}"),
            output: "y".into(),
            measured: Measured::Scalar { value, uncertainty },
            weight: 1.0,
            source: String::new(),
            shared: Vec::new(),
        };
        Study {
            parameters: vec![StudyParameter {
                search: Parameter::new("a", 0.0, 2.0),
                input: "a".into(),
                case: None,
                nominal: 1.0,
                prior: None,
            }],
            cases: values
                .iter()
                .enumerate()
                .map(|(i, &v)| Case::new(format!("c{i}"), Role::Fit, vec![observation(i, v)]))
                .collect(),
            named_cases: true,
            residuals: Residuals::Normalised,
            loss: LossKind::Squares,
        }
    }

    /// The closed form of the constant discrepancy is the density of the
    /// residuals under their full covariance.
    #[test]
    fn the_constant_discrepancy_is_the_normal_density_of_correlated_residuals() {
        let posterior = StudyPosterior::new(
            &study(&[(1.0, Some(0.1)), (2.0, Some(0.2))]),
            Discrepancy::Constant,
            0,
        )
        .unwrap();
        let tau: f64 = 0.3;
        let (r0, r1): (f64, f64) = (1.0 - 1.2, 2.0 - 1.5);
        let (a, b, c) = (0.01 + tau * tau, tau * tau, 0.04 + tau * tau);
        let det = a * c - b * b;
        let quadratic = (c * r0 * r0 - 2.0 * b * r0 * r1 + a * r1 * r1) / det;
        let expected = -0.5 * (quadratic + det.ln() + 2.0 * (2.0 * PI).ln());
        let got = posterior.outputs[0].constant_log_density(
            &[r0, r1],
            &posterior.variances(None, &[]),
            tau,
        );
        assert!((got - expected).abs() < 1e-12, "{got} {expected}");
    }

    /// The noise integrated by the midpoint rule equals the closed form:
    /// with a log-uniform noise over [lo, hi] and m residuals, the
    /// integral is an incomplete gamma function.
    #[test]
    fn the_noise_integral_equals_its_incomplete_gamma_closed_form() {
        let values = [(4.0, None), (5.0, None), (8.0, None)];
        let posterior = StudyPosterior::new(&study(&values), Discrepancy::None, 0).unwrap();
        let outputs = [4.2, 4.9, 8.5];
        let got = posterior.log_likelihood(&outputs, &[]);
        // sum (r / y)^2 and the product of 1 / (sqrt(2 pi) |y|).
        let q: f64 = values
            .iter()
            .zip(outputs)
            .map(|((y, _), m)| ((y - m) / y).powi(2))
            .sum();
        let m = 3.0;
        let [low, high] = NOISE_RANGE_PCT.map(|p| p / 100.0);
        let a = m / 2.0;
        let p = |x: f64| statrs::function::gamma::gamma_lr(a, x);
        let integral = ((high / low).ln()).recip()
            * 0.5
            * (2.0 / q).powf(a)
            * statrs::function::gamma::gamma(a)
            * (p(q / (2.0 * low * low)) - p(q / (2.0 * high * high)));
        let constant: f64 = values
            .iter()
            .map(|(y, _)| -(2.0 * PI).sqrt().ln() - y.ln())
            .sum();
        let expected = integral.ln() + constant;
        // The midpoint rule's error, far below any Monte-Carlo error.
        assert!((got - expected).abs() < 1e-5, "{got} {expected}");
    }

    /// The curve's fast path (no emulator variance) is the full density.
    #[test]
    fn a_curve_density_without_an_emulator_equals_its_fast_form() {
        let curve = CurveParts::new(
            "c".into(),
            vec![0, 1, 2, 3],
            vec![0.5, 0.2, 0.1, 0.1],
            CurveMetric::Mape,
        );
        let residuals = [0.3, -0.1, 0.05, 0.2];
        for (factor, correlation) in [(1.0, 0.0), (3.0, 0.5), (0.4, 0.9)] {
            let full = curve_log_density(&curve, &residuals, &[], factor, correlation);
            let (quadratic, constant) = curve.unit_factor_terms(&residuals, correlation);
            let fast = -0.5 * quadratic / (factor * factor) - 4.0 * f64::ln(factor) - constant;
            assert!((full - fast).abs() < 1e-12, "{full} {fast}");
        }
        // And with the factor integrated out, as the chains read it: the
        // constants summed once at construction and the factor's integral
        // in closed form give the full density's integral at every
        // correlation node, by a midpoint rule far finer than a chain's.
        let mut curve = curve;
        curve.set_factor_prior(CURVE_FACTOR_RANGE, 40);
        let fine = ScaleGrid::new(CURVE_FACTOR_RANGE, 20_000, |x| 1.0 / x);
        let fast = curve.by_correlation(&residuals, &[]);
        // An emulator's variance too small to count takes the nodes' way,
        // within the 40 nodes' midpoint rule's own error.
        let by_nodes = curve.by_correlation(&residuals, &[1e-300; 4]);
        for (k, fast) in fast.iter().enumerate() {
            let full = fine.log_integral(|factor| {
                curve_log_density(&curve, &residuals, &[], factor, correlation_node(k))
            });
            assert!((full - fast).abs() < 1e-9, "node {k}: {full} {fast}");
            assert!(
                (by_nodes[k] - fast).abs() < 1e-5,
                "node {k}: {} {fast}",
                by_nodes[k]
            );
        }
    }

    #[test]
    fn scales_are_drawn_inside_their_ranges_and_named() {
        let posterior = StudyPosterior::new(
            &study(&[(4.0, None), (6.0, None)]),
            Discrepancy::Constant,
            0,
        )
        .unwrap();
        assert_eq!(
            posterior.scale_names(),
            ["measurement_noise_pct", "discrepancy_sd.y"]
        );
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(1);
        for _ in 0..100 {
            let scales = posterior.draw_scales(&[4.1, 5.0], &[], &mut rng);
            let noise = scales.noise_pct.unwrap();
            assert!((NOISE_RANGE_PCT[0]..=NOISE_RANGE_PCT[1]).contains(&noise));
            let range = posterior.outputs[0].tau_range;
            assert!((range[0]..=range[1]).contains(&scales.discrepancy[0].tau));
        }
        assert!(posterior.log_prior(&[3.0]).is_infinite());
    }

    /// Two holds read by one transducer whose error is shared, plus a
    /// value of another: the likelihood is the normal density under the
    /// covariance with the shared error's square off the diagonal.
    #[test]
    fn a_shared_transducer_error_correlates_the_holds_it_measured() {
        use crate::study::SharedError;
        let mut study = study(&[(10.0, Some(0.5)), (12.0, Some(0.5)), (3.0, Some(0.2))]);
        for case in &mut study.cases[..2] {
            case.observations[0].shared = vec![SharedError {
                source: "boom_head_pressure".into(),
                effect: 0.4,
            }];
        }
        let posterior = StudyPosterior::new(&study, Discrepancy::None, 0).unwrap();
        assert_eq!(posterior.shared_sources, ["boom_head_pressure"]);
        let outputs = [9.5, 11.0, 3.1];
        let (r0, r1, r2): (f64, f64, f64) = (0.5, 1.0, -0.1);
        // Own variance 0.25 - 0.16 = 0.09, shared 0.16.
        let (a, b) = (0.25, 0.16);
        let det = a * a - b * b;
        let quadratic = (a * r0 * r0 - 2.0 * b * r0 * r1 + a * r1 * r1) / det;
        let expected = -0.5 * (quadratic + det.ln() + 2.0 * (2.0 * PI).ln())
            - 0.5 * (r2 * r2 / 0.04 + 0.04f64.ln() + (2.0 * PI).ln());
        let got = posterior.log_likelihood(&outputs, &[]);
        assert!((got - expected).abs() < 1e-12, "{got} {expected}");
        // Shared by two outputs that each have a discrepancy: refused.
        study.cases[2].observations[0].output = "z".into();
        study.cases[2].observations[0].shared = vec![SharedError {
            source: "boom_head_pressure".into(),
            effect: 0.1,
        }];
        let error = StudyPosterior::new(&study, Discrepancy::Constant, 0).unwrap_err();
        assert!(
            error.contains("boom_head_pressure") && error.contains("y and z"),
            "{error}"
        );
        // A shared part larger than the value's uncertainty: refused.
        study.cases[2].observations[0].shared[0].effect = 0.3;
        let error = StudyPosterior::new(&study, Discrepancy::None, 0).unwrap_err();
        assert!(error.contains("exceed its uncertainty"), "{error}");
    }
}
