//! The reports of a tensile test and of the GTN twin run on it: the flow
//! curve and simulated curve as CSV, the text reports of `acq tensile-props`
//! and `acq twin gtn`, and their SVG figures. The method is documented in
//! [`acq_analysis::extract::tensile_props`] and [`crate::tensile_model`].

use std::fmt::Write as _;

use acq_analysis::extract::tensile_props::{FlowPoint, TensileProperties};
use acq_report::plot::{chart_svg, grid_svg, Chart, Series, SeriesStyle};

/// Header of the flow curve CSV.
pub const FLOW_CURVE_HEADER: &str = "PLASTIC_STRAIN,TRUE_STRESS_MPA";

/// The flow curve as CSV, shortest round-trip numbers.
/// A path's file name for a title (the whole path if it has none).
pub fn file_name(path: &std::path::Path) -> String {
    path.file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| path.display().to_string())
}

pub fn flow_curve_csv(points: &[FlowPoint]) -> String {
    let mut text = String::with_capacity(32 * (points.len() + 1));
    text.push_str(FLOW_CURVE_HEADER);
    text.push('\n');
    for point in points {
        let _ = writeln!(text, "{},{}", point.plastic_strain, point.true_stress_mpa);
    }
    text
}

/// The human-readable report.
pub fn report(name: &str, p: &TensileProperties) -> String {
    let mut out = String::new();
    let fit = &p.elastic_fit;
    let y = &p.yield_point;
    let uts = &p.uts;
    let m = &p.post_uts_slope;
    let flow = &p.flow_curve;
    let _ = writeln!(
        out,
        "{name}: {} points; specimen diameter {} mm (area {:.4} mm2), strain = displacement / {} mm",
        p.test_points, p.diameter_mm, p.area_mm2, p.strain_length_mm
    );
    let _ = writeln!(
        out,
        "Young's modulus E   {:.0} MPa: least squares through the origin over points {}..{} ({} points, stress <= {:.1} MPa = min(60 % UTS, 80 % Rp0.2)), rms residual {:.1} MPa",
        p.youngs_modulus_mpa,
        fit.first_point,
        fit.last_point,
        fit.points_used,
        fit.stress_limit_mpa,
        fit.rms_residual_mpa
    );
    let _ = writeln!(
        out,
        "yield Rp0.2         {:.1} MPa (0.2 % offset) at strain {:.5}, u = {:.5} mm, F = {:.4} kN; true stress {:.1} MPa",
        y.stress_mpa, y.strain, y.displacement_mm, y.force_kn, y.true_stress_mpa
    );
    let _ = writeln!(
        out,
        "UTS                 {} kN at u = {} mm (point {}): engineering {:.1} MPa at strain {:.5}; true {:.1} MPa at true strain {:.5}",
        uts.force_kn,
        uts.displacement_mm,
        uts.point,
        uts.engineering_stress_mpa,
        uts.engineering_strain,
        uts.true_stress_mpa,
        uts.true_strain
    );
    let fits: Vec<String> = m
        .fits
        .iter()
        .map(|f| format!("{}: {:.1}", f.points, f.slope_mpa))
        .collect();
    let _ = writeln!(
        out,
        "post-UTS slope m    fits to the last n points up to the UTS (n: MPa) {}; bounds {} .. {} MPa (largest rounded up to {} MPa)",
        fits.join(", "),
        m.lower_bound_mpa,
        m.upper_bound_mpa,
        acq_analysis::extract::tensile_props::SLOPE_BOUND_STEP_MPA
    );
    let _ = writeln!(
        out,
        "flow curve          {} rows from the onset of plasticity (strain {:.5}, after point {}) to the UTS, plastic strain unshifted; dropped {} non-increasing, pooled {} for a rising stress",
        flow.points.len(),
        flow.onset_strain,
        flow.onset_after_point,
        flow.dropped_non_increasing,
        flow.pooled_for_increasing_stress
    );
    let _ = writeln!(
        out,
        "  {:>14}  {:>17}",
        "plastic strain", "true stress [MPa]"
    );
    let rows = &flow.points;
    let shown: Vec<usize> = if rows.len() <= 6 {
        (0..rows.len()).collect()
    } else {
        vec![0, 1, 2, rows.len() - 3, rows.len() - 2, rows.len() - 1]
    };
    for (k, &i) in shown.iter().enumerate() {
        if k > 0 && i != shown[k - 1] + 1 {
            let _ = writeln!(out, "  {:>14}  {:>17}", "...", "...");
        }
        let _ = writeln!(
            out,
            "  {:>14.6}  {:>17.2}",
            rows[i].plastic_strain, rows[i].true_stress_mpa
        );
    }
    for note in &p.notes {
        let _ = writeln!(out, "note: {note}");
    }
    out
}

/// Three panels: the engineering curve with E, the offset line, Rp0.2 and
/// the UTS; the same zoomed on the elastic range; the flow curve with its
/// extensions past the UTS at the bounds of m (mapped exactly to plastic
/// strain).
pub fn properties_svg(
    title: &str,
    points: &[acq_analysis::extract::tensile_props::TestPoint],
    p: &TensileProperties,
) -> String {
    let strain = |u: f64| u / p.strain_length_mm;
    let stress = |f: f64| 1000.0 * f / p.area_mm2;
    let engineering: Vec<(f64, f64)> = points
        .iter()
        .map(|q| (strain(q.displacement_mm), stress(q.force_kn)))
        .collect();
    let e = p.youngs_modulus_mpa;
    let y = &p.yield_point;
    let elastic_end = y.stress_mpa / e;
    let offset = acq_analysis::extract::tensile_props::YIELD_OFFSET_STRAIN;
    let marked = |name: &str, series: Series| {
        Chart::new(name, "engineering strain [-]", "engineering stress [MPa]")
            .with_series(series)
            .with_series(
                Series::new(
                    format!("E = {:.0} GPa", e / 1000.0),
                    vec![(0.0, 0.0), (elastic_end, y.stress_mpa)],
                )
                .with_style(SeriesStyle::Dashed),
            )
            .with_series(
                Series::new(
                    "0.2 % offset",
                    vec![(offset, 0.0), (y.strain, y.stress_mpa)],
                )
                .with_style(SeriesStyle::Dashed),
            )
            .with_series(
                Series::new(
                    format!("Rp0.2 = {:.1} MPa", y.stress_mpa),
                    vec![(y.strain, y.stress_mpa)],
                )
                .with_style(SeriesStyle::Markers),
            )
            .with_series(
                Series::new(
                    format!("UTS = {:.1} MPa", p.uts.engineering_stress_mpa),
                    vec![(p.uts.engineering_strain, p.uts.engineering_stress_mpa)],
                )
                .with_style(SeriesStyle::Markers),
            )
    };
    let whole = marked(
        "Engineering stress-strain",
        Series::new("test", engineering.clone()),
    );
    // The elastic range up to a little past Rp0.2, every point marked.
    let zoom_strain = 2.0 * y.strain;
    let elastic_points: Vec<(f64, f64)> = engineering
        .iter()
        .copied()
        .take_while(|&(strain, _)| strain <= 1.5 * zoom_strain)
        .collect();
    let zoom = marked(
        "Elastic range: E and Rp0.2",
        Series::new("test", elastic_points).with_style(SeriesStyle::LineAndMarkers),
    )
    .with_x_range(0.0, zoom_strain)
    .with_y_range(0.0, 1.2 * y.stress_mpa);

    // Extensions: true stress = UTS + m (true strain - UTS true strain), up
    // to the true strain of the last test point (at least 1.5x the UTS's).
    let last_true_strain = points
        .last()
        .map(|q| strain(q.displacement_mm).ln_1p())
        .unwrap_or(p.uts.true_strain)
        .max(1.5 * p.uts.true_strain);
    let extension = |m: f64| -> Vec<(f64, f64)> {
        (0..=20)
            .map(|k| {
                let true_strain =
                    p.uts.true_strain + (last_true_strain - p.uts.true_strain) * k as f64 / 20.0;
                let true_stress = p.uts.true_stress_mpa + m * (true_strain - p.uts.true_strain);
                (true_strain - true_stress / e, true_stress)
            })
            .collect()
    };
    let flow: Vec<(f64, f64)> = p
        .flow_curve
        .points
        .iter()
        .map(|f| (f.plastic_strain, f.true_stress_mpa))
        .collect();
    let m = &p.post_uts_slope;
    let right = Chart::new(
        "Flow curve and post-UTS slope bounds",
        "plastic strain [-]",
        "true stress [MPa]",
    )
    .with_series(Series::new("flow curve (test)", flow).with_style(SeriesStyle::LineAndMarkers))
    .with_series(
        Series::new(
            format!("m = {} MPa", m.lower_bound_mpa),
            extension(m.lower_bound_mpa),
        )
        .with_style(SeriesStyle::Dashed),
    )
    .with_series(
        Series::new(
            format!("m = {} MPa", m.upper_bound_mpa),
            extension(m.upper_bound_mpa),
        )
        .with_style(SeriesStyle::Dashed),
    );
    grid_svg(title, &[whole, zoom, right], 3, 440.0, 380.0)
}

/// Header of the simulated curve CSV (the test files' first two columns).
pub const SIMULATED_CURVE_HEADER: &str = "DISPLACEMENT,FORCE,NECK_DIAMETER,FAILED_POINTS";

/// The simulated curve as CSV.
pub fn simulated_curve_csv(curve: &[acq_twins::tensile::solver::CurvePoint]) -> String {
    let mut text = String::from(SIMULATED_CURVE_HEADER);
    text.push('\n');
    for p in curve {
        let _ = writeln!(
            text,
            "{},{},{},{}",
            p.displacement_mm, p.force_kn, p.neck_diameter_mm, p.failed_points
        );
    }
    text
}

pub fn twin_report(
    name: &str,
    model: &crate::tensile_model::TensileModel,
    inputs: &crate::tensile_model::GtnInputs,
    run: &crate::tensile_model::TensileRun,
) -> String {
    use acq_twins::tensile::solver::Outcome;
    let p = &model.properties;
    let result = &run.result;
    let mut text = String::new();
    let _ = writeln!(text, "GTN tensile twin: {name}");
    let _ = writeln!(
        text,
        "  material from the test: E {:.0} MPa, nu {}, flow curve {} points from Rp0.2 {:.1} MPa to UTS, then m = {} MPa",
        p.youngs_modulus_mpa,
        crate::tensile_model::POISSON_RATIO,
        p.flow_curve.points.len(),
        p.yield_point.stress_mpa,
        inputs.m_mpa
    );
    let _ = writeln!(
        text,
        "  GTN: q1 {} q2 {} q3 {} epsN {} sN {} fN {} f0 {}{}",
        inputs.q1,
        inputs.q2,
        inputs.q3,
        inputs.eps_n,
        inputs.s_n,
        inputs.f_n,
        inputs.f0,
        inputs
            .coalescence
            .map(|(c, f)| format!(", coalescence fc {c} fF {f}"))
            .unwrap_or_default()
    );
    let _ = writeln!(
        text,
        "  model: {}, imperfection {} of the radius",
        model.settings.mesh_sentence(),
        model.settings.geometry.imperfection
    );
    // The curve always holds the origin, so there is a largest point.
    let peak = result
        .curve
        .iter()
        .copied()
        .max_by(|a, b| a.force_kn.total_cmp(&b.force_kn))
        .unwrap_or(result.curve[0]);
    let _ = writeln!(text);
    let _ = writeln!(text, "                 test        twin");
    let _ = writeln!(
        text,
        "  max force kN   {:>8.4}    {:>8.4}",
        p.uts.force_kn, peak.force_kn
    );
    let _ = writeln!(
        text,
        "  at u mm        {:>8.4}    {:>8.4}",
        p.uts.displacement_mm, peak.displacement_mm
    );
    let last = result.curve.last().copied().unwrap_or(peak);
    let test_last = model.test.last().copied();
    if let Some(t) = test_last {
        let _ = writeln!(
            text,
            "  last point     {:>8.4} kN at {:.4} mm    {:>8.4} kN at {:.4} mm (neck diameter {:.3} mm, {} failed points)",
            t.force_kn, t.displacement_mm, last.force_kn, last.displacement_mm, last.neck_diameter_mm, last.failed_points
        );
    }
    let _ = writeln!(text);
    let outcome = match &result.outcome {
        Outcome::ReachedEnd => "reached the test's last displacement".to_string(),
        Outcome::Fractured { displacement_mm } => {
            format!("the bar broke at u = {displacement_mm:.4} mm")
        }
        Outcome::NotConverged {
            displacement_mm,
            reason,
        } => {
            format!("did not converge beyond u = {displacement_mm:.4} mm: {reason}")
        }
    };
    let _ = writeln!(text, "  run: {outcome}");
    let _ = writeln!(
        text,
        "       {} steps, {} Newton iterations, {} step cuts, {:.3} s",
        result.steps, result.newton_iterations, result.step_cuts, run.wall_s
    );
    let _ = writeln!(
        text,
        "  MAPE {:.3} % over {} grid points (step {:.6} mm{})",
        run.mape.mape_percent,
        run.mape.grid_points,
        run.mape.step_mm,
        if run.mape.padded_points > 0 {
            format!(
                ", {} past the simulation's end at zero force",
                run.mape.padded_points
            )
        } else {
            String::new()
        }
    );
    if let Some(split) = &run.mape.split {
        let _ = writeln!(
            text,
            "       {:.3} % up to the test's maximum force at {} mm ({} points), {:.3} % after it ({} points)",
            split.before_percent,
            split.split_at_mm,
            split.before_points,
            split.after_percent,
            split.after_points
        );
    }
    text
}

/// The test's points against the twin's curve.
pub fn comparison_svg(
    title: &str,
    test: &[acq_analysis::extract::tensile_props::TestPoint],
    curve: &[acq_twins::tensile::solver::CurvePoint],
) -> String {
    labelled_comparison_svg(title, "test", test, curve)
}

/// A reference curve's points (a test, another FE code), named
/// `reference`, against the twin's curve.
pub fn labelled_comparison_svg(
    title: &str,
    reference: &str,
    test: &[acq_analysis::extract::tensile_props::TestPoint],
    curve: &[acq_twins::tensile::solver::CurvePoint],
) -> String {
    let mut chart = Chart::new(title, "displacement (half gauge), mm", "force, kN");
    chart.series.push(Series {
        name: reference.into(),
        points: test
            .iter()
            .map(|p| (p.displacement_mm, p.force_kn))
            .collect(),
        style: SeriesStyle::Markers,
    });
    chart.series.push(Series {
        name: "acq GTN twin".into(),
        points: curve
            .iter()
            .map(|p| (p.displacement_mm, p.force_kn))
            .collect(),
        style: SeriesStyle::Line,
    });
    chart_svg(&chart, 760.0, 480.0)
}
