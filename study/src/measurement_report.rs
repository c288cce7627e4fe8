//! The measured values' uncertainty as a calibration report shows it:
//! each observation's standard uncertainty split into the parts it shares
//! with other observations (a transducer's calibration, a session's zero)
//! and its own, with each part's share of the variance, as metrology labs
//! present a budget. A part shared by several observations is one error in
//! the posterior, however many holds carry it.

use acq_report::document::{Document, Table};

use super::study::{Role, Study};

/// The section, when an observation states its uncertainty.
pub fn write_measurement_uncertainty(report: &mut Document, study: &Study) {
    let mut table = Table::new(&[
        "case",
        "observation",
        "measured",
        "u",
        "source",
        "its part of u",
        "share of the variance",
    ]);
    let mut sources: Vec<(String, usize)> = Vec::new();
    let mut stated = 0;
    for (case, observation) in study
        .observations(Role::Fit)
        .into_iter()
        .chain(study.observations(Role::Validate))
    {
        let Some((value, u)) = observation.stated_scalar() else {
            continue;
        };
        if case.priors || u.is_nan() || u <= 0.0 {
            continue;
        }
        stated += 1;
        let mut row = |source: String, part: f64| {
            table.row(vec![
                case.name.clone(),
                observation.name.clone(),
                acq_report::number::plain(value, 6),
                acq_report::number::plain(u, 3),
                source,
                acq_report::number::plain(part, 3),
                format!("{:.1} %", 100.0 * (part / u).powi(2)),
            ]);
        };
        let mut shared_variance = 0.0;
        for shared in &observation.shared {
            shared_variance += shared.effect * shared.effect;
            row(format!("{} (shared)", shared.source), shared.effect.abs());
            match sources.iter_mut().find(|(s, _)| *s == shared.source) {
                Some((_, count)) => *count += 1,
                None => sources.push((shared.source.clone(), 1)),
            }
        }
        row(
            "its own (scatter, resolution)".into(),
            (u * u - shared_variance).max(0.0).sqrt(),
        );
    }
    if stated == 0 {
        return;
    }
    report.heading(2, "The measured values' uncertainty");
    report.paragraph(
        "Each measured value's standard uncertainty `u` as its budget states it (JCGM 100): the parts it shares with other values (a transducer's certificate and accuracy class, a session's zero or shunt gain) and its own, each with its share of the variance.",
    );
    report.table(table);
    if !sources.is_empty() {
        let listed: Vec<String> = sources
            .iter()
            .map(|(source, count)| {
                format!(
                    "{source} ({count} value{})",
                    if *count == 1 { "" } else { "s" }
                )
            })
            .collect();
        report.paragraph(format!(
            "Shared sources: {}. Each is one error however many values carry it: more holds average the own parts away, never these.",
            listed.join(", ")
        ));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::study::{Case, LossKind, Measured, Observation, Residuals};
    use acq_metrology::budget::SharedError;

    fn observation(name: &str, value: f64, u: f64, shared: Vec<SharedError>) -> Observation {
        Observation {
            name: name.into(),
            output: name.into(),
            measured: Measured::Scalar {
                value,
                uncertainty: Some(u),
            },
            weight: 1.0,
            source: "test".into(),
            shared,
        }
    }

    /// Two holds of one transducer: u = 2 of which 1.6 is the
    /// transducer's (64 % of the variance) and 1.2 each hold's own (36 %).
    #[test]
    fn each_part_is_shown_with_its_share_and_a_shared_source_once() {
        let transducer = || {
            vec![SharedError {
                source: "boom_head_pressure".into(),
                effect: -1.6,
            }]
        };
        let case = |name: &str| Case {
            name: name.into(),
            role: Role::Fit,
            inputs: Vec::new(),
            observations: vec![observation("p", 80.0, 2.0, transducer())],
            priors: false,
        };
        let study = Study {
            parameters: Vec::new(),
            cases: vec![case("hold1"), case("hold2")],
            named_cases: true,
            residuals: Residuals::Relative,
            loss: LossKind::Mean,
        };
        let mut report = Document::new();
        write_measurement_uncertainty(&mut report, &study);
        let text = report.to_markdown();
        assert!(
            text.contains("| hold1 | p | 80 | 2 | boom_head_pressure (shared) | 1.6 | 64.0 % |"),
            "{text}"
        );
        assert!(
            text.contains("| hold2 | p | 80 | 2 | its own (scatter, resolution) | 1.2 | 36.0 % |"),
            "{text}"
        );
        assert!(
            text.contains("Shared sources: boom_head_pressure (2 values)"),
            "{text}"
        );
    }

    #[test]
    fn a_study_without_stated_uncertainties_has_no_section() {
        let mut unstated = observation("p", 80.0, 1.0, Vec::new());
        unstated.measured = Measured::Scalar {
            value: 80.0,
            uncertainty: None,
        };
        let study = Study {
            parameters: Vec::new(),
            cases: vec![Case {
                name: "hold1".into(),
                role: Role::Fit,
                inputs: Vec::new(),
                observations: vec![unstated],
                priors: false,
            }],
            named_cases: true,
            residuals: Residuals::Relative,
            loss: LossKind::Mean,
        };
        let mut report = Document::new();
        write_measurement_uncertainty(&mut report, &study);
        assert!(report.to_markdown().is_empty());
    }
}
