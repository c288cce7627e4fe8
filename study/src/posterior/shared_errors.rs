//! Errors the observations share: a transducer's calibration error is the
//! same in every hold it measured, so no number of holds averages it away
//! (JCGM 100 5.2; `../shared` reference: "systematic errors are shared").
//!
//! Each shared source `t` is one normal error, standardised `z_t ~ N(0, 1)`,
//! that moves observation `i` by `S[i][t] z_t` (the budget's `c u`, signed).
//! Integrated out, it leaves the residuals jointly normal with covariance
//! `diag(v) + S S'`, `v` each observation's own variance: exact for the
//! linear-Gaussian error the budget states, and no extra coordinate for
//! the sampler. Without shared sources the covariance is diagonal and every
//! density below is the diagonal one, term for term.

use std::f64::consts::PI;

use nalgebra::{Cholesky, DMatrix, DVector, Dyn};

/// The smallest share of an observation's variance left as its own when
/// its shared parts take (nearly) all of it: keeps `diag(v) + S S'`
/// positive definite (a value whose whole error is its transducer's, no
/// scatter stated).
pub const LEAST_OWN_SHARE: f64 = 1e-6;

/// The covariance `diag(v) + S S'` of a group of observations' errors,
/// ready to solve with.
#[derive(Clone, Debug)]
pub enum ErrorCovariance {
    /// No shared source: `diag(v)`.
    Diagonal(DVector<f64>),
    /// With shared sources: its Cholesky factor and log determinant.
    Full {
        cholesky: Cholesky<f64, Dyn>,
        matrix: DMatrix<f64>,
        log_det: f64,
    },
}

impl ErrorCovariance {
    /// `diag(variances) + loadings loadings'` (`loadings`: a row per
    /// observation, a column per shared source; no column: diagonal).
    /// `None` when it is not positive definite (a variance not above 0).
    pub fn new(variances: DVector<f64>, loadings: &DMatrix<f64>) -> Option<Self> {
        if variances.iter().any(|v| !(*v > 0.0 && v.is_finite())) {
            return None;
        }
        if loadings.ncols() == 0 || loadings.iter().all(|l| *l == 0.0) {
            return Some(ErrorCovariance::Diagonal(variances));
        }
        let matrix = DMatrix::from_diagonal(&variances) + loadings * loadings.transpose();
        let cholesky = matrix.clone().cholesky()?;
        let log_det = 2.0
            * cholesky
                .l_dirty()
                .diagonal()
                .iter()
                .map(|d| d.ln())
                .sum::<f64>();
        Some(ErrorCovariance::Full {
            cholesky,
            matrix,
            log_det,
        })
    }

    /// `C^-1 x`.
    pub fn solve(&self, x: &DVector<f64>) -> DVector<f64> {
        match self {
            ErrorCovariance::Diagonal(v) => x.component_div(v),
            ErrorCovariance::Full { cholesky, .. } => cholesky.solve(x),
        }
    }

    /// `ln det C`.
    pub fn log_det(&self) -> f64 {
        match self {
            ErrorCovariance::Diagonal(v) => v.iter().map(|v| v.ln()).sum(),
            ErrorCovariance::Full { log_det, .. } => *log_det,
        }
    }

    /// `C` itself.
    pub fn matrix(&self) -> DMatrix<f64> {
        match self {
            ErrorCovariance::Diagonal(v) => DMatrix::from_diagonal(v),
            ErrorCovariance::Full { matrix, .. } => matrix.clone(),
        }
    }

    /// The normal log density of `residuals` with this covariance.
    pub fn log_density(&self, residuals: &DVector<f64>) -> f64 {
        let quadratic = match self {
            ErrorCovariance::Diagonal(v) => {
                residuals.iter().zip(v.iter()).map(|(r, v)| r * r / v).sum()
            }
            ErrorCovariance::Full { cholesky, .. } => residuals.dot(&cholesky.solve(residuals)),
        };
        -0.5 * (quadratic + self.log_det() + residuals.len() as f64 * (2.0 * PI).ln())
    }

    /// `L^-1` and `ln det C` for whitening: `C = L L'`, so `L^-1 r` has
    /// unit covariance (for the diagonal, `diag(v)^-1/2`).
    pub fn inverse_factor(&self) -> DMatrix<f64> {
        match self {
            ErrorCovariance::Diagonal(v) => DMatrix::from_diagonal(&v.map(|v| 1.0 / v.sqrt())),
            ErrorCovariance::Full { cholesky, .. } => {
                let n = cholesky.l_dirty().nrows();
                cholesky
                    .l()
                    .solve_lower_triangular(&DMatrix::identity(n, n))
                    .unwrap_or_else(|| DMatrix::from_element(n, n, f64::NAN))
            }
        }
    }
}

/// The loadings of `rows` (observation indices) on every shared source
/// that touches one of them: a row per observation, a column per source
/// in the order they first appear. `shared[i]` is observation `i`'s
/// `(source, effect)` list.
pub fn loadings_of(rows: &[usize], shared: &[Vec<(usize, f64)>]) -> DMatrix<f64> {
    let mut sources: Vec<usize> = Vec::new();
    for &i in rows {
        for &(source, _) in &shared[i] {
            if !sources.contains(&source) {
                sources.push(source);
            }
        }
    }
    let mut matrix = DMatrix::zeros(rows.len(), sources.len());
    for (row, &i) in rows.iter().enumerate() {
        for &(source, effect) in &shared[i] {
            if let Some(column) = sources.iter().position(|s| *s == source) {
                matrix[(row, column)] += effect;
            }
        }
    }
    matrix
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two holds of one transducer: the density is the bivariate normal
    /// with covariance `[[v0 + s^2, s^2], [s^2, v1 + s^2]]`, by hand.
    #[test]
    fn two_holds_of_one_transducer_have_the_bivariate_normal_density() {
        let (v0, v1, s) = (0.04, 0.09, 1.2);
        let covariance = ErrorCovariance::new(
            DVector::from_vec(vec![v0, v1]),
            &DMatrix::from_row_slice(2, 1, &[s, s]),
        )
        .unwrap();
        let (r0, r1): (f64, f64) = (0.7, 1.1);
        let (a, b, c) = (v0 + s * s, s * s, v1 + s * s);
        let det = a * c - b * b;
        let quadratic = (c * r0 * r0 - 2.0 * b * r0 * r1 + a * r1 * r1) / det;
        let expected = -0.5 * (quadratic + det.ln() + 2.0 * (2.0 * PI).ln());
        let got = covariance.log_density(&DVector::from_vec(vec![r0, r1]));
        assert!((got - expected).abs() < 1e-12, "{got} {expected}");
        // Whitening: L^-1 C L^-T is the identity.
        let w = covariance.inverse_factor();
        let identity = &w * covariance.matrix() * w.transpose();
        assert!((identity - DMatrix::identity(2, 2)).abs().max() < 1e-12);
    }

    #[test]
    fn without_shared_sources_the_covariance_is_diagonal() {
        let covariance =
            ErrorCovariance::new(DVector::from_vec(vec![1.0, 4.0]), &DMatrix::zeros(2, 0)).unwrap();
        assert!(matches!(covariance, ErrorCovariance::Diagonal(_)));
        let got = covariance.log_density(&DVector::from_vec(vec![1.0, 2.0]));
        let expected = -0.5 * (1.0 + 1.0 + 4f64.ln() + 2.0 * (2.0 * PI).ln());
        assert!((got - expected).abs() < 1e-14);
        assert!(
            ErrorCovariance::new(DVector::from_vec(vec![0.0]), &DMatrix::zeros(1, 0)).is_none()
        );
    }

    #[test]
    fn loadings_take_each_source_once_with_its_signs() {
        // Observation 0: head +1; 1: head +1, rod -0.5; 2: nothing.
        let shared = vec![vec![(3, 1.0)], vec![(3, 1.0), (7, -0.5)], vec![]];
        let m = loadings_of(&[0, 1, 2], &shared);
        assert_eq!(m.ncols(), 2);
        assert_eq!(
            m.row(1).iter().copied().collect::<Vec<_>>(),
            vec![1.0, -0.5]
        );
        assert_eq!(m.row(2).iter().copied().collect::<Vec<_>>(), vec![0.0, 0.0]);
    }
}
