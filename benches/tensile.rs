//! One GTN tensile simulation of the Dataset-1 test (P91, 20 C) to its last
//! displacement with the published parameters, and one to fracture (the
//! same with coalescence, fc = 0.02, fF = 0.15, which breaks at 1.75 mm):
//! wall time and peak memory. Target: under 1 s and under 100 MB.
//! Then meshes by element size in the neck: 0.33, 0.18 and
//! 0.09 mm; target for 0.09 mm under 5 s.
//!
//! Then what the curve's sensitivities in the eight parameters cost: runs
//! with and without them alternated on the same model, the ratio of their
//! medians.
//!
//! `cargo bench --bench tensile`

use std::path::Path;

use acq_analysis::extract::tensile_props::{read_test_csv, tensile_properties, SpecimenGeometry};
use acq_twins::tensile::mesh::MeshDensity;
use acq_workflows::tensile_model::{GtnInputs, ModelSettings, TensileModel};

fn peak_rss_mb() -> f64 {
    let status = std::fs::read_to_string("/proc/self/status").unwrap_or_default();
    status
        .lines()
        .find_map(|l| l.strip_prefix("VmHWM:"))
        .and_then(|v| v.trim().trim_end_matches("kB").trim().parse::<f64>().ok())
        .map_or(f64::NAN, |kb| kb / 1024.0)
}

fn main() {
    let test_path = Path::new(env!("CARGO_MANIFEST_DIR")).join("data/tensile/P91_20_2_DF_SS.csv");
    let points = read_test_csv(&test_path).expect("test file");
    let properties = tensile_properties(&points, SpecimenGeometry::default()).expect("properties");
    let inputs = GtnInputs::parse(
        "q1=1.332,q2=0.9952,q3=2.295,epsN=0.29,sN=0.1671,fN=0.03869,f0=0.00137,m=534.1",
    )
    .expect("parameters");
    let fracture = GtnInputs::parse(
        "q1=1.332,q2=0.9952,q3=2.295,epsN=0.29,sN=0.1671,fN=0.03869,f0=0.00137,m=534.1,fc=0.02,fF=0.15",
    )
    .expect("parameters");
    println!("run        mesh         neck mm  threads  runs  median s  min s   steps  iterations  MAPE %");
    let geometry = ModelSettings::default().geometry;
    let by_size = |mm: f64| MeshDensity::by_element_size(&geometry, mm, None).expect("mesh");
    let by_counts = |radial: usize, axial: usize| MeshDensity {
        radial_elements: radial,
        axial_elements: axial,
        ..Default::default()
    };
    let model_on = |mesh: MeshDensity| {
        TensileModel::new(
            points.clone(),
            properties.clone(),
            ModelSettings {
                mesh,
                ..Default::default()
            },
        )
    };
    for (label, inputs, mesh, runs) in [
        ("published", &inputs, by_counts(6, 30), 5),
        ("published", &inputs, by_counts(8, 40), 5),
        ("fracture", &fracture, by_counts(6, 30), 5),
        ("published", &inputs, by_size(0.33), 5),
        ("published", &inputs, by_size(0.18), 3),
        ("published", &inputs, by_size(0.09), 3),
    ] {
        let model = model_on(mesh);
        let mut times = Vec::new();
        let mut last = None;
        for _ in 0..runs {
            let run = model.run(inputs).expect("run");
            times.push(run.wall_s);
            last = Some(run);
        }
        times.sort_by(f64::total_cmp);
        let run = last.expect("at least one run");
        let (neck_radial_mm, _) = mesh.neck_element_mm(&geometry);
        println!(
            "{label:<10} {:<12} {:>7.3}  {:>7}  {:>4}  {:>8.3}  {:>5.3}  {:>6}  {:>10}  {:>6.3}",
            format!("{}x{}", mesh.radial_elements, mesh.axial_elements),
            neck_radial_mm,
            std::thread::available_parallelism().map_or(1, |n| n.get()),
            times.len(),
            times[times.len() / 2],
            times[0],
            run.result.steps,
            run.result.newton_iterations,
            run.mape.mape_percent
        );
    }
    println!();
    println!("sensitivities  mesh         runs  plain s  with s  ratio");
    for mesh in [by_counts(6, 30), by_size(0.33)] {
        let model = model_on(mesh);
        let (mut plain, mut with) = (Vec::new(), Vec::new());
        for _ in 0..5 {
            let start = std::time::Instant::now();
            model.pull(&inputs).expect("run");
            plain.push(start.elapsed().as_secs_f64());
            let start = std::time::Instant::now();
            let (_, sensitivities) = model.pull_with_sensitivities(&inputs).expect("run");
            sensitivities.expect("sensitivities");
            with.push(start.elapsed().as_secs_f64());
        }
        plain.sort_by(f64::total_cmp);
        with.sort_by(f64::total_cmp);
        let (plain, with) = (plain[plain.len() / 2], with[with.len() / 2]);
        println!(
            "published      {:<12} {:>4}  {plain:>7.3}  {with:>6.3}  {:>5.2}",
            format!("{}x{}", mesh.radial_elements, mesh.axial_elements),
            5,
            with / plain
        );
    }
    println!(
        "peak resident memory of the whole benchmark: {:.1} MB",
        peak_rss_mb()
    );
}
