//! Evaluating a function at many points on all cores, with results in input order.
//!
//! Workers claim the next unevaluated point from a shared counter (a slow model run does
//! not hold up a whole chunk) and the results are put back in input order, so the outcome
//! never depends on the number of threads or on their timing. A batch whose sequential
//! cost, estimated by timing its first point, is under 2 ms runs on the calling thread.

use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::OnceLock;
use std::time::{Duration, Instant};

/// Below this estimated sequential time a batch is evaluated on the calling thread.
const WORTH_THREADS: Duration = Duration::from_millis(2);

/// `f` at every point, in the order of `points`, using up to `available_parallelism` threads.
///
/// A panic inside `f` is passed on to the caller unchanged.
pub(crate) fn evaluate_all<T, F>(points: &[Vec<f64>], f: &F) -> Vec<T>
where
    T: Send,
    F: Fn(&[f64]) -> T + Sync,
{
    let Some((first, rest)) = points.split_first() else {
        return Vec::new();
    };
    // Time one call to see whether threads pay: starting them costs tens of microseconds
    // (far more on a loaded machine), more than a whole batch of a cheap surrogate.
    let start = Instant::now();
    let first_value = f(first);
    let estimated_rest = start
        .elapsed()
        .saturating_mul(u32::try_from(rest.len()).unwrap_or(u32::MAX));
    let threads = worker_threads().min(rest.len());
    if threads <= 1 || estimated_rest < WORTH_THREADS {
        return std::iter::once(first_value)
            .chain(rest.iter().map(|x| f(x)))
            .collect();
    }
    let points = rest;
    let next = AtomicUsize::new(0);
    let mut indexed: Vec<(usize, T)> = std::thread::scope(|scope| {
        let workers: Vec<_> = (0..threads)
            .map(|_| {
                scope.spawn(|| {
                    let mut done = Vec::new();
                    loop {
                        let index = next.fetch_add(1, Ordering::Relaxed);
                        let Some(x) = points.get(index) else { break };
                        done.push((index, f(x)));
                    }
                    done
                })
            })
            .collect();
        let mut all = Vec::with_capacity(points.len());
        for worker in workers {
            match worker.join() {
                Ok(done) => all.extend(done),
                Err(panic) => std::panic::resume_unwind(panic),
            }
        }
        all
    });
    indexed.sort_unstable_by_key(|&(index, _)| index);
    std::iter::once(first_value)
        .chain(indexed.into_iter().map(|(_, value)| value))
        .collect()
}

/// The number of cores this process may use, asked once: the answer comes from cgroup
/// files, and reading them every generation cost more than a cheap generation itself.
fn worker_threads() -> usize {
    static THREADS: OnceLock<usize> = OnceLock::new();
    *THREADS.get_or_init(|| std::thread::available_parallelism().map_or(1, usize::from))
}
