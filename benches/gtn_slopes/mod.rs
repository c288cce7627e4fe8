//! The search with the curve's slopes in hand: how many simulations a
//! test would need if every run also gave the slopes of its curve's
//! errors in each parameter (as a twin that computes its sensitivities
//! would). A reference for the calibration's own count, not a method.
//!
//! The start is the calibration's: the L12 design at the box's corners,
//! every run counted. From its best run, Gauss-Newton steps on the signed
//! errors in 20 parts of the curve (the residuals the calibration's local
//! steps fit, weighted as they weight them: each by `1 / |r|`, floored at
//! a tenth of the mean, so the squares at the centre are the absolute
//! errors the MAPE sums), each in a trust region (Levenberg-Marquardt, the
//! step clipped to the box): the slopes by forward differences of a thousandth
//! of each parameter's range at every new centre, **not counted**, since
//! they stand for what the run itself would give. Each step is one counted
//! run, kept when the MAPE falls (the radius then at least twice the step,
//! at most the box), else the radius halves.

use std::path::Path;

use acq_algorithms::doe::{orthogonal_array_l12, two_level_to_unit};
use acq_algorithms::evaluation::Parameter;
use acq_analysis::extract::tensile_props::{read_test_csv, tensile_properties, SpecimenGeometry};
use acq_analysis::loss::curve::{CurveMapeOptions, TestCurve};
use acq_workflows::calibrate::gtn::parameters;
use acq_workflows::tensile_model::{GtnInputs, ModelSettings, TensileModel};

/// The residuals: the curve's signed errors in this many parts.
const PARTS: usize = 20;
/// A slope's forward difference, in units of the parameter's range.
const DIFFERENCE_STEP: f64 = 1e-3;
/// The first trust radius, in the unit box.
const FIRST_RADIUS: f64 = 0.2;

/// What one test's search came to.
pub struct SlopesSearch {
    /// Counted simulations to the target (None: not within the budget).
    pub to_target: Option<usize>,
    pub best_mape_pct: f64,
    pub counted: usize,
    /// The uncounted runs the slopes took.
    pub slope_runs: usize,
}

/// A test and its model, scoring a point of the unit box.
struct Scorer {
    model: TensileModel,
    test: TestCurve,
    options: CurveMapeOptions,
    search_box: Vec<Parameter>,
}

/// A point of the unit box with its MAPE and part errors, %.
#[derive(Clone)]
struct Scored {
    unit_point: Vec<f64>,
    mape_pct: f64,
    part_errors_pct: Vec<f64>,
}

impl Scorer {
    /// The test as the calibration takes it: E, the flow curve and m's
    /// bound re-derived from it, the default mesh.
    fn new(test_csv: &Path) -> Self {
        let points = read_test_csv(test_csv).expect("test");
        let properties = tensile_properties(&points, SpecimenGeometry::default()).expect("props");
        let search_box = parameters(properties.post_uts_slope.upper_bound_mpa.max(1.0));
        let curve: Vec<(f64, f64)> = points
            .iter()
            .map(|p| (p.displacement_mm, p.force_kn))
            .collect();
        let options = CurveMapeOptions {
            split_at_mm: Some(properties.uts.displacement_mm),
            ..CurveMapeOptions::default()
        };
        Scorer {
            model: TensileModel::new(points, properties, ModelSettings::default()),
            test: TestCurve::new(&curve).expect("test curve"),
            options,
            search_box,
        }
    }

    fn score(&self, unit_point: &[f64]) -> Option<Scored> {
        let values: Vec<f64> = self
            .search_box
            .iter()
            .zip(unit_point)
            .map(|(p, &u)| p.from_unit(u.clamp(0.0, 1.0)))
            .collect();
        let inputs = GtnInputs::from_values(&values).ok()?;
        let pulled = self.model.pull(&inputs).ok()?;
        let simulation: Vec<(f64, f64)> = pulled
            .curve
            .iter()
            .map(|p| (p.displacement_mm, p.force_kn))
            .collect();
        let (mape, parts) = self
            .test
            .errors_by_part(&simulation, self.options, PARTS)
            .ok()?;
        Some(Scored {
            unit_point: unit_point.to_vec(),
            mape_pct: mape.mape_percent,
            part_errors_pct: parts,
        })
    }

    /// The part errors' slopes at `centre`, a row per part, by forward
    /// differences (backward at the box's upper face), on both cores.
    fn slopes(&self, centre: &Scored) -> Vec<Vec<f64>> {
        let columns: Vec<Vec<f64>> = std::thread::scope(|scope| {
            let handles: Vec<_> = (0..centre.unit_point.len())
                .map(|k| {
                    scope.spawn(move || {
                        let mut moved = centre.unit_point.clone();
                        let step = if moved[k] + DIFFERENCE_STEP <= 1.0 {
                            DIFFERENCE_STEP
                        } else {
                            -DIFFERENCE_STEP
                        };
                        moved[k] += step;
                        match self.score(&moved) {
                            Some(run) => run
                                .part_errors_pct
                                .iter()
                                .zip(&centre.part_errors_pct)
                                .map(|(a, b)| (a - b) / step)
                                .collect(),
                            None => vec![0.0; centre.part_errors_pct.len()],
                        }
                    })
                })
                .collect();
            handles
                .into_iter()
                .map(|h| h.join().expect("a slope's run"))
                .collect()
        });
        (0..centre.part_errors_pct.len())
            .map(|part| columns.iter().map(|column| column[part]).collect())
            .collect()
    }
}

/// One test searched as the module says, within `budget` counted runs.
pub fn search_with_slopes(test_csv: &Path, target_mape_pct: f64, budget: usize) -> SlopesSearch {
    let scorer = Scorer::new(test_csv);
    let start = two_level_to_unit(&orthogonal_array_l12(scorer.search_box.len()).expect("L12"));
    let mut counted = 0;
    let mut to_target = None;
    let mut best: Option<Scored> = None;
    let reached = |run: &Scored, counted: usize, to_target: Option<usize>| {
        to_target.or((run.mape_pct < target_mape_pct).then_some(counted))
    };
    for point in &start {
        counted += 1;
        if let Some(run) = scorer.score(point) {
            to_target = reached(&run, counted, to_target);
            if best.as_ref().is_none_or(|b| run.mape_pct < b.mape_pct) {
                best = Some(run);
            }
        }
    }
    let mut centre = best.expect("a start run simulates");
    let mut radius = FIRST_RADIUS;
    let mut slope_runs = 0;
    let mut slopes: Option<Vec<Vec<f64>>> = None;
    while to_target.is_none() && counted < budget {
        let jacobian = slopes.get_or_insert_with(|| {
            slope_runs += centre.unit_point.len();
            scorer.slopes(&centre)
        });
        let step = levenberg_marquardt_step(jacobian, &centre.part_errors_pct, radius);
        let trial: Vec<f64> = centre
            .unit_point
            .iter()
            .zip(&step)
            .map(|(c, s)| (c + s).clamp(0.0, 1.0))
            .collect();
        let taken = distance(&trial, &centre.unit_point);
        counted += 1;
        match scorer.score(&trial) {
            Some(run) if run.mape_pct < centre.mape_pct => {
                to_target = reached(&run, counted, to_target);
                centre = run;
                slopes = None;
                radius = (2.0 * taken).max(radius).min(1.0);
            }
            _ => radius = 0.5 * taken.max(1e-6),
        }
    }
    SlopesSearch {
        to_target,
        best_mape_pct: centre.mape_pct,
        counted,
        slope_runs,
    }
}

fn distance(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).powi(2))
        .sum::<f64>()
        .sqrt()
}

/// The step minimising `sum w (r + J s)^2` with `|s|` at most `radius`
/// (`w` as the module says): the Gauss-Newton step if it is that short,
/// else `(J'WJ + lambda D) s = -J'Wr` with lambda found by bisection (D:
/// J'WJ's largest diagonal, times one).
fn levenberg_marquardt_step(jacobian: &[Vec<f64>], residuals: &[f64], radius: f64) -> Vec<f64> {
    let d = jacobian.first().map_or(0, Vec::len);
    let mean = residuals.iter().map(|r| r.abs()).sum::<f64>() / residuals.len().max(1) as f64;
    let floor = (0.1 * mean).max(f64::MIN_POSITIVE);
    let mut normal = nalgebra::DMatrix::<f64>::zeros(d, d);
    let mut gradient = nalgebra::DVector::<f64>::zeros(d);
    for (row, &r) in jacobian.iter().zip(residuals) {
        let weight = 1.0 / r.abs().max(floor);
        let row = nalgebra::DVector::from_column_slice(row);
        normal += &row * row.transpose() * weight;
        gradient -= row * (weight * r);
    }
    let scale = normal.diagonal().max().max(f64::MIN_POSITIVE);
    let step_with = |lambda: f64| {
        let mut damped = normal.clone();
        for a in 0..d {
            // A trace of damping keeps a rank-deficient J'J solvable.
            damped[(a, a)] += (lambda + 1e-12) * scale;
        }
        damped
            .cholesky()
            .map_or_else(|| nalgebra::DVector::zeros(d), |c| c.solve(&gradient))
    };
    let gauss_newton = step_with(0.0);
    if gauss_newton.norm() <= radius {
        return gauss_newton.as_slice().to_vec();
    }
    let (mut low, mut high) = (0.0, 1.0);
    while step_with(high).norm() > radius && high < 1e12 {
        high *= 10.0;
    }
    for _ in 0..60 {
        let middle = 0.5 * (low + high);
        if step_with(middle).norm() > radius {
            low = middle;
        } else {
            high = middle;
        }
    }
    step_with(high).as_slice().to_vec()
}
