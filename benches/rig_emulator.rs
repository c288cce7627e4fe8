//! A user's solver at the rig through its saved emulator (BENCHMARKS.md,
//! "The rig that knows when it has enough"): how long an update of the
//! study takes with eight unknowns.
//!
//! The earlier study of fixtures/rig-emulator (its stand-in solver, twelve
//! cases on a grid of the boom's inclination and the tooth force) saves
//! its emulator; the study at the rig loads it, and at each of three
//! hidden truths (within the priors, none used to make the files) an
//! operator holds the eight points it names, each hold's levels from the
//! solver itself with a typical transducer's noise.
//!
//! `cargo bench --bench rig_emulator` (about two minutes on 2 cores);
//! `ACQ_BENCH_VERBOSE=1` prints how each update was sampled.

use std::collections::BTreeMap;
use std::path::Path;
use std::sync::Arc;
use std::time::Instant;

use acq_analysis::extract::quantities::RigQuantities;
use acq_workflows::calibrate::external::{run, CalibrateExternalOptions};
use acq_workflows::rig_study::tracker::Tracker;
use acq_workflows::rig_study::RigStudy;
use acq_workflows::virtual_rig::synthetic_hold;
use rand::SeedableRng;

const HOLDS: usize = 8;

#[path = "../tests/common/rig_emulator.rs"]
mod rig_emulator;

fn main() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let temp = tempfile::tempdir().unwrap();
    let dir = temp.path();
    for file in ["boom.sh", "study.toml", "rig_study.toml"] {
        std::fs::copy(
            root.join("fixtures/rig-emulator").join(file),
            dir.join(file),
        )
        .unwrap();
    }
    // One run at a time: the search then proposes the same points in the
    // same order every time (with two, its runs finish in either order),
    // so the emulator, and every update after it, is the same from build
    // to build and two builds' times compare.
    let spec = std::fs::read_to_string(dir.join("study.toml")).unwrap();
    assert!(
        spec.contains("parallel = 2"),
        "the fixture's study runs two at a time"
    );
    std::fs::write(
        dir.join("study.toml"),
        spec.replace("parallel = 2", "parallel = 1"),
    )
    .unwrap();
    let start = Instant::now();
    run(CalibrateExternalOptions {
        spec: dir.join("study.toml"),
        out: dir.join("run"),
        resume: false,
        seed: 1,
    })
    .unwrap();
    println!(
        "the earlier study and its emulator: {:.1} s",
        start.elapsed().as_secs_f64()
    );
    let rig = acq_io::input::load_rig(&root.join("fixtures/rigs/excavator.toml")).unwrap();
    let quantities = RigQuantities::of(&rig);
    let study = Arc::new(RigStudy::load(&dir.join("rig_study.toml"), &quantities).unwrap());
    let truths: [[f64; 8]; 3] = [
        [235.0, 225.0, 455.0, 2.62, 4.42, 0.95, 1.07, 0.38],
        [120.0, 280.0, 380.0, 2.35, 4.2, 1.06, 0.93, 0.42],
        [190.0, 240.0, 500.0, 2.7, 4.5, 1.0, 1.02, 0.4],
    ];
    let mut updates = Vec::new();
    for (t, truth) in truths.iter().enumerate() {
        let mut noise = rand_chacha::ChaCha8Rng::seed_from_u64(100 + t as u64);
        let mut tracker = Tracker::new(study.clone());
        let mut holds = Vec::new();
        for k in 0..HOLDS {
            let next = tracker.next().unwrap().expect("candidates").clone();
            let at = |name: &str| next.inputs.iter().find(|(n, _)| n == name).unwrap().1;
            let (incl, force) = (at("boom_inclination_deg"), at("force_kN"));
            let stresses = rig_emulator::user_solver(dir, truth, incl, force);
            let mut levels = BTreeMap::new();
            levels.insert("boom_inclination".to_string(), incl);
            levels.insert("tip_force".to_string(), force);
            for gauge in ["sg01", "sg05", "sg10", "sg14"] {
                levels.insert(gauge.to_string(), stresses[gauge].as_f64().unwrap());
            }
            holds.push((
                format!("hold{}", k + 1),
                synthetic_hold(&quantities, &levels, 600, &mut noise),
            ));
            let update = Instant::now();
            tracker.update(&holds, &mut |_| {});
            updates.push(update.elapsed().as_secs_f64());
            if std::env::var_os("ACQ_BENCH_VERBOSE").is_some() {
                if let Ok(posterior) = tracker.posterior() {
                    println!(
                        "  truth {} hold {}: {:.2} s, {}",
                        t + 1,
                        k + 1,
                        updates[updates.len() - 1],
                        posterior.how
                    );
                }
            }
        }
        let posterior = tracker.posterior().unwrap();
        let covered = posterior
            .parameters
            .iter()
            .zip(truth)
            .filter(|(p, x)| p.q05 <= **x && **x <= p.q95)
            .count();
        println!(
            "truth {}: updates {:.2?} s; the truth in {covered}/8 90 % intervals; shrinkage {:.3}",
            t + 1,
            &updates[updates.len() - HOLDS..],
            posterior.shrinkage()
        );
    }
    updates.sort_by(f64::total_cmp);
    let quantile = |q: f64| updates[((updates.len() - 1) as f64 * q).round() as usize];
    println!(
        "update after a hold, 8 unknowns on the emulator, {} updates of 1 to {HOLDS} holds: median {:.2} s, p90 {:.2} s, max {:.2} s",
        updates.len(),
        quantile(0.5),
        quantile(0.9),
        quantile(1.0)
    );
}
