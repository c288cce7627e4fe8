//! Bounded quasi-Newton minimisation: a projected L-BFGS in the spirit of L-BFGS-B, the local
//! optimiser under the Gaussian-process hyperparameter fit and the acquisition maximisation.
//!
//! Method, per iteration:
//! 1. the projected gradient `P(x - g) - x` (inf-norm) decides convergence;
//! 2. variables sitting on a bound whose gradient pushes them outwards are held fixed, the
//!    others are "free";
//! 3. the L-BFGS two-loop recursion, applied to the gradient restricted to the free variables,
//!    gives the search direction (steepest descent if that is not a descent direction);
//! 4. a backtracking Armijo line search along the projected path `P(x + t d)`, with safeguarded
//!    quadratic interpolation; a non-finite value or gradient counts as `+inf` and just shortens
//!    the step, so the objective may fail (overflow, a singular matrix) away from the start.
//!
//! This is not the full Byrd-Lu-Nocedal-Zhu L-BFGS-B (no generalised Cauchy point, no
//! subspace minimisation): on the smooth, low-dimensional problems of this crate (a dozen
//! hyperparameters, an acquisition in a handful of inputs) it converges as well and is much
//! simpler to keep panic-free. The crates that offer L-BFGS-B (`rustimization`, `lbfgsb`) wrap
//! the Fortran/C code, and the pure-Rust port found (`rcompat-lbfgsb`) is young and
//! single-purpose (R's `optim` semantics), so a dependency gained nothing.

use thiserror::Error;

/// Why a bounded minimisation could not start. Each message says what to change.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum OptimError {
    #[error("the start point is empty: give at least one variable")]
    Empty,
    #[error(
        "the start point has {start} variables but there are {lower} lower and {upper} upper \
         bounds: give one lower and one upper bound per variable (use -inf/+inf for none)"
    )]
    DimensionMismatch {
        start: usize,
        lower: usize,
        upper: usize,
    },
    #[error(
        "variable {index}: lower bound {lower} is not <= upper bound {upper}: give lower <= upper, \
         no NaN (use -inf/+inf for an unbounded side)"
    )]
    InvalidBounds {
        index: usize,
        lower: f64,
        upper: f64,
    },
    #[error("variable {index} of the start point is {value}: start from finite values")]
    NonFiniteStart { index: usize, value: f64 },
    #[error(
        "the objective or its gradient is not finite at the start point (value {value}): start \
         where the function is defined"
    )]
    NonFiniteObjective { value: f64 },
    #[error(
        "invalid settings: {0}; use LbfgsSettings::default() as a starting point \
         (memory >= 1, tolerances >= 0)"
    )]
    InvalidSettings(&'static str),
}

/// Tuning of [`minimize_bounded`].
#[derive(Clone, Debug, PartialEq)]
pub struct LbfgsSettings {
    /// Number of (step, gradient change) pairs kept for the inverse-Hessian approximation.
    pub memory: usize,
    /// Upper limit on accepted steps.
    pub max_iterations: usize,
    /// Converged when the inf-norm of the projected gradient `P(x - g) - x` is at most this.
    pub gradient_tolerance: f64,
    /// Converged when one step lowers f by at most this times `max(|f_old|, |f_new|, 1)`
    /// (scipy's `ftol` criterion).
    pub relative_tolerance: f64,
}

impl Default for LbfgsSettings {
    fn default() -> Self {
        Self {
            memory: 10,
            max_iterations: 200,
            gradient_tolerance: 1e-6,
            relative_tolerance: 1e-10,
        }
    }
}

/// Why the iteration stopped.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Termination {
    /// The projected gradient is below `gradient_tolerance`.
    GradientTolerance,
    /// The last step decreased f by less than `relative_tolerance` (relative).
    RelativeDecrease,
    /// `max_iterations` steps were taken.
    MaxIterations,
    /// No step along the projected steepest-descent path lowered f (the point is optimal to
    /// rounding, or the gradient is wrong).
    LineSearchFailed,
}

/// The result of [`minimize_bounded`]: the best point found, always inside the bounds.
#[derive(Clone, Debug, PartialEq)]
pub struct Minimum {
    pub x: Vec<f64>,
    pub value: f64,
    /// Accepted steps.
    pub iterations: usize,
    /// Calls of the objective (value and gradient together).
    pub evaluations: usize,
    /// True when stopped by the gradient or relative-decrease test.
    pub converged: bool,
    pub termination: Termination,
    /// Inf-norm of the projected gradient at `x`.
    pub projected_gradient: f64,
}

/// Armijo sufficient-decrease constant.
const ARMIJO: f64 = 1e-4;
/// Backtracking steps before the line search gives up: the step then is below 1e-12 of the
/// first trial, far under what moves any f64 coordinate of interest.
const MAX_BACKTRACKS: usize = 40;
/// Relative size of a first-order decrease that f64 rounding of f can no longer confirm.
const ROUNDING_FLOOR: f64 = 8.0 * f64::EPSILON;

/// Minimises `f` inside the box `lower <= x <= upper`, starting from `x0` (projected into the
/// box). `f(x, grad)` returns the value and writes the gradient into `grad`; a non-finite value
/// or gradient is treated as `+inf` (the line search backs off). Bounds may be infinite.
pub fn minimize_bounded<F: FnMut(&[f64], &mut [f64]) -> f64>(
    mut f: F,
    x0: &[f64],
    lower: &[f64],
    upper: &[f64],
    settings: &LbfgsSettings,
) -> Result<Minimum, OptimError> {
    let n = x0.len();
    if n == 0 {
        return Err(OptimError::Empty);
    }
    if lower.len() != n || upper.len() != n {
        return Err(OptimError::DimensionMismatch {
            start: n,
            lower: lower.len(),
            upper: upper.len(),
        });
    }
    for index in 0..n {
        let (low, high) = (lower[index], upper[index]);
        if low.is_nan() || high.is_nan() || low > high || low == f64::INFINITY {
            return Err(OptimError::InvalidBounds {
                index,
                lower: lower[index],
                upper: upper[index],
            });
        }
        if upper[index] == f64::NEG_INFINITY {
            return Err(OptimError::InvalidBounds {
                index,
                lower: lower[index],
                upper: upper[index],
            });
        }
        if !x0[index].is_finite() {
            return Err(OptimError::NonFiniteStart {
                index,
                value: x0[index],
            });
        }
    }
    if settings.memory == 0 {
        return Err(OptimError::InvalidSettings("memory is 0"));
    }
    let invalid_tolerance = |t: f64| t.is_nan() || t < 0.0;
    if invalid_tolerance(settings.gradient_tolerance)
        || invalid_tolerance(settings.relative_tolerance)
    {
        return Err(OptimError::InvalidSettings(
            "a tolerance is negative or NaN",
        ));
    }

    let mut evaluations = 0usize;
    let mut evaluate = |x: &[f64], grad: &mut [f64]| -> f64 {
        evaluations += 1;
        let value = f(x, grad);
        if value.is_finite() && grad.iter().all(|g| g.is_finite()) {
            value
        } else {
            f64::INFINITY
        }
    };

    let mut x: Vec<f64> = (0..n).map(|i| x0[i].clamp(lower[i], upper[i])).collect();
    let mut grad = vec![0.0; n];
    let mut value = evaluate(&x, &mut grad);
    if !value.is_finite() {
        return Err(OptimError::NonFiniteObjective { value });
    }

    let mut memory = Memory::new(settings.memory, n);
    let mut direction = vec![0.0; n];
    let mut free = vec![true; n];
    let mut trial_x = vec![0.0; n];
    let mut trial_grad = vec![0.0; n];
    let mut iterations = 0usize;
    let termination;

    loop {
        let projected_gradient = projected_gradient_norm(&x, &grad, lower, upper);
        if projected_gradient <= settings.gradient_tolerance {
            termination = Termination::GradientTolerance;
            break;
        }
        if iterations >= settings.max_iterations {
            termination = Termination::MaxIterations;
            break;
        }

        // Free variables: not pinned on a bound by a gradient pointing out of the box.
        let mut free_set_changed = false;
        for i in 0..n {
            let pinned_low = x[i] <= lower[i] && grad[i] > 0.0;
            let pinned_high = x[i] >= upper[i] && grad[i] < 0.0;
            let is_free = !(pinned_low || pinned_high);
            free_set_changed |= is_free != free[i];
            free[i] = is_free;
        }
        // The curvature pairs describe the objective on the old free subspace; mixing them
        // into the new one gives poor directions (a 2-D quadratic then needs a dozen steps
        // after one variable lands on its bound), so start the memory afresh.
        if free_set_changed {
            memory.clear();
        }

        // Try the quasi-Newton direction first; if its line search fails, forget the curvature
        // pairs (they may be stale after the active set changed) and try steepest descent.
        let mut accepted = None;
        for use_memory in [true, false] {
            if !use_memory && memory.is_empty() {
                continue;
            }
            if !use_memory {
                memory.clear();
            }
            let slope =
                search_direction(&mut memory, &grad, &free, &x, lower, upper, &mut direction);
            if slope.is_nan() || slope >= 0.0 {
                continue;
            }
            // Without curvature information the first trial step moves at most one unit
            // (L-BFGS-B does the same), so a steep start does not fly to the bounds.
            let first_step = if memory.is_empty() {
                let norm = direction.iter().map(|d| d * d).sum::<f64>().sqrt();
                (1.0 / norm).min(1.0)
            } else {
                1.0
            };
            if let Some(trial_value) = line_search(
                &mut evaluate,
                LineSearchStart {
                    x: &x,
                    value,
                    grad: &grad,
                    direction: &direction,
                    slope,
                    first_step,
                },
                lower,
                upper,
                &mut trial_x,
                &mut trial_grad,
            ) {
                accepted = Some(trial_value);
                break;
            }
        }
        let Some(new_value) = accepted else {
            termination = Termination::LineSearchFailed;
            break;
        };

        memory.push(&x, &trial_x, &grad, &trial_grad, &free);
        let decrease = value - new_value;
        let scale = value.abs().max(new_value.abs()).max(1.0);
        std::mem::swap(&mut x, &mut trial_x);
        std::mem::swap(&mut grad, &mut trial_grad);
        value = new_value;
        iterations += 1;
        if decrease <= settings.relative_tolerance * scale {
            termination = Termination::RelativeDecrease;
            break;
        }
    }

    let projected_gradient = projected_gradient_norm(&x, &grad, lower, upper);
    let converged = matches!(
        termination,
        Termination::GradientTolerance | Termination::RelativeDecrease
    );
    Ok(Minimum {
        x,
        value,
        iterations,
        evaluations,
        converged,
        termination,
        projected_gradient,
    })
}

/// Inf-norm of `P(x - g) - x`, zero exactly at a bound-constrained stationary point.
fn projected_gradient_norm(x: &[f64], grad: &[f64], lower: &[f64], upper: &[f64]) -> f64 {
    x.iter()
        .zip(grad)
        .zip(lower.iter().zip(upper))
        .map(|((&xi, &gi), (&lo, &hi))| ((xi - gi).clamp(lo, hi) - xi).abs())
        .fold(0.0, f64::max)
}

/// Writes the search direction and returns the slope `grad . direction` (negative for a
/// descent direction). Components of pinned variables, and of free variables on a bound that
/// the direction would push outwards (projection would clip them to zero anyway), are zero.
fn search_direction(
    memory: &mut Memory,
    grad: &[f64],
    free: &[bool],
    x: &[f64],
    lower: &[f64],
    upper: &[f64],
    direction: &mut [f64],
) -> f64 {
    for i in 0..grad.len() {
        direction[i] = if free[i] { grad[i] } else { 0.0 };
    }
    memory.apply_inverse_hessian(direction);
    let mut slope = 0.0;
    for i in 0..grad.len() {
        let d = -direction[i];
        let outwards = (x[i] <= lower[i] && d < 0.0) || (x[i] >= upper[i] && d > 0.0);
        direction[i] = if free[i] && !outwards && d.is_finite() {
            d
        } else {
            0.0
        };
        slope += grad[i] * direction[i];
    }
    slope
}

struct LineSearchStart<'a> {
    x: &'a [f64],
    value: f64,
    grad: &'a [f64],
    direction: &'a [f64],
    slope: f64,
    first_step: f64,
}

/// Backtracking Armijo search along `P(x + t d)`. On success `trial_x`/`trial_grad` hold the
/// accepted point and its gradient and the value is returned.
fn line_search<E: FnMut(&[f64], &mut [f64]) -> f64>(
    evaluate: &mut E,
    start: LineSearchStart<'_>,
    lower: &[f64],
    upper: &[f64],
    trial_x: &mut [f64],
    trial_grad: &mut [f64],
) -> Option<f64> {
    let mut step = start.first_step;
    for _ in 0..MAX_BACKTRACKS {
        let mut moved = false;
        let mut predicted = 0.0;
        for i in 0..start.x.len() {
            trial_x[i] = (start.x[i] + step * start.direction[i]).clamp(lower[i], upper[i]);
            moved |= trial_x[i] != start.x[i];
            predicted += start.grad[i] * (trial_x[i] - start.x[i]);
        }
        // Below a few rounding errors of f the Armijo test compares noise: the point is as
        // good as this direction can make it, and backtracking further only burns calls.
        if !moved || -predicted <= ROUNDING_FLOOR * start.value.abs() {
            return None;
        }
        // Along the projected path the first-order decrease is `g . (x(t) - x)`; if clipping
        // made it non-negative the step is too long to trust the model: shorten it.
        if predicted < 0.0 {
            let trial_value = evaluate(trial_x, trial_grad);
            if trial_value <= start.value + ARMIJO * predicted {
                return Some(trial_value);
            }
            step = if trial_value.is_finite() {
                // Minimiser of the quadratic through f(0), f'(0) and f(t), kept in
                // [0.1 t, 0.5 t] so one bad model cannot stall or barely move the search.
                let curvature = trial_value - start.value - start.slope * step;
                let quadratic = if curvature > 0.0 {
                    -start.slope * step * step / (2.0 * curvature)
                } else {
                    0.5 * step
                };
                quadratic.clamp(0.1 * step, 0.5 * step)
            } else {
                0.25 * step
            };
        } else {
            step *= 0.5;
        }
    }
    None
}

/// The L-BFGS curvature pairs, a ring buffer of the last `capacity` (s, y) pairs.
struct Memory {
    steps: Vec<Vec<f64>>,
    gradient_changes: Vec<Vec<f64>>,
    inverse_curvatures: Vec<f64>,
    alphas: Vec<f64>,
    /// Index of the oldest pair.
    head: usize,
    len: usize,
}

impl Memory {
    fn new(capacity: usize, n: usize) -> Self {
        Self {
            steps: vec![vec![0.0; n]; capacity],
            gradient_changes: vec![vec![0.0; n]; capacity],
            inverse_curvatures: vec![0.0; capacity],
            alphas: vec![0.0; capacity],
            head: 0,
            len: 0,
        }
    }

    fn is_empty(&self) -> bool {
        self.len == 0
    }

    fn clear(&mut self) {
        self.len = 0;
        self.head = 0;
    }

    fn slot(&self, age: usize) -> usize {
        (self.head + age) % self.steps.len()
    }

    /// Stores the pair if it has positive curvature `s . y`: without a Wolfe curvature
    /// condition in the line search that is not guaranteed, and a non-positive pair would
    /// make the approximation indefinite.
    /// Only the free components of the gradient change are kept: the pinned ones do not
    /// move, and their gradient change would otherwise leak into the free directions.
    fn push(&mut self, x: &[f64], new_x: &[f64], grad: &[f64], new_grad: &[f64], free: &[bool]) {
        let capacity = self.steps.len();
        let slot = if self.len < capacity {
            self.slot(self.len)
        } else {
            self.head
        };
        let mut sy = 0.0;
        let mut yy = 0.0;
        {
            let s = &mut self.steps[slot];
            let y = &mut self.gradient_changes[slot];
            for i in 0..x.len() {
                s[i] = new_x[i] - x[i];
                y[i] = if free[i] { new_grad[i] - grad[i] } else { 0.0 };
                sy += s[i] * y[i];
                yy += y[i] * y[i];
            }
        }
        if !sy.is_finite() || sy <= f64::EPSILON * yy {
            return;
        }
        self.inverse_curvatures[slot] = 1.0 / sy;
        if self.len < capacity {
            self.len += 1;
        } else {
            self.head = (self.head + 1) % capacity;
        }
    }

    /// Two-loop recursion: overwrites `v` with `H v`, H the L-BFGS inverse-Hessian estimate
    /// scaled by `s.y / y.y` of the newest pair (identity when empty).
    fn apply_inverse_hessian(&mut self, v: &mut [f64]) {
        if self.len == 0 {
            return;
        }
        for age in (0..self.len).rev() {
            let k = self.slot(age);
            let alpha = self.inverse_curvatures[k] * dot(&self.steps[k], v);
            self.alphas[k] = alpha;
            axpy(-alpha, &self.gradient_changes[k], v);
        }
        let newest = self.slot(self.len - 1);
        let y = &self.gradient_changes[newest];
        let gamma = 1.0 / (self.inverse_curvatures[newest] * dot(y, y));
        for vi in v.iter_mut() {
            *vi *= gamma;
        }
        for age in 0..self.len {
            let k = self.slot(age);
            let beta = self.inverse_curvatures[k] * dot(&self.gradient_changes[k], v);
            axpy(self.alphas[k] - beta, &self.steps[k], v);
        }
    }
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

fn axpy(a: f64, x: &[f64], y: &mut [f64]) {
    for (yi, xi) in y.iter_mut().zip(x) {
        *yi += a * xi;
    }
}
