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

use acq_calib::next_point::draws_moments;
use acq_study::posterior::shared_errors::LEAST_OWN_SHARE;
use acq_study::study::{Measured, Study};
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
            let Measured::Scalar {
                value,
                uncertainty: Some(u),
            } = observation.measured
            else {
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
        let weighted = DMatrix::from_fn(t, n, |s, i| loading[(i, s)] / rows[i].own_variance); // S' D^-1
        let conditional = (DMatrix::identity(t, t) + &weighted * &loading).try_inverse()?;
        let gain = &conditional * &weighted;
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
