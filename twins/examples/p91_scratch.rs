use acq_twins::tensile::flow_curve::FlowCurve;
use acq_twins::tensile::gtn::{Elasticity, GtnMaterial, GtnParameters};
use acq_twins::tensile::mesh::{BarGeometry, MeshDensity};
use acq_twins::tensile::solver::LoadingSettings;
use acq_twins::tensile::TensileTwin;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let nr: usize = args.get(1).map(|s| s.parse().unwrap()).unwrap_or(8);
    let nz: usize = args.get(2).map(|s| s.parse().unwrap()).unwrap_or(40);
    let damage = args.get(3).map(|s| s != "j2").unwrap_or(true);
    let text = std::fs::read_to_string("data/tensile/P91_20_2_DF_SS.csv").unwrap();
    let mut rows: Vec<(f64, f64)> = Vec::new();
    for line in text.lines().skip(1) {
        let f: Vec<&str> = line.split(',').collect();
        rows.push((f[0].parse().unwrap(), f[1].parse().unwrap()));
    }
    let e = 207011.0;
    let imax = rows
        .iter()
        .enumerate()
        .max_by(|a, b| a.1 .1.partial_cmp(&b.1 .1).unwrap())
        .unwrap()
        .0;
    let mut eps = vec![];
    let mut sig = vec![];
    for &(u, f) in &rows[..=imax] {
        let es = u / 12.5;
        let s = f * 1000.0 / (std::f64::consts::PI * 4.0);
        let ts = s * (1.0 + es);
        let te = (1.0 + es).ln();
        let ep = te - ts / e;
        if ts < 403.7 {
            continue;
        }
        if let Some(&last) = eps.last() {
            if ep <= last {
                continue;
            }
        }
        eps.push(ep);
        sig.push(ts);
    }
    let first = eps[0];
    for x in &mut eps {
        *x -= first;
    }
    let flow = if std::env::var("LINEAR").is_ok() {
        FlowCurve::linear(440.0, 300.0).unwrap()
    } else {
        FlowCurve::new(eps, sig, 534.1).unwrap()
    };
    let mut parameters = GtnParameters {
        q1: 1.332,
        q2: 0.9952,
        q3: 2.295,
        nucleation_mean_strain: 0.29,
        nucleation_std_strain: 0.1671,
        nucleated_void_fraction: 0.03869,
        initial_porosity: 0.00137,
        coalescence: None,
    };
    if !damage {
        parameters = GtnParameters::von_mises();
    }
    let material = GtnMaterial::new(
        Elasticity {
            youngs_modulus_mpa: e,
            poisson_ratio: 0.3,
        },
        parameters,
        flow,
    )
    .unwrap();
    let twin = TensileTwin {
        geometry: BarGeometry::default(),
        mesh: MeshDensity {
            radial_elements: nr,
            axial_elements: nz,
            axial_grading: 8.0,
        },
        material,
    };
    let start = std::time::Instant::now();
    let result = twin.pull(&LoadingSettings::to(2.607)).unwrap();
    let wall = start.elapsed().as_secs_f64();
    for p in result.curve.iter().step_by(10) {
        println!(
            "{:.4} {:.4} {:.4} {}",
            p.displacement_mm, p.force_kn, p.neck_diameter_mm, p.failed_points
        );
    }
    let last = result.curve.last().unwrap();
    println!(
        "last {:.4} {:.4} {:.4} {}",
        last.displacement_mm, last.force_kn, last.neck_diameter_mm, last.failed_points
    );
    println!(
        "{:?} steps {} its {} cuts {} max {:.4} wall {:.3}s",
        result.outcome,
        result.steps,
        result.newton_iterations,
        result.step_cuts,
        result.max_force_kn(),
        wall
    );
}
