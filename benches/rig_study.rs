//! The rig that knows when it has enough (BENCHMARKS.md): does the next
//! test point the study names reach a narrow posterior in fewer holds than
//! a fixed design, and how long does an update take?
//!
//! For each of ten hidden truths (drawn with a fixed seed uniformly within
//! each parameter's prior 90 % interval: plausible machines, none of them
//! used to design the study), the example study at the rig
//! (examples/excavator-rig/study.toml) is fed holds by three operators:
//! - **adaptive**: each hold at the point the study names next;
//! - **random**: points drawn from the same candidates;
//! - **published**: the published study's three poses (Cases 1 and 2 by
//!   their points, Case 3 near the top of the boom's and arm's strokes),
//!   at 40 kN and the study's load direction, over and over.
//!
//! A hold's measured values are the twin-driven virtual rig's levels at the
//! truth, each mean off by its standard error of 600 readings of a typical
//! transducer (`virtual_rig::synthetic_hold`; tests/rig_study.rs plays such
//! holds on the in-process bus), each value's budget the rig's (its
//! transducers' data sheets: the errors shared by every hold, as an
//! extracted hold carries them; `ACQ_BENCH_SCATTER_ONLY=1` leaves them
//! out, as the bench did before 2026-11-29). The target: the posterior's shrinkage
//! (the geometric mean of the parameters' 90 % widths over their prior's)
//! at most `TARGET`. Each operator stops at the target or after
//! `MAX_HOLDS`; at its end, how many parameters' 90 % intervals hold the
//! truth. Then the next-point search over a grid of more than 1,000
//! candidates is timed on its own.
//!
//! `cargo bench --bench rig_study` (about ten minutes on 2 cores);
//! `ACQ_BENCH_TRUTHS=2` runs the first two truths only.

use std::collections::BTreeMap;
use std::path::Path;
use std::sync::Arc;
use std::time::Instant;

use acq_analysis::extract::quantities::RigQuantities;
use acq_twins::excavator::inclinations::Inclinations;
use acq_twins::excavator::pose_fit::published_poses;
use acq_twins::excavator::{Excavator, Inputs, Strokes};
use acq_workflows::rig_study::tracker::Tracker;
use acq_workflows::rig_study::RigStudy;
use acq_workflows::virtual_rig::{hold_levels, synthetic_hold, RigSensors, TestPoint};
use rand::{RngExt, SeedableRng};

const STUDY: &str = "examples/excavator-rig/study.toml";
const TRUTHS: usize = 10;
const MAX_HOLDS: usize = 16;
const TARGET: f64 = 0.5;

#[derive(Clone, Copy, PartialEq)]
enum Operator {
    Adaptive,
    Random,
    Published,
}

impl Operator {
    fn name(self) -> &'static str {
        match self {
            Operator::Adaptive => "adaptive",
            Operator::Random => "random",
            Operator::Published => "published",
        }
    }
}

struct Run {
    holds_to_target: Option<usize>,
    covered: usize,
    update_s: Vec<f64>,
}

fn direction(from: [f64; 2], to: [f64; 2]) -> f64 {
    (to[1] - from[1]).atan2(to[0] - from[0]).to_degrees()
}

/// The published poses as inclinations: Cases 1 and 2 from their points,
/// Case 3 (unpublished points) at boom 640 mm, arm 540 mm, bucket 250 mm.
fn published(geometry: &acq_twins::excavator::geometry::Geometry) -> Vec<Inclinations> {
    let mut poses: Vec<Inclinations> = published_poses()
        .iter()
        .map(|p| Inclinations {
            boom_deg: direction([0.0, 0.0], p.b),
            arm_deg: direction(p.b, p.g),
            bucket_deg: direction(p.g, p.j),
        })
        .collect();
    let twin = Excavator::new(geometry.clone()).unwrap();
    let case3 = twin
        .evaluate(&Inputs {
            strokes: Strokes {
                bucket_mm: 250.0,
                arm_mm: 540.0,
                boom_mm: 640.0,
            },
            tip_force_kn: 1.0,
            tip_force_angle_deg: -10.0,
        })
        .unwrap();
    poses.push(Inclinations::of(&case3.pose));
    poses
}

/// The hold's values as `acq extract` writes them from a recording on
/// `rig`: the same statistics, each value's budget from the rig's records
/// (net forces through both chambers). Unchanged with
/// `ACQ_BENCH_SCATTER_ONLY`.
fn with_rig_budgets(
    rig: &acq_rig::Rig,
    hold: Vec<acq_analysis::extract::measured::MeasuredValue>,
) -> Vec<acq_analysis::extract::measured::MeasuredValue> {
    use acq_analysis::extract::run::{hold_values, HoldWindow};
    use acq_analysis::extract::uncertainty::SessionParts;
    if std::env::var_os("ACQ_BENCH_SCATTER_ONLY").is_some() {
        return hold;
    }
    let stats: Vec<_> = rig
        .sensors
        .iter()
        .map(|s| {
            hold.iter()
                .find(|v| v.quantity == s.name)
                .map(|v| v.stats)
                .unwrap_or_default()
        })
        .collect();
    let width = rig.sensors.len();
    let window = HoldWindow {
        name: "hold",
        start_s: 0.0,
        end_s: 0.0,
    };
    hold_values(
        rig,
        &window,
        &stats,
        &vec![Vec::new(); width],
        &vec![SessionParts::default(); width],
    )
    .into_iter()
    .filter(|v| v.stats.mean.is_some())
    .collect()
}

fn main() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let rig = acq_io::input::load_rig(&root.join("fixtures/rigs/excavator.toml")).unwrap();
    let quantities = RigQuantities::of(&rig);
    let study = Arc::new(RigStudy::load(&root.join(STUDY), &quantities).unwrap());
    let sensors = RigSensors::of_rig(
        &quantities,
        "tip_force",
        ["boom_inclination", "arm_inclination", "bucket_inclination"],
    );
    let prior = study.prior();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(20_261_127);
    let truths: Vec<Vec<f64>> = (0..TRUTHS)
        .map(|_| {
            prior
                .parameters
                .iter()
                .map(|p| p.prior_q05 + (p.prior_q95 - p.prior_q05) * rng.random::<f64>())
                .collect()
        })
        .collect();
    let names: Vec<String> = study.parameters.iter().map(|p| p.input.clone()).collect();
    let index = |name: &str| {
        study
            .candidates
            .names
            .iter()
            .position(|n| n == name)
            .unwrap()
    };
    let point_of = |values: &[f64]| TestPoint {
        inclinations: Inclinations {
            boom_deg: values[index("boom_inclination_deg")],
            arm_deg: values[index("arm_inclination_deg")],
            bucket_deg: values[index("bucket_inclination_deg")],
        },
        tip_force_kn: values[index("force_kN")],
        tip_force_angle_deg: -10.0,
    };
    let template = study.geometry.as_ref().expect("the excavator twin");
    let fixed = published(&template.with(&[]).unwrap());
    let run_truths = std::env::var("ACQ_BENCH_TRUTHS")
        .ok()
        .and_then(|n| n.parse().ok())
        .unwrap_or(TRUTHS)
        .min(TRUTHS);
    println!("truths ({}):", names.join(", "));
    for truth in &truths {
        println!("  {truth:.3?}");
    }
    let mut table: BTreeMap<&str, Vec<Run>> = BTreeMap::new();
    for (t, truth) in truths.iter().enumerate().take(run_truths) {
        let values: Vec<(&str, f64)> = names
            .iter()
            .map(|n| n.as_str())
            .zip(truth.iter().copied())
            .collect();
        let geometry = template.with(&values).unwrap();
        for operator in [Operator::Adaptive, Operator::Random, Operator::Published] {
            let mut noise = rand_chacha::ChaCha8Rng::seed_from_u64(1000 * t as u64 + 7);
            let mut pick = rand_chacha::ChaCha8Rng::seed_from_u64(1000 * t as u64 + 13);
            let mut tracker = Tracker::new(study.clone());
            let mut holds = Vec::new();
            let mut run = Run {
                holds_to_target: None,
                covered: 0,
                update_s: Vec::new(),
            };
            for k in 0..MAX_HOLDS {
                let point = match operator {
                    Operator::Adaptive => {
                        let next = tracker.next().unwrap().expect("candidates").clone();
                        let values: Vec<f64> = next.inputs.iter().map(|(_, v)| *v).collect();
                        point_of(&values)
                    }
                    Operator::Random => {
                        let c = pick.random_range(0..study.candidates.points.len());
                        point_of(&study.candidates.points[c])
                    }
                    Operator::Published => TestPoint {
                        inclinations: fixed[k % fixed.len()],
                        tip_force_kn: 40.0,
                        tip_force_angle_deg: -10.0,
                    },
                };
                let levels = hold_levels(&geometry, &sensors, &BTreeMap::new(), &point).unwrap();
                holds.push((
                    format!("hold{}", k + 1),
                    with_rig_budgets(&rig, synthetic_hold(&quantities, &levels, 600, &mut noise)),
                ));
                let start = Instant::now();
                tracker.update(&holds, &mut |_| {});
                run.update_s.push(start.elapsed().as_secs_f64());
                let posterior = tracker.posterior().unwrap();
                if std::env::var_os("ACQ_BENCH_VERBOSE").is_some() {
                    println!(
                        "  {} hold {}: {:.2} s, {}",
                        operator.name(),
                        k + 1,
                        run.update_s[k],
                        posterior.how
                    );
                }
                if posterior.shrinkage() <= TARGET {
                    run.holds_to_target = Some(k + 1);
                    break;
                }
            }
            let posterior = tracker.posterior().unwrap();
            run.covered = posterior
                .parameters
                .iter()
                .zip(truth)
                .filter(|(p, x)| p.q05 <= **x && **x <= p.q95)
                .count();
            println!(
                "truth {} {:>9}: {} holds, shrinkage {:.3}, truth in {}/{} intervals, updates {:.2?} s",
                t + 1,
                operator.name(),
                run.holds_to_target.map_or(format!(">{MAX_HOLDS}"), |n| n.to_string()),
                posterior.shrinkage(),
                run.covered,
                truth.len(),
                run.update_s
            );
            table.entry(operator.name()).or_default().push(run);
        }
    }
    println!("\n| operator | holds to shrinkage <= {TARGET} (median) | per truth | truths with every 90 % interval holding the truth | parameters' intervals holding the truth |");
    println!("|---|---|---|---|---|");
    for operator in ["adaptive", "random", "published"] {
        let runs = &table[operator];
        let mut counts: Vec<usize> = runs
            .iter()
            .map(|r| r.holds_to_target.unwrap_or(MAX_HOLDS + 1))
            .collect();
        let per_truth: Vec<String> = runs
            .iter()
            .map(|r| {
                r.holds_to_target
                    .map_or(format!(">{MAX_HOLDS}"), |n| n.to_string())
            })
            .collect();
        counts.sort_unstable();
        let median = if counts.len() % 2 == 1 {
            counts[counts.len() / 2] as f64
        } else {
            counts[counts.len() / 2 - 1] as f64 * 0.5 + counts[counts.len() / 2] as f64 * 0.5
        };
        let all = runs.iter().filter(|r| r.covered == 4).count();
        let covered: usize = runs.iter().map(|r| r.covered).sum();
        let median = if median > MAX_HOLDS as f64 {
            format!("more than {MAX_HOLDS}")
        } else {
            median.to_string()
        };
        println!(
            "| {operator} | {median} | {} | {all}/{} | {covered}/{} |",
            per_truth.join(" "),
            runs.len(),
            4 * runs.len()
        );
    }
    let mut updates: Vec<f64> = table
        .values()
        .flatten()
        .flat_map(|r| r.update_s.iter().copied())
        .collect();
    updates.sort_by(f64::total_cmp);
    let quantile = |q: f64| updates[((updates.len() - 1) as f64 * q).round() as usize];
    println!(
        "\nupdate after a hold (posterior and next point), {} updates: median {:.2} s, p90 {:.2} s, max {:.2} s",
        updates.len(),
        quantile(0.5),
        quantile(0.9),
        quantile(1.0)
    );

    // The next-point search alone over a fine grid of candidates.
    let fine = std::fs::read_to_string(root.join(STUDY))
        .unwrap()
        .replace(
            "\"../../data/excavator/dx55.toml\"",
            &format!("{:?}", root.join("data/excavator/dx55.toml")),
        )
        .replace(
            "{ from = -10.0, to = 50.0, steps = 7 }",
            "{ from = -10.0, to = 50.0, steps = 13 }",
        )
        .replace(
            "{ from = -110.0, to = -10.0, steps = 6 }",
            "{ from = -110.0, to = -10.0, steps = 11 }",
        )
        .replace(
            "{ from = -150.0, to = -30.0, steps = 5 }",
            "{ from = -150.0, to = -30.0, steps = 9 }",
        );
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("fine.toml");
    std::fs::write(&path, fine).unwrap();
    let fine = RigStudy::load(&path, &quantities).unwrap();
    let noise = fine.expected_noise(&[]).unwrap();
    let mut times = Vec::new();
    for _ in 0..5 {
        let start = Instant::now();
        let next = fine.next_point(&fine.prior(), &noise).unwrap().unwrap();
        times.push(start.elapsed().as_secs_f64());
        assert_eq!(next.candidates, fine.candidates.points.len());
    }
    times.sort_by(f64::total_cmp);
    println!(
        "next-point search over {} candidates: median {:.3} s of 5 (min {:.3}, max {:.3})",
        fine.candidates.points.len(),
        times[2],
        times[0],
        times[4]
    );
}
