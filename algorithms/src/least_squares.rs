//! Bounded nonlinear least squares: Levenberg-Marquardt in the unit box.
//!
//! For models that cost little and answer smoothly (a twin that runs in
//! microseconds, a solver converged tightly), a local Gauss-Newton search
//! reaches the optimum in a few hundred runs where a global search needs
//! thousands. It minimises `sum r_i(u)^2` over `u` in `[0, 1]^d`, where the
//! residuals `r` are a function of the model's outputs at `u`.
//!
//! - The Jacobian is taken by forward differences, all `d` shifted points
//!   in one batch (so a caller can run them in parallel), stepping inward at
//!   a bound. A failed run leaves its column zero for that iteration.
//! - The step solves `(J^T J + lambda diag(J^T J)) delta = -J^T r` (Marquardt's
//!   scaling, so parameters of different sensitivity step alike) over the
//!   free parameters; a parameter at a bound whose gradient points out of
//!   the box is held there (a projected step), and every step is clipped to
//!   the box.
//! - A step that lowers the cost is taken and `lambda` falls; one that does
//!   not raises `lambda` and is tried again without a new Jacobian.
//!
//! Written here rather than taken from a crate: the well-kept Rust
//! Levenberg-Marquardt crates take no bounds and evaluate one point at a
//! time, and a study's runs must go through its logging, resumable
//! evaluator in batches.

use faer::prelude::*;
use faer::Mat;

/// How the search runs and when it stops.
#[derive(Clone, Debug)]
pub struct LeastSquaresSettings {
    /// Model runs at most, Jacobians included.
    pub max_evaluations: usize,
    /// The forward-difference step in the unit box.
    pub difference_step: f64,
    /// Converged when a taken step lowers the cost by less than this
    /// share of it.
    pub relative_tolerance: f64,
    /// The step (unit box) of the central differences the returned
    /// Jacobian is taken with.
    pub spread_step: f64,
    /// Also converged when the last [`STALL_STEPS`] taken steps together
    /// lowered it by less than this share: a model whose outputs are
    /// smooth only to some digits (an iterative solve inside) makes the
    /// search creep at the end instead of stopping.
    pub stall_tolerance: f64,
}

/// The taken steps [`LeastSquaresSettings::stall_tolerance`] looks back over.
pub const STALL_STEPS: usize = 5;

impl Default for LeastSquaresSettings {
    fn default() -> Self {
        LeastSquaresSettings {
            max_evaluations: 2000,
            difference_step: 1e-6,
            relative_tolerance: 1e-10,
            stall_tolerance: 1e-6,
            spread_step: 1e-3,
        }
    }
}

/// Why the search stopped.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Stop {
    /// A step lowered the cost by less than the tolerance (or to zero).
    Converged,
    /// No step along the gradient lowers the cost any more: a (possibly
    /// bounded) minimum at the resolution of the differences.
    NoDescent,
    /// The run budget is spent.
    Budget,
}

/// What the search found.
#[derive(Clone, Debug)]
pub struct LeastSquaresResult {
    /// The optimum in the unit box.
    pub point: Vec<f64>,
    /// The model's outputs there.
    pub outputs: Vec<f64>,
    pub residuals: Vec<f64>,
    /// `sum r_i^2` there.
    pub cost: f64,
    /// d output / d unit at the optimum (central differences), one row per
    /// output.
    pub output_jacobian: Vec<Vec<f64>>,
    /// d residual / d unit at the optimum, one row per residual.
    pub residual_jacobian: Vec<Vec<f64>>,
    pub iterations: usize,
    pub evaluations: usize,
    pub stop: Stop,
}

/// Why the search could not run.
#[derive(Debug)]
pub enum LeastSquaresError<E> {
    /// The caller's runner failed (a log that cannot be written).
    Run(E),
    /// The start point's run failed, so there is nothing to descend from.
    StartFailed,
    /// The residuals are not all finite at the start point.
    NotFinite,
}

impl<E: std::fmt::Display> std::fmt::Display for LeastSquaresError<E> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            LeastSquaresError::Run(e) => write!(f, "{e}"),
            LeastSquaresError::StartFailed => write!(
                f,
                "the model run at the start point failed, so the least-squares search has nowhere to start; fix the nominal values or the bounds"
            ),
            LeastSquaresError::NotFinite => write!(
                f,
                "the residuals at the start point are not all finite (a measured value of 0 with relative residuals, or an uncertainty of 0)"
            ),
        }
    }
}

/// Runs a batch of unit-box points: each one's outputs, or `None`.
type BatchRunner<'r, E> =
    dyn FnMut(&[Vec<f64>]) -> Result<Vec<Option<Vec<f64>>>, LeastSquaresError<E>> + 'r;

fn sum_of_squares(r: &[f64]) -> f64 {
    r.iter().map(|v| v * v).sum()
}

/// Minimises `sum residuals(outputs(u))^2` from `start` (unit box). `run`
/// takes a batch of unit-box points and gives each one's outputs, or `None`
/// for a failed run.
pub fn least_squares<E>(
    start: Vec<f64>,
    mut run: impl FnMut(&[Vec<f64>]) -> Result<Vec<Option<Vec<f64>>>, E>,
    residuals: impl Fn(&[f64]) -> Vec<f64>,
    settings: &LeastSquaresSettings,
) -> Result<LeastSquaresResult, LeastSquaresError<E>> {
    let d = start.len();
    let mut x: Vec<f64> = start.iter().map(|u| u.clamp(0.0, 1.0)).collect();
    let mut evaluations = 0usize;
    let mut run_batch = |points: &[Vec<f64>], evaluations: &mut usize| {
        *evaluations += points.len();
        run(points).map_err(LeastSquaresError::Run)
    };
    let Some(mut outputs) = run_batch(std::slice::from_ref(&x), &mut evaluations)?
        .pop()
        .flatten()
    else {
        return Err(LeastSquaresError::StartFailed);
    };
    let mut r = residuals(&outputs);
    if r.iter().any(|v| !v.is_finite()) {
        return Err(LeastSquaresError::NotFinite);
    }
    let mut cost = sum_of_squares(&r);

    let mut lambda = 1e-3;
    let mut iterations = 0;
    let mut taken_costs = vec![cost];
    let mut jacobian_at_x = None;
    let stop = loop {
        if evaluations + d + 1 > settings.max_evaluations {
            break Stop::Budget;
        }
        if jacobian_at_x.is_none() {
            let mut batch = |p: &[Vec<f64>]| run_batch(p, &mut evaluations);
            jacobian_at_x = Some(forward_jacobians(
                &x,
                &outputs,
                &r,
                settings.difference_step,
                &residuals,
                &mut batch,
            )?);
        }
        let (_, j) = jacobian_at_x.as_ref().expect("just computed");
        iterations += 1;
        let r_column = Mat::from_fn(r.len(), 1, |k, _| r[k]);
        let gradient = j.transpose() * &r_column;
        let normal = j.transpose() * j;
        let free = free_parameters(&x, &gradient, &normal);
        if free.is_empty() {
            break Stop::NoDescent;
        }
        let delta = damped_step(&free, &normal, &gradient, lambda);
        if delta.iter().any(|v| !v.is_finite()) {
            lambda *= 4.0;
            if lambda > 1e12 {
                break Stop::NoDescent;
            }
            continue;
        }
        // A step whose run fails (the model cannot be built there: a
        // linkage that no longer closes) is halved along the same
        // direction a few times before the damping rises: the boundary of
        // where the model runs is no reason to turn.
        let mut fraction = 1.0;
        let (candidate, tried) = loop {
            let candidate: Vec<f64> = x
                .iter()
                .zip(&delta)
                .map(|(u, s)| (u + fraction * s).clamp(0.0, 1.0))
                .collect();
            let tried = run_batch(std::slice::from_ref(&candidate), &mut evaluations)?
                .pop()
                .flatten();
            if tried.is_some() || fraction < 0.1 || evaluations + d + 2 > settings.max_evaluations {
                break (candidate, tried);
            }
            fraction *= 0.5;
        };
        let moved = candidate
            .iter()
            .zip(&x)
            .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
        if moved < 1e-14 {
            break Stop::NoDescent;
        }
        let better = tried.and_then(|y| {
            let ry = residuals(&y);
            let c = sum_of_squares(&ry);
            (c.is_finite() && c < cost).then_some((y, ry, c))
        });
        match better {
            Some((y, ry, c)) => {
                let decrease = cost - c;
                x = candidate;
                outputs = y;
                r = ry;
                cost = c;
                jacobian_at_x = None;
                lambda = (lambda / 3.0).max(1e-12);
                taken_costs.push(cost);
                let stalled = taken_costs.len() > STALL_STEPS && {
                    let before = taken_costs[taken_costs.len() - 1 - STALL_STEPS];
                    before - cost <= settings.stall_tolerance * before
                };
                if decrease <= settings.relative_tolerance * (cost + decrease)
                    || cost == 0.0
                    || stalled
                {
                    break Stop::Converged;
                }
            }
            None => {
                lambda *= 4.0;
                if lambda > 1e12 {
                    break Stop::NoDescent;
                }
            }
        }
    };
    let (output_jacobian, residual_jacobian) = {
        let mut batch = |p: &[Vec<f64>]| run_batch(p, &mut evaluations);
        spread_jacobians(
            &x,
            &outputs,
            &r,
            settings.spread_step,
            &residuals,
            &mut batch,
        )?
    };
    Ok(LeastSquaresResult {
        point: x,
        outputs,
        residuals: r,
        cost,
        output_jacobian,
        residual_jacobian,
        iterations,
        evaluations,
        stop,
    })
}

/// Forward-difference Jacobians of the outputs and the residuals at `x`
/// (unit box), stepping `h` inward at an upper bound. A shifted run that
/// failed or gave non-finite values leaves its column zero.
fn forward_jacobians<E>(
    x: &[f64],
    outputs: &[f64],
    r: &[f64],
    h: f64,
    residuals: &impl Fn(&[f64]) -> Vec<f64>,
    run_batch: &mut BatchRunner<'_, E>,
) -> Result<(Mat<f64>, Mat<f64>), LeastSquaresError<E>> {
    let d = x.len();
    let steps: Vec<f64> = x
        .iter()
        .map(|&u| if u + h <= 1.0 { h } else { -h })
        .collect();
    let points: Vec<Vec<f64>> = (0..d)
        .map(|i| {
            let mut p = x.to_vec();
            p[i] += steps[i];
            p
        })
        .collect();
    let shifted = run_batch(&points)?;
    let mut output_jacobian = Mat::<f64>::zeros(outputs.len(), d);
    let mut residual_jacobian = Mat::<f64>::zeros(r.len(), d);
    for (i, result) in shifted.into_iter().enumerate() {
        let Some(y) = result else { continue };
        let ry = residuals(&y);
        if y.len() != outputs.len() || ry.len() != r.len() {
            continue;
        }
        if ry.iter().chain(&y).any(|v| !v.is_finite()) {
            continue;
        }
        for k in 0..outputs.len() {
            output_jacobian[(k, i)] = (y[k] - outputs[k]) / steps[i];
        }
        for k in 0..r.len() {
            residual_jacobian[(k, i)] = (ry[k] - r[k]) / steps[i];
        }
    }
    Ok((output_jacobian, residual_jacobian))
}

/// The parameters a step may move: seen by the residuals, and not held at
/// a bound that the descent direction (-gradient) would leave.
fn free_parameters(x: &[f64], gradient: &Mat<f64>, normal: &Mat<f64>) -> Vec<usize> {
    (0..x.len())
        .filter(|&i| {
            let g = gradient[(i, 0)];
            let seen = normal[(i, i)] > 0.0;
            let held = (x[i] <= 0.0 && g > 0.0) || (x[i] >= 1.0 && g < 0.0);
            seen && !held
        })
        .collect()
}

/// The Levenberg-Marquardt step over the free parameters, damped by
/// `lambda` times the normal matrix's diagonal (floored, so a parameter
/// the residuals barely see is still damped); zero for the others.
fn damped_step(free: &[usize], normal: &Mat<f64>, gradient: &Mat<f64>, lambda: f64) -> Vec<f64> {
    let scale_floor = free.iter().map(|&i| normal[(i, i)]).fold(0.0f64, f64::max) * 1e-12;
    let n = free.len();
    let system = Mat::from_fn(n, n, |a, b| {
        let (i, k) = (free[a], free[b]);
        let damping = if a == b {
            lambda * normal[(i, i)].max(scale_floor)
        } else {
            0.0
        };
        normal[(i, k)] + damping
    });
    let rhs = Mat::from_fn(n, 1, |a, _| -gradient[(free[a], 0)]);
    let solution = system.partial_piv_lu().solve(&rhs);
    let mut delta = vec![0.0; normal.nrows()];
    for (a, &i) in free.iter().enumerate() {
        delta[i] = solution[(a, 0)];
    }
    delta
}

/// A matrix as its rows.
type Rows = Vec<Vec<f64>>;

/// The Jacobians returned (for the parameters' spread), as rows: central
/// differences over a wider step `s`, since a model smooth only at some
/// scale (an inner search, a tolerance) must not turn a tiny jump into a
/// huge slope there. Both sides where both ran; else the side that ran
/// and the centre.
fn spread_jacobians<E>(
    x: &[f64],
    outputs: &[f64],
    r: &[f64],
    s: f64,
    residuals: &impl Fn(&[f64]) -> Vec<f64>,
    run_batch: &mut BatchRunner<'_, E>,
) -> Result<(Rows, Rows), LeastSquaresError<E>> {
    let d = x.len();
    let stencil: Vec<(f64, f64)> = x
        .iter()
        .map(|&u| {
            let centre = u.clamp(s, 1.0 - s);
            (centre - s, centre + s)
        })
        .collect();
    let points: Vec<Vec<f64>> = (0..d)
        .flat_map(|i| {
            let (low, high) = stencil[i];
            [low, high].map(|v| {
                let mut p = x.to_vec();
                p[i] = v;
                p
            })
        })
        .collect();
    let shifted = run_batch(&points)?;
    let mut output_jacobian = Mat::<f64>::zeros(outputs.len(), d);
    let mut residual_jacobian = Mat::<f64>::zeros(r.len(), d);
    fn usable(y: &Option<Vec<f64>>, length: usize) -> Option<&Vec<f64>> {
        y.as_ref()
            .filter(|y| y.len() == length && y.iter().all(|v| v.is_finite()))
    }
    for i in 0..d {
        let (low, high) = stencil[i];
        // Both sides where both ran; else the side that ran and the centre.
        let sides = match (
            usable(&shifted[2 * i], outputs.len()),
            usable(&shifted[2 * i + 1], outputs.len()),
        ) {
            (Some(a), Some(b)) => Some((a.clone(), low, b.clone(), high)),
            (Some(a), None) => Some((a.clone(), low, outputs.to_vec(), x[i])),
            (None, Some(b)) => Some((outputs.to_vec(), x[i], b.clone(), high)),
            (None, None) => None,
        };
        let Some((ya, ua, yb, ub)) = sides else {
            continue;
        };
        if ub == ua {
            continue;
        }
        let (ra, rb) = (residuals(&ya), residuals(&yb));
        for k in 0..outputs.len() {
            output_jacobian[(k, i)] = (yb[k] - ya[k]) / (ub - ua);
        }
        for k in 0..r.len().min(ra.len()).min(rb.len()) {
            residual_jacobian[(k, i)] = (rb[k] - ra[k]) / (ub - ua);
        }
    }
    let rows = |m: &Mat<f64>| -> Vec<Vec<f64>> {
        (0..m.nrows())
            .map(|k| (0..m.ncols()).map(|i| m[(k, i)]).collect())
            .collect()
    };
    Ok((rows(&output_jacobian), rows(&residual_jacobian)))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn solve(
        start: Vec<f64>,
        outputs: impl Fn(&[f64]) -> Option<Vec<f64>>,
        residuals: impl Fn(&[f64]) -> Vec<f64>,
    ) -> LeastSquaresResult {
        least_squares::<String>(
            start,
            |points| Ok(points.iter().map(|p| outputs(p)).collect()),
            residuals,
            &LeastSquaresSettings::default(),
        )
        .expect("runs")
    }

    #[test]
    fn a_linear_problem_lands_on_the_normal_equations_solution() {
        // (x - 0.3)^2 + 4 (y - 0.6)^2 + (x + y - 1)^2: the normal equations
        // 2x + y = 1.3, x + 5y = 3.4 give x = 3.1/9, y = 1.3 - 2x.
        let result = solve(
            vec![0.9, 0.1],
            |u| Some(u.to_vec()),
            |y| vec![y[0] - 0.3, 2.0 * (y[1] - 0.6), y[0] + y[1] - 1.0],
        );
        let x = 3.1 / 9.0;
        assert!((result.point[0] - x).abs() < 1e-7, "{:?}", result.point);
        assert!((result.point[1] - (1.3 - 2.0 * x)).abs() < 1e-7);
        assert_eq!(result.stop, Stop::Converged);
        // The Jacobian of the residuals is the constant matrix.
        let j = &result.residual_jacobian;
        assert!((j[1][1] - 2.0).abs() < 1e-6 && (j[2][0] - 1.0).abs() < 1e-6);
    }

    #[test]
    fn rosenbrock_valley_is_followed_to_its_minimum() {
        // x, y in [-2, 2]: residuals 10 (y - x^2), 1 - x; minimum at (1, 1).
        let to_xy = |u: &[f64]| vec![4.0 * u[0] - 2.0, 4.0 * u[1] - 2.0];
        let result = solve(
            vec![0.2, 0.9],
            |u| Some(to_xy(u)),
            |p| vec![10.0 * (p[1] - p[0] * p[0]), 1.0 - p[0]],
        );
        let p = to_xy(&result.point);
        assert!(
            (p[0] - 1.0).abs() < 1e-5 && (p[1] - 1.0).abs() < 1e-5,
            "{p:?}"
        );
        assert!(result.cost < 1e-10);
        assert!(result.evaluations < 400, "{}", result.evaluations);
    }

    #[test]
    fn a_minimum_outside_the_box_stops_at_its_face() {
        // Unbounded minimum at (1.5, 0.5); in the box: (1, 0.5).
        let result = solve(
            vec![0.2, 0.2],
            |u| Some(u.to_vec()),
            |y| vec![y[0] - 1.5, y[1] - 0.5],
        );
        assert_eq!(result.point[0], 1.0);
        assert!((result.point[1] - 0.5).abs() < 1e-8, "{:?}", result.point);
        assert!((result.cost - 0.25).abs() < 1e-12);
    }

    #[test]
    fn an_exponential_decay_is_recovered_from_exact_data() {
        // y = a exp(-b t), a in [0, 10], b in [0, 5]; truth a = 3, b = 1.2.
        let times: Vec<f64> = (0..12).map(|k| 0.25 * k as f64).collect();
        let data: Vec<f64> = times.iter().map(|t| 3.0 * (-1.2 * t).exp()).collect();
        let model = |u: &[f64]| -> Vec<f64> {
            let (a, b) = (10.0 * u[0], 5.0 * u[1]);
            times.iter().map(|t| a * (-b * t).exp()).collect()
        };
        let result = solve(
            vec![0.5, 0.5],
            |u| Some(model(u)),
            |y| y.iter().zip(&data).map(|(m, d)| m - d).collect(),
        );
        assert!((10.0 * result.point[0] - 3.0).abs() < 1e-6);
        assert!((5.0 * result.point[1] - 1.2).abs() < 1e-6);
    }

    #[test]
    fn failed_runs_are_stepped_around_and_a_failed_start_is_an_error() {
        // Runs fail for x > 0.7; the minimum at x = 0.5 is still reached.
        let result = solve(
            vec![0.1],
            |u| (u[0] <= 0.7).then(|| u.to_vec()),
            |y| vec![y[0] - 0.5],
        );
        assert!((result.point[0] - 0.5).abs() < 1e-8);
        let failed = least_squares::<String>(
            vec![0.9],
            |points| Ok(points.iter().map(|_| None).collect()),
            |y: &[f64]| y.to_vec(),
            &LeastSquaresSettings::default(),
        );
        assert!(matches!(failed, Err(LeastSquaresError::StartFailed)));
    }

    #[test]
    fn the_budget_is_kept() {
        let settings = LeastSquaresSettings {
            max_evaluations: 7,
            ..LeastSquaresSettings::default()
        };
        let mut runs = 0;
        let result = least_squares::<String>(
            vec![0.2, 0.9],
            |points| {
                runs += points.len();
                Ok(points
                    .iter()
                    .map(|u| Some(vec![4.0 * u[0] - 2.0, 4.0 * u[1] - 2.0]))
                    .collect())
            },
            |p| vec![10.0 * (p[1] - p[0] * p[0]), 1.0 - p[0]],
            &settings,
        )
        .expect("runs");
        assert!(runs <= 7 + 2, "{runs}");
        assert_eq!(result.evaluations, runs);
    }
}
