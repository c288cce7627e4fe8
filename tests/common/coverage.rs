//! The coverage of a curve's posterior: replicates of a saturating curve
//! with a force transducer's correlated noise, the truth drawn from the
//! prior, and whether each posterior's 90 % intervals held it
//! (`tests/posterior.rs` asserts the share; `benches/curve_coverage.rs`
//! measures it on more replicates for every metric).

use acq_algorithms::mcmc::{sample, SamplerSettings};
use acq_analysis::loss::metrics::CurveMetric;
use acq_study::posterior::likelihood::StudyPosterior;
use acq_study::posterior::Discrepancy;
use acq_study::study::{
    Case, LossKind, Measured, Model, ModelRun, Observation, Residuals, Role, Study,
};
use rand::SeedableRng;
use rand_distr::{Distribution, Normal, Uniform};

use super::toy::{input, toy_parameters};

/// A saturating curve `y = a (1 - exp(-x / b))` at the points `xs`, in process.
struct Saturating {
    xs: Vec<f64>,
}

impl Model for Saturating {
    fn run(
        &self,
        inputs: &[(String, f64)],
        _scalars: &[&str],
        curves: &[&str],
    ) -> Result<ModelRun, String> {
        let (a, b) = (input(inputs, "a")?, input(inputs, "b")?);
        let curve: Vec<(f64, f64)> = self
            .xs
            .iter()
            .map(|&x| (x, a * (1.0 - (-x / b).exp())))
            .collect();
        Ok(ModelRun {
            scalars: Vec::new(),
            curves: curves.iter().map(|_| curve.clone()).collect(),
        })
    }

    fn is_cheap(&self) -> bool {
        true
    }
}

/// For each of `replicates` replicates, whether the 90 % intervals of a
/// and b held the truth: a saturating curve of `points` points with the
/// truth drawn from the prior and the AR(1) noise above, scored by
/// `metric`.
pub fn correlated_curve_hits(metric: CurveMetric, points: u32, replicates: u64) -> Vec<[bool; 2]> {
    use acq_algorithms::evaluation::Simulator;
    use acq_study::method::CURVE_PARTS;
    use acq_study::simulator::StudySimulator;
    // Over 0 to 4 (f64::from(points) / 4.0 is exact: the MAPE test's
    // points are i / 60, bit for bit).
    let xs: Vec<f64> = (1..=points)
        .map(|i| f64::from(i) / (f64::from(points) / 4.0))
        .collect();
    let model = Saturating { xs: xs.clone() };
    let (correlation, sd) = (0.8f64, 0.06);
    let innovation = Normal::new(0.0, sd * (1.0 - correlation * correlation).sqrt()).unwrap();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(13);
    let bounds = [("a", 5.0, 15.0), ("b", 0.5, 2.0)];
    let mut hits = Vec::new();
    for replicate in 0..replicates {
        let truth = truth_from_prior(&bounds, &mut rng);
        let mut noise = Normal::new(0.0, sd).unwrap().sample(&mut rng);
        let measured: Vec<(f64, f64)> = xs
            .iter()
            .map(|&x| {
                noise = correlation * noise + innovation.sample(&mut rng);
                (x, truth[0] * (1.0 - (-x / truth[1]).exp()) + noise)
            })
            .collect();
        let study = Study {
            parameters: toy_parameters(&bounds),
            cases: vec![Case::new(
                "test",
                Role::Fit,
                vec![Observation {
                    name: "force".into(),
                    output: "force".into(),
                    measured: Measured::Curve {
                        points: measured,
                        axes: ["x".into(), "y".into()],
                        metric,
                    },
                    weight: 1.0,
                    source: String::new(),
                    shared: Vec::new(),
                }],
            )],
            named_cases: false,
            residuals: Residuals::Relative,
            loss: LossKind::Mean,
        };
        let density = StudyPosterior::new(&study, Discrepancy::None, CURVE_PARTS).unwrap();
        let simulator =
            StudySimulator::new(&study, &model, Role::Fit).with_curve_parts(CURVE_PARTS);
        let log_density = |point: &[f64]| match simulator.evaluate(point) {
            Ok(outputs) => density.log_prior(point) + density.log_likelihood(&outputs, &[]),
            Err(_) => f64::NEG_INFINITY,
        };
        let settings = SamplerSettings {
            chains: 2,
            draws: 200,
            warmup: 400,
            thin: None,
            seed: replicate,
        };
        let chains = sample(
            log_density,
            &density.support(),
            &[truth.clone(), truth.clone()],
            &[0.3, 0.3],
            &settings,
            &|_| {},
        )
        .unwrap();
        let m = chains.summaries();
        hits.push([0, 1].map(|i| (m[i].q05..=m[i].q95).contains(&truth[i])));
    }
    hits
}

/// A truth drawn uniformly from the bounds: the prior, so a right
/// posterior covers it at its nominal rate.
pub fn truth_from_prior(bounds: &[(&str, f64, f64)], rng: &mut impl rand::Rng) -> Vec<f64> {
    bounds
        .iter()
        .map(|&(_, lower, upper)| Uniform::new(lower, upper).unwrap().sample(rng))
        .collect()
}
