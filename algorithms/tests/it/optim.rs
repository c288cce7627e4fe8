//! Checks of the bounded L-BFGS against problems whose minimiser is known in closed form.

use acq_algorithms::optim::{minimize_bounded, LbfgsSettings, OptimError, Termination};

const UNBOUNDED: f64 = f64::INFINITY;

fn rosenbrock(x: &[f64], grad: &mut [f64]) -> f64 {
    let (a, b) = (x[0], x[1]);
    grad[0] = -2.0 * (1.0 - a) - 400.0 * a * (b - a * a);
    grad[1] = 200.0 * (b - a * a);
    (1.0 - a).powi(2) + 100.0 * (b - a * a).powi(2)
}

#[test]
fn rosenbrock_unconstrained_reaches_the_minimum_to_1e_6() {
    let mut calls = 0usize;
    let minimum = minimize_bounded(
        |x, g| {
            calls += 1;
            rosenbrock(x, g)
        },
        &[-1.2, 1.0],
        &[-UNBOUNDED; 2],
        &[UNBOUNDED; 2],
        &LbfgsSettings::default(),
    )
    .expect("valid problem");
    assert!(minimum.converged, "{minimum:?}");
    assert!((minimum.x[0] - 1.0).abs() < 1e-6, "{minimum:?}");
    assert!((minimum.x[1] - 1.0).abs() < 1e-6, "{minimum:?}");
    assert!(minimum.value < 1e-12);
    // The reported count is the true number of calls, and L-BFGS needs only a few dozen.
    assert_eq!(minimum.evaluations, calls);
    assert!(minimum.evaluations < 150, "{minimum:?}");
    assert!(minimum.iterations <= minimum.evaluations);
}

/// f = 0.5 x'Ax - b'x with A = [[2,1],[1,2]], b = (6,0): the unconstrained minimiser (4,-2)
/// lies outside x0 <= 2. On the face x0 = 2, df/dx1 = x0 + 2 x1 = 0 gives x1 = -1, and there
/// df/dx0 = 2*2 - 1 - 6 = -3 < 0 pushes against the upper bound: KKT holds, the minimum is
/// (2, -1) with value 0.5*(8 - 4 + 2) - 12 = -9.
#[test]
fn quadratic_with_optimum_on_a_bound_matches_closed_form() {
    let quadratic = |x: &[f64], g: &mut [f64]| {
        g[0] = 2.0 * x[0] + x[1] - 6.0;
        g[1] = x[0] + 2.0 * x[1];
        0.5 * (2.0 * x[0] * x[0] + 2.0 * x[0] * x[1] + 2.0 * x[1] * x[1]) - 6.0 * x[0]
    };
    let minimum = minimize_bounded(
        quadratic,
        &[0.5, 3.0],
        &[0.0, -5.0],
        &[2.0, 5.0],
        &LbfgsSettings::default(),
    )
    .expect("valid problem");
    assert!(minimum.converged, "{minimum:?}");
    assert_eq!(minimum.x[0], 2.0, "the bound is hit exactly, by projection");
    assert!((minimum.x[1] + 1.0).abs() < 1e-7, "{minimum:?}");
    assert!((minimum.value + 9.0).abs() < 1e-12, "{minimum:?}");
    assert_eq!(minimum.termination, Termination::GradientTolerance);
}

/// f = (x+1)^2 + (y-3)^2 + 0.5xy on [0,1]^2 is convex; at the corner (0,1) the gradient is
/// (2 + 0.5, -4): it points out of the box through both active bounds, so (0,1) is the
/// minimum, with value 1 + 4 = 5.
#[test]
fn minimum_at_a_corner_is_found_exactly() {
    let f = |x: &[f64], g: &mut [f64]| {
        g[0] = 2.0 * (x[0] + 1.0) + 0.5 * x[1];
        g[1] = 2.0 * (x[1] - 3.0) + 0.5 * x[0];
        (x[0] + 1.0).powi(2) + (x[1] - 3.0).powi(2) + 0.5 * x[0] * x[1]
    };
    let minimum = minimize_bounded(
        f,
        &[0.7, 0.2],
        &[0.0, 0.0],
        &[1.0, 1.0],
        &LbfgsSettings::default(),
    )
    .expect("valid problem");
    assert!(minimum.converged);
    assert_eq!(minimum.x, vec![0.0, 1.0]);
    assert_eq!(minimum.value, 5.0);
    assert_eq!(minimum.projected_gradient, 0.0);
}

/// A 6-D Rosenbrock chain in a box that cuts off the unconstrained minimiser (all ones). No
/// closed form here, so the check is first-order optimality, recomputed outside the solver:
/// every coordinate is either interior with zero gradient or on a bound with the gradient
/// pointing outwards.
#[test]
fn bounded_rosenbrock_chain_satisfies_kkt() {
    let n = 6;
    let chain = |x: &[f64], g: &mut [f64]| {
        g.iter_mut().for_each(|gi| *gi = 0.0);
        let mut value = 0.0;
        for i in 0..x.len() - 1 {
            let t = x[i + 1] - x[i] * x[i];
            value += (1.0 - x[i]).powi(2) + 100.0 * t * t;
            g[i] += -2.0 * (1.0 - x[i]) - 400.0 * x[i] * t;
            g[i + 1] += 200.0 * t;
        }
        value
    };
    let (lower, upper) = (vec![-2.0; n], vec![0.5; n]);
    let minimum = minimize_bounded(
        chain,
        &vec![0.0; n],
        &lower,
        &upper,
        &LbfgsSettings::default(),
    )
    .expect("valid problem");
    assert!(minimum.converged, "{minimum:?}");
    let mut grad = vec![0.0; n];
    chain(&minimum.x, &mut grad);
    let mut on_bound = 0;
    for i in 0..n {
        assert!(minimum.x[i] >= lower[i] && minimum.x[i] <= upper[i]);
        if minimum.x[i] == upper[i] {
            on_bound += 1;
            assert!(
                grad[i] <= 1e-6,
                "x{i} on the upper bound must be pushed up: {grad:?}"
            );
        } else {
            assert!(
                grad[i].abs() < 1e-5,
                "interior x{i} must be stationary: {grad:?}"
            );
        }
    }
    assert!(
        on_bound >= 1,
        "the bound is active at this minimum: {minimum:?}"
    );
}

/// f = x - ln x is +inf/NaN for x <= 0: a long trial step into that region must be rejected
/// and shortened, not accepted or propagated. The minimum is x = 1.
#[test]
fn non_finite_values_make_the_line_search_back_off() {
    let f = |x: &[f64], g: &mut [f64]| {
        g[0] = 1.0 - 1.0 / x[0];
        x[0] - x[0].ln()
    };
    let minimum = minimize_bounded(
        f,
        &[0.05],
        &[-UNBOUNDED],
        &[UNBOUNDED],
        &LbfgsSettings::default(),
    )
    .expect("valid problem");
    assert!(minimum.converged, "{minimum:?}");
    assert!((minimum.x[0] - 1.0).abs() < 1e-6, "{minimum:?}");
}

#[test]
fn iteration_limit_is_respected_and_reported() {
    let settings = LbfgsSettings {
        max_iterations: 3,
        ..LbfgsSettings::default()
    };
    let minimum = minimize_bounded(
        rosenbrock,
        &[-1.2, 1.0],
        &[-UNBOUNDED; 2],
        &[UNBOUNDED; 2],
        &settings,
    )
    .expect("valid problem");
    assert_eq!(minimum.iterations, 3);
    assert!(!minimum.converged);
    assert_eq!(minimum.termination, Termination::MaxIterations);
}

#[test]
fn start_outside_the_box_is_projected() {
    let minimum = minimize_bounded(
        |x, g| {
            g[0] = 2.0 * (x[0] - 0.5);
            (x[0] - 0.5).powi(2)
        },
        &[40.0],
        &[0.0],
        &[1.0],
        &LbfgsSettings::default(),
    )
    .expect("valid problem");
    assert!((minimum.x[0] - 0.5).abs() < 1e-8);
}

#[test]
fn invalid_problems_are_errors_not_panics() {
    let settings = LbfgsSettings::default();
    let quad = |x: &[f64], g: &mut [f64]| {
        g[0] = 2.0 * x[0];
        x[0] * x[0]
    };
    assert_eq!(
        minimize_bounded(quad, &[], &[], &[], &settings),
        Err(OptimError::Empty)
    );
    assert!(matches!(
        minimize_bounded(quad, &[1.0], &[0.0, 0.0], &[1.0], &settings),
        Err(OptimError::DimensionMismatch { .. })
    ));
    assert!(matches!(
        minimize_bounded(quad, &[1.0], &[2.0], &[1.0], &settings),
        Err(OptimError::InvalidBounds { index: 0, .. })
    ));
    assert!(matches!(
        minimize_bounded(quad, &[1.0], &[f64::NAN], &[1.0], &settings),
        Err(OptimError::InvalidBounds { .. })
    ));
    assert!(matches!(
        minimize_bounded(quad, &[f64::NAN], &[0.0], &[1.0], &settings),
        Err(OptimError::NonFiniteStart { .. })
    ));
    assert!(matches!(
        minimize_bounded(|_, _| f64::NAN, &[0.5], &[0.0], &[1.0], &settings),
        Err(OptimError::NonFiniteObjective { .. })
    ));
    let no_memory = LbfgsSettings {
        memory: 0,
        ..settings
    };
    assert!(matches!(
        minimize_bounded(quad, &[0.5], &[0.0], &[1.0], &no_memory),
        Err(OptimError::InvalidSettings(_))
    ));
    // The messages tell the caller what to do.
    let message = OptimError::Empty.to_string();
    assert!(message.contains("give at least one variable"));
}
