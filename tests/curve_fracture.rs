//! A GTN simulation that breaks before the test does: as the initial void
//! fraction f0 rises, the simulated P91 bar fractures earlier and, past
//! f0 of about 0.12, its curve ends before the test's. Every metric's loss
//! must move continuously through that change (no jump where the curve
//! starts ending early), which a search needs to step across it. The
//! sweep is plotted (`fracture.svg`; kept where `ACQ_KEEP_PLOTS` points).

mod common;

use acq_analysis::extract::tensile_props::{read_test_csv, tensile_properties, SpecimenGeometry};
use acq_analysis::loss::metrics::{every_metric, CurveMetric};
use acq_report::plot::{chart_svg, Chart, Series};
use acq_twins::tensile::mesh::MeshDensity;
use acq_workflows::tensile_model::{GtnInputs, ModelSettings, TensileModel};

#[test]
fn each_metric_is_continuous_where_the_simulation_starts_breaking_before_the_test() {
    let test = read_test_csv(&common::root().join("data/tensile/P91_20_2_DF_SS.csv")).unwrap();
    let properties = tensile_properties(&test, SpecimenGeometry::default()).unwrap();
    let settings = ModelSettings {
        mesh: MeshDensity {
            radial_elements: 3,
            axial_elements: 12,
            ..MeshDensity::default()
        },
        ..ModelSettings::default()
    };
    let measured: Vec<(f64, f64)> = test
        .iter()
        .map(|p| (p.displacement_mm, p.force_kn))
        .collect();
    let test_end_mm = measured.last().unwrap().0;
    let model = TensileModel::new(test, properties, settings);
    let sweep: Vec<f64> = (0..=24).map(|k| 0.08 + 0.005 * k as f64).collect();
    let mut values: Vec<Vec<f64>> = vec![Vec::new(); CurveMetric::ALL.len()];
    let mut ended_early = Vec::new();
    for &f0 in &sweep {
        let inputs = GtnInputs::parse(&format!(
            "q1=1.5,q2=1,q3=2.25,epsN=0.3,sN=0.1,fN=0.04,f0={f0},m=400"
        ))
        .unwrap();
        let result = model.pull(&inputs).unwrap();
        let simulated: Vec<(f64, f64)> = result
            .curve
            .iter()
            .map(|p| (p.displacement_mm, p.force_kn))
            .collect();
        ended_early.push(simulated.last().unwrap().0 < test_end_mm - 1e-6);
        for (k, (metric, value)) in every_metric(&measured, &simulated).into_iter().enumerate() {
            values[k].push(value.unwrap_or_else(|e| panic!("{metric} at f0 = {f0}: {e}")));
        }
    }
    // The sweep crosses the change: the first runs reach the test's end,
    // the last ones break before it.
    assert!(
        !ended_early[0] && *ended_early.last().unwrap(),
        "{ended_early:?}"
    );
    let mut chart = Chart::new(
        "Each metric over f0, scaled to its own range (the simulation ends before the test right of the mark)",
        "initial void fraction f0",
        "metric, 0 to 1 over the sweep",
    );
    for (metric, series) in CurveMetric::ALL.iter().zip(&values) {
        let (low, high) = series
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), v| {
                (l.min(*v), h.max(*v))
            });
        assert!(high > low, "{metric} does not move with f0");
        // Continuous: no step between neighbours is more than three times
        // the largest of the steps around it (a jump where the curve starts
        // ending early would be), nor a fifth of the whole rise.
        let steps: Vec<f64> = series.windows(2).map(|w| (w[1] - w[0]).abs()).collect();
        for (i, step) in steps.iter().enumerate() {
            let around = [i.checked_sub(1), i.checked_sub(2), Some(i + 1), Some(i + 2)]
                .into_iter()
                .flatten()
                .filter_map(|j| steps.get(j))
                .fold(0.0f64, |m, s| m.max(*s));
            assert!(
                *step <= 3.0 * around.max(1e-3 * (high - low)) && *step <= 0.2 * (high - low),
                "{metric} jumps by {step} between f0 = {} and {} (steps around: {around}, range {})",
                sweep[i],
                sweep[i + 1],
                high - low
            );
        }
        chart = chart.with_series(Series::new(
            metric.to_string(),
            sweep
                .iter()
                .zip(series)
                .map(|(&f, v)| (f, (v - low) / (high - low)))
                .collect(),
        ));
    }
    let first_early = sweep[ended_early.iter().position(|e| *e).unwrap()];
    chart = chart.with_series(Series::new(
        "first run ending early",
        vec![(first_early, 0.0), (first_early, 1.0)],
    ));
    let dir = tempfile::tempdir().unwrap();
    let svg = chart_svg(&chart, 800.0, 480.0);
    assert!(svg.contains("<svg") && svg.contains("frechet"));
    std::fs::write(dir.path().join("fracture.svg"), &svg).unwrap();
    if let Some(keep) = std::env::var_os("ACQ_KEEP_PLOTS") {
        std::fs::write(std::path::Path::new(&keep).join("fracture.svg"), &svg).unwrap();
    }
}
