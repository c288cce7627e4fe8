//! How a study is searched: the method and its settings, the start design,
//! and how the run goes (progress label, parallel runs, resume).

use std::path::Path;

use acq_algorithms::bo::Acquisition;
use acq_algorithms::doe::{
    full_factorial, latin_hypercube, orthogonal_array_l12, read_design_csv, sobol_points,
    two_level_to_unit,
};
use acq_algorithms::evaluation::Parameter;
use acq_error::{AcqError, Result};

use super::posterior::settings::PosteriorSettings;
use super::search::to_unit;
use super::surrogate_moo::SurrogateMooSettings;

/// Bayesian optimisation's settings in a study.
#[derive(Clone, Debug)]
pub struct BoMethod {
    /// lhs, sobol, l12, factorial, or a CSV file of points.
    pub start: String,
    pub start_runs: usize,
    pub max_evals: usize,
    pub target_loss: Option<f64>,
    pub acquisition: Option<Acquisition>,
    pub patience: Option<usize>,
    /// Points proposed (and run) at once.
    pub batch: usize,
    pub seed: u64,
    /// Local trust-region steps on the residuals (each curve's errors in
    /// [`CURVE_PARTS`] parts) between the global ones.
    pub local_steps: bool,
    /// Synchronous batches of `batch` points: the result depends only on
    /// the inputs and the seed, not on which run finishes first (slots
    /// wait for the slowest run of each batch).
    pub deterministic: bool,
}

pub use super::study::CURVE_PARTS;

/// Least squares' settings in a study.
#[derive(Clone, Debug)]
pub struct LeastSquaresMethod {
    /// Model runs at most (each Jacobian costs one per parameter).
    pub max_evals: usize,
}

/// Two levels of one model searched together
/// ([`acq_algorithms::multi_fidelity`]): the model input `mesh` at a cheap
/// (coarse) and an expensive (fine) element size. The calibrated point is
/// the best expensive run.
#[derive(Clone, Debug)]
pub struct MultiFidelityMethod {
    /// The cheap level's start design: lhs, sobol, l12, factorial, or a CSV file.
    pub start: String,
    pub start_runs: usize,
    /// How many of the start design's points also run expensive (nested,
    /// so co-kriging sees both levels at the same points): the best at the
    /// cheap level with local steps, the first ones without.
    pub expensive_start_runs: usize,
    /// The `mesh` input of each level.
    pub cheap_mesh: f64,
    pub expensive_mesh: f64,
    /// Runs of both levels at most, the start designs included.
    pub max_evals: usize,
    /// Expensive runs at most.
    pub max_expensive: usize,
    pub target_loss: Option<f64>,
    pub seed: u64,
    /// Local trust-region steps at the expensive level on the residuals
    /// (each curve's errors in [`CURVE_PARTS`] parts) between the
    /// two-level ones.
    pub local_steps: bool,
}

/// The search method of a study.
#[derive(Clone, Debug)]
pub enum Method {
    Bo(BoMethod),
    MultiFidelity(MultiFidelityMethod),
    SurrogateMoo(SurrogateMooSettings),
    LeastSquares(LeastSquaresMethod),
}

/// How a study runs, besides its method.
pub struct RunSettings<'a> {
    /// The progress line's label.
    pub label: String,
    /// For messages and the report's title (the spec's path).
    pub title: String,
    /// Where a CSV start design's path starts.
    pub spec_directory: &'a Path,
    pub parallel: usize,
    pub resume: bool,
    /// The posterior stage after the search, when asked for.
    pub posterior: Option<PosteriorSettings>,
    /// Told of every evaluation, beside the progress line.
    pub progress: Option<crate::progress::ProgressObserver<'a>>,
}

/// `rows` with each repeated row dropped, in order.
fn distinct_rows(rows: Vec<Vec<f64>>) -> Vec<Vec<f64>> {
    let mut distinct: Vec<Vec<f64>> = Vec::with_capacity(rows.len());
    for row in rows {
        if !distinct.contains(&row) {
            distinct.push(row);
        }
    }
    distinct
}

/// The start design in the unit box; read before the run directory exists,
/// so a refused design leaves nothing behind. None for the methods that
/// start from their own design.
pub fn start_design(
    parameters: &[Parameter],
    method: &Method,
    spec_directory: &Path,
) -> Result<Vec<Vec<f64>>> {
    let (start, n, seed) = match method {
        Method::Bo(bo) => (bo.start.as_str(), bo.start_runs, bo.seed),
        Method::MultiFidelity(mf) => (mf.start.as_str(), mf.start_runs, mf.seed),
        Method::SurrogateMoo(_) | Method::LeastSquares(_) => return Ok(Vec::new()),
    };
    let d = parameters.len();
    let config = |e: String| AcqError::Config(format!("search.start: {e}"));
    Ok(match start {
        "lhs" => latin_hypercube(n, d, seed),
        "sobol" => sobol_points(n, d, Some(seed)).map_err(|e| config(e.to_string()))?,
        // Fewer than four factors repeat rows of L12 (only 2^d corners
        // exist): each corner is run once.
        "l12" => distinct_rows(two_level_to_unit(
            &orthogonal_array_l12(d).map_err(|e| config(e.to_string()))?,
        )),
        "factorial" => full_factorial(&vec![2; d]).map_err(|e| config(e.to_string()))?,
        file => {
            let path = spec_directory.join(file);
            let text = acq_io::input::read_text(&path).map_err(|e| AcqError::open(&path, e))?;
            acq_io::input::note_input(&path);
            let names: Vec<&str> = parameters.iter().map(|p| p.name.as_str()).collect();
            let points = read_design_csv(&text, &names)
                .map_err(|e| AcqError::Malformed(format!("{}: {e}", path.display())))?;
            points.iter().map(|p| to_unit(parameters, p)).collect()
        }
    })
}

#[cfg(test)]
mod tests {
    use super::distinct_rows;

    #[test]
    fn a_start_design_runs_each_repeated_row_once_in_order() {
        let rows = vec![
            vec![0.0, 1.0],
            vec![1.0, 0.0],
            vec![0.0, 1.0],
            vec![1.0, 1.0],
            vec![1.0, 0.0],
        ];
        assert_eq!(
            distinct_rows(rows),
            vec![vec![0.0, 1.0], vec![1.0, 0.0], vec![1.0, 1.0]]
        );
    }
}
