//! The kernel matrix, its jittered Cholesky factorisation, and the log marginal likelihood with
//! its analytic gradient in the log-hyperparameters: the inner loop of the GP fit, with every
//! buffer allocated once per fit and reused by each evaluation.
//!
//! Matrices are `Vec<f64>` in column-major order (faer's layout) of which only the lower
//! triangle is ever written or read: the kernel matrix is symmetric, and working down a column
//! keeps the hot loops on contiguous memory.

use faer::dyn_stack::{MemBuffer, MemStack, StackReq};
use faer::linalg::cholesky::llt;
use faer::linalg::cholesky::llt::factor::LltRegularization;
use faer::{MatMut, MatRef, Par};

use super::kernel::Kernel;

/// Jitter levels tried in turn when the factorisation fails, as multiples of the mean of the
/// kernel diagonal: zero first, then each a hundred times the last, up to 1e-4. Beyond that the
/// matrix is not "numerically singular" but wrong (NaN, negative variance), or the data has
/// many exact duplicates that only a larger noise bound can explain.
pub(crate) const JITTER_LEVELS: [f64; 5] = [0.0, 1e-10, 1e-8, 1e-6, 1e-4];

const HALF_LN_TWO_PI: f64 = 0.918_938_533_204_672_8;

/// Hyperparameters in the modelled units (unit box and standardised output, or the data's own
/// units with fixed hyperparameters).
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct ModelledHyperparameters {
    /// One shared, or one per input.
    pub length_scales: Vec<f64>,
    pub signal_variance: f64,
    pub noise_variance: f64,
}

impl ModelledHyperparameters {
    /// From the optimiser's vector `[ln l_1 .. ln l_p, ln signal, ln noise]`.
    pub fn from_log(log_parameters: &[f64]) -> Self {
        let p = log_parameters.len().saturating_sub(2);
        Self {
            length_scales: log_parameters[..p].iter().map(|v| v.exp()).collect(),
            signal_variance: log_parameters.get(p).map_or(f64::NAN, |v| v.exp()),
            noise_variance: log_parameters.get(p + 1).map_or(f64::NAN, |v| v.exp()),
        }
    }
}

/// The training data in modelled units plus every buffer one likelihood evaluation needs.
pub(crate) struct Workspace {
    n: usize,
    d: usize,
    kernel: Kernel,
    /// Inputs by dimension: column k of the inputs at `[k n, (k+1) n)`, so the distance loops
    /// run over contiguous memory.
    inputs_by_dimension: Vec<f64>,
    outputs: Vec<f64>,
    /// The inputs divided by their length scale, same layout.
    scaled: Vec<f64>,
    /// k(r_ij) for i >= j (unit signal variance).
    correlation: Vec<f64>,
    /// g(r_ij) = -k'(r)/r for i >= j.
    slope: Vec<f64>,
    /// The kernel matrix, overwritten in place by its Cholesky factor L.
    factor: Vec<f64>,
    /// K^-1, lower triangle.
    inverse: Vec<f64>,
    /// K^-1 y.
    alpha: Vec<f64>,
    /// Per-column scratch: squared distances, then gradient weights.
    column_scratch: Vec<f64>,
    /// Length-scale gradient accumulators.
    length_gradient: Vec<f64>,
    /// The length scales of the current evaluation (one shared, or one per input).
    length_scales: Vec<f64>,
    stack: MemBuffer,
    /// Jitter (absolute, added to the diagonal) used by the last successful factorisation.
    pub jitter: f64,
    /// When set, `negative_log_likelihood_and_gradient` uses exactly this jitter instead of
    /// escalating (to evaluate a saved model as it was factorised).
    pub fixed_jitter: Option<f64>,
}

impl Workspace {
    /// `inputs` row-major `n x d` in modelled units, `outputs` in modelled units.
    pub fn new(kernel: Kernel, inputs: &[f64], outputs: &[f64], d: usize) -> Self {
        let n = outputs.len();
        let mut inputs_by_dimension = vec![0.0; n * d];
        for i in 0..n {
            for k in 0..d {
                inputs_by_dimension[k * n + i] = inputs[i * d + k];
            }
        }
        let scratch = StackReq::any_of(&[
            llt::factor::cholesky_in_place_scratch::<f64>(n, Par::Seq, Default::default()),
            llt::solve::solve_in_place_scratch::<f64>(n, 1, Par::Seq),
            llt::inverse::inverse_scratch::<f64>(n, Par::Seq),
        ]);
        Self {
            n,
            d,
            kernel,
            inputs_by_dimension,
            outputs: outputs.to_vec(),
            scaled: vec![0.0; n * d],
            correlation: vec![0.0; n * n],
            slope: vec![0.0; n * n],
            factor: vec![0.0; n * n],
            inverse: vec![0.0; n * n],
            alpha: vec![0.0; n],
            column_scratch: vec![0.0; n],
            length_gradient: vec![0.0; d],
            length_scales: Vec::with_capacity(d),
            stack: MemBuffer::new(scratch),
            jitter: 0.0,
            fixed_jitter: None,
        }
    }

    pub fn cholesky_factor(&self) -> &[f64] {
        &self.factor
    }

    pub fn alpha(&self) -> &[f64] {
        &self.alpha
    }

    /// Fills `correlation` (and `slope` when `with_slope`) for `self.length_scales`.
    fn assemble(&mut self, with_slope: bool) {
        // Runs the loops compiled for the best SIMD level of this CPU (AVX2/AVX-512 where
        // present, baseline otherwise): with the kernel's branch-free exp they vectorise.
        pulp::Arch::new().dispatch(Vectorised {
            workspace: self,
            task: Task::Assemble { with_slope },
        });
    }

    #[inline(always)]
    fn assemble_inner(&mut self, with_slope: bool) {
        let (n, d) = (self.n, self.d);
        let kernel = self.kernel;
        for k in 0..d {
            let scale = if self.length_scales.len() == 1 {
                self.length_scales[0]
            } else {
                self.length_scales[k]
            };
            let inverse_scale = 1.0 / scale;
            let source = &self.inputs_by_dimension[k * n..(k + 1) * n];
            let target = &mut self.scaled[k * n..(k + 1) * n];
            for (t, s) in target.iter_mut().zip(source) {
                *t = s * inverse_scale;
            }
        }
        for j in 0..n {
            let distances = &mut self.column_scratch[j..n];
            distances.iter_mut().for_each(|v| *v = 0.0);
            for k in 0..d {
                let column = &self.scaled[k * n + j..(k + 1) * n];
                let anchor = column[0];
                for (r2, u) in distances.iter_mut().zip(column) {
                    let delta = u - anchor;
                    *r2 += delta * delta;
                }
            }
            let correlation = &mut self.correlation[j * n + j..(j + 1) * n];
            if with_slope {
                let slope = &mut self.slope[j * n + j..(j + 1) * n];
                kernel.fill_values_and_slopes(distances, correlation, slope);
            } else {
                kernel.fill_values(distances, correlation);
            }
        }
    }

    /// Factorises `signal * correlation + (noise + jitter) I` into `factor`, escalating the
    /// jitter through `JITTER_LEVELS` unless `fixed_jitter` is given. Returns false if no level
    /// works.
    fn factorise(&mut self, signal: f64, noise: f64, fixed_jitter: Option<f64>) -> bool {
        let n = self.n;
        let diagonal_mean = signal + noise;
        let single;
        let levels: &[f64] = match fixed_jitter {
            Some(jitter) => {
                single = [jitter];
                &single
            }
            None => &JITTER_LEVELS,
        };
        for &level in levels {
            let jitter = if fixed_jitter.is_some() {
                level
            } else {
                level * diagonal_mean
            };
            for j in 0..n {
                let range = j * n + j..(j + 1) * n;
                for (f, c) in self.factor[range.clone()]
                    .iter_mut()
                    .zip(&self.correlation[range])
                {
                    *f = signal * c;
                }
                self.factor[j * n + j] += noise + jitter;
            }
            let matrix = MatMut::from_column_major_slice_mut(&mut self.factor, n, n);
            let result = llt::factor::cholesky_in_place(
                matrix,
                LltRegularization::default(),
                Par::Seq,
                MemStack::new(&mut self.stack),
                Default::default(),
            );
            // faer stops on a non-positive pivot; NaN in the matrix can slip through as NaN
            // entries, so the diagonal is checked as well.
            let diagonal_ok = (0..n).all(|j| {
                let l = self.factor[j * n + j];
                l.is_finite() && l > 0.0
            });
            if result.is_ok() && diagonal_ok {
                self.jitter = jitter;
                return true;
            }
        }
        false
    }

    /// Solves for alpha = K^-1 y with the current factor and returns the log marginal
    /// likelihood `-y'alpha/2 - sum ln L_ii - n ln(2 pi)/2`.
    fn solve_and_likelihood(&mut self) -> f64 {
        let n = self.n;
        self.alpha.copy_from_slice(&self.outputs);
        let factor = MatRef::from_column_major_slice(&self.factor, n, n);
        llt::solve::solve_in_place(
            factor,
            MatMut::from_column_major_slice_mut(&mut self.alpha, n, 1),
            Par::Seq,
            MemStack::new(&mut self.stack),
        );
        let fit: f64 = self
            .outputs
            .iter()
            .zip(&self.alpha)
            .map(|(y, a)| y * a)
            .sum();
        let log_determinant_half: f64 = (0..n).map(|j| self.factor[j * n + j].ln()).sum();
        -0.5 * fit - log_determinant_half - n as f64 * HALF_LN_TWO_PI
    }

    /// Factorises at the given hyperparameters (escalating jitter unless `fixed_jitter`) and
    /// returns the log marginal likelihood, or None if the matrix cannot be factorised.
    pub fn factorise_at(
        &mut self,
        hyper: &ModelledHyperparameters,
        fixed_jitter: Option<f64>,
    ) -> Option<f64> {
        self.length_scales.clear();
        self.length_scales.extend_from_slice(&hyper.length_scales);
        self.assemble(false);
        if !self.factorise(hyper.signal_variance, hyper.noise_variance, fixed_jitter) {
            return None;
        }
        let value = self.solve_and_likelihood();
        value.is_finite().then_some(value)
    }

    /// The lower triangle of K^-1 at the current factor, column-major.
    pub fn inverse_from_factor(&mut self) -> &[f64] {
        let n = self.n;
        llt::inverse::inverse(
            MatMut::from_column_major_slice_mut(&mut self.inverse, n, n),
            MatRef::from_column_major_slice(&self.factor, n, n),
            Par::Seq,
            MemStack::new(&mut self.stack),
        );
        &self.inverse
    }

    /// The objective of the fit: minus the log marginal likelihood at
    /// `log_parameters = [ln l_1 .. ln l_p, ln signal, ln noise]`, with its gradient in
    /// `gradient`. `+inf` when the kernel matrix cannot be factorised (the line search then
    /// backs off).
    ///
    /// dL/d theta = tr((alpha alpha' - K^-1) dK/d theta) / 2 (Rasmussen & Williams eq. 5.9),
    /// with W = alpha alpha' - K^-1 and, per pair (i, j):
    /// - d K_ij / d ln signal = signal k(r_ij),
    /// - d K_ij / d ln noise = noise [i = j],
    /// - d K_ij / d ln l_k = signal g(r_ij) (x_ik - x_jk)^2 / l_k^2.
    ///
    /// The jitter is held constant (it is a numerical device, not a parameter).
    pub fn negative_log_likelihood_and_gradient(
        &mut self,
        log_parameters: &[f64],
        gradient: &mut [f64],
    ) -> f64 {
        let p = log_parameters.len() - 2;
        let signal = log_parameters[p].exp();
        let noise = log_parameters[p + 1].exp();
        self.length_scales.clear();
        self.length_scales
            .extend(log_parameters[..p].iter().map(|v| v.exp()));
        self.assemble(true);
        if !self.factorise(signal, noise, self.fixed_jitter) {
            return f64::INFINITY;
        }
        let log_likelihood = self.solve_and_likelihood();
        if !log_likelihood.is_finite() {
            return f64::INFINITY;
        }
        self.inverse_from_factor();

        let (trace, correlation_sum) = pulp::Arch::new().dispatch(Vectorised {
            workspace: self,
            task: Task::GradientSums { isotropic: p == 1 },
        });
        // Off-diagonal sums cover i > j only: the symmetric half doubles them, which cancels
        // the 1/2 of the trace formula.
        for (g, sum) in gradient[..p].iter_mut().zip(&self.length_gradient) {
            *g = -signal * sum;
        }
        gradient[p] = -0.5 * signal * (trace + 2.0 * correlation_sum);
        gradient[p + 1] = -0.5 * noise * trace;
        -log_likelihood
    }

    /// The sums of the gradient, from `alpha`, `inverse`, `correlation`, `slope`, `scaled`:
    /// returns `(sum_i W_ii, sum_{i>j} W_ij k_ij)` and leaves
    /// `sum_{i>j} W_ij g_ij (u_ik - u_jk)^2` per length scale in `length_gradient`.
    #[inline(always)]
    fn accumulate_gradient_sums(&mut self, isotropic: bool) -> (f64, f64) {
        let (n, d) = (self.n, self.d);
        let mut trace = 0.0;
        let mut correlation_sum = 0.0;
        self.length_gradient.iter_mut().for_each(|v| *v = 0.0);
        for j in 0..n {
            let column = j * n + j + 1..(j + 1) * n;
            let inverse = &self.inverse[column.clone()];
            let correlation = &self.correlation[column.clone()];
            let slope = &self.slope[column];
            let alpha_j = self.alpha[j];
            trace += alpha_j * alpha_j - self.inverse[j * n + j];
            let weights = &mut self.column_scratch[j + 1..n];
            // W_ij = alpha_i alpha_j - [K^-1]_ij for i > j.
            for ((w, inv), a) in weights.iter_mut().zip(inverse).zip(&self.alpha[j + 1..]) {
                *w = a * alpha_j - inv;
            }
            correlation_sum += chunked_dot(weights, correlation);
            for (w, g) in weights.iter_mut().zip(slope) {
                *w *= g;
            }
            for k in 0..d {
                let scaled = &self.scaled[k * n + j..(k + 1) * n];
                let sum = chunked_weighted_squares(weights, &scaled[1..], scaled[0]);
                self.length_gradient[if isotropic { 0 } else { k }] += sum;
            }
        }
        (trace, correlation_sum)
    }
}

/// A hot loop to run under `pulp::Arch::dispatch`. A struct rather than a closure because
/// only an `#[inline(always)]` body is compiled inside the dispatcher's target-feature
/// function; a closure's body stays an ordinary baseline-SSE2 function.
struct Vectorised<'a> {
    workspace: &'a mut Workspace,
    task: Task,
}

enum Task {
    Assemble { with_slope: bool },
    GradientSums { isotropic: bool },
}

impl pulp::WithSimd for Vectorised<'_> {
    /// `(trace, correlation sum)` for `GradientSums`, zeros for `Assemble`.
    type Output = (f64, f64);

    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, _simd: S) -> Self::Output {
        match self.task {
            Task::Assemble { with_slope } => {
                self.workspace.assemble_inner(with_slope);
                (0.0, 0.0)
            }
            Task::GradientSums { isotropic } => self.workspace.accumulate_gradient_sums(isotropic),
        }
    }
}

/// Independent accumulators in the reductions: one running sum is a chain of dependent adds
/// the compiler may not reorder (no fast-math), which ran at a quarter of the possible speed.
const LANES: usize = 8;

/// sum_i a_i b_i.
#[inline(always)]
fn chunked_dot(a: &[f64], b: &[f64]) -> f64 {
    let mut partial = [0.0; LANES];
    let mut a_chunks = a.chunks_exact(LANES);
    let mut b_chunks = b.chunks_exact(LANES);
    for (ac, bc) in (&mut a_chunks).zip(&mut b_chunks) {
        for lane in 0..LANES {
            partial[lane] += ac[lane] * bc[lane];
        }
    }
    let tail: f64 = a_chunks
        .remainder()
        .iter()
        .zip(b_chunks.remainder())
        .map(|(x, y)| x * y)
        .sum();
    partial.iter().sum::<f64>() + tail
}

/// sum_i w_i (u_i - anchor)^2.
#[inline(always)]
fn chunked_weighted_squares(weights: &[f64], values: &[f64], anchor: f64) -> f64 {
    let mut partial = [0.0; LANES];
    let mut w_chunks = weights.chunks_exact(LANES);
    let mut u_chunks = values.chunks_exact(LANES);
    for (wc, uc) in (&mut w_chunks).zip(&mut u_chunks) {
        for lane in 0..LANES {
            let delta = uc[lane] - anchor;
            partial[lane] += wc[lane] * delta * delta;
        }
    }
    let tail: f64 = w_chunks
        .remainder()
        .iter()
        .zip(u_chunks.remainder())
        .map(|(w, u)| w * (u - anchor) * (u - anchor))
        .sum();
    partial.iter().sum::<f64>() + tail
}
