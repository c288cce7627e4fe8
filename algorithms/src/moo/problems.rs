//! Benchmark problems with known Pareto fronts (Zitzler, Deb, Thiele 2000; Deb, Thiele,
//! Laumanns, Zitzler 2002), to check the optimiser and the indicators against the truth.

use std::f64::consts::PI;
use std::str::FromStr;

use super::MooError;

/// A benchmark problem in its usual size: ZDT1-3 with 30 variables and 2 objectives,
/// DTLZ2 with 12 variables and 3 objectives; all variables in [0, 1].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Problem {
    /// Convex front `f2 = 1 - sqrt(f1)`.
    Zdt1,
    /// Concave front `f2 = 1 - f1^2`.
    Zdt2,
    /// Five disconnected pieces of `f2 = 1 - sqrt(f1) - f1 sin(10 pi f1)`.
    Zdt3,
    /// The positive octant of the unit sphere.
    Dtlz2,
}

impl FromStr for Problem {
    type Err = MooError;

    /// `zdt1`, `zdt2`, `zdt3` or `dtlz2`, in any case.
    fn from_str(name: &str) -> Result<Self, Self::Err> {
        match name.trim().to_ascii_lowercase().as_str() {
            "zdt1" => Ok(Self::Zdt1),
            "zdt2" => Ok(Self::Zdt2),
            "zdt3" => Ok(Self::Zdt3),
            "dtlz2" => Ok(Self::Dtlz2),
            _ => Err(MooError::UnknownProblem {
                name: name.to_string(),
            }),
        }
    }
}

impl Problem {
    /// The lowercase name `FromStr` accepts.
    pub fn name(self) -> &'static str {
        match self {
            Self::Zdt1 => "zdt1",
            Self::Zdt2 => "zdt2",
            Self::Zdt3 => "zdt3",
            Self::Dtlz2 => "dtlz2",
        }
    }

    /// Decision variables: 30 for ZDT, 12 for DTLZ2 (k = 10 distance variables).
    pub fn variables(self) -> usize {
        match self {
            Self::Zdt1 | Self::Zdt2 | Self::Zdt3 => 30,
            Self::Dtlz2 => 12,
        }
    }

    /// Objectives: 2 for ZDT, 3 for DTLZ2.
    pub fn objectives(self) -> usize {
        match self {
            Self::Zdt1 | Self::Zdt2 | Self::Zdt3 => 2,
            Self::Dtlz2 => 3,
        }
    }

    /// Every variable in [0, 1].
    pub fn bounds(self) -> Vec<(f64, f64)> {
        vec![(0.0, 1.0); self.variables()]
    }

    /// The usual hypervolume reference point: 1.1 in every objective.
    pub fn reference_point(self) -> Vec<f64> {
        vec![1.1; self.objectives()]
    }

    /// The objectives at `x`.
    ///
    /// Any number of variables is accepted (the formulas generalise); missing ones count
    /// as their value on the Pareto set (0 for ZDT, 0.5 for DTLZ2).
    pub fn evaluate(self, x: &[f64]) -> Vec<f64> {
        match self {
            Self::Zdt1 | Self::Zdt2 | Self::Zdt3 => {
                let f1 = x.first().copied().unwrap_or(0.0);
                let rest = x.get(1..).unwrap_or(&[]);
                let g = if rest.is_empty() {
                    1.0
                } else {
                    1.0 + 9.0 * rest.iter().sum::<f64>() / rest.len() as f64
                };
                let ratio = f1 / g;
                let h = match self {
                    Self::Zdt1 => 1.0 - ratio.sqrt(),
                    Self::Zdt2 => 1.0 - ratio * ratio,
                    _ => 1.0 - ratio.sqrt() - ratio * (10.0 * PI * f1).sin(),
                };
                vec![f1, g * h]
            }
            Self::Dtlz2 => {
                let angle = |i: usize| x.get(i).copied().unwrap_or(0.5) * PI / 2.0;
                let g: f64 = x
                    .get(2..)
                    .unwrap_or(&[])
                    .iter()
                    .map(|v| (v - 0.5).powi(2))
                    .sum();
                let radius = 1.0 + g;
                vec![
                    radius * angle(0).cos() * angle(1).cos(),
                    radius * angle(0).cos() * angle(1).sin(),
                    radius * angle(0).sin(),
                ]
            }
        }
    }

    /// About `points` points of the true Pareto front (only non-dominated ones for ZDT3,
    /// whose curve has dominated stretches; a grid of about `points` on DTLZ2's sphere).
    pub fn pareto_front(self, points: usize) -> Vec<Vec<f64>> {
        let steps = points.max(2);
        let grid = |k: usize, count: usize| k as f64 / (count - 1) as f64;
        match self {
            Self::Zdt1 => (0..steps)
                .map(|k| {
                    let f1 = grid(k, steps);
                    vec![f1, 1.0 - f1.sqrt()]
                })
                .collect(),
            Self::Zdt2 => (0..steps)
                .map(|k| {
                    let f1 = grid(k, steps);
                    vec![f1, 1.0 - f1 * f1]
                })
                .collect(),
            Self::Zdt3 => {
                // Sample the curve densely, then keep its non-dominated points: scanning by
                // increasing f1, a point survives if its f2 is below every earlier one.
                let dense = steps.saturating_mul(20);
                let curve: Vec<(f64, f64)> = (0..dense)
                    .map(|k| {
                        let f1 = grid(k, dense);
                        (f1, 1.0 - f1.sqrt() - f1 * (10.0 * PI * f1).sin())
                    })
                    .collect();
                let mut lowest = f64::INFINITY;
                let on_front: Vec<Vec<f64>> = curve
                    .into_iter()
                    .filter(|&(_, f2)| {
                        let keep = f2 < lowest;
                        lowest = lowest.min(f2);
                        keep
                    })
                    .map(|(f1, f2)| vec![f1, f2])
                    .collect();
                let stride = (on_front.len() / steps).max(1);
                on_front.into_iter().step_by(stride).collect()
            }
            Self::Dtlz2 => {
                let side = ((steps as f64).sqrt().ceil() as usize).max(2);
                let mut front = Vec::with_capacity(side * side);
                for i in 0..side {
                    for j in 0..side {
                        let (a, b) = (grid(i, side) * PI / 2.0, grid(j, side) * PI / 2.0);
                        front.push(vec![a.cos() * b.cos(), a.cos() * b.sin(), a.sin()]);
                    }
                }
                front
            }
        }
    }

    /// The hypervolume of the whole true front for [`Problem::reference_point`]: closed
    /// form for ZDT1 (2/3 + 0.21), ZDT2 (1/3 + 0.21) and DTLZ2 (1.1^3 - pi/6); for ZDT3
    /// the area under its five pieces integrated numerically once (1.331754...).
    pub fn true_hypervolume(self) -> f64 {
        // The margin between the unit box and the reference point: 1.1^2 - 1.
        const MARGIN_2D: f64 = 0.21;
        match self {
            Self::Zdt1 => 2.0 / 3.0 + MARGIN_2D,
            Self::Zdt2 => 1.0 / 3.0 + MARGIN_2D,
            // Exact to 1e-6 (100 001-point sweep, checked against pymoo's HV indicator).
            Self::Zdt3 => 1.331_754,
            Self::Dtlz2 => 1.1_f64.powi(3) - PI / 6.0,
        }
    }
}
