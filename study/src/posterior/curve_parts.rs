//! A measured curve's term of the posterior density: its parts' errors
//! as a stationary AR(1) sequence along the curve, the error factor and
//! the correlation of neighbouring parts integrated out
//! ([`super::likelihood`] sums it with the other observations').

use std::f64::consts::PI;

use acq_analysis::loss::metrics::CurveMetric;

use super::factor_integral::LogUniformFactor;
use super::scale_grid::ScaleGrid;

/// A measured curve as the likelihood reads it: the signed errors (%) of
/// its parts, each the model's minus the measured averaged over a run of
/// the curve's grid. Part `j` errs with a standard deviation of
/// `factor * scatter[j]`: `scatter[j]` is how precisely the measured
/// curve gives that part's mean if its noise were white
/// ([`test_scatter_by_part`](acq_analysis::loss::curve::test_scatter_by_part), so a part where the force is small and its
/// relative noise large counts less), and `factor`, one per curve and
/// log-uniform over [`CURVE_FACTOR_RANGE`](super::likelihood::CURVE_FACTOR_RANGE), takes up what white noise
/// does not explain: noise correlated along the curve, and the model's
/// own error. Averaging a part's errors first removes the correlation
/// within a part; parts are about 5 % of the curve, longer than the
/// noise's correlation on a rig (checked by coverage in
/// `tests/posterior.rs`).
#[derive(Clone, Debug)]
pub struct CurveParts {
    /// `case/name` or `name`.
    pub key: String,
    /// Its parts (indices into [`StudyPosterior::observations`](super::likelihood::StudyPosterior::observations)).
    pub parts: Vec<usize>,
    /// Each part's white-noise standard error, %.
    pub(super) scatter_pct: Vec<f64>,
    /// How the curve is scored (and so which residuals its parts are).
    pub metric: CurveMetric,
    /// The factor's prior as nodes: how a factor is drawn, and integrated
    /// out beside an emulator's variance.
    pub(super) grid: ScaleGrid,
    /// The same prior integrated in closed form, for an exact model.
    factor: LogUniformFactor,
    /// At each correlation node, every term of the density at a factor of
    /// 1 but the quadratic form ([`CurveParts::unit_factor_terms`]): they
    /// depend on the scatters alone, so they are summed once, not at every
    /// step of a chain.
    pub(super) unit_factor_constants: Vec<f64>,
}

/// The correlations of neighbouring parts' errors a curve's likelihood
/// integrates over (uniform prior on 0 to 0.98, midpoint rule).
pub(super) const CURVE_CORRELATIONS: usize = 25;

pub(super) fn correlation_node(k: usize) -> f64 {
    0.98 * (k as f64 + 0.5) / CURVE_CORRELATIONS as f64
}

impl CurveParts {
    /// A curve's parts with each part's scatter, its error factor not yet
    /// given a grid (one node).
    pub(super) fn new(
        key: String,
        parts: Vec<usize>,
        scatter_pct: Vec<f64>,
        metric: CurveMetric,
    ) -> Self {
        let mut curve = CurveParts {
            key,
            parts,
            scatter_pct,
            metric,
            grid: ScaleGrid::new([1.0, 2.0], 1, |_| 1.0),
            factor: LogUniformFactor::new([1.0, 2.0], 1),
            unit_factor_constants: Vec::new(),
        };
        let no_residuals = vec![0.0; curve.parts.iter().max().map_or(0, |&i| i + 1)];
        curve.unit_factor_constants = (0..CURVE_CORRELATIONS)
            .map(|k| {
                curve
                    .unit_factor_terms(&no_residuals, correlation_node(k))
                    .1
            })
            .collect();
        curve
    }

    /// Gives the error factor its log-uniform prior over `range`, as
    /// `nodes` for draws and beside an emulator's variance.
    pub(super) fn set_factor_prior(&mut self, range: [f64; 2], nodes: usize) {
        self.grid = ScaleGrid::new(range, nodes, |x| 1.0 / x);
        self.factor = LogUniformFactor::new(range, self.parts.len());
    }

    /// The log likelihood at each correlation node, the factor integrated out.
    pub(super) fn by_correlation(&self, residuals: &[f64], emulator: &[f64]) -> Vec<f64> {
        let exact_model = self
            .parts
            .iter()
            .all(|&i| emulator.get(i).is_none_or(|v| *v == 0.0));
        if exact_model {
            // Without an emulator's variance the factor only scales the
            // quadratic form, which three sums over the parts give at
            // every correlation; the factor's integral is then a closed form.
            let sums = self.lag_sums(residuals);
            return (0..CURVE_CORRELATIONS)
                .map(|k| {
                    self.factor
                        .log_integral(sums.quadratic(correlation_node(k)))
                        - self.unit_factor_constants[k]
                })
                .collect();
        }
        // With an emulator's variance, each factor node's standardised
        // residuals and log standard deviations, once for every
        // correlation node (they do not depend on it).
        let standardised: Vec<(Vec<f64>, f64)> = self
            .grid
            .nodes
            .iter()
            .map(|&factor| self.standardised(residuals, emulator, factor))
            .collect();
        (0..CURVE_CORRELATIONS)
            .map(|k| {
                let correlation = correlation_node(k);
                self.grid.log_integral_by_node(|node| {
                    let (z, log_sd) = &standardised[node];
                    ar1_log_density(z, *log_sd, correlation)
                })
            })
            .collect()
    }

    /// The sums over the parts' residuals at a factor of 1 (`z = r /
    /// scatter`) that give the AR(1) quadratic form at any correlation.
    fn lag_sums(&self, residuals: &[f64]) -> LagSums {
        let mut sums = LagSums::default();
        let mut previous: Option<f64> = None;
        for (&i, scatter) in self.parts.iter().zip(&self.scatter_pct) {
            let z = residuals[i] / scatter;
            match previous {
                None => sums.first_squared = z * z,
                Some(before) => {
                    sums.later_squared += z * z;
                    sums.lagged_product += z * before;
                    sums.earlier_squared += before * before;
                }
            }
            previous = Some(z);
        }
        sums
    }

    /// Each part's residual over its standard deviation at `factor` (the
    /// emulator's variance added), and the sum of the deviations' logs.
    pub(super) fn standardised(
        &self,
        residuals: &[f64],
        emulator: &[f64],
        factor: f64,
    ) -> (Vec<f64>, f64) {
        let mut log_sd = 0.0;
        let z = self
            .parts
            .iter()
            .zip(&self.scatter_pct)
            .map(|(&i, scatter)| {
                let sd =
                    ((factor * scatter).powi(2) + emulator.get(i).copied().unwrap_or(0.0)).sqrt();
                log_sd += sd.ln();
                residuals[i] / sd
            })
            .collect();
        (z, log_sd)
    }

    /// At a factor of 1: the AR(1) quadratic form of the standardised
    /// residuals, and every other term of [`curve_log_density`] but the
    /// factor's (the scatters' logs, the correlation's and 2 pi's).
    pub(super) fn unit_factor_terms(&self, residuals: &[f64], correlation: f64) -> (f64, f64) {
        let innovation = 1.0 - correlation * correlation;
        let mut constant = 0.0;
        for (part, scatter) in self.scatter_pct.iter().take(self.parts.len()).enumerate() {
            if part > 0 {
                constant += 0.5 * innovation.ln();
            }
            constant += 0.5 * (2.0 * PI).ln() + scatter.ln();
        }
        (self.lag_sums(residuals).quadratic(correlation), constant)
    }
}

/// `z_1^2`, and over the later parts `z_j^2`, `z_j z_(j-1)` and
/// `z_(j-1)^2`: the AR(1) quadratic form at correlation `c` is
/// `z_1^2 + sum (z_j - c z_(j-1))^2 / (1 - c^2)`.
#[derive(Clone, Copy, Debug, Default)]
struct LagSums {
    first_squared: f64,
    later_squared: f64,
    lagged_product: f64,
    earlier_squared: f64,
}

impl LagSums {
    fn quadratic(&self, correlation: f64) -> f64 {
        let innovation = 1.0 - correlation * correlation;
        self.first_squared
            + (self.later_squared - 2.0 * correlation * self.lagged_product
                + correlation * correlation * self.earlier_squared)
                / innovation
    }
}

/// The log density of a curve's parts' residuals (%) with error factor
/// `factor` and neighbouring parts correlated by `correlation`: each
/// part's residual over its standard deviation (`factor` times its scatter,
/// the emulator's variance added) is a stationary AR(1) sequence along the
/// curve, so a smooth miss over many parts counts as one miss, not many.
pub(super) fn curve_log_density(
    curve: &CurveParts,
    residuals: &[f64],
    emulator: &[f64],
    factor: f64,
    correlation: f64,
) -> f64 {
    let (z, log_sd) = curve.standardised(residuals, emulator, factor);
    ar1_log_density(&z, log_sd, correlation)
}

/// The log density of standardised residuals `z` as a stationary AR(1)
/// sequence of lag-one `correlation`, their standard deviations' logs
/// summing to `log_sd`. Its quadratic form term by term, as written: the
/// sums of [`LagSums`] are checked against it.
fn ar1_log_density(z: &[f64], log_sd: f64, correlation: f64) -> f64 {
    let innovation = 1.0 - correlation * correlation;
    let mut quadratic = 0.0;
    let mut previous: Option<f64> = None;
    for &z in z {
        quadratic += match previous {
            None => z * z,
            Some(before) => (z - correlation * before).powi(2) / innovation,
        };
        previous = Some(z);
    }
    let n = z.len() as f64;
    -0.5 * (quadratic + (n - 1.0).max(0.0) * innovation.ln() + n * (2.0 * PI).ln()) - log_sd
}
