//! Curve MAPE: the loss of the published tensile/GTN calibration,
//!
//! ```text
//! MAPE = 100 / n * sum |(F_test(u) - F_sim(u)) / F_test(u)|   [%]
//! ```
//!
//! over a common displacement grid, with every choice the publication left
//! open made explicit:
//!
//! 1. **Points.** Each curve is `(displacement_mm, force_kn)` in test order.
//!    Displacement must not decrease (an error names the curve and the
//!    index). A run of equal displacements keeps only its **last** point
//!    (the published code kept the first; the last is the latest reading
//!    at that displacement). Each curve needs 2 distinct displacements.
//! 2. **Interpolation.** Both curves through the not-a-knot cubic spline
//!    of [`crate::interp`] (scipy's `interp1d(kind='cubic')` /
//!    `CubicSpline`); fewer than 4 points give a parabola or a line.
//! 3. **Step.** The smallest positive displacement increment found in
//!    either curve, not rounded (the published code rounded it to 6
//!    decimals). A grid of more than [`MAX_GRID_POINTS`] points is an
//!    error rather than a long wait.
//! 4. **Grid.** From the first test point whose force is not tiny (the
//!    origin row `0, 0` would divide by zero; the published code skipped
//!    the first rows) in steps of the step up to the test's last
//!    displacement, that end included when it falls on the grid (within
//!    1e-9 of a step; the published `np.arange` left it out).
//! 5. **Tiny forces.** A grid point where the interpolated test force is
//!    at most [`TINY_FORCE_FRACTION`] (1e-6) of the test's largest absolute
//!    force is left out of the mean and counted in `excluded_points`.
//! 6. **Simulation shorter than the test.** Past the simulation's last
//!    displacement (by more than 1e-9 of a step) its force is 0, as the
//!    published code padded it: each such point adds 100 % to the sum
//!    (`padded_points`). With
//!    [`CurveMapeOptions::truncate_at_simulation_end`] the grid ends at the
//!    simulation's end instead. A simulation longer than the test is
//!    compared over the test's range only.
//! 7. **Simulation starting late.** A simulation whose first displacement
//!    lies after the grid's start is an error (its spline would
//!    extrapolate); FE results normally start at 0.
//!
//! 8. **Split (the published per-part variant).** With
//!    [`CurveMapeOptions::split_at_mm`] (normally the test's UTS
//!    displacement) the same terms are also averaged separately over the
//!    grid points at or before the split and after it ([`SplitMape`]); the
//!    overall MAPE is unchanged.
//!
//! Nothing here panics: empty, non-finite and decreasing input are
//! [`CurveLossError`]s.

use std::fmt;

use crate::interp::{CubicSpline, InterpError};

/// Test forces at most this fraction of the test's largest absolute force
/// are left out of the mean.
pub const TINY_FORCE_FRACTION: f64 = 1e-6;
/// Largest grid the loss computes.
pub const MAX_GRID_POINTS: usize = 1_000_000;
/// Tolerance, in steps, for "on the grid" and "past the simulation's end".
const GRID_TOLERANCE_STEPS: f64 = 1e-9;

/// How the loss treats a simulation that ends before the test does.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct CurveMapeOptions {
    /// `false` (default, as published): force 0 past the simulation's end,
    /// 100 % error per grid point there. `true`: the grid ends at the
    /// simulation's end.
    pub truncate_at_simulation_end: bool,
    /// Also report the MAPE before and after this displacement (mm).
    pub split_at_mm: Option<f64>,
}

/// The MAPE on either side of a split displacement.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct SplitMape {
    pub split_at_mm: f64,
    /// Over the grid points at or before the split (NaN if there are none).
    pub before_percent: f64,
    pub before_points: usize,
    /// Over the grid points after the split (NaN if there are none).
    pub after_percent: f64,
    pub after_points: usize,
}

/// The loss and how it was computed.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct CurveMape {
    /// Mean absolute percentage error over the grid points in the mean.
    pub mape_percent: f64,
    /// Points on the common displacement grid.
    pub grid_points: usize,
    /// Grid points left out because the test force there is tiny; the mean
    /// is over `grid_points - excluded_points`.
    pub excluded_points: usize,
    /// Grid step: the smallest displacement increment of either curve.
    pub step_mm: f64,
    /// First and last grid displacement.
    pub grid_start_mm: f64,
    pub grid_end_mm: f64,
    /// Grid points in the mean past the simulation's end (force 0 there).
    pub padded_points: usize,
    /// The per-part MAPE, when a split was asked for.
    pub split: Option<SplitMape>,
}

/// Which curve a problem is in.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CurveName {
    Test,
    Simulation,
}

impl fmt::Display for CurveName {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            CurveName::Test => "test",
            CurveName::Simulation => "simulation",
        })
    }
}

/// Why a curve MAPE cannot be computed.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum CurveLossError {
    #[error("the {curve} curve has {points} distinct displacement(s); at least 2 are needed")]
    TooFewPoints { curve: CurveName, points: usize },
    #[error("the {curve} curve's point {index} is not finite (displacement {displacement_mm}, force {force_kn})")]
    NotFinite {
        curve: CurveName,
        index: usize,
        displacement_mm: f64,
        force_kn: f64,
    },
    #[error("the {curve} curve's displacement decreases at point {index}: {displacement_mm} mm after {previous_mm} mm")]
    Decreasing {
        curve: CurveName,
        index: usize,
        previous_mm: f64,
        displacement_mm: f64,
    },
    #[error("the test curve carries no force (every force is 0)")]
    NoTestForce,
    #[error("the simulation starts at {simulation_start_mm} mm, after the grid's start at {grid_start_mm} mm (the test's first loaded point); it would have to be extrapolated")]
    SimulationStartsLate {
        simulation_start_mm: f64,
        grid_start_mm: f64,
    },
    #[error("a step of {step_mm} mm over {span_mm} mm would make a grid of more than {MAX_GRID_POINTS} points; are two displacements nearly equal?")]
    GridTooLarge { step_mm: f64, span_mm: f64 },
    #[error("no grid point to compare: {0}")]
    NothingToCompare(String),
    #[error("the {curve} curve cannot be interpolated: {source}")]
    Spline {
        curve: CurveName,
        #[source]
        source: InterpError,
    },
}

/// The curve MAPE of `simulation` against `test`, both as
/// `(displacement_mm, force_kn)` points; see the module documentation for
/// the exact definition.
pub fn curve_mape(
    test: &[(f64, f64)],
    simulation: &[(f64, f64)],
    options: CurveMapeOptions,
) -> Result<CurveMape, CurveLossError> {
    TestCurve::new(test)?.mape(simulation, options)
}

/// The curve MAPE, and the signed error (%, simulation above the test
/// positive) averaged over each of `parts` consecutive runs of the grid
/// points in the mean, of as equal a count as the grid allows (fewer
/// parts when there are fewer points).
///
/// The parts say *where* along the curve and in which direction the
/// simulation misses, which a single MAPE hides: a local search can fit
/// a linear model to them (a Gauss-Newton step).
pub fn curve_errors_by_part(
    test: &[(f64, f64)],
    simulation: &[(f64, f64)],
    options: CurveMapeOptions,
    parts: usize,
) -> Result<(CurveMape, Vec<f64>), CurveLossError> {
    TestCurve::new(test)?.errors_by_part(simulation, options, parts)
}

/// A test curve checked and interpolated once, for the many simulations a
/// calibration or a posterior compares with it: what the test alone
/// decides (its points, its spline) is not computed again per run. The
/// free functions above build one per call.
#[derive(Clone, Debug)]
pub struct TestCurve {
    prepared: Prepared,
    spline: CubicSpline,
    /// Its largest absolute force, kN.
    max_force: f64,
    /// Its own grid's step (its closest displacements), mm, and `(x,
    /// force)` at each of that grid's points to its last displacement: the
    /// grid of every simulation sampled no finer than the test, so its
    /// forces are interpolated once, not at every comparison.
    own_step_mm: f64,
    own_grid: Vec<(f64, f64)>,
}

impl TestCurve {
    pub fn new(points: &[(f64, f64)]) -> Result<Self, CurveLossError> {
        let prepared = prepare(points, CurveName::Test)?;
        let spline = prepared.spline(CurveName::Test)?;
        let max_force = prepared.force.iter().fold(0.0f64, |m, f| m.max(f.abs()));
        let mut test_curve = TestCurve {
            prepared,
            spline,
            max_force,
            own_step_mm: f64::NAN,
            own_grid: Vec::new(),
        };
        // Compared with itself, the test makes its own grid (or none, and
        // every comparison fails as it would).
        let own = test_curve.points();
        let mut own_grid = Vec::new();
        let options = CurveMapeOptions::default();
        if let Ok(mape) = compare_on_grid(&test_curve, &own, options, |_, _| {}) {
            let mut piece = 0;
            own_grid = (0..mape.grid_points)
                .map(|i| {
                    let x = grid_x(mape.grid_start_mm, i, mape.step_mm, mape.grid_end_mm);
                    (x, test_curve.spline.eval_walking(x, &mut piece))
                })
                .collect();
            test_curve.own_step_mm = mape.step_mm;
        }
        test_curve.own_grid = own_grid;
        Ok(test_curve)
    }

    /// [`curve_mape`] of `simulation` against this test.
    pub fn mape(
        &self,
        simulation: &[(f64, f64)],
        options: CurveMapeOptions,
    ) -> Result<CurveMape, CurveLossError> {
        compare_on_grid(self, simulation, options, |_, _| {})
    }

    /// [`curve_errors_by_part`] of `simulation` against this test.
    pub fn errors_by_part(
        &self,
        simulation: &[(f64, f64)],
        options: CurveMapeOptions,
        parts: usize,
    ) -> Result<(CurveMape, Vec<f64>), CurveLossError> {
        let mut signed_pct = Vec::new();
        let mape = compare_on_grid(self, simulation, options, |_, error| {
            signed_pct.push(100.0 * error)
        })?;
        let parts = parts.min(signed_pct.len()).max(1);
        let means = (0..parts)
            .map(|part| {
                let run = &signed_pct
                    [part * signed_pct.len() / parts..(part + 1) * signed_pct.len() / parts];
                run.iter().sum::<f64>() / run.len() as f64
            })
            .collect();
        Ok((mape, means))
    }

    /// Its force at point `i`, `x`, of a grid `step_mm` apart: as kept
    /// where that is its own grid's point (a point the simulation's end
    /// cuts short is not), else interpolated, the spline's piece walked
    /// on from `*piece`.
    fn force_on_grid(&self, i: usize, x: f64, step_mm: f64, piece: &mut usize) -> f64 {
        match self.own_grid.get(i) {
            Some(&(own_x, force)) if step_mm == self.own_step_mm && own_x == x => force,
            _ => self.spline.eval_walking(x, piece),
        }
    }

    /// How many of `parts` the test's own grid fills: `parts`, or its
    /// compared points when there are fewer. A simulation sampled more
    /// finely than the test would make a finer grid and so more parts;
    /// asking [`TestCurve::errors_by_part`] for this many keeps its parts
    /// those the test itself can tell apart ([`test_scatter_by_part`]).
    pub fn parts(&self, options: CurveMapeOptions, parts: usize) -> usize {
        let mut compared = 0usize;
        let own = self.points();
        match compare_on_grid(self, &own, options, |_, _| compared += 1) {
            Ok(_) => parts.min(compared).max(1),
            Err(_) => parts.max(1),
        }
    }

    /// Its points as checked (runs of equal displacement reduced to their last).
    fn points(&self) -> Vec<(f64, f64)> {
        self.prepared
            .displacement
            .iter()
            .copied()
            .zip(self.prepared.force.iter().copied())
            .collect()
    }
}

/// How precisely the test curve itself gives the mean of each of the
/// `parts` of [`curve_errors_by_part`] (same grid, same parts), %: the
/// test's noise relative to the part's mean force, over the square root
/// of its points there.
///
/// The noise is a force transducer's: the same in kN along the curve (so
/// a part at a small force is less precise relative to it; each point
/// counts by its own force, as in the part's mean error), estimated
/// once from the second differences of the test's forces (a smooth
/// curve's are nearly constant within a part, white noise's have a
/// variance of 6 sd^2), pooled over the parts. A part's own few second
/// differences would weigh it by chance. A curve too short for a part to
/// hold three points (twelve points in twenty parts) is read whole
/// instead ([`short_curve_noise`]). White noise gives the standard
/// error of the part's mean; correlated noise and model error scale it by
/// a factor of their own, which a posterior estimates.
pub fn test_scatter_by_part(
    test: &[(f64, f64)],
    options: CurveMapeOptions,
    parts: usize,
) -> Result<Vec<f64>, CurveLossError> {
    let test_curve = TestCurve::new(test)?;
    let mut grid = Vec::new();
    compare_on_grid(&test_curve, &test_curve.points(), options, |x, _| {
        grid.push(x)
    })?;
    let measured = &test_curve.prepared;
    let parts = parts.min(grid.len()).max(1);
    // A part's measured points: those from its first to its last grid
    // point. A part of one grid point can fall between two measured points
    // when the step, the smallest increment, comes out a rounding below
    // their spacing (0.3 (i + 1) in floating point) and hold none: it then
    // takes those from its start to the next part's, so that every
    // measured point counts somewhere.
    let starts: Vec<f64> = (0..parts)
        .map(|part| grid[part * grid.len() / parts])
        .collect();
    let step = grid
        .windows(2)
        .map(|w| w[1] - w[0])
        .fold(f64::INFINITY, f64::min);
    let tolerance = if step.is_finite() {
        GRID_TOLERANCE_STEPS * step
    } else {
        0.0
    };
    let points = || measured.displacement.iter().zip(&measured.force);
    let forces_by_part: Vec<Vec<f64>> = (0..parts)
        .map(|part| {
            let run = &grid[part * grid.len() / parts..(part + 1) * grid.len() / parts];
            let (low, high) = (run[0], run[run.len() - 1]);
            let inside: Vec<f64> = points()
                .filter(|(x, _)| (low..=high).contains(*x))
                .map(|(_, f)| *f)
                .collect();
            if !inside.is_empty() {
                return inside;
            }
            let next = starts
                .get(part + 1)
                .map_or(f64::INFINITY, |s| s - tolerance);
            points()
                .filter(|(x, _)| (low - tolerance..next).contains(*x))
                .map(|(_, f)| *f)
                .collect()
        })
        .collect();
    let mut squares = 0.0;
    let mut degrees = 0usize;
    let per_part: Vec<(f64, usize)> = forces_by_part
        .into_iter()
        .enumerate()
        .map(|(part, inside)| {
            // A part between two measured points (a test sampled unevenly,
            // its grid as fine as its closest points) is as precise as
            // the force interpolated at its start.
            let inside = if inside.is_empty() {
                vec![test_curve.spline.eval(starts[part])]
            } else {
                inside
            };
            // The part's mean relative error weighs each point by 1 / force:
            // white noise of sd s gives it an sd of s sqrt(mean(1 / f^2)) /
            // sqrt(n), which at the foot of a rising curve is far above
            // s / mean(f) / sqrt(n).
            let inverse_square = inside
                .iter()
                .filter(|f| f.abs() > 0.0)
                .map(|f| f.powi(-2))
                .sum::<f64>()
                / inside.len().max(1) as f64;
            let level = inverse_square.sqrt().recip();
            let second: Vec<f64> = inside
                .windows(3)
                .map(|w| w[2] - 2.0 * w[1] + w[0])
                .collect();
            if second.len() >= 2 {
                let mean = second.iter().sum::<f64>() / second.len() as f64;
                squares += second.iter().map(|d| (d - mean).powi(2)).sum::<f64>();
                degrees += second.len() - 1;
            }
            (level, inside.len().max(1))
        })
        .collect();
    let noise = if degrees > 0 {
        (squares / degrees as f64 / 6.0).sqrt()
    } else {
        short_curve_noise(&[&measured.force]).unwrap_or(0.0)
    };
    // A noiseless test (a simulated one): a floor of 1e-9 of the force
    // keeps the weights finite.
    let largest = measured.force.iter().fold(0.0f64, |m, f| m.max(f.abs()));
    let noise = noise.max(1e-9 * largest);
    Ok(per_part
        .into_iter()
        .map(|(level, points)| 100.0 * noise / level.max(noise) / (points as f64).sqrt())
        .collect())
}

/// The white noise's standard deviation in a short curve's values (each
/// of `axes`, pooled), from the second differences of consecutive
/// points, whose mean is removed over runs of three along the curve (the
/// curve's own bend changes little within three steps). `None` when
/// there are fewer than five points, too few to tell noise from shape:
/// the caller's floor then stands.
///
/// Neighbouring second differences share noise (white noise of sd s
/// gives each a variance of 6 s^2, and a run of n of them a sum of
/// variance 4 s^2), so a run's squares about its mean expect
/// (6 n - 4 / n) s^2, which is what they are divided by: unbiased for
/// white noise, where dividing by 6 (n - 1) would read 18 % high.
///
/// The parts' own second differences serve a curve of many points
/// better, their curvature removed part by part; this reads one whose
/// parts hold fewer than three points each, which would otherwise give
/// no estimate at all, and a measured curve taken as exact (a posterior
/// then finds every draw but the exact fit impossible and cannot move).
pub fn short_curve_noise(axes: &[&[f64]]) -> Option<f64> {
    let (mut squares, mut expected) = (0.0, 0.0);
    for values in axes {
        let second: Vec<f64> = values
            .windows(3)
            .map(|w| w[2] - 2.0 * w[1] + w[0])
            .collect();
        let runs = second.len() / 3;
        for run in 0..runs {
            // The last run takes the remainder.
            let end = if run + 1 == runs {
                second.len()
            } else {
                3 * (run + 1)
            };
            let block = &second[3 * run..end];
            let n = block.len() as f64;
            let mean = block.iter().sum::<f64>() / n;
            squares += block.iter().map(|d| (d - mean).powi(2)).sum::<f64>();
            expected += 6.0 * n - 4.0 / n;
        }
    }
    (expected > 0.0).then(|| (squares / expected).sqrt())
}

/// The curve MAPE, and the signed error (%, simulation above the test
/// positive) at each compared grid point, as `(x, error)`: where along
/// the curve the simulation misses, for a plot.
pub fn curve_errors_along(
    test: &[(f64, f64)],
    simulation: &[(f64, f64)],
    options: CurveMapeOptions,
) -> Result<(CurveMape, Vec<(f64, f64)>), CurveLossError> {
    let mut along = Vec::new();
    let mape = compare_on_grid(&TestCurve::new(test)?, simulation, options, |x, error| {
        along.push((x, 100.0 * error))
    })?;
    Ok((mape, along))
}

/// The grid's point `i`: `step_mm` apart from `start`, the last at `end`.
fn grid_x(start: f64, i: usize, step_mm: f64, end: f64) -> f64 {
    (start + i as f64 * step_mm).min(end)
}

/// The loop all of the above share: `signed_error` sees each compared
/// grid point's `x` and `(simulated - test) / test`, in grid order.
fn compare_on_grid(
    test_curve: &TestCurve,
    simulation: &[(f64, f64)],
    options: CurveMapeOptions,
    mut signed_error: impl FnMut(f64, f64),
) -> Result<CurveMape, CurveLossError> {
    let test = &test_curve.prepared;
    let simulation = prepare(simulation, CurveName::Simulation)?;
    let step_mm = test
        .displacement
        .windows(2)
        .chain(simulation.displacement.windows(2))
        .map(|w| w[1] - w[0])
        .fold(f64::INFINITY, f64::min);

    let max_force = test_curve.max_force;
    if max_force == 0.0 {
        return Err(CurveLossError::NoTestForce);
    }
    let tiny = TINY_FORCE_FRACTION * max_force;
    let first_loaded = test.force.iter().position(|f| f.abs() > tiny).unwrap_or(0);
    let start = test.displacement[first_loaded];
    let simulation_start = simulation.displacement[0];
    let simulation_end = simulation.displacement[simulation.displacement.len() - 1];
    let mut end = test.displacement[test.displacement.len() - 1];
    if options.truncate_at_simulation_end {
        end = end.min(simulation_end);
    }
    if simulation_start > start {
        return Err(CurveLossError::SimulationStartsLate {
            simulation_start_mm: simulation_start,
            grid_start_mm: start,
        });
    }
    if end < start {
        return Err(CurveLossError::NothingToCompare(format!(
            "the simulation ends at {simulation_end} mm, before the test's first loaded point at {start} mm"
        )));
    }
    let span = end - start;
    let intervals = span / step_mm + GRID_TOLERANCE_STEPS;
    if !intervals.is_finite() || intervals >= MAX_GRID_POINTS as f64 {
        return Err(CurveLossError::GridTooLarge {
            step_mm,
            span_mm: span,
        });
    }
    let grid_points = intervals.floor() as usize + 1;

    let simulation_spline = simulation.spline(CurveName::Simulation)?;
    let past_simulation = simulation_end + GRID_TOLERANCE_STEPS * step_mm;
    let (mut test_piece, mut simulation_piece) = (0, 0);
    let mut sum = 0.0;
    // (sum, points) at or before the split.
    let mut before = (0.0, 0usize);
    let mut excluded_points = 0;
    let mut padded_points = 0;
    let mut last = start;
    for i in 0..grid_points {
        let x = grid_x(start, i, step_mm, end);
        last = x;
        let test_force = test_curve.force_on_grid(i, x, step_mm, &mut test_piece);
        if test_force.is_nan() || test_force.abs() <= tiny {
            excluded_points += 1;
            continue;
        }
        let simulated_force = if x > past_simulation {
            padded_points += 1;
            0.0
        } else {
            simulation_spline.eval_walking(x.min(simulation_end), &mut simulation_piece)
        };
        let signed = (simulated_force - test_force) / test_force;
        signed_error(x, signed);
        let term = signed.abs();
        sum += term;
        if options.split_at_mm.is_some_and(|split| x <= split) {
            before.0 += term;
            before.1 += 1;
        }
    }
    let compared = grid_points - excluded_points;
    if compared == 0 {
        return Err(CurveLossError::NothingToCompare(format!(
            "the test force is tiny at all {grid_points} grid points"
        )));
    }
    let split = options.split_at_mm.map(|split_at_mm| {
        let after_points = compared - before.1;
        let mean = |total: f64, points: usize| {
            if points == 0 {
                f64::NAN
            } else {
                100.0 * total / points as f64
            }
        };
        SplitMape {
            split_at_mm,
            before_percent: mean(before.0, before.1),
            before_points: before.1,
            after_percent: mean(sum - before.0, after_points),
            after_points,
        }
    });
    Ok(CurveMape {
        mape_percent: 100.0 * sum / compared as f64,
        split,
        grid_points,
        excluded_points,
        step_mm,
        grid_start_mm: start,
        grid_end_mm: last,
        padded_points,
    })
}

/// A checked curve with runs of equal displacement reduced to their last
/// point.
#[derive(Clone, Debug)]
struct Prepared {
    displacement: Vec<f64>,
    force: Vec<f64>,
}

impl Prepared {
    fn spline(&self, curve: CurveName) -> Result<CubicSpline, CurveLossError> {
        CubicSpline::new(&self.displacement, &self.force)
            .map_err(|source| CurveLossError::Spline { curve, source })
    }
}

fn prepare(points: &[(f64, f64)], curve: CurveName) -> Result<Prepared, CurveLossError> {
    let mut displacement: Vec<f64> = Vec::with_capacity(points.len());
    let mut force: Vec<f64> = Vec::with_capacity(points.len());
    for (index, &(u, f)) in points.iter().enumerate() {
        if !u.is_finite() || !f.is_finite() {
            return Err(CurveLossError::NotFinite {
                curve,
                index,
                displacement_mm: u,
                force_kn: f,
            });
        }
        match displacement.last() {
            Some(&previous) if u < previous => {
                return Err(CurveLossError::Decreasing {
                    curve,
                    index,
                    previous_mm: previous,
                    displacement_mm: u,
                })
            }
            Some(&previous) if u == previous => {
                if let Some(last) = force.last_mut() {
                    *last = f;
                }
            }
            _ => {
                displacement.push(u);
                force.push(f);
            }
        }
    }
    if displacement.len() < 2 {
        return Err(CurveLossError::TooFewPoints {
            curve,
            points: displacement.len(),
        });
    }
    Ok(Prepared {
        displacement,
        force,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// The test's forces kept on its own grid change no comparison in
    /// its last bit: simulations sampled as the test is, more coarsely,
    /// more finely, ending early (the grid's last point cut short), and
    /// unevenly, each against the same test with nothing kept.
    #[test]
    fn a_test_s_forces_kept_on_its_grid_give_every_comparison_bit_for_bit() {
        let uneven: Vec<(f64, f64)> = test_curve()
            .into_iter()
            .map(|(u, f)| (u * (1.0 + 0.03 * (7.0 * u).sin()), f))
            .collect();
        for test in [test_curve(), uneven] {
            let kept = TestCurve::new(&test).unwrap();
            assert!(kept.own_grid.len() > 10, "{}", kept.own_grid.len());
            let mut computed = kept.clone();
            computed.own_grid.clear();
            let simulation = |step: f64, end: f64| -> Vec<(f64, f64)> {
                let steps = (end / step).round() as usize;
                (0..=steps)
                    .map(|i| {
                        let u = i as f64 * step;
                        (u, 5.1 * (1.0 - (-2.9 * u).exp()) + 0.35 * u)
                    })
                    .collect()
            };
            for (step, end) in [
                (0.1, 2.0),
                (0.2, 2.0),
                (0.05, 2.0),
                (0.1, 1.37),
                (0.013, 2.5),
            ] {
                for truncate in [false, true] {
                    let options = CurveMapeOptions {
                        truncate_at_simulation_end: truncate,
                        ..CurveMapeOptions::default()
                    };
                    let sim = simulation(step, end);
                    let (a, parts_a) = kept.errors_by_part(&sim, options, 20).unwrap();
                    let (b, parts_b) = computed.errors_by_part(&sim, options, 20).unwrap();
                    assert_eq!(a.mape_percent.to_bits(), b.mape_percent.to_bits());
                    assert_eq!(a.grid_points, b.grid_points);
                    if step >= 0.1 {
                        // Sampled no finer than the test: its own grid.
                        assert_eq!(a.step_mm.to_bits(), kept.own_step_mm.to_bits());
                    }
                    let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                    assert_eq!(bits(&parts_a), bits(&parts_b), "step {step}, end {end}");
                }
            }
        }
    }

    /// A hardening curve from the origin, points 0.1 mm apart.
    fn test_curve() -> Vec<(f64, f64)> {
        (0..=20)
            .map(|i| {
                let u = 0.1 * i as f64;
                (u, 5.0 * (1.0 - (-3.0 * u).exp()) + 0.4 * u)
            })
            .collect()
    }

    #[test]
    fn identical_curves_give_zero() {
        let curve = test_curve();
        let loss = curve_mape(&curve, &curve, CurveMapeOptions::default()).unwrap();
        assert_eq!(loss.mape_percent, 0.0);
        assert_eq!(loss.padded_points, 0);
        assert_eq!(loss.excluded_points, 0);
        // From the first loaded point (0.1) to 2.0 in steps of 0.1, end included.
        assert_eq!(loss.grid_points, 20);
        assert!((loss.step_mm - 0.1).abs() < 1e-12);
        assert_eq!(loss.grid_start_mm, 0.1);
        assert!((loss.grid_end_mm - 2.0).abs() < 1e-12);
    }

    #[test]
    fn a_simulation_at_ninety_percent_is_ten_percent_off() {
        let curve = test_curve();
        let simulation: Vec<(f64, f64)> = curve.iter().map(|&(u, f)| (u, 0.9 * f)).collect();
        let loss = curve_mape(&curve, &simulation, CurveMapeOptions::default()).unwrap();
        assert!((loss.mape_percent - 10.0).abs() < 1e-12, "{loss:?}");
    }

    #[test]
    fn a_simulation_that_stops_halfway_is_padded_with_zero_force() {
        // Test: F = u on 0..10 mm (grid 1..=10, 10 points); the simulation
        // matches it up to 5 mm and stops: grid points 6..=10 have force 0,
        // 100 % each, so MAPE = (5 * 0 + 5 * 100) / 10 = 50 %.
        let test: Vec<(f64, f64)> = (0..=10).map(|i| (i as f64, i as f64)).collect();
        let simulation = &test[..=5];
        let loss = curve_mape(&test, simulation, CurveMapeOptions::default()).unwrap();
        assert_eq!(loss.grid_points, 10);
        assert_eq!(loss.padded_points, 5);
        assert!((loss.mape_percent - 50.0).abs() < 1e-12, "{loss:?}");

        let truncated = curve_mape(
            &test,
            simulation,
            CurveMapeOptions {
                truncate_at_simulation_end: true,
                ..Default::default()
            },
        )
        .unwrap();
        assert_eq!(truncated.grid_points, 5);
        assert_eq!(truncated.padded_points, 0);
        assert_eq!(truncated.grid_end_mm, 5.0);
        assert!(truncated.mape_percent.abs() < 1e-12);
    }

    /// `(displacement_mm, force_kn)`.
    type Point = (f64, f64);

    /// Test F = u at u = 1..10, simulation F = u + 0.1 u^2 at u = 0..10:
    /// the not-a-knot spline reproduces polynomials up to cubics exactly,
    /// so the error at u is +10 u %.
    fn line_and_parabola_above() -> (Vec<Point>, Vec<Point>) {
        let test = (1..=10).map(|i| (i as f64, i as f64)).collect();
        let simulation = (0..=10)
            .map(|i| {
                let u = i as f64;
                (u, u + 0.1 * u * u)
            })
            .collect();
        (test, simulation)
    }

    #[test]
    fn the_split_averages_each_side_and_leaves_the_total_alone() {
        let (test, simulation) = line_and_parabola_above();
        let options = CurveMapeOptions {
            split_at_mm: Some(4.0),
            ..Default::default()
        };
        let whole = curve_mape(&test, &test, CurveMapeOptions::default()).unwrap();
        assert!(whole.split.is_none());
        // Grid: u = 1..10 in steps of 1 (the smallest increment).
        let loss = curve_mape(&test, &simulation, options).unwrap();
        let split = loss.split.unwrap();
        assert_eq!((split.before_points, split.after_points), (4, 6));
        // Before: mean of 10, 20, 30, 40; after: of 50..100; all: of 10..100.
        assert!((split.before_percent - 25.0).abs() < 1e-9, "{split:?}");
        assert!((split.after_percent - 75.0).abs() < 1e-9, "{split:?}");
        assert!((loss.mape_percent - 55.0).abs() < 1e-9, "{loss:?}");
    }

    #[test]
    fn the_parts_average_the_signed_errors_in_grid_order() {
        // Error +10 u % at u = 1..10. Two parts: mean of 10..50 and of
        // 60..100; with the simulation below the test, the signs turn.
        let (test, above) = line_and_parabola_above();
        let (mape, parts) =
            curve_errors_by_part(&test, &above, CurveMapeOptions::default(), 2).unwrap();
        assert_eq!(parts.len(), 2);
        assert!((parts[0] - 30.0).abs() < 1e-9, "{parts:?}");
        assert!((parts[1] - 80.0).abs() < 1e-9, "{parts:?}");
        let whole = curve_mape(&test, &above, CurveMapeOptions::default()).unwrap();
        assert_eq!(mape, whole);
        let below: Vec<(f64, f64)> = above.iter().map(|&(u, f)| (u, 2.0 * u - f)).collect();
        let (_, parts) =
            curve_errors_by_part(&test, &below, CurveMapeOptions::default(), 2).unwrap();
        assert!((parts[0] + 30.0).abs() < 1e-9 && (parts[1] + 80.0).abs() < 1e-9);
        // More parts than grid points: one per point.
        let (_, parts) =
            curve_errors_by_part(&test, &above, CurveMapeOptions::default(), 50).unwrap();
        assert_eq!(parts.len(), 10);
        assert!((parts[9] - 100.0).abs() < 1e-9, "{parts:?}");
    }

    #[test]
    fn the_step_is_the_smallest_increment_of_either_curve() {
        // Test increments 0.5 and 0.3; the simulation has one of 0.125.
        let test = [(0.0, 0.0), (0.5, 1.0), (1.0, 2.0), (1.3, 2.6), (2.0, 4.0)];
        let simulation = [(0.0, 0.0), (0.125, 0.25), (1.0, 2.0), (2.5, 5.0)];
        let loss = curve_mape(&test, &simulation, CurveMapeOptions::default()).unwrap();
        assert_eq!(loss.step_mm, 0.125);
        // 0.5 ..= 2.0 in steps of 0.125: 13 points.
        assert_eq!(loss.grid_points, 13);
        assert_eq!(loss.grid_end_mm, 2.0);
        assert!(loss.mape_percent.abs() < 1e-12);
    }

    /// Golden values computed independently with scipy 1.17.1:
    /// python3 -c "
    /// import numpy as np; from scipy.interpolate import CubicSpline as C
    /// tx=[0,0.1,0.25,0.4,0.6,0.75,1.0]; tf=[0,2.0,3.1,3.6,3.8,3.7,3.2]
    /// sx=[0,0.05,0.2,0.35,0.5,0.7,0.8]; sf=[0,1.2,2.9,3.5,3.75,3.65,3.4]
    /// step=min(np.diff(tx).min(),np.diff(sx).min()); n=int(np.floor((tx[-1]-tx[1])/step+1e-9))+1
    /// g=tx[1]+np.arange(n)*step; ft=C(tx,tf)(g); fs=np.where(g>sx[-1]+1e-9*step,0.0,C(sx,sf)(np.minimum(g,sx[-1])))
    /// print(n, repr(100*np.mean(np.abs((ft-fs)/ft))), int((g>sx[-1]+1e-9*step).sum()))"
    /// -> 19 22.32923287656055 4
    /// and truncated (grid 0.1..=0.8, n = 15): 1.6170283103100247.
    #[test]
    fn matches_an_independent_scipy_computation() {
        let test = [
            (0.0, 0.0),
            (0.1, 2.0),
            (0.25, 3.1),
            (0.4, 3.6),
            (0.6, 3.8),
            (0.75, 3.7),
            (1.0, 3.2),
        ];
        let simulation = [
            (0.0, 0.0),
            (0.05, 1.2),
            (0.2, 2.9),
            (0.35, 3.5),
            (0.5, 3.75),
            (0.7, 3.65),
            (0.8, 3.4),
        ];
        let loss = curve_mape(&test, &simulation, CurveMapeOptions::default()).unwrap();
        assert_eq!(loss.grid_points, 19);
        assert_eq!(loss.padded_points, 4);
        assert!(
            (loss.mape_percent - 22.32923287656055).abs() < 1e-10,
            "{loss:?}"
        );
        let truncated = curve_mape(
            &test,
            &simulation,
            CurveMapeOptions {
                truncate_at_simulation_end: true,
                ..Default::default()
            },
        )
        .unwrap();
        assert_eq!(truncated.grid_points, 15);
        assert!((truncated.mape_percent - 1.6170283103100247).abs() < 1e-10);
    }

    #[test]
    fn duplicate_displacements_keep_the_last_point() {
        let test = [(0.0, 0.0), (1.0, 1.0), (2.0, 2.0), (3.0, 3.0)];
        let simulation = [(0.0, 0.0), (1.0, 7.0), (1.0, 1.0), (2.0, 2.0), (3.0, 3.0)];
        let loss = curve_mape(&test, &simulation, CurveMapeOptions::default()).unwrap();
        assert!(loss.mape_percent.abs() < 1e-12);
        assert_eq!(loss.step_mm, 1.0);
    }

    /// A short curve's noise, read whole: none on a parabola (its second
    /// differences are constant), the sd of white noise on a line within
    /// its sampling error, and no estimate from four points.
    #[test]
    fn a_short_curves_noise_is_read_from_the_whole_curve() {
        use rand::SeedableRng;
        use rand_distr::{Distribution, Normal};
        let parabola: Vec<f64> = (0..12).map(|i| 0.5 * f64::from(i).powi(2) + 3.0).collect();
        assert!(short_curve_noise(&[&parabola]).unwrap() < 1e-12);
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(4);
        let noise = Normal::new(0.0, 0.1).unwrap();
        let line: Vec<f64> = (0..3002)
            .map(|i| 2.0 + 0.01 * f64::from(i) + noise.sample(&mut rng))
            .collect();
        // 3000 second differences in 1000 runs: the estimate's relative sd
        // is about 1.5 %, so 5 % is over 3 sds.
        let estimate = short_curve_noise(&[&line]).unwrap();
        assert!((estimate / 0.1 - 1.0).abs() < 0.05, "{estimate}");
        assert_eq!(short_curve_noise(&[&[1.0, 2.0, 3.0, 4.0]]), None);
    }

    /// Twelve or fifteen points in twenty parts: no part holds three, and
    /// the scatter comes from the curve as a whole, not the 1e-9 floor of
    /// a noiseless one. At 0.3 (i + 1) the smallest increment is a
    /// rounding below 0.3, so the grid's points fall just before the
    /// measured ones: each part still reads its own point.
    #[test]
    fn a_short_test_has_a_scatter_of_its_noise_in_every_part() {
        use rand::SeedableRng;
        use rand_distr::{Distribution, Normal};
        for (points, spacing) in [(12, 0.25), (15, 0.3)] {
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(9);
            let noise = Normal::new(0.0, 0.02).unwrap();
            let test: Vec<(f64, f64)> = (0..points)
                .map(|i| {
                    let x = spacing * f64::from(i + 1);
                    (x, 3.0 * (-0.7 * x).exp() + noise.sample(&mut rng))
                })
                .collect();
            let scatter = test_scatter_by_part(&test, CurveMapeOptions::default(), 20).unwrap();
            assert_eq!(scatter.len(), test.len(), "one part per grid point");
            // 0.02 kN on forces of 0.4 to 2.5 kN, one point a part: 0.8 to
            // 5 %. The estimate from so few points is rough: a factor of 3
            // either way.
            for (part, pct) in scatter.iter().enumerate() {
                let expected = 100.0 * 0.02 / test[part].1;
                assert!(
                    (expected / 3.0..=expected * 3.0).contains(pct),
                    "{points} points, part {part}: {pct} % against {expected} %"
                );
            }
        }
    }

    #[test]
    fn bad_curves_are_errors_not_panics() {
        let good = test_curve();
        let options = CurveMapeOptions::default();
        assert!(matches!(
            curve_mape(&[], &good, options),
            Err(CurveLossError::TooFewPoints {
                curve: CurveName::Test,
                points: 0
            })
        ));
        assert!(matches!(
            curve_mape(&good, &[(1.0, 1.0), (1.0, 2.0)], options),
            Err(CurveLossError::TooFewPoints {
                curve: CurveName::Simulation,
                points: 1
            })
        ));
        let mut nan = good.clone();
        nan[3].1 = f64::NAN;
        assert!(matches!(
            curve_mape(&nan, &good, options),
            Err(CurveLossError::NotFinite { index: 3, .. })
        ));
        let mut backwards = good.clone();
        backwards[5].0 = 0.2;
        let error = curve_mape(&backwards, &good, options).unwrap_err();
        assert!(matches!(
            error,
            CurveLossError::Decreasing {
                curve: CurveName::Test,
                index: 5,
                ..
            }
        ));
        assert!(error.to_string().contains("test curve"), "{error}");
        let zero: Vec<(f64, f64)> = good.iter().map(|&(u, _)| (u, 0.0)).collect();
        assert_eq!(
            curve_mape(&zero, &good, options),
            Err(CurveLossError::NoTestForce)
        );
        let late: Vec<(f64, f64)> = good[3..].to_vec();
        assert!(matches!(
            curve_mape(&good, &late, options),
            Err(CurveLossError::SimulationStartsLate { .. })
        ));
        let crowded = [(0.0, 0.0), (1e-9, 1e-9), (1.0, 1.0), (2.0, 2.0)];
        let error = curve_mape(&good, &crowded, options).unwrap_err();
        assert!(matches!(error, CurveLossError::GridTooLarge { .. }));
        assert!(error.to_string().contains("1000000 points"), "{error}");
    }

    fn any_curve() -> impl Strategy<Value = Vec<(f64, f64)>> {
        proptest::collection::vec(
            (
                prop_oneof![
                    4 => 0.0..2.0f64,
                    1 => Just(0.0),
                    1 => Just(f64::NAN),
                    1 => -1.0..0.0f64,
                ],
                prop_oneof![
                    4 => -10.0..10.0f64,
                    1 => Just(0.0),
                    1 => Just(f64::INFINITY),
                ],
            ),
            0..12,
        )
        .prop_map(|steps| {
            let mut u = 0.0;
            steps
                .into_iter()
                .map(|(step, f)| {
                    u += step;
                    (u, f)
                })
                .collect()
        })
    }

    proptest! {
        #[test]
        fn never_panics(test in any_curve(), simulation in any_curve(), truncate in any::<bool>()) {
            let options = CurveMapeOptions {
                truncate_at_simulation_end: truncate,
                split_at_mm: Some(1.0),
            };
            if let Ok(loss) = curve_mape(&test, &simulation, options) {
                prop_assert!(loss.mape_percent >= 0.0);
                prop_assert!(loss.grid_points >= 1 && loss.grid_points <= MAX_GRID_POINTS);
                let split = loss.split.unwrap();
                prop_assert_eq!(
                    split.before_points + split.after_points,
                    loss.grid_points - loss.excluded_points
                );
            }
        }
    }
}
