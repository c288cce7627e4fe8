//! A curve's error factor integrated out in closed form, where the model
//! is exact (no emulator's variance): the density of the curve's `P`
//! parts at factor `f` is `f^-P exp(-Q / 2 f^2)` times what does not
//! depend on `f`, and under the factor's log-uniform prior on `[a, b]`
//!
//! ```text
//! (1 / L) ∫_a^b f^-P exp(-Q / 2f²) df / f
//!     = Γ(P/2) (2 / Q)^(P/2) [P(P/2, Q / 2a²) - P(P/2, Q / 2b²)] / 2L
//! ```
//!
//! (`u = Q / 2f²`; `L = ln(b / a)`; `P(s, x)` the regularised lower
//! incomplete gamma function). A chain evaluates it at every correlation
//! node of every step, where the midpoint rule in `ln f` took some seventy
//! exponentials a node.
//!
//! The incomplete gamma functions are written here, in logarithms: a
//! chain's first steps land where `Q` is a hundred million and both
//! functions' complements underflow, and the crates that give them
//! (statrs) give them as plain numbers, with `ln Γ(s)` computed again at
//! every call. The series and the continued fraction are Cephes's, as
//! statrs has them.

use statrs::function::gamma::ln_gamma;

/// The factor's log-uniform prior over a range, and a curve's part count.
#[derive(Clone, Debug)]
pub(super) struct LogUniformFactor {
    range: [f64; 2],
    /// `P / 2`.
    shape: f64,
    ln_gamma_shape: f64,
    /// `ln(b / a)`.
    log_range: f64,
    parts: f64,
}

impl LogUniformFactor {
    pub(super) fn new(range: [f64; 2], parts: usize) -> Self {
        let parts = parts.max(1) as f64;
        LogUniformFactor {
            range,
            shape: parts / 2.0,
            ln_gamma_shape: ln_gamma(parts / 2.0),
            log_range: (range[1] / range[0]).ln(),
            parts,
        }
    }

    /// `ln` of the prior mean of `f^-P exp(-quadratic / 2f²)`.
    pub(super) fn log_integral(&self, quadratic: f64) -> f64 {
        let [low, high] = self.range;
        if quadratic.is_nan() || quadratic == f64::INFINITY {
            return f64::NEG_INFINITY;
        }
        if quadratic <= 0.0 {
            // (a^-P - b^-P) / (P L)
            return -self.parts * low.ln() + ln_one_minus_exp(self.parts * (low / high).ln())
                - (self.parts * self.log_range).ln();
        }
        let near = quadratic / (2.0 * high * high);
        let far = quadratic / (2.0 * low * low);
        self.ln_gamma_shape + self.shape * (2.0 / quadratic).ln() + self.ln_lower_between(near, far)
            - (2.0 * self.log_range).ln()
    }

    /// `ln(P(s, far) - P(s, near))`, `near < far`.
    fn ln_lower_between(&self, near: f64, far: f64) -> f64 {
        let s = self.shape;
        if far < s + 1.0 {
            let top = self.ln_lower(far);
            top + ln_one_minus_exp(self.ln_lower(near) - top)
        } else if near >= s + 1.0 {
            let top = self.ln_upper(near);
            top + ln_one_minus_exp(self.ln_upper(far) - top)
        } else {
            // 1 - Q(s, far) - P(s, near), each well below one.
            (-(self.ln_upper(far).exp() + self.ln_lower(near).exp())).ln_1p()
        }
    }

    /// `ln P(s, x)` by its series, `x < s + 1`.
    fn ln_lower(&self, x: f64) -> f64 {
        let s = self.shape;
        let (mut denominator, mut term, mut sum) = (s, 1.0, 1.0);
        for _ in 0..MAX_TERMS {
            denominator += 1.0;
            term *= x / denominator;
            sum += term;
            if term <= sum * EPSILON {
                break;
            }
        }
        s * x.ln() - x - self.ln_gamma_shape + (sum / s).ln()
    }

    /// `ln Q(s, x)` by its continued fraction (modified Lentz), `x >= s + 1`.
    fn ln_upper(&self, x: f64) -> f64 {
        let s = self.shape;
        let mut b = x + 1.0 - s;
        let mut c = 1.0 / TINY;
        let mut d = 1.0 / b;
        let mut fraction = d;
        for i in 1..MAX_TERMS {
            let i = i as f64;
            let a = -i * (i - s);
            b += 2.0;
            d = a * d + b;
            if d.abs() < TINY {
                d = TINY;
            }
            c = b + a / c;
            if c.abs() < TINY {
                c = TINY;
            }
            d = 1.0 / d;
            let step = d * c;
            fraction *= step;
            if (step - 1.0).abs() <= EPSILON {
                break;
            }
        }
        s * x.ln() - x - self.ln_gamma_shape + fraction.ln()
    }
}

/// Relative precision at which a series or fraction stops.
const EPSILON: f64 = 1e-16;
/// Far more than either needs within their ranges (about `sqrt(s)` + 10
/// for the fraction, `x` + 20 for the series at `x < s + 1`, `s` at most
/// a few hundred).
const MAX_TERMS: usize = 2000;
const TINY: f64 = 1e-300;

/// `ln(1 - e^x)`, `x <= 0`, without cancellation at either end.
fn ln_one_minus_exp(x: f64) -> f64 {
    if x > -std::f64::consts::LN_2 {
        (-x.exp_m1()).ln()
    } else {
        (-x.exp()).ln_1p()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const RANGE: [f64; 2] = [0.1, 1e4];

    /// The integral by the midpoint rule in `ln f`, on grids of `N` and
    /// `2N` cells extrapolated to a cell of nothing (Richardson: the rule's
    /// error goes as the cell squared), in its logarithm.
    fn by_quadrature(parts: usize, quadratic: f64) -> f64 {
        let log_terms = |nodes: usize| -> Vec<f64> {
            let cell = (RANGE[1] / RANGE[0]).ln() / nodes as f64;
            (0..nodes)
                .map(|k| {
                    let t = RANGE[0].ln() + (k as f64 + 0.5) * cell;
                    -(parts as f64) * t - 0.5 * quadratic * (-2.0 * t).exp()
                })
                .collect()
        };
        let (coarse, fine) = (log_terms(200_000), log_terms(400_000));
        let top = coarse
            .iter()
            .chain(&fine)
            .copied()
            .fold(f64::NEG_INFINITY, f64::max);
        let mean =
            |terms: &[f64]| terms.iter().map(|t| (t - top).exp()).sum::<f64>() / terms.len() as f64;
        top + ((4.0 * mean(&fine) - mean(&coarse)) / 3.0).ln()
    }

    #[test]
    fn the_closed_form_equals_a_fine_quadrature_from_no_misfit_to_a_large_one() {
        for parts in [1, 2, 5, 20, 21, 120] {
            let factor = LogUniformFactor::new(RANGE, parts);
            // From residuals far inside the noise (the factor's mass at
            // its lower end) through a factor of order one to residuals
            // three hundred times the scatter; beyond, the mass crowds
            // against the upper end faster than a grid resolves it.
            for per_part in [0.0, 1e-30, 1e-6, 0.01, 0.3, 1.0, 7.0, 40.0, 1e3, 1e5] {
                let quadratic = per_part * parts as f64;
                let closed = factor.log_integral(quadratic);
                let fine = by_quadrature(parts, quadratic);
                assert!(
                    (closed - fine).abs() < 1e-9 * (1.0 + fine.abs()),
                    "P {parts}, Q {quadratic}: {closed} against {fine}"
                );
            }
        }
    }

    /// `ln Q(s, x)` for a whole `s`: `e^-x` times the first `s` terms of
    /// `e^x`'s series.
    fn ln_upper_whole(s: usize, x: f64) -> f64 {
        let terms: Vec<f64> = (0..s)
            .map(|k| k as f64 * x.ln() - ln_gamma(k as f64 + 1.0))
            .collect();
        let top = terms.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        -x + top + terms.iter().map(|t| (t - top).exp()).sum::<f64>().ln()
    }

    #[test]
    fn where_the_factor_meets_its_upper_end_the_closed_form_equals_the_finite_sum() {
        // An even part count makes s whole, where Q(s, x) is a finite sum.
        for parts in [2, 20, 120] {
            let factor = LogUniformFactor::new(RANGE, parts);
            let s = parts / 2;
            for per_part in [1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e12] {
                let quadratic = per_part * parts as f64;
                let near = quadratic / (2.0 * RANGE[1] * RANGE[1]);
                let far = quadratic / (2.0 * RANGE[0] * RANGE[0]);
                let (top, bottom) = (ln_upper_whole(s, near), ln_upper_whole(s, far));
                let expected = ln_gamma(s as f64)
                    + s as f64 * (2.0 / quadratic).ln()
                    + top
                    + ln_one_minus_exp(bottom - top)
                    - (2.0 * factor.log_range).ln();
                let closed = factor.log_integral(quadratic);
                assert!(
                    (closed - expected).abs() < 1e-10 * (1.0 + expected.abs()),
                    "P {parts}, Q {quadratic}: {closed} against {expected}"
                );
            }
            // And the fraction alone, on either side of its hand-over.
            for x in [s as f64 + 1.0, s as f64 + 1.5, 3.0 * s as f64 + 5.0, 1e4] {
                let (got, expected) = (factor.ln_upper(x), ln_upper_whole(s, x));
                assert!(
                    (got - expected).abs() < 1e-12 * (1.0 + expected.abs()),
                    "s {s}, x {x}: {got} against {expected}"
                );
            }
        }
    }
}
