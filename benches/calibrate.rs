//! The excavator calibration workflow end to end (82 twin runs, 15 surrogate
//! fits, NSGA-II 400 x 100 on the GPs, TOPSIS, reports), NSGA-II alone on
//! the three GPs of case 1, and the GTN calibration of Dataset 1 (up to 60
//! simulations, target 2 %). Targets: the workflow under 2 s per
//! case, NSGA-II on the GP under 1 s, the GTN calibration under 2 % within
//! 60 simulations in a few minutes.
//!
//! `cargo bench --bench calibrate`

use std::path::Path;
use std::time::Instant;

use acq_algorithms::doe::latin_hypercube;
use acq_algorithms::evaluation::Simulator;
use acq_algorithms::gp::{Gp, GpSettings, Kernel};
use acq_algorithms::moo::{nsga2, Nsga2Settings};
use acq_study::simulator::StudySimulator;
use acq_study::study::Role;
use acq_twins::excavator::case::CaseFile;
use acq_twins::excavator::geometry::GeometryTemplate;
use acq_workflows::calibrate::builtin::ExcavatorModel;
use acq_workflows::calibrate::excavator::{case_study, run, CalibrateExcavatorOptions};
use acq_workflows::calibrate::gtn::CalibrateGtnOptions;

fn median(mut values: Vec<f64>) -> f64 {
    values.sort_by(f64::total_cmp);
    values[values.len() / 2]
}

fn main() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    println!("excavator workflow (defaults: 40 LHS + 40 test runs, GP SE-ARD, NSGA-II 400 x 100)");
    for case in ["case1", "case2"] {
        let mut times = Vec::new();
        for _ in 0..5 {
            let dir = tempfile::tempdir().expect("temp dir");
            let args = CalibrateExcavatorOptions::published(
                &root.join(format!("data/excavator/{case}.toml")),
                &dir.path().join("run"),
            );
            let start = Instant::now();
            run(args).expect("workflow");
            times.push(start.elapsed().as_secs_f64());
        }
        println!(
            "  {case}: median {:.3} s, min {:.3} s over {} runs",
            median(times.clone()),
            times.iter().copied().fold(f64::INFINITY, f64::min),
            times.len()
        );
    }

    // NSGA-II alone on the three GPs of case 1.
    let case = CaseFile::load(&root.join("data/excavator/case1.toml")).expect("case");
    let model = ExcavatorModel::new(GeometryTemplate::dx55(), false).expect("twin");
    let study = case_study(
        &case,
        &case.measured.expect("case 1 has measured pressures"),
        [None, None, None],
    );
    let simulator = StudySimulator::new(&study, &model, Role::Fit);
    let bounds: Vec<(f64, f64)> = simulator
        .parameters()
        .iter()
        .map(|p| (p.lower, p.upper))
        .collect();
    let inputs: Vec<Vec<f64>> = latin_hypercube(40, 4, 1)
        .iter()
        .map(|u| {
            u.iter()
                .zip(&bounds)
                .map(|(v, (l, h))| l + v * (h - l))
                .collect()
        })
        .collect();
    let outputs: Vec<Vec<f64>> = inputs
        .iter()
        .map(|x| simulator.evaluate(x).expect("twin run"))
        .collect();
    let settings = GpSettings {
        kernel: Kernel::SquaredExponential,
        input_bounds: Some(bounds.clone()),
        ..GpSettings::default()
    };
    let mut fit_times = Vec::new();
    let mut gps = Vec::new();
    for k in 0..3 {
        let y: Vec<f64> = outputs.iter().map(|o| o[k]).collect();
        let start = Instant::now();
        gps.push(Gp::fit(&inputs, &y, &settings).expect("gp"));
        fit_times.push(start.elapsed().as_secs_f64());
    }
    let measured = [116.89, 193.46, 73.35];
    let mut times = Vec::new();
    for _ in 0..5 {
        let start = Instant::now();
        let result = nsga2(
            |x| {
                gps.iter()
                    .zip(measured)
                    .map(|(gp, m)| 100.0 * (m - gp.predict(x).mean).abs() / m)
                    .collect()
            },
            &bounds,
            &Nsga2Settings::default(),
        )
        .expect("nsga2");
        times.push(start.elapsed().as_secs_f64());
        assert!(!result.front.is_empty());
    }
    println!(
        "GP fit n = 40, d = 4 (twin data, SE-ARD, 5 restarts): {:.2} / {:.2} / {:.2} ms",
        1e3 * fit_times[0],
        1e3 * fit_times[1],
        1e3 * fit_times[2]
    );
    println!(
        "NSGA-II 400 x 100 on the three GP means: median {:.3} s over {} runs",
        median(times.clone()),
        times.len()
    );

    // The GTN search's target: every shipped P91 test under 1 % within 30
    // simulations at the default mesh; with and without the local steps.
    let dir = tempfile::tempdir().expect("temp dir");
    for test in ["P91_20_2_DF_SS.csv", "P91_500_DF_SS.csv"] {
        for global_only in [false, true] {
            let out = dir.path().join(format!("{test}-{global_only}"));
            let start = Instant::now();
            acq_workflows::calibrate::gtn::run(CalibrateGtnOptions {
                max_evals: 60,
                target_mape_pct: 1.0,
                global_only,
                ..CalibrateGtnOptions::new(&root.join("data/tensile").join(test), &out)
            })
            .expect("gtn calibration");
            let summary: serde_json::Value = serde_json::from_str(
                &std::fs::read_to_string(out.join("summary.json")).expect("summary"),
            )
            .expect("json");
            println!(
                "GTN calibration, {test}, {}: best MAPE {:.3} % after {} simulations (1 % reached at {}), {:.1} s",
                if global_only { "global steps only" } else { "with local steps" },
                summary["best_mape"].as_f64().unwrap_or(f64::NAN),
                summary["evaluations"],
                summary["evaluations_to_target"],
                start.elapsed().as_secs_f64()
            );
        }
    }
}
