//! `acq gp fit|predict` and `acq moo`: the engine's building blocks on
//! their own, for users' data and for side-by-side checks against other
//! tools (scikit-learn, pymoo).

use std::path::PathBuf;

use acq_algorithms::doe::read_design_csv;
use acq_algorithms::gp::{FixedHyperparameters, Gp, GpSettings, Kernel};
use acq_algorithms::moo::{hypervolume, nsga2, Nsga2Settings, Problem, Tournament};
use acq_error::{AcqError, Result};
use acq_io::output::Output;
use clap::{Args, Subcommand};
use serde::{Deserialize, Serialize};

#[derive(Subcommand, Debug)]
pub enum GpCommand {
    /// Fit a GP to columns of a CSV; the model as JSON.
    Fit(GpFitArgs),
    /// Mean and standard deviation (of the latent function) at the points of a CSV.
    Predict(GpPredictArgs),
}

#[derive(Args, Debug)]
pub struct GpFitArgs {
    /// Training data: a CSV with a header row.
    #[arg(long, value_name = "CSV")]
    pub train: PathBuf,
    /// Input columns, comma-separated.
    #[arg(long, value_delimiter = ',', required = true)]
    pub inputs: Vec<String>,
    /// Output column.
    #[arg(long)]
    pub output: String,
    /// Kernel: se, matern12, matern32, matern52.
    #[arg(long, default_value = "se")]
    pub kernel: Kernel,
    /// One length scale per input (otherwise one shared).
    #[arg(long)]
    pub ard: bool,
    /// LENGTHSCALES,SIGNAL_VAR,NOISE_VAR in the data's own units (one length scale, or one
    /// per input): no fit, no input scaling, no output standardisation, zero mean.
    #[arg(
        long,
        value_name = "L[,L..],SIGNAL_VAR,NOISE_VAR",
        value_delimiter = ',',
        allow_negative_numbers = true
    )]
    pub fixed: Option<Vec<f64>>,
    /// Multistart L-BFGS starts of the fit (1 to 1,000).
    #[arg(long, default_value_t = 5, value_parser = clap::value_parser!(u16).range(1..=1000))]
    pub restarts: u16,
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// The model (JSON).
    #[arg(short = 'o', long = "output-model", value_name = "model.json")]
    pub model: PathBuf,
}

#[derive(Args, Debug)]
pub struct GpPredictArgs {
    /// A model written by `acq gp fit`.
    #[arg(long, value_name = "model.json")]
    pub model: PathBuf,
    /// Points: a CSV with (at least) the model's input columns.
    #[arg(long, value_name = "CSV")]
    pub points: PathBuf,
    /// Predictions: columns mean,std.
    #[arg(short = 'o', long = "output", value_name = "OUT.csv")]
    pub output: PathBuf,
}

/// What `acq gp fit` writes: the GP with the names of its columns.
#[derive(Serialize, Deserialize)]
struct ModelFile {
    inputs: Vec<String>,
    output: String,
    gp: Gp,
}

fn read_columns(path: &PathBuf, names: &[&str]) -> Result<Vec<Vec<f64>>> {
    let text = std::fs::read_to_string(path).map_err(|e| AcqError::open(path, e))?;
    read_design_csv(&text, names)
        .map_err(|e| AcqError::Malformed(format!("{}: {e}", path.display())))
}

pub fn run_gp(command: GpCommand) -> Result<()> {
    match command {
        GpCommand::Fit(args) => {
            let mut names: Vec<&str> = args.inputs.iter().map(String::as_str).collect();
            names.push(&args.output);
            let rows = read_columns(&args.train, &names)?;
            let d = args.inputs.len();
            let inputs: Vec<Vec<f64>> = rows.iter().map(|r| r[..d].to_vec()).collect();
            let outputs: Vec<f64> = rows.iter().map(|r| r[d]).collect();
            let fixed = match &args.fixed {
                None => None,
                Some(values) => {
                    let scales = values.len().saturating_sub(2);
                    if values.len() < 3 || !(scales == 1 || scales == d) {
                        return Err(AcqError::Config(format!(
                            "--fixed: {} values; give 1 or {d} length scales, then the signal and noise variances",
                            values.len()
                        )));
                    }
                    Some(FixedHyperparameters {
                        length_scales: values[..scales].to_vec(),
                        signal_variance: values[scales],
                        noise_variance: values[scales + 1],
                    })
                }
            };
            let settings = GpSettings {
                kernel: args.kernel,
                ard: args.ard,
                restarts: usize::from(args.restarts),
                seed: args.seed,
                fixed,
                ..GpSettings::default()
            };
            let gp = Gp::fit(&inputs, &outputs, &settings)
                .map_err(|e| AcqError::Config(format!("{}: {e}", args.train.display())))?;
            eprintln!(
                "GP on {} points: log marginal likelihood {:.6}, leave-one-out RMSE {:.6}",
                inputs.len(),
                gp.log_marginal_likelihood(),
                gp.leave_one_out().rmse
            );
            let file = ModelFile {
                inputs: args.inputs.clone(),
                output: args.output.clone(),
                gp,
            };
            let json = serde_json::to_string_pretty(&file)
                .map_err(|e| AcqError::Config(format!("cannot serialise the model: {e}")))?;
            Output::write_complete(&args.model, json.as_bytes())
        }
        GpCommand::Predict(args) => {
            let text =
                std::fs::read_to_string(&args.model).map_err(|e| AcqError::open(&args.model, e))?;
            let file: ModelFile = serde_json::from_str(&text).map_err(|e| {
                AcqError::Malformed(format!(
                    "{}: not a model of acq gp fit: {e}",
                    args.model.display()
                ))
            })?;
            let gp = Gp::from_json(&serde_json::to_string(&file.gp).unwrap_or_default())
                .map_err(|e| AcqError::Malformed(format!("{}: {e}", args.model.display())))?;
            let names: Vec<&str> = file.inputs.iter().map(String::as_str).collect();
            let points = read_columns(&args.points, &names)?;
            let mut out = String::from("mean,std\n");
            for p in gp.predict_many(&points) {
                out.push_str(&format!("{},{}\n", p.mean, p.std));
            }
            Output::write_complete(&args.output, out.as_bytes())
        }
    }
}

#[derive(Args, Debug)]
pub struct MooArgs {
    /// zdt1, zdt2, zdt3 or dtlz2.
    #[arg(long)]
    pub problem: Problem,
    /// Population size (4 to 100,000).
    #[arg(long, default_value_t = 100, value_parser = clap::value_parser!(u32).range(4..=100_000))]
    pub pop: u32,
    /// Generations (1 to 1,000,000).
    #[arg(long, default_value_t = 250, value_parser = clap::value_parser!(u32).range(1..=1_000_000))]
    pub gens: u32,
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Largest share of the population on the first front (1 = textbook NSGA-II, as the
    /// benchmark literature runs it; calibration uses 0.5).
    #[arg(long, default_value_t = 1.0)]
    pub pareto_fraction: f64,
    /// How parents are picked: `dominance` (Deb's reference code and pymoo: one that
    /// dominates the other wins, each member in two tournaments a generation) or `rank`
    /// (the lower front wins, as a calibration's search picks them).
    #[arg(long, value_enum, default_value = "dominance")]
    pub tournament: TournamentArg,
    /// The final non-dominated front: columns f1,f2[,f3].
    #[arg(short = 'o', long = "output", value_name = "front.csv")]
    pub output: PathBuf,
}

#[derive(Clone, Copy, Debug, clap::ValueEnum)]
pub enum TournamentArg {
    Dominance,
    Rank,
}

pub fn run_moo(args: MooArgs) -> Result<()> {
    let problem = args.problem;
    let settings = Nsga2Settings {
        population: args.pop as usize,
        generations: args.gens as usize,
        pareto_fraction: args.pareto_fraction,
        seed: args.seed,
        tournament: match args.tournament {
            TournamentArg::Dominance => Tournament::DominanceThenCrowding,
            TournamentArg::Rank => Tournament::RankThenCrowding,
        },
        ..Nsga2Settings::default()
    };
    let start = std::time::Instant::now();
    let result = nsga2(|x| problem.evaluate(x), &problem.bounds(), &settings)
        .map_err(|e| AcqError::Config(e.to_string()))?;
    let wall_s = start.elapsed().as_secs_f64();
    let m = problem.objectives();
    let mut out = (1..=m)
        .map(|k| format!("f{k}"))
        .collect::<Vec<_>>()
        .join(",")
        + "\n";
    for individual in &result.front {
        let row: Vec<String> = individual
            .objectives
            .iter()
            .map(|v| v.to_string())
            .collect();
        out.push_str(&row.join(","));
        out.push('\n');
    }
    Output::write_complete(&args.output, out.as_bytes())?;
    let front: Vec<Vec<f64>> = result.front.iter().map(|i| i.objectives.clone()).collect();
    let reference = problem.reference_point();
    let volume = hypervolume(&front, &reference).unwrap_or(f64::NAN);
    eprintln!(
        "{}: {} points on the front, hypervolume {volume:.6} (reference {reference:?}), {} evaluations, {wall_s:.3} s",
        problem.name(),
        front.len(),
        result.evaluations
    );
    Ok(())
}
