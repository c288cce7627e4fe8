//! The surrogates a GP is compared against, behind one trait, and the held-out RMSE that ranks
//! them: a least-squares polynomial of total degree 1 to 3 and an interpolating cubic
//! radial-basis-function model with a linear tail.

use faer::prelude::*;
use faer::Mat;
use thiserror::Error;

use crate::training_data::DataError;

use crate::gp::Gp;

/// A fitted model of one output over a box of inputs.
pub trait Surrogate {
    /// Prediction at `x` (data units); NaN for a point of the wrong dimension or with
    /// non-finite coordinates.
    fn predict(&self, x: &[f64]) -> f64;
    /// Short name for reports, e.g. "gp", "polynomial-2", "rbf-cubic".
    fn name(&self) -> &str;
}

impl Surrogate for Gp {
    /// The posterior mean.
    fn predict(&self, x: &[f64]) -> f64 {
        Gp::predict(self, x).mean
    }

    fn name(&self) -> &str {
        "gp"
    }
}

/// Root-mean-square error of `surrogate` on the given points (use points it was not fitted
/// on). NaN when there are no points or the two lengths differ.
pub fn rmse(surrogate: &dyn Surrogate, inputs: &[Vec<f64>], outputs: &[f64]) -> f64 {
    if inputs.is_empty() || inputs.len() != outputs.len() {
        return f64::NAN;
    }
    let squares: f64 = inputs
        .iter()
        .zip(outputs)
        .map(|(x, y)| (surrogate.predict(x) - y).powi(2))
        .sum();
    (squares / outputs.len() as f64).sqrt()
}

/// Why a surrogate could not be fitted. Each message says what to do.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum SurrogateError {
    #[error(transparent)]
    Data(#[from] DataError),
    #[error(
        "{points} points for {terms} unknowns: add points or lower the degree (a polynomial of \
         degree p in d inputs has (d+p)!/(d! p!) terms)"
    )]
    TooFewPoints { points: usize, terms: usize },
    #[error("polynomial degree {0}: use 1, 2 or 3")]
    InvalidDegree(usize),
    #[error(
        "the points determine only {rank} of the {terms} unknowns: spread the points over the \
         box (they lie on a lower-dimensional set, or an input is constant) or lower the degree"
    )]
    RankDeficient { rank: usize, terms: usize },
    #[error(
        "input bounds: {0}; give one finite (lower, upper) with lower < upper per input, or \
         None to use the data's range"
    )]
    InvalidBounds(String),
    #[error(
        "rows {first} and {second} have the same inputs: an interpolating RBF cannot take two \
         values at one point; average or drop duplicates"
    )]
    DuplicatePoints { first: usize, second: usize },
}

/// Per-input affine map of the data's bounding box onto the unit box.
#[derive(Clone, Debug, PartialEq)]
struct BoxScaling {
    low: Vec<f64>,
    width: Vec<f64>,
}

impl BoxScaling {
    /// From the given bounds, else from the data's min/max.
    fn new(
        inputs: &[Vec<f64>],
        d: usize,
        bounds: Option<&[(f64, f64)]>,
    ) -> Result<Self, SurrogateError> {
        let Some(bounds) = bounds else {
            return Ok(Self::from_data(inputs, d));
        };
        if bounds.len() != d {
            return Err(SurrogateError::InvalidBounds(format!(
                "{} bounds for {d} inputs",
                bounds.len()
            )));
        }
        if let Some(k) = bounds
            .iter()
            .position(|(lo, hi)| !(lo.is_finite() && hi.is_finite() && lo < hi))
        {
            return Err(SurrogateError::InvalidBounds(format!(
                "input {k} has {:?}",
                bounds[k]
            )));
        }
        Ok(Self {
            low: bounds.iter().map(|b| b.0).collect(),
            width: bounds.iter().map(|b| b.1 - b.0).collect(),
        })
    }

    /// The data's bounding box; a constant input keeps width 1 (the rank
    /// check then reports it).
    fn from_data(inputs: &[Vec<f64>], d: usize) -> Self {
        let (low, width) = crate::training_data::data_box(inputs, d);
        Self { low, width }
    }

    /// Into the unit box [0, 1]^d; None for a point of the wrong dimension or non-finite.
    fn unit(&self, x: &[f64]) -> Option<Vec<f64>> {
        if x.len() != self.low.len() || x.iter().any(|v| !v.is_finite()) {
            return None;
        }
        Some(
            x.iter()
                .zip(self.low.iter().zip(&self.width))
                .map(|(v, (lo, w))| (v - lo) / w)
                .collect(),
        )
    }
}

/// Full polynomial of total degree 1, 2 or 3, fitted by least squares (column-pivoted QR).
///
/// The monomials are in the inputs mapped to [-1, 1] (the unit box, centred; the box is the
/// given input bounds or the data's range): on [0, 1] the powers x, x^2, x^3 are nearly
/// collinear and the least-squares problem loses digits. The fitted function does not depend
/// on the box, only the conditioning does.
#[derive(Clone, Debug, PartialEq)]
pub struct Polynomial {
    degree: usize,
    scaling: BoxScaling,
    /// One exponent per input for each term, constant term first.
    exponents: Vec<Vec<u8>>,
    coefficients: Vec<f64>,
    name: String,
}

/// All exponent vectors of `d` inputs with total degree <= `degree`, by increasing degree.
fn monomial_exponents(d: usize, degree: usize) -> Vec<Vec<u8>> {
    let mut terms = vec![vec![0u8; d]];
    let mut previous = vec![vec![0u8; d]];
    for _ in 0..degree {
        // Each term of the next degree raises one input of a term of this degree; raising
        // only inputs at or after the term's last nonzero one generates each exactly once.
        let mut next = Vec::new();
        for term in &previous {
            let first = term.iter().rposition(|&e| e > 0).unwrap_or(0);
            for k in first..d {
                let mut raised = term.clone();
                raised[k] += 1;
                next.push(raised);
            }
        }
        terms.extend(next.iter().cloned());
        previous = next;
    }
    terms
}

fn monomial(exponents: &[u8], centred: &[f64]) -> f64 {
    exponents
        .iter()
        .zip(centred)
        .map(|(&e, &z)| z.powi(i32::from(e)))
        .product()
}

/// Relative size below which a pivot of R counts as zero: far above rounding (1e-16) yet
/// far below any honestly determined term.
const RANK_TOLERANCE: f64 = 1e-10;

/// Numerical rank from the R of a column-pivoted QR (its diagonal decreases in magnitude).
fn rank_from_pivoted_r(r: MatRef<'_, f64>, columns: usize) -> usize {
    let largest = r[(0, 0)].abs();
    (0..columns.min(r.nrows()))
        .take_while(|&k| r[(k, k)].abs() > RANK_TOLERANCE * largest)
        .count()
}

/// Numerical column rank of a tall matrix.
fn full_column_rank(matrix: &Mat<f64>) -> usize {
    let qr = matrix.col_piv_qr();
    rank_from_pivoted_r(qr.R(), matrix.ncols())
}

impl Polynomial {
    /// Least-squares fit of all monomials of total degree <= `degree` (1..=3). Needs at least
    /// as many points as terms, spread so that they determine every term. `input_bounds`
    /// (one `(lower, upper)` per input) sets the box; `None` uses the data's range.
    pub fn fit(
        inputs: &[Vec<f64>],
        outputs: &[f64],
        degree: usize,
        input_bounds: Option<&[(f64, f64)]>,
    ) -> Result<Polynomial, SurrogateError> {
        if !(1..=3).contains(&degree) {
            return Err(SurrogateError::InvalidDegree(degree));
        }
        let d = crate::training_data::check(inputs, outputs)?;
        let exponents = monomial_exponents(d, degree);
        let (n, terms) = (outputs.len(), exponents.len());
        if n < terms {
            return Err(SurrogateError::TooFewPoints { points: n, terms });
        }
        let scaling = BoxScaling::new(inputs, d, input_bounds)?;
        let centred: Vec<Vec<f64>> = inputs
            .iter()
            .map(|x| {
                scaling
                    .unit(x)
                    .unwrap_or_default()
                    .iter()
                    .map(|z| 2.0 * z - 1.0)
                    .collect()
            })
            .collect();
        let design = Mat::from_fn(n, terms, |i, j| monomial(&exponents[j], &centred[i]));
        let qr = design.col_piv_qr();
        let rank = rank_from_pivoted_r(qr.R(), terms);
        if rank < terms {
            return Err(SurrogateError::RankDeficient { rank, terms });
        }
        let rhs = Mat::from_fn(n, 1, |i, _| outputs[i]);
        let solution = qr.solve_lstsq(&rhs);
        let coefficients: Vec<f64> = (0..terms).map(|j| solution[(j, 0)]).collect();
        if coefficients.iter().any(|c| !c.is_finite()) {
            return Err(SurrogateError::RankDeficient { rank: 0, terms });
        }
        Ok(Polynomial {
            degree,
            scaling,
            exponents,
            coefficients,
            name: format!("polynomial-{degree}"),
        })
    }

    pub fn degree(&self) -> usize {
        self.degree
    }

    /// Number of monomials, (d + degree)! / (d! degree!).
    pub fn n_terms(&self) -> usize {
        self.exponents.len()
    }
}

impl Surrogate for Polynomial {
    fn predict(&self, x: &[f64]) -> f64 {
        let Some(unit) = self.scaling.unit(x) else {
            return f64::NAN;
        };
        let centred: Vec<f64> = unit.iter().map(|z| 2.0 * z - 1.0).collect();
        self.exponents
            .iter()
            .zip(&self.coefficients)
            .map(|(e, c)| c * monomial(e, &centred))
            .sum()
    }

    fn name(&self) -> &str {
        &self.name
    }
}

/// Interpolating radial-basis-function model with the cubic kernel phi(r) = r^3 and a linear
/// polynomial tail, on inputs scaled to the unit box (the given input bounds or the data's
/// range: distances then weigh every input by its range, not by its unit):
/// `s(x) = sum_i w_i |x - x_i|^3 + c_0 + sum_k c_k x_k`, with `sum_i w_i p(x_i) = 0` for every
/// linear p.
///
/// The cubic is the standard choice for surrogate-based optimisation (Gutmann; Regis &
/// Shoemaker): it has no shape parameter to tune, and with the linear tail the interpolation
/// system is uniquely solvable for any distinct points not all on one hyperplane, and
/// reproduces linear functions exactly.
#[derive(Clone, Debug, PartialEq)]
pub struct RadialBasis {
    scaling: BoxScaling,
    /// Training inputs in the unit box, row-major.
    centres: Vec<f64>,
    weights: Vec<f64>,
    /// Constant, then one slope per input (unit-box units).
    tail: Vec<f64>,
}

/// Relative residual above which the interpolation solve is judged to have failed.
const RESIDUAL_TOLERANCE: f64 = 1e-8;

impl RadialBasis {
    /// Interpolates the points. Needs at least d + 1 distinct points not on one hyperplane.
    /// `input_bounds` (one `(lower, upper)` per input) sets the unit box; `None` uses the
    /// data's range.
    pub fn fit(
        inputs: &[Vec<f64>],
        outputs: &[f64],
        input_bounds: Option<&[(f64, f64)]>,
    ) -> Result<RadialBasis, SurrogateError> {
        let d = crate::training_data::check(inputs, outputs)?;
        let n = outputs.len();
        if n < d + 1 {
            return Err(SurrogateError::TooFewPoints {
                points: n,
                terms: d + 1,
            });
        }
        let scaling = BoxScaling::new(inputs, d, input_bounds)?;
        let centres: Vec<f64> = inputs
            .iter()
            .flat_map(|x| scaling.unit(x).unwrap_or_default())
            .collect();
        for first in 0..n {
            for second in first + 1..n {
                if centres[first * d..(first + 1) * d] == centres[second * d..(second + 1) * d] {
                    return Err(SurrogateError::DuplicatePoints { first, second });
                }
            }
        }
        let row = |i: usize| &centres[i * d..(i + 1) * d];
        // Unique solvability needs the tail's basis [1 x] to have full column rank (points not
        // all on one hyperplane); a singular system with consistent data would otherwise still
        // "solve", to one of infinitely many interpolants.
        let tail_matrix = Mat::from_fn(n, d + 1, |i, j| tail_basis(row(i), j));
        let rank = full_column_rank(&tail_matrix);
        if rank < d + 1 {
            return Err(SurrogateError::RankDeficient { rank, terms: d + 1 });
        }
        // [Phi P; P' 0] [w; c] = [y; 0], P = [1 x].
        let size = n + d + 1;
        let system = Mat::from_fn(size, size, |i, j| match (i < n, j < n) {
            (true, true) => cubic(distance(row(i), row(j))),
            (true, false) => tail_basis(row(i), j - n),
            (false, true) => tail_basis(row(j), i - n),
            (false, false) => 0.0,
        });
        let rhs = Mat::from_fn(size, 1, |i, _| if i < n { outputs[i] } else { 0.0 });
        let solution = system.partial_piv_lu().solve(&rhs);
        // Not unisolvent (points on a hyperplane) shows as a non-finite or inexact solution.
        let residual = &system * &solution - &rhs;
        let scale = outputs.iter().fold(1.0f64, |m, y| m.max(y.abs()));
        let worst = (0..size).fold(0.0f64, |m, i| m.max(residual[(i, 0)].abs()));
        if worst.is_nan() || worst > RESIDUAL_TOLERANCE * scale {
            return Err(SurrogateError::RankDeficient {
                rank: n,
                terms: size,
            });
        }
        Ok(RadialBasis {
            scaling,
            centres,
            weights: (0..n).map(|i| solution[(i, 0)]).collect(),
            tail: (n..size).map(|i| solution[(i, 0)]).collect(),
        })
    }
}

fn distance(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y) * (x - y))
        .sum::<f64>()
        .sqrt()
}

fn cubic(r: f64) -> f64 {
    r * r * r
}

/// The linear tail's basis: 1, x_1, ..., x_d.
fn tail_basis(x: &[f64], index: usize) -> f64 {
    if index == 0 {
        1.0
    } else {
        x.get(index - 1).copied().unwrap_or(0.0)
    }
}

impl Surrogate for RadialBasis {
    fn predict(&self, x: &[f64]) -> f64 {
        let Some(unit) = self.scaling.unit(x) else {
            return f64::NAN;
        };
        let d = unit.len();
        let radial: f64 = self
            .centres
            .chunks_exact(d)
            .zip(&self.weights)
            .map(|(centre, w)| w * cubic(distance(centre, &unit)))
            .sum();
        let linear: f64 = self
            .tail
            .iter()
            .enumerate()
            .map(|(index, c)| c * tail_basis(&unit, index))
            .sum();
        radial + linear
    }

    fn name(&self) -> &str {
        "rbf-cubic"
    }
}
