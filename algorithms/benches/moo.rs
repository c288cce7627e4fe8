//! Wall time of NSGA-II at the calibration's size and on ZDT1, as medians of repeated runs.
//!
//! Run: `cargo bench -p acq-algorithms --bench moo` (add `-- --quick` for 3 repetitions).
//! Case 1 is the calibration's pick step: population 400 x 100 generations over 4
//! parameters and 3 objectives, each objective a Gaussian-process posterior mean (30
//! squared-exponential terms), so the time is mostly the algorithm's own. The target is
//! under one second. Case 2 is ZDT1 at pymoo's comparison size (100 x 250).

use std::hint::black_box;
use std::time::{Duration, Instant};

use acq_algorithms::moo::{hypervolume, nsga2, Nsga2Settings, Problem};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Three stand-ins for GP posterior means over the unit box in 4-D: each a weighted sum of
/// squared-exponential bumps around 30 fixed "training points".
struct SurrogateMeans {
    centres: Vec<[f64; 4]>,
    weights: [Vec<f64>; 3],
    inverse_length_squared: f64,
}

impl SurrogateMeans {
    fn new(seed: u64) -> Self {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let centres = (0..30)
            .map(|_| std::array::from_fn(|_| rng.random::<f64>()))
            .collect();
        let mut weights = || (0..30).map(|_| rng.random::<f64>() - 0.3).collect();
        Self {
            centres,
            weights: [weights(), weights(), weights()],
            inverse_length_squared: 1.0 / (2.0 * 0.3 * 0.3),
        }
    }

    fn evaluate(&self, x: &[f64]) -> Vec<f64> {
        let mut means = vec![0.0; 3];
        for (k, centre) in self.centres.iter().enumerate() {
            let squared: f64 = centre.iter().zip(x).map(|(c, v)| (c - v) * (c - v)).sum();
            let kernel = (-squared * self.inverse_length_squared).exp();
            for (mean, weights) in means.iter_mut().zip(&self.weights) {
                *mean += weights[k] * kernel;
            }
        }
        means
    }
}

fn median(mut times: Vec<Duration>) -> Duration {
    times.sort();
    times[times.len() / 2]
}

fn time_runs(repetitions: usize, mut run: impl FnMut(u64) -> f64) -> (Duration, Duration, f64) {
    let mut times = Vec::with_capacity(repetitions);
    let mut last_quality = 0.0;
    for repetition in 0..repetitions {
        let start = Instant::now();
        last_quality = black_box(run(repetition as u64 + 1));
        times.push(start.elapsed());
    }
    let fastest = times.iter().copied().min().unwrap_or_default();
    (median(times), fastest, last_quality)
}

fn main() {
    let quick = std::env::args().any(|a| a == "--quick");
    let repetitions = if quick { 3 } else { 9 };
    let threads = std::thread::available_parallelism().map_or(1, usize::from);
    println!("moo bench: {repetitions} repetitions, {threads} threads");

    let means = SurrogateMeans::new(7);
    let bounds = vec![(0.0, 1.0); 4];
    let (median_time, fastest, front_size) = time_runs(repetitions, |seed| {
        let settings = Nsga2Settings {
            seed,
            ..Nsga2Settings::default()
        };
        match nsga2(|x| means.evaluate(x), &bounds, &settings) {
            Ok(result) => result.front.len() as f64,
            Err(error) => {
                eprintln!("nsga2 failed: {error}");
                f64::NAN
            }
        }
    });
    println!(
        "nsga2 pop 400 x 100 gen, 4 inputs, 3 GP-mean objectives: median {:.3} s (fastest {:.3} s), \
         40 400 evaluations, last front {front_size} points, target < 1 s",
        median_time.as_secs_f64(),
        fastest.as_secs_f64()
    );

    let problem = Problem::Zdt1;
    let (median_time, fastest, volume) = time_runs(repetitions, |seed| {
        let settings = Nsga2Settings {
            population: 100,
            generations: 250,
            pareto_fraction: 1.0,
            seed,
            ..Nsga2Settings::default()
        };
        nsga2(|x| problem.evaluate(x), &problem.bounds(), &settings)
            .ok()
            .and_then(|result| {
                let front: Vec<Vec<f64>> = result.front.into_iter().map(|i| i.objectives).collect();
                hypervolume(&front, &problem.reference_point()).ok()
            })
            .unwrap_or(f64::NAN)
    });
    println!(
        "nsga2 zdt1 pop 100 x 250 gen: median {:.3} s (fastest {:.3} s), last HV {volume:.6} \
         (true front {:.6})",
        median_time.as_secs_f64(),
        fastest.as_secs_f64(),
        problem.true_hypervolume()
    );
}
