//! The GTN curve search on tests it was not designed on.
//!
//! Synthetic tensile tests are made with the twin itself: the flow curve
//! and Young's modulus of a shipped P91 test, a GTN parameter set from a
//! maximin Latin hypercube over the search box, the default mesh in steps
//! of 2 um (finer than the calibration's 10 um: the test is not the
//! model), pulled to
//! the shipped test's last displacement (or as far as the twin gets, or
//! until the force has fallen to the fraction of its maximum at which the
//! shipped test stopped: a machine's break detection), read
//! at the shipped test's own displacements (so the x grid is the test's,
//! not the model's) with Gaussian force noise of the size the shipped test
//! shows (its scatter about the line through its neighbours, robustly). Each
//! synthetic test is then calibrated like a user's: `acq calibrate gtn
//! --test T --target-mape 1 --max-evals 30` at the default mesh, E and the
//! flow curve re-derived from the noisy curve.
//!
//! Two sets with their own seeds: `tune` (8 per flow curve), on which the
//! search may be designed, and `held-out` (12 per flow curve), run only to
//! report. `ACQ_BENCH_SET=tune|held-out|shipped|all` (default all);
//! `ACQ_BENCH_MAX_EVALS` (default 30); `ACQ_BENCH_NOISE_SCALE` multiplies
//! the noise (default 1); `ACQ_BENCH_KEEP=DIR` keeps the
//! synthetic tests' CSVs and run directories.
//!
//! `ACQ_BENCH_SEARCH=slopes` runs each test through [`gtn_slopes`]
//! instead of the calibration: the count the search would reach if each
//! run gave its curve's slopes (a reference, the slopes' runs not counted).
//!
//! Exits 1 when a test needs more than 20 simulations to reach 1 %.
//!
//! `cargo bench --bench gtn_generalisation`

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

use acq_algorithms::doe::latin_hypercube;
use acq_analysis::extract::tensile_props::{
    read_test_csv, tensile_properties, SpecimenGeometry, TestPoint,
};
use acq_workflows::calibrate::gtn::{parameters, CalibrateGtnOptions};
use acq_workflows::tensile_model::{GtnInputs, ModelSettings, TensileModel, PARAMETER_NAMES};
use rand::SeedableRng;
use rand_distr::{Distribution, Normal};

mod gtn_slopes;

const SHIPPED: [&str; 2] = ["P91_20_2_DF_SS.csv", "P91_500_DF_SS.csv"];
const TUNE_SEED: u64 = 11;
const TUNE_PER_FLOW_CURVE: usize = 8;
const HELD_OUT_SEED: u64 = 29;
const HELD_OUT_PER_FLOW_CURVE: usize = 12;
const TARGET_MAPE_PCT: f64 = 1.0;
/// The goal: every test under the target MAPE within this many simulations
/// (the bench exits 1 when one is not).
const GOAL_SIMULATIONS: usize = 20;

/// The force scatter of a measured curve, kN: each point's distance from
/// the line through its two neighbours, over the plastic part up to the
/// maximum force (where the curve is smooth), as a robust standard
/// deviation of one point (1.4826 MAD, over the factor sqrt(1 + w^2 +
/// (1 - w)^2) that the neighbours' own noise adds).
fn force_scatter_kn(test: &[TestPoint]) -> f64 {
    let peak = test
        .iter()
        .enumerate()
        .max_by(|a, b| a.1.force_kn.total_cmp(&b.1.force_kn))
        .map_or(0, |(i, _)| i);
    let yield_force = 0.8 * test[peak].force_kn;
    let mut deviations: Vec<f64> = test[..=peak]
        .windows(3)
        .filter(|w| w[1].force_kn > yield_force)
        .filter_map(|w| {
            let span = w[2].displacement_mm - w[0].displacement_mm;
            if span <= 0.0 {
                return None;
            }
            let weight = (w[1].displacement_mm - w[0].displacement_mm) / span;
            let line = w[0].force_kn + weight * (w[2].force_kn - w[0].force_kn);
            let inflation = (1.0 + weight.powi(2) + (1.0 - weight).powi(2)).sqrt();
            Some((w[1].force_kn - line).abs() / inflation)
        })
        .collect();
    deviations.sort_by(f64::total_cmp);
    1.4826 * deviations[deviations.len() / 2]
}

struct Synthetic {
    name: String,
    truth: Vec<f64>,
    path: PathBuf,
    /// The test stopped before the shipped test's end: the truth broke
    /// (its force fell to the shipped test's last fraction of its maximum)
    /// or stopped converging.
    ends_early: bool,
}

/// Writes the synthetic tests of one set into `dir`.
fn make_set(
    root: &Path,
    dir: &Path,
    set: &str,
    seed: u64,
    per_flow_curve: usize,
    noise_scale: f64,
) -> Vec<Synthetic> {
    let mut tests = Vec::new();
    for (flow_index, shipped) in SHIPPED.iter().enumerate() {
        let points = read_test_csv(&root.join("data/tensile").join(shipped)).expect("test");
        let properties = tensile_properties(&points, SpecimenGeometry::default()).expect("props");
        let box_ = parameters(properties.post_uts_slope.upper_bound_mpa.max(1.0));
        let scatter_kn = noise_scale * force_scatter_kn(&points);
        let shipped_max_kn = points.iter().map(|p| p.force_kn).fold(0.0, f64::max);
        let stop_fraction = points.last().map_or(0.0, |p| p.force_kn) / shipped_max_kn;
        // Steps of 2 um, not the default 10: read at the test's points, a
        // coarser curve cuts the corner at yield, and E re-derived from it
        // came out 2.5 % low.
        let settings = ModelSettings {
            output_interval_mm: 0.002,
            ..ModelSettings::default()
        };
        let model = TensileModel::new(points.clone(), properties, settings);
        let design = latin_hypercube(
            per_flow_curve,
            PARAMETER_NAMES.len(),
            seed + flow_index as u64,
        );
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed * 1000 + flow_index as u64);
        let noise = Normal::new(0.0, scatter_kn).expect("noise");
        for (index, unit) in design.iter().enumerate() {
            let truth: Vec<f64> = box_
                .iter()
                .zip(unit)
                .map(|(p, &u)| p.from_unit(u))
                .collect();
            let inputs = GtnInputs::from_values(&truth).expect("eight values");
            let pulled = model.pull(&inputs).expect("the truth simulates");
            let curve = &pulled.curve;
            let last_mm = curve.last().map_or(0.0, |p| p.displacement_mm);
            let end_mm = model.end_displacement_mm();
            let mut ends_early = last_mm < end_mm - 1e-9;
            let mut csv = String::from("DISPLACEMENT,FORCE\n0,0\n");
            let mut max_force_kn: f64 = 0.0;
            for point in points.iter().filter(|p| p.displacement_mm > 0.0) {
                if point.displacement_mm > last_mm {
                    break;
                }
                let at = curve.partition_point(|c| c.displacement_mm < point.displacement_mm);
                let force_kn = if at == 0 {
                    curve[0].force_kn
                } else {
                    let (a, b) = (&curve[at - 1], &curve[at]);
                    let w = (point.displacement_mm - a.displacement_mm)
                        / (b.displacement_mm - a.displacement_mm);
                    a.force_kn + w * (b.force_kn - a.force_kn)
                };
                let noisy = force_kn + noise.sample(&mut rng);
                writeln!(csv, "{},{noisy}", point.displacement_mm).unwrap();
                // The machine's break detection: the shipped test stopped
                // with its force at this fraction of its maximum.
                max_force_kn = max_force_kn.max(force_kn);
                if force_kn < stop_fraction * max_force_kn {
                    ends_early = true;
                    break;
                }
            }
            let name = format!("{set}-{}-{index:02}", &shipped[..6]);
            let path = dir.join(format!("{name}.csv"));
            std::fs::write(&path, csv).expect("write test");
            tests.push(Synthetic {
                name,
                truth,
                path,
                ends_early,
            });
        }
        eprintln!("{shipped}: force scatter {scatter_kn:.4} kN (the synthetic tests' noise)");
    }
    tests
}

/// The truth's MAPE on its own synthetic test, E and flow curve re-derived
/// from the noisy curve as the calibration does (None: the truth's m is
/// past the re-derived bound, or the run fails).
fn truth_mape(test: &Synthetic) -> (Option<f64>, bool) {
    let points = read_test_csv(&test.path).expect("synthetic test");
    let properties = tensile_properties(&points, SpecimenGeometry::default()).expect("props");
    let m_in_box = test.truth[7] <= properties.post_uts_slope.upper_bound_mpa.max(1.0);
    let model = TensileModel::new(points, properties, ModelSettings::default());
    let inputs = GtnInputs::from_values(&test.truth).expect("eight values");
    (
        model.run(&inputs).ok().map(|r| r.mape.mape_percent),
        m_in_box,
    )
}

struct Row {
    name: String,
    truth_mape_pct: Option<f64>,
    best_mape_pct: f64,
    to_target: Option<usize>,
    evaluations: usize,
    wall_s: f64,
    note: String,
}

/// How each test is searched.
#[derive(Clone, Copy, PartialEq)]
enum Search {
    /// `acq calibrate gtn`, as a user runs it.
    Calibration,
    /// The reference with the slopes in hand ([`gtn_slopes`]).
    WithSlopes,
}

/// (best MAPE %, simulations to target, simulations, wall s, a note).
fn search(
    how: Search,
    test: &Path,
    out: &Path,
    max_evals: u32,
) -> (f64, Option<usize>, usize, f64, Option<String>) {
    if how == Search::WithSlopes {
        let start = Instant::now();
        let found = gtn_slopes::search_with_slopes(test, TARGET_MAPE_PCT, max_evals as usize);
        return (
            found.best_mape_pct,
            found.to_target,
            found.counted,
            start.elapsed().as_secs_f64(),
            Some(format!(
                "{} runs for the slopes, not counted",
                found.slope_runs
            )),
        );
    }
    let (best, to_target, evaluations, wall_s) = calibrate(test, out, max_evals);
    (best, to_target, evaluations, wall_s, None)
}

fn calibrate(test: &Path, out: &Path, max_evals: u32) -> (f64, Option<usize>, usize, f64) {
    let start = Instant::now();
    let found = acq_workflows::calibrate::gtn::run(CalibrateGtnOptions {
        max_evals,
        target_mape_pct: TARGET_MAPE_PCT,
        ..CalibrateGtnOptions::new(test, out)
    })
    .expect("gtn calibration");
    (
        found.best_mape_pct,
        found.evaluations_to_target,
        found.evaluations,
        start.elapsed().as_secs_f64(),
    )
}

fn report(set: &str, rows: &[Row], max_evals: u32) {
    println!("\n{set}: target {TARGET_MAPE_PCT} % within {max_evals} simulations (default mesh)");
    println!("| test | truth's MAPE % | best MAPE % | simulations to 1 % | wall s | note |");
    println!("|---|---|---|---|---|---|");
    for row in rows {
        println!(
            "| {} | {} | {:.3} | {} | {:.1} | {} |",
            row.name,
            row.truth_mape_pct.map_or("-".into(), |m| format!("{m:.3}")),
            row.best_mape_pct,
            row.to_target
                .map_or(format!("not in {}", row.evaluations), |n| n.to_string()),
            row.wall_s,
            row.note
        );
    }
    let mut counts: Vec<usize> = rows.iter().filter_map(|r| r.to_target).collect();
    counts.sort_unstable();
    let reached = counts.len();
    let median = counts.get(counts.len() / 2).copied();
    println!(
        "{set}: {reached} of {} reach {TARGET_MAPE_PCT} % within {max_evals} ({:.0} %); simulations to target: median {}, max {}",
        rows.len(),
        100.0 * reached as f64 / rows.len().max(1) as f64,
        median.map_or("-".into(), |m| m.to_string()),
        counts.last().map_or("-".into(), |m| m.to_string()),
    );
}

/// One test searched `how`, its row.
fn search_one(how: Search, test: &Synthetic, dir: &Path, max_evals: u32) -> Row {
    let (truth_mape_pct, m_in_box) = if test.truth.is_empty() {
        (None, true)
    } else {
        truth_mape(test)
    };
    let out = dir.join(format!("run-{}", test.name));
    if out.exists() {
        std::fs::remove_dir_all(&out).expect("an earlier run's directory");
    }
    let (best_mape_pct, to_target, evaluations, wall_s, search_note) =
        search(how, &test.path, &out, max_evals);
    let mut note: Vec<String> = search_note.into_iter().collect();
    if test.ends_early {
        note.push("breaks early".to_string());
    }
    if !m_in_box {
        note.push("truth's m past the re-derived bound".to_string());
    }
    if !test.truth.is_empty() {
        note.push(format!(
            "truth {}",
            PARAMETER_NAMES
                .iter()
                .zip(&test.truth)
                .map(|(n, v)| format!("{n}={v:.4}"))
                .collect::<Vec<_>>()
                .join(" ")
        ));
    }
    let row = Row {
        name: test.name.clone(),
        truth_mape_pct,
        best_mape_pct,
        to_target,
        evaluations,
        wall_s,
        note: note.join("; "),
    };
    eprintln!(
        "{}: best {:.3} % (truth {:?}), to target {:?}",
        row.name, row.best_mape_pct, row.truth_mape_pct, row.to_target
    );
    row
}

fn main() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let which = std::env::var("ACQ_BENCH_SET").unwrap_or_else(|_| "all".into());
    let max_evals: u32 = std::env::var("ACQ_BENCH_MAX_EVALS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(30);
    let how = match std::env::var("ACQ_BENCH_SEARCH").as_deref() {
        Ok("slopes") => Search::WithSlopes,
        Ok("calibration") | Err(_) => Search::Calibration,
        Ok(other) => panic!("ACQ_BENCH_SEARCH={other}: give calibration or slopes"),
    };
    let noise_scale: f64 = std::env::var("ACQ_BENCH_NOISE_SCALE")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(1.0);
    let scratch = tempfile::tempdir().expect("temp dir");
    let dir = std::env::var_os("ACQ_BENCH_KEEP")
        .map(PathBuf::from)
        .unwrap_or_else(|| scratch.path().to_path_buf());
    std::fs::create_dir_all(&dir).expect("work dir");
    let mut sets: Vec<(&str, Vec<Synthetic>)> = Vec::new();
    if matches!(which.as_str(), "shipped" | "all") {
        let shipped = SHIPPED
            .iter()
            .map(|name| Synthetic {
                name: name.to_string(),
                truth: Vec::new(),
                path: root.join("data/tensile").join(name),
                ends_early: false,
            })
            .collect();
        sets.push(("shipped", shipped));
    }
    if matches!(which.as_str(), "tune" | "all") {
        sets.push((
            "tune",
            make_set(
                root,
                &dir,
                "tune",
                TUNE_SEED,
                TUNE_PER_FLOW_CURVE,
                noise_scale,
            ),
        ));
    }
    if matches!(which.as_str(), "held-out" | "all") {
        sets.push((
            "held-out",
            make_set(
                root,
                &dir,
                "held-out",
                HELD_OUT_SEED,
                HELD_OUT_PER_FLOW_CURVE,
                noise_scale,
            ),
        ));
    }
    let mut everything = Vec::new();
    for (set, tests) in &sets {
        let mut rows = Vec::new();
        for test in tests {
            rows.push(search_one(how, test, &dir, max_evals));
        }
        report(set, &rows, max_evals);
        everything.extend(rows);
    }
    if sets.len() > 1 {
        report("all sets", &everything, max_evals);
    }
    let missed: Vec<&str> = everything
        .iter()
        .filter(|row| row.to_target.is_none_or(|n| n > GOAL_SIMULATIONS))
        .map(|row| row.name.as_str())
        .collect();
    if !missed.is_empty() {
        eprintln!(
            "goal not met: {} of {} tests need more than {GOAL_SIMULATIONS} simulations to reach {TARGET_MAPE_PCT} %: {}",
            missed.len(),
            everything.len(),
            missed.join(", ")
        );
        std::process::exit(1);
    }
}
