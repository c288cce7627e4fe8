//! The curve's sensitivities against what they must equal: the uniform
//! bar's closed form differentiated in the flow curve's slope m, exact
//! zeros where a parameter cannot act, and central differences of whole
//! runs of a necking, damaging bar.

use acq_twins::tensile::flow_curve::FlowCurve;
use acq_twins::tensile::mesh::{BarGeometry, MeshDensity};
use acq_twins::tensile::sensitivity::ForceSensitivities;
use acq_twins::tensile::solver::{LoadingSettings, Outcome, PullResult};
use acq_twins::tensile::{TensileTwin, GTN_PARAMETER_NAMES};

use crate::tensile_bar::{j2_twin, p91_like_twin, uniform_force_kn};

/// Steps of the output interval only, converged far below the default
/// tolerance: differences of whole runs then see the parameter, not the
/// solver's tolerance or a step size that changed with it.
fn exact_settings(end_mm: f64, interval_mm: f64) -> LoadingSettings {
    let mut settings = LoadingSettings::to(end_mm);
    settings.output_interval_mm = interval_mm;
    settings.relative_tolerance = 1e-10;
    settings.hardening.step_mm = 0.0;
    settings
}

fn pull_with_sensitivities(
    twin: &TensileTwin,
    settings: &LoadingSettings,
) -> (PullResult, ForceSensitivities) {
    let (result, sensitivities) = twin.pull_with_sensitivities(settings).unwrap();
    let sensitivities = sensitivities.unwrap();
    assert_eq!(sensitivities.kn_per_unit.len(), result.curve.len());
    assert_eq!(sensitivities.parameter_names, GTN_PARAMETER_NAMES.to_vec());
    (result, sensitivities)
}

/// A flow curve that ends its table at 5 % plastic strain and goes on with
/// slope m: past the table the flow stress is `σ_uts + m (ε_p - ε_uts)`.
fn short_table(post_uts_slope_mpa: f64) -> FlowCurve {
    let strains: Vec<f64> = (0..=10).map(|i| 0.005 * i as f64).collect();
    let stresses = strains
        .iter()
        .map(|&e| 400.0 + 200.0 * (1.0 - (-40.0 * e).exp()))
        .collect();
    FlowCurve::new(strains, stresses, post_uts_slope_mpa).unwrap()
}

#[test]
fn the_uniform_bar_moves_with_m_as_its_closed_form_and_not_with_the_void_parameters() {
    // A perfect bar stays uniform (see the closed-form test of the bar), so
    // its force is the 1-D closed form and so is the force's derivative in
    // m: taken here by central differences of that closed form, an
    // independent calculation.
    let m_mpa = 300.0;
    let geometry = BarGeometry {
        diameter_mm: 6.0,
        half_length_mm: 15.0,
        imperfection: 0.0,
    };
    let mesh = MeshDensity {
        radial_elements: 3,
        axial_elements: 6,
        axial_grading: 2.0,
        neck_zone: None,
    };
    let (youngs_mpa, poisson) = (200_000.0, 0.3);
    let twin = j2_twin(geometry, mesh, youngs_mpa, poisson, short_table(m_mpa));
    let (result, sensitivities) = pull_with_sensitivities(&twin, &exact_settings(3.5, 0.25));
    assert_eq!(result.outcome, Outcome::ReachedEnd);

    let m = GTN_PARAMETER_NAMES.iter().position(|n| *n == "m").unwrap();
    let mut past_the_table = 0;
    for (point, slopes) in result.curve.iter().zip(&sensitivities.kn_per_unit) {
        let strain = (1.0 + point.displacement_mm / geometry.half_length_mm).ln();
        let force = |slope_mpa: f64| {
            uniform_force_kn(
                strain,
                youngs_mpa,
                poisson,
                geometry.area_mm2(),
                &short_table(slope_mpa),
            )
        };
        let closed_form = (force(m_mpa + 1.0) - force(m_mpa - 1.0)) / 2.0;
        // Past the table the slope is about (ε_p - 0.05) A0 exp(-ε) / 1000.
        if closed_form > 1e-4 {
            past_the_table += 1;
        }
        // The bar is still uniform (past about 4 mm it starts to neck from
        // round-off: the force leaves the closed form by 1e-10, its slope
        // in m by 1e-3).
        let uniform = force(m_mpa);
        assert!(
            (point.force_kn - uniform).abs() <= 1e-10 * uniform,
            "at {} mm the bar is no longer uniform",
            point.displacement_mm
        );
        assert!(
            (slopes[m] - closed_form).abs() <= 1e-4 * closed_form.abs() + 1e-9,
            "at {} mm: dF/dm {:e} kN/MPa, closed form {closed_form:e}",
            point.displacement_mm,
            slopes[m]
        );
        // Without voids and with none nucleated (f0 = fN = 0) the yield
        // surface is von Mises whatever q1, q2, q3, εN and sN are.
        for name in ["q1", "q2", "q3", "epsN", "sN"] {
            let index = GTN_PARAMETER_NAMES.iter().position(|n| *n == name).unwrap();
            assert_eq!(slopes[index], 0.0, "{name} at {} mm", point.displacement_mm);
        }
        // Voids, initial or nucleated, can only weaken the bar.
        for name in ["fN", "f0"] {
            let index = GTN_PARAMETER_NAMES.iter().position(|n| *n == name).unwrap();
            assert!(slopes[index] <= 0.0, "{name}: {slopes:?}");
        }
    }
    assert!(
        past_the_table >= 8,
        "only {past_the_table} points past the table"
    );
}

/// The twin with one GTN parameter (in [`GTN_PARAMETER_NAMES`]'s order)
/// moved by `step`.
fn moved(twin: &TensileTwin, index: usize, step: f64) -> TensileTwin {
    let mut twin = twin.clone();
    let p = &mut twin.material.parameters;
    match index {
        0 => p.q1 += step,
        1 => p.q2 += step,
        2 => p.q3 += step,
        3 => p.nucleation_mean_strain += step,
        4 => p.nucleation_std_strain += step,
        5 => p.nucleated_void_fraction += step,
        6 => p.initial_porosity += step,
        _ => {
            let m = twin.material.flow.post_uts_slope_mpa();
            twin.material.flow = twin
                .material
                .flow
                .with_post_uts_slope_mpa(m + step)
                .unwrap();
        }
    }
    twin
}

fn parameter_values(twin: &TensileTwin) -> [f64; 8] {
    let p = &twin.material.parameters;
    [
        p.q1,
        p.q2,
        p.q3,
        p.nucleation_mean_strain,
        p.nucleation_std_strain,
        p.nucleated_void_fraction,
        p.initial_porosity,
        twin.material.flow.post_uts_slope_mpa(),
    ]
}

/// Compares every parameter's sensitivities with central differences of
/// whole runs (a step of `relative` of each value), point by point up to
/// the last `intact_margin` points before the first where a material point
/// has failed (fracture is a jump no derivative follows), within
/// half a percent of that parameter's largest difference along the curve.
fn check_against_whole_runs(
    twin: &TensileTwin,
    settings: &LoadingSettings,
    relative: f64,
    intact_margin: usize,
) {
    let (result, sensitivities) = pull_with_sensitivities(twin, settings);
    let intact = result
        .curve
        .iter()
        .take_while(|p| p.failed_points == 0)
        .count()
        - intact_margin;
    assert!(intact > 10, "only {intact} points before the first failure");
    // Past it the derivative is what the broken bar's equations give, and
    // finite.
    assert!(sensitivities
        .kn_per_unit
        .iter()
        .flatten()
        .all(|v| v.is_finite()));
    let values = parameter_values(twin);
    for (index, name) in GTN_PARAMETER_NAMES.iter().enumerate() {
        let step = relative * values[index].abs();
        let up = moved(twin, index, step).pull(settings).unwrap();
        let down = moved(twin, index, -step).pull(settings).unwrap();
        let length = intact.min(up.curve.len()).min(down.curve.len());
        assert_eq!(length, intact, "{name}: a run ended early");
        let differences: Vec<f64> = (0..length)
            .map(|i| (up.curve[i].force_kn - down.curve[i].force_kn) / (2.0 * step))
            .collect();
        let largest = differences.iter().fold(0.0_f64, |a, d| a.max(d.abs()));
        assert!(largest > 0.0, "{name} moves nothing");
        let worst = (0..length)
            .map(|i| (sensitivities.kn_per_unit[i][index] - differences[i]).abs())
            .fold(0.0_f64, f64::max);

        assert!(
            worst <= 5e-3 * largest,
            "{name}: sensitivities differ from whole runs by {worst:e} kN per unit, \
             the largest difference along the curve is {largest:e}"
        );
    }
}

#[test]
fn a_necking_bar_with_voids_moves_with_each_parameter_as_whole_runs_do() {
    // The P91-like bar of the mesh-convergence test, coarse, pulled past its
    // force maximum into the neck where voids grow and nucleate: every
    // parameter acts.
    let twin = p91_like_twin(MeshDensity {
        radial_elements: 3,
        axial_elements: 12,
        axial_grading: 4.0,
        neck_zone: None,
    });
    check_against_whole_runs(&twin, &exact_settings(3.0, 0.05), 1e-3, 0);
}

#[test]
fn a_bar_that_breaks_moves_as_whole_runs_do_until_its_first_point_fails() {
    // The coalescence bar of the fracture test, coarse: voids link up in
    // the neck and points fail; the sensitivities go on through the failure
    // and agree with whole runs before it. Not the last point before the
    // first failure: there the force falls by a quarter in one output
    // interval as the neck's points unload elastically and coalesce, and
    // the run's derivative (one branch of each point's switch) is 1.5 %
    // from whole runs' (differences of 1e-3 and 1e-4 agree to 0.1 %); the
    // point before it agrees to 1e-5.
    use acq_twins::tensile::gtn::Coalescence;
    let mut twin = p91_like_twin(MeshDensity {
        radial_elements: 4,
        axial_elements: 16,
        axial_grading: 4.0,
        neck_zone: None,
    });
    twin.material.parameters.coalescence = Some(Coalescence {
        critical_porosity: 0.02,
        failure_porosity: 0.15,
    });
    check_against_whole_runs(&twin, &exact_settings(4.0, 0.05), 1e-4, 1);
}
