//! Mesh convergence of the GTN twin: one parameter set at several element
//! sizes in the neck, the curves overlaid, and per size the MAPE, the
//! maximum force and where the bar broke.
//!
//! GTN softening localises in one band of elements, so after the maximum
//! force the curve depends on the element size. This is the table a user
//! reads before choosing the size to calibrate at (`acq twin gtn
//! --convergence`).

use std::fmt::Write as _;

use acq_report::plot::{chart_svg, Chart, Series, SeriesStyle};
use acq_twins::tensile::mesh::MeshDensity;
use acq_twins::tensile::solver::Outcome;

use acq_study::mesh_study::{
    curve_convergence, output_convergence, MeshStudyOutcome, OutputConvergence,
};

use crate::calibrate::builtin::GTN_CURVE;
use crate::tensile_model::{GtnInputs, TensileModel};

/// One element size's run.
#[derive(Clone, Debug)]
pub struct SizeRun {
    pub element_mm: f64,
    pub mesh: MeshDensity,
    pub mape_pct: f64,
    pub max_force_kn: f64,
    /// Where the force fell to the fracture fraction, or the run stopped
    /// converging; None if the bar held to the test's last displacement.
    pub fracture_mm: Option<f64>,
    /// (displacement mm, force kN).
    pub curve: Vec<(f64, f64)>,
    pub steps: usize,
    pub newton_iterations: usize,
    pub wall_s: f64,
}

/// Runs `inputs` on `model`'s test at each of `sizes_mm` (neck zone
/// `zone_mm`, default half a diameter), coarsest first.
///
/// # Errors
/// A size the bar cannot be meshed at, or parameters out of range: the
/// message names the size.
pub fn mesh_convergence(
    model: &TensileModel,
    inputs: &GtnInputs,
    sizes_mm: &[f64],
    zone_mm: Option<f64>,
    mut progress: impl FnMut(&SizeRun),
) -> Result<Vec<SizeRun>, String> {
    let mut sizes = sizes_mm.to_vec();
    sizes.sort_by(|a, b| b.total_cmp(a));
    let mut runs = Vec::with_capacity(sizes.len());
    for element_mm in sizes {
        let mesh = MeshDensity::by_element_size(&model.settings.geometry, element_mm, zone_mm)
            .map_err(|e| format!("element size {element_mm} mm: {e}"))?;
        let mut sized = model.clone();
        sized.settings.mesh = mesh;
        let run = sized.run(inputs)?;
        let fracture_mm = match run.result.outcome {
            Outcome::ReachedEnd => None,
            Outcome::Fractured { displacement_mm }
            | Outcome::NotConverged {
                displacement_mm, ..
            } => Some(displacement_mm),
        };
        let size_run = SizeRun {
            element_mm,
            mesh,
            mape_pct: run.mape.mape_percent,
            max_force_kn: run.result.max_force_kn(),
            fracture_mm,
            curve: run
                .result
                .curve
                .iter()
                .map(|p| (p.displacement_mm, p.force_kn))
                .collect(),
            steps: run.result.steps,
            newton_iterations: run.result.newton_iterations,
            wall_s: run.wall_s,
        };
        progress(&size_run);
        runs.push(size_run);
    }
    Ok(runs)
}

/// The table of a convergence study, one line per size.
pub fn convergence_table(runs: &[SizeRun]) -> String {
    let mut text = String::from(
        "element mm  mesh       MAPE %  max force kN  broke at mm  steps  iterations  wall s\n",
    );
    for run in runs {
        let mesh = format!("{}x{}", run.mesh.radial_elements, run.mesh.axial_elements);
        let broke = run
            .fracture_mm
            .map_or_else(|| "held".to_string(), |d| format!("{d:.4}"));
        let _ = writeln!(
            text,
            "{:>10.4}  {mesh:<9} {:>7.3}  {:>12.4}  {broke:>11}  {:>5}  {:>10}  {:>6.2}",
            run.element_mm,
            run.mape_pct,
            run.max_force_kn,
            run.steps,
            run.newton_iterations,
            run.wall_s
        );
    }
    text
}

/// The runs as a mesh study (the format of `acq mesh-study`'s): the grid
/// convergence of each scalar they give (`max_force_kn`, `mape_pct`, and
/// `fracture_mm` when every size broke) and the force curve compared part
/// by part (`force_displacement`), at the parameter point `at`.
///
/// # Errors
/// An output whose values the procedure cannot take (not finite).
pub fn mesh_study_outcome(
    runs: &[SizeRun],
    at: Vec<(String, f64)>,
) -> Result<MeshStudyOutcome, String> {
    let by_size = |value: &dyn Fn(&SizeRun) -> Option<f64>| -> Vec<(f64, Option<f64>)> {
        runs.iter().map(|r| (r.element_mm, value(r))).collect()
    };
    let mut scalars = vec![
        ("max_force_kn", by_size(&|r| Some(r.max_force_kn))),
        ("mape_pct", by_size(&|r| Some(r.mape_pct))),
    ];
    if runs.iter().all(|r| r.fracture_mm.is_some()) {
        scalars.push(("fracture_mm", by_size(&|r| r.fracture_mm)));
    }
    let outputs = scalars
        .into_iter()
        .map(|(key, values)| output_convergence(key.into(), &values))
        .collect::<acq_error::Result<Vec<_>>>()
        .map_err(|e| e.to_string())?;
    // After the maximum force the softening localises in one band of
    // elements, and those parts converge differently from the hardening
    // before it, which one number would hide.
    let curve = curve_convergence(
        GTN_CURVE.into(),
        ["displacement [mm]".into(), "force [kN]".into()],
        runs.iter()
            .map(|r| (r.element_mm, r.curve.clone()))
            .collect(),
    )
    .map_err(|e| e.to_string())?;
    Ok(MeshStudyOutcome {
        outputs,
        curves: vec![curve],
        at,
        evaluations: runs.len(),
        failed: 0,
        size_unit: Some("mm".into()),
    })
}

/// A mesh study's grid convergence as text, with three sizes or more: a
/// line per scalar and per part of the force curve, the convergence named
/// (Celik et al. 2008; least squares beyond three sizes).
pub fn grid_convergence_lines(outcome: &MeshStudyOutcome) -> String {
    let line = |output: &OutputConvergence| {
        output
            .convergence
            .as_ref()
            .map_or_else(|| "fewer than three sizes".to_string(), |s| s.to_string())
    };
    if outcome.evaluations < 3 {
        return String::new();
    }
    let mut text = String::from("grid convergence (the finest size's GCI):\n");
    for output in &outcome.outputs {
        let _ = writeln!(text, "  {:<13} {}", output.key, line(output));
    }
    for curve in &outcome.curves {
        if !curve.parts.is_empty() {
            text.push_str(
                "the force curve part by part (its mean force over each span of displacement):\n",
            );
        }
        for (from_mm, to_mm, part) in &curve.parts {
            let _ = writeln!(text, "  {from_mm:.3} .. {to_mm:.3} mm  {}", line(part));
        }
    }
    text
}

/// The test's points and each size's curve in one plot.
pub fn convergence_svg(title: &str, test: &[(f64, f64)], runs: &[SizeRun]) -> String {
    let mut chart = Chart::new(title, "displacement (half gauge), mm", "force, kN");
    chart
        .series
        .push(Series::new("test", test.to_vec()).with_style(SeriesStyle::Markers));
    for run in runs {
        chart.series.push(Series::new(
            format!(
                "{} mm elements (MAPE {:.2} %)",
                run.element_mm, run.mape_pct
            ),
            run.curve.clone(),
        ));
    }
    chart_svg(&chart, 760.0, 480.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn run(element_mm: f64, fracture_mm: Option<f64>) -> SizeRun {
        SizeRun {
            element_mm,
            mesh: MeshDensity::default(),
            mape_pct: 2.5,
            max_force_kn: 7.4,
            fracture_mm,
            curve: vec![(0.0, 0.0), (1.0, 7.4)],
            steps: 10,
            newton_iterations: 25,
            wall_s: 0.5,
        }
    }

    #[test]
    fn the_table_has_a_line_per_size_and_says_where_the_bar_broke() {
        let table = convergence_table(&[run(0.33, None), run(0.09, Some(1.75))]);
        let lines: Vec<&str> = table.lines().collect();
        assert_eq!(lines.len(), 3);
        assert!(lines[1].contains("held"), "{table}");
        assert!(lines[2].contains("1.7500"), "{table}");
        assert!(lines[2].trim_start().starts_with("0.0900"), "{table}");
        let svg = convergence_svg("t", &[(0.5, 3.0)], &[run(0.33, None)]);
        assert!(svg.starts_with("<svg") && svg.contains("0.33 mm elements"));
    }
}
