//! The spec file as written: every table and key, its type and its
//! default. Nothing here is checked beyond its type: that is
//! [`super::checks`]'s business, one function per section.

use std::collections::BTreeMap;

use acq_algorithms::evaluation::Scale;
use serde::Deserialize;

use crate::posterior::{Discrepancy, PosteriorSettings};
use crate::study::{LossKind, Residuals, Role};

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SpecFile {
    /// A user's solver run as a command (the default) or a built-in twin.
    #[serde(default)]
    pub model: ModelName,
    /// The built-in excavator's geometry file, next to the spec [default:
    /// the shipped DX55-class file].
    pub geometry: Option<String>,
    /// Re-fit the excavator's pose numbers to the published poses when a
    /// geometry number changes.
    #[serde(default = "default_refit_poses")]
    pub refit_poses: bool,
    /// The tensile test the built-in GTN twin is set up from (a CSV next
    /// to the spec, as `acq twin gtn --test` reads): its flow curve,
    /// Young's modulus, specimen and last displacement.
    pub test: Option<String>,
    /// Program and arguments; placeholders `{params}`, `{out}`, `{dir}`, `{NAME}`.
    #[serde(default)]
    pub command: Vec<String>,
    /// File the command writes, relative to the run directory (.json or
    /// .csv); needed when there are scalar outputs.
    #[serde(default)]
    pub output_file: String,
    /// Files next to the spec each run needs, linked into its directory.
    #[serde(default)]
    pub link_files: Vec<String>,
    /// Files next to the spec each run needs a copy of.
    #[serde(default)]
    pub copy_files: Vec<String>,
    #[serde(default = "default_timeout_s")]
    pub timeout_s: f64,
    #[serde(default)]
    pub retries: u32,
    /// Runs at a time on the local executor (`[executor] parallel` is the
    /// same, for any executor).
    pub parallel: Option<usize>,
    /// Where the runs happen: child processes or Slurm jobs.
    #[serde(default)]
    pub executor: ExecutorSpec,
    #[serde(rename = "parameter")]
    pub parameters: Vec<SpecParameter>,
    #[serde(rename = "output", default)]
    pub outputs: Vec<MeasuredOutput>,
    #[serde(rename = "curve", default)]
    pub curves: Vec<CurveSpec>,
    #[serde(rename = "case", default)]
    pub cases: Vec<CaseSpec>,
    #[serde(default)]
    pub search: Search,
    /// `[posterior]`: sample the posterior after the search.
    pub posterior: Option<PosteriorSpec>,
    /// `[holds]`: a study at the rig, whose cases are the holds of a
    /// recording (`acq_workflows::rig_study`).
    pub holds: Option<HoldsSpec>,
    /// `[candidates]`: the conditions an operator can set, by input name:
    /// a list of values or `{ from, to, steps }`; every combination is a
    /// candidate for the next test point.
    #[serde(default)]
    pub candidates: BTreeMap<String, CandidateValues>,
    /// `[emulator]`: save an emulator of a user's model after its study,
    /// or (at the rig) run one in its place.
    pub emulator: Option<EmulatorSpec>,
    /// `[mesh_study]`: the element sizes the command's `{mesh}` takes.
    pub mesh_study: Option<MeshStudySpec>,
}

/// `[mesh_study]`: the same runs at several element sizes (`acq
/// mesh-study`), and the size a calibration of the spec runs at.
#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MeshStudySpec {
    /// Representative element sizes, any unit, one run (per case) each;
    /// at least three.
    #[serde(default)]
    pub sizes: Vec<f64>,
    /// The parameters the mesh study runs at, by name [default: each
    /// parameter's nominal value].
    #[serde(default)]
    pub at: BTreeMap<String, f64>,
    /// The size `acq calibrate external` runs at [default: the smallest].
    pub calibrate_at: Option<f64>,
    /// The sizes' unit (`"mm"`), for the plots' axes [default: none
    /// named; the built-in GTN twin's sizes are mm, the excavator's m].
    pub unit: Option<String>,
}

/// `[emulator]`: an emulator of a user's model over its parameters and its
/// cases' inputs ([`crate::saved_emulator`]).
#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EmulatorSpec {
    /// `acq calibrate external`: after the search, fit one to its runs and
    /// write it into the run directory under this name.
    pub save: Option<String>,
    /// A study at the rig: run this saved emulator (a path from the
    /// spec's directory) in place of the model.
    pub load: Option<String>,
}

/// `[holds]`: how a hold's measured values become a case. Each entry is
/// read by `acq_workflows::rig_study::mapping`: a number (a fixed input), a
/// quantity's name, or `{ quantity, uncertainty, instrument }`.
#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HoldsSpec {
    /// The model's inputs, by input name.
    #[serde(default)]
    pub inputs: BTreeMap<String, toml::Value>,
    /// The observations, by the model's output name.
    #[serde(default)]
    pub observe: BTreeMap<String, toml::Value>,
}

/// One input's candidate values.
#[derive(Clone, Debug)]
pub enum CandidateValues {
    List(Vec<f64>),
    Range(CandidateRange),
}

/// `{ from, to, steps }`: `steps` values evenly from `from` to `to`.
#[derive(Clone, Debug)]
pub struct CandidateRange {
    pub from: f64,
    pub to: f64,
    pub steps: usize,
}

/// Read by hand rather than as an untagged enum, whose one message for
/// every mistake ("did not match any variant") names neither the form nor
/// the value at fault.
impl<'de> Deserialize<'de> for CandidateValues {
    fn deserialize<D: serde::Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        let value = toml::Value::deserialize(deserializer)?;
        candidate_values(&value).map_err(serde::de::Error::custom)
    }
}

const CANDIDATE_FORMS: &str =
    "give a list of numbers ([5.0, 20.0]) or { from = 5.0, to = 40.0, steps = 8 }";

fn candidate_number(value: &toml::Value, what: &str) -> Result<f64, String> {
    match value {
        toml::Value::Float(x) => Ok(*x),
        toml::Value::Integer(i) => Ok(*i as f64),
        other => Err(format!(
            "{what} = {other} is not a number; {CANDIDATE_FORMS}"
        )),
    }
}

fn candidate_values(value: &toml::Value) -> Result<CandidateValues, String> {
    match value {
        toml::Value::Array(items) => items
            .iter()
            .enumerate()
            .map(|(k, item)| candidate_number(item, &format!("value {}", k + 1)))
            .collect::<Result<_, _>>()
            .map(CandidateValues::List),
        toml::Value::Table(table) => {
            if let Some(unknown) = table
                .keys()
                .find(|k| !["from", "to", "steps"].contains(&k.as_str()))
            {
                return Err(format!("unknown key {unknown:?}; {CANDIDATE_FORMS}"));
            }
            let number = |key: &str| {
                table
                    .get(key)
                    .ok_or_else(|| format!("{key} is missing; {CANDIDATE_FORMS}"))
                    .and_then(|v| candidate_number(v, key))
            };
            let steps = match table.get("steps") {
                Some(toml::Value::Integer(n)) if *n >= 1 => *n as usize,
                Some(other) => {
                    return Err(format!(
                        "steps = {other}: give a whole number of values from 1, both ends included, as in {{ from = 5.0, to = 40.0, steps = 8 }}"
                    ))
                }
                None => return Err(format!("steps is missing; {CANDIDATE_FORMS}")),
            };
            Ok(CandidateValues::Range(CandidateRange {
                from: number("from")?,
                to: number("to")?,
                steps,
            }))
        }
        other => Err(format!(
            "{other} is neither a list nor a range; {CANDIDATE_FORMS}"
        )),
    }
}

/// `[posterior]`: the posterior stage after the search.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PosteriorSpec {
    /// Kept draws per chain.
    #[serde(default = "default_draws")]
    pub draws: usize,
    #[serde(default = "default_chains")]
    pub chains: usize,
    #[serde(default)]
    pub discrepancy: Discrepancy,
    /// Model runs at posterior draws, per case.
    #[serde(default = "default_predictive_runs")]
    pub predictive_runs: usize,
    /// Model runs an emulated posterior may add where its emulator is
    /// unsure: a budget, for a model whose runs cost minutes.
    #[serde(default = "default_refinement_runs")]
    pub refinement_runs: usize,
    #[serde(default = "default_posterior_seed")]
    pub seed: u64,
    /// A validate observation's numerical uncertainty (u_num of ASME V&V
    /// 20, from the user's own mesh study), in its unit, by its name.
    #[serde(default)]
    pub numerical_uncertainty: BTreeMap<String, f64>,
    /// The run directory of `acq mesh-study` on this spec (from the spec's
    /// directory): each validate value's u_num from its grid convergence.
    pub mesh_study: Option<String>,
}

fn default_draws() -> usize {
    PosteriorSettings::default().draws
}
fn default_chains() -> usize {
    PosteriorSettings::default().chains
}
fn default_predictive_runs() -> usize {
    PosteriorSettings::default().predictive_runs
}
fn default_refinement_runs() -> usize {
    PosteriorSettings::default().refinement_runs
}
fn default_posterior_seed() -> u64 {
    PosteriorSettings::default().seed
}

impl PosteriorSpec {
    pub fn settings(&self) -> PosteriorSettings {
        PosteriorSettings {
            draws: self.draws,
            chains: self.chains,
            discrepancy: self.discrepancy,
            predictive_runs: self.predictive_runs,
            refinement_runs: self.refinement_runs,
            seed: self.seed,
            numerical_uncertainty: self
                .numerical_uncertainty
                .iter()
                .map(|(name, u)| (name.clone(), *u))
                .collect(),
            numerical_uncertainty_sources: self
                .numerical_uncertainty
                .keys()
                .map(|name| (name.clone(), "stated in the spec".to_string()))
                .collect(),
        }
    }
}

/// `model`: which model the study calibrates.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ModelName {
    /// A user's solver, run as `command`.
    #[default]
    Command,
    /// The built-in excavator twin.
    Excavator,
    /// The built-in GTN tensile twin, set up from `test`.
    Gtn,
}

impl ModelName {
    /// The name as a spec writes it.
    pub fn name(self) -> &'static str {
        match self {
            ModelName::Command => "command",
            ModelName::Excavator => "excavator",
            ModelName::Gtn => "gtn",
        }
    }
}

fn default_refit_poses() -> bool {
    true
}

fn default_timeout_s() -> f64 {
    3600.0
}

/// `[executor]`: where the solver runs.
#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ExecutorSpec {
    #[serde(default)]
    pub kind: ExecutorKind,
    /// Runs (jobs) in flight at once [default: 1].
    pub parallel: Option<usize>,
    pub partition: Option<String>,
    pub account: Option<String>,
    /// Slurm's time limit per job, in Slurm's format.
    pub time_limit: Option<String>,
    pub cpus_per_job: Option<u32>,
    /// Slurm's `--mem` per job (`4G`).
    pub memory_per_job: Option<String>,
    #[serde(default)]
    pub sbatch_args: Vec<String>,
    /// Lines the job script runs before the solver.
    #[serde(default)]
    pub prelude: Vec<String>,
}

/// `[executor] kind`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ExecutorKind {
    /// Child processes of acq.
    #[default]
    Local,
    /// Slurm batch jobs.
    Slurm,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SpecParameter {
    pub name: String,
    pub lower: f64,
    pub upper: f64,
    #[serde(default)]
    pub scale: Scale,
    /// Where the initial errors are reported [default: the prior's value,
    /// else the middle].
    pub nominal: Option<f64>,
    /// The case this parameter belongs to [default: shared by all].
    pub case: Option<String>,
    /// Where class-typical values lie: `{ value, uncertainty }`, a penalty
    /// in standard deviations for straying from it.
    pub prior: Option<PriorSpec>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PriorSpec {
    pub value: f64,
    pub uncertainty: f64,
}

/// `[[output]]`: a measured scalar of a study without cases.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MeasuredOutput {
    pub name: String,
    pub measured: f64,
    pub uncertainty: Option<f64>,
    pub weight: Option<f64>,
}

/// `[[curve]]`: a curve the solver writes, compared with a measured one by
/// the curve MAPE.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CurveSpec {
    pub name: String,
    /// The CSV the solver writes in its run directory.
    pub file: String,
    /// Its x and y column names.
    pub x: String,
    pub y: String,
    /// Without cases: the measured curve, a CSV next to the spec, and its
    /// column names.
    pub measured_file: Option<String>,
    pub measured_x: Option<String>,
    pub measured_y: Option<String>,
    pub weight: Option<f64>,
    /// How the curve is scored: `"mape"` (the default), `"pcm"`,
    /// `"frechet"`, `"dtw"` or `"area"` (`acq_analysis::loss::metrics`);
    /// a case's curve observation may say otherwise.
    pub metric: Option<String>,
    /// The units of x and y (`"mm"`, `"kN"`), for the axes of the report's
    /// plots; without them an axis is named by its column alone.
    pub x_unit: Option<String>,
    pub y_unit: Option<String>,
}

impl CurveSpec {
    /// The axes' titles: each column with its unit when given
    /// (`DISPLACEMENT [mm]`).
    pub fn axes(&self, x: &str, y: &str) -> [String; 2] {
        let title = |column: &str, unit: &Option<String>| match unit {
            Some(unit) => format!("{column} [{unit}]"),
            None => column.to_string(),
        };
        [title(x, &self.x_unit), title(y, &self.y_unit)]
    }
}

/// `[[case]]`: a load case with its fixed inputs and measured values.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CaseSpec {
    pub name: String,
    #[serde(default = "default_role")]
    pub role: Role,
    #[serde(default)]
    pub inputs: BTreeMap<String, f64>,
    /// Each observation: a number, or a table (read by
    /// [`super::observations::case_observation`]).
    #[serde(default)]
    pub measured: toml::Table,
}

fn default_role() -> Role {
    Role::Fit
}

/// `[search]`: the method and its settings; unset ones take the
/// method's published defaults.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Search {
    #[serde(default)]
    pub method: MethodName,
    #[serde(default = "default_residuals")]
    pub residuals: Residuals,
    /// lhs, sobol, l12, factorial, or a CSV file of points next to the spec.
    #[serde(default = "default_start")]
    pub start: String,
    #[serde(default = "default_start_runs")]
    pub start_runs: usize,
    #[serde(default = "default_max_evals")]
    pub max_evals: usize,
    pub target_loss_pct: Option<f64>,
    #[serde(default = "default_loss")]
    pub loss: LossKind,
    pub acquisition: Option<String>,
    pub patience: Option<usize>,
    pub training_runs: Option<usize>,
    pub test_runs: Option<usize>,
    pub population: Option<usize>,
    pub generations: Option<usize>,
    pub pareto_fraction: Option<f64>,
    pub kernel: Option<String>,
    pub refine_tolerance: Option<f64>,
    pub refine_rounds: Option<usize>,
    /// Bayesian optimisation: local Gauss-Newton steps on the residuals
    /// (each curve's errors along its length) between the global ones.
    /// Default: on (measured on the CalculiX example, curve and scalars,
    /// and on the GTN preset: BENCHMARKS.md, "Local steps").
    pub local_steps: Option<bool>,
    /// Bayesian optimisation with `parallel` above 1: synchronous batches,
    /// so the result depends only on the spec and the seed [default:
    /// false, runs go as they finish and no slot idles].
    #[serde(default)]
    pub deterministic: bool,
    /// How the surrogate-MOO search picks its front point: "topsis"
    /// (default, the published method), "topsis-common" or "minimax".
    pub pick: Option<String>,
    /// multi-fidelity: the cheap level's element size (`{mesh}`); the
    /// expensive level is `[mesh_study] calibrate_at`.
    pub cheap_mesh: Option<f64>,
    /// multi-fidelity: expensive runs at most [default: max_evals].
    pub max_expensive: Option<usize>,
    /// multi-fidelity: how many of the start design's points also run
    /// expensive: those with the lowest cheap losses when the local steps
    /// are on (they start from the best of them), the first ones when
    /// they are off [default: half the start design, at least 2].
    pub expensive_start_runs: Option<usize>,
}

/// `[search] method`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum MethodName {
    /// Bayesian optimisation (the tensile study's).
    #[default]
    Bo,
    /// GP surrogates, NSGA-II and a pick (the excavator study's).
    SurrogateMoo,
    /// Levenberg-Marquardt from the nominal point.
    LeastSquares,
    /// Bayesian optimisation over a cheap and an expensive element size
    /// (co-kriging; each run's level chosen by expected gain per second).
    MultiFidelity,
}

impl Search {
    /// multi-fidelity: the expensive start runs, set or by default.
    pub fn expensive_start_runs(&self) -> usize {
        self.expensive_start_runs
            .unwrap_or((self.start_runs / 2).max(2))
    }
}

impl Default for Search {
    fn default() -> Self {
        toml::from_str("").expect("every search field has a default")
    }
}

fn default_residuals() -> Residuals {
    Residuals::Relative
}
fn default_start() -> String {
    "lhs".into()
}
fn default_start_runs() -> usize {
    10
}
fn default_max_evals() -> usize {
    60
}
fn default_loss() -> LossKind {
    LossKind::Mean
}

/// Limits of a spec's numbers: beyond them a value is a typo, and some
/// (a timeout past `Instant`'s range) would panic.
pub const MAX_TIMEOUT_S: f64 = 1e7;
pub const MAX_RETRIES: u32 = 100;
pub const MAX_PARALLEL: usize = 256;
pub const MAX_EVALUATIONS: usize = 100_000;
/// `[posterior]`: at most this many draws per chain, chains, and
/// predictive runs per case.
pub use crate::posterior::settings::MAX_DRAWS;
pub const MAX_CHAINS: usize = 64;
pub const MAX_PREDICTIVE_RUNS: usize = 100_000;

/// The most refinement runs a spec's `[posterior]` may allow: each is a
/// model run, and past a few hundred the emulator's fits dominate.
pub const MAX_REFINEMENT_RUNS: usize = 1000;
/// The built-in start designs of `search.start`.
pub const START_DESIGNS: [&str; 4] = ["lhs", "sobol", "l12", "factorial"];
