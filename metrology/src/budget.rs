//! An uncertainty budget: where each part of a value's uncertainty comes
//! from, and what they make together (JCGM 100:2008, clauses 4 to 6 and
//! annex G).

use statrs::distribution::{ContinuousCDF, Normal, StudentsT};

/// The level of confidence an expanded uncertainty states unless told.
pub const LEVEL_95: f64 = 0.95;

/// One source of uncertainty of a result.
#[derive(Clone, Debug, PartialEq)]
pub struct Contribution {
    /// What it is (`"calibration curve"`, `"accuracy class"`, `"resolution"`).
    pub source: String,
    /// The input's standard uncertainty, in the input's unit.
    pub standard_uncertainty: f64,
    /// How much the result moves per unit of the input (`df/dx_i`); 1 for
    /// a source stated in the result's own unit.
    pub sensitivity: f64,
    /// Degrees of freedom of the standard uncertainty; `None` is infinite
    /// (a Type B estimate taken as exactly known).
    pub dof: Option<f64>,
    /// The source whose error this is, where that error is the same in
    /// every value the source gives (a transducer's calibration, in every
    /// hold it measured): averaging values does not reduce it, and a
    /// posterior must treat it as one error (JCGM 100 5.2). `None`: an
    /// error of this value alone (a hold's scatter, rounding).
    pub shared_by: Option<String>,
}

/// A part of a value's error that recurs, the same, in every value its
/// source gives: the source, and how far the value moves for one standard
/// uncertainty of it (`c_i u_i`, signed, in the value's unit).
#[derive(Clone, Debug, PartialEq)]
pub struct SharedError {
    pub source: String,
    pub effect: f64,
}

impl Contribution {
    /// A source stated in the result's unit (sensitivity 1).
    pub fn direct(source: &str, standard_uncertainty: f64, dof: Option<f64>) -> Self {
        Contribution {
            source: source.to_string(),
            standard_uncertainty,
            sensitivity: 1.0,
            dof,
            shared_by: None,
        }
    }

    /// The same source, its error the same in every value `source` gives.
    pub fn shared_by(self, source: &str) -> Self {
        Contribution {
            shared_by: Some(source.to_string()),
            ..self
        }
    }

    /// Its part of the result's standard uncertainty, `|c_i| u(x_i)`.
    pub fn in_result(&self) -> f64 {
        (self.sensitivity * self.standard_uncertainty).abs()
    }
}

/// A limit `+-half_width` with nothing known of where in it the error
/// lies (an accuracy class, a tolerance): rectangular, `a / sqrt(3)`.
pub fn rectangular(half_width: f64) -> f64 {
    half_width.abs() / 3f64.sqrt()
}

/// A stated expanded uncertainty `U` with its coverage factor `k`: `U / k`.
pub fn from_expanded(expanded: f64, coverage_factor: f64) -> f64 {
    expanded.abs() / coverage_factor
}

/// The resolution `q` of a display or a quantised signal: the rounding
/// error is rectangular over `+-q/2`, `q / sqrt(12)`.
pub fn resolution(step: f64) -> f64 {
    step.abs() / 12f64.sqrt()
}

/// A result's budget: its uncorrelated contributions combined by the law
/// of propagation (first order).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Budget {
    pub contributions: Vec<Contribution>,
}

impl Budget {
    /// `u_c = sqrt(sum (c_i u_i)^2)`.
    pub fn combined(&self) -> f64 {
        // A fold from +0.0: an empty `sum` of floats is -0.0, and a budget
        // with nothing in it is 0, not "-0".
        self.contributions
            .iter()
            .fold(0.0, |sum, c| sum + c.in_result().powi(2))
            .sqrt()
    }

    /// Welch-Satterthwaite: `nu_eff = u_c^4 / sum((c_i u_i)^4 / nu_i)`;
    /// `None` (infinite) when every part with a size has infinite degrees
    /// of freedom.
    pub fn effective_dof(&self) -> Option<f64> {
        let combined = self.combined();
        let denominator: f64 = self
            .contributions
            .iter()
            .filter_map(|c| c.dof.map(|dof| c.in_result().powi(4) / dof))
            .sum();
        (denominator > 0.0).then(|| combined.powi(4) / denominator)
    }

    /// `k` for `level` (two-sided) from Student's t at the effective
    /// degrees of freedom; the normal distribution's when they are infinite.
    pub fn coverage_factor(&self, level: f64) -> f64 {
        coverage_factor(self.effective_dof(), level)
    }

    /// `U = k u_c` for `level`.
    pub fn expanded(&self, level: f64) -> f64 {
        self.coverage_factor(level) * self.combined()
    }

    /// The errors this value shares with others, one per source: the
    /// contributions of one source combined in quadrature (independent
    /// of each other, all the same in every value), with the sign of
    /// their sensitivity; in the order the sources first appear.
    pub fn shared_errors(&self) -> Vec<SharedError> {
        let mut shared: Vec<(String, f64, f64)> = Vec::new();
        for c in &self.contributions {
            let Some(source) = &c.shared_by else { continue };
            let part = c.sensitivity * c.standard_uncertainty;
            match shared.iter_mut().find(|(s, _, _)| s == source) {
                Some((_, variance, sign)) => {
                    *variance += part * part;
                    if *sign == 0.0 {
                        *sign = part.signum();
                    }
                }
                None => shared.push((source.clone(), part * part, part.signum())),
            }
        }
        shared
            .into_iter()
            .map(|(source, variance, sign)| SharedError {
                source,
                effect: sign * variance.sqrt(),
            })
            .collect()
    }

    /// Each contribution's share of the combined variance, in the order
    /// of [`Budget::contributions`] (all 0 when the budget is empty or 0).
    pub fn variance_shares(&self) -> Vec<f64> {
        let total = self.combined().powi(2);
        self.contributions
            .iter()
            .map(|c| {
                if total > 0.0 {
                    c.in_result().powi(2) / total
                } else {
                    0.0
                }
            })
            .collect()
    }
}

/// `k` for a two-sided `level` at `dof` degrees of freedom (`None`:
/// infinite). JCGM 100 G.3: the t-distribution's quantile.
pub fn coverage_factor(dof: Option<f64>, level: f64) -> f64 {
    let quantile = 0.5 + level / 2.0;
    let z = Normal::new(0.0, 1.0)
        .map(|d| d.inverse_cdf(quantile))
        .unwrap_or(f64::NAN);
    match dof {
        Some(dof) if dof.is_finite() && dof > 0.0 && dof <= LARGE_DOF => {
            StudentsT::new(0.0, 1.0, dof)
                .map(|d| d.inverse_cdf(quantile))
                .unwrap_or(z)
        }
        // statrs' t quantile drifts from 1e6 degrees of freedom on and does
        // not return beyond about 1e7 (measured with statrs 0.18): above a
        // thousand, Fisher's (1925) expansion in 1/nu, whose next term is
        // below 1e-9 there.
        Some(dof) if dof.is_finite() && dof > LARGE_DOF => {
            let (z3, z5) = (z.powi(3), z.powi(5));
            z + (z3 + z) / (4.0 * dof) + (5.0 * z5 + 16.0 * z3 + 3.0 * z) / (96.0 * dof * dof)
        }
        _ => z,
    }
}

/// Degrees of freedom above which the t quantile is taken by expansion.
const LARGE_DOF: f64 = 1000.0;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_type_b_conversions_are_the_gums() {
        assert!((rectangular(3f64.sqrt()) - 1.0).abs() < 1e-15);
        assert_eq!(from_expanded(0.2, 2.0), 0.1);
        assert!((resolution(12f64.sqrt()) - 1.0).abs() < 1e-15);
    }

    #[test]
    fn coverage_factors_are_the_t_tables() {
        // JCGM 100 table G.2: t_95.45 ... here the 95 % column of any t table.
        for (dof, k) in [(1.0, 12.706), (9.0, 2.262), (10.0, 2.228), (30.0, 2.042)] {
            assert!(
                (coverage_factor(Some(dof), LEVEL_95) - k).abs() < 5e-4,
                "{dof}"
            );
        }
        assert!((coverage_factor(None, LEVEL_95) - 1.959_964).abs() < 1e-6);
        // Where the expansion takes over, it meets Student's t (statrs at
        // 1e3 gives 1.9623391; at 1e4 1.9602012); and it keeps falling to
        // the normal's from above for any count a hold can have.
        assert!((coverage_factor(Some(1000.0), LEVEL_95) - 1.962_339).abs() < 1e-6);
        assert!((coverage_factor(Some(1000.5), LEVEL_95) - 1.962_339).abs() < 1e-5);
        assert!((coverage_factor(Some(1e4), LEVEL_95) - 1.960_201).abs() < 1e-6);
        let mut previous = f64::INFINITY;
        for dof in [1e3 + 1.0, 1e4, 1e6, 5.4e7, 1e12] {
            let k = coverage_factor(Some(dof), LEVEL_95);
            assert!(k < previous && k > 1.959_963_9, "{dof}: {k}");
            previous = k;
        }
    }

    #[test]
    fn welch_satterthwaite_by_hand() {
        // Two parts of 0.3 (9 dof) and 0.4 (infinite): u_c = 0.5,
        // nu = 0.5^4 / (0.3^4 / 9) = 0.0625 / 0.0009 = 69.44.
        let budget = Budget {
            contributions: vec![
                Contribution::direct("a", 0.3, Some(9.0)),
                Contribution {
                    source: "b".into(),
                    standard_uncertainty: 0.2,
                    sensitivity: -2.0,
                    dof: None,
                    shared_by: None,
                },
            ],
        };
        assert!((budget.combined() - 0.5).abs() < 1e-15);
        let dof = budget.effective_dof().unwrap();
        assert!((dof - 0.0625 / 0.0009).abs() < 1e-9, "{dof}");
        let shares = budget.variance_shares();
        assert!((shares[0] - 0.36).abs() < 1e-12 && (shares[1] - 0.64).abs() < 1e-12);
        let only_type_b = Budget {
            contributions: vec![Contribution::direct("b", 0.1, None)],
        };
        assert_eq!(only_type_b.effective_dof(), None);
    }

    /// A net force of two transducers' pressures: each transducer's
    /// calibration is shared (with the sign of its sensitivity), its two
    /// sources in quadrature; the scatter is not.
    #[test]
    fn shared_errors_are_one_per_source_with_the_sign_of_its_sensitivity() {
        let head = |source: &str, u: f64| Contribution {
            sensitivity: 2.0,
            ..Contribution::direct(source, u, None).shared_by("head")
        };
        let budget = Budget {
            contributions: vec![
                Contribution::direct("scatter", 0.5, Some(9.0)),
                head("curve", 0.3),
                Contribution {
                    sensitivity: -1.5,
                    ..Contribution::direct("accuracy", 0.2, None).shared_by("rod")
                },
                head("accuracy", 0.4),
            ],
        };
        let shared = budget.shared_errors();
        assert_eq!(shared.len(), 2);
        assert_eq!(shared[0].source, "head");
        assert!((shared[0].effect - 2.0 * 0.5).abs() < 1e-15);
        assert_eq!(shared[1].source, "rod");
        assert!((shared[1].effect + 0.3).abs() < 1e-15);
    }
}
