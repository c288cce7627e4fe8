//! The excavator twin's identification and both case calibrations, end to
//! end, as a user runs them (target: together under 10 s on two cores):
//!
//! - `acq calibrate external --spec data/excavator/identify.toml` (least
//!   squares over 29 geometry numbers and the Case-2 load);
//! - `acq calibrate excavator --case data/excavator/case1.toml` and
//!   `case2.toml` on the identified twin (surrogate + NSGA-II + TOPSIS).
//!
//! Three rounds; the median of each step and of the total.
//!
//! `cargo bench --bench identify`

use std::path::Path;
use std::time::Instant;

use acq_workflows::calibrate::excavator::{run as calibrate_case, CalibrateExcavatorOptions};
use acq_workflows::calibrate::external::{run as run_study, CalibrateExternalOptions};

fn median(mut values: Vec<f64>) -> f64 {
    values.sort_by(f64::total_cmp);
    values[values.len() / 2]
}

fn main() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut steps: [Vec<f64>; 4] = Default::default();
    for _ in 0..3 {
        let dir = tempfile::tempdir().expect("temp dir");
        let start = Instant::now();
        run_study(CalibrateExternalOptions {
            spec: root.join("data/excavator/identify.toml"),
            out: dir.path().join("identify"),
            resume: false,
            seed: 1,
        })
        .expect("identification");
        steps[0].push(start.elapsed().as_secs_f64());
        for (k, case) in ["case1", "case2"].into_iter().enumerate() {
            let start = Instant::now();
            let case_path = root.join(format!("data/excavator/{case}.toml"));
            let geometry = dir.path().join("identify/geometry.toml");
            let out = dir.path().join(case);
            // The published workflow's settings, the command line's defaults.
            calibrate_case(CalibrateExcavatorOptions {
                geometry: Some(geometry),
                ..CalibrateExcavatorOptions::published(&case_path, &out)
            })
            .expect("calibration");
            steps[k + 1].push(start.elapsed().as_secs_f64());
        }
        steps[3]
            .push(steps[0].last().unwrap() + steps[1].last().unwrap() + steps[2].last().unwrap());
    }
    for (name, times) in [
        "identification",
        "case 1 calibration",
        "case 2 calibration",
        "total",
    ]
    .iter()
    .zip(&steps)
    {
        println!(
            "{name}: median {:.2} s ({:?})",
            median(times.clone()),
            times
                .iter()
                .map(|t| (t * 100.0).round() / 100.0)
                .collect::<Vec<_>>()
        );
    }
}
