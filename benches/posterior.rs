//! The posterior stage on the built-in excavator twin, sampled directly:
//! 4 chains of 1,000 kept draws (issue 35's target: every R-hat below
//! 1.01 in under 5 s on this machine). Each case is calibrated with and
//! without `--posterior` in the same run; the difference is the stage's
//! time (sampling, the scales, 50 predictive runs, the files).
//!
//! `cargo bench --bench posterior`

use std::path::Path;
use std::time::Instant;

use acq_calib::gp::Kernel;
use acq_workflows::calibrate::excavator::{run, CalibrateExcavatorArgs, PosteriorDiscrepancy};

fn median(mut values: Vec<f64>) -> f64 {
    values.sort_by(f64::total_cmp);
    values[values.len() / 2]
}

fn main() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let arguments = |case: &str, out: &Path, posterior: bool, discrepancy| CalibrateExcavatorArgs {
        case: root.join(format!("data/excavator/{case}.toml")),
        measured: None,
        window: None,
        load_quantity: "tip_force".into(),
        geometry: None,
        out: out.to_path_buf(),
        training: 40,
        test_runs: 40,
        population: 400,
        generations: 100,
        pareto_fraction: 0.5,
        weights: vec![1.0, 1.0, 1.0],
        pick: "minimax".parse().expect("a pick"),
        kernel: Kernel::SquaredExponential,
        seed: 1,
        resume: false,
        parallel: None,
        posterior,
        discrepancy,
    };
    println!("posterior of the excavator twin, sampled directly (4 chains x 1,000 draws)");
    for (case, discrepancy, label) in [
        ("case1", PosteriorDiscrepancy::None, "noise scale estimated"),
        (
            "case1",
            PosteriorDiscrepancy::Constant,
            "constant discrepancy",
        ),
        ("case2", PosteriorDiscrepancy::None, "noise scale estimated"),
    ] {
        let mut stage_s = Vec::new();
        let mut worst_rhat = 0.0f64;
        let mut least_ess = f64::INFINITY;
        for _ in 0..3 {
            let dir = tempfile::tempdir().expect("temp dir");
            let start = Instant::now();
            run(arguments(
                case,
                &dir.path().join("search"),
                false,
                discrepancy,
            ))
            .expect("search");
            let search_s = start.elapsed().as_secs_f64();
            let start = Instant::now();
            run(arguments(
                case,
                &dir.path().join("posterior"),
                true,
                discrepancy,
            ))
            .expect("posterior");
            stage_s.push(start.elapsed().as_secs_f64() - search_s);
            let summary: serde_json::Value = serde_json::from_str(
                &std::fs::read_to_string(dir.path().join("posterior/summary.json"))
                    .expect("summary"),
            )
            .expect("json");
            for entry in summary["posterior"]
                .as_object()
                .expect("posterior")
                .values()
            {
                worst_rhat = worst_rhat.max(entry["rhat"].as_f64().unwrap_or(f64::INFINITY));
                least_ess = least_ess.min(entry["ess_bulk"].as_f64().unwrap_or(0.0));
            }
        }
        println!(
            "  {case}, {label}: posterior stage median {:.2} s (min {:.2} s) over {} runs; largest R-hat {worst_rhat:.4}, least bulk ESS {least_ess:.0}",
            median(stage_s.clone()),
            stage_s.iter().copied().fold(f64::INFINITY, f64::min),
            stage_s.len()
        );
    }
}
