//! Pulling the bar: displacement control, implicit Newton with the exact
//! tangent, step cutting, and the force-displacement curve.
//!
//! Each step prescribes the end displacement and iterates `K du = -f_int`
//! on the free degrees of freedom until the out-of-balance force is below
//! `relative_tolerance` of the reaction (and a floor of 1e-6 N). A step
//! that does not converge in `max_newton_iterations`, or in which a
//! material point or element fails to evaluate, is halved and retried; a
//! step that converges quickly lets the next one grow again, up to the
//! output interval, or up to [`HardeningSteps::step_mm`] while the bar
//! still hardens steeply and smoothly. The curve is written at every output
//! interval exactly (steps are cut to land on it; inside a longer hardening
//! step the points are interpolated), so its spacing does not depend on
//! how hard the solver had to work.
//!
//! The load step is a discretisation of its own: the return mapping is
//! backward Euler, first order in the step, and after the maximum force
//! the neck's softening depends on it (at 0.09 mm elements, halving the
//! 0.01 mm step raises the force at the test's end by 1.4 %; before the
//! maximum, 1e-5). `--step-mm` in `acq twin gtn` shows it.
//!
//! The run ends at the end displacement, when the force has fallen below a
//! fraction of its maximum after the maximum (the bar has broken), or when
//! a step cannot be made to converge even at `min_step_mm`; the last two
//! are reported with the displacement reached. The tolerance is relative
//! to the reaction with a floor of 1 N, so the unloaded first iterations
//! do not chase round-off.

use serde::Serialize;

use super::element::{
    evaluate_into, ElementDisplacement, ElementForce, ElementOutput, ElementShape,
    ElementStiffness, GaussPointState, PointMaterial,
};
use super::mesh::Mesh;
use super::split_band::SplitBandMatrix;

/// A step that converges in this many iterations or fewer lets the next grow.
const EASY_STEP_ITERATIONS: usize = 6;

/// How the bar is pulled and when the run stops.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct LoadingSettings {
    /// End displacement to reach, mm (the test's last displacement).
    pub end_displacement_mm: f64,
    /// Spacing of the output curve, mm; also the largest step once
    /// [`HardeningSteps`] no longer allows longer ones.
    pub output_interval_mm: f64,
    /// Below this step size a non-converging step ends the run, mm.
    pub min_step_mm: f64,
    pub max_newton_iterations: usize,
    pub relative_tolerance: f64,
    /// After the maximum, a force below this fraction of it is fracture.
    pub fracture_force_fraction: f64,
    pub hardening: HardeningSteps,
}

/// Longer steps while the bar hardens uniformly, well before the maximum
/// force; the output points inside them are interpolated.
///
/// Why only there: the return mapping is backward Euler, first order in
/// the step, and after the maximum the neck amplifies any difference of
/// its state. Longer steps up to 0.04 mm while the force still rises by
/// 10 % per mm leave the curve within 3e-4 of all-0.01 mm steps; steps
/// that long up to the maximum itself moved the softening by 1 %
/// (BENCHMARKS.md, "GTN twin speed").
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct HardeningSteps {
    /// The largest step, mm (no longer steps when at most the output
    /// interval).
    pub step_mm: f64,
    /// Longer steps while the force rises by at least this fraction of
    /// itself per mm over the last step.
    pub min_rise_per_mm: f64,
    /// ... and the curve is this straight over `step_mm`: a straight line
    /// through two steps would miss the next by at most this fraction of
    /// the force, estimated from the last three and scaled to `step_mm`
    /// (not in the elastic-plastic knee).
    pub curvature: f64,
}

impl LoadingSettings {
    pub fn to(end_displacement_mm: f64) -> Self {
        LoadingSettings {
            end_displacement_mm,
            output_interval_mm: 0.01,
            min_step_mm: 1e-6,
            max_newton_iterations: 16,
            // 3e-4 of the reaction: one Newton correction from the
            // predictor usually meets it (its residual is 1e-4 to 3e-4;
            // 1e-5 needed a second), and it moves the curve by at most 3e-4
            // against 1e-5 (BENCHMARKS.md), under a tenth of a class-0.5
            // load cell's error and of what halving the 0.01 mm step moves
            // the softening. Abaqus/Standard's default force criterion is
            // 5e-3.
            relative_tolerance: 3e-4,
            fracture_force_fraction: 0.02,
            hardening: HardeningSteps {
                step_mm: 0.04,
                min_rise_per_mm: 0.1,
                curvature: 1e-2,
            },
        }
    }
}

/// One output point.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct CurvePoint {
    pub displacement_mm: f64,
    pub force_kn: f64,
    /// Current diameter at the mid-gauge plane, mm.
    pub neck_diameter_mm: f64,
    /// Gauss points that no longer carry load.
    pub failed_points: usize,
}

/// How the run ended.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Outcome {
    /// The end displacement was reached.
    ReachedEnd,
    /// The force fell to `fracture_force_fraction` of its maximum.
    Fractured { displacement_mm: f64 },
    /// A step could not be made to converge.
    NotConverged {
        displacement_mm: f64,
        reason: String,
    },
}

/// The curve and how it was obtained.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct PullResult {
    pub curve: Vec<CurvePoint>,
    pub outcome: Outcome,
    pub steps: usize,
    pub newton_iterations: usize,
    pub step_cuts: usize,
}

impl PullResult {
    /// Largest force of the curve, kN.
    pub fn max_force_kn(&self) -> f64 {
        self.curve.iter().map(|p| p.force_kn).fold(0.0, f64::max)
    }
}

/// The meshed bar with its material, ready to be pulled.
pub struct Bar<M: PointMaterial> {
    mesh: Mesh,
    shapes: Vec<ElementShape>,
    material: M,
    threads: usize,
}

const MAX_THREADS: usize = 8;
/// Fewer elements than this per thread do not pay for the thread.
const MIN_ELEMENTS_PER_THREAD: usize = 32;
/// Runs of neighbouring elements per thread (see `Bar::assemble`).
const RUNS_PER_THREAD: usize = 16;

/// Degrees of freedom whose value is prescribed.
pub(super) struct Constraints {
    pub(super) fixed: Vec<usize>,
    pub(super) pulled: Vec<usize>,
    pub(super) is_constrained: Vec<bool>,
}

/// Displacement, assembly at convergence, Newton iterations.
type NewtonResult<S> = (Vec<f64>, Assembly<S>, usize);

/// Storage the assemblies of a pull share: each element's force and
/// stiffness, written by the threads that evaluate the elements and read by
/// the serial scatter, and state vectors that earlier assemblies filled and
/// nothing holds any more.
pub(super) struct AssemblyBuffers<S> {
    forces: Vec<ElementForce>,
    stiffnesses: Vec<ElementStiffness>,
    spare_states: Vec<Vec<[GaussPointState<S>; 4]>>,
    /// The last factorisation's storage: a fresh one of megabytes a solve
    /// was mostly page faults.
    pub(super) spare_matrix: Option<SplitBandMatrix>,
}

impl<S: Copy> AssemblyBuffers<S> {
    fn new() -> Self {
        AssemblyBuffers {
            forces: Vec::new(),
            stiffnesses: Vec::new(),
            spare_states: Vec::new(),
            spare_matrix: None,
        }
    }

    /// A state vector no longer needed; a later assembly writes into it.
    pub(super) fn recycle(&mut self, states: Vec<[GaussPointState<S>; 4]>) {
        // Two are in use at most (a step's start and the last iteration's).
        if self.spare_states.len() < 2 {
            self.spare_states.push(states);
        }
    }

    /// A state vector of `like`'s length, its contents to be overwritten.
    fn states_like(&mut self, like: &[[GaussPointState<S>; 4]]) -> Vec<[GaussPointState<S>; 4]> {
        match self.spare_states.pop() {
            Some(spare) if spare.len() == like.len() => spare,
            _ => like.to_vec(),
        }
    }
}

pub(super) struct Assembly<S> {
    /// The tangent, when asked for.
    pub(super) stiffness: Option<SplitBandMatrix>,
    pub(super) force_n: Vec<f64>,
    pub(super) states: Vec<[GaussPointState<S>; 4]>,
}

/// A converged step, as [`Bar::pull_observed`] shows it to its observer.
pub(super) struct ConvergedStep<'a, S> {
    /// The points' states at the start of the step.
    pub(super) states_before: &'a [[GaussPointState<S>; 4]],
    pub(super) displacement: &'a [f64],
    /// The nodal forces at the converged displacement, N.
    pub(super) force_n: &'a [f64],
    pub(super) states_after: &'a [[GaussPointState<S>; 4]],
    pub(super) constraints: &'a Constraints,
}

/// What the observer of a pull is called with after each converged step;
/// the numbers it returns are carried to the output curve and interpolated
/// as the force is (see [`OutputCurve`]).
pub(super) type StepObserver<'o, S> =
    dyn FnMut(&ConvergedStep<'_, S>, &mut AssemblyBuffers<S>) -> Vec<f64> + 'o;

impl<M: PointMaterial + Sync> Bar<M>
where
    M::State: Send + Sync,
{
    pub fn new(mesh: Mesh, material: M) -> Self {
        let shapes = mesh
            .elements
            .iter()
            .map(|element| ElementShape::new(&element.map(|n| mesh.nodes_mm[n])))
            .collect();
        let threads = std::thread::available_parallelism()
            .map_or(1, |n| n.get())
            .min(MAX_THREADS);
        Bar {
            mesh,
            shapes,
            material,
            threads,
        }
    }

    /// Evaluate elements on at most this many threads (default: the cores, up to 8).
    pub fn with_threads(mut self, threads: usize) -> Self {
        self.threads = threads.max(1);
        self
    }

    pub fn mesh(&self) -> &Mesh {
        &self.mesh
    }

    pub fn material(&self) -> &M {
        &self.material
    }

    pub(super) fn constraints(&self) -> Constraints {
        let dofs = 2 * self.mesh.node_count();
        let fixed: Vec<usize> = self
            .mesh
            .axis_nodes()
            .map(|n| 2 * n)
            .chain(self.mesh.symmetry_plane_nodes().map(|n| 2 * n + 1))
            .collect();
        let pulled: Vec<usize> = self.mesh.end_nodes().map(|n| 2 * n + 1).collect();
        let mut is_constrained = vec![false; dofs];
        for &dof in fixed.iter().chain(&pulled) {
            is_constrained[dof] = true;
        }
        Constraints {
            fixed,
            pulled,
            is_constrained,
        }
    }

    /// `last`: the states the previous assembly gave (see
    /// [`PointMaterial::update`]). `material` is the bar's, or the bar's
    /// with a parameter moved (the sensitivities).
    pub(super) fn assemble(
        &self,
        material: &M,
        displacement: &[f64],
        states: &[[GaussPointState<M::State>; 4]],
        last: &[[GaussPointState<M::State>; 4]],
        mut stiffness: Option<SplitBandMatrix>,
        buffers: &mut AssemblyBuffers<M::State>,
    ) -> Result<Assembly<M::State>, String> {
        let dofs = displacement.len();
        let with_stiffness = stiffness.is_some();
        let mut force_n = vec![0.0; dofs];
        let element_dofs = |element: &[usize; 4]| -> [usize; 8] {
            std::array::from_fn(|k| 2 * element[k / 2] + k % 2)
        };
        // Element evaluations are independent: split them over the cores
        // in runs of neighbouring elements, several runs a core, which the
        // thread pool hands out as cores come free. The elements run along
        // the bar, so one run a core would give one core the neck (plastic,
        // several times dearer per point) and the other the elastic end;
        // more runs also let a core that a shared machine slows hand work
        // to the other. Each element writes its results into its own slot
        // of the buffers; the scatter is serial, in element order, so the
        // sums do not depend on the thread count.
        let count = self.mesh.elements.len();
        let threads = self
            .threads
            .min(count.div_ceil(MIN_ELEMENTS_PER_THREAD))
            .max(1);
        let run_length = if threads == 1 {
            count.max(1)
        } else {
            count.div_ceil(RUNS_PER_THREAD * threads).max(1)
        };
        let mut new_states = buffers.states_like(states);
        buffers.forces.resize(count, ElementForce::zeros());
        buffers.stiffnesses.resize(count, ElementStiffness::zeros());
        type Run<'a, S> = (
            usize,
            (
                (&'a mut [[GaussPointState<S>; 4]], &'a mut [ElementForce]),
                &'a mut [ElementStiffness],
            ),
        );
        // The error of a run's first failing element.
        let evaluate_run = |(run, ((run_states, forces), stiffnesses)): Run<'_, M::State>| {
            let first = run * run_length;
            let slots = run_states.iter_mut().zip(forces).zip(stiffnesses);
            for (index, ((new_states, force_n), stiffness_n_per_mm)) in (first..).zip(slots) {
                let dofs = element_dofs(&self.mesh.elements[index]);
                let local = ElementDisplacement::from_fn(|k, _| displacement[dofs[k]]);
                let element = if with_stiffness {
                    evaluate_into::<true, M>
                } else {
                    evaluate_into::<false, M>
                };
                let output = ElementOutput {
                    force_n,
                    stiffness_n_per_mm,
                    states: new_states,
                };
                element(
                    &self.shapes[index],
                    material,
                    &states[index],
                    &last[index],
                    &local,
                    output,
                )
                .map_err(|error| (index, format!("element {index}: {error}")))?;
            }
            Ok(())
        };
        let failures: Vec<(usize, String)> = if threads == 1 {
            new_states
                .chunks_mut(run_length)
                .zip(buffers.forces.chunks_mut(run_length))
                .zip(buffers.stiffnesses.chunks_mut(run_length))
                .enumerate()
                .map(evaluate_run)
                .filter_map(Result::err)
                .collect()
        } else {
            use rayon::prelude::*;
            new_states
                .par_chunks_mut(run_length)
                .zip(buffers.forces.par_chunks_mut(run_length))
                .zip(buffers.stiffnesses.par_chunks_mut(run_length))
                .enumerate()
                .map(evaluate_run)
                .filter_map(Result::err)
                .collect()
        };
        // The failure of the lowest element, as a serial loop would give it.
        if let Some((_, message)) = failures.into_iter().min_by_key(|(index, _)| *index) {
            return Err(message);
        }
        for (index, element) in self.mesh.elements.iter().enumerate() {
            let dofs = element_dofs(element);
            let force = &buffers.forces[index];
            for (a, &row) in dofs.iter().enumerate() {
                force_n[row] += force[a];
            }
            if let Some(stiffness) = stiffness.as_mut() {
                stiffness.add_element(&dofs, &buffers.stiffnesses[index]);
            }
        }
        Ok(Assembly {
            stiffness,
            force_n,
            states: new_states,
        })
    }

    /// A zero stiffness matrix of the bar's shape: the last one's storage
    /// when the buffers hold it.
    pub(super) fn cleared_stiffness(
        &self,
        buffers: &mut AssemblyBuffers<M::State>,
    ) -> SplitBandMatrix {
        match buffers.spare_matrix.take() {
            Some(mut matrix) => {
                matrix.clear();
                matrix
            }
            None => self.zero_stiffness(),
        }
    }

    /// A zero stiffness matrix of the bar's shape.
    fn zero_stiffness(&self) -> SplitBandMatrix {
        let per_node_row = 2 * (self.mesh.radial_elements + 1);
        SplitBandMatrix::zeros(
            2 * self.mesh.node_count(),
            per_node_row,
            self.mesh.half_bandwidth(),
            self.threads > 1,
        )
    }

    fn failed_points(&self, states: &[[GaussPointState<M::State>; 4]]) -> usize {
        states
            .iter()
            .flatten()
            .filter(|point| self.material.has_failed(&point.material))
            .count()
    }

    fn curve_point(
        &self,
        displacement_mm: f64,
        displacement: &[f64],
        force_n: &[f64],
        constraints: &Constraints,
        failed_points: usize,
    ) -> CurvePoint {
        let force: f64 = constraints.pulled.iter().map(|&dof| force_n[dof]).sum();
        let neck = self.mesh.neck_surface_node();
        CurvePoint {
            displacement_mm,
            force_kn: force / 1000.0,
            neck_diameter_mm: 2.0 * (self.mesh.nodes_mm[neck][0] + displacement[2 * neck]),
            failed_points,
        }
    }

    /// Pulls the bar from rest to `settings.end_displacement_mm`.
    pub fn pull(&self, settings: &LoadingSettings) -> PullResult {
        self.pull_observed(settings, None).0
    }

    /// [`Bar::pull`], showing each converged step to `observer`; what it
    /// returns for each step comes back for each output point.
    pub(super) fn pull_observed(
        &self,
        settings: &LoadingSettings,
        mut observer: Option<&mut StepObserver<'_, M::State>>,
    ) -> (PullResult, Vec<Vec<f64>>) {
        let constraints = self.constraints();
        let dofs = 2 * self.mesh.node_count();
        let mut displacement = vec![0.0; dofs];
        let initial = GaussPointState::new(self.material.initial_state());
        let mut states = vec![[initial; 4]; self.mesh.elements.len()];
        let rest = CurvePoint {
            displacement_mm: 0.0,
            force_kn: 0.0,
            neck_diameter_mm: 2.0 * self.mesh.nodes_mm[self.mesh.neck_surface_node()][0],
            failed_points: 0,
        };
        let mut output = OutputCurve::new(rest, settings);
        let mut result = PullResult {
            curve: Vec::new(),
            outcome: Outcome::ReachedEnd,
            steps: 0,
            newton_iterations: 0,
            step_cuts: 0,
        };
        let end = settings.end_displacement_mm;
        let interval = output.interval_mm;
        let mut pulled_mm = 0.0;
        let mut step_mm = interval;
        // Displacement per mm of end displacement in the last step: the
        // predictor of the next (it carries the last step's unloading
        // pattern, so Newton starts on the right elastic/plastic split).
        let mut rate: Option<Vec<f64>> = None;
        let mut buffers = AssemblyBuffers::new();
        while pulled_mm < end - 1e-12 * end {
            let target = if step_mm > interval {
                (pulled_mm + step_mm).min(end)
            } else {
                (pulled_mm + step_mm).min(output.next_mm)
            };
            let increment = target - pulled_mm;
            let predicted: Option<Vec<f64>> = rate.as_ref().map(|rate| {
                displacement
                    .iter()
                    .zip(rate)
                    .map(|(u, v)| u + v * increment)
                    .collect()
            });
            let start = predicted.as_deref().unwrap_or(&displacement);
            let jump = if predicted.is_some() { 0.0 } else { increment };
            match self.converge_step(start, &states, &constraints, jump, settings, &mut buffers) {
                Ok((new_displacement, assembly, iterations)) => {
                    let observed = match observer.as_mut() {
                        Some(observer) => observer(
                            &ConvergedStep {
                                states_before: &states,
                                displacement: &new_displacement,
                                force_n: &assembly.force_n,
                                states_after: &assembly.states,
                                constraints: &constraints,
                            },
                            &mut buffers,
                        ),
                        None => Vec::new(),
                    };
                    result.steps += 1;
                    result.newton_iterations += iterations;
                    rate = Some(
                        new_displacement
                            .iter()
                            .zip(&displacement)
                            .map(|(new, old)| (new - old) / increment)
                            .collect(),
                    );
                    displacement = new_displacement;
                    buffers.recycle(std::mem::replace(&mut states, assembly.states));
                    pulled_mm = target;
                    let failed = self.failed_points(&states);
                    let point = self.curve_point(
                        target,
                        &displacement,
                        &assembly.force_n,
                        &constraints,
                        failed,
                    );
                    let hardening = output.converged(point, observed);
                    if let Some(fractured_mm) = output.fractured_at {
                        result.outcome = Outcome::Fractured {
                            displacement_mm: fractured_mm,
                        };
                        break;
                    }
                    let largest = if hardening {
                        settings.hardening.step_mm.max(interval)
                    } else {
                        interval
                    };
                    step_mm = if iterations <= EASY_STEP_ITERATIONS {
                        (step_mm * 1.5).min(largest)
                    } else {
                        step_mm.min(largest)
                    };
                }
                Err(reason) => {
                    result.step_cuts += 1;
                    step_mm = increment / 2.0;
                    if step_mm < settings.min_step_mm {
                        result.outcome = Outcome::NotConverged {
                            displacement_mm: pulled_mm,
                            reason,
                        };
                        break;
                    }
                }
            }
        }
        result.curve = output.points;
        (result, output.observed)
    }

    /// Newton iterations for one step; the displacement, assembly at
    /// convergence and iteration count, or why it failed. `start` already holds the prescribed end displacement unless
    /// `increment_mm` (the jump still to apply to the pulled end) is non-zero.
    fn converge_step(
        &self,
        start: &[f64],
        states: &[[GaussPointState<M::State>; 4]],
        constraints: &Constraints,
        increment_mm: f64,
        settings: &LoadingSettings,
        buffers: &mut AssemblyBuffers<M::State>,
    ) -> Result<NewtonResult<M::State>, String> {
        let mut displacement = start.to_vec();
        let mut first_residual = f64::NAN;
        // The states the last iteration reached (at first, the last step's).
        let mut last_states: Option<Vec<[GaussPointState<M::State>; 4]>> = None;
        for iteration in 0..=settings.max_newton_iterations {
            let last = last_states.as_deref().unwrap_or(states);
            if iteration > 0 {
                // The check needs the forces only; most steps converge here
                // (at 0.09 mm, three in four at the first check), so the
                // tangent is assembled only when another correction follows.
                let check =
                    self.assemble(&self.material, &displacement, states, last, None, buffers)?;
                let (residual, reaction) = norms(&check.force_n, &constraints.is_constrained);
                if !residual.is_finite() {
                    return Err("the out-of-balance force is not finite".into());
                }
                // Relative to the reaction, with a floor of 1 N of reaction.
                if residual <= settings.relative_tolerance * reaction.max(1.0) {
                    return Ok((displacement, check, iteration));
                }
                buffers.recycle(check.states);
                if iteration == 1 {
                    first_residual = residual;
                } else if residual > 1e6 * first_residual {
                    return Err(format!(
                        "Newton diverged (out-of-balance force {residual:.3e} N)"
                    ));
                }
                if iteration == settings.max_newton_iterations {
                    return Err(format!(
                        "no convergence in {iteration} iterations (out-of-balance force {residual:.3e} N, reaction {reaction:.3e} N)"
                    ));
                }
            }
            let matrix = self.cleared_stiffness(buffers);
            let assembly = self.assemble(
                &self.material,
                &displacement,
                states,
                last,
                Some(matrix),
                buffers,
            )?;
            let Some(mut stiffness) = assembly.stiffness else {
                return Err("the tangent was not assembled".into());
            };
            let mut rhs: Vec<f64> = assembly.force_n.iter().map(|f| -f).collect();
            let pulled_value = if iteration == 0 { increment_mm } else { 0.0 };
            for &dof in &constraints.fixed {
                stiffness.prescribe(dof, 0.0, &mut rhs);
            }
            for &dof in &constraints.pulled {
                stiffness.prescribe(dof, pulled_value, &mut rhs);
            }
            stiffness
                .solve_in_place(&mut rhs)
                .map_err(|error| error.to_string())?;
            for (u, du) in displacement.iter_mut().zip(&rhs) {
                *u += du;
            }
            buffers.spare_matrix = Some(stiffness);
            if let Some(old) = last_states.replace(assembly.states) {
                buffers.recycle(old);
            }
        }
        Err("no convergence".into())
    }
}

/// The output curve at every `output_interval_mm`, built from the
/// converged steps: a step that ends on an output point gives it; points
/// inside a longer step (before the maximum force, see
/// [`HardeningSteps`]) are interpolated by the parabola
/// through the last three converged steps.
struct OutputCurve {
    interval_mm: f64,
    end_mm: f64,
    /// The next output displacement, mm.
    next_mm: f64,
    /// The last three converged steps, oldest first.
    recent: Vec<CurvePoint>,
    points: Vec<CurvePoint>,
    /// What the pull's observer gave for each of `recent` (empty: zeros)...
    recent_observed: Vec<Vec<f64>>,
    /// ... and for each of `points`, interpolated as the force is.
    observed: Vec<Vec<f64>>,
    peak_force_kn: f64,
    fracture_force_fraction: f64,
    fractured_at: Option<f64>,
    hardening: HardeningSteps,
}

impl OutputCurve {
    fn new(rest: CurvePoint, settings: &LoadingSettings) -> Self {
        let end_mm = settings.end_displacement_mm;
        let interval_mm = settings
            .output_interval_mm
            .min(end_mm)
            .max(settings.min_step_mm);
        OutputCurve {
            interval_mm,
            end_mm,
            next_mm: interval_mm.min(end_mm),
            recent: vec![rest],
            points: vec![rest],
            recent_observed: vec![Vec::new()],
            observed: vec![Vec::new()],
            peak_force_kn: 0.0,
            fracture_force_fraction: settings.fracture_force_fraction,
            fractured_at: None,
            hardening: settings.hardening,
        }
    }

    /// Takes a converged step's point; emits the output points up to it.
    /// Whether the force still rises steeply and smoothly enough for a
    /// longer step (see [`HardeningSteps`]).
    fn converged(&mut self, point: CurvePoint, observed: Vec<f64>) -> bool {
        let same = 1e-12 * self.end_mm.max(1.0);
        if self.recent.len() == 3 {
            self.recent.remove(0);
            self.recent_observed.remove(0);
        }
        self.recent.push(point);
        self.recent_observed.push(observed);
        while self.fractured_at.is_none() && self.next_mm <= point.displacement_mm + same {
            let (output, observed) = if (point.displacement_mm - self.next_mm).abs() <= same {
                (point, self.recent_observed[self.recent.len() - 1].clone())
            } else {
                self.interpolated(self.next_mm)
            };
            self.points.push(output);
            self.observed.push(observed);
            self.peak_force_kn = self.peak_force_kn.max(output.force_kn);
            if output.force_kn < self.fracture_force_fraction * self.peak_force_kn {
                self.fractured_at = Some(output.displacement_mm);
            }
            if self.next_mm >= self.end_mm - same {
                break;
            }
            self.next_mm = (self.next_mm + self.interval_mm).min(self.end_mm);
        }
        let [older, previous, newest] = match self.recent.as_slice() {
            &[a, b, c] => [a, b, c],
            _ => return false,
        };
        let slope = (previous.force_kn - older.force_kn)
            / (previous.displacement_mm - older.displacement_mm);
        let last_step_mm = newest.displacement_mm - previous.displacement_mm;
        let straight = previous.force_kn + slope * last_step_mm;
        // The miss grows with the square of the step: scaled to a long one.
        let missed = (newest.force_kn - straight).abs() / newest.force_kn.abs().max(1e-12)
            * (self.hardening.step_mm / last_step_mm).powi(2);
        let rise_per_mm = (newest.force_kn - previous.force_kn)
            / (newest.displacement_mm - previous.displacement_mm)
            / newest.force_kn.abs().max(1e-12);
        rise_per_mm >= self.hardening.min_rise_per_mm && missed <= self.hardening.curvature
    }

    /// The parabola through the recent converged steps at `x_mm` (a line
    /// with only two), and through what the observer gave for them.
    fn interpolated(&self, x_mm: f64) -> (CurvePoint, Vec<f64>) {
        let newest = self.recent[self.recent.len() - 1];
        let weights: Vec<f64> = self
            .recent
            .iter()
            .enumerate()
            .map(|(i, a)| {
                self.recent
                    .iter()
                    .enumerate()
                    .filter(|&(j, _)| j != i)
                    .map(|(_, b)| {
                        (x_mm - b.displacement_mm) / (a.displacement_mm - b.displacement_mm)
                    })
                    .product()
            })
            .collect();
        let blend = |value: fn(&CurvePoint) -> f64| -> f64 {
            self.recent
                .iter()
                .zip(&weights)
                .map(|(p, w)| w * value(p))
                .sum()
        };
        let point = CurvePoint {
            displacement_mm: x_mm,
            force_kn: blend(|p| p.force_kn),
            neck_diameter_mm: blend(|p| p.neck_diameter_mm),
            failed_points: newest.failed_points,
        };
        // The weights do not depend on the forces: the blend of the forces'
        // derivatives is the derivative of the blend.
        let length = self.recent_observed.iter().map(Vec::len).max().unwrap_or(0);
        let observed = (0..length)
            .map(|i| {
                self.recent_observed
                    .iter()
                    .zip(&weights)
                    .map(|(values, w)| w * values.get(i).copied().unwrap_or(0.0))
                    .sum()
            })
            .collect();
        (point, observed)
    }
}

/// Euclidean norms of the free (out-of-balance) and constrained (reaction)
/// parts of a nodal force vector.
fn norms(force_n: &[f64], is_constrained: &[bool]) -> (f64, f64) {
    let (mut free, mut constrained) = (0.0, 0.0);
    for (f, &c) in force_n.iter().zip(is_constrained) {
        if c {
            constrained += f * f;
        } else {
            free += f * f;
        }
    }
    (free.sqrt(), constrained.sqrt())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tensile::element::Hencky;
    use crate::tensile::mesh::{BarGeometry, MeshDensity};

    /// The elements are evaluated in runs on several threads and scattered
    /// in element order: a damaged bar pulled to fracture gives the same
    /// curve, to the bit, on one thread or more, with runs of any length.
    #[test]
    fn a_pull_gives_the_same_bits_on_one_thread_or_several() {
        use crate::tensile::flow_curve::FlowCurve;
        use crate::tensile::gtn::{Coalescence, Elasticity, GtnMaterial, GtnParameters};
        let material = GtnMaterial::new(
            Elasticity {
                youngs_modulus_mpa: 207_011.0,
                poisson_ratio: 0.3,
            },
            GtnParameters {
                coalescence: Some(Coalescence {
                    critical_porosity: 0.02,
                    failure_porosity: 0.15,
                }),
                ..GtnParameters::tvergaard_chu_needleman(0.001)
            },
            FlowCurve::new(
                vec![0.0, 0.01, 0.04, 0.09],
                vec![404.0, 468.0, 573.0, 650.0],
                534.0,
            )
            .unwrap(),
        )
        .unwrap();
        let density = MeshDensity {
            radial_elements: 4,
            axial_elements: 20,
            ..MeshDensity::default()
        };
        let pull = |threads: usize| {
            let mesh = Mesh::new(&BarGeometry::default(), &density).unwrap();
            Bar::new(mesh, material.clone())
                .with_threads(threads)
                .pull(&LoadingSettings::to(4.0))
        };
        let one = pull(1);
        assert!(
            matches!(one.outcome, Outcome::Fractured { .. }),
            "{:?}",
            one.outcome
        );
        assert!(one.curve.iter().any(|point| point.failed_points > 0));
        for threads in [2, 3] {
            let several = pull(threads);
            assert_eq!(several.outcome, one.outcome, "{threads} threads");
            assert_eq!(several.curve.len(), one.curve.len(), "{threads} threads");
            for (a, b) in several.curve.iter().zip(&one.curve) {
                assert_eq!(
                    a.force_kn.to_bits(),
                    b.force_kn.to_bits(),
                    "{threads} threads at {} mm",
                    a.displacement_mm
                );
                assert_eq!(a.failed_points, b.failed_points);
            }
        }
    }

    #[test]
    fn an_elastic_bar_stretches_uniformly_as_the_closed_form_says() {
        // Hencky: tau_zz = E ln(lambda) under uniaxial stress, so the force
        // is F = tau_zz / J * A = E ln(lambda) A0 / lambda, exactly.
        let geometry = BarGeometry {
            imperfection: 0.0,
            ..BarGeometry::default()
        };
        let mesh = Mesh::new(
            &geometry,
            &MeshDensity {
                radial_elements: 3,
                axial_elements: 4,
                axial_grading: 2.0,
                neck_zone: None,
            },
        )
        .unwrap();
        let material = Hencky {
            youngs_modulus_mpa: 1000.0,
            poisson_ratio: 0.3,
        };
        let bar = Bar::new(mesh, material);
        let mut settings = LoadingSettings::to(2.5);
        settings.output_interval_mm = 0.5;
        // Exact up to the out-of-balance tolerance: a tight one.
        settings.relative_tolerance = 1e-10;
        let result = bar.pull(&settings);
        assert_eq!(result.outcome, Outcome::ReachedEnd);
        assert_eq!(result.curve.len(), 6);
        for point in &result.curve[1..] {
            let stretch = 1.0 + point.displacement_mm / geometry.half_length_mm;
            let expected_kn = 1000.0 * stretch.ln() * geometry.area_mm2() / stretch / 1000.0;
            assert!(
                (point.force_kn - expected_kn).abs() < 1e-9 * expected_kn,
                "{point:?} vs {expected_kn}"
            );
            // Lateral log strain -nu ln(lambda).
            let expected_diameter = geometry.diameter_mm * (-0.3 * stretch.ln()).exp();
            assert!((point.neck_diameter_mm - expected_diameter).abs() < 1e-9);
        }
        // Newton with the exact tangent on a hyperelastic problem: few iterations.
        assert!(result.newton_iterations <= 4 * result.steps, "{result:?}");
    }

    #[test]
    fn long_hardening_steps_interpolate_the_output_points_of_an_elastic_bar() {
        // The same closed form, pulled in output points of 0.01 mm: while
        // the force rises the steps grow to 0.04 mm and the points between
        // are interpolated; the parabola's error is third order in the step
        // (about 1e-8 of the force here).
        let geometry = BarGeometry {
            imperfection: 0.0,
            ..BarGeometry::default()
        };
        let mesh = Mesh::new(&geometry, &MeshDensity::default()).unwrap();
        let material = Hencky {
            youngs_modulus_mpa: 1000.0,
            poisson_ratio: 0.3,
        };
        let result = Bar::new(mesh, material).pull(&LoadingSettings::to(1.0));
        assert_eq!(result.outcome, Outcome::ReachedEnd);
        assert_eq!(result.curve.len(), 101);
        assert!(result.steps < 40, "long steps were taken: {}", result.steps);
        for (k, point) in result.curve.iter().enumerate().skip(1) {
            assert!((point.displacement_mm - 0.01 * k as f64).abs() < 1e-12);
            let stretch = 1.0 + point.displacement_mm / geometry.half_length_mm;
            let expected_kn = 1000.0 * stretch.ln() * geometry.area_mm2() / stretch / 1000.0;
            // The out-of-balance tolerance (3e-4 of the reaction) bounds
            // the rest.
            assert!(
                (point.force_kn - expected_kn).abs() < 3e-4 * expected_kn,
                "{point:?} vs {expected_kn}"
            );
        }
    }

    fn point_at(displacement_mm: f64, force_kn: f64) -> CurvePoint {
        CurvePoint {
            displacement_mm,
            force_kn,
            neck_diameter_mm: 4.0 - displacement_mm,
            failed_points: 0,
        }
    }

    #[test]
    fn the_output_curve_is_exact_for_a_parabola_and_finds_fracture_inside_a_long_step() {
        let parabola = |u: f64| 1.0 + 8.0 * u - 3.0 * u * u;
        let mut settings = LoadingSettings::to(1.0);
        settings.output_interval_mm = 0.01;
        let mut output = OutputCurve::new(point_at(0.0, 1.0), &settings);
        for u in [0.01, 0.02, 0.06, 0.1, 0.14] {
            // What an observer gives is interpolated as the force is.
            output.converged(point_at(u, parabola(u)), vec![u, parabola(u)]);
        }
        assert_eq!(output.points.len(), 15);
        assert_eq!(output.observed.len(), 15);
        for (point, observed) in output.points[1..].iter().zip(&output.observed[1..]) {
            let u = point.displacement_mm;
            assert!((point.force_kn - parabola(u)).abs() < 1e-12, "{point:?}");
            assert!((point.neck_diameter_mm - (4.0 - u)).abs() < 1e-12);
            assert!((observed[0] - u).abs() < 1e-12, "{observed:?}");
            assert!((observed[1] - parabola(u)).abs() < 1e-12, "{observed:?}");
        }
        // A force that falls to 1 % of the maximum within a step: fracture
        // at the first output point below 2 %, none after it.
        output.converged(point_at(0.16, 0.01), Vec::new());
        let fractured = output.fractured_at.expect("fracture");
        assert!((fractured - 0.16).abs() < 1e-12, "{fractured}");
        assert_eq!(
            output.points.last().map(|p| p.displacement_mm),
            Some(fractured)
        );
    }
}
