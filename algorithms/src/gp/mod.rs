//! Gaussian-process regression: fit a GP to (input, output) samples by maximising the log
//! marginal likelihood, then predict the mean and the latent standard deviation anywhere.
//!
//! The model, unless hyperparameters are fixed:
//! - inputs are scaled to the unit box, `z = (x - lower) / (upper - lower)` per input, with the
//!   bounds from `GpSettings::input_bounds` or the data's min/max (an input constant in the
//!   data gets width 1: it carries no information either way);
//! - outputs are standardised, `(y - mean) / std` with the population std; the GP prior mean
//!   is the constant training average, which is 0 on the standardised scale (it is not a
//!   free hyperparameter: with standardised outputs fitting it adds nothing but an
//!   unidentifiable direction to the likelihood);
//! - covariance `signal * k(r) + noise * I`, `r^2 = sum_k ((z_k - z'_k) / l_k)^2` with one
//!   length scale per input (ARD) or one shared;
//! - the hyperparameters maximise the log marginal likelihood (analytic gradient, bounded
//!   L-BFGS in log space, bounds: length scales [1e-3, 1e3] boxes, signal variance
//!   [1e-4, 1e4], noise `GpSettings::noise_bounds`), multistart: a default start plus seeded
//!   random ones, each explored briefly, the best polished (see `optimise_hyperparameters`);
//! - if the Cholesky factorisation fails, a jitter of 1e-10, 1e-8, ... 1e-4 times the mean
//!   diagonal is added until it succeeds; the one used is reported.
//!
//! With `GpSettings::fixed` nothing is scaled, the mean is zero and the given hyperparameters
//! (in the data's own units) are used as they are: predictions then equal scikit-learn's
//! `GaussianProcessRegressor(kernel=ConstantKernel(s) * RBF(l) [or Matern(l, nu)],
//! alpha=noise, optimizer=None, normalize_y=False)`. The std returned here is always that of
//! the latent function, without observation noise: scikit-learn's std equals it when the
//! noise is given as `alpha`, but includes the noise when it is a `WhiteKernel` term.

mod error;
mod kernel;
mod likelihood;

use std::fmt;

use faer::{MatMut, MatRef, Par};

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use crate::optim::{minimize_bounded, LbfgsSettings};
pub use error::GpError;
pub use kernel::Kernel;
use likelihood::{ModelledHyperparameters, Workspace};

/// Hyperparameters given by the user, in the data's own units (see `GpSettings::fixed`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FixedHyperparameters {
    /// One (shared by all inputs) or one per input, in input units.
    pub length_scales: Vec<f64>,
    /// Variance of the latent function, in output units squared.
    pub signal_variance: f64,
    /// Observation-noise variance on the diagonal, in output units squared (may be 0).
    pub noise_variance: f64,
}

/// How to fit a [`Gp`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct GpSettings {
    pub kernel: Kernel,
    /// One length scale per input (true) or one shared (false).
    pub ard: bool,
    /// Number of L-BFGS starts: the default start plus `restarts - 1` random ones. Each is
    /// explored by a short L-BFGS run and the best polished, so the fit costs about one full
    /// optimisation plus a fraction of one per start (less above 200 points, where the
    /// exploration runs on a subset).
    pub restarts: usize,
    /// Seed of the random starts: same data, same settings, same fit.
    pub seed: u64,
    /// Per-input `(lower, upper)` mapped to the unit box; `None` uses the data's min/max.
    pub input_bounds: Option<Vec<(f64, f64)>>,
    /// Use these hyperparameters, in data units, without scaling, standardisation, mean or
    /// optimisation.
    pub fixed: Option<FixedHyperparameters>,
    /// Bounds on the noise variance of the standardised output (1 = all the output variance).
    pub noise_bounds: (f64, f64),
}

impl Default for GpSettings {
    fn default() -> Self {
        Self {
            kernel: Kernel::Matern52,
            ard: true,
            restarts: 5,
            seed: 0,
            input_bounds: None,
            fixed: None,
            noise_bounds: (1e-10, 1.0),
        }
    }
}

/// Bounds of the fit, in the modelled units: length scales in the unit box, signal variance
/// relative to the standardised output.
const LENGTH_SCALE_BOUNDS: (f64, f64) = (1e-3, 1e3);
const SIGNAL_VARIANCE_BOUNDS: (f64, f64) = (1e-4, 1e4);
/// The default start: a length scale of half the box, the signal carrying all the output
/// variance, a small noise (clamped into the noise bounds).
const DEFAULT_LENGTH_SCALE: f64 = 0.5;
const DEFAULT_NOISE_VARIANCE: f64 = 1e-3;
/// Range of the random starts' length scales, inside the bounds: shorter than 1/20 of the box
/// or longer than 5 boxes are starts from which the likelihood is flat and L-BFGS stalls.
const RANDOM_LENGTH_SCALES: (f64, f64) = (0.05, 5.0);
const RANDOM_SIGNAL_VARIANCES: (f64, f64) = (0.1, 10.0);

/// L-BFGS tolerances of the fit: scipy's L-BFGS-B defaults (`pgtol` 1e-5, `factr` 1e7), the
/// ones scikit-learn fits with, so the two stop at comparable points.
fn fit_optimiser_settings() -> LbfgsSettings {
    LbfgsSettings {
        memory: 10,
        max_iterations: 200,
        gradient_tolerance: 1e-5,
        relative_tolerance: 1e7 * f64::EPSILON,
    }
}

/// Above this many points the first stage of the multistart works on a random subset of
/// this size (see `optimise_hyperparameters`).
const EXPLORATION_SUBSET: usize = 200;

/// The first stage of the multistart: a basin finder, stopped once a step gains less than
/// 1e-7 of the likelihood or after 30 steps.
fn exploration_settings() -> LbfgsSettings {
    LbfgsSettings {
        memory: 10,
        max_iterations: 30,
        gradient_tolerance: 1e-3,
        relative_tolerance: 1e-7,
    }
}

/// Mean and latent standard deviation at one point, in output units.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Prediction {
    pub mean: f64,
    /// Standard deviation of the latent function, without observation noise.
    pub std: f64,
}

/// A prediction with its input gradient, in output units per input unit.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PredictionGradient {
    pub mean: f64,
    pub std: f64,
    pub mean_gradient: Vec<f64>,
    /// Zero where the std is zero (at a noise-free training point the std has a kink).
    pub std_gradient: Vec<f64>,
}

/// Closed-form leave-one-out predictions (Rasmussen & Williams eq. 5.12), at the fitted
/// hyperparameters and scaling, in output units.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct LeaveOneOut {
    /// Mean at each training point from the other n - 1.
    pub means: Vec<f64>,
    /// Predictive std at each training point from the other n - 1, noise included.
    pub stds: Vec<f64>,
    /// Observed minus leave-one-out mean.
    pub residuals: Vec<f64>,
    pub rmse: f64,
}

/// The fitted hyperparameters in both unit systems.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Hyperparameters {
    pub kernel: Kernel,
    /// One per input, in that input's units.
    pub length_scales: Vec<f64>,
    /// As optimised, in the unit box: one (shared) or one per input. With fixed
    /// hyperparameters, the data units as given.
    pub length_scales_unit_box: Vec<f64>,
    /// Latent-function variance, in output units squared.
    pub signal_variance: f64,
    /// Observation-noise variance, in output units squared.
    pub noise_variance: f64,
    /// The same two relative to the standardised output, the scale of the bounds (equal to
    /// the above with fixed hyperparameters).
    pub signal_variance_standardised: f64,
    pub noise_variance_standardised: f64,
    /// The constant prior mean, in output units: the training average (0 when fixed).
    pub mean: f64,
    /// Added to the diagonal (standardised units) for the factorisation to succeed; 0 unless
    /// the kernel matrix was numerically singular.
    pub jitter: f64,
}

/// A fitted Gaussian process. Serialises (serde, JSON via [`Gp::to_json`]) as its settings,
/// scaling, hyperparameters and training data; loading refactorises, so a loaded model
/// predicts bit-for-bit as the saved one.
#[derive(Clone, Serialize, Deserialize)]
#[serde(try_from = "GpRecord", into = "GpRecord")]
pub struct Gp {
    record: GpRecord,
    /// Row-major `n x d`: the modelled inputs divided by their length scales.
    scaled_inputs: Vec<f64>,
    /// The same, column-major (`d x n`): what [`Gp::predict_mean`] runs
    /// down, one input at a time over every training point, so that its
    /// loops vectorise.
    scaled_columns: Vec<f64>,
    /// Per input, the factor from data units to length-scale units: 1 / (width l_k).
    input_to_scaled: Vec<f64>,
    /// Cholesky factor of the training covariance, column-major, lower triangle.
    cholesky: Vec<f64>,
    /// K^-1 y (modelled units).
    alpha: Vec<f64>,
    log_marginal_likelihood: f64,
}

/// What is saved: everything that defines the model, nothing that is recomputed.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct GpRecord {
    format: u32,
    kernel: Kernel,
    /// True when the hyperparameters were given (no scaling, zero mean).
    fixed: bool,
    input_offset: Vec<f64>,
    input_width: Vec<f64>,
    output_mean: f64,
    output_scale: f64,
    /// Modelled units (see `Hyperparameters::length_scales_unit_box`).
    length_scales: Vec<f64>,
    signal_variance: f64,
    noise_variance: f64,
    jitter: f64,
    /// Training data, in data units.
    inputs: Vec<Vec<f64>>,
    outputs: Vec<f64>,
}

const FORMAT_VERSION: u32 = 1;

impl fmt::Debug for Gp {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Gp")
            .field("kernel", &self.record.kernel)
            .field("points", &self.record.outputs.len())
            .field("inputs", &self.record.input_offset.len())
            .field("hyperparameters", &self.hyperparameters())
            .field("log_marginal_likelihood", &self.log_marginal_likelihood)
            .finish()
    }
}

impl Gp {
    /// Fits a GP to `outputs[i] = f(inputs[i]) + noise`. See the module doc for the model.
    pub fn fit(inputs: &[Vec<f64>], outputs: &[f64], settings: &GpSettings) -> Result<Gp, GpError> {
        let d = validate_data(inputs, outputs)?;
        validate_settings(settings, d)?;
        if let Some(fixed) = &settings.fixed {
            let record = GpRecord {
                format: FORMAT_VERSION,
                kernel: settings.kernel,
                fixed: true,
                input_offset: vec![0.0; d],
                input_width: vec![1.0; d],
                output_mean: 0.0,
                output_scale: 1.0,
                length_scales: fixed.length_scales.clone(),
                signal_variance: fixed.signal_variance,
                noise_variance: fixed.noise_variance,
                jitter: 0.0,
                inputs: inputs.to_vec(),
                outputs: outputs.to_vec(),
            };
            return Gp::from_record(record, None);
        }

        let (input_offset, input_width) = input_scaling(inputs, settings.input_bounds.as_deref());
        let (output_mean, output_scale) = output_scaling(outputs)?;
        let mut record = GpRecord {
            format: FORMAT_VERSION,
            kernel: settings.kernel,
            fixed: false,
            input_offset,
            input_width,
            output_mean,
            output_scale,
            length_scales: Vec::new(),
            signal_variance: 1.0,
            noise_variance: 1.0,
            jitter: 0.0,
            inputs: inputs.to_vec(),
            outputs: outputs.to_vec(),
        };
        let (modelled_inputs, modelled_outputs) = record.modelled_data();
        let best = optimise_hyperparameters(&modelled_inputs, &modelled_outputs, settings, d)?;
        record.length_scales = best.length_scales;
        record.signal_variance = best.signal_variance;
        record.noise_variance = best.noise_variance;
        Gp::from_record(record, None)
    }

    /// Mean and latent std at `x` (data units). A point of the wrong dimension or with
    /// non-finite coordinates gives NaN for both.
    pub fn predict(&self, x: &[f64]) -> Prediction {
        let mut buffers = PredictBuffers::new(self.n_points());
        self.predict_into(x, &mut buffers)
    }

    /// The mean alone at `x` (data units; NaN for an invalid point): the
    /// cross-covariance and one dot product, O(n d), where the std needs a
    /// triangular solve, O(n^2). What a sampler that reads only the mean
    /// asks at every step; the same bits as [`Gp::predict`]'s.
    pub fn predict_mean(&self, x: &[f64]) -> f64 {
        let d = self.n_inputs();
        if d == 0 {
            return self.predict(x).mean;
        }
        if x.len() != d || x.iter().any(|v| !v.is_finite()) {
            return f64::NAN;
        }
        // Each training point's squared distance, an input at a time over
        // every point, then its correlation, then the sum against alpha:
        // the same operations in the same order as `cross_covariance` and
        // `dot` (the same bits), but in loops over the points that
        // vectorise (the kernel's exp is branch-free for that).
        let n = self.n_points();
        let mut r_squared = vec![0.0; n];
        for (k, xk) in x.iter().enumerate() {
            let point = (xk - self.record.input_offset[k])
                / self.record.input_width[k]
                / self.record.length_scale(k);
            let column = &self.scaled_columns[k * n..(k + 1) * n];
            for (sum, a) in r_squared.iter_mut().zip(column) {
                *sum += (a - point) * (a - point);
            }
        }
        let mut correlation = vec![0.0; n];
        self.record.kernel.fill_values(&r_squared, &mut correlation);
        let signal = self.record.signal_variance;
        let mean: f64 = correlation
            .iter()
            .zip(&self.alpha)
            .map(|(k, alpha)| signal * k * alpha)
            .sum();
        self.record.output_mean + self.record.output_scale * mean
    }

    /// Predictions at many points. Works in blocks of points so the triangular solve for the
    /// variances is one matrix operation per block (several times faster than point by point
    /// for a few hundred training points); agrees with [`Gp::predict`] to rounding.
    pub fn predict_many(&self, xs: &[Vec<f64>]) -> Vec<Prediction> {
        const BLOCK: usize = 128;
        let n = self.n_points();
        let invalid = Prediction {
            mean: f64::NAN,
            std: f64::NAN,
        };
        let mut buffers = PredictBuffers::new(n);
        let mut block = vec![0.0; n * BLOCK];
        let mut predictions = Vec::with_capacity(xs.len());
        for chunk in xs.chunks(BLOCK) {
            // Column j of `block` is the cross-covariance of the j-th valid point.
            let mut valid = Vec::with_capacity(chunk.len());
            let mut means = Vec::with_capacity(chunk.len());
            for x in chunk {
                let ok = self.cross_covariance(x, &mut buffers);
                valid.push(ok);
                if ok {
                    let column = means.len();
                    block[column * n..(column + 1) * n].copy_from_slice(&buffers.covariance);
                    means.push(dot(&buffers.covariance, &self.alpha));
                }
            }
            let m = means.len();
            let solved = &mut block[..n * m];
            faer::linalg::triangular_solve::solve_lower_triangular_in_place(
                MatRef::from_column_major_slice(&self.cholesky, n, n),
                MatMut::from_column_major_slice_mut(solved, n, m),
                Par::Seq,
            );
            let mut next = 0;
            for ok in valid {
                if !ok {
                    predictions.push(invalid);
                    continue;
                }
                let column = &solved[next * n..(next + 1) * n];
                let variance = (self.record.signal_variance - dot(column, column)).max(0.0);
                predictions.push(self.to_data_units(means[next], variance));
                next += 1;
            }
        }
        predictions
    }

    /// Mean, latent std and their gradients with respect to `x`, all in data units (for
    /// maximising an acquisition by L-BFGS). NaN everywhere for an invalid point.
    pub fn predict_with_gradient(&self, x: &[f64]) -> PredictionGradient {
        let d = self.n_inputs();
        let n = self.n_points();
        let invalid = PredictionGradient {
            mean: f64::NAN,
            std: f64::NAN,
            mean_gradient: vec![f64::NAN; d],
            std_gradient: vec![f64::NAN; d],
        };
        let mut buffers = PredictBuffers::new(n);
        if !self.cross_covariance(x, &mut buffers) {
            return invalid;
        }
        let (mean, variance) = self.mean_and_variance(&mut buffers);
        // beta = K^-1 k*, from v = L^-1 k* by back substitution: d var / dx = -2 beta' dk*/dx.
        let mut beta = buffers.solved.clone();
        self.back_substitute(&mut beta);
        let signal = self.record.signal_variance;
        let std = variance.sqrt();
        let mut mean_gradient = vec![0.0; d];
        let mut variance_gradient = vec![0.0; d];
        let rows = self.scaled_inputs.chunks_exact(d);
        for (((row, slope), alpha), beta) in rows.zip(&buffers.slope).zip(&self.alpha).zip(&beta) {
            // dk(x, x_i)/du_k = -g(r) (u_k - u_ik) in length-scale units u.
            let weight = signal * slope;
            for (k, (u, u_i)) in buffers.point.iter().zip(row).enumerate() {
                let dk = -weight * (u - u_i);
                mean_gradient[k] += alpha * dk;
                variance_gradient[k] -= 2.0 * beta * dk;
            }
        }
        let scale = self.record.output_scale;
        let mut std_gradient = vec![0.0; d];
        for k in 0..d {
            let to_data = self.input_to_scaled[k] * scale;
            mean_gradient[k] *= to_data;
            std_gradient[k] = if std > 0.0 {
                variance_gradient[k] / (2.0 * std) * to_data
            } else {
                0.0
            };
        }
        PredictionGradient {
            mean: self.record.output_mean + scale * mean,
            std: scale * std,
            mean_gradient,
            std_gradient,
        }
    }

    /// Log marginal likelihood at the fitted hyperparameters, of the data as modelled: the
    /// standardised outputs (data units with fixed hyperparameters). This is the number
    /// scikit-learn reports with `normalize_y=True`; in the data's units it would be lower by
    /// `n ln(output std)`.
    pub fn log_marginal_likelihood(&self) -> f64 {
        self.log_marginal_likelihood
    }

    /// Gradient of [`Gp::log_marginal_likelihood`] with respect to the logarithms of the
    /// modelled hyperparameters, ordered `[ln l_1 .. ln l_p, ln signal variance, ln noise
    /// variance]` (p = 1 shared length scale, or one per input). Near zero at an interior
    /// optimum of the fit; for diagnostics, and to check the analytic gradient the fit uses.
    pub fn log_marginal_likelihood_gradient(&self) -> Vec<f64> {
        let record = &self.record;
        let (modelled_inputs, modelled_outputs) = record.modelled_data();
        let mut workspace = Workspace::new(
            record.kernel,
            &modelled_inputs,
            &modelled_outputs,
            self.n_inputs(),
        );
        workspace.fixed_jitter = Some(record.jitter);
        let mut log_parameters: Vec<f64> = record.length_scales.iter().map(|l| l.ln()).collect();
        log_parameters.push(record.signal_variance.ln());
        log_parameters.push(record.noise_variance.ln());
        let mut gradient = vec![0.0; log_parameters.len()];
        workspace.negative_log_likelihood_and_gradient(&log_parameters, &mut gradient);
        gradient.iter().map(|g| -g).collect()
    }

    /// Leave-one-out predictions in closed form: with alpha = K^-1 y, the mean at point i from
    /// the others is `y_i - alpha_i / [K^-1]_ii` and its variance `1 / [K^-1]_ii` (noise
    /// included). The scaling and hyperparameters stay those of the full fit.
    pub fn leave_one_out(&self) -> LeaveOneOut {
        let n = self.n_points();
        let inverse_diagonal = self.inverse_diagonal();
        let scale = self.record.output_scale;
        let mut means = Vec::with_capacity(n);
        let mut stds = Vec::with_capacity(n);
        let mut residuals = Vec::with_capacity(n);
        for ((alpha, inverse), observed) in self
            .alpha
            .iter()
            .zip(&inverse_diagonal)
            .zip(&self.record.outputs)
        {
            let residual = scale * alpha / inverse;
            residuals.push(residual);
            means.push(observed - residual);
            stds.push(scale / inverse.sqrt());
        }
        let rmse = (residuals.iter().map(|r| r * r).sum::<f64>() / n as f64).sqrt();
        LeaveOneOut {
            means,
            stds,
            residuals,
            rmse,
        }
    }

    pub fn hyperparameters(&self) -> Hyperparameters {
        let record = &self.record;
        let d = self.n_inputs();
        let variance_scale = record.output_scale * record.output_scale;
        let length_scales = (0..d)
            .map(|k| record.length_scale(k) * record.input_width[k])
            .collect();
        Hyperparameters {
            kernel: record.kernel,
            length_scales,
            length_scales_unit_box: record.length_scales.clone(),
            signal_variance: record.signal_variance * variance_scale,
            noise_variance: record.noise_variance * variance_scale,
            signal_variance_standardised: record.signal_variance,
            noise_variance_standardised: record.noise_variance,
            mean: record.output_mean,
            jitter: record.jitter,
        }
    }

    pub fn n_inputs(&self) -> usize {
        self.record.input_offset.len()
    }

    /// Number of training points.
    pub fn n_points(&self) -> usize {
        self.record.outputs.len()
    }

    pub fn kernel(&self) -> Kernel {
        self.record.kernel
    }

    /// The model as JSON (see the type doc for what is stored).
    pub fn to_json(&self) -> String {
        // Serialising plain numbers, strings and vectors cannot fail; an empty object would
        // then be rejected by `from_json` rather than panicking here.
        serde_json::to_string_pretty(self).unwrap_or_else(|_| String::from("{}"))
    }

    /// Loads a model saved by [`Gp::to_json`], checking every dimension and refactorising.
    pub fn from_json(json: &str) -> Result<Gp, GpError> {
        serde_json::from_str(json).map_err(|e| GpError::InvalidModel(e.to_string()))
    }

    /// Builds the derived state; `jitter: None` escalates from zero (a fit), `Some` uses the
    /// recorded jitter (a load).
    fn from_record(mut record: GpRecord, jitter: Option<f64>) -> Result<Gp, GpError> {
        let d = record.input_offset.len();
        let (modelled_inputs, modelled_outputs) = record.modelled_data();
        let mut workspace = Workspace::new(record.kernel, &modelled_inputs, &modelled_outputs, d);
        let hyper = ModelledHyperparameters {
            length_scales: record.length_scales.clone(),
            signal_variance: record.signal_variance,
            noise_variance: record.noise_variance,
        };
        let log_marginal_likelihood = workspace
            .factorise_at(&hyper, jitter)
            .ok_or(GpError::NotPositiveDefinite)?;
        record.jitter = workspace.jitter;
        let input_to_scaled: Vec<f64> = (0..d)
            .map(|k| 1.0 / (record.input_width[k] * record.length_scale(k)))
            .collect();
        let scaled_inputs: Vec<f64> = modelled_inputs
            .iter()
            .enumerate()
            .map(|(index, z)| z / record.length_scale(index % d))
            .collect();
        let n = scaled_inputs.len() / d.max(1);
        let scaled_columns: Vec<f64> = (0..d)
            .flat_map(|k| (0..n).map(move |i| (k, i)))
            .map(|(k, i)| scaled_inputs[i * d + k])
            .collect();
        Ok(Gp {
            scaled_inputs,
            scaled_columns,
            input_to_scaled,
            cholesky: workspace.cholesky_factor().to_vec(),
            alpha: workspace.alpha().to_vec(),
            log_marginal_likelihood,
            record,
        })
    }

    /// Fills `buffers.point` (length-scale units), `covariance` (k*) and `slope` (g(r)) for
    /// `x`; false if `x` is not a finite point of the right dimension.
    fn cross_covariance(&self, x: &[f64], buffers: &mut PredictBuffers) -> bool {
        let d = self.n_inputs();
        if x.len() != d || x.iter().any(|v| !v.is_finite()) {
            return false;
        }
        buffers.point.clear();
        for (k, xk) in x.iter().enumerate() {
            buffers.point.push(
                (xk - self.record.input_offset[k])
                    / self.record.input_width[k]
                    / self.record.length_scale(k),
            );
        }
        let signal = self.record.signal_variance;
        for i in 0..self.n_points() {
            let row = &self.scaled_inputs[i * d..(i + 1) * d];
            let r_squared: f64 = row
                .iter()
                .zip(&buffers.point)
                .map(|(a, b)| (a - b) * (a - b))
                .sum();
            let (k, g) = self.record.kernel.value_and_slope(r_squared);
            buffers.covariance[i] = signal * k;
            buffers.slope[i] = g;
        }
        true
    }

    /// Standardised mean and latent variance from the filled cross-covariance; leaves
    /// `buffers.solved = L^-1 k*`.
    fn mean_and_variance(&self, buffers: &mut PredictBuffers) -> (f64, f64) {
        let mean = dot(&buffers.covariance, &self.alpha);
        buffers.solved.copy_from_slice(&buffers.covariance);
        self.forward_substitute(&mut buffers.solved);
        let explained: f64 = buffers.solved.iter().map(|v| v * v).sum();
        // Rounding can push the difference of two nearly equal numbers below zero.
        let variance = (self.record.signal_variance - explained).max(0.0);
        (mean, variance)
    }

    fn predict_into(&self, x: &[f64], buffers: &mut PredictBuffers) -> Prediction {
        if !self.cross_covariance(x, buffers) {
            return Prediction {
                mean: f64::NAN,
                std: f64::NAN,
            };
        }
        let (mean, variance) = self.mean_and_variance(buffers);
        self.to_data_units(mean, variance)
    }

    /// From the modelled mean and latent variance to a data-unit prediction.
    fn to_data_units(&self, mean: f64, variance: f64) -> Prediction {
        Prediction {
            mean: self.record.output_mean + self.record.output_scale * mean,
            std: self.record.output_scale * variance.sqrt(),
        }
    }

    /// Solves L v = b in place (column-oriented, L column-major lower).
    fn forward_substitute(&self, v: &mut [f64]) {
        let n = v.len();
        for j in 0..n {
            let column = &self.cholesky[j * n..(j + 1) * n];
            v[j] /= column[j];
            let vj = v[j];
            for (vi, l) in v[j + 1..].iter_mut().zip(&column[j + 1..]) {
                *vi -= l * vj;
            }
        }
    }

    /// Solves L' w = b in place.
    fn back_substitute(&self, w: &mut [f64]) {
        let n = w.len();
        for j in (0..n).rev() {
            let column = &self.cholesky[j * n..(j + 1) * n];
            let dot: f64 = column[j + 1..]
                .iter()
                .zip(&w[j + 1..])
                .map(|(l, x)| l * x)
                .sum();
            w[j] = (w[j] - dot) / column[j];
        }
    }

    /// diag(K^-1) = column sums of squares of L^-1, computed column by column of L^-1 (each
    /// a forward substitution of a unit vector, starting at its nonzero).
    fn inverse_diagonal(&self) -> Vec<f64> {
        let n = self.n_points();
        let mut diagonal = vec![0.0; n];
        let mut column = vec![0.0; n];
        for j in 0..n {
            // Column j of L^-1 is zero above row j.
            column.iter_mut().for_each(|v| *v = 0.0);
            column[j] = 1.0;
            for c in j..n {
                let l_column = &self.cholesky[c * n..(c + 1) * n];
                column[c] /= l_column[c];
                let vc = column[c];
                for (vi, l) in column[c + 1..].iter_mut().zip(&l_column[c + 1..]) {
                    *vi -= l * vc;
                }
            }
            // Row j of L^-T L^-1 diagonal: sum over rows of (L^-1)_{rj}^2.
            diagonal[j] = column[j..].iter().map(|v| v * v).sum();
        }
        diagonal
    }
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// Work buffers of one prediction, reused by `predict_many`.
struct PredictBuffers {
    point: Vec<f64>,
    covariance: Vec<f64>,
    slope: Vec<f64>,
    solved: Vec<f64>,
}

impl PredictBuffers {
    fn new(n: usize) -> Self {
        Self {
            point: Vec::new(),
            covariance: vec![0.0; n],
            slope: vec![0.0; n],
            solved: vec![0.0; n],
        }
    }
}

impl GpRecord {
    fn length_scale(&self, k: usize) -> f64 {
        if self.length_scales.len() == 1 {
            self.length_scales[0]
        } else {
            self.length_scales[k]
        }
    }

    /// Row-major modelled inputs and modelled outputs.
    fn modelled_data(&self) -> (Vec<f64>, Vec<f64>) {
        let d = self.input_offset.len();
        let mut inputs = Vec::with_capacity(self.inputs.len() * d);
        for row in &self.inputs {
            for ((x, offset), width) in row.iter().zip(&self.input_offset).zip(&self.input_width) {
                inputs.push((x - offset) / width);
            }
        }
        let outputs = self
            .outputs
            .iter()
            .map(|y| (y - self.output_mean) / self.output_scale)
            .collect();
        (inputs, outputs)
    }

    /// Everything `from_record` relies on, so a hand-edited or truncated file is an error.
    fn validate(&self) -> Result<(), String> {
        if self.format != FORMAT_VERSION {
            return Err(format!(
                "format {} is not the supported {FORMAT_VERSION}",
                self.format
            ));
        }
        let d = self.input_offset.len();
        if d == 0 || self.input_width.len() != d {
            return Err(format!(
                "{} input offsets and {} widths: need the same positive number",
                d,
                self.input_width.len()
            ));
        }
        if self.outputs.len() < 2 || self.inputs.len() != self.outputs.len() {
            return Err(format!(
                "{} input rows and {} outputs: need the same number, at least 2",
                self.inputs.len(),
                self.outputs.len()
            ));
        }
        if let Some(row) = self.inputs.iter().position(|r| r.len() != d) {
            return Err(format!("input row {row} does not have {d} values"));
        }
        if self.length_scales.len() != 1 && self.length_scales.len() != d {
            return Err(format!(
                "{} length scales for {d} inputs: need 1 or {d}",
                self.length_scales.len()
            ));
        }
        let all_finite = self.inputs.iter().flatten().all(|v| v.is_finite())
            && self.outputs.iter().all(|v| v.is_finite())
            && self.input_offset.iter().all(|v| v.is_finite());
        let positive = |v: &f64| v.is_finite() && *v > 0.0;
        if !all_finite
            || !self.input_width.iter().all(positive)
            || !self.length_scales.iter().all(positive)
            || !positive(&self.signal_variance)
            || !positive(&self.output_scale)
            || !self.output_mean.is_finite()
            || !(self.noise_variance.is_finite() && self.noise_variance >= 0.0)
            || !(self.jitter.is_finite() && self.jitter >= 0.0)
        {
            return Err("a value is NaN, infinite or a non-positive scale".to_string());
        }
        Ok(())
    }
}

/// Loading: the message becomes part of `GpError::InvalidModel`.
impl TryFrom<GpRecord> for Gp {
    type Error = String;

    fn try_from(record: GpRecord) -> Result<Self, Self::Error> {
        record.validate()?;
        let jitter = record.jitter;
        Gp::from_record(record, Some(jitter)).map_err(|e| e.to_string())
    }
}

impl From<Gp> for GpRecord {
    fn from(gp: Gp) -> Self {
        gp.record
    }
}

/// Checks the training data; returns the number of inputs.
fn validate_data(inputs: &[Vec<f64>], outputs: &[f64]) -> Result<usize, GpError> {
    let d = crate::training_data::check(inputs, outputs)?;
    if outputs.len() < 2 {
        return Err(GpError::TooFewPoints {
            points: outputs.len(),
        });
    }
    Ok(d)
}

fn validate_settings(settings: &GpSettings, d: usize) -> Result<(), GpError> {
    let invalid = |message: String| Err(GpError::InvalidSettings(message));
    if let Some(fixed) = &settings.fixed {
        if fixed.length_scales.len() != 1 && fixed.length_scales.len() != d {
            return invalid(format!(
                "{} fixed length scales for {d} inputs: give 1 (shared) or {d}",
                fixed.length_scales.len()
            ));
        }
        let positive = |v: f64| v.is_finite() && v > 0.0;
        let valid = fixed.length_scales.iter().all(|l| positive(*l))
            && positive(fixed.signal_variance)
            && fixed.noise_variance.is_finite()
            && fixed.noise_variance >= 0.0;
        if !valid {
            return invalid(
                "fixed hyperparameters must be finite, with positive length scales and signal \
                 variance and a non-negative noise variance"
                    .to_string(),
            );
        }
        return Ok(());
    }
    if settings.restarts == 0 {
        return invalid("restarts is 0: use at least 1 (the default start)".to_string());
    }
    let (low, high) = settings.noise_bounds;
    if !(low > 0.0 && low <= high && high.is_finite()) {
        return invalid(format!(
            "noise bounds ({low}, {high}): need 0 < lower <= upper < inf (default (1e-10, 1))"
        ));
    }
    if let Some(bounds) = &settings.input_bounds {
        if bounds.len() != d {
            return invalid(format!(
                "{} input bounds for {d} inputs: give one (lower, upper) per input",
                bounds.len()
            ));
        }
        if let Some(k) = bounds
            .iter()
            .position(|(lo, hi)| !(lo.is_finite() && hi.is_finite() && lo < hi))
        {
            return invalid(format!(
                "input bounds of input {k} are {:?}: need finite lower < upper",
                bounds[k]
            ));
        }
    }
    Ok(())
}

/// Per-input offset and width of the unit-box map.
fn input_scaling(inputs: &[Vec<f64>], bounds: Option<&[(f64, f64)]>) -> (Vec<f64>, Vec<f64>) {
    let d = inputs[0].len();
    match bounds {
        Some(bounds) => bounds.iter().map(|&(lo, hi)| (lo, hi - lo)).unzip(),
        None => crate::training_data::data_box(inputs, d),
    }
}

/// Mean and population standard deviation of the outputs.
fn output_scaling(outputs: &[f64]) -> Result<(f64, f64), GpError> {
    let n = outputs.len() as f64;
    let mean = outputs.iter().sum::<f64>() / n;
    let variance = outputs.iter().map(|y| (y - mean) * (y - mean)).sum::<f64>() / n;
    let std = variance.sqrt();
    // Relative to the mean: below 1e-12 the standardised outputs are rounding noise.
    if !std.is_finite() || !mean.is_finite() || std <= 1e-12 * mean.abs() {
        return Err(GpError::ConstantOutput { value: outputs[0] });
    }
    Ok((mean, std))
}

/// Multistart maximisation of the log marginal likelihood of the modelled data (row-major
/// `n x d` inputs); returns the best hyperparameters.
///
/// Two stages. First every start runs a short, loosely converged L-BFGS that finds its basin;
/// above `EXPLORATION_SUBSET` points this stage works on a seeded random subset of that size
/// (27 times cheaper per evaluation at n = 600 than the full O(n^3) and, for hyperparameters,
/// nearly as informative). Then only the best is polished to full tolerance on all the data:
/// the likelihood is flat near its optimum (a long tail of tiny decreases), so polishing every
/// start would cost several times more for the same answer.
fn optimise_hyperparameters(
    inputs: &[f64],
    outputs: &[f64],
    settings: &GpSettings,
    d: usize,
) -> Result<ModelledHyperparameters, GpError> {
    let n = outputs.len();
    let p = if settings.ard { d } else { 1 };
    let (noise_low, noise_high) = settings.noise_bounds;
    let mut lower = vec![LENGTH_SCALE_BOUNDS.0.ln(); p];
    let mut upper = vec![LENGTH_SCALE_BOUNDS.1.ln(); p];
    lower.extend([SIGNAL_VARIANCE_BOUNDS.0.ln(), noise_low.ln()]);
    upper.extend([SIGNAL_VARIANCE_BOUNDS.1.ln(), noise_high.ln()]);

    let mut starts = Vec::with_capacity(settings.restarts);
    let mut default_start = vec![DEFAULT_LENGTH_SCALE.ln(); p];
    default_start.extend([
        0.0,
        DEFAULT_NOISE_VARIANCE.clamp(noise_low, noise_high).ln(),
    ]);
    starts.push(default_start.clone());
    let mut rng = ChaCha8Rng::seed_from_u64(settings.seed);
    for _ in 1..settings.restarts {
        let mut start: Vec<f64> = (0..p)
            .map(|_| log_uniform(&mut rng, RANDOM_LENGTH_SCALES))
            .collect();
        start.push(log_uniform(&mut rng, RANDOM_SIGNAL_VARIANCES));
        start.push(log_uniform(&mut rng, settings.noise_bounds));
        starts.push(start);
    }

    let mut full = Workspace::new(settings.kernel, inputs, outputs, d);
    if starts.len() == 1 {
        let best = run_starts(
            &mut full,
            &starts,
            &lower,
            &upper,
            &fit_optimiser_settings(),
        );
        let (_, log_parameters) = best.ok_or(GpError::FitFailed)?;
        return Ok(ModelledHyperparameters::from_log(&log_parameters));
    }

    let exploration = exploration_settings();
    let explored = if n > EXPLORATION_SUBSET {
        let rows = random_subset(n, EXPLORATION_SUBSET, &mut rng);
        let subset_inputs: Vec<f64> = rows
            .iter()
            .flat_map(|&i| inputs[i * d..(i + 1) * d].iter().copied())
            .collect();
        let subset_outputs: Vec<f64> = rows.iter().map(|&i| outputs[i]).collect();
        let mut subset = Workspace::new(settings.kernel, &subset_inputs, &subset_outputs, d);
        run_starts(&mut subset, &starts, &lower, &upper, &exploration)
    } else {
        run_starts(&mut full, &starts, &lower, &upper, &exploration)
    };

    let polish = fit_optimiser_settings();
    let mut best = explored.and_then(|(_, x)| run_starts(&mut full, &[x], &lower, &upper, &polish));
    // The subset's best need not be better on all the data than the default start: if the
    // default start (one evaluation) beats the polished result, polish from it too, so the
    // fit never ends below its default.
    let mut gradient = vec![0.0; default_start.len()];
    let default_value = full.negative_log_likelihood_and_gradient(&default_start, &mut gradient);
    if best
        .as_ref()
        .is_none_or(|(value, _)| default_value < *value)
    {
        if let Some(candidate) = run_starts(&mut full, &[default_start], &lower, &upper, &polish) {
            if best.as_ref().is_none_or(|(value, _)| candidate.0 < *value) {
                best = Some(candidate);
            }
        }
    }
    let (_, log_parameters) = best.ok_or(GpError::FitFailed)?;
    Ok(ModelledHyperparameters::from_log(&log_parameters))
}

/// Runs L-BFGS from each start on `workspace`; returns the lowest (value, point), or None if
/// no start had a finite likelihood (such starts are skipped, not fatal).
fn run_starts(
    workspace: &mut Workspace,
    starts: &[Vec<f64>],
    lower: &[f64],
    upper: &[f64],
    optimiser: &LbfgsSettings,
) -> Option<(f64, Vec<f64>)> {
    let mut best: Option<(f64, Vec<f64>)> = None;
    for start in starts {
        let objective = |theta: &[f64], gradient: &mut [f64]| {
            workspace.negative_log_likelihood_and_gradient(theta, gradient)
        };
        let Ok(minimum) = minimize_bounded(objective, start, lower, upper, optimiser) else {
            continue;
        };
        if best
            .as_ref()
            .is_none_or(|(value, _)| minimum.value < *value)
        {
            best = Some((minimum.value, minimum.x));
        }
    }
    best
}

/// A log-uniform draw in `[low, high]`, as a logarithm.
fn log_uniform(rng: &mut ChaCha8Rng, (low, high): (f64, f64)) -> f64 {
    let u: f64 = rng.random();
    low.ln() + u * (high.ln() - low.ln())
}

/// `size` distinct indices of `0..n`, sorted (a partial Fisher-Yates shuffle).
fn random_subset(n: usize, size: usize, rng: &mut ChaCha8Rng) -> Vec<usize> {
    let mut indices: Vec<usize> = (0..n).collect();
    for i in 0..size.min(n) {
        let u: f64 = rng.random();
        // u < 1, so the pick stays below n; min() guards the rounding edge.
        let pick = (i + (u * (n - i) as f64) as usize).min(n - 1);
        indices.swap(i, pick);
    }
    indices.truncate(size.min(n));
    indices.sort_unstable();
    indices
}
