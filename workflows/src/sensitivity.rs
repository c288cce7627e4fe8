//! One-at-a-time sensitivity: each uncertain input swept across its bounds
//! with the others at nominal, every model output recorded.
//!
//! The first step of the published calibration (before the surrogate): it
//! shows which inputs move which outputs, and by how much, over the range
//! the calibration may search. Model-agnostic: a model is a function from
//! input values to output values that may fail with a reason.

use std::fmt::Write as _;

use acq_io::output::csv_field;
use acq_report::plot::{Chart, Series};

/// An uncertain input and the range it is swept over.
#[derive(Debug, Clone, PartialEq)]
pub struct Factor {
    pub name: String,
    pub unit: String,
    pub bounds: [f64; 2],
    pub nominal: f64,
}

/// A model output.
#[derive(Debug, Clone, PartialEq)]
pub struct Response {
    pub name: String,
    pub unit: String,
}

/// One evaluation of the sweep: `factor` set to `value`, the rest nominal.
#[derive(Debug, Clone, PartialEq)]
pub struct SweepRun {
    pub factor: usize,
    pub value: f64,
    pub outputs: Result<Vec<f64>, String>,
}

#[derive(Debug, Clone, PartialEq)]
pub struct Sweep {
    pub factors: Vec<Factor>,
    pub responses: Vec<Response>,
    pub nominal_outputs: Result<Vec<f64>, String>,
    pub runs: Vec<SweepRun>,
}

/// Sweeps every factor over `points` evenly spaced values (bounds included).
pub fn one_at_a_time(
    factors: &[Factor],
    responses: &[Response],
    points: usize,
    mut model: impl FnMut(&[f64]) -> Result<Vec<f64>, String>,
) -> Sweep {
    let nominal: Vec<f64> = factors.iter().map(|f| f.nominal).collect();
    let nominal_outputs = model(&nominal);
    let points = points.max(2);
    let mut runs = Vec::with_capacity(factors.len() * points);
    for (k, factor) in factors.iter().enumerate() {
        let [low, high] = factor.bounds;
        for step in 0..points {
            let value = low + (high - low) * step as f64 / (points - 1) as f64;
            let mut inputs = nominal.clone();
            inputs[k] = value;
            runs.push(SweepRun {
                factor: k,
                value,
                outputs: model(&inputs),
            });
        }
    }
    Sweep {
        factors: factors.to_vec(),
        responses: responses.to_vec(),
        nominal_outputs,
        runs,
    }
}

impl Sweep {
    /// Per factor and response: largest minus smallest output over the
    /// sweep (None when no run of that factor succeeded).
    pub fn swings(&self) -> Vec<Vec<Option<f64>>> {
        (0..self.factors.len())
            .map(|k| {
                (0..self.responses.len())
                    .map(|r| {
                        let values = self
                            .runs
                            .iter()
                            .filter(|run| run.factor == k)
                            .filter_map(|run| run.outputs.as_ref().ok().map(|o| o[r]));
                        let (low, high) = values
                            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
                                (lo.min(v), hi.max(v))
                            });
                        (low <= high).then_some(high - low)
                    })
                    .collect()
            })
            .collect()
    }

    pub fn failed_runs(&self) -> usize {
        self.runs.iter().filter(|run| run.outputs.is_err()).count()
    }

    /// The table: `factor,value,<response>_<unit>...,error`; one row per run.
    pub fn to_csv(&self) -> String {
        let mut text = String::from("factor,factor_unit,value");
        for response in &self.responses {
            let _ = write!(
                text,
                ",{}",
                csv_field(&format!("{}_{}", response.name, response.unit))
            );
        }
        text.push_str(",error\n");
        for run in &self.runs {
            let factor = &self.factors[run.factor];
            let _ = write!(
                text,
                "{},{},{}",
                csv_field(&factor.name),
                csv_field(&factor.unit),
                run.value
            );
            match &run.outputs {
                Ok(outputs) => {
                    for value in outputs {
                        let _ = write!(text, ",{value}");
                    }
                    text.push_str(",\n");
                }
                Err(reason) => {
                    text.push_str(&",".repeat(self.responses.len()));
                    let _ = writeln!(text, ",{}", csv_field(reason));
                }
            }
        }
        text
    }

    /// One chart per chosen response: x is each factor's position in its
    /// range (-1 lower bound, 0 nominal, +1 upper), one line per factor; a
    /// failed run is a gap. `reference` adds a labelled horizontal line.
    pub fn charts(
        &self,
        responses: &[usize],
        reference: impl Fn(usize) -> Option<(f64, String)>,
    ) -> Vec<Chart> {
        responses
            .iter()
            .map(|&r| {
                let response = &self.responses[r];
                let mut chart = Chart::new(
                    response.name.clone(),
                    "input across its range (-1 lower, +1 upper)",
                    response.unit.clone(),
                );
                for (k, factor) in self.factors.iter().enumerate() {
                    let [low, high] = factor.bounds;
                    let half = 0.5 * (high - low);
                    let points = self
                        .runs
                        .iter()
                        .filter(|run| run.factor == k)
                        .map(|run| {
                            let x = if half > 0.0 {
                                (run.value - 0.5 * (low + high)) / half
                            } else {
                                0.0
                            };
                            let y = run.outputs.as_ref().map_or(f64::NAN, |o| o[r]);
                            (x, y)
                        })
                        .collect();
                    chart = chart.with_series(Series::new(
                        format!("{} [{} .. {} {}]", factor.name, low, high, factor.unit),
                        points,
                    ));
                }
                if let Some((value, label)) = reference(r) {
                    chart = chart.with_reference_line(value, label);
                }
                chart
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn factors() -> Vec<Factor> {
        vec![
            Factor {
                name: "a".into(),
                unit: "mm".into(),
                bounds: [0.0, 2.0],
                nominal: 1.0,
            },
            Factor {
                name: "b".into(),
                unit: "deg".into(),
                bounds: [-1.0, 1.0],
                nominal: 0.0,
            },
        ]
    }

    fn responses() -> Vec<Response> {
        vec![
            Response {
                name: "sum".into(),
                unit: "bar".into(),
            },
            Response {
                name: "square".into(),
                unit: "MPa".into(),
            },
        ]
    }

    #[test]
    fn sweeps_each_factor_with_the_others_nominal() {
        let sweep = one_at_a_time(&factors(), &responses(), 5, |x| {
            Ok(vec![x[0] + 10.0 * x[1], x[0] * x[0]])
        });
        assert_eq!(sweep.runs.len(), 10);
        assert_eq!(sweep.nominal_outputs, Ok(vec![1.0, 1.0]));
        // Factor a from 0 to 2 with b = 0: sum swings 2, square 4.
        // Factor b from -1 to 1 with a = 1: sum swings 20, square 0.
        let swings = sweep.swings();
        assert_eq!(swings[0], vec![Some(2.0), Some(4.0)]);
        assert_eq!(swings[1], vec![Some(20.0), Some(0.0)]);
        let values: Vec<f64> = sweep
            .runs
            .iter()
            .filter(|r| r.factor == 1)
            .map(|r| r.value)
            .collect();
        assert_eq!(values, vec![-1.0, -0.5, 0.0, 0.5, 1.0]);
    }

    #[test]
    fn failures_are_rows_with_a_reason_and_gaps_in_the_plot() {
        let sweep = one_at_a_time(&factors(), &responses(), 3, |x| {
            if x[0] > 1.5 {
                Err("beyond reach, \"a\"".into())
            } else {
                Ok(vec![x[0], x[1]])
            }
        });
        assert_eq!(sweep.failed_runs(), 1);
        let csv = sweep.to_csv();
        let lines: Vec<&str> = csv.lines().collect();
        assert_eq!(
            lines[0],
            "factor,factor_unit,value,sum_bar,square_MPa,error"
        );
        assert_eq!(lines[3], "a,mm,2,,,\"beyond reach, \"\"a\"\"\"");
        assert_eq!(lines[1], "a,mm,0,0,0,");
        let charts = sweep.charts(&[0], |_| Some((1.0, "measured".into())));
        assert_eq!(charts.len(), 1);
        assert!(charts[0].series[0].points[2].1.is_nan());
        assert_eq!(charts[0].series[0].points[0].0, -1.0);
        assert_eq!(charts[0].reference_lines.len(), 1);
    }
}
