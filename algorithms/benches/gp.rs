//! Timing of the GP fit (default settings: Matern 5/2, ARD, 5 restarts) at the two sizes the
//! calibration loop meets, n = 40 / d = 4 and n = 500 / d = 8, and of prediction throughput.
//! Run with `cargo bench -p acq-algorithms --bench gp`; prints medians of several runs.

use std::hint::black_box;
use std::time::{Duration, Instant};

use acq_algorithms::gp::{Gp, GpSettings};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// A smooth test response in the unit cube (Friedman's #1 extended with gentler terms for
/// inputs past the fifth), plus 1% observation noise.
fn response(x: &[f64], rng: &mut ChaCha8Rng) -> f64 {
    let mut y = 10.0 * (std::f64::consts::PI * x[0] * x[1]).sin() + 20.0 * (x[2] - 0.5).powi(2);
    for (k, xk) in x.iter().enumerate().skip(3) {
        y += (10.0 / k as f64) * xk;
    }
    let noise: f64 = rng.random::<f64>() - 0.5;
    y + 0.1 * noise
}

fn data(n: usize, d: usize, seed: u64) -> (Vec<Vec<f64>>, Vec<f64>) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let inputs: Vec<Vec<f64>> = (0..n)
        .map(|_| (0..d).map(|_| rng.random::<f64>()).collect())
        .collect();
    let outputs = inputs.iter().map(|x| response(x, &mut rng)).collect();
    (inputs, outputs)
}

fn median(mut times: Vec<Duration>) -> Duration {
    times.sort();
    times[times.len() / 2]
}

fn bench_fit(n: usize, d: usize, restarts: usize, runs: usize) {
    let (inputs, outputs) = data(n, d, 7);
    let settings = GpSettings {
        restarts,
        ..GpSettings::default()
    };
    let mut times = Vec::with_capacity(runs);
    let mut last = None;
    for _ in 0..runs {
        let start = Instant::now();
        let gp = Gp::fit(black_box(&inputs), black_box(&outputs), &settings);
        times.push(start.elapsed());
        last = Some(gp);
    }
    let lml = match last {
        Some(Ok(gp)) => gp.log_marginal_likelihood(),
        _ => f64::NAN,
    };
    println!(
        "fit n={n:4} d={d} ARD matern52 restarts={restarts}: median {:9.3} ms over {runs} runs \
         (min {:9.3} ms), log marginal likelihood {lml:.4}",
        median(times.clone()).as_secs_f64() * 1e3,
        times
            .iter()
            .min()
            .map_or(f64::NAN, |t| t.as_secs_f64() * 1e3),
    );
}

fn bench_predict(n: usize, d: usize) {
    let (inputs, outputs) = data(n, d, 7);
    let Ok(gp) = Gp::fit(&inputs, &outputs, &GpSettings::default()) else {
        println!("predict n={n} d={d}: fit failed");
        return;
    };
    let (queries, _) = data(2000, d, 11);
    let mut times = Vec::new();
    for _ in 0..5 {
        let start = Instant::now();
        black_box(gp.predict_many(black_box(&queries)));
        times.push(start.elapsed());
    }
    let per_point = median(times).as_secs_f64() / queries.len() as f64;
    println!(
        "predict_many n={n:4} d={d}: {:8.2} us/point ({:.0} points/s, mean + std)",
        per_point * 1e6,
        1.0 / per_point
    );
}

fn main() {
    bench_fit(40, 4, 5, 21);
    bench_fit(500, 8, 5, 5);
    bench_fit(500, 8, 2, 5);
    bench_predict(40, 4);
    bench_predict(500, 8);
}
