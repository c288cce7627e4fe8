//! Cubic spline interpolation of measured or simulated curves.
//!
//! [`CubicSpline`] is the interpolant scipy builds with
//! `scipy.interpolate.CubicSpline(x, y)` (default `bc_type='not-a-knot'`),
//! which for four or more points is also what
//! `interp1d(x, y, kind='cubic')` gives: a piecewise cubic with continuous
//! first and second derivatives whose third derivative is also continuous
//! at the second and the second-to-last knot (so the first two and the
//! last two pieces are one cubic each). A cubic polynomial is reproduced
//! exactly.
//!
//! - 4 or more points: the not-a-knot cubic spline. The knot slopes come
//!   from one tridiagonal system, solved in O(n) by Gaussian elimination
//!   with partial pivoting (the not-a-knot end rows are not diagonally
//!   dominant, so plain Thomas elimination is not used).
//! - 3 points: the parabola through them (scipy does the same for
//!   not-a-knot with 3 points).
//! - 2 points: the straight line through them.
//!
//! Evaluation finds the piece by binary search, O(log n), or, along
//! increasing x ([`CubicSpline::eval_walking`]), by walking on from the
//! last piece: a curve compared on a grid finer than its knots. Outside
//! [`CubicSpline::domain`] the end pieces are extended (as scipy does by
//! default); callers that must not extrapolate check the domain first. A
//! non-finite `x` evaluates to NaN. Nothing here panics.

/// Why a spline cannot be built.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum InterpError {
    #[error("a spline needs at least 2 points, got {0}")]
    TooFewPoints(usize),
    #[error("x has {x} values but y has {y}")]
    LengthMismatch { x: usize, y: usize },
    #[error("point {index} is not finite (x = {x}, y = {y})")]
    NotFinite { index: usize, x: f64, y: f64 },
    #[error("x is not strictly increasing at index {index}: x[{index}] = {x} after x[{previous}] = {previous_x}", previous = .index.saturating_sub(1))]
    NotIncreasing {
        index: usize,
        previous_x: f64,
        x: f64,
    },
    /// The slope system is singular or its solution overflowed (x so
    /// extreme that the pieces' lengths under- or overflow).
    #[error(
        "the spline's equations cannot be solved for these points (extreme spacing or values)"
    )]
    Singular,
}

/// A not-a-knot cubic spline (parabola for 3 points, line for 2) through
/// points with strictly increasing x.
#[derive(Clone, Debug, PartialEq)]
pub struct CubicSpline {
    x: Vec<f64>,
    /// Per piece `i` (between `x[i]` and `x[i + 1]`), with `t = x - x[i]`:
    /// `y = ((c[0] t + c[1]) t + c[2]) t + c[3]`.
    coefficients: Vec<[f64; 4]>,
}

impl CubicSpline {
    /// Builds the spline through `(x[i], y[i])`.
    pub fn new(x: &[f64], y: &[f64]) -> Result<Self, InterpError> {
        if x.len() != y.len() {
            return Err(InterpError::LengthMismatch {
                x: x.len(),
                y: y.len(),
            });
        }
        let n = x.len();
        if n < 2 {
            return Err(InterpError::TooFewPoints(n));
        }
        for (index, (&xi, &yi)) in x.iter().zip(y).enumerate() {
            if !xi.is_finite() || !yi.is_finite() {
                return Err(InterpError::NotFinite {
                    index,
                    x: xi,
                    y: yi,
                });
            }
            if index > 0 && xi <= x[index - 1] {
                return Err(InterpError::NotIncreasing {
                    index,
                    previous_x: x[index - 1],
                    x: xi,
                });
            }
        }
        let dx: Vec<f64> = x.windows(2).map(|w| w[1] - w[0]).collect();
        let secant: Vec<f64> = y
            .windows(2)
            .zip(&dx)
            .map(|(w, &h)| (w[1] - w[0]) / h)
            .collect();
        if dx.iter().chain(&secant).any(|v| !v.is_finite()) {
            return Err(InterpError::Singular);
        }
        let slopes = match n {
            2 => vec![secant[0]; 2],
            3 => parabola_slopes(x, &dx, &secant),
            _ => not_a_knot_slopes(x, &dx, &secant)?,
        };
        let coefficients: Vec<[f64; 4]> = (0..n - 1)
            .map(|i| {
                let h = dx[i];
                let t = (slopes[i] + slopes[i + 1] - 2.0 * secant[i]) / h;
                [t / h, (secant[i] - slopes[i]) / h - t, slopes[i], y[i]]
            })
            .collect();
        if coefficients.iter().flatten().any(|c| !c.is_finite()) {
            return Err(InterpError::Singular);
        }
        Ok(CubicSpline {
            x: x.to_vec(),
            coefficients,
        })
    }

    /// First and last knot: where the spline interpolates rather than
    /// extrapolates.
    pub fn domain(&self) -> (f64, f64) {
        (self.x[0], self.x[self.x.len() - 1])
    }

    /// The knots' x.
    pub fn knots(&self) -> &[f64] {
        &self.x
    }

    /// The spline at `x` (end pieces extended outside the domain; NaN for
    /// a non-finite `x`).
    pub fn eval(&self, x: f64) -> f64 {
        if !x.is_finite() {
            return f64::NAN;
        }
        self.eval_in(self.piece_of(x), x)
    }

    /// [`CubicSpline::eval`], its piece found by walking on from `*piece`
    /// (then left there for the next call): along increasing x, a step or
    /// none instead of a search. The same value as `eval` for any `x` and
    /// any `*piece`; `0` starts a walk.
    pub fn eval_walking(&self, x: f64, piece: &mut usize) -> f64 {
        if !x.is_finite() {
            return f64::NAN;
        }
        let pieces = self.coefficients.len();
        let mut i = (*piece).min(pieces - 1);
        if i > 0 && self.x[i] > x {
            // x went back: searched for.
            i = self.piece_of(x);
        } else {
            while i + 1 < pieces && self.x[i + 1] <= x {
                i += 1;
            }
        }
        *piece = i;
        self.eval_in(i, x)
    }

    /// The piece `x` falls in: the last whose start is at or before `x`,
    /// the end pieces extended outward.
    fn piece_of(&self, x: f64) -> usize {
        self.x
            .partition_point(|&knot| knot <= x)
            .saturating_sub(1)
            .min(self.coefficients.len() - 1)
    }

    fn eval_in(&self, i: usize, x: f64) -> f64 {
        let t = x - self.x[i];
        let [c0, c1, c2, c3] = self.coefficients[i];
        ((c0 * t + c1) * t + c2) * t + c3
    }

    /// [`CubicSpline::eval`] at every value of `xs`.
    pub fn eval_many(&self, xs: &[f64]) -> Vec<f64> {
        xs.iter().map(|&x| self.eval(x)).collect()
    }
}

/// Slopes at the 3 knots of the parabola through them.
fn parabola_slopes(x: &[f64], dx: &[f64], secant: &[f64]) -> Vec<f64> {
    // Second divided difference = the parabola's leading coefficient.
    let a = (secant[1] - secant[0]) / (x[2] - x[0]);
    vec![
        secant[0] - a * dx[0],
        secant[0] + a * dx[0],
        secant[1] + a * dx[1],
    ]
}

/// Knot slopes of the not-a-knot spline (n >= 4), as scipy sets them up:
/// interior rows from continuity of the second derivative, end rows from
/// continuity of the third derivative at the second and second-to-last
/// knots. The system is tridiagonal.
fn not_a_knot_slopes(x: &[f64], dx: &[f64], secant: &[f64]) -> Result<Vec<f64>, InterpError> {
    let n = x.len();
    let mut lower = vec![0.0; n - 1];
    let mut diagonal = vec![0.0; n];
    let mut upper = vec![0.0; n - 1];
    let mut rhs = vec![0.0; n];
    for i in 1..n - 1 {
        lower[i - 1] = dx[i];
        diagonal[i] = 2.0 * (dx[i - 1] + dx[i]);
        upper[i] = dx[i - 1];
        rhs[i] = 3.0 * (dx[i] * secant[i - 1] + dx[i - 1] * secant[i]);
    }
    let d = x[2] - x[0];
    diagonal[0] = dx[1];
    upper[0] = d;
    rhs[0] = ((dx[0] + 2.0 * d) * dx[1] * secant[0] + dx[0] * dx[0] * secant[1]) / d;
    let d = x[n - 1] - x[n - 3];
    diagonal[n - 1] = dx[n - 3];
    lower[n - 2] = d;
    rhs[n - 1] = (dx[n - 2] * dx[n - 2] * secant[n - 3]
        + (2.0 * d + dx[n - 2]) * dx[n - 3] * secant[n - 2])
        / d;
    solve_tridiagonal(lower, diagonal, upper, rhs)
}

/// Solves a tridiagonal system (LAPACK `dgtsv`: LU with partial pivoting,
/// which fills one extra superdiagonal, kept in `lower`).
fn solve_tridiagonal(
    mut lower: Vec<f64>,
    mut diagonal: Vec<f64>,
    mut upper: Vec<f64>,
    mut rhs: Vec<f64>,
) -> Result<Vec<f64>, InterpError> {
    let n = diagonal.len();
    for i in 0..n - 1 {
        if diagonal[i].abs() >= lower[i].abs() {
            if diagonal[i] == 0.0 {
                return Err(InterpError::Singular);
            }
            let factor = lower[i] / diagonal[i];
            diagonal[i + 1] -= factor * upper[i];
            rhs[i + 1] -= factor * rhs[i];
            lower[i] = 0.0;
        } else {
            // Swap rows i and i + 1.
            let factor = diagonal[i] / lower[i];
            diagonal[i] = lower[i];
            let temp = diagonal[i + 1];
            diagonal[i + 1] = upper[i] - factor * temp;
            if i + 1 < n - 1 {
                lower[i] = upper[i + 1];
                upper[i + 1] = -factor * lower[i];
            } else {
                lower[i] = 0.0;
            }
            upper[i] = temp;
            let temp = rhs[i];
            rhs[i] = rhs[i + 1];
            rhs[i + 1] = temp - factor * rhs[i + 1];
        }
    }
    if diagonal[n - 1] == 0.0 {
        return Err(InterpError::Singular);
    }
    rhs[n - 1] /= diagonal[n - 1];
    if n > 1 {
        rhs[n - 2] = (rhs[n - 2] - upper[n - 2] * rhs[n - 1]) / diagonal[n - 2];
    }
    for i in (0..n.saturating_sub(2)).rev() {
        rhs[i] = (rhs[i] - upper[i] * rhs[i + 1] - lower[i] * rhs[i + 2]) / diagonal[i];
    }
    if rhs.iter().any(|s| !s.is_finite()) {
        return Err(InterpError::Singular);
    }
    Ok(rhs)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn close(a: f64, b: f64, tolerance: f64) -> bool {
        (a - b).abs() <= tolerance * (1.0 + b.abs())
    }

    #[test]
    fn reproduces_a_cubic_exactly() {
        let cubic = |x: f64| 0.7 * x * x * x - 2.0 * x * x + 0.5 * x - 3.0;
        let x = [-2.0, -1.3, -0.2, 0.0, 0.9, 1.0, 2.5, 4.0, 4.1];
        let y: Vec<f64> = x.iter().map(|&v| cubic(v)).collect();
        let spline = CubicSpline::new(&x, &y).unwrap();
        for i in 0..=600 {
            let v = -2.0 + 6.1 * i as f64 / 600.0;
            assert!(close(spline.eval(v), cubic(v), 1e-12), "at {v}");
        }
        // Four points: one cubic.
        let spline = CubicSpline::new(&x[..4], &y[..4]).unwrap();
        assert!(close(spline.eval(-0.7), cubic(-0.7), 1e-12));
    }

    /// Golden values from scipy 1.17.1:
    /// python3 -c "from scipy.interpolate import CubicSpline;
    ///   x=[0.0,0.3,0.45,1.1,1.6,2.85,3.0,4.2]; y=[1.0,-0.4,0.25,2.0,1.1,-1.3,-0.9,0.5];
    ///   cs=CubicSpline(x,y); print([repr(float(v)) for v in
    ///   cs([-0.2,0.1,0.4,0.8,1.35,2.0,2.9,3.7,4.2,4.5])]);
    ///   print([repr(float(v)) for v in CubicSpline(x[:3],y[:3])([0.2,0.4])])"
    #[test]
    fn matches_scipy_on_a_non_uniform_grid() {
        let x = [0.0, 0.3, 0.45, 1.1, 1.6, 2.85, 3.0, 4.2];
        let y = [1.0, -0.4, 0.25, 2.0, 1.1, -1.3, -0.9, 0.5];
        let at = [-0.2, 0.1, 0.4, 0.8, 1.35, 2.0, 2.9, 3.7, 4.2, 4.5];
        let scipy = [
            6.364422055797147,
            -0.1284762213935387,
            0.008136063255296963,
            1.5802851002212128,
            1.7434162936873987,
            -0.21498917830572412,
            -1.1889552519723565,
            1.5799604642048526,
            0.5000000000000009,
            -2.830657629149922,
        ];
        let spline = CubicSpline::new(&x, &y).unwrap();
        for (&v, &expected) in at.iter().zip(&scipy) {
            assert!(close(spline.eval(v), expected, 1e-12), "at {v}");
        }
        assert_eq!(spline.eval_many(&at).len(), at.len());
        assert_eq!(spline.domain(), (0.0, 4.2));

        let parabola = CubicSpline::new(&x[..3], &y[..3]).unwrap();
        assert!(close(parabola.eval(0.2), -0.3333333333333331, 1e-12));
        assert!(close(parabola.eval(0.4), -0.06666666666666662, 1e-12));
    }

    #[test]
    fn two_points_give_a_line_and_three_a_parabola() {
        let line = CubicSpline::new(&[1.0, 3.0], &[2.0, 6.0]).unwrap();
        assert!(close(line.eval(2.0), 4.0, 1e-15));
        assert!(close(line.eval(5.0), 10.0, 1e-15));
        let parabola = CubicSpline::new(&[0.0, 1.0, 3.0], &[0.0, 1.0, 9.0]).unwrap();
        assert!(close(parabola.eval(2.0), 4.0, 1e-14));
        assert!(close(parabola.eval(-1.0), 1.0, 1e-14));
    }

    #[test]
    fn bad_points_are_errors_that_say_where() {
        assert_eq!(
            CubicSpline::new(&[1.0], &[1.0]),
            Err(InterpError::TooFewPoints(1))
        );
        assert_eq!(
            CubicSpline::new(&[0.0, 1.0], &[1.0]),
            Err(InterpError::LengthMismatch { x: 2, y: 1 })
        );
        let error = CubicSpline::new(&[0.0, 1.0, 1.0, 2.0], &[0.0; 4]).unwrap_err();
        assert!(matches!(error, InterpError::NotIncreasing { index: 2, .. }));
        assert!(error.to_string().contains("index 2"), "{error}");
        assert!(matches!(
            CubicSpline::new(&[0.0, 1.0, 2.0], &[0.0, f64::NAN, 1.0]),
            Err(InterpError::NotFinite { index: 1, .. })
        ));
        let spline = CubicSpline::new(&[0.0, 1.0, 2.0, 3.0], &[0.0, 1.0, 0.0, 1.0]).unwrap();
        assert!(spline.eval(f64::NAN).is_nan());
    }

    fn increasing_points() -> impl Strategy<Value = (Vec<f64>, Vec<f64>)> {
        proptest::collection::vec((1e-3..10.0f64, -1e3..1e3f64), 2..40).prop_map(|steps| {
            let mut x = Vec::with_capacity(steps.len());
            let mut position = -5.0;
            for &(step, _) in &steps {
                position += step;
                x.push(position);
            }
            (x, steps.iter().map(|&(_, y)| y).collect())
        })
    }

    proptest! {
        #[test]
        fn interpolates_its_knots((x, y) in increasing_points()) {
            let spline = CubicSpline::new(&x, &y).unwrap();
            let scale = y.iter().fold(1.0f64, |m, v| m.max(v.abs()));
            for (&xi, &yi) in x.iter().zip(&y) {
                prop_assert!((spline.eval(xi) - yi).abs() <= 1e-9 * scale, "{} vs {}", spline.eval(xi), yi);
            }
        }

        /// A walk gives the search's value bit for bit, wherever it starts
        /// and whichever way x goes, in and outside the knots.
        #[test]
        fn walking_gives_what_searching_gives(
            (x, y) in increasing_points(),
            at in proptest::collection::vec(-5.0..450.0f64, 1..60),
            start in 0usize..50,
        ) {
            let spline = CubicSpline::new(&x, &y).unwrap();
            let mut piece = start;
            let mut sorted = at.clone();
            sorted.sort_by(f64::total_cmp);
            for &point in at.iter().chain(&sorted).chain(&[f64::NAN, 1.0]) {
                let walked = spline.eval_walking(point, &mut piece);
                let searched = spline.eval(point);
                prop_assert!(
                    walked.to_bits() == searched.to_bits(),
                    "at {point}: {walked} against {searched}"
                );
            }
        }

        #[test]
        fn never_panics(
            x in proptest::collection::vec(proptest::num::f64::ANY, 0..12),
            y in proptest::collection::vec(proptest::num::f64::ANY, 0..12),
            at in proptest::num::f64::ANY,
            piece in proptest::num::usize::ANY,
        ) {
            if let Ok(spline) = CubicSpline::new(&x, &y) {
                let _ = spline.eval(at);
                let _ = spline.eval_walking(at, &mut piece.clone());
                let _ = spline.eval_many(&x);
            }
        }

        #[test]
        fn never_panics_on_extreme_spacing(
            x in proptest::collection::vec(-1e300..1e300f64, 2..12),
            y in proptest::collection::vec(-1e300..1e300f64, 2..12),
        ) {
            let mut x = x;
            x.sort_by(f64::total_cmp);
            x.dedup();
            let n = x.len().min(y.len());
            if let Ok(spline) = CubicSpline::new(&x[..n], &y[..n]) {
                let _ = spline.eval_many(&x);
            }
        }
    }
}
