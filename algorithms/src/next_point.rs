//! Which test point to run next: of the conditions an operator can set,
//! the one whose measurement is expected to shrink the posterior most.
//!
//! The posterior is taken as Gaussian, `N(m, S)` (the mean and covariance
//! of its draws), and each candidate's outputs as linear in the parameters
//! around `m`: `y_c = y_c(m) + J_c (theta - m) + e`, `e ~ N(0, R_c)` with
//! `R_c` diagonal (the instruments' standard uncertainties). For that
//! model the expected information gain of measuring at `c` is exact:
//!
//! `EIG_c = 1/2 log det(I + R_c^-1/2 J_c S J_c' R_c^-1/2)` (nats),
//!
//! which is the Bayesian D-optimality criterion (the log ratio of the
//! posterior volumes before and after), and the posterior after it is
//!
//! `S'_c = S - S J_c' (J_c S J_c' + R_c)^-1 J_c S`,
//!
//! whose diagonal says which parameter the point narrows, from what to
//! what. Where only some parameters are of interest (the others nuisance,
//! or disputed), the criterion is the gain on their marginal, `1/2 log
//! (det S_ii / det S'_ii)` over their block `i` (Ds-optimality), which is
//! `EIG_c` when every parameter is of interest. Both are computed through the Cholesky factor of the small
//! `outputs x outputs` matrix `J_c S J_c' + R_c`, so a thousand candidates
//! cost a thousand small factorisations. A nonlinear model is as good as
//! its linearisation over the posterior's width: the caller gives `J_c`
//! at the posterior mean.

use faer::prelude::*;
use faer::{Mat, Side};

/// One condition the operator can set, as the model sees it there.
#[derive(Clone, Debug, PartialEq)]
pub struct Candidate {
    /// d output / d parameter at the posterior mean: one row per output.
    pub jacobian: Vec<Vec<f64>>,
    /// Each output's measurement standard uncertainty (> 0).
    pub noise_sd: Vec<f64>,
}

/// What measuring at one candidate is expected to do.
#[derive(Clone, Debug, PartialEq)]
pub struct Gain {
    /// Expected information gain, nats.
    pub information_nats: f64,
    /// The part of it on the parameters of interest (their marginal's),
    /// nats: what chooses the candidate.
    pub interest_nats: f64,
    /// Each parameter's standard deviation after the measurement.
    pub sd_after: Vec<f64>,
}

/// The best candidate and what every candidate would give.
#[derive(Clone, Debug, PartialEq)]
pub struct NextPoint {
    pub best: usize,
    /// Each parameter's standard deviation now.
    pub sd_before: Vec<f64>,
    /// Per candidate, in the order given.
    pub gains: Vec<Gain>,
}

/// Why no next point can be named.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum NextPointError {
    #[error("no candidate conditions to choose from")]
    NoCandidates,
    #[error("the posterior covariance is not square ({rows} rows of {parameters})")]
    Covariance { rows: usize, parameters: usize },
    #[error(
        "candidate {candidate}: a Jacobian row has {columns} columns for {parameters} parameters"
    )]
    Shape {
        candidate: usize,
        columns: usize,
        parameters: usize,
    },
    #[error("candidate {candidate}: {outputs} outputs but {uncertainties} standard uncertainties")]
    Uncertainties {
        candidate: usize,
        outputs: usize,
        uncertainties: usize,
    },
    #[error(
        "candidate {candidate}: a standard uncertainty must be positive and finite, got {value}"
    )]
    BadUncertainty { candidate: usize, value: f64 },
    #[error("candidate {candidate}: its Jacobian is not finite")]
    NotFinite { candidate: usize },
    #[error("parameter {index} of interest, of {parameters} parameters")]
    Interest { index: usize, parameters: usize },
}

fn to_mat(rows: &[Vec<f64>], columns: usize) -> Mat<f64> {
    Mat::from_fn(rows.len(), columns, |i, j| rows[i][j])
}

/// What measuring at `candidate` would do to the posterior `covariance`
/// (square, parameters x parameters), the parameters of interest those
/// `interest` indexes. Shapes as [`next_point`] checks them.
pub fn gain(covariance: &[Vec<f64>], candidate: &Candidate, interest: &[usize]) -> Gain {
    let parameters = covariance.len();
    let s = to_mat(covariance, parameters);
    let j = to_mat(&candidate.jacobian, parameters);
    let s_jt = &s * j.transpose(); // S J'
    let mut predicted = &j * &s_jt; // J S J'
    for (k, sd) in candidate.noise_sd.iter().enumerate() {
        predicted[(k, k)] += sd * sd;
    }
    let unchanged = || Gain {
        information_nats: 0.0,
        interest_nats: 0.0,
        sd_after: (0..parameters)
            .map(|p| covariance[p][p].max(0.0).sqrt())
            .collect(),
    };
    // log det(J S J' + R) - log det(R) = log det(I + R^-1/2 J S J' R^-1/2).
    let Ok(llt) = predicted.llt(Side::Lower) else {
        return unchanged();
    };
    let lower = llt.L();
    let log_det_predicted: f64 = (0..lower.nrows()).map(|k| 2.0 * lower[(k, k)].ln()).sum();
    let log_det_noise: f64 = candidate.noise_sd.iter().map(|sd| 2.0 * sd.ln()).sum();
    // diag(S J' (J S J' + R)^-1 J S).
    let solved = llt.solve(s_jt.transpose().to_owned()); // (J S J' + R)^-1 J S
    let reduction =
        |p: usize, q: usize| -> f64 { (0..j.nrows()).map(|k| s_jt[(p, k)] * solved[(k, q)]).sum() };
    let sd_after = (0..parameters)
        .map(|p| (covariance[p][p] - reduction(p, p)).max(0.0).sqrt())
        .collect();
    let information_nats = 0.5 * (log_det_predicted - log_det_noise);
    let interest_nats = if interest.len() == parameters {
        information_nats
    } else {
        let block = |after: bool| {
            Mat::from_fn(interest.len(), interest.len(), |a, b| {
                let (p, q) = (interest[a], interest[b]);
                covariance[p][q] - if after { reduction(p, q) } else { 0.0 }
            })
        };
        match (log_det(block(false)), log_det(block(true))) {
            (Some(before), Some(after)) => 0.5 * (before - after),
            // A block with no variance left: nothing more to learn on it.
            _ => 0.0,
        }
    };
    Gain {
        information_nats,
        interest_nats,
        sd_after,
    }
}

/// log det of a symmetric positive definite matrix; `None` if it is not.
fn log_det(matrix: Mat<f64>) -> Option<f64> {
    let llt = matrix.llt(Side::Lower).ok()?;
    let lower = llt.L();
    Some((0..lower.nrows()).map(|k| 2.0 * lower[(k, k)].ln()).sum())
}

/// The candidate with the largest expected information gain on the
/// parameters `interest` indexes (every parameter: `EIG_c`), and what each
/// would do; `covariance`: the posterior's, parameters x parameters.
pub fn next_point(
    covariance: &[Vec<f64>],
    candidates: &[Candidate],
    interest: &[usize],
) -> Result<NextPoint, NextPointError> {
    let parameters = covariance.len();
    if let Some(row) = covariance.iter().find(|r| r.len() != parameters) {
        return Err(NextPointError::Covariance {
            rows: parameters,
            parameters: row.len(),
        });
    }
    if candidates.is_empty() {
        return Err(NextPointError::NoCandidates);
    }
    for (index, c) in candidates.iter().enumerate() {
        if let Some(row) = c.jacobian.iter().find(|r| r.len() != parameters) {
            return Err(NextPointError::Shape {
                candidate: index,
                columns: row.len(),
                parameters,
            });
        }
        if c.noise_sd.len() != c.jacobian.len() {
            return Err(NextPointError::Uncertainties {
                candidate: index,
                outputs: c.jacobian.len(),
                uncertainties: c.noise_sd.len(),
            });
        }
        if let Some(&value) = c.noise_sd.iter().find(|v| !(v.is_finite() && **v > 0.0)) {
            return Err(NextPointError::BadUncertainty {
                candidate: index,
                value,
            });
        }
        if c.jacobian.iter().flatten().any(|v| !v.is_finite()) {
            return Err(NextPointError::NotFinite { candidate: index });
        }
    }
    if let Some(&index) = interest.iter().find(|&&p| p >= parameters) {
        return Err(NextPointError::Interest { index, parameters });
    }
    let gains: Vec<Gain> = candidates
        .iter()
        .map(|c| gain(covariance, c, interest))
        .collect();
    let best = gains
        .iter()
        .enumerate()
        .max_by(|a, b| a.1.interest_nats.total_cmp(&b.1.interest_nats))
        .map_or(0, |(i, _)| i);
    Ok(NextPoint {
        best,
        sd_before: (0..parameters)
            .map(|p| covariance[p][p].max(0.0).sqrt())
            .collect(),
        gains,
    })
}

/// The mean and covariance of posterior draws (one `Vec` per draw).
pub fn draws_moments(draws: &[Vec<f64>]) -> Option<(Vec<f64>, Vec<Vec<f64>>)> {
    let n = draws.len();
    let d = draws.first()?.len();
    if n < 2 || draws.iter().any(|x| x.len() != d) {
        return None;
    }
    let mean: Vec<f64> = (0..d)
        .map(|i| draws.iter().map(|x| x[i]).sum::<f64>() / n as f64)
        .collect();
    let covariance = (0..d)
        .map(|i| {
            (0..d)
                .map(|j| {
                    draws
                        .iter()
                        .map(|x| (x[i] - mean[i]) * (x[j] - mean[j]))
                        .sum::<f64>()
                        / (n - 1) as f64
                })
                .collect()
        })
        .collect();
    Some((mean, covariance))
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{DMatrix, DVector};
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;
    use rand_distr::{Distribution, Normal};

    /// A nalgebra matrix as rows (nalgebra checks faer's arithmetic here).
    fn rows(m: &DMatrix<f64>) -> Vec<Vec<f64>> {
        (0..m.nrows())
            .map(|i| m.row(i).iter().copied().collect())
            .collect()
    }

    #[test]
    fn one_parameter_matches_the_closed_form() {
        // sigma' ^2 = sigma^2 r^2 / (sigma^2 j^2 + r^2); EIG = 1/2 ln(1 + j^2 sigma^2 / r^2).
        let (sigma, j, r) = (2.0f64, 3.0f64, 1.5f64);
        let covariance = vec![vec![sigma * sigma]];
        let candidate = Candidate {
            jacobian: vec![vec![j]],
            noise_sd: vec![r],
        };
        let g = gain(&covariance, &candidate, &[0]);
        let expected_sd = (sigma * sigma * r * r / (sigma * sigma * j * j + r * r)).sqrt();
        assert!((g.sd_after[0] - expected_sd).abs() < 1e-12, "{g:?}");
        let expected_eig = 0.5 * (1.0 + j * j * sigma * sigma / (r * r)).ln();
        assert!((g.information_nats - expected_eig).abs() < 1e-12);
    }

    #[test]
    fn the_point_that_sees_the_unknown_direction_wins() {
        // a is known to 0.1, b only to 5: a point that measures b wins over
        // one that measures a with the same instrument.
        let covariance = vec![vec![0.01, 0.0], vec![0.0, 25.0]];
        let sees_a = Candidate {
            jacobian: vec![vec![1.0, 0.0]],
            noise_sd: vec![0.5],
        };
        let sees_b = Candidate {
            jacobian: vec![vec![0.0, 1.0]],
            noise_sd: vec![0.5],
        };
        let next = next_point(&covariance, &[sees_a.clone(), sees_b.clone()], &[0, 1]).unwrap();
        assert_eq!(next.best, 1);
        assert!((next.sd_before[1] - 5.0).abs() < 1e-12);
        assert!(next.gains[1].sd_after[1] < 0.5);
        // Measuring b leaves a where it was.
        assert!((next.gains[1].sd_after[0] - 0.1).abs() < 1e-12);
        // With only a of interest (b disputed), the point that sees a wins,
        // and seeing b gains nothing on a.
        let on_a = next_point(&covariance, &[sees_a, sees_b], &[0]).unwrap();
        assert_eq!(on_a.best, 0);
        assert!(on_a.gains[1].interest_nats.abs() < 1e-12, "{on_a:?}");
    }

    /// The gain on some parameters equals their marginal's, computed the
    /// long way: 1/2 ln(det S_ii / det S'_ii) with S' from the information
    /// form; on every parameter it is the whole EIG.
    #[test]
    fn the_gain_on_some_parameters_is_their_marginals() {
        let covariance =
            DMatrix::from_row_slice(3, 3, &[4.0, 1.2, -0.5, 1.2, 2.0, 0.3, -0.5, 0.3, 1.0]);
        let jacobian = DMatrix::from_row_slice(2, 3, &[1.0, -2.0, 0.5, 0.3, 0.0, 4.0]);
        let noise = [0.7, 1.3];
        let candidate = Candidate {
            jacobian: rows(&jacobian),
            noise_sd: noise.to_vec(),
        };
        let r_inverse = DMatrix::from_diagonal(&DVector::from_iterator(
            2,
            noise.iter().map(|s| 1.0 / (s * s)),
        ));
        let after = (covariance.clone().try_inverse().unwrap()
            + jacobian.transpose() * &r_inverse * &jacobian)
            .try_inverse()
            .unwrap();
        for interest in [vec![0], vec![2], vec![0, 2], vec![1, 2]] {
            let g = gain(&rows(&covariance), &candidate, &interest);
            let block = |m: &DMatrix<f64>| {
                DMatrix::from_fn(interest.len(), interest.len(), |a, b| {
                    m[(interest[a], interest[b])]
                })
            };
            let expected =
                0.5 * (block(&covariance).determinant() / block(&after).determinant()).ln();
            assert!(
                (g.interest_nats - expected).abs() < 1e-10,
                "{interest:?}: {} against {expected}",
                g.interest_nats
            );
            assert!(g.interest_nats <= g.information_nats + 1e-12);
        }
        let all = gain(&rows(&covariance), &candidate, &[0, 1, 2]);
        assert_eq!(all.interest_nats, all.information_nats);
    }

    /// The posterior after a point equals the Bayesian update done the long
    /// way (information form), with correlated parameters and two outputs.
    #[test]
    fn the_update_equals_the_information_form() {
        let covariance =
            DMatrix::from_row_slice(3, 3, &[4.0, 1.2, -0.5, 1.2, 2.0, 0.3, -0.5, 0.3, 1.0]);
        let jacobian = DMatrix::from_row_slice(2, 3, &[1.0, -2.0, 0.5, 0.3, 0.0, 4.0]);
        let noise = [0.7, 1.3];
        let g = gain(
            &rows(&covariance),
            &Candidate {
                jacobian: rows(&jacobian),
                noise_sd: noise.to_vec(),
            },
            &[0, 1, 2],
        );
        let r_inverse = DMatrix::from_diagonal(&DVector::from_iterator(
            2,
            noise.iter().map(|s| 1.0 / (s * s)),
        ));
        let information = covariance.clone().try_inverse().unwrap()
            + jacobian.transpose() * &r_inverse * &jacobian;
        let after = information.try_inverse().unwrap();
        for p in 0..3 {
            assert!((g.sd_after[p] - after[(p, p)].sqrt()).abs() < 1e-12, "{p}");
        }
        // EIG = 1/2 ln(det S / det S').
        let expected = 0.5 * (covariance.determinant() / after.determinant()).ln();
        assert!((g.information_nats - expected).abs() < 1e-10);
    }

    /// An independent integration: the mutual information between the
    /// parameters and the measurement estimated by nested Monte Carlo
    /// (log p(y|theta) - log of the average over prior draws of p(y|theta')),
    /// which uses nothing of the closed form.
    #[test]
    fn the_information_gain_equals_a_nested_monte_carlo_estimate() {
        let covariance = DMatrix::from_row_slice(2, 2, &[1.0, 0.6, 0.6, 2.0]);
        let jacobian = DMatrix::from_row_slice(2, 2, &[1.0, 0.5, -0.3, 1.0]);
        let noise = [0.8, 0.6];
        let eig = gain(
            &rows(&covariance),
            &Candidate {
                jacobian: rows(&jacobian),
                noise_sd: noise.to_vec(),
            },
            &[0, 1],
        )
        .information_nats;
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let normal = Normal::new(0.0, 1.0).unwrap();
        let l = covariance.clone().cholesky().unwrap().l();
        let draw = |rng: &mut ChaCha8Rng| {
            let z = DVector::from_iterator(2, (0..2).map(|_| normal.sample(rng)));
            &l * z
        };
        let log_likelihood = |y: &DVector<f64>, theta: &DVector<f64>| {
            let mean = &jacobian * theta;
            (0..2)
                .map(|k| {
                    let z = (y[k] - mean[k]) / noise[k];
                    -0.5 * z * z - noise[k].ln() - 0.5 * (2.0 * std::f64::consts::PI).ln()
                })
                .sum::<f64>()
        };
        let inner: Vec<DVector<f64>> = (0..4000).map(|_| draw(&mut rng)).collect();
        let outer = 3000;
        let mut total = 0.0;
        for _ in 0..outer {
            let theta = draw(&mut rng);
            let mean = &jacobian * &theta;
            let y = DVector::from_iterator(
                2,
                (0..2).map(|k| mean[k] + noise[k] * normal.sample(&mut rng)),
            );
            let own = log_likelihood(&y, &theta);
            let logs: Vec<f64> = inner.iter().map(|t| log_likelihood(&y, t)).collect();
            let top = logs.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
            let marginal =
                top + (logs.iter().map(|v| (v - top).exp()).sum::<f64>() / logs.len() as f64).ln();
            total += own - marginal;
        }
        let estimate = total / outer as f64;
        assert!(
            (estimate - eig).abs() < 0.03 * eig.max(0.1),
            "nested Monte Carlo {estimate:.4} against the closed form {eig:.4}"
        );
    }

    #[test]
    fn bad_candidates_are_refused_with_the_reason() {
        let covariance = vec![vec![1.0, 0.0], vec![0.0, 1.0]];
        let good = Candidate {
            jacobian: covariance.clone(),
            noise_sd: vec![1.0, 1.0],
        };
        assert_eq!(
            next_point(&covariance, &[], &[0, 1]),
            Err(NextPointError::NoCandidates)
        );
        let mut wrong = good.clone();
        wrong.noise_sd = vec![1.0];
        assert!(matches!(
            next_point(&covariance, &[good.clone(), wrong], &[0, 1]),
            Err(NextPointError::Uncertainties { candidate: 1, .. })
        ));
        let mut zero = good.clone();
        zero.noise_sd[0] = 0.0;
        assert!(matches!(
            next_point(&covariance, &[zero], &[0, 1]),
            Err(NextPointError::BadUncertainty { candidate: 0, .. })
        ));
        let mut nan = good.clone();
        nan.jacobian[0][1] = f64::NAN;
        assert!(matches!(
            next_point(&covariance, &[nan], &[0, 1]),
            Err(NextPointError::NotFinite { candidate: 0 })
        ));
        assert_eq!(
            next_point(&covariance, &[good], &[2]),
            Err(NextPointError::Interest {
                index: 2,
                parameters: 2
            })
        );
    }

    #[test]
    fn moments_of_draws() {
        let draws = vec![vec![1.0, 2.0], vec![3.0, 2.0], vec![2.0, 5.0]];
        let (mean, covariance) = draws_moments(&draws).unwrap();
        assert_eq!(mean, [2.0, 3.0]);
        assert!((covariance[0][0] - 1.0).abs() < 1e-12);
        assert!((covariance[1][1] - 3.0).abs() < 1e-12);
        assert!((covariance[0][1] - 0.0).abs() < 1e-12);
        assert!(draws_moments(&draws[..1]).is_none());
    }
}
