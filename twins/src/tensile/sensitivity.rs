//! The curve's sensitivities: how the force at each output point moves
//! with each material parameter, computed along with the pull by direct
//! differentiation of the discrete equations (one run, not one run per
//! parameter as finite differences of the twin would take).
//!
//! After a step n -> n+1 has converged, equilibrium on the free degrees of
//! freedom, `f(u_{n+1}, h_n, p) = 0`, is differentiated in a parameter p
//! with the prescribed displacements fixed:
//!
//! `K du_{n+1}/dp = -(∂f/∂h_n dh_n/dp + ∂f/∂p)`,
//!
//! K the tangent at `u_{n+1}` (assembled once more there, so the derivative
//! is exact for the discrete equations; Newton's last tangent is an
//! iteration old). The right-hand side is one stress-only pass of the
//! elements at `u_{n+1}` with the history moved along `dh_n/dp` and the
//! parameter moved; a second pass at `u_{n+1} + t du/dp` gives the new
//! history's derivative `dh_{n+1}/dp` and the reaction's. Both are
//! directional derivatives by a forward difference of step `t` (the
//! semi-analytical form of direct differentiation): the return mapping is
//! solved to rounding, so a relative step of 1e-6 leaves about 1e-6 of
//! truncation and much less of rounding. The history of a point is its
//! plastic metric and the material's internal variables.
//!
//! The derivative is that of the run as it was stepped: the step sizes,
//! which depend on the parameters in steps, are held, as they are in any
//! derivative of a discretised solution.

use std::borrow::Cow;

use nalgebra::SVector;

use super::element::{GaussPointState, PointMaterial};
use super::solver::{AssemblyBuffers, Bar, ConvergedStep, LoadingSettings, PullResult};
use super::split_band::SplitBandMatrix;

/// Internal variables a material's state carries, besides the plastic
/// metric the element keeps.
pub const INTERNAL_VARIABLES: usize = 2;

/// A material whose parameters the curve can be differentiated in.
pub trait ParameterisedMaterial: PointMaterial + Clone + Sync {
    /// The parameters' names, in the order of their indices.
    fn parameter_names(&self) -> Vec<&'static str>;
    /// This material with parameter `index` moved by `step`, in the
    /// parameter's own unit.
    ///
    /// # Errors
    /// The moved value is out of the parameter's range.
    fn moved(&self, index: usize, step: f64) -> Result<Self, String>;
    /// The forward-difference step of parameter `index`: small against the
    /// parameter, large against rounding.
    fn difference_step(&self, index: usize) -> f64;
    /// The state's internal variables, as numbers.
    fn internal_variables(state: &Self::State) -> [f64; INTERNAL_VARIABLES];
    /// `state` with its internal variables moved by `by`.
    fn with_internal_variables_moved(
        state: &Self::State,
        by: [f64; INTERNAL_VARIABLES],
    ) -> Self::State;
}

/// One point's history, differentiated in one parameter: the plastic
/// metric's four components, then the internal variables.
type PointHistoryDerivative = SVector<f64, { 4 + INTERNAL_VARIABLES }>;

/// The reaction force at each output point of a pull, differentiated in
/// each parameter.
#[derive(Clone, Debug, PartialEq)]
pub struct ForceSensitivities {
    pub parameter_names: Vec<&'static str>,
    /// One row per curve point, one column per parameter: kN per unit of
    /// the parameter.
    pub kn_per_unit: Vec<Vec<f64>>,
}

/// The largest change a difference step makes to a history variable
/// (strains, porosity, the plastic metric's components) and to a nodal
/// displacement (mm): where a derivative is large (a point about to fail,
/// the unloading side of a neck) the step is shortened below these, so
/// the difference stays a derivative and no point leaves its state's range.
const LARGEST_HISTORY_CHANGE: f64 = 1e-6;
const LARGEST_DISPLACEMENT_CHANGE_MM: f64 = 1e-6;

/// One parameter's derivatives as the pull goes on.
struct ParameterTrack<M> {
    index: usize,
    /// The material with this parameter moved by `step`.
    moved: M,
    step: f64,
    /// Each element's points' history derivatives at the last converged step.
    history: Vec<[PointHistoryDerivative; 4]>,
}

/// The derivatives of every parameter as the pull goes on.
struct Tracks<M> {
    parameters: Vec<ParameterTrack<M>>,
    /// Why they could not be carried on, if so: every later step's are void.
    failure: Option<String>,
}

impl<M: ParameterisedMaterial> Bar<M>
where
    M::State: Send + Sync,
{
    /// [`Bar::pull`], and the force's derivative in each of the material's
    /// parameters at each output point.
    ///
    /// # Errors
    /// The sensitivities only (the pull's result is returned either way): a
    /// parameter could not be moved, or the tangent at a converged step was
    /// singular.
    pub fn pull_with_sensitivities(
        &self,
        settings: &LoadingSettings,
    ) -> (PullResult, Result<ForceSensitivities, String>) {
        let material = self.material();
        let names = material.parameter_names();
        let elements = self.mesh().elements.len();
        let initial = material.initial_state();
        let parameters: Result<Vec<ParameterTrack<M>>, String> = (0..names.len())
            .map(|index| {
                let step = material.difference_step(index);
                let moved = material
                    .moved(index, step)
                    .map_err(|e| format!("{}: {e}", names[index]))?;
                // A parameter may set the initial state (an initial porosity).
                let before = M::internal_variables(&initial);
                let after = M::internal_variables(&moved.initial_state());
                let mut point = PointHistoryDerivative::zeros();
                for (i, (a, b)) in after.iter().zip(before).enumerate() {
                    point[4 + i] = (a - b) / step;
                }
                Ok(ParameterTrack {
                    index,
                    moved,
                    step,
                    history: vec![[point; 4]; elements],
                })
            })
            .collect();
        let mut tracks = match parameters {
            Ok(parameters) => Tracks {
                parameters,
                failure: None,
            },
            Err(message) => Tracks {
                parameters: Vec::new(),
                failure: Some(message),
            },
        };
        let count = names.len();
        let mut observer = |step: &ConvergedStep<'_, M::State>,
                            buffers: &mut AssemblyBuffers<M::State>| {
            if tracks.failure.is_some() {
                return vec![f64::NAN; count];
            }
            match self.differentiate_step(step, &mut tracks.parameters, buffers) {
                Ok(reaction_n) => reaction_n,
                Err(message) => {
                    tracks.failure = Some(message);
                    vec![f64::NAN; count]
                }
            }
        };
        let (result, observed) = self.pull_observed(settings, Some(&mut observer));
        if let Some(failure) = tracks.failure {
            return (result, Err(failure));
        }
        let kn_per_unit = observed
            .into_iter()
            .map(|mut row| {
                // The rest point's force depends on nothing.
                row.resize(count, 0.0);
                row.iter().map(|n| n / 1000.0).collect()
            })
            .collect();
        (
            result,
            Ok(ForceSensitivities {
                parameter_names: names,
                kn_per_unit,
            }),
        )
    }

    /// Carries every parameter's history derivative over one converged
    /// step; the reaction's derivatives (N per unit). The tangent is
    /// factored once for all the parameters' right-hand sides.
    fn differentiate_step(
        &self,
        step: &ConvergedStep<'_, M::State>,
        parameters: &mut [ParameterTrack<M>],
        buffers: &mut AssemblyBuffers<M::State>,
    ) -> Result<Vec<f64>, String> {
        let mut reactions = vec![0.0; parameters.len()];
        let mut right_hand_sides = Vec::with_capacity(parameters.len());
        for (at, track) in parameters.iter().enumerate() {
            if let Some(rhs) = self.force_change(step, track, buffers)? {
                right_hand_sides.push((at, rhs));
            }
        }
        if right_hand_sides.is_empty() {
            return Ok(reactions);
        }
        let mut tangent = self.prescribed_tangent(step, buffers)?;
        let factors = tangent
            .factor()
            .map_err(|error| format!("sensitivities: {error}"))?;
        for (at, (first_step, mut rhs)) in right_hand_sides {
            tangent.solve_factored(&factors, &mut rhs);
            reactions[at] =
                self.carry_history(step, &mut parameters[at], first_step, &rhs, buffers)?;
        }
        buffers.spare_matrix = Some(tangent);
        Ok(reactions)
    }

    /// `-(∂f/∂h_n dh_n/dp + ∂f/∂p)` on the free degrees of freedom, and the
    /// difference step it was taken with; `None` when nothing the parameter
    /// touches has yielded yet (the derivatives stay zero).
    fn force_change(
        &self,
        step: &ConvergedStep<'_, M::State>,
        track: &ParameterTrack<M>,
        buffers: &mut AssemblyBuffers<M::State>,
    ) -> Result<Option<(f64, Vec<f64>)>, String> {
        let history_size = largest(track.history.iter().flatten().flat_map(|h| h.iter()));
        let first_step = shortened(track.step, history_size, LARGEST_HISTORY_CHANGE);
        let material = self.moved_by(track, first_step)?;
        let moved_states = moved_history::<M>(step.states_before, &track.history, first_step);
        let pass = self.assemble(
            &material,
            step.displacement,
            &moved_states,
            step.states_after,
            None,
            buffers,
        )?;
        let rhs: Vec<f64> = pass
            .force_n
            .iter()
            .zip(step.force_n)
            .zip(&step.constraints.is_constrained)
            .map(|((moved, base), &constrained)| {
                if constrained {
                    0.0
                } else {
                    -(moved - base) / first_step
                }
            })
            .collect();
        buffers.recycle(pass.states);
        let untouched = rhs.iter().all(|v| *v == 0.0)
            && track
                .history
                .iter()
                .flatten()
                .all(|h| h.iter().all(|v| *v == 0.0));
        Ok((!untouched).then_some((first_step, rhs)))
    }

    /// Moves the displacement along `du/dp` (`displacement_slope`) with the
    /// parameter and the history: the new history's derivative, kept in
    /// `track`, and the reaction's, returned (N per unit).
    fn carry_history(
        &self,
        step: &ConvergedStep<'_, M::State>,
        track: &mut ParameterTrack<M>,
        first_step: f64,
        displacement_slope: &[f64],
        buffers: &mut AssemblyBuffers<M::State>,
    ) -> Result<f64, String> {
        let second_step = shortened(
            first_step,
            largest(displacement_slope.iter()),
            LARGEST_DISPLACEMENT_CHANGE_MM,
        );
        let material = self.moved_by(track, second_step)?;
        let moved_states = moved_history::<M>(step.states_before, &track.history, second_step);
        let displacement: Vec<f64> = step
            .displacement
            .iter()
            .zip(displacement_slope)
            .map(|(u, du)| u + second_step * du)
            .collect();
        let pass = self.assemble(
            &material,
            &displacement,
            &moved_states,
            step.states_after,
            None,
            buffers,
        )?;
        let reaction: f64 = step
            .constraints
            .pulled
            .iter()
            .map(|&dof| (pass.force_n[dof] - step.force_n[dof]) / second_step)
            .sum();
        let base_material = self.material();
        for ((history, moved), base) in track
            .history
            .iter_mut()
            .zip(&pass.states)
            .zip(step.states_after)
        {
            for k in 0..4 {
                // A failed point carries nothing whatever its history.
                history[k] = if base_material.has_failed(&base[k].material) {
                    PointHistoryDerivative::zeros()
                } else {
                    history_difference::<M>(&moved[k], &base[k]) / second_step
                };
            }
        }
        buffers.recycle(pass.states);
        Ok(reaction)
    }

    /// The bar's material with `track`'s parameter moved by `step`.
    fn moved_by<'t>(&self, track: &'t ParameterTrack<M>, step: f64) -> Result<Cow<'t, M>, String> {
        if step == track.step {
            Ok(Cow::Borrowed(&track.moved))
        } else {
            self.material().moved(track.index, step).map(Cow::Owned)
        }
    }

    /// The tangent at the converged displacement, the prescribed degrees
    /// of freedom replaced by identity rows (their derivative is zero).
    fn prescribed_tangent(
        &self,
        step: &ConvergedStep<'_, M::State>,
        buffers: &mut AssemblyBuffers<M::State>,
    ) -> Result<SplitBandMatrix, String> {
        let matrix = self.cleared_stiffness(buffers);
        let assembly = self.assemble(
            self.material(),
            step.displacement,
            step.states_before,
            step.states_after,
            Some(matrix),
            buffers,
        )?;
        buffers.recycle(assembly.states);
        let Some(mut matrix) = assembly.stiffness else {
            return Err("the tangent was not assembled".into());
        };
        let mut unused = vec![0.0; step.displacement.len()];
        for &dof in step
            .constraints
            .fixed
            .iter()
            .chain(&step.constraints.pulled)
        {
            matrix.prescribe(dof, 0.0, &mut unused);
        }
        Ok(matrix)
    }
}

/// The largest magnitude of `values` (0 for none).
fn largest<'v>(values: impl Iterator<Item = &'v f64>) -> f64 {
    values.fold(0.0_f64, |a, v| a.max(v.abs()))
}

/// `step`, shortened so that `step * size` is at most `limit`.
fn shortened(step: f64, size: f64, limit: f64) -> f64 {
    if step * size > limit {
        limit / size
    } else {
        step
    }
}

/// The points' states moved by `step` along their history derivatives.
fn moved_history<M: ParameterisedMaterial>(
    states: &[[GaussPointState<M::State>; 4]],
    history: &[[PointHistoryDerivative; 4]],
    step: f64,
) -> Vec<[GaussPointState<M::State>; 4]> {
    states
        .iter()
        .zip(history)
        .map(|(points, derivatives)| {
            std::array::from_fn(|k| {
                let point = &points[k];
                let by = derivatives[k] * step;
                let internal: [f64; INTERNAL_VARIABLES] = std::array::from_fn(|i| by[4 + i]);
                GaussPointState {
                    plastic_metric: point.plastic_metric + by.fixed_rows::<4>(0),
                    material: M::with_internal_variables_moved(&point.material, internal),
                    stress_mpa: point.stress_mpa,
                }
            })
        })
        .collect()
}

/// `moved - base` as a history vector.
fn history_difference<M: ParameterisedMaterial>(
    moved: &GaussPointState<M::State>,
    base: &GaussPointState<M::State>,
) -> PointHistoryDerivative {
    let metric = moved.plastic_metric - base.plastic_metric;
    let (a, b) = (
        M::internal_variables(&moved.material),
        M::internal_variables(&base.material),
    );
    PointHistoryDerivative::from_fn(|i, _| {
        if i < 4 {
            metric[i]
        } else {
            a[i - 4] - b[i - 4]
        }
    })
}
