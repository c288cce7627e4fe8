//! The posterior of a model too slow to run at every step (a user's
//! solver, the GTN twin): sampled on an emulator of it, one Gaussian
//! process per value the likelihood reads, trained on every logged run
//! (the search's, then the refinement's).
//!
//! The emulator's own variance joins each value's error variance, so where
//! it is unsure the posterior is wider, never falsely narrow. It is refined
//! where the posterior lies: after each round of sampling, the draws where
//! the emulator's standard deviation is largest against the measurement's
//! are run on the model (through the logging evaluator, so they resume and
//! may be cluster jobs), until at 95 % of the draws it is below
//! [`REFINE_RATIO`] of the measurement's (the posterior then widens by at
//! most 3 %) or the refinement's budget of runs is spent. The doubt weighed
//! is the latent GP's, which runs take away; a GP's fitted scatter (a
//! solver's run-to-run noise, or a jump it cannot follow, as where a
//! simulated bar breaks) stays in the likelihood and is reported as the
//! floor it is.

use acq_algorithms::evaluation::{Evaluation, Parameter};
use acq_algorithms::gp::{Gp, GpSettings, Kernel};
use acq_algorithms::mcmc::{quantile, Chains};
use acq_algorithms::multi_fidelity::CoKriging;

use super::super::search::to_unit;
use super::likelihood::{Scales, StudyPosterior};

/// Refinement ends when the emulator's sd is below this share of the
/// measurement's at 95 % of the posterior draws.
pub const REFINE_RATIO: f64 = 0.25;
/// Runs per refinement round: a new round refits the GPs and samples again.
pub const RUNS_PER_ROUND: usize = 4;

/// One GP per observation the likelihood reads.
pub struct Emulator {
    parameters: Vec<Parameter>,
    gps: Vec<Emulated>,
    /// Each GP's fitted noise variance, in the output's units squared.
    noise_variances: Vec<f64>,
    /// The output index of each observation, and how many outputs the fit
    /// simulator has.
    output_indices: Vec<usize>,
    outputs: usize,
    /// Runs it was trained on.
    pub runs: usize,
    /// Coarse-mesh runs it was trained on too (co-kriging; 0: none).
    pub coarse_runs: usize,
}

/// How one observation's value is emulated.
enum Emulated {
    Gp(Box<Gp>),
    /// Over a coarse mesh's runs too ([`acq_algorithms::multi_fidelity`]).
    CoKriging(Box<CoKriging>),
    /// Every run gave the same value.
    Constant(f64),
}

impl Emulator {
    /// Fits the GPs to the successful `runs` (search vectors and fit
    /// outputs); with two or more `coarse_runs` (a two-level search's
    /// cheap level, the same outputs), co-kriging over both levels.
    pub fn fit(
        parameters: &[Parameter],
        density: &StudyPosterior,
        runs: &[Evaluation],
        coarse_runs: &[Evaluation],
        seed: u64,
    ) -> Result<Emulator, String> {
        let width = runs
            .iter()
            .find_map(|e| e.outcome.as_ref().ok().map(Vec::len))
            .unwrap_or(0);
        let coarse: Vec<(Vec<f64>, &Vec<f64>)> = coarse_runs
            .iter()
            .filter_map(|e| {
                let outputs = e.outcome.as_ref().ok().filter(|y| y.len() == width)?;
                Some((to_unit(parameters, &e.parameters), outputs))
            })
            .collect();
        let (inputs, outputs): (Vec<Vec<f64>>, Vec<&Vec<f64>>) = runs
            .iter()
            .filter_map(|e| Some((to_unit(parameters, &e.parameters), e.outcome.as_ref().ok()?)))
            .unzip();
        if inputs.len() < parameters.len() + 2 {
            return Err(format!(
                "the emulator needs at least {} successful runs of the model (one per parameter and two more); the search left {}",
                parameters.len() + 2,
                inputs.len()
            ));
        }
        let settings = GpSettings {
            kernel: Kernel::Matern52,
            ard: true,
            restarts: 3,
            seed,
            input_bounds: Some(vec![(0.0, 1.0); parameters.len()]),
            ..GpSettings::default()
        };
        let gps = density
            .observations
            .iter()
            .map(|o| {
                let column: Vec<f64> = outputs.iter().map(|y| y[o.output_index]).collect();
                // A value no parameter moves (a load case at zero load, a
                // gauge the parameters do not reach) is that value, surely.
                if column.iter().all(|v| *v == column[0]) {
                    return Ok(Emulated::Constant(column[0]));
                }
                if coarse.len() >= 2 {
                    let fine: Vec<(Vec<f64>, f64)> =
                        inputs.iter().cloned().zip(column.iter().copied()).collect();
                    let cheap: Vec<(Vec<f64>, f64)> = coarse
                        .iter()
                        .map(|(x, y)| (x.clone(), y[o.output_index]))
                        .collect();
                    if let Ok(model) = CoKriging::fit(&cheap, &fine, &settings) {
                        return Ok(Emulated::CoKriging(Box::new(model)));
                    }
                }
                Gp::fit(&inputs, &column, &settings)
                    .map(|gp| Emulated::Gp(Box::new(gp)))
                    .map_err(|e| format!("emulating {}: {e}", o.key))
            })
            .collect::<Result<Vec<_>, _>>()?;
        Ok(Emulator {
            parameters: parameters.to_vec(),
            noise_variances: gps
                .iter()
                .map(|gp| match gp {
                    Emulated::Gp(gp) => gp.hyperparameters().noise_variance,
                    Emulated::CoKriging(model) => model.noise_variance(),
                    Emulated::Constant(_) => 0.0,
                })
                .collect(),
            gps,
            output_indices: density
                .observations
                .iter()
                .map(|o| o.output_index)
                .collect(),
            outputs: outputs.first().map_or(0, |y| y.len()),
            runs: inputs.len(),
            coarse_runs: if coarse.len() >= 2 { coarse.len() } else { 0 },
        })
    }

    /// The fit outputs the likelihood reads at `point` (the others NaN)
    /// and each observation's emulator variance (latent and fitted noise:
    /// a solver's run-to-run scatter is uncertainty too).
    pub fn predict(&self, point: &[f64]) -> (Vec<f64>, Vec<f64>) {
        let unit = to_unit(&self.parameters, point);
        let mut outputs = vec![f64::NAN; self.outputs];
        let variances = self
            .gps
            .iter()
            .zip(&self.output_indices)
            .zip(&self.noise_variances)
            .map(|((gp, &index), noise)| match gp {
                Emulated::Gp(gp) => {
                    let prediction = gp.predict(&unit);
                    outputs[index] = prediction.mean;
                    prediction.std.powi(2) + noise
                }
                Emulated::CoKriging(model) => {
                    let prediction = model.predict(&unit);
                    outputs[index] = prediction.mean;
                    prediction.std.powi(2) + noise
                }
                Emulated::Constant(value) => {
                    outputs[index] = *value;
                    0.0
                }
            })
            .collect();
        (outputs, variances)
    }

    /// The largest ratio of the fitted run-to-run scatter's sd (the GPs'
    /// noise) to the measurement's over the observations: the floor no
    /// number of runs takes the emulator's doubt below.
    pub fn scatter_ratio(&self, density: &StudyPosterior, scales: &Scales) -> f64 {
        self.noise_variances
            .iter()
            .enumerate()
            .map(|(i, v)| v.sqrt() / density.observation_sd(i, scales))
            .fold(0.0, f64::max)
    }

    /// The largest ratio of the emulator's sd to the measurement's over
    /// the observations, at `point`, with the noise `scales` where the
    /// study states none: the part of its doubt more runs take away (the
    /// latent GP's; the fitted scatter stays however many runs there are,
    /// and the likelihood carries it).
    pub fn unsureness(&self, density: &StudyPosterior, point: &[f64], scales: &Scales) -> f64 {
        let unit = to_unit(&self.parameters, point);
        self.gps
            .iter()
            .enumerate()
            .map(|(i, gp)| match gp {
                Emulated::Gp(gp) => gp.predict(&unit).std / density.observation_sd(i, scales),
                Emulated::CoKriging(model) => {
                    model.predict(&unit).std / density.observation_sd(i, scales)
                }
                Emulated::Constant(_) => 0.0,
            })
            .fold(0.0, f64::max)
    }
}

/// Where to run the model next: the draws (about 400 spread over the
/// chains) with the largest unsureness, at most `count`, none closer than
/// 2 % of the box to one already picked; and the unsureness at 95 % of the
/// draws. Empty when that is below [`REFINE_RATIO`].
pub fn refinement_points(
    emulator: &Emulator,
    density: &StudyPosterior,
    chains: &Chains,
    scales: &Scales,
    count: usize,
) -> (Vec<Vec<f64>>, f64) {
    let draws: Vec<&Vec<f64>> = chains.pooled().collect();
    let step = (draws.len() / 400).max(1);
    let mut scored: Vec<(f64, &Vec<f64>)> = draws
        .iter()
        .step_by(step)
        .map(|d| (emulator.unsureness(density, d, scales), *d))
        .collect();
    let mut ratios: Vec<f64> = scored.iter().map(|(r, _)| *r).collect();
    ratios.sort_by(f64::total_cmp);
    let at_95 = quantile(&ratios, 0.95);
    if at_95 <= REFINE_RATIO {
        return (Vec::new(), at_95);
    }
    scored.sort_by(|a, b| b.0.total_cmp(&a.0));
    let mut picked: Vec<Vec<f64>> = Vec::new();
    let unit = |p: &[f64]| to_unit(&emulator.parameters, p);
    for (_, draw) in scored {
        if picked.len() == count {
            break;
        }
        let u = unit(draw);
        let far = picked.iter().all(|p| {
            let q = unit(p);
            u.iter()
                .zip(&q)
                .map(|(a, b)| (a - b).powi(2))
                .sum::<f64>()
                .sqrt()
                > 0.02
        });
        if far {
            picked.push(draw.clone());
        }
    }
    (picked, at_95)
}
