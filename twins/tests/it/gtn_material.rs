//! Checks of the GTN material point (`acq_twins::tensile::gtn`):
//!
//! 1. the consistent tangent against central finite differences of `update`;
//! 2. the implicit update against an independent, fine-step forward-Euler
//!    integration of the rate equations written here (it shares only
//!    `FlowCurve` with the code under test);
//! 3. the sign of porosity evolution (shear, compression, tension);
//! 4. the J2 limit against closed forms (radial return, uniaxial strain);
//! 5. parameter validation and failure;
//! 6. property tests: never a panic or NaN; a plastic result lies on the yield
//!    surface with the flow along its normal.

use acq_twins::tensile::flow_curve::FlowCurve;
use acq_twins::tensile::gtn::{
    mandel_from_tensor, tensor_from_mandel, yield_function, Coalescence, Elasticity, GtnError,
    GtnMaterial, GtnParameters, Mandel, MandelTangent, MaterialState, ParameterError,
    FAILURE_FRACTION,
};
use nalgebra::{Matrix3, SMatrix, SVector};
use proptest::prelude::*;

type Vector6 = SVector<f64, 6>;
type Matrix6 = SMatrix<f64, 6, 6>;

const SQRT_2: f64 = std::f64::consts::SQRT_2;

// ---------------------------------------------------------------- fixtures

fn p91_elasticity() -> Elasticity {
    Elasticity {
        youngs_modulus_mpa: 207_011.0,
        poisson_ratio: 0.3,
    }
}

/// P91-like matrix curve: ~404 MPa at yield to 650 MPa at eps_p 0.09 (UTS),
/// then m = 534 MPa.
fn p91_flow() -> FlowCurve {
    FlowCurve::new(
        vec![0.0, 0.005, 0.01, 0.02, 0.04, 0.06, 0.09],
        vec![404.0, 440.0, 468.0, 512.0, 573.0, 615.0, 650.0],
        534.0,
    )
    .unwrap()
}

/// Published Dataset 1 GTN parameters (note q3 = 2.295 > q1² = 1.774).
fn p91_parameters() -> GtnParameters {
    GtnParameters {
        q1: 1.332,
        q2: 0.9952,
        q3: 2.295,
        nucleation_mean_strain: 0.29,
        nucleation_std_strain: 0.1671,
        nucleated_void_fraction: 0.03869,
        initial_porosity: 0.00137,
        coalescence: None,
    }
}

fn p91_material() -> GtnMaterial {
    GtnMaterial::new(p91_elasticity(), p91_parameters(), p91_flow()).unwrap()
}

/// Deterministic generator for the seeded loops (SplitMix64).
struct Rng(u64);

impl Rng {
    fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    fn uniform(&mut self, low: f64, high: f64) -> f64 {
        let unit = (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64;
        low + (high - low) * unit
    }
}

fn diagonal(e11: f64, e22: f64, e33: f64) -> Vector6 {
    Vector6::new(e11, e22, e33, 0.0, 0.0, 0.0)
}

// ------------------------------------------- independent explicit integrator
//
// Continuum rate equations, forward Euler, with nothing from gtn.rs: own Mandel
// algebra, own yield function and gradient, own stiffness.
//
//   σ̇ = C:(ε̇ - λ̇ N),  N = ∂Φ/∂σ = Φ_p I/3 + Φ_q (3/2) s/q
//   ε̇_m = λ̇ σ:N / ((1 - f) σ_y)
//   ḟ = (1 - f) λ̇ tr N + A(ε_m) ε̇_m
//   Φ̇ = 0  =>  λ̇ = N:C:ε̇ / (N:C:N - Φ_σy h σ:N/((1-f)σ_y) - Φ_f ((1-f) tr N + A σ:N/((1-f)σ_y)))

struct ExplicitGtn {
    bulk_mpa: f64,
    shear_mpa: f64,
    q1: f64,
    q2: f64,
    q3: f64,
    mean_strain_n: f64,
    std_strain_n: f64,
    fraction_n: f64,
    flow: FlowCurve,
    stress_mpa: Vector6,
    matrix_strain: f64,
    porosity: f64,
}

struct YieldPoint {
    phi: f64,
    gradient: Vector6,
    phi_flow_stress: f64,
    phi_porosity: f64,
    flow_stress_mpa: f64,
    hardening_mpa: f64,
}

impl ExplicitGtn {
    fn new(elasticity: &Elasticity, parameters: &GtnParameters, flow: FlowCurve) -> Self {
        let e = elasticity.youngs_modulus_mpa;
        let nu = elasticity.poisson_ratio;
        Self {
            bulk_mpa: e / (3.0 * (1.0 - 2.0 * nu)),
            shear_mpa: e / (2.0 * (1.0 + nu)),
            q1: parameters.q1,
            q2: parameters.q2,
            q3: parameters.q3,
            mean_strain_n: parameters.nucleation_mean_strain,
            std_strain_n: parameters.nucleation_std_strain,
            fraction_n: parameters.nucleated_void_fraction,
            flow,
            stress_mpa: Vector6::zeros(),
            matrix_strain: 0.0,
            porosity: parameters.initial_porosity,
        }
    }

    fn stiffness_times(&self, strain: &Vector6) -> Vector6 {
        let trace = strain[0] + strain[1] + strain[2];
        let mut stress = strain * (2.0 * self.shear_mpa);
        for i in 0..3 {
            stress[i] += (self.bulk_mpa - 2.0 * self.shear_mpa / 3.0) * trace;
        }
        stress
    }

    fn yield_point(&self, stress: &Vector6) -> YieldPoint {
        let p = (stress[0] + stress[1] + stress[2]) / 3.0;
        let mut s = *stress;
        for i in 0..3 {
            s[i] -= p;
        }
        let q = (1.5 * s.dot(&s)).sqrt();
        let (sy, h) = self.flow.flow_stress_mpa(self.matrix_strain);
        let f = self.porosity;
        let arg = 1.5 * self.q2 * p / sy;
        let phi = (q / sy).powi(2) + 2.0 * self.q1 * f * arg.cosh() - 1.0 - self.q3 * f * f;
        let phi_p = 2.0 * self.q1 * f * arg.sinh() * 1.5 * self.q2 / sy;
        let phi_q = 2.0 * q / (sy * sy);
        let mut gradient = Vector6::zeros();
        if q > 0.0 {
            gradient = s * (phi_q * 1.5 / q);
        }
        for i in 0..3 {
            gradient[i] += phi_p / 3.0;
        }
        YieldPoint {
            phi,
            gradient,
            phi_flow_stress: -2.0 * q * q / sy.powi(3) - 2.0 * self.q1 * f * arg.sinh() * arg / sy,
            phi_porosity: 2.0 * self.q1 * arg.cosh() - 2.0 * self.q3 * f,
            flow_stress_mpa: sy,
            hardening_mpa: h,
        }
    }

    fn nucleation(&self) -> f64 {
        let z = (self.matrix_strain - self.mean_strain_n) / self.std_strain_n;
        self.fraction_n / (self.std_strain_n * (2.0 * std::f64::consts::PI).sqrt())
            * (-0.5 * z * z).exp()
    }

    /// One forward-Euler substep of total strain increment `strain_increment`.
    fn substep(&mut self, strain_increment: &Vector6) {
        let at_start = self.yield_point(&self.stress_mpa);
        let elastic_increment = self.stiffness_times(strain_increment);
        let on_surface = at_start.phi > -1e-6;
        let loading = at_start.gradient.dot(&elastic_increment) > 0.0;
        let mut remaining = *strain_increment;
        if !(on_surface && loading) {
            let trial = self.stress_mpa + elastic_increment;
            if self.yield_point(&trial).phi <= 0.0 {
                self.stress_mpa = trial;
                return;
            }
            // Elastic up to the surface (bisection on the elastic fraction).
            let (mut inside, mut outside) = (0.0_f64, 1.0_f64);
            for _ in 0..60 {
                let mid = 0.5 * (inside + outside);
                if self
                    .yield_point(&(self.stress_mpa + elastic_increment * mid))
                    .phi
                    <= 0.0
                {
                    inside = mid;
                } else {
                    outside = mid;
                }
            }
            self.stress_mpa += elastic_increment * inside;
            remaining = strain_increment * (1.0 - inside);
        }
        let point = self.yield_point(&self.stress_mpa);
        let n = point.gradient;
        let c_n = self.stiffness_times(&n);
        let matrix_fraction = 1.0 - self.porosity;
        let work_per_multiplier =
            self.stress_mpa.dot(&n) / (matrix_fraction * point.flow_stress_mpa);
        let trace_n = n[0] + n[1] + n[2];
        let denominator = n.dot(&c_n)
            - point.phi_flow_stress * point.hardening_mpa * work_per_multiplier
            - point.phi_porosity
                * (matrix_fraction * trace_n + self.nucleation() * work_per_multiplier);
        let multiplier = n.dot(&self.stiffness_times(&remaining)) / denominator;
        if multiplier <= 0.0 {
            self.stress_mpa += self.stiffness_times(&remaining);
            return;
        }
        let matrix_increment = multiplier * work_per_multiplier;
        let porosity_increment =
            matrix_fraction * multiplier * trace_n + self.nucleation() * matrix_increment;
        self.stress_mpa += self.stiffness_times(&(remaining - n * multiplier));
        self.matrix_strain += matrix_increment;
        self.porosity += porosity_increment;
    }
}

/// Total-strain path: piecewise linear through `waypoints` (starting at 0),
/// evaluated at parameter `t` in [0, 1] with equal time per leg.
fn path_strain(waypoints: &[Vector6], t: f64) -> Vector6 {
    let legs = waypoints.len();
    let position = (t * legs as f64).min(legs as f64);
    let leg = (position.floor() as usize).min(legs - 1);
    let local = position - leg as f64;
    let start = if leg == 0 {
        Vector6::zeros()
    } else {
        waypoints[leg - 1]
    };
    start + (waypoints[leg] - start) * local
}

struct PathSample {
    stress_mpa: Vector6,
    porosity: f64,
    matrix_strain: f64,
}

fn run_explicit(
    material: &GtnMaterial,
    waypoints: &[Vector6],
    substeps: usize,
    samples: usize,
) -> Vec<PathSample> {
    let mut model = ExplicitGtn::new(
        &material.elasticity,
        &material.parameters,
        material.flow.clone(),
    );
    let mut out = Vec::with_capacity(samples);
    let per_sample = substeps / samples;
    let mut previous = Vector6::zeros();
    for k in 1..=substeps {
        let strain = path_strain(waypoints, k as f64 / substeps as f64);
        model.substep(&(strain - previous));
        previous = strain;
        if k % per_sample == 0 {
            out.push(PathSample {
                stress_mpa: model.stress_mpa,
                porosity: model.porosity,
                matrix_strain: model.matrix_strain,
            });
        }
    }
    out
}

fn run_implicit(material: &GtnMaterial, waypoints: &[Vector6], steps: usize) -> Vec<PathSample> {
    let mut state = MaterialState::initial(&material.parameters);
    let mut elastic_strain = Mandel::zeros();
    let mut previous = Vector6::zeros();
    let mut out = Vec::with_capacity(steps);
    for k in 1..=steps {
        let strain = path_strain(waypoints, k as f64 / steps as f64);
        let update = material
            .update(&state, &(elastic_strain + (strain - previous)))
            .unwrap_or_else(|error| panic!("step {k}: {error}"));
        assert!(!update.state.failed, "step {k} failed");
        previous = strain;
        state = update.state;
        elastic_strain = update.elastic_strain;
        out.push(PathSample {
            stress_mpa: update.stress_mpa,
            porosity: state.porosity,
            matrix_strain: state.matrix_plastic_strain,
        });
    }
    out
}

struct Agreement {
    /// max over the path of |σ_imp - σ_exp| (any component) / peak stress
    /// (largest |σ_ij| of the explicit path).
    stress: f64,
    /// The same at the end of the path (away from yield knees and corners).
    final_stress: f64,
    /// max |f_imp - f_exp| / max(f_exp).
    porosity: f64,
    /// max |ε_m,imp - ε_m,exp| / max(ε_m,exp).
    matrix_strain: f64,
    peak_stress_mpa: f64,
}

/// Explicit reference: 100,000 forward-Euler substeps, sampled at 2000 points.
const EXPLICIT_SUBSTEPS: usize = 100_000;
const REFERENCE_SAMPLES: usize = 2000;

fn von_mises(stress: &Vector6) -> f64 {
    let p = (stress[0] + stress[1] + stress[2]) / 3.0;
    let mut s = *stress;
    for i in 0..3 {
        s[i] -= p;
    }
    (1.5 * s.dot(&s)).sqrt()
}

fn triaxiality(stress: &Vector6) -> f64 {
    (stress[0] + stress[1] + stress[2]) / 3.0 / von_mises(stress)
}

fn compare(
    material: &GtnMaterial,
    waypoints: &[Vector6],
    reference: &[PathSample],
    implicit_steps: usize,
) -> Agreement {
    let implicit = run_implicit(material, waypoints, implicit_steps);
    let stride = reference.len() / implicit_steps;
    let explicit: Vec<&PathSample> = reference.iter().skip(stride - 1).step_by(stride).collect();
    assert_eq!(explicit.len(), implicit.len());
    let peak = reference
        .iter()
        .map(|s| s.stress_mpa.amax())
        .fold(0.0, f64::max);
    let max_porosity = reference.iter().map(|s| s.porosity).fold(0.0, f64::max);
    let max_matrix = reference
        .iter()
        .map(|s| s.matrix_strain)
        .fold(0.0, f64::max);
    let mut agreement = Agreement {
        stress: 0.0,
        final_stress: 0.0,
        porosity: 0.0,
        matrix_strain: 0.0,
        peak_stress_mpa: peak,
    };
    for (e, i) in explicit.iter().zip(&implicit) {
        agreement.final_stress = (e.stress_mpa - i.stress_mpa).amax() / peak;
        agreement.stress = agreement.stress.max(agreement.final_stress);
        agreement.porosity = agreement
            .porosity
            .max((e.porosity - i.porosity).abs() / max_porosity);
        agreement.matrix_strain = agreement
            .matrix_strain
            .max((e.matrix_strain - i.matrix_strain).abs() / max_matrix);
    }
    agreement
}

/// A comparison path with the tolerances its shape allows at 200 implicit
/// steps (max over the path of the stress error, fraction of peak stress).
struct ComparisonPath {
    name: &'static str,
    waypoints: Vec<Vector6>,
    stress_tolerance_200: f64,
}

fn comparison_paths() -> Vec<ComparisonPath> {
    vec![
        // Uniaxial strain: the triaxiality jumps to ~3.5 right after yield and
        // q falls from 406 to ~210 MPa within ε ≈ 0.01 (25 steps of 200): the
        // first-order error peaks there (~1 % measured).
        ComparisonPath {
            name: "uniaxial strain",
            waypoints: vec![diagonal(0.08, 0.0, 0.0)],
            stress_tolerance_200: 1.5e-2,
        },
        // Lateral/axial strain-rate ratios -0.47 and -0.41: the triaxiality
        // over the plastic part averages ~1 and ~2 (plastic dilatation absorbs
        // the imposed volume change, so it does not run away). Smooth paths:
        // 0.5 % of peak stress.
        ComparisonPath {
            name: "triaxial T~1",
            waypoints: vec![diagonal(0.2, -0.2 * 0.47, -0.2 * 0.47)],
            stress_tolerance_200: 5e-3,
        },
        ComparisonPath {
            name: "triaxial T~2",
            waypoints: vec![diagonal(0.1, -0.1 * 0.41, -0.1 * 0.41)],
            stress_tolerance_200: 5e-3,
        },
        // Tension, then shear at fixed normal strains: the flow direction turns
        // abruptly at the corner, where the first-order error peaks (~2 %).
        ComparisonPath {
            name: "tension then shear",
            waypoints: vec![
                diagonal(0.1, -0.1 * 0.47, -0.1 * 0.47),
                diagonal(0.1, -0.1 * 0.47, -0.1 * 0.47)
                    + Vector6::new(0.0, 0.0, 0.0, 0.0, 0.0, SQRT_2 * 0.1),
            ],
            stress_tolerance_200: 2.5e-2,
        },
    ]
}

// ---------------------------------------------------------------- 1. tangent

fn finite_difference_tangent(
    material: &GtnMaterial,
    state: &MaterialState,
    strain: &Mandel,
    step: f64,
) -> Option<MandelTangent> {
    let mut tangent = MandelTangent::zeros();
    for j in 0..6 {
        let mut plus = *strain;
        let mut minus = *strain;
        plus[j] += step;
        minus[j] -= step;
        let up = material.update(state, &plus).ok()?;
        let down = material.update(state, &minus).ok()?;
        if !(up.plastic && down.plastic) || up.state.failed || down.state.failed {
            return None;
        }
        tangent.set_column(j, &((up.stress_mpa - down.stress_mpa) / (2.0 * step)));
    }
    Some(tangent)
}

fn random_trial_strain(rng: &mut Rng, magnitude: f64) -> Mandel {
    let mut strain = Mandel::zeros();
    for component in strain.iter_mut() {
        *component = rng.uniform(-1.0, 1.0);
    }
    // A volumetric bias spreads the triaxiality from compression to ~3.
    let bias = rng.uniform(-0.3, 1.0);
    for i in 0..3 {
        strain[i] += bias;
    }
    strain * (magnitude / strain.norm())
}

#[test]
fn consistent_tangent_matches_central_differences() {
    let mut rng = Rng(0x5EED_0001);
    let with_coalescence = GtnMaterial {
        parameters: GtnParameters {
            coalescence: Some(Coalescence {
                critical_porosity: 0.06,
                failure_porosity: 0.2,
            }),
            ..p91_parameters()
        },
        ..p91_material()
    };
    let without_nucleation = GtnMaterial {
        parameters: GtnParameters {
            nucleated_void_fraction: 0.0,
            ..p91_parameters()
        },
        ..p91_material()
    };
    let materials = [p91_material(), with_coalescence, without_nucleation];
    let mut checked = 0;
    let mut nucleating = 0;
    let mut worst = 0.0_f64;
    for sample in 0..600 {
        let material = &materials[sample % 3];
        let state = MaterialState {
            matrix_plastic_strain: rng.uniform(0.0, 0.6),
            porosity: rng.uniform(0.0, 0.1),
            failed: false,
            last_increments: [0.0; 4],
        };
        let magnitude = rng.uniform(0.002, 0.02);
        let strain = random_trial_strain(&mut rng, magnitude);
        let update = material.update(&state, &strain).unwrap();
        if !update.plastic || update.state.failed {
            continue;
        }
        // 1e-7 relative: truncation error ~h² is negligible and rounding
        // (1e-16 σ / h ~ 1e-9 relative) is far below the 1e-5 bound.
        let step = 1e-7 * strain.amax();
        let Some(numerical) = finite_difference_tangent(material, &state, &strain, step) else {
            continue;
        };
        let error = (numerical - update.tangent_mpa).norm() / update.tangent_mpa.norm();
        assert!(
            error < 1e-5,
            "sample {sample}: relative tangent error {error:e} at {state:?}, strain {strain:?}"
        );
        worst = worst.max(error);
        checked += 1;
        let (intensity, _) = material
            .parameters
            .nucleation_intensity(update.state.matrix_plastic_strain);
        if intensity > 1e-3 {
            nucleating += 1;
        }
    }
    println!("tangent: {checked} plastic states, {nucleating} with nucleation active, worst relative error {worst:.2e}");
    assert!(checked >= 300, "only {checked} plastic samples");
    assert!(
        nucleating >= 50,
        "only {nucleating} samples with active nucleation"
    );
}

/// At finite strain the return mapping solves for the Kirchhoff stress τ
/// while the yield function and the work equivalence of the reference hold
/// for the Cauchy stress τ/J: check both conditions directly with the public
/// yield function, and `∂τ/∂J` against central differences in J.
#[test]
fn volume_ratio_puts_the_cauchy_stress_on_the_yield_surface() {
    let mut rng = Rng(0x5EED_0007);
    let material = p91_material();
    let mut checked = 0;
    let mut worst_sensitivity = 0.0_f64;
    for sample in 0..300 {
        let state = MaterialState {
            matrix_plastic_strain: rng.uniform(0.0, 0.5),
            porosity: rng.uniform(0.001, 0.08),
            failed: false,
            last_increments: [0.0; 4],
        };
        let volume_ratio = rng.uniform(0.98, 1.12);
        let magnitude = rng.uniform(0.003, 0.02);
        let strain = random_trial_strain(&mut rng, magnitude);
        let update = material
            .update_at_volume_ratio(&state, &strain, volume_ratio)
            .unwrap();
        if !update.plastic || update.state.failed {
            continue;
        }
        let cauchy = update.stress_mpa / volume_ratio;
        let mean = (cauchy[0] + cauchy[1] + cauchy[2]) / 3.0;
        let (flow_stress, _) = material
            .flow
            .flow_stress_mpa(update.state.matrix_plastic_strain);
        let phi = yield_function(
            &material.parameters,
            mean,
            von_mises(&cauchy),
            flow_stress,
            update.state.porosity,
        );
        assert!(phi.abs() < 1e-8, "sample {sample}: Φ(τ/J) = {phi:e}");
        // (1 - f) σ_y Δε_m = σ : Δε_p, Δε_p = ε_tr - ε_e.
        let plastic_increment = strain - update.elastic_strain;
        let matrix_increment = update.state.matrix_plastic_strain - state.matrix_plastic_strain;
        let work = cauchy.dot(&plastic_increment);
        let matrix_work = (1.0 - update.state.porosity) * flow_stress * matrix_increment;
        assert!(
            (work - matrix_work).abs() <= 1e-8 * work.abs().max(1e-6),
            "sample {sample}: σ:Δε_p = {work:e}, (1-f) σ_y Δε_m = {matrix_work:e}"
        );

        let step = 1e-6;
        let up = material
            .update_at_volume_ratio(&state, &strain, volume_ratio + step)
            .unwrap();
        let down = material
            .update_at_volume_ratio(&state, &strain, volume_ratio - step)
            .unwrap();
        if !(up.plastic && down.plastic) || up.state.failed || down.state.failed {
            continue;
        }
        let numerical = (up.stress_mpa - down.stress_mpa) / (2.0 * step);
        let error = (numerical - update.stress_by_volume_ratio_mpa).norm()
            / update.stress_by_volume_ratio_mpa.norm().max(1.0);
        assert!(
            error < 1e-5,
            "sample {sample}: ∂τ/∂J {:?} vs differences {numerical:?}",
            update.stress_by_volume_ratio_mpa
        );
        worst_sensitivity = worst_sensitivity.max(error);
        checked += 1;
    }
    println!("∂τ/∂J: {checked} plastic states, worst relative error {worst_sensitivity:.2e}");
    assert!(checked >= 150, "only {checked} plastic samples");
}

#[test]
fn volume_ratio_one_is_the_small_strain_update() {
    let material = p91_material();
    let state = MaterialState {
        matrix_plastic_strain: 0.1,
        porosity: 0.01,
        failed: false,
        last_increments: [0.0; 4],
    };
    let strain = diagonal(0.01, -0.002, -0.002);
    let small = material.update(&state, &strain).unwrap();
    let finite = material
        .update_at_volume_ratio(&state, &strain, 1.0)
        .unwrap();
    assert_eq!(small, finite);
    assert!(small.stress_by_volume_ratio_mpa.norm() > 0.0);
    for bad in [0.0, -1.0, f64::NAN, f64::INFINITY] {
        assert!(matches!(
            material.update_at_volume_ratio(&state, &strain, bad),
            Err(GtnError::InvalidVolumeRatio { .. })
        ));
    }
}

#[test]
fn hydrostatic_trial_tangent_matches_central_differences() {
    // q_tr = 0: the flow direction is undefined; the deviatoric tangent is the
    // limit 2G q/q_tr.
    let material = p91_material();
    let state = MaterialState {
        matrix_plastic_strain: 0.1,
        porosity: 0.05,
        failed: false,
        last_increments: [0.0; 4],
    };
    let strain = diagonal(0.004, 0.004, 0.004);
    let update = material.update(&state, &strain).unwrap();
    assert!(update.plastic);
    // A smaller step: the deviatoric response is only smooth to first order
    // around q = 0 (q enters squared), so the central difference has an O(h)
    // error there.
    let numerical = finite_difference_tangent(&material, &state, &strain, 1e-9).unwrap();
    let error = (numerical - update.tangent_mpa).norm() / update.tangent_mpa.norm();
    assert!(error < 1e-4, "relative tangent error {error:e}");
}

// --------------------------------------------- 2. implicit vs explicit paths

#[test]
fn implicit_update_matches_fine_explicit_integration() {
    let material = p91_material();
    for path in comparison_paths() {
        let name = path.name;
        let reference = run_explicit(
            &material,
            &path.waypoints,
            EXPLICIT_SUBSTEPS,
            REFERENCE_SAMPLES,
        );
        let mut errors = Vec::new();
        for steps in [100, 200, 2000] {
            let agreement = compare(&material, &path.waypoints, &reference, steps);
            println!(
                "{name:>20} {steps:>5} steps: stress max {:.2e} / end {:.2e} of peak {:.0} MPa, porosity {:.2e}, eps_m {:.2e}",
                agreement.stress,
                agreement.final_stress,
                agreement.peak_stress_mpa,
                agreement.porosity,
                agreement.matrix_strain
            );
            errors.push(agreement);
        }
        let coarse = &errors[1];
        let fine = &errors[2];
        // 200 steps: the path's stress tolerance (see `comparison_paths`);
        // porosity and matrix strain within 1 % of their maxima (measured
        // <= 0.3 %), and at the end of the path, away from knees and corners,
        // 0.5 % of peak stress.
        assert!(
            coarse.stress < path.stress_tolerance_200,
            "{name}: stress {:e}",
            coarse.stress
        );
        assert!(
            coarse.final_stress < 5e-3,
            "{name}: final stress {:e}",
            coarse.final_stress
        );
        assert!(
            coarse.porosity < 1e-2,
            "{name}: porosity {:e}",
            coarse.porosity
        );
        assert!(
            coarse.matrix_strain < 1e-2,
            "{name}: eps_m {:e}",
            coarse.matrix_strain
        );
        // 2000 steps: backward Euler is first order, so 10x smaller steps
        // must cut every error at least 5x (both schemes converge to the same
        // solution; the explicit reference is ~20x finer still).
        assert!(
            fine.stress < coarse.stress / 5.0,
            "{name}: stress {:e}",
            fine.stress
        );
        assert!(
            fine.stress < path.stress_tolerance_200 / 5.0,
            "{name}: stress {:e}",
            fine.stress
        );
        assert!(fine.porosity < 1e-3, "{name}: porosity {:e}", fine.porosity);
        assert!(
            fine.matrix_strain < 1e-3,
            "{name}: eps_m {:e}",
            fine.matrix_strain
        );
    }
}

#[test]
fn comparison_paths_reach_the_intended_triaxialities() {
    let material = p91_material();
    let paths = comparison_paths();
    let mean_plastic_triaxiality = |index: usize| {
        let samples = run_explicit(&material, &paths[index].waypoints, 20_000, 20);
        let plastic: Vec<f64> = samples
            .iter()
            .filter(|s| s.matrix_strain > 0.0)
            .map(|s| triaxiality(&s.stress_mpa))
            .collect();
        plastic.iter().sum::<f64>() / plastic.len() as f64
    };
    let t1 = mean_plastic_triaxiality(1);
    let t2 = mean_plastic_triaxiality(2);
    println!("mean plastic triaxiality: {t1:.2}, {t2:.2}");
    assert!((0.8..1.3).contains(&t1), "T~1 path averages {t1}");
    assert!((1.6..2.3).contains(&t2), "T~2 path averages {t2}");
}

// ------------------------------------------------------- 3. porosity sign

fn drive(material: &GtnMaterial, increment: &Vector6, steps: usize) -> Vec<MaterialState> {
    let mut state = MaterialState::initial(&material.parameters);
    let mut elastic = Mandel::zeros();
    let mut states = vec![state];
    for _ in 0..steps {
        let update = material.update(&state, &(elastic + increment)).unwrap();
        state = update.state;
        elastic = update.elastic_strain;
        states.push(state);
    }
    states
}

#[test]
fn isochoric_shear_without_nucleation_keeps_the_porosity() {
    let material = GtnMaterial {
        parameters: GtnParameters {
            nucleated_void_fraction: 0.0,
            initial_porosity: 0.01,
            ..p91_parameters()
        },
        ..p91_material()
    };
    // Simple shear strain: p = 0 throughout, so no volumetric flow.
    let shear = Vector6::new(0.0, 0.0, 0.0, 0.0, 0.0, SQRT_2 * 0.003);
    let states = drive(&material, &shear, 100);
    let last = states.last().unwrap();
    assert!(last.matrix_plastic_strain > 0.2, "{last:?}");
    for state in &states {
        // Rounding only: p is 0 to ~1e-13 MPa, so sinh(...) ~1e-16.
        assert!((state.porosity - 0.01).abs() < 1e-14, "{state:?}");
    }
    // With nucleation the same path does raise the porosity.
    let nucleating = GtnMaterial {
        parameters: GtnParameters {
            initial_porosity: 0.01,
            ..p91_parameters()
        },
        ..p91_material()
    };
    let states = drive(&nucleating, &shear, 100);
    assert!(
        states.last().unwrap().porosity > 0.015,
        "{:?}",
        states.last()
    );
}

#[test]
fn porosity_shrinks_under_compression_and_grows_under_tension() {
    let material = GtnMaterial {
        parameters: GtnParameters {
            nucleated_void_fraction: 0.0,
            initial_porosity: 0.02,
            ..p91_parameters()
        },
        ..p91_material()
    };
    let compression = drive(&material, &diagonal(-0.001, 0.0, 0.0), 80);
    for pair in compression.windows(2) {
        assert!(pair[1].porosity <= pair[0].porosity, "{pair:?}");
        assert!(pair[1].porosity >= 0.0, "{pair:?}");
    }
    assert!(
        compression.last().unwrap().porosity < 0.019,
        "{:?}",
        compression.last()
    );
    let tension = drive(&material, &diagonal(0.001, 0.0, 0.0), 80);
    for pair in tension.windows(2) {
        assert!(pair[1].porosity >= pair[0].porosity, "{pair:?}");
    }
    assert!(
        tension.last().unwrap().porosity > 0.03,
        "{:?}",
        tension.last()
    );
}

#[test]
fn hydrostatic_compression_closes_voids_but_never_below_zero() {
    let material = GtnMaterial {
        parameters: GtnParameters {
            nucleated_void_fraction: 0.0,
            initial_porosity: 0.05,
            ..p91_parameters()
        },
        ..p91_material()
    };
    // The implicit closure f = f_n/(1 + c) stays >= 0.
    let states = drive(&material, &diagonal(-0.002, -0.002, -0.002), 100);
    for pair in states.windows(2) {
        assert!(pair[1].porosity <= pair[0].porosity);
        assert!(pair[1].porosity >= 0.0);
    }
    assert!(
        states.last().unwrap().porosity < 0.01,
        "{:?}",
        states.last()
    );
}

// --------------------------------------------------------------- 4. J2 limit

fn j2_material(hardening_mpa: f64) -> GtnMaterial {
    GtnMaterial::new(
        p91_elasticity(),
        GtnParameters::von_mises(),
        FlowCurve::linear(400.0, hardening_mpa).unwrap(),
    )
    .unwrap()
}

#[test]
fn j2_limit_uniaxial_strain_matches_closed_form() {
    let hardening = 1500.0;
    let material = j2_material(hardening);
    let e = 207_011.0;
    let nu = 0.3;
    let bulk = e / (3.0 * (1.0 - 2.0 * nu));
    let shear = e / (2.0 * (1.0 + nu));
    let mut state = MaterialState::initial(&material.parameters);
    let mut elastic = Mandel::zeros();
    let step = 0.0005;
    let mut plastic_steps = 0;
    for k in 1..=200 {
        let total = step * k as f64;
        let update = material
            .update(&state, &(elastic + diagonal(step, 0.0, 0.0)))
            .unwrap();
        state = update.state;
        elastic = update.elastic_strain;
        // Closed form: p = K e; q = min(2G e, σ0 + H ε_m) with
        // ε_m = (2G e - σ0)/(3G + H) once 2G e > σ0 (radial return is exact
        // on a proportional path with linear hardening).
        let matrix_strain = ((2.0 * shear * total - 400.0) / (3.0 * shear + hardening)).max(0.0);
        let q = (2.0 * shear * total).min(400.0 + hardening * matrix_strain);
        let p = bulk * total;
        let expected = diagonal(p + 2.0 * q / 3.0, p - q / 3.0, p - q / 3.0);
        let error = (update.stress_mpa - expected).amax() / expected.amax();
        // 1e-12: both sides are exact up to rounding of O(10) operations.
        assert!(error < 1e-12, "step {k}: relative error {error:e}");
        assert!(
            (state.matrix_plastic_strain - matrix_strain).abs() <= 1e-12 * matrix_strain.max(1e-3)
        );
        assert_eq!(state.porosity, 0.0);
        plastic_steps += usize::from(update.plastic);
    }
    assert!(plastic_steps > 150);
}

#[test]
fn j2_limit_matches_radial_return_and_its_tangent() {
    let hardening = 800.0;
    let material = j2_material(hardening);
    let bulk = material.elasticity.bulk_modulus_mpa();
    let shear = material.elasticity.shear_modulus_mpa();
    let mut rng = Rng(0x5EED_0004);
    let mut checked = 0;
    for _ in 0..300 {
        let matrix_strain_n = rng.uniform(0.0, 0.3);
        let state = MaterialState {
            matrix_plastic_strain: matrix_strain_n,
            porosity: 0.0,
            failed: false,
            last_increments: [0.0; 4],
        };
        let magnitude = rng.uniform(0.001, 0.03);
        let strain = random_trial_strain(&mut rng, magnitude);
        let update = material.update(&state, &strain).unwrap();

        // Classic radial return, written out here.
        let volumetric = strain[0] + strain[1] + strain[2];
        let mut deviatoric_strain = strain;
        for i in 0..3 {
            deviatoric_strain[i] -= volumetric / 3.0;
        }
        let trial_deviator = deviatoric_strain * (2.0 * shear);
        let trial_q = (1.5 * trial_deviator.dot(&trial_deviator)).sqrt();
        let yield_n = 400.0 + hardening * matrix_strain_n;
        let increment = ((trial_q - yield_n) / (3.0 * shear + hardening)).max(0.0);
        let scale = 1.0 - 3.0 * shear * increment / trial_q;
        let mut expected = trial_deviator * scale;
        for i in 0..3 {
            expected[i] += bulk * volumetric;
        }
        let error = (update.stress_mpa - expected).amax() / expected.amax();
        assert!(error < 1e-12, "stress relative error {error:e}");
        assert!(
            (update.state.matrix_plastic_strain - (matrix_strain_n + increment)).abs()
                <= 1e-12 * (matrix_strain_n + increment).max(1e-3)
        );
        if increment == 0.0 {
            assert!(!update.plastic);
            continue;
        }
        // Simo-Hughes consistent tangent:
        // D = K 1⊗1 + 2G θ I_dev - 2G θ̄ n̂⊗n̂, θ = 1 - 3G Δγ/q_tr,
        // θ̄ = 1/(1 + H/3G) - (1 - θ), n̂ = s_tr/|s_tr|.
        let theta = 1.0 - 3.0 * shear * increment / trial_q;
        let theta_bar = 1.0 / (1.0 + hardening / (3.0 * shear)) - (1.0 - theta);
        let unit = trial_deviator / trial_deviator.norm();
        let one = Vector6::new(1.0, 1.0, 1.0, 0.0, 0.0, 0.0);
        let deviatoric_projector = Matrix6::identity() - one * one.transpose() / 3.0;
        let expected_tangent = one * one.transpose() * bulk
            + deviatoric_projector * (2.0 * shear * theta)
            - unit * unit.transpose() * (2.0 * shear * theta_bar);
        let tangent_error =
            (update.tangent_mpa - expected_tangent).norm() / expected_tangent.norm();
        // Rounding ~1e-15 (the general solver's 4x4 LU too), 1e-11 leaves room.
        assert!(
            tangent_error < 1e-11,
            "tangent relative error {tangent_error:e}"
        );
        let asymmetry = (update.tangent_mpa - update.tangent_mpa.transpose()).norm()
            / update.tangent_mpa.norm();
        assert!(
            asymmetry < 1e-12,
            "J2 tangent must be symmetric: {asymmetry:e}"
        );
        // ∂τ/∂J: J scales the flow stress, q = J σ_y(ε_m,n + Δ), so at J = 1
        // dq/dJ = 3G σ_y / (3G + H) along n = 3/2 s_tr/q_tr; and central
        // differences in J.
        let flow_direction = trial_deviator * (1.5 / trial_q);
        let yield_now = 400.0 + hardening * (matrix_strain_n + increment);
        let expected_sensitivity =
            flow_direction * (2.0 * shear * yield_now / (3.0 * shear + hardening));
        let sensitivity_error = (update.stress_by_volume_ratio_mpa - expected_sensitivity).amax()
            / expected_sensitivity.amax();
        assert!(
            sensitivity_error < 1e-11,
            "∂τ/∂J relative error {sensitivity_error:e}"
        );
        let step = 1e-6;
        let at = |volume_ratio: f64| {
            material
                .update_at_volume_ratio(&state, &strain, volume_ratio)
                .unwrap()
        };
        let (up, down) = (at(1.0 + step), at(1.0 - step));
        if up.plastic && down.plastic {
            let numerical = (up.stress_mpa - down.stress_mpa) / (2.0 * step);
            let error = (numerical - expected_sensitivity).amax() / expected_sensitivity.amax();
            assert!(error < 1e-6, "∂τ/∂J against differences: {error:e}");
        }
        checked += 1;
    }
    assert!(checked > 150, "{checked}");
}

// ------------------------------------------------- 5. validation and failure

#[test]
fn each_bad_parameter_is_named() {
    let good = p91_parameters();
    let cases: Vec<(GtnParameters, &str)> = vec![
        (GtnParameters { q1: 0.0, ..good }, "q1"),
        (
            GtnParameters {
                q1: f64::NAN,
                ..good
            },
            "q1",
        ),
        (GtnParameters { q2: -1.0, ..good }, "q2"),
        (GtnParameters { q3: -0.1, ..good }, "q3"),
        (
            GtnParameters {
                nucleation_mean_strain: f64::INFINITY,
                ..good
            },
            "epsN",
        ),
        (
            GtnParameters {
                nucleation_std_strain: 0.0,
                ..good
            },
            "sN",
        ),
        (
            GtnParameters {
                nucleated_void_fraction: -0.01,
                ..good
            },
            "fN",
        ),
        (
            GtnParameters {
                initial_porosity: -1e-3,
                ..good
            },
            "f0",
        ),
        (
            GtnParameters {
                initial_porosity: 1.0,
                ..good
            },
            "f0",
        ),
        (
            GtnParameters {
                coalescence: Some(Coalescence {
                    critical_porosity: 0.0,
                    failure_porosity: 0.2,
                }),
                ..good
            },
            "f_c",
        ),
        (
            GtnParameters {
                coalescence: Some(Coalescence {
                    critical_porosity: 0.9,
                    failure_porosity: 0.95,
                }),
                ..good
            },
            "f_c",
        ),
        (
            GtnParameters {
                coalescence: Some(Coalescence {
                    critical_porosity: 0.05,
                    failure_porosity: 0.04,
                }),
                ..good
            },
            "f_F",
        ),
        (
            GtnParameters {
                initial_porosity: 0.1,
                coalescence: Some(Coalescence {
                    critical_porosity: 0.02,
                    failure_porosity: 0.08,
                }),
                ..good
            },
            "f0",
        ),
    ];
    for (parameters, name) in cases {
        let error = parameters.validate().unwrap_err();
        let message = error.to_string();
        assert!(message.contains(name), "{name}: {message}");
        // The material refuses to update with them.
        let material = GtnMaterial {
            parameters,
            ..p91_material()
        };
        assert!(matches!(
            material.update(&MaterialState::initial(&good), &Mandel::zeros()),
            Err(GtnError::InvalidParameters(_))
        ));
    }
    assert!(good.validate().is_ok());
    assert!(GtnParameters::von_mises().validate().is_ok());
    let bad_elasticity = [
        Elasticity {
            youngs_modulus_mpa: 0.0,
            poisson_ratio: 0.3,
        },
        Elasticity {
            youngs_modulus_mpa: 2e5,
            poisson_ratio: 0.5,
        },
    ];
    assert!(matches!(
        bad_elasticity[0].validate(),
        Err(ParameterError::YoungsModulus(_))
    ));
    assert!(matches!(
        bad_elasticity[1].validate(),
        Err(ParameterError::PoissonRatio(_))
    ));
}

#[test]
fn porosity_functions() {
    let mut parameters = p91_parameters();
    // q3 > q1²: no real root, failure at f = 1.
    assert_eq!(parameters.failure_porosity(), 1.0);
    parameters.q3 = parameters.q1 * parameters.q1;
    assert!((parameters.failure_porosity() - 1.0 / parameters.q1).abs() < 1e-15);
    parameters.q3 = 1.5;
    let root = parameters.failure_porosity();
    assert!((1.0 - 2.0 * parameters.q1 * root + 1.5 * root * root).abs() < 1e-14);
    parameters.coalescence = Some(Coalescence {
        critical_porosity: 0.04,
        failure_porosity: 0.2,
    });
    assert_eq!(parameters.failure_porosity(), 0.2);
    assert_eq!(parameters.effective_porosity(0.03), (0.03, 1.0));
    let (at_failure, slope) = parameters.effective_porosity(0.2);
    assert!((at_failure - parameters.ultimate_effective_porosity()).abs() < 1e-14);
    assert!((slope - (at_failure - 0.04) / 0.16).abs() < 1e-12);
}

#[test]
fn mandel_round_trip_and_double_contraction() {
    let a = Matrix3::new(1.0, 2.0, 3.0, 2.0, 4.0, 5.0, 3.0, 5.0, 6.0);
    let b = Matrix3::new(-1.0, 0.5, 0.2, 0.5, 2.0, -0.3, 0.2, -0.3, 0.7);
    assert_eq!(tensor_from_mandel(&mandel_from_tensor(&a)), a);
    let contraction: f64 = a.component_mul(&b).sum();
    assert!((mandel_from_tensor(&a).dot(&mandel_from_tensor(&b)) - contraction).abs() < 1e-13);
}

#[test]
fn coalescence_path_fails_cleanly_and_stays_failed() {
    let material = GtnMaterial {
        parameters: GtnParameters {
            coalescence: Some(Coalescence {
                critical_porosity: 0.02,
                failure_porosity: 0.1,
            }),
            ..p91_parameters()
        },
        ..p91_material()
    };
    let mut state = MaterialState::initial(&material.parameters);
    let mut elastic = Mandel::zeros();
    let mut failed_at = None;
    for k in 0..2000 {
        let update = material
            .update(&state, &(elastic + diagonal(0.002, 0.0, 0.0)))
            .unwrap_or_else(|error| panic!("step {k}: {error}"));
        assert!(update.stress_mpa.iter().all(|v| v.is_finite()));
        assert!(update.tangent_mpa.iter().all(|v| v.is_finite()));
        if update.state.failed {
            assert_eq!(update.stress_mpa, Mandel::zeros());
            assert_eq!(update.tangent_mpa, MandelTangent::zeros());
            failed_at.get_or_insert(k);
        } else {
            assert!(failed_at.is_none(), "a failed point came back at step {k}");
            assert!(update.state.porosity < FAILURE_FRACTION * 0.1);
        }
        state = update.state;
        elastic = update.elastic_strain;
    }
    let failed_at = failed_at.expect("uniaxial strain to 4 must fail the point");
    println!("coalescence path failed at step {failed_at}");
}

#[test]
fn hydrostatic_tension_to_large_strain_never_gives_nan() {
    // P91 (q3 > q1², no coalescence): the surface never vanishes, failure only
    // near f = 1. Also q3 = q1², where the surface vanishes at f = 1/q1.
    let p91 = p91_material();
    let vanishing = GtnMaterial {
        parameters: GtnParameters {
            q3: 1.332 * 1.332,
            ..p91_parameters()
        },
        ..p91_material()
    };
    for (name, material) in [("p91", p91), ("q3 = q1^2", vanishing)] {
        let mut state = MaterialState::initial(&material.parameters);
        let mut elastic = Mandel::zeros();
        let mut failed = false;
        for k in 0..400 {
            match material.update(&state, &(elastic + diagonal(0.01, 0.01, 0.01))) {
                Ok(update) => {
                    assert!(
                        update.stress_mpa.iter().all(|v| v.is_finite()),
                        "{name} {k}"
                    );
                    assert!(update.state.porosity.is_finite() && update.state.porosity < 1.0);
                    state = update.state;
                    elastic = update.elastic_strain;
                    failed |= state.failed;
                }
                Err(error) => panic!("{name} step {k}: {error}"),
            }
        }
        assert!(
            failed,
            "{name}: volumetric strain 12 must fail the point ({state:?})"
        );
    }
}

#[test]
fn bad_inputs_are_errors() {
    let material = p91_material();
    let state = MaterialState::initial(&material.parameters);
    let mut strain = Mandel::zeros();
    strain[4] = f64::NAN;
    assert!(matches!(
        material.update(&state, &strain),
        Err(GtnError::NonFiniteTrialStrain { component: 4, .. })
    ));
    for bad in [
        MaterialState {
            porosity: -0.1,
            ..state
        },
        MaterialState {
            porosity: 1.0,
            ..state
        },
        MaterialState {
            matrix_plastic_strain: f64::NAN,
            ..state
        },
        MaterialState {
            matrix_plastic_strain: -1.0,
            ..state
        },
    ] {
        assert!(matches!(
            material.update(&bad, &Mandel::zeros()),
            Err(GtnError::InvalidState { .. })
        ));
    }
    let failed = MaterialState {
        failed: true,
        ..state
    };
    let update = material.update(&failed, &diagonal(0.01, 0.0, 0.0)).unwrap();
    assert!(update.state.failed && !update.plastic);
    assert_eq!(update.stress_mpa, Mandel::zeros());
}

// ------------------------------------------------------------ 6. properties

fn parameters_strategy() -> impl Strategy<Value = GtnParameters> {
    (
        (0.9..1.6f64, 0.9..1.1f64, 0.81..2.56f64),
        (0.25..0.40f64, 0.10..0.20f64, 0.0..0.09f64, 0.0..0.01f64),
        prop::option::of((0.02..0.1f64, 0.05..0.3f64)),
    )
        .prop_map(
            |((q1, q2, q3), (mean, std, fraction, f0), coalescence)| GtnParameters {
                q1,
                q2,
                q3,
                nucleation_mean_strain: mean,
                nucleation_std_strain: std,
                nucleated_void_fraction: fraction,
                initial_porosity: f0,
                coalescence: coalescence.map(|(critical, extra)| Coalescence {
                    critical_porosity: critical,
                    failure_porosity: critical + extra,
                }),
            },
        )
}

proptest! {
    #![proptest_config(ProptestConfig {
        cases: 2000,
        failure_persistence: None,
        ..ProptestConfig::default()
    })]

    #[test]
    fn update_is_finite_and_a_plastic_result_satisfies_the_local_equations(
        parameters in parameters_strategy(),
        matrix_plastic_strain in 0.0..1.0f64,
        porosity_fraction in 0.0..1.0f64,
        strain in prop::array::uniform6(-0.05..0.05f64),
    ) {
        prop_assume!(parameters.validate().is_ok());
        check_local_equations(parameters, matrix_plastic_strain, porosity_fraction, strain)?;
    }
}

/// The property above: a finite update, and a plastic one on the yield
/// surface of its new state with a plastic strain along the normal.
fn check_local_equations(
    parameters: GtnParameters,
    matrix_plastic_strain: f64,
    porosity_fraction: f64,
    strain: [f64; 6],
) -> Result<(), TestCaseError> {
    let material = GtnMaterial {
        parameters,
        ..p91_material()
    };
    let state = MaterialState {
        matrix_plastic_strain,
        porosity: porosity_fraction * 0.2 * parameters.failure_porosity(),
        failed: false,
        last_increments: [0.0; 4],
    };
    let trial = Mandel::from_row_slice(&strain);
    let Ok(update) = material.update(&state, &trial) else {
        // An error is allowed (the caller cuts the step); a panic is not.
        return Ok(());
    };
    prop_assert!(update.stress_mpa.iter().all(|v| v.is_finite()));
    prop_assert!(update.elastic_strain.iter().all(|v| v.is_finite()));
    prop_assert!(update.tangent_mpa.iter().all(|v| v.is_finite()));
    prop_assert!(update.state.porosity >= 0.0 && update.state.porosity < 1.0);
    prop_assert!(update.state.matrix_plastic_strain >= state.matrix_plastic_strain);
    if update.state.failed {
        prop_assert_eq!(update.stress_mpa, Mandel::zeros());
        return Ok(());
    }
    if !update.plastic {
        prop_assert!(material.yield_function_at(&update.stress_mpa, &state) <= 1e-10);
        return Ok(());
    }
    // Consistency: on the yield surface of the new state. Φ is
    // dimensionless (~2x relative stress error); 1e-9 is far above the
    // Newton tolerance and far below any real error.
    let phi = material.yield_function_at(&update.stress_mpa, &update.state);
    // f_{n+1} = f_n + (1 - f) Δε_v + A Δε_m. When compression closes the
    // voids, f_n or the nucleated A Δε_m, it is the small difference of
    // larger terms and only known to ~1e-16 of them: Φ (dominated by
    // 2 q1 f cosh, ∂Φ/∂f ~ 1/f on the surface) then carries an error
    // ~1e-16 (terms)/f_{n+1}. A Δε_m is bounded by |Δf| + |Δε_v|.
    let [volumetric_increment, _, _, porosity_increment] = update.state.last_increments;
    let terms = state.porosity + 2.0 * volumetric_increment.abs() + porosity_increment.abs();
    let rounding = 1e-13 * terms / update.state.porosity.max(1e-300);
    prop_assert!(phi.abs() < 1e-9 + rounding, "phi = {}", phi);
    // Normality: Δε_p = ε_tr - ε_e parallel to ∂Φ/∂σ at the new stress,
    // with a non-negative multiplier.
    let plastic_increment = trial - update.elastic_strain;
    let normal = yield_gradient(&material, &update.stress_mpa, &update.state);
    let multiplier = plastic_increment.dot(&normal) / normal.norm_squared();
    prop_assert!(multiplier >= 0.0);
    let misfit = (plastic_increment - normal * multiplier).norm() / plastic_increment.norm();
    // Same rounding allowance: ∂Φ/∂p is proportional to f_{n+1}.
    prop_assert!(misfit < 1e-8 + rounding, "flow-rule misfit {}", misfit);
    Ok(())
}

/// A case the property once found: a void-free point under ~15 σ_y of
/// pressure whose voids nucleate (A Δε_m = 0.021) and close (Δε_v = -0.021)
/// in one step to f = 1.9e-10. Φ of the returned stress is -4e-8: one
/// rounding unit of those terms times ∂Φ/∂f ~ 1/f, not a Newton error.
#[test]
fn voids_nucleating_from_zero_leave_the_stress_on_the_surface() {
    let parameters = GtnParameters {
        q1: 0.9,
        q2: 0.9,
        q3: 0.81,
        nucleation_mean_strain: 0.25,
        nucleation_std_strain: 0.193_063_323_412_265_76,
        nucleated_void_fraction: 0.065_457_184_724_356_12,
        initial_porosity: 0.0,
        coalescence: Some(Coalescence {
            critical_porosity: 0.02,
            failure_porosity: 0.07,
        }),
    };
    let strain = [
        -0.037_724_799_079_210_94,
        -0.029_262_870_293_411_33,
        -0.036_789_572_452_014_356,
        0.0,
        0.0,
        0.030_518_302_808_203_782,
    ];
    check_local_equations(parameters, 0.138_143_183_462_964_1, 0.0, strain).unwrap();
}

/// ∂Φ/∂σ from a central difference of the public yield function (5e-4 MPa
/// steps on stresses of order 100-1000 MPa: error ~1e-10 relative).
fn yield_gradient(material: &GtnMaterial, stress: &Mandel, state: &MaterialState) -> Mandel {
    let (flow_stress, _) = material.flow.flow_stress_mpa(state.matrix_plastic_strain);
    let (f_star, _) = material.parameters.effective_porosity(state.porosity);
    let phi = |sigma: &Mandel| {
        let p = (sigma[0] + sigma[1] + sigma[2]) / 3.0;
        yield_function(
            &material.parameters,
            p,
            von_mises(sigma),
            flow_stress,
            f_star,
        )
    };
    let step = 5e-4;
    let mut gradient = Mandel::zeros();
    for j in 0..6 {
        let mut plus = *stress;
        let mut minus = *stress;
        plus[j] += step;
        minus[j] -= step;
        gradient[j] = (phi(&plus) - phi(&minus)) / (2.0 * step);
    }
    gradient
}

#[test]
fn a_trial_a_hair_outside_the_surface_converges() {
    // Regression: the return mapping starts at zero increments for such a
    // trial, and a zero strain scale once made every Newton step look
    // infinitely bad (found by the tensile bar near the force maximum).
    let material = p91_material();
    let state = MaterialState {
        matrix_plastic_strain: 0.08,
        porosity: 0.004,
        failed: false,
        last_increments: [0.0; 4],
    };
    let direction = diagonal(-0.3, 1.0, -0.3);
    let stiffness = material.elasticity.stiffness_mpa();
    let phi_at = |t: f64| material.yield_function_at(&(stiffness * (direction * t)), &state);
    let (mut low, mut high) = (0.0, 0.01);
    for _ in 0..200 {
        let mid = 0.5 * (low + high);
        if phi_at(mid) > 0.0 {
            high = mid;
        } else {
            low = mid;
        }
    }
    for excess in [1e-12, 1e-10, 1e-8, 1e-6] {
        let trial = direction * (high * (1.0 + excess));
        let update = material
            .update(&state, &trial)
            .unwrap_or_else(|e| panic!("excess {excess}: {e}"));
        assert!(update.state.matrix_plastic_strain >= state.matrix_plastic_strain);
        assert!(update.state.matrix_plastic_strain - state.matrix_plastic_strain < 1e-5);
    }
}
