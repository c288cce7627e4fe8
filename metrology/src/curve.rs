//! A calibration curve: the straight line through a certificate's points
//! (reading, value) by least squares, and how well it is known at every
//! reading.
//!
//! Without stated uncertainties of the points, the residual scatter is
//! the curve's uncertainty, with `n - 2` degrees of freedom (JCGM 100
//! example H.3, the thermometer). With them, the points are weighted by
//! `1 / u_i^2` and the curve's uncertainty is the weighted fit's
//! covariance, with infinite degrees of freedom (the certificate's).

/// Why a certificate's points give no curve; each message says what to fix.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum CurveError {
    #[error("{given} calibration point(s); a line needs at least {needed} ({why})")]
    TooFewPoints {
        given: usize,
        needed: usize,
        why: &'static str,
    },
    #[error("calibration point {index} ([{reading}, {value}]) is not a pair of finite numbers")]
    NotFinite {
        index: usize,
        reading: f64,
        value: f64,
    },
    #[error("calibration points must be in the order of their readings, each reading above the one before (or each below), but point {index} ([{reading}, {value}]) breaks that order")]
    NotMonotonic {
        index: usize,
        reading: f64,
        value: f64,
    },
    #[error("{given} uncertainties for {points} calibration points: give one per point")]
    UncertaintyCount { given: usize, points: usize },
    #[error("the uncertainty of calibration point {index} is {uncertainty}; give a finite number above 0")]
    BadUncertainty { index: usize, uncertainty: f64 },
}

/// `value = intercept + slope (reading - reading_mean)`, with its
/// parameters' covariance.
#[derive(Clone, Debug, PartialEq)]
pub struct CalibrationCurve {
    /// The mean reading of the points (weighted when the points state
    /// their uncertainties): where the intercept is taken, so that the
    /// intercept and the slope are nearly uncorrelated.
    pub reading_mean: f64,
    pub intercept: f64,
    pub slope: f64,
    /// Variances of the intercept and the slope, and their covariance.
    pub intercept_variance: f64,
    pub slope_variance: f64,
    pub covariance: f64,
    /// Degrees of freedom of the curve's uncertainty; `None` is infinite.
    pub dof: Option<f64>,
    /// The residuals' standard deviation (value unit).
    pub residual_std: f64,
    pub points: usize,
}

impl CalibrationCurve {
    /// The least-squares line through `points` (reading, value), weighted
    /// by `standard_uncertainties` (value unit, one per point) when given.
    pub fn fit(
        points: &[[f64; 2]],
        standard_uncertainties: Option<&[f64]>,
    ) -> Result<Self, CurveError> {
        let needed = if standard_uncertainties.is_some() {
            2
        } else {
            3
        };
        if points.len() < needed {
            return Err(CurveError::TooFewPoints {
                given: points.len(),
                needed,
                why: if standard_uncertainties.is_some() {
                    "two parameters"
                } else {
                    "two parameters and at least one degree of freedom for the scatter about it"
                },
            });
        }
        for (index, &[reading, value]) in points.iter().enumerate() {
            if !(reading.is_finite() && value.is_finite()) {
                return Err(CurveError::NotFinite {
                    index: index + 1,
                    reading,
                    value,
                });
            }
        }
        check_monotonic(points)?;
        let weights: Vec<f64> = match standard_uncertainties {
            None => vec![1.0; points.len()],
            Some(u) if u.len() != points.len() => {
                return Err(CurveError::UncertaintyCount {
                    given: u.len(),
                    points: points.len(),
                })
            }
            Some(u) => {
                for (index, &uncertainty) in u.iter().enumerate() {
                    if !(uncertainty.is_finite() && uncertainty > 0.0) {
                        return Err(CurveError::BadUncertainty {
                            index: index + 1,
                            uncertainty,
                        });
                    }
                }
                u.iter().map(|u| 1.0 / (u * u)).collect()
            }
        };
        let total_weight: f64 = weights.iter().sum();
        let weighted_mean = |f: &dyn Fn(&[f64; 2]) -> f64| -> f64 {
            points
                .iter()
                .zip(&weights)
                .map(|(p, w)| w * f(p))
                .sum::<f64>()
                / total_weight
        };
        let reading_mean = weighted_mean(&|p| p[0]);
        let value_mean = weighted_mean(&|p| p[1]);
        let sxx: f64 = points
            .iter()
            .zip(&weights)
            .map(|(p, w)| w * (p[0] - reading_mean).powi(2))
            .sum();
        let sxy: f64 = points
            .iter()
            .zip(&weights)
            .map(|(p, w)| w * (p[0] - reading_mean) * (p[1] - value_mean))
            .sum();
        // Monotonic readings of at least two points: sxx > 0.
        let slope = sxy / sxx;
        let intercept = value_mean;
        let residual_sum: f64 = points
            .iter()
            .zip(&weights)
            .map(|(p, w)| w * (p[1] - intercept - slope * (p[0] - reading_mean)).powi(2))
            .sum();
        let n = points.len() as f64;
        let unweighted_residual_std = (points
            .iter()
            .map(|p| (p[1] - intercept - slope * (p[0] - reading_mean)).powi(2))
            .sum::<f64>()
            / (n - 2.0).max(1.0))
        .sqrt();
        let (scale, dof) = match standard_uncertainties {
            // The scatter about the line is the points' only uncertainty.
            None => (residual_sum / (n - 2.0), Some(n - 2.0)),
            Some(_) => (1.0, None),
        };
        Ok(CalibrationCurve {
            reading_mean,
            intercept,
            slope,
            // About the weighted mean reading the two are uncorrelated.
            intercept_variance: scale / total_weight,
            slope_variance: scale / sxx,
            covariance: 0.0,
            dof,
            residual_std: unweighted_residual_std,
            points: points.len(),
        })
    }

    /// The value at `reading`.
    pub fn value_at(&self, reading: f64) -> f64 {
        self.intercept + self.slope * (reading - self.reading_mean)
    }

    /// The reading that gives `value` (the slope is never 0: the points
    /// are monotonic).
    pub fn reading_at(&self, value: f64) -> f64 {
        self.reading_mean + (value - self.intercept) / self.slope
    }

    /// The curve's standard uncertainty at `reading` (value unit).
    pub fn standard_uncertainty_at(&self, reading: f64) -> f64 {
        let dx = reading - self.reading_mean;
        (self.intercept_variance + dx * dx * self.slope_variance + 2.0 * dx * self.covariance)
            .max(0.0)
            .sqrt()
    }
}

/// Readings strictly rising or strictly falling: a reading twice, or a
/// turn, is a typing error (the values may scatter about the line, as a
/// correction's do).
fn check_monotonic(points: &[[f64; 2]]) -> Result<(), CurveError> {
    let rising = points[1][0] > points[0][0];
    for (index, pair) in points.windows(2).enumerate() {
        let ok = if rising {
            pair[1][0] > pair[0][0]
        } else {
            pair[1][0] < pair[0][0]
        };
        if !ok {
            return Err(CurveError::NotMonotonic {
                index: index + 2,
                reading: pair[1][0],
                value: pair[1][1],
            });
        }
    }
    Ok(())
}

/// JCGM 100:2008 example H.3, table H.6: a thermometer's readings t_k
/// (degrees C) and their corrections b_k = t_ref - t_k, the published
/// worked example of a calibration line whose uncertainty comes from its
/// residual scatter (the curve's and `acq budget`'s tests reproduce it).
pub const JCGM_100_H3: [[f64; 2]; 11] = [
    [21.521, -0.171],
    [22.012, -0.169],
    [22.512, -0.166],
    [23.003, -0.159],
    [23.507, -0.164],
    [23.999, -0.165],
    [24.513, -0.156],
    [25.002, -0.157],
    [25.503, -0.159],
    [26.010, -0.161],
    [26.511, -0.160],
];

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn jcgm_100_h3_the_correction_at_30_degrees_and_its_uncertainty() {
        // As a sensor's points: the reading, and the reference's value
        // t_ref = t + b.
        let points: Vec<[f64; 2]> = JCGM_100_H3.iter().map(|&[t, b]| [t, t + b]).collect();
        let curve = CalibrationCurve::fit(&points, None).unwrap();
        // H.3: b(30) = -0.1494 C with u = 0.0041 C, 9 degrees of freedom;
        // y1 = -0.1712 C at t0 = 20 C, y2 = 0.00218 per C, s = 0.0035 C.
        let correction = curve.value_at(30.0) - 30.0;
        assert!((correction - -0.1494).abs() < 5e-5, "{correction}");
        let u = curve.standard_uncertainty_at(30.0);
        assert!((u - 0.0041).abs() < 5e-5, "{u}");
        assert_eq!(curve.dof, Some(9.0));
        assert!(((curve.value_at(20.0) - 20.0) - -0.1712).abs() < 5e-5);
        assert!(((curve.slope - 1.0) - 0.00218).abs() < 5e-6);
        assert!((curve.residual_std - 0.0035).abs() < 5e-5);
        // The corrections themselves as the values: the same line, less 1.
        let corrections = CalibrationCurve::fit(&JCGM_100_H3, None).unwrap();
        assert!((corrections.value_at(30.0) - -0.1494).abs() < 5e-5);
        assert!((corrections.standard_uncertainty_at(30.0) - u).abs() < 1e-12);
    }

    #[test]
    fn stated_uncertainties_weight_the_points_and_give_the_fits_covariance() {
        // Two exact points with u = 0.1 each: the line through them, and at
        // the middle u = 0.1 / sqrt(2) (the mean of two).
        let curve = CalibrationCurve::fit(&[[0.0, 1.0], [10.0, 21.0]], Some(&[0.1, 0.1])).unwrap();
        assert!((curve.value_at(5.0) - 11.0).abs() < 1e-12);
        assert!((curve.standard_uncertainty_at(5.0) - 0.1 / 2f64.sqrt()).abs() < 1e-12);
        // At an end the line is known as well as that point: var(a) +
        // 25 var(b) = 0.005 + 25 * 0.01 / 50 = 0.01.
        assert!((curve.standard_uncertainty_at(10.0) - 0.1).abs() < 1e-12);
        assert_eq!(curve.dof, None);
        assert!((curve.reading_at(21.0) - 10.0).abs() < 1e-12);
    }

    #[test]
    fn bad_points_are_refused_with_what_to_fix() {
        let fit = |p: &[[f64; 2]], u: Option<&[f64]>| CalibrationCurve::fit(p, u).unwrap_err();
        assert!(matches!(
            fit(&[[0.0, 0.0], [1.0, 1.0]], None),
            CurveError::TooFewPoints { needed: 3, .. }
        ));
        assert!(matches!(
            fit(&[[0.0, 0.0], [2.0, 2.0], [1.0, 3.0]], None),
            CurveError::NotMonotonic { index: 3, .. }
        ));
        assert!(matches!(
            fit(&[[0.0, 0.0], [0.0, 2.0], [1.0, 3.0]], None),
            CurveError::NotMonotonic { index: 2, .. }
        ));
        assert!(matches!(
            fit(&[[0.0, 0.0], [1.0, 1.0]], Some(&[0.1, -0.1])),
            CurveError::BadUncertainty { index: 2, .. }
        ));
        assert!(matches!(
            fit(&[[0.0, 0.0], [1.0, 1.0]], Some(&[0.1])),
            CurveError::UncertaintyCount { .. }
        ));
        assert!(matches!(
            fit(&[[0.0, f64::NAN], [1.0, 1.0], [2.0, 2.0]], None),
            CurveError::NotFinite { index: 1, .. }
        ));
    }
}
