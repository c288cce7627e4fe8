//! The model's own error (Kennedy and O'Hagan 2001): an additive
//! discrepancy `delta` per model output, with its scale `tau` integrated
//! out (and with `gp` its length over the cases' inputs).
//!
//! - `constant`: `delta` is the same in every case, normal with sd `tau`.
//!   The residuals of one output are jointly normal with covariance
//!   `diag(u^2) + tau^2 1 1'`, whose density has a closed form
//!   (Sherman-Morrison).
//! - `gp`: `delta` varies smoothly over the cases' fixed inputs, a Gaussian
//!   process with sd `tau` and a squared-exponential correlation of length
//!   `l`: covariance `diag(u^2) + tau^2 K(l)`. The inputs are those every
//!   case of the output sets and that differ between cases, each scaled by
//!   its range over those cases, so `l` is in ranges; its prior is
//!   log-uniform over [`LENGTH_RANGE`]: from a tenth of the range (each
//!   case its own error) to ten ranges (a constant, the `constant` model
//!   nested in it). A validate case's discrepancy is the process's
//!   conditional at its inputs: near a fit case it is the error measured
//!   there, far from every one it falls back to the prior, `tau`.
//!
//! The scale's prior is half-Cauchy with a scale of 10 % of the output's
//! measured size, the weakly informative prior Gelman (2006) recommends
//! for a hierarchical scale: flat near zero, so a model that happens to
//! fit one value exactly makes no spike there (a log-uniform prior would),
//! and with a tail that allows an error as large as the value.

use std::f64::consts::PI;

use nalgebra::{DMatrix, DVector};

use super::scale_grid::ScaleGrid;
use super::shared_errors::ErrorCovariance;

/// The half-Cauchy scale of the discrepancy's standard deviation,
/// relative to the output's size, and the range its integral covers (below
/// it the prior is flat and the likelihood no larger than at its lower
/// end, so the part left out is below 1e-5 of the prior's mass; above it
/// the Cauchy tail holds 0.6 %).
pub const DISCREPANCY_SCALE: f64 = 0.1;
pub const DISCREPANCY_RANGE: [f64; 2] = [1e-6, 10.0];
/// The range of the `gp` discrepancy's correlation length, in ranges of
/// the cases' inputs, and its midpoint rule's cells (the likelihood of a
/// handful of cases changes slowly in the length: a cell is a factor 1.5).
pub const LENGTH_RANGE: [f64; 2] = [0.1, 10.0];
const LENGTH_NODES: usize = 12;

/// One model output's discrepancy.
#[derive(Clone, Debug)]
pub struct OutputDiscrepancy {
    pub output: String,
    /// Its fit observations (indices into the posterior's observations).
    pub observations: Vec<usize>,
    /// The range its scale's integral covers.
    pub tau_range: [f64; 2],
    pub tau_grid: ScaleGrid,
    pub form: Form,
    /// Its observations' loadings on the errors they share (a row each, a
    /// column per source; no column when they share none).
    pub loadings: DMatrix<f64>,
}

/// How the discrepancy varies over the cases.
#[derive(Clone, Debug)]
pub enum Form {
    Constant,
    Gp(Box<GpDiscrepancy>),
}

/// A `gp` discrepancy's places: where each case lies in the inputs.
#[derive(Clone, Debug)]
pub struct GpDiscrepancy {
    /// The inputs the process varies over.
    pub inputs: Vec<String>,
    /// Every case with this output, fit and validate: where the
    /// discrepancy is reported and predicted.
    pub sites: Vec<Site>,
    /// The site of each fit observation.
    observation_sites: Vec<usize>,
    pub length_grid: ScaleGrid,
    /// The fit observations' correlation matrix at each length node.
    correlations: Vec<DMatrix<f64>>,
    /// Each node's [`Whitened`] form at the stated variances, kept while
    /// the variances stay those (no noise scale, no emulator).
    fixed: Option<FixedForms>,
}

/// One output's observations as its density reads them: their residuals,
/// their own error variances, and the covariance of their errors (the
/// variances with the errors they share).
pub(super) struct Group {
    residuals: DVector<f64>,
    variances: DVector<f64>,
    errors: ErrorCovariance,
}

/// `W K W' = Q diag(lambda) Q'` with `W` the measurement errors' whitening
/// (`diag(v)^-1/2`, or `L^-1` of `C = diag(v) + S S' = L L'` when they
/// share errors), kept as `lambda` and `Q' W`: then for every `tau` the
/// density under `C + tau^2 K` is a sum over the eigenvalues, with no
/// factorisation per `tau`.
#[derive(Clone, Debug)]
struct Whitened {
    eigenvalues: DVector<f64>,
    rotation: DMatrix<f64>,
    log_det_variances: f64,
}

impl Whitened {
    fn new(correlation: &DMatrix<f64>, errors: &ErrorCovariance) -> Self {
        let (scaled, whitening) = match errors {
            ErrorCovariance::Diagonal(variances) => {
                let scale = variances.map(|v| 1.0 / v.sqrt());
                let scaled = DMatrix::from_fn(correlation.nrows(), correlation.ncols(), |i, j| {
                    scale[i] * correlation[(i, j)] * scale[j]
                });
                (scaled, DMatrix::from_diagonal(&scale))
            }
            ErrorCovariance::Full { .. } => {
                let whitening = errors.inverse_factor();
                let scaled = &whitening * correlation * whitening.transpose();
                // Symmetric up to rounding; the eigen solver reads one half.
                (0.5 * (&scaled + scaled.transpose()), whitening)
            }
        };
        let eigen = scaled.symmetric_eigen();
        Whitened {
            // Rounding can leave a zero eigenvalue of a near-singular K
            // slightly negative; K is positive semi-definite.
            eigenvalues: eigen.eigenvalues.map(|l| l.max(0.0)),
            rotation: eigen.eigenvectors.transpose() * whitening,
            log_det_variances: errors.log_det(),
        }
    }

    /// At each of `taus`, the log determinant of the residuals'
    /// covariance (`ln det` of the errors' plus `sum ln(1 + tau^2
    /// lambda)`): the density's normalising term, which the residuals do
    /// not change.
    fn log_dets(&self, taus: &[f64]) -> Vec<f64> {
        taus.iter()
            .map(|&tau| {
                let tau2 = tau * tau;
                let mut log_det = self.log_det_variances;
                for lambda in self.eigenvalues.iter() {
                    log_det += (1.0 + tau2 * lambda).ln();
                }
                log_det
            })
            .collect()
    }

    /// [`Whitened::log_density`] at the `k`-th of `taus`, its log
    /// determinant `log_dets[k]` ([`Whitened::log_dets`]): the same value
    /// to the bit, without a logarithm per eigenvalue.
    fn log_density_at_nodes<'a>(
        &'a self,
        residuals: &DVector<f64>,
        taus: &'a [f64],
        log_dets: &'a [f64],
    ) -> impl Fn(usize) -> f64 + 'a {
        let rotated = &self.rotation * residuals;
        let n = residuals.len() as f64;
        move |k: usize| {
            let tau2 = taus[k] * taus[k];
            let mut quadratic = 0.0;
            for (z, lambda) in rotated.iter().zip(self.eigenvalues.iter()) {
                quadratic += z * z / (1.0 + tau2 * lambda);
            }
            -0.5 * (quadratic + log_dets[k] + n * (2.0 * PI).ln())
        }
    }

    /// The log density of `residuals` for each `tau` the integral asks.
    fn log_density(&self, residuals: &DVector<f64>) -> impl Fn(f64) -> f64 + '_ {
        let rotated = &self.rotation * residuals;
        let n = residuals.len() as f64;
        move |tau: f64| {
            let tau2 = tau * tau;
            let (mut quadratic, mut log_det) = (0.0, self.log_det_variances);
            for (z, lambda) in rotated.iter().zip(self.eigenvalues.iter()) {
                let stretch = 1.0 + tau2 * lambda;
                quadratic += z * z / stretch;
                log_det += stretch.ln();
            }
            -0.5 * (quadratic + log_det + n * (2.0 * PI).ln())
        }
    }
}

/// The whitened forms at the observations' stated variances, one per
/// length node, and their log determinants at each scale node.
#[derive(Clone, Debug)]
struct FixedForms {
    variances: DVector<f64>,
    whitened: Vec<Whitened>,
    taus: Vec<f64>,
    /// Per length node, per scale node.
    log_dets: Vec<Vec<f64>>,
}

/// A case's place in the scaled inputs.
#[derive(Clone, Debug, PartialEq)]
pub struct Site {
    pub case: String,
    pub place: Vec<f64>,
}

/// The discrepancy drawn at one posterior draw: its scale, its length
/// (`gp`), and at each site (one for `constant`) its conditional normal
/// `(mean, variance)` given the draw's residuals.
#[derive(Clone, Debug, PartialEq)]
pub struct DrawnDiscrepancy {
    pub tau: f64,
    pub length: Option<f64>,
    pub at_sites: Vec<(f64, f64)>,
}

impl GpDiscrepancy {
    /// The process over `sites` (case name and raw inputs), read at the
    /// fit observations' sites. `Err` when the cases do not differ in any
    /// input they all set.
    pub fn new(
        sites: Vec<(String, Vec<(String, f64)>)>,
        observation_sites: Vec<usize>,
    ) -> Result<Self, String> {
        let Some((_, first)) = sites.first() else {
            return Err("no case to place".into());
        };
        let mut inputs = Vec::new();
        let mut spans = Vec::new();
        for (name, _) in first {
            let values: Option<Vec<f64>> = sites
                .iter()
                .map(|(_, inputs)| inputs.iter().find(|(n, _)| n == name).map(|(_, v)| *v))
                .collect();
            let Some(values) = values else { continue };
            let low = values.iter().copied().fold(f64::INFINITY, f64::min);
            let high = values.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            if high > low && !inputs.contains(name) {
                inputs.push(name.clone());
                spans.push((low, high - low));
            }
        }
        if inputs.is_empty() {
            return Err(
                "its cases set no input that differs between them, so a discrepancy that varies over the inputs is a constant one: use discrepancy = \"constant\", or give the cases their inputs (`inputs = { ... }`)".into(),
            );
        }
        let sites: Vec<Site> = sites
            .into_iter()
            .map(|(case, raw)| Site {
                place: inputs
                    .iter()
                    .zip(&spans)
                    .map(|(name, (low, span))| {
                        let value = raw.iter().find(|(n, _)| n == name).map_or(0.0, |(_, v)| *v);
                        (value - low) / span
                    })
                    .collect(),
                case,
            })
            .collect();
        // Log-uniform: the density of the logarithm is flat.
        let length_grid = ScaleGrid::new(LENGTH_RANGE, LENGTH_NODES, |x| 1.0 / x);
        let places: Vec<&[f64]> = observation_sites
            .iter()
            .map(|&s| sites[s].place.as_slice())
            .collect();
        let correlations = length_grid
            .nodes
            .iter()
            .map(|&length| correlation_matrix(&places, &places, length))
            .collect();
        Ok(GpDiscrepancy {
            inputs,
            sites,
            observation_sites,
            length_grid,
            correlations,
            fixed: None,
        })
    }

    /// Keeps the whitened forms at `variances` (the observations' stated
    /// ones) with the errors they share (`loadings`), for every
    /// evaluation that has exactly these.
    /// With them, the log determinants at each of `tau_grid`'s nodes.
    pub fn fix_variances(
        &mut self,
        variances: Vec<f64>,
        loadings: &DMatrix<f64>,
        tau_grid: &ScaleGrid,
    ) {
        let variances = DVector::from_vec(variances);
        let Some(errors) = ErrorCovariance::new(variances.clone(), loadings) else {
            return;
        };
        let whitened: Vec<Whitened> = self
            .correlations
            .iter()
            .map(|k| Whitened::new(k, &errors))
            .collect();
        let taus = tau_grid.nodes.clone();
        let log_dets = whitened.iter().map(|w| w.log_dets(&taus)).collect();
        self.fixed = Some(FixedForms {
            variances,
            whitened,
            taus,
            log_dets,
        });
    }

    /// The log likelihood of one output's residuals, tau and length
    /// integrated out.
    fn log_density(&self, tau_grid: &ScaleGrid, group: &Group) -> f64 {
        let integrate =
            |whitened: &Whitened| tau_grid.log_integral(whitened.log_density(&group.residuals));
        match &self.fixed {
            Some(fixed) if fixed.variances == group.variances && fixed.taus == tau_grid.nodes => {
                self.length_grid.log_integral_by_node(|k| {
                    let log_density = fixed.whitened[k].log_density_at_nodes(
                        &group.residuals,
                        &fixed.taus,
                        &fixed.log_dets[k],
                    );
                    tau_grid.log_integral_by_node(log_density)
                })
            }
            _ => self.length_grid.log_integral_by_node(|k| {
                integrate(&Whitened::new(&self.correlations[k], &group.errors))
            }),
        }
    }
}

impl OutputDiscrepancy {
    /// The sites its discrepancy is given at: every case (`gp`), or one
    /// for all (`constant`, named by an empty case).
    pub fn sites(&self) -> Vec<&str> {
        match &self.form {
            Form::Constant => vec![""],
            Form::Gp(gp) => gp.sites.iter().map(|s| s.case.as_str()).collect(),
        }
    }

    /// The index of `case`'s site: `constant`'s only one, or the case's.
    pub fn site_of(&self, case: &str) -> Option<usize> {
        match &self.form {
            Form::Constant => Some(0),
            Form::Gp(gp) => gp.sites.iter().position(|s| s.case == case),
        }
    }

    /// The log density of its observations' residuals (with error
    /// variances `variances`, indexed like all observations), the
    /// discrepancy's scale (and length) integrated out.
    pub fn log_density(&self, residuals: &[f64], variances: &[f64]) -> f64 {
        match &self.form {
            Form::Constant => self
                .tau_grid
                .log_integral(|tau| self.constant_log_density(residuals, variances, tau)),
            Form::Gp(gp) => match self.group(residuals, variances) {
                Some(group) => gp.log_density(&self.tau_grid, &group),
                None => f64::NEG_INFINITY,
            },
        }
    }

    /// The scale (and length) drawn from their conditional given the
    /// residuals, and the discrepancy at each site given them.
    pub fn draw(
        &self,
        residuals: &[f64],
        variances: &[f64],
        rng: &mut impl rand::Rng,
    ) -> DrawnDiscrepancy {
        match &self.form {
            Form::Constant => {
                let tau = self.tau_grid.draw(
                    |tau| self.constant_log_density(residuals, variances, tau),
                    rng,
                );
                let (_, sum_r, precision, _) = self.constant_terms(residuals, variances);
                let precision = precision + 1.0 / (tau * tau);
                DrawnDiscrepancy {
                    tau,
                    length: None,
                    at_sites: vec![(sum_r / precision, 1.0 / precision)],
                }
            }
            Form::Gp(gp) => {
                let Some(group) = self.group(residuals, variances) else {
                    return DrawnDiscrepancy {
                        tau: f64::NAN,
                        length: None,
                        at_sites: vec![(f64::NAN, f64::NAN); gp.sites.len()],
                    };
                };
                let length = gp.length_grid.draw(
                    |length| {
                        let whitened =
                            Whitened::new(&self.correlation_at(gp, length), &group.errors);
                        self.tau_grid
                            .log_integral(whitened.log_density(&group.residuals))
                    },
                    rng,
                );
                let correlation = self.correlation_at(gp, length);
                let whitened = Whitened::new(&correlation, &group.errors);
                let tau = self
                    .tau_grid
                    .draw(whitened.log_density(&group.residuals), rng);
                DrawnDiscrepancy {
                    tau,
                    length: Some(length),
                    at_sites: gp_conditional(gp, &group, &correlation, tau, length),
                }
            }
        }
    }

    /// `r' C^-1 r`, `1' C^-1 r`, `1' C^-1 1` and `ln det C` of its
    /// observations, `C` their errors' covariance (`diag(v)` when they
    /// share none); NaN where `C` is not positive definite.
    fn constant_terms(&self, residuals: &[f64], variances: &[f64]) -> (f64, f64, f64, f64) {
        if self.loadings.ncols() == 0 {
            let (mut r2, mut sum_r, mut precision, mut log_det) = (0.0, 0.0, 0.0, 0.0);
            for &i in &self.observations {
                let (r, v) = (residuals[i], variances[i]);
                r2 += r * r / v;
                sum_r += r / v;
                precision += 1.0 / v;
                log_det += v.ln();
            }
            return (r2, sum_r, precision, log_det);
        }
        let Some(group) = self.group(residuals, variances) else {
            return (f64::NAN, f64::NAN, f64::NAN, f64::NAN);
        };
        let ones = DVector::from_element(self.observations.len(), 1.0);
        let solved = group.errors.solve(&group.residuals);
        (
            group.residuals.dot(&solved),
            ones.dot(&solved),
            ones.dot(&group.errors.solve(&ones)),
            group.errors.log_det(),
        )
    }

    /// `constant`: the density of the residuals under `C + tau^2 1 1'`,
    /// `C` the measurement errors' covariance (Sherman-Morrison).
    pub(super) fn constant_log_density(
        &self,
        residuals: &[f64],
        variances: &[f64],
        tau: f64,
    ) -> f64 {
        let tau2 = tau * tau;
        let (r2, sum_r, precision, log_det) = self.constant_terms(residuals, variances);
        let shrink = 1.0 + tau2 * precision;
        let quadratic = r2 - tau2 * sum_r * sum_r / shrink;
        -0.5 * (quadratic
            + log_det
            + shrink.ln()
            + self.observations.len() as f64 * (2.0 * PI).ln())
    }

    /// Its observations' residuals, variances and errors' covariance;
    /// `None` when that is not positive definite.
    fn group(&self, residuals: &[f64], variances: &[f64]) -> Option<Group> {
        let n = self.observations.len();
        let variances = DVector::from_iterator(n, self.observations.iter().map(|&i| variances[i]));
        Some(Group {
            residuals: DVector::from_iterator(n, self.observations.iter().map(|&i| residuals[i])),
            errors: ErrorCovariance::new(variances.clone(), &self.loadings)?,
            variances,
        })
    }

    fn correlation_at(&self, gp: &GpDiscrepancy, length: f64) -> DMatrix<f64> {
        let places: Vec<&[f64]> = gp
            .observation_sites
            .iter()
            .map(|&s| gp.sites[s].place.as_slice())
            .collect();
        correlation_matrix(&places, &places, length)
    }
}

/// The squared-exponential correlation between two sets of places.
fn correlation_matrix(rows: &[&[f64]], columns: &[&[f64]], length: f64) -> DMatrix<f64> {
    DMatrix::from_fn(rows.len(), columns.len(), |i, j| {
        let distance2: f64 = rows[i]
            .iter()
            .zip(columns[j])
            .map(|(a, b)| (a - b).powi(2))
            .sum();
        (-0.5 * distance2 / (length * length)).exp()
    })
}

/// The process's conditional `(mean, variance)` at every site given the
/// residuals: `tau^2 k' C^-1 r` and `tau^2 - tau^4 k' C^-1 k`.
fn gp_conditional(
    gp: &GpDiscrepancy,
    group: &Group,
    correlation: &DMatrix<f64>,
    tau: f64,
    length: f64,
) -> Vec<(f64, f64)> {
    let tau2 = tau * tau;
    let residuals = &group.residuals;
    let covariance = correlation * tau2 + group.errors.matrix();
    let Some(cholesky) = covariance.cholesky() else {
        return vec![(0.0, tau2); gp.sites.len()];
    };
    let weights = cholesky.solve(residuals);
    let observed: Vec<&[f64]> = gp
        .observation_sites
        .iter()
        .map(|&s| gp.sites[s].place.as_slice())
        .collect();
    gp.sites
        .iter()
        .map(|site| {
            let cross = correlation_matrix(&[site.place.as_slice()], &observed, length);
            let cross = cross.row(0).transpose() * tau2;
            let mean = cross.dot(&weights);
            let reduction = cross.dot(&cholesky.solve(&cross));
            (mean, (tau2 - reduction).max(0.0))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn gp_output(places: &[f64], observation_sites: Vec<usize>) -> OutputDiscrepancy {
        let sites = places
            .iter()
            .enumerate()
            .map(|(i, &x)| (format!("c{i}"), vec![("x".to_string(), x)]))
            .collect();
        let observations = (0..observation_sites.len()).collect();
        let gp = GpDiscrepancy::new(sites, observation_sites).unwrap();
        OutputDiscrepancy {
            output: "y".into(),
            observations,
            tau_range: [0.01, 10.0],
            tau_grid: ScaleGrid::new([0.01, 10.0], 40, |t| 1.0 / (1.0 + t * t)),
            form: Form::Gp(Box::new(gp)),
            loadings: DMatrix::zeros(2, 0),
        }
    }

    fn group_of(residuals: Vec<f64>, variances: Vec<f64>, loadings: &DMatrix<f64>) -> Group {
        let variances = DVector::from_vec(variances);
        Group {
            residuals: DVector::from_vec(residuals),
            errors: ErrorCovariance::new(variances.clone(), loadings).unwrap(),
            variances,
        }
    }

    /// The Cholesky density equals the normal density of the residuals
    /// written out for two observations.
    #[test]
    fn the_gp_density_is_the_normal_density_of_correlated_residuals() {
        let output = gp_output(&[0.0, 2.0], vec![0, 1]);
        let Form::Gp(gp) = &output.form else {
            unreachable!()
        };
        assert_eq!(gp.sites[1].place, [1.0], "scaled by the range");
        let (tau, length): (f64, f64) = (0.3, 0.5);
        let rho = (-0.5 / (length * length)).exp();
        let (r0, r1, v0, v1) = (-0.2, 0.5, 0.01, 0.04);
        let (a, b, c) = (v0 + tau * tau, rho * tau * tau, v1 + tau * tau);
        let det = a * c - b * b;
        let quadratic = (c * r0 * r0 - 2.0 * b * r0 * r1 + a * r1 * r1) / det;
        let expected = -0.5 * (quadratic + det.ln() + 2.0 * (2.0 * PI).ln());
        let correlation = output.correlation_at(gp, length);
        let group = group_of(vec![r0, r1], vec![v0, v1], &DMatrix::zeros(2, 0));
        let got = Whitened::new(&correlation, &group.errors).log_density(&group.residuals)(tau);
        assert!((got - expected).abs() < 1e-12, "{got} {expected}");
        // The integral by the kept forms equals the one computed afresh.
        let mut fixed = gp.clone();
        fixed.fix_variances(vec![v0, v1], &DMatrix::zeros(2, 0), &output.tau_grid);
        let (kept, afresh) = (
            fixed.log_density(&output.tau_grid, &group),
            gp.log_density(&output.tau_grid, &group),
        );
        // Bit for bit: the log determinants kept are the same sums.
        assert!(
            fixed.fixed.is_some() && kept.to_bits() == afresh.to_bits(),
            "{kept} {afresh}"
        );
    }

    /// At a site it was observed at, with a tiny measurement error, the
    /// conditional is the residual there; far from every site it is the
    /// prior (mean 0, variance tau^2); with a length far beyond the range
    /// it is the constant discrepancy's conditional.
    #[test]
    fn the_gp_conditional_interpolates_and_falls_back_to_the_prior() {
        let output = gp_output(&[0.0, 1.0, 0.5, 100.0], vec![0, 1]);
        let Form::Gp(gp) = &output.form else {
            unreachable!()
        };
        let group = group_of(vec![0.4, 0.6], vec![1e-10, 1e-10], &DMatrix::zeros(2, 0));
        let (tau, length) = (1.0, 0.005);
        let correlation = output.correlation_at(gp, length);
        let at = gp_conditional(gp, &group, &correlation, tau, length);
        assert!((at[0].0 - 0.4).abs() < 1e-6 && at[0].1 < 1e-6, "{at:?}");
        assert!((at[1].0 - 0.6).abs() < 1e-6, "{at:?}");
        assert!(
            at[3].0.abs() < 1e-12 && (at[3].1 - 1.0).abs() < 1e-12,
            "{at:?}"
        );

        // A long length: the constant discrepancy, Sherman-Morrison's form.
        let group = group_of(vec![0.4, 0.6], vec![0.01, 0.04], &DMatrix::zeros(2, 0));
        let length = 1e4;
        let correlation = output.correlation_at(gp, length);
        let at = gp_conditional(gp, &group, &correlation, tau, length);
        let precision = 1.0 + 1.0 / 0.01 + 1.0 / 0.04;
        let mean = (0.4 / 0.01 + 0.6 / 0.04) / precision;
        assert!((at[2].0 - mean).abs() < 1e-6, "{} {mean}", at[2].0);
        assert!((at[2].1 - 1.0 / precision).abs() < 1e-6);
    }

    #[test]
    fn cases_that_share_their_inputs_are_refused_with_the_way_out() {
        let sites = vec![
            ("a".to_string(), vec![("x".to_string(), 1.0)]),
            ("b".to_string(), vec![("x".to_string(), 1.0)]),
        ];
        let error = GpDiscrepancy::new(sites, vec![0, 1]).unwrap_err();
        assert!(error.contains("discrepancy = \"constant\""), "{error}");
    }

    /// With a shared error the GP's whitened density and the constant's
    /// Sherman-Morrison form are the normal density under
    /// `diag(v) + s s' + tau^2 K`, written out for two observations.
    #[test]
    fn a_shared_error_adds_its_covariance_to_both_discrepancies() {
        let (r0, r1, v0, v1, s0, s1): (f64, f64, f64, f64, f64, f64) =
            (-0.2, 0.5, 0.01, 0.04, 0.3, -0.2);
        let (tau, length): (f64, f64) = (0.4, 0.5);
        let loadings = DMatrix::from_row_slice(2, 1, &[s0, s1]);
        let density = |rho: f64| {
            let (a, b, c) = (
                v0 + s0 * s0 + tau * tau,
                s0 * s1 + rho * tau * tau,
                v1 + s1 * s1 + tau * tau,
            );
            let det = a * c - b * b;
            let quadratic = (c * r0 * r0 - 2.0 * b * r0 * r1 + a * r1 * r1) / det;
            -0.5 * (quadratic + det.ln() + 2.0 * (2.0 * PI).ln())
        };
        let mut output = gp_output(&[0.0, 2.0], vec![0, 1]);
        output.loadings = loadings.clone();
        let Form::Gp(gp) = &output.form else {
            unreachable!()
        };
        let group = group_of(vec![r0, r1], vec![v0, v1], &loadings);
        let whitened = Whitened::new(&output.correlation_at(gp, length), &group.errors);
        let got = whitened.log_density(&group.residuals)(tau);
        let rho = (-0.5 / (length * length)).exp();
        assert!((got - density(rho)).abs() < 1e-12, "{got} {}", density(rho));
        output.form = Form::Constant;
        let got = output.constant_log_density(&[r0, r1], &[v0, v1], tau);
        assert!((got - density(1.0)).abs() < 1e-12, "{got} {}", density(1.0));
    }
}
