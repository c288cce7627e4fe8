//! How a channel's reading becomes a sensor's value: the kind's linear
//! physics after the rig's scale and offset (or a certificate's line), or a
//! certificate's polynomial where the lab states one.

use super::linear::Linear;

/// A sensor's reading-to-value map.
#[derive(Clone, Debug, PartialEq)]
pub enum Conversion {
    Linear(Linear),
    /// `sum c_i r^i` of a certificate, lowest power first; monotonic over
    /// the readings it is used on (the rig checks it over the range).
    Polynomial(Vec<f64>),
}

/// Newton steps before [`Conversion::invert`] gives up: a monotonic
/// polynomial from the linear term's guess converges in a handful.
const MAX_NEWTON_STEPS: usize = 60;

impl Conversion {
    #[inline]
    pub fn apply(&self, reading: f64) -> f64 {
        match self {
            Conversion::Linear(linear) => linear.apply(reading),
            Conversion::Polynomial(coefficients) => horner(coefficients, reading).0,
        }
    }

    /// The reading that gives `value`; `None` where there is none (a zero
    /// gain, a polynomial whose slope vanishes on the way).
    pub fn invert(&self, value: f64) -> Option<f64> {
        match self {
            Conversion::Linear(linear) => linear.invert(value),
            Conversion::Polynomial(coefficients) => {
                let slope = coefficients.get(1).copied().unwrap_or(0.0);
                let mut reading = Linear {
                    gain: slope,
                    offset: coefficients.first().copied().unwrap_or(0.0),
                }
                .invert(value)?;
                for _ in 0..MAX_NEWTON_STEPS {
                    let (at, derivative) = horner(coefficients, reading);
                    if derivative == 0.0 || !derivative.is_finite() {
                        return None;
                    }
                    let step = (at - value) / derivative;
                    reading -= step;
                    if step.abs() <= 1e-13 * reading.abs().max(1.0) {
                        return reading.is_finite().then_some(reading);
                    }
                }
                None
            }
        }
    }

    /// `d value / d reading` at `reading`.
    pub fn slope(&self, reading: f64) -> f64 {
        match self {
            Conversion::Linear(linear) => linear.gain,
            Conversion::Polynomial(coefficients) => horner(coefficients, reading).1,
        }
    }
}

/// The polynomial and its derivative at `x` (Horner's scheme).
fn horner(coefficients: &[f64], x: f64) -> (f64, f64) {
    let mut value = 0.0;
    let mut derivative = 0.0;
    for &c in coefficients.iter().rev() {
        derivative = derivative * x + value;
        value = value * x + c;
    }
    (value, derivative)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_quadratic_is_applied_and_inverted_as_its_closed_form_says() {
        // v = 0.05 + 1.002 r + 2e-5 r^2: at r = 150, v = 0.05 + 150.3 + 0.45.
        let quadratic = Conversion::Polynomial(vec![0.05, 1.002, 2e-5]);
        assert!((quadratic.apply(150.0) - 150.8).abs() < 1e-12);
        assert!((quadratic.slope(150.0) - (1.002 + 2.0 * 2e-5 * 150.0)).abs() < 1e-15);
        // The root of 2e-5 r^2 + 1.002 r + (0.05 - v) = 0.
        let v = 150.8;
        let (a, b, c): (f64, f64, f64) = (2e-5, 1.002, 0.05 - v);
        let root = (-b + (b * b - 4.0 * a * c).sqrt()) / (2.0 * a);
        assert!((quadratic.invert(v).unwrap() - root).abs() < 1e-9, "{root}");
        assert!((root - 150.0).abs() < 1e-9);
        let linear = Conversion::Linear(Linear {
            gain: 2.0,
            offset: 1.0,
        });
        assert_eq!(linear.invert(5.0), Some(2.0));
        assert_eq!(Conversion::Polynomial(vec![1.0, 0.0]).invert(3.0), None);
    }
}
