//! The linear map every sensor profile compiles to, and the errors of
//! building one. Shared by all kinds; depends on none of them.

/// `output = gain * input + offset`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Linear {
    pub gain: f64,
    pub offset: f64,
}

impl Linear {
    pub const IDENTITY: Linear = Linear {
        gain: 1.0,
        offset: 0.0,
    };

    pub fn scale(gain: f64) -> Self {
        Linear { gain, offset: 0.0 }
    }

    #[inline]
    pub fn apply(self, input: f64) -> f64 {
        self.gain * input + self.offset
    }

    /// `self` applied after `first`.
    pub fn after(self, first: Linear) -> Linear {
        Linear {
            gain: self.gain * first.gain,
            offset: self.gain * first.offset + self.offset,
        }
    }

    /// The input that gives `output` (for simulators); `None` if the gain is 0.
    pub fn invert(self, output: f64) -> Option<f64> {
        (self.gain != 0.0).then(|| (output - self.offset) / self.gain)
    }
}

/// A unit the profile does not know, or a missing constant.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum ProfileError {
    #[error("unit '{unit}' is not a {kind} unit (expected one of: {expected})")]
    UnknownUnit {
        unit: String,
        kind: &'static str,
        expected: String,
    },
    #[error("{0}")]
    Invalid(String),
}

/// The error for a unit a kind does not accept: `kind` is the kind's name
/// (`SensorKind::name`), `accepted` its input units.
pub(crate) fn unknown_unit(unit: &str, kind: &'static str, accepted: &[&str]) -> ProfileError {
    ProfileError::UnknownUnit {
        unit: unit.to_string(),
        kind,
        expected: accepted.join(", "),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn composition_and_inverse() {
        let first = Linear {
            gain: 2.0,
            offset: 1.0,
        };
        let second = Linear {
            gain: 10.0,
            offset: -3.0,
        };
        let both = second.after(first);
        assert_eq!(both.apply(4.0), second.apply(first.apply(4.0)));
        assert_eq!(both.invert(both.apply(4.0)), Some(4.0));
        assert_eq!(Linear::scale(0.0).invert(1.0), None);
    }
}
