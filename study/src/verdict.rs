//! One verdict per parameter, derived once from all the evidence a
//! calibration has, and read by every table of the report, `summary.json`
//! and the terminal: a reviewer never meets two verdicts on one parameter.
//!
//! The evidence, strongest first: the posterior (it weighs the measured
//! values over the whole prior range), the bounds (a value or an interval
//! that reaches one is pressed there by the data, or cut by the range),
//! then the identifiability at the calibrated point (linearised). A
//! parameter on a bound is never "pinned down" or "identified": what the
//! data would say beyond the bound is unknown. The verdicts are derived in
//! [`crate::outcome::StudyOutcome::verdicts`]; this module only names them,
//! so that every module that writes one can read it.

/// What one parameter's verdict rests on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Evidence {
    /// The posterior's 90 % interval against its prior range.
    Posterior,
    /// The calibrated value on a bound, without a posterior.
    Bound,
    /// The identifiability at the calibrated point (linearised).
    CalibratedPoint,
    /// No evidence was computed (too few runs for the surrogates).
    None,
}

/// One parameter's verdict: its words (the first are the verdict's name:
/// "pinned down", "narrowed", "conflict", "identified", ...), and what
/// they rest on.
#[derive(Clone, Debug, PartialEq)]
pub struct ParameterVerdict {
    pub name: String,
    pub words: String,
    pub evidence: Evidence,
}

impl ParameterVerdict {
    /// The verdict's name: its words up to the first colon or comma.
    pub fn short(&self) -> &str {
        self.words
            .split([':', ','])
            .next()
            .unwrap_or(&self.words)
            .trim()
    }
}

/// The verdict of `name`, if it is a parameter.
pub fn verdict_of<'a>(
    verdicts: &'a [ParameterVerdict],
    name: &str,
) -> Option<&'a ParameterVerdict> {
    verdicts.iter().find(|v| v.name == name)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_verdicts_name_is_its_words_before_the_reason() {
        let verdict = |words: &str| ParameterVerdict {
            name: "x".into(),
            words: words.into(),
            evidence: Evidence::Posterior,
        };
        assert_eq!(verdict("pinned down").short(), "pinned down");
        assert_eq!(
            verdict("conflict: the data push it against its upper bound").short(),
            "conflict"
        );
        assert_eq!(
            verdict("narrowed, up to its lower bound").short(),
            "narrowed"
        );
    }
}
