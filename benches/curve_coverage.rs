//! How often a curve's 90 % posterior intervals hold the truth, for each
//! curve metric (BENCHMARKS.md, "Coverage of a curve's posterior"): a
//! saturating curve `y = a (1 - exp(-x / b))` of 120 points with a force
//! transducer's AR(1) noise (sd 0.06 on forces of 5 to 15, lag-one
//! correlation 0.8), the truth drawn from the uniform prior, the posterior
//! sampled in process (2 chains of 200 draws after 400 of warm-up) with
//! the curve read as 20 parts ([`StudyPosterior`]'s curve treatment: for
//! MAPE the parts' mean relative errors, for a coupling metric its signed
//! distances averaged over parts of the measured curve's length, each
//! with the measured curve's own scatter and a scale the posterior
//! estimates). A right posterior holds the truth in 90 % of the
//! replicates; with 400 the binomial sd of that share is 1.5 %.
//!
//! `cargo bench --bench curve_coverage` (about 15 minutes on 2 cores);
//! `ACQ_BENCH_REPLICATES` (default 400), `ACQ_BENCH_METRICS` (a comma
//! list, default every metric).
//!
//! [`StudyPosterior`]: acq_study::posterior::likelihood::StudyPosterior

use std::time::Instant;

use acq_analysis::loss::metrics::CurveMetric;

#[path = "../tests/common/mod.rs"]
mod common;

fn main() {
    let replicates: u64 = std::env::var("ACQ_BENCH_REPLICATES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(400);
    let metrics: Vec<CurveMetric> = match std::env::var("ACQ_BENCH_METRICS") {
        Ok(list) => list
            .split(',')
            .map(|name| {
                name.trim()
                    .parse()
                    .unwrap_or_else(|e| panic!("ACQ_BENCH_METRICS: {e}"))
            })
            .collect(),
        Err(_) => vec![
            CurveMetric::Mape,
            CurveMetric::Pcm,
            CurveMetric::Frechet,
            CurveMetric::Dtw,
            CurveMetric::Area,
        ],
    };
    println!("| metric | a: intervals holding the truth | b | replicates | wall s |");
    println!("|---|---|---|---|---|");
    for metric in metrics {
        let start = Instant::now();
        let hits = common::coverage::correlated_curve_hits(metric, 120, replicates);
        let share = |i: usize| hits.iter().filter(|h| h[i]).count() as f64 / hits.len() as f64;
        println!(
            "| {} | {:.1} % | {:.1} % | {replicates} | {:.0} |",
            metric.as_str(),
            100.0 * share(0),
            100.0 * share(1),
            start.elapsed().as_secs_f64()
        );
    }
}
