//! What the holds say of the errors they share, jointly with the
//! parameters: for the next test point, where a new hold's error is partly
//! one the earlier holds have already seen (a transducer's calibration).
//!
//! The posterior integrates each shared error out ([`acq_study::posterior::shared_errors`]);
//! here each is drawn back. With the observations' residuals `r` at a
//! posterior draw, the standardised errors `z` (prior `N(0, I)`, moving the
//! observations by `S z`, each observation's own variance `D`) are normal:
//! covariance `(I + S' D^-1 S)^-1`, mean that times `S' D^-1 r`. The
//! parameters' draws with those means give the joint moments. A candidate
//! hold then adds its own error only: the part it shares is a coordinate
//! the earlier holds have narrowed, not fresh noise, so a repeat of the
//! same hold no longer looks as informative as a new one.

use acq_algorithms::next_point::draws_moments;
use acq_study::posterior::shared_errors::LEAST_OWN_SHARE;
use acq_study::study::Study;
use nalgebra::{DMatrix, DVector};

use super::RigStudy;

/// The parameters' draws kept for the shared errors' moments: each needs
/// a model run per hold.
const DRAWS_FOR_SHARED: usize = 200;

/// The joint posterior of the parameters and the shared errors.
#[derive(Clone, Debug, PartialEq)]
pub struct SharedErrorsPosterior {
    /// The sources (a sensor, or a quantity's instrument term).
    pub sources: Vec<String>,
    /// Each observation's effect of each source in a new hold (`c u`, the
    /// last hold's; `[observation][source]`).
    pub loadings: Vec<Vec<f64>>,
    /// The covariance of (parameters, standardised shared errors).
    pub joint_covariance: Vec<Vec<f64>>,
}

/// One observation of one hold as the shared errors' conditional reads it.
struct SharedRow {
    /// Its case (hold) in the study.
    case: usize,
    measured: f64,
    own_variance: f64,
    /// `(source, effect)`.
    shared: Vec<(usize, f64)>,
}

/// Every scalar observation of `study`'s holds with the sources it shares,
/// and the sources in the order they first appear.
fn shared_rows(study: &Study) -> (Vec<SharedRow>, Vec<String>) {
    let mut sources: Vec<String> = Vec::new();
    let mut rows = Vec::new();
    for (case, holds) in study.cases.iter().enumerate().filter(|(_, c)| !c.priors) {
        for observation in &holds.observations {
            let Some((value, u)) = observation.stated_scalar() else {
                continue;
            };
            let mut shared = Vec::new();
            for part in &observation.shared {
                let index = sources
                    .iter()
                    .position(|s| *s == part.source)
                    .unwrap_or_else(|| {
                        sources.push(part.source.clone());
                        sources.len() - 1
                    });
                shared.push((index, part.effect));
            }
            let shared_variance: f64 = shared.iter().map(|(_, e)| e * e).sum();
            rows.push(SharedRow {
                case,
                measured: value,
                own_variance: (u * u - shared_variance).max(LEAST_OWN_SHARE * u * u),
                shared,
            });
        }
    }
    (rows, sources)
}

/// The standardised shared errors `z` given the residuals `r`, with
/// loadings `S` (a row per observation) and the observations' own
/// variances `D`: covariance `(I + S' D^-1 S)^-1` and the gain `K` whose
/// `K r` is the mean (`None` when that matrix is singular).
fn shared_error_conditional(
    loading: &DMatrix<f64>,
    own_variances: &[f64],
) -> Option<(DMatrix<f64>, DMatrix<f64>)> {
    let (n, t) = loading.shape();
    let weighted = DMatrix::from_fn(t, n, |s, i| loading[(i, s)] / own_variances[i]); // S' D^-1
    let conditional = (DMatrix::identity(t, t) + &weighted * loading).try_inverse()?;
    let gain = &conditional * &weighted;
    Some((conditional, gain))
}

impl RigStudy {
    /// The shared errors' joint posterior with the parameters' `draws`, for
    /// `study` (the holds as cases); `None` when no error is shared or no
    /// draw runs.
    pub fn shared_errors_posterior(
        &self,
        study: &Study,
        draws: &[Vec<f64>],
    ) -> Option<SharedErrorsPosterior> {
        let (rows, sources) = shared_rows(study);
        if sources.is_empty() {
            return None;
        }
        let (n, t) = (rows.len(), sources.len());
        let loading = DMatrix::from_fn(n, t, |i, s| {
            rows[i]
                .shared
                .iter()
                .filter(|(k, _)| *k == s)
                .map(|(_, e)| e)
                .sum::<f64>()
        });
        let own: Vec<f64> = rows.iter().map(|r| r.own_variance).collect();
        let (conditional, gain) = shared_error_conditional(&loading, &own)?;
        let step = draws.len().div_ceil(DRAWS_FOR_SHARED).max(1);
        let joint: Vec<Vec<f64>> = draws
            .iter()
            .step_by(step)
            .filter_map(|theta| {
                let mut residuals: DVector<f64> = DVector::zeros(n);
                let mut last_case = None;
                let mut outputs: Vec<f64> = Vec::new();
                let mut within = 0;
                for (i, row) in rows.iter().enumerate() {
                    if last_case != Some(row.case) {
                        outputs = self.outputs_at(theta, &study.cases[row.case].inputs).ok()?;
                        (last_case, within) = (Some(row.case), 0);
                    }
                    residuals[i] = row.measured - outputs.get(within)?;
                    within += 1;
                }
                let mean: DVector<f64> = &gain * residuals;
                Some(theta.iter().copied().chain(mean.iter().copied()).collect())
            })
            .collect();
        let (_, mut covariance) = draws_moments(&joint)?;
        let p = covariance.len() - t;
        for a in 0..t {
            for b in 0..t {
                covariance[p + a][p + b] += conditional[(a, b)];
            }
        }
        let observations = self.mapping.observations.len();
        let last_case = rows.last()?.case;
        let loadings = (0..observations)
            .map(|k| {
                let mut effects = vec![0.0; t];
                if let Some(row) = rows.iter().filter(|r| r.case == last_case).nth(k) {
                    for (source, effect) in &row.shared {
                        effects[*source] += effect;
                    }
                }
                effects
            })
            .collect();
        Some(SharedErrorsPosterior {
            sources,
            loadings,
            joint_covariance: covariance,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// One transducer read in two holds, `r_i = s z + e_i`, `z ~ N(0, 1)`,
    /// `e_i ~ N(0, v)`: by hand, `z | r` has variance `1 / (1 + 2 s^2 / v)`
    /// and mean that times `s (r_1 + r_2) / v`.
    #[test]
    fn one_shared_error_in_two_holds_has_its_closed_form_conditional() {
        let (s, v): (f64, f64) = (1.2, 0.09);
        let loading = DMatrix::from_row_slice(2, 1, &[s, s]);
        let (conditional, gain) = shared_error_conditional(&loading, &[v, v]).unwrap();
        let variance = 1.0 / (1.0 + 2.0 * s * s / v);
        assert!((conditional[(0, 0)] - variance).abs() < 1e-15);
        let residuals = DVector::from_vec(vec![0.7, 1.1]);
        let mean = (&gain * residuals)[0];
        assert!(
            (mean - variance * s * (0.7 + 1.1) / v).abs() < 1e-14,
            "{mean}"
        );
    }
}
