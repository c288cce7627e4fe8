//! What a study asks of its posterior stage: draws, chains, the model
//! error it allows for, predictive runs, the seed.

/// `[posterior] discrepancy`: the model error the posterior allows for.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Discrepancy {
    /// The model is right up to its parameters.
    #[default]
    None,
    /// An additive error per output, the same in every case.
    Constant,
    /// An additive error per output that varies smoothly over the cases'
    /// inputs (a Gaussian process).
    Gp,
}

/// Model runs the emulator's refinement may spend beyond the search,
/// unless a preset whose model is cheap enough allows more.
pub const DEFAULT_REFINEMENT_RUNS: usize = 20;

/// The most kept draws per chain a posterior is asked for (a spec's
/// `[posterior] draws`, a preset's `--posterior-draws`): a million per
/// chain is already hours of model runs.
pub const MAX_DRAWS: usize = 1_000_000;

/// How the posterior is sampled.
#[derive(Clone, Debug, PartialEq)]
pub struct PosteriorSettings {
    /// Kept draws per chain.
    pub draws: usize,
    pub chains: usize,
    pub discrepancy: Discrepancy,
    /// Model runs at posterior draws, per case.
    pub predictive_runs: usize,
    /// Model runs the emulator's refinement may spend beyond the search
    /// (an emulated posterior only).
    pub refinement_runs: usize,
    pub seed: u64,
    /// Validate observations' numerical uncertainty (u_num of ASME V&V
    /// 20), by observation name or `case/name` (a mesh study's key); 0 for
    /// the others.
    pub numerical_uncertainty: Vec<(String, f64)>,
    /// Where each of them came from, by the same key.
    pub numerical_uncertainty_sources: Vec<(String, String)>,
}

impl Default for PosteriorSettings {
    fn default() -> Self {
        PosteriorSettings {
            draws: 1000,
            chains: 4,
            discrepancy: Discrepancy::None,
            predictive_runs: 50,
            refinement_runs: DEFAULT_REFINEMENT_RUNS,
            seed: 1,
            numerical_uncertainty: Vec::new(),
            numerical_uncertainty_sources: Vec::new(),
        }
    }
}
