//! Matrix flow stress of the GTN material: true stress vs equivalent plastic
//! strain of the dense matrix.
//!
//! The curve is a table measured up to the ultimate tensile strength (UTS),
//! interpolated piecewise linearly, then continued past the last table point
//! (the UTS point) by a straight line whose slope `m` is a calibration
//! parameter (the test cannot measure the matrix hardening after necking):
//!
//! ```text
//! sigma_y(eps_p) = s_i + (s_{i+1} - s_i) / (e_{i+1} - e_i) * (eps_p - e_i)   e_i <= eps_p < e_{i+1}
//! sigma_y(eps_p) = s_last + m * (eps_p - e_last)                                eps_p >= e_last
//! ```
//!
//! [`FlowCurve::flow_stress_mpa`] returns the flow stress together with the
//! hardening slope `d sigma_y / d eps_p` the return mapping needs for its
//! Jacobian. The slope is that of the segment to the right of `eps_p`, so at an
//! interior knot the right segment's slope is reported (the one a further
//! increment of plastic strain will follow).
//!
//! Every constructor validates its input ([`FlowCurveError`]); deserialisation
//! goes through the same check.

use serde::{Deserialize, Serialize};

/// Why a flow curve was rejected. Each message says what to fix.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum FlowCurveError {
    /// No table point at all.
    #[error("flow curve needs at least one point (plastic strain 0, initial yield stress)")]
    Empty,
    /// The two columns have different lengths.
    #[error(
        "flow curve columns differ in length: {strains} plastic strains vs {stresses} stresses; give one stress per strain"
    )]
    LengthMismatch {
        /// Number of plastic strains given.
        strains: usize,
        /// Number of stresses given.
        stresses: usize,
    },
    /// The table does not start at zero plastic strain.
    #[error(
        "flow curve must start at plastic strain 0 (the initial yield point), got {first}; prepend the yield point"
    )]
    FirstStrainNotZero {
        /// The first plastic strain given.
        first: f64,
    },
    /// Plastic strains are not strictly increasing.
    #[error(
        "flow curve plastic strains must be strictly increasing: point {index} has {strain} after {previous}; sort the table and drop duplicates"
    )]
    StrainsNotIncreasing {
        /// Index of the offending point.
        index: usize,
        /// Its plastic strain.
        strain: f64,
        /// The plastic strain of the point before it.
        previous: f64,
    },
    /// A table value is NaN or infinite.
    #[error(
        "flow curve point {index} is not finite (plastic strain {strain}, stress {stress_mpa} MPa)"
    )]
    NonFinite {
        /// Index of the offending point.
        index: usize,
        /// Its plastic strain.
        strain: f64,
        /// Its stress.
        stress_mpa: f64,
    },
    /// A flow stress is zero or negative.
    #[error("flow curve stress at point {index} must be > 0 MPa, got {stress_mpa}")]
    StressNotPositive {
        /// Index of the offending point.
        index: usize,
        /// Its stress.
        stress_mpa: f64,
    },
    /// The post-UTS slope is negative or not finite.
    #[error("post-UTS slope m must be finite and >= 0 MPa, got {0}")]
    InvalidPostUtsSlope(f64),
    /// The linear-hardening modulus is negative or not finite.
    #[error("linear hardening modulus must be finite and >= 0 MPa, got {0}")]
    InvalidHardening(f64),
}

/// Matrix flow stress vs equivalent plastic strain: a table (piecewise linear)
/// up to the UTS point, then a straight line with slope `m`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "UncheckedFlowCurve")]
pub struct FlowCurve {
    plastic_strain: Vec<f64>,
    true_stress_mpa: Vec<f64>,
    post_uts_slope_mpa: f64,
    /// Derived from the table, for [`FlowCurve::flow_stress_mpa`], which every
    /// return-mapping iteration calls: each segment's slope, and the mean
    /// knot spacing that guesses a strain's segment.
    #[serde(skip_serializing)]
    segment_slope_mpa: Vec<f64>,
    #[serde(skip_serializing)]
    mean_spacing: f64,
}

/// The serialised form, checked by [`FlowCurve::new`] on the way in.
#[derive(Deserialize)]
struct UncheckedFlowCurve {
    plastic_strain: Vec<f64>,
    true_stress_mpa: Vec<f64>,
    post_uts_slope_mpa: f64,
}

impl TryFrom<UncheckedFlowCurve> for FlowCurve {
    type Error = FlowCurveError;

    fn try_from(raw: UncheckedFlowCurve) -> Result<Self, Self::Error> {
        FlowCurve::new(
            raw.plastic_strain,
            raw.true_stress_mpa,
            raw.post_uts_slope_mpa,
        )
    }
}

impl FlowCurve {
    /// Builds a flow curve from a table of (plastic strain, true stress in MPa)
    /// ending at the UTS point and the slope `m` (MPa) of the line after it.
    ///
    /// # Errors
    /// Fewer than one point, columns of different length, a first plastic strain
    /// other than 0, strains not strictly increasing, any non-finite value, a
    /// stress <= 0, or a slope `m` that is negative or not finite.
    pub fn new(
        plastic_strain: Vec<f64>,
        true_stress_mpa: Vec<f64>,
        post_uts_slope_mpa: f64,
    ) -> Result<Self, FlowCurveError> {
        if plastic_strain.len() != true_stress_mpa.len() {
            return Err(FlowCurveError::LengthMismatch {
                strains: plastic_strain.len(),
                stresses: true_stress_mpa.len(),
            });
        }
        if plastic_strain.is_empty() {
            return Err(FlowCurveError::Empty);
        }
        for (index, (&strain, &stress_mpa)) in
            plastic_strain.iter().zip(&true_stress_mpa).enumerate()
        {
            if !strain.is_finite() || !stress_mpa.is_finite() {
                return Err(FlowCurveError::NonFinite {
                    index,
                    strain,
                    stress_mpa,
                });
            }
            if stress_mpa <= 0.0 {
                return Err(FlowCurveError::StressNotPositive { index, stress_mpa });
            }
        }
        if plastic_strain[0] != 0.0 {
            return Err(FlowCurveError::FirstStrainNotZero {
                first: plastic_strain[0],
            });
        }
        for (index, pair) in plastic_strain.windows(2).enumerate() {
            if pair[1] <= pair[0] {
                return Err(FlowCurveError::StrainsNotIncreasing {
                    index: index + 1,
                    strain: pair[1],
                    previous: pair[0],
                });
            }
        }
        if !post_uts_slope_mpa.is_finite() || post_uts_slope_mpa < 0.0 {
            return Err(FlowCurveError::InvalidPostUtsSlope(post_uts_slope_mpa));
        }
        let segment_slope_mpa = plastic_strain
            .windows(2)
            .zip(true_stress_mpa.windows(2))
            .map(|(strain, stress)| (stress[1] - stress[0]) / (strain[1] - strain[0]))
            .collect();
        let mean_spacing =
            plastic_strain[plastic_strain.len() - 1] / (plastic_strain.len() - 1).max(1) as f64;
        Ok(Self {
            plastic_strain,
            true_stress_mpa,
            post_uts_slope_mpa,
            segment_slope_mpa,
            mean_spacing,
        })
    }

    /// Linear hardening `sigma_y = sigma_0 + H eps_p` (handy for tests and
    /// benchmarks): a one-point table continued with slope `H`.
    ///
    /// # Errors
    /// `initial_yield_mpa` not finite or <= 0, `hardening_mpa` not finite or < 0.
    pub fn linear(initial_yield_mpa: f64, hardening_mpa: f64) -> Result<Self, FlowCurveError> {
        if !hardening_mpa.is_finite() || hardening_mpa < 0.0 {
            return Err(FlowCurveError::InvalidHardening(hardening_mpa));
        }
        Self::new(vec![0.0], vec![initial_yield_mpa], hardening_mpa)
    }

    /// `(flow stress MPa, hardening slope d sigma_y / d eps_p MPa)` at plastic
    /// strain `plastic_strain`.
    ///
    /// A negative (or NaN) plastic strain is treated as 0: the matrix cannot
    /// un-harden. Inside a segment the slope is that segment's; at an interior
    /// knot it is the right segment's; from the last table point on it is `m`.
    pub fn flow_stress_mpa(&self, plastic_strain: f64) -> (f64, f64) {
        // `!(x > 0)` also catches NaN.
        let strain = if plastic_strain > 0.0 {
            plastic_strain
        } else {
            0.0
        };
        let last = self.plastic_strain.len() - 1;
        if strain >= self.plastic_strain[last] {
            let stress = self.true_stress_mpa[last]
                + self.post_uts_slope_mpa * (strain - self.plastic_strain[last]);
            return (stress, self.post_uts_slope_mpa);
        }
        // The segment `left` with knot[left] <= strain < knot[left + 1]: the
        // mean spacing's guess, moved a knot or two (tables of equal strain
        // bins, as tensile-props makes), else a binary search.
        let knots = &self.plastic_strain;
        let mut left = ((strain / self.mean_spacing) as usize).min(last - 1);
        for _ in 0..2 {
            if knots[left] > strain {
                left -= 1;
            } else if knots[left + 1] <= strain {
                left += 1;
            }
        }
        if !(knots[left] <= strain && strain < knots[left + 1]) {
            // Knots at or left of `strain`: >= 1 because the first is 0.
            left = knots.partition_point(|&knot| knot <= strain) - 1;
        }
        let slope = self.segment_slope_mpa[left];
        let stress = self.true_stress_mpa[left] + slope * (strain - knots[left]);
        (stress, slope)
    }

    /// Flow stress at zero plastic strain (MPa).
    pub fn initial_yield_mpa(&self) -> f64 {
        self.true_stress_mpa[0]
    }

    /// Slope `m` of the straight line after the last table point (MPa).
    pub fn post_uts_slope_mpa(&self) -> f64 {
        self.post_uts_slope_mpa
    }

    /// The same table continued with slope `m` (MPa) instead.
    ///
    /// # Errors
    /// `m` negative or not finite.
    pub fn with_post_uts_slope_mpa(&self, post_uts_slope_mpa: f64) -> Result<Self, FlowCurveError> {
        if !post_uts_slope_mpa.is_finite() || post_uts_slope_mpa < 0.0 {
            return Err(FlowCurveError::InvalidPostUtsSlope(post_uts_slope_mpa));
        }
        Ok(Self {
            post_uts_slope_mpa,
            ..self.clone()
        })
    }

    /// Plastic strains of the table (first is 0, strictly increasing).
    pub fn plastic_strain(&self) -> &[f64] {
        &self.plastic_strain
    }

    /// True stresses of the table (MPa), one per plastic strain.
    pub fn true_stress_mpa(&self) -> &[f64] {
        &self.true_stress_mpa
    }

    /// Plastic strain of the last table point (the UTS point).
    pub fn uts_plastic_strain(&self) -> f64 {
        self.plastic_strain[self.plastic_strain.len() - 1]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn table() -> FlowCurve {
        FlowCurve::new(vec![0.0, 0.01, 0.05], vec![400.0, 450.0, 550.0], 300.0).unwrap()
    }

    #[test]
    fn interpolates_inside_segments() {
        let curve = table();
        let (stress, slope) = curve.flow_stress_mpa(0.005);
        // 400 + 5000 * 0.005; exact up to one rounding of the product.
        assert!((stress - 425.0).abs() < 1e-12, "{stress}");
        assert!((slope - 5000.0).abs() < 1e-9, "{slope}");
        let (stress, slope) = curve.flow_stress_mpa(0.03);
        assert!((stress - 500.0).abs() < 1e-12, "{stress}");
        assert!((slope - 2500.0).abs() < 1e-9, "{slope}");
    }

    #[test]
    fn knots_use_the_right_segment() {
        let curve = table();
        assert_eq!(curve.flow_stress_mpa(0.0), (400.0, 5000.0));
        let (stress, slope) = curve.flow_stress_mpa(0.01);
        assert!((stress - 450.0).abs() < 1e-12);
        assert!((slope - 2500.0).abs() < 1e-9, "right segment, got {slope}");
        // The last knot (UTS) continues with m.
        let (stress, slope) = curve.flow_stress_mpa(0.05);
        assert!((stress - 550.0).abs() < 1e-12);
        assert_eq!(slope, 300.0);
    }

    #[test]
    fn every_strain_finds_its_segment_in_even_and_uneven_tables() {
        // The segment search against its definition: the last knot at or
        // left of the strain, on tables of equal bins, jittered bins and
        // widely uneven ones, at knots, between them and past the end.
        let mut state = 0x2545_F491_4F6C_DD1Du64;
        let mut uniform = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        for table in 0..60 {
            let points = 2 + table % 40;
            let mut strains = vec![0.0];
            for _ in 1..points {
                let step = match table % 3 {
                    0 => 0.002,
                    1 => 0.002 * (0.9 + 0.2 * uniform()),
                    _ => 1e-4 + 0.05 * uniform() * uniform(),
                };
                strains.push(strains[strains.len() - 1] + step);
            }
            let stresses: Vec<f64> = (0..points)
                .map(|i| 400.0 + 3.0 * i as f64 + uniform())
                .collect();
            let curve = FlowCurve::new(strains.clone(), stresses.clone(), 250.0).unwrap();
            let end = strains[points - 1];
            let probes = strains
                .iter()
                .copied()
                .chain((0..200).map(|_| 1.1 * end * uniform()));
            for strain in probes {
                let left = strains.iter().rposition(|&knot| knot <= strain).unwrap();
                let expected = if left == points - 1 {
                    (stresses[left] + 250.0 * (strain - strains[left]), 250.0)
                } else {
                    let slope =
                        (stresses[left + 1] - stresses[left]) / (strains[left + 1] - strains[left]);
                    (stresses[left] + slope * (strain - strains[left]), slope)
                };
                assert_eq!(
                    curve.flow_stress_mpa(strain),
                    expected,
                    "table {table}, strain {strain}"
                );
            }
        }
    }

    #[test]
    fn extends_past_uts_with_slope_m() {
        let curve = table();
        let (stress, slope) = curve.flow_stress_mpa(0.25);
        assert!((stress - (550.0 + 300.0 * 0.2)).abs() < 1e-9, "{stress}");
        assert_eq!(slope, 300.0);
    }

    #[test]
    fn negative_and_nan_strains_are_zero() {
        let curve = table();
        assert_eq!(curve.flow_stress_mpa(-1.0), curve.flow_stress_mpa(0.0));
        assert_eq!(curve.flow_stress_mpa(f64::NAN), curve.flow_stress_mpa(0.0));
    }

    #[test]
    fn linear_hardening() {
        let curve = FlowCurve::linear(300.0, 1000.0).unwrap();
        assert_eq!(curve.initial_yield_mpa(), 300.0);
        let (stress, slope) = curve.flow_stress_mpa(0.1);
        assert!((stress - 400.0).abs() < 1e-12);
        assert_eq!(slope, 1000.0);
        assert_eq!(
            FlowCurve::linear(300.0, -1.0),
            Err(FlowCurveError::InvalidHardening(-1.0))
        );
        assert!(matches!(
            FlowCurve::linear(0.0, 1.0),
            Err(FlowCurveError::StressNotPositive { .. })
        ));
    }

    #[test]
    fn rejects_bad_tables() {
        assert_eq!(
            FlowCurve::new(vec![], vec![], 0.0),
            Err(FlowCurveError::Empty)
        );
        assert!(matches!(
            FlowCurve::new(vec![0.0, 0.1], vec![1.0], 0.0),
            Err(FlowCurveError::LengthMismatch {
                strains: 2,
                stresses: 1
            })
        ));
        assert!(matches!(
            FlowCurve::new(vec![0.01, 0.1], vec![1.0, 2.0], 0.0),
            Err(FlowCurveError::FirstStrainNotZero { .. })
        ));
        assert!(matches!(
            FlowCurve::new(vec![0.0, 0.1, 0.1], vec![1.0, 2.0, 3.0], 0.0),
            Err(FlowCurveError::StrainsNotIncreasing { index: 2, .. })
        ));
        assert!(matches!(
            FlowCurve::new(vec![0.0, f64::NAN], vec![1.0, 2.0], 0.0),
            Err(FlowCurveError::NonFinite { index: 1, .. })
        ));
        assert!(matches!(
            FlowCurve::new(vec![0.0, 0.1], vec![1.0, f64::INFINITY], 0.0),
            Err(FlowCurveError::NonFinite { index: 1, .. })
        ));
        assert!(matches!(
            FlowCurve::new(vec![0.0, 0.1], vec![1.0, -2.0], 0.0),
            Err(FlowCurveError::StressNotPositive { index: 1, .. })
        ));
        assert_eq!(
            FlowCurve::new(vec![0.0], vec![1.0], -1.0),
            Err(FlowCurveError::InvalidPostUtsSlope(-1.0))
        );
        assert!(matches!(
            FlowCurve::new(vec![0.0], vec![1.0], f64::NAN),
            Err(FlowCurveError::InvalidPostUtsSlope(_))
        ));
    }

    #[test]
    fn error_messages_say_what_to_fix() {
        let message = FlowCurve::new(vec![0.0, 0.1, 0.05], vec![1.0, 2.0, 3.0], 0.0)
            .unwrap_err()
            .to_string();
        assert!(message.contains("strictly increasing"), "{message}");
        let message = FlowCurve::new(vec![0.0], vec![1.0], -5.0)
            .unwrap_err()
            .to_string();
        assert!(message.contains("post-UTS slope m"), "{message}");
    }

    #[test]
    fn deserialisation_is_validated() {
        let good: FlowCurve = toml::from_str(
            "plastic_strain = [0.0, 0.1]\ntrue_stress_mpa = [400.0, 500.0]\npost_uts_slope_mpa = 100.0\n",
        )
        .unwrap();
        assert_eq!(good.true_stress_mpa(), &[400.0, 500.0]);
        let round_trip: FlowCurve = toml::from_str(&toml::to_string(&good).unwrap()).unwrap();
        assert_eq!(round_trip, good);
        let bad: Result<FlowCurve, _> = toml::from_str(
            "plastic_strain = [0.0, 0.1]\ntrue_stress_mpa = [400.0, -500.0]\npost_uts_slope_mpa = 100.0\n",
        );
        let message = bad.unwrap_err().to_string();
        assert!(message.contains("must be > 0"), "{message}");
    }
}
