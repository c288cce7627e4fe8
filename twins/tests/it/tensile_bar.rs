//! The tensile twin's bar against closed forms: uniform finite-strain J2
//! stretching, the Considere force maximum and the neck of the classic
//! necking-bar benchmark, and mesh/step convergence of the pre-peak curve.

use acq_twins::tensile::flow_curve::FlowCurve;
use acq_twins::tensile::gtn::{Elasticity, GtnMaterial, GtnParameters};
use acq_twins::tensile::mesh::{BarGeometry, MeshDensity};
use acq_twins::tensile::solver::{LoadingSettings, Outcome, PullResult};
use acq_twins::tensile::TensileTwin;

/// Saturation hardening of the necking-bar benchmark (Simo 1988; Simo and
/// Armero 1992; de Souza Neto, Peric and Owen 2008, sec. 14.9): MPa.
fn benchmark_flow_stress_mpa(plastic_strain: f64) -> f64 {
    450.0 + 129.24 * plastic_strain + (715.0 - 450.0) * (1.0 - (-16.93 * plastic_strain).exp())
}

fn benchmark_hardening_mpa(plastic_strain: f64) -> f64 {
    129.24 + (715.0 - 450.0) * 16.93 * (-16.93 * plastic_strain).exp()
}

/// The saturation law as a fine table (the flow curve is piecewise linear),
/// continued with its asymptotic slope.
fn benchmark_flow_curve() -> FlowCurve {
    let strains: Vec<f64> = (0..=600)
        .map(|i| 2.0 * (i as f64 / 600.0).powi(2))
        .collect();
    let stresses = strains
        .iter()
        .map(|&e| benchmark_flow_stress_mpa(e))
        .collect();
    FlowCurve::new(strains, stresses, 129.24).unwrap()
}

/// The published Dataset-1 GTN parameters, with optional coalescence.
fn published_dataset_1(coalescence: Option<acq_twins::tensile::gtn::Coalescence>) -> GtnParameters {
    GtnParameters {
        q1: 1.332,
        q2: 0.9952,
        q3: 2.295,
        nucleation_mean_strain: 0.29,
        nucleation_std_strain: 0.1671,
        nucleated_void_fraction: 0.03869,
        initial_porosity: 0.00137,
        coalescence,
    }
}

pub(crate) fn j2_twin(
    geometry: BarGeometry,
    mesh: MeshDensity,
    youngs_modulus_mpa: f64,
    poisson_ratio: f64,
    flow: FlowCurve,
) -> TensileTwin {
    let material = GtnMaterial::new(
        Elasticity {
            youngs_modulus_mpa,
            poisson_ratio,
        },
        GtnParameters::von_mises(),
        flow,
    )
    .unwrap();
    TensileTwin {
        geometry,
        mesh,
        material,
    }
}

/// Force of a bar stretched uniformly, from the 1-D closed form. The axial
/// log strain splits into plastic and elastic parts, the elastic part is
/// Hencky (`tau = E eps_e`, lateral `-nu eps_e`), so the volume ratio is
/// `J = exp((1 - 2 nu) tau / E)` (plastic flow is isochoric); the yield
/// condition holds for the Cauchy stress, `tau / J = sigma_y(eps - tau / E)`,
/// and the force is `sigma A = tau A0 exp(-eps)`.
pub(crate) fn uniform_force_kn(
    axial_log_strain: f64,
    youngs_modulus_mpa: f64,
    poisson_ratio: f64,
    area_mm2: f64,
    flow: &FlowCurve,
) -> f64 {
    let volume_ratio = |tau: f64| ((1.0 - 2.0 * poisson_ratio) * tau / youngs_modulus_mpa).exp();
    let yield_strain = flow.initial_yield_mpa() / youngs_modulus_mpa;
    let tau = if axial_log_strain <= yield_strain {
        youngs_modulus_mpa * axial_log_strain
    } else {
        // Newton on g(tau) = tau - J(tau) sigma_y(eps - tau/E).
        let mut tau = flow.initial_yield_mpa();
        for _ in 0..100 {
            let plastic = axial_log_strain - tau / youngs_modulus_mpa;
            let (stress, slope) = flow.flow_stress_mpa(plastic);
            let ratio = volume_ratio(tau);
            let g = tau - ratio * stress;
            let dg = 1.0 - ratio * (1.0 - 2.0 * poisson_ratio) / youngs_modulus_mpa * stress
                + ratio * slope / youngs_modulus_mpa;
            tau -= g / dg;
            if g.abs() < 1e-12 * tau {
                break;
            }
        }
        tau
    };
    tau * area_mm2 * (-axial_log_strain).exp() / 1000.0
}

#[test]
fn a_perfect_bar_follows_the_uniform_closed_form_through_large_strain() {
    // No imperfection: the deformation stays uniform, so the FE result must
    // be the 1-D closed form to solver tolerance, well past the Considere
    // point (there is no bifurcation without a trigger).
    let flow = benchmark_flow_curve();
    let geometry = BarGeometry {
        diameter_mm: 12.826,
        half_length_mm: 26.667,
        imperfection: 0.0,
    };
    let twin = j2_twin(
        geometry,
        MeshDensity {
            radial_elements: 3,
            axial_elements: 6,
            axial_grading: 2.0,
            neck_zone: None,
        },
        206_900.0,
        0.29,
        flow.clone(),
    );
    // The error follows the out-of-balance tolerance: within it at the
    // default, and 1e-6 at a tolerance a hundred times tighter.
    let default_tolerance = LoadingSettings::to(8.0).relative_tolerance;
    for (tolerance, bound) in [(default_tolerance, default_tolerance), (1e-7, 1e-6)] {
        let mut settings = LoadingSettings::to(8.0);
        settings.output_interval_mm = 0.25;
        settings.relative_tolerance = tolerance;
        let result = twin.pull(&settings).unwrap();
        assert_eq!(result.outcome, Outcome::ReachedEnd);
        let mut worst: f64 = 0.0;
        for point in &result.curve[1..] {
            let strain = (1.0 + point.displacement_mm / geometry.half_length_mm).ln();
            let expected = uniform_force_kn(strain, 206_900.0, 0.29, geometry.area_mm2(), &flow);
            worst = worst.max((point.force_kn - expected).abs() / expected);
        }
        assert!(
            worst < bound,
            "tolerance {tolerance:e}: largest relative force error {worst:e}"
        );
    }
}

fn considere_strain(flow: &FlowCurve) -> f64 {
    // Rigid-plastic Considere: d sigma / d eps = sigma; bisection.
    let (mut low, mut high) = (0.0, 2.0);
    for _ in 0..200 {
        let mid = 0.5 * (low + high);
        let (stress, slope) = flow.flow_stress_mpa(mid);
        if slope > stress {
            low = mid;
        } else {
            high = mid;
        }
    }
    0.5 * (low + high)
}

fn necking_bar(mesh: MeshDensity) -> (TensileTwin, PullResult) {
    // The classic necking bar: radius 6.413 mm, length 53.334 mm (half
    // 26.667), 1.8 % radius reduction at mid-length, E = 206.9 GPa,
    // nu = 0.29, saturation hardening; pulled 7 mm on the half model
    // (14 mm total elongation). Our imperfection has a cosine profile over
    // the half length (the originals taper differently), so the onset of
    // necking is not expected to coincide exactly.
    let geometry = BarGeometry {
        diameter_mm: 12.826,
        half_length_mm: 26.667,
        imperfection: 0.018,
    };
    let twin = j2_twin(geometry, mesh, 206_900.0, 0.29, benchmark_flow_curve());
    let mut settings = LoadingSettings::to(7.0);
    settings.output_interval_mm = 0.1;
    let result = twin.pull(&settings).unwrap();
    (twin, result)
}

#[test]
fn the_necking_bar_peaks_at_the_considere_force_and_then_necks() {
    let (twin, result) = necking_bar(MeshDensity {
        radial_elements: 6,
        axial_elements: 30,
        axial_grading: 6.0,
        neck_zone: None,
    });
    assert_eq!(result.outcome, Outcome::ReachedEnd, "{:?}", result.outcome);
    let flow = &twin.material.flow;
    let geometry = twin.geometry;
    let neck_area = geometry.area_mm2() * (1.0 - geometry.imperfection).powi(2);
    let eps_c = considere_strain(flow);
    let (sigma_c, hardening_c) = flow.flow_stress_mpa(eps_c);
    assert!((hardening_c - benchmark_hardening_mpa(eps_c)).abs() < 0.02 * hardening_c);
    // The weakest section reaches the Considere force first.
    let considere_kn = sigma_c * neck_area * (-eps_c).exp() / 1000.0;
    let (peak_index, peak) = result
        .curve
        .iter()
        .enumerate()
        .max_by(|a, b| a.1.force_kn.total_cmp(&b.1.force_kn))
        .unwrap();
    let relative = (peak.force_kn - considere_kn) / considere_kn;
    assert!(
        relative.abs() < 0.005,
        "peak {} kN vs Considere {considere_kn} kN ({relative:e})",
        peak.force_kn
    );
    // At the peak the neck is still nearly the uniform bar at eps_c.
    let uniform_diameter =
        geometry.diameter_mm * (1.0 - geometry.imperfection) * (-0.5 * eps_c).exp();
    assert!(
        (peak.neck_diameter_mm - uniform_diameter).abs() < 0.02 * uniform_diameter,
        "{peak:?} vs {uniform_diameter}"
    );
    // After the peak the force falls and the neck keeps shrinking.
    let last = result.curve.last().unwrap();
    assert!(peak_index < result.curve.len() - 10);
    assert!(last.force_kn < 0.9 * peak.force_kn, "{last:?}");
    let ratio = last.neck_diameter_mm / geometry.diameter_mm;
    assert!(ratio < 0.75, "radius ratio at 7 mm: {ratio}");
    eprintln!(
        "necking bar: peak {:.3} kN at u = {:.2} mm (Considere {considere_kn:.3} kN), radius ratio at u = 7 mm {ratio:.4}",
        peak.force_kn, peak.displacement_mm
    );
}

/// A P91-like damaged bar: Voce flow curve, the published Dataset-1 GTN
/// parameters.
pub(crate) fn p91_like_twin(mesh: MeshDensity) -> TensileTwin {
    let strains: Vec<f64> = (0..=100).map(|i| 0.1 * i as f64 / 100.0).collect();
    let stresses = strains
        .iter()
        .map(|&e| 440.0 + 260.0 * (1.0 - (-25.0 * e).exp()))
        .collect();
    let flow = FlowCurve::new(strains, stresses, 534.1).unwrap();
    let parameters = published_dataset_1(None);
    let material = GtnMaterial::new(
        Elasticity {
            youngs_modulus_mpa: 207_011.0,
            poisson_ratio: 0.3,
        },
        parameters,
        flow,
    )
    .unwrap();
    TensileTwin {
        geometry: BarGeometry::default(),
        mesh,
        material,
    }
}

fn pull_to(twin: &TensileTwin, end_mm: f64, step_mm: f64) -> PullResult {
    let mut settings = LoadingSettings::to(end_mm);
    settings.output_interval_mm = step_mm;
    twin.pull(&settings).unwrap()
}

#[test]
fn the_pre_peak_curve_is_converged_in_mesh_and_step() {
    // Up to 1 mm (before the force maximum of this material) the curve
    // must not depend on the element size or the load step; after the
    // maximum damage localises and it does (documented, not asserted).
    let coarse = pull_to(
        &p91_like_twin(MeshDensity {
            radial_elements: 4,
            axial_elements: 20,
            axial_grading: 8.0,
            neck_zone: None,
        }),
        1.0,
        0.02,
    );
    let fine = pull_to(
        &p91_like_twin(MeshDensity {
            radial_elements: 8,
            axial_elements: 40,
            axial_grading: 8.0,
            neck_zone: None,
        }),
        1.0,
        0.02,
    );
    let fine_steps = pull_to(
        &p91_like_twin(MeshDensity {
            radial_elements: 4,
            axial_elements: 20,
            axial_grading: 8.0,
            neck_zone: None,
        }),
        1.0,
        0.005,
    );
    assert_eq!(coarse.outcome, Outcome::ReachedEnd);
    assert_eq!(fine.outcome, Outcome::ReachedEnd);
    let peak = fine.max_force_kn();
    let mut mesh_difference: f64 = 0.0;
    let mut step_difference: f64 = 0.0;
    for (index, point) in coarse.curve.iter().enumerate().skip(1) {
        mesh_difference =
            mesh_difference.max((point.force_kn - fine.curve[index].force_kn).abs() / peak);
        // The 0.005 mm run has 4 points per 0.02 mm one.
        let same_point = &fine_steps.curve[4 * index];
        assert!((same_point.displacement_mm - point.displacement_mm).abs() < 1e-12);
        step_difference = step_difference.max((point.force_kn - same_point.force_kn).abs() / peak);
    }
    assert!(mesh_difference < 5e-4, "mesh: {mesh_difference:e}");
    assert!(step_difference < 5e-4, "step: {step_difference:e}");
    eprintln!("pre-peak: mesh 4x20 vs 8x40 {mesh_difference:.2e}, step 0.02 vs 0.005 mm {step_difference:.2e} of the peak");
}

/// With coalescence the voids link up in the neck and the bar breaks: the
/// run ends as `Fractured` (force below 2 % of the peak), the broken points
/// are counted, and the fracture comes after the maximum, in the neck.
#[test]
fn a_bar_with_coalescence_breaks_in_the_neck() {
    use acq_twins::tensile::gtn::Coalescence;
    let flow = FlowCurve::new(
        vec![0.0, 0.005, 0.01, 0.02, 0.04, 0.06, 0.09],
        vec![404.0, 440.0, 468.0, 512.0, 573.0, 615.0, 650.0],
        534.0,
    )
    .unwrap();
    let material = GtnMaterial::new(
        Elasticity {
            youngs_modulus_mpa: 207_011.0,
            poisson_ratio: 0.3,
        },
        published_dataset_1(Some(Coalescence {
            critical_porosity: 0.02,
            failure_porosity: 0.15,
        })),
        flow,
    )
    .unwrap();
    let twin = TensileTwin {
        geometry: BarGeometry::default(),
        mesh: MeshDensity::default(),
        material,
    };
    let result = twin.pull(&LoadingSettings::to(4.0)).unwrap();
    let Outcome::Fractured { displacement_mm } = result.outcome else {
        panic!("expected fracture, got {:?}", result.outcome);
    };
    let peak = result
        .curve
        .iter()
        .max_by(|a, b| a.force_kn.total_cmp(&b.force_kn))
        .unwrap();
    let last = result.curve.last().unwrap();
    println!(
        "fracture at {displacement_mm:.3} mm (peak {:.3} kN at {:.2} mm), {} failed points, {} steps, {} cuts",
        peak.force_kn, peak.displacement_mm, last.failed_points, result.steps, result.step_cuts
    );
    assert!(displacement_mm > peak.displacement_mm + 0.1 && displacement_mm < 4.0);
    assert!(last.force_kn < 0.02 * peak.force_kn, "{last:?}");
    assert!(last.failed_points > 0);
    // Nothing had failed before the force began to drop.
    assert!(result
        .curve
        .iter()
        .filter(|p| p.displacement_mm <= peak.displacement_mm)
        .all(|p| p.failed_points == 0));
    // The neck had thinned well below the uniform diameter at the peak.
    assert!(
        last.neck_diameter_mm < 0.9 * peak.neck_diameter_mm,
        "{last:?}"
    );
}
