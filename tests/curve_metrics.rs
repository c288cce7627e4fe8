//! acq's curve metrics against `similaritymeasures` 1.5.0 (Jekel et al.
//! 2019), the library that compared them on curves like these: 1,000
//! random pairs of rising curves, loops, curves that drop at fracture,
//! curves that end early on either side, random walks, of different
//! lengths (2 to 150 points). Each value equal to 1e-9 relative, on the
//! curves normalised by the measured one's range as acq normalises (the
//! library's PCM normalises so itself). acq's PCM always maps the simulated
//! curve onto the measured one, the library's the shorter onto the longer:
//! it is checked against the library's own code without that swap, and
//! against the library itself where the measured curve is the longer. The
//! library lives in a scratch virtualenv, never in acq's dependencies.

mod common;

use acq_analysis::loss::metrics::{matched, CurveMetric};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

type Curve = Vec<[f64; 2]>;

/// A pair of curves of one of the shapes users bring, with random sizes,
/// noise and offsets.
fn random_pair(rng: &mut ChaCha8Rng, kind: usize) -> (Curve, Curve) {
    let n = rng.random_range(2..150usize);
    let m = rng.random_range(2..150usize);
    let noise = rng.random_range(0.0..0.05);
    let jitter = |rng: &mut ChaCha8Rng| noise * (rng.random::<f64>() - 0.5);
    let curve = |rng: &mut ChaCha8Rng, count: usize, shape: &dyn Fn(f64) -> [f64; 2]| {
        (0..count)
            .map(|k| {
                let t = if count == 1 {
                    0.0
                } else {
                    k as f64 / (count - 1) as f64
                };
                let [x, y] = shape(t);
                [x + jitter(rng), y + jitter(rng)]
            })
            .collect::<Curve>()
    };
    match kind % 5 {
        // A pull to fracture: rising, softening, dropping at the end.
        0 => {
            let (stiff, drop_at) = (rng.random_range(5.0..20.0), rng.random_range(0.7..1.0));
            let (stiff2, drop2) = (
                stiff * rng.random_range(0.8..1.2),
                rng.random_range(0.6..1.0),
            );
            let pull = move |stiffness: f64, drop_at: f64| {
                move |t: f64| {
                    let force = (1.0 - (-stiffness * t).exp())
                        * if t > drop_at {
                            ((1.0 - t) / (1.0 - drop_at + 1e-9)).max(0.0)
                        } else {
                            1.0
                        };
                    [t * 8.0, 40.0 * force]
                }
            };
            (
                curve(rng, n, &pull(stiff, drop_at)),
                curve(rng, m, &pull(stiff2, drop2)),
            )
        }
        // A hysteresis loop: x goes back.
        1 => {
            let (phase, phase2) = (rng.random_range(0.1..1.0), rng.random_range(0.1..1.0));
            let turns = rng.random_range(1.0..2.0);
            let lp = move |phase: f64| {
                move |t: f64| {
                    let a = std::f64::consts::TAU * turns * t;
                    [a.sin(), (a + phase).sin()]
                }
            };
            (curve(rng, n, &lp(phase)), curve(rng, m, &lp(phase2)))
        }
        // The simulation ends early (or late) along the same path.
        2 => {
            let end = rng.random_range(0.3..1.5);
            let shape = |t: f64| [t, t.sqrt() + 0.3 * t];
            let simulated_shape = move |t: f64| {
                let s = t * end;
                [s, s.sqrt() + 0.28 * s]
            };
            (curve(rng, n, &shape), curve(rng, m, &simulated_shape))
        }
        // Load and unload: up, then back down along another path.
        3 => {
            let set = rng.random_range(0.1..0.5);
            let set2 = set * rng.random_range(0.5..1.5);
            let cycle = move |set: f64| {
                move |t: f64| {
                    if t <= 0.5 {
                        [2.0 * t, 2.0 * t]
                    } else {
                        let u = 2.0 * (t - 0.5);
                        [1.0 - u * (1.0 - set), 1.0 - u]
                    }
                }
            };
            (curve(rng, n, &cycle(set)), curve(rng, m, &cycle(set2)))
        }
        // Random walks.
        _ => {
            let walk = |rng: &mut ChaCha8Rng, count: usize| {
                let mut at = [0.0, 0.0];
                (0..count)
                    .map(|_| {
                        at = [
                            at[0] + rng.random::<f64>() - 0.3,
                            at[1] + rng.random::<f64>() - 0.5,
                        ];
                        at
                    })
                    .collect::<Curve>()
            };
            (walk(rng, n.max(3)), walk(rng, m))
        }
    }
}

#[test]
fn each_metric_equals_similaritymeasures_on_random_pairs() {
    let mut rng = ChaCha8Rng::seed_from_u64(2019);
    let pairs: Vec<(Curve, Curve)> = (0..1000).map(|k| random_pair(&mut rng, k)).collect();
    let python = common::scratch_python("curves");
    let dir = tempfile::tempdir().unwrap();
    let data = dir.path().join("pairs.json");
    std::fs::write(&data, serde_json::json!(pairs).to_string()).unwrap();
    let script = common::root().join("tests/similaritymeasures/metrics.py");
    let output = std::process::Command::new(&python)
        .args([common::path_arg(&script), common::path_arg(&data)])
        .output()
        .unwrap();
    assert!(output.status.success(), "{}", common::stderr(&output));
    let theirs: Vec<[f64; 7]> = serde_json::from_slice(&output.stdout).unwrap();
    assert_eq!(theirs.len(), pairs.len());
    let mut compared = 0;
    let mut measured_longer = 0;
    let mut crossing = 0;
    for (k, ((measured, simulated), values)) in pairs.iter().zip(&theirs).enumerate() {
        let [library_pcm, frechet, dtw, area, measured_reference_pcm, longer, area_unordered] =
            *values;
        if (area - area_unordered).abs() > 1e-9 * area.abs() {
            crossing += 1;
        }
        // acq's PCM maps the simulated curve onto the measured one; the
        // library, the shorter onto the longer. Where the measured curve
        // is the longer, they are the same.
        let mut expected = vec![
            (
                CurveMetric::Pcm,
                measured_reference_pcm,
                "the library's PCM without its swap",
            ),
            (CurveMetric::Frechet, frechet, "similaritymeasures"),
            (CurveMetric::Dtw, dtw, "similaritymeasures"),
            (CurveMetric::Area, area, "similaritymeasures"),
        ];
        if longer == 1.0 {
            measured_longer += 1;
            expected.push((CurveMetric::Pcm, library_pcm, "similaritymeasures"));
        }
        for (metric, reference, whose) in expected {
            let ours = matched(metric, measured, simulated).unwrap().value;
            assert!(
                (ours - reference).abs() <= 1e-9 * reference.abs().max(1e-12),
                "pair {k} ({} x {} points, kind {}): {metric} {ours} against {whose}' {reference}",
                measured.len(),
                simulated.len(),
                k % 5
            );
            compared += 1;
        }
    }
    // Both sides of PCM's difference are exercised.
    assert!(
        (200..=800).contains(&measured_longer),
        "{measured_longer} pairs of 1,000 with the measured curve the longer"
    );
    assert_eq!(compared, 4000 + measured_longer);
    // The area's re-ordering of self-crossing quadrilaterals is exercised:
    // in the loops, the load-unload cycles and the random walks, curves
    // cross between two points.
    assert!(
        crossing >= 200,
        "{crossing} pairs of 1,000 with a crossing quadrilateral"
    );
}
