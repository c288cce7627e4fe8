//! Time of one excavator evaluation (issue target: under 20 us for pose +
//! statics + both frame models, so a 40,000-run genetic algorithm on the
//! twin itself takes under a second).
//!
//! `cargo bench -p acq-twins --bench excavator` evaluates 200,000 input sets
//! spread over the Case-1 box (strokes and angle varied so nothing is
//! cached) and reports the median of 9 batches, with the pose alone and
//! the pose + statics (no frame models) as peers in the same run.

use std::hint::black_box;
use std::time::Instant;

use acq_twins::excavator::case::CaseFile;
use acq_twins::excavator::geometry::Geometry;
use acq_twins::excavator::{statics, Excavator, Inputs};

const BATCH: usize = 200_000;

fn inputs(case: &CaseFile) -> Vec<Inputs> {
    let mut state = 0x9E37_79B9_7F4A_7C15u64;
    let mut unit = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    let b = case.bounds;
    let within = |range: [f64; 2], u: f64| range[0] + (range[1] - range[0]) * u;
    (0..BATCH)
        .map(|_| {
            let mut i = case.nominal();
            i.strokes.bucket_mm = within(b.bucket_stroke_mm, unit());
            i.strokes.arm_mm = within(b.arm_stroke_mm, unit());
            i.strokes.boom_mm = within(b.boom_stroke_mm, unit());
            i.tip_force_angle_deg = within(b.force_angle_deg, unit());
            i
        })
        .collect()
}

fn median_ns_per_call(mut run: impl FnMut() -> f64) -> f64 {
    let mut times: Vec<f64> = (0..9)
        .map(|_| {
            let start = Instant::now();
            black_box(run());
            start.elapsed().as_nanos() as f64 / BATCH as f64
        })
        .collect();
    times.sort_by(f64::total_cmp);
    times[4]
}

fn main() {
    let case = CaseFile::parse(include_str!("../../data/excavator/case1.toml")).unwrap();
    let twin = Excavator::new(Geometry::dx55()).unwrap();
    let sets = inputs(&case);

    let pose_ns = median_ns_per_call(|| {
        sets.iter()
            .map(|i| twin.pose(&i.strokes).unwrap().j.x)
            .sum()
    });
    let statics_ns = median_ns_per_call(|| {
        sets.iter()
            .map(|i| {
                let pose = twin.pose(&i.strokes).unwrap();
                let loads = twin.loads(&pose, i);
                statics::solve(&pose, &loads).unwrap().cylinders[0].axial_force_n
            })
            .sum()
    });
    let full_ns = median_ns_per_call(|| {
        sets.iter()
            .map(|i| twin.evaluate(i).unwrap().arm.max_von_mises_mpa)
            .sum()
    });
    println!("excavator twin, median of 9 batches of {BATCH} evaluations over the Case-1 box:");
    println!("  pose only                    {:>8.2} us", pose_ns * 1e-3);
    println!(
        "  pose + statics               {:>8.2} us",
        statics_ns * 1e-3
    );
    println!(
        "  full (+ boom and arm frames) {:>8.2} us   (target < 20 us)",
        full_ns * 1e-3
    );
    println!(
        "  => 40,000 full evaluations in {:.2} s on one core",
        full_ns * 40_000.0 * 1e-9
    );
}
