//! Multi-objective optimisation: NSGA-II over box bounds, and the tools to judge a front.
//!
//! - [`nsga2`]: the algorithm (Deb et al. 2002) with pymoo's default operators, a
//!   MATLAB-style Pareto fraction, and parallel evaluation of each generation.
//! - [`fast_non_dominated_sort`], [`crowding_distance`]: its two building blocks, public
//!   for tests and for ranking any set of objective vectors.
//! - [`hypervolume`]: the exact dominated volume of a front (2 or 3 objectives).
//! - [`Problem`]: the ZDT1-3 and DTLZ2 benchmarks with their true fronts, to check all this.
//!
//! Everything minimises. An objective vector with a NaN or an infinity is treated as
//! dominated by every finite one (a failed model run loses every comparison).

mod hypervolume;
mod nsga2;
mod operators;
pub(crate) mod parallel;
mod problems;
mod sorting;

pub use hypervolume::hypervolume;
pub use nsga2::{
    environmental_selection, nsga2, Individual, Nsga2Result, Nsga2Settings, Tournament,
};
pub use problems::Problem;
pub use sorting::{crowding_distance, fast_non_dominated_sort};

/// What stops a multi-objective run or a hypervolume, and what to do about it.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MooError {
    /// No decision variable.
    #[error("no decision variable: pass at least one (lower, upper) bound")]
    NoVariables,
    /// A bound that is not a finite interval.
    #[error(
        "bound {index} is ({lower}, {upper}): bounds must be finite with lower <= upper; \
         fix the parameter's range"
    )]
    InvalidBound {
        /// 0-based variable index.
        index: usize,
        /// Lower bound given.
        lower: f64,
        /// Upper bound given.
        upper: f64,
    },
    /// A setting outside its range.
    #[error("NSGA-II setting {name} = {value}: expected {expected}")]
    InvalidSetting {
        /// Field name in [`Nsga2Settings`].
        name: &'static str,
        /// The value given.
        value: f64,
        /// The allowed range, in words.
        expected: &'static str,
    },
    /// The objective function returned an empty vector.
    #[error("the objective function returned no value; it must return at least one objective")]
    NoObjectives,
    /// The objective function returned vectors of different lengths.
    #[error(
        "the objective function returned {found} objectives after returning {expected}; \
         it must always return the same number"
    )]
    ObjectiveCountChanged {
        /// Count returned first.
        expected: usize,
        /// Count returned later.
        found: usize,
    },
    /// A hypervolume reference point that cannot bound anything.
    #[error("hypervolume reference point {reference:?}: expected 1 to 3 finite coordinates")]
    InvalidReference {
        /// The reference given.
        reference: Vec<f64>,
    },
    /// A front point whose length differs from the reference point's.
    #[error("hypervolume: point {index} has {found} objectives, the reference point has {expected}; pass points and reference of the same length")]
    DimensionMismatch {
        /// 0-based point index.
        index: usize,
        /// Objectives in the reference.
        expected: usize,
        /// Objectives in the point.
        found: usize,
    },
    /// A front point at minus infinity, which would dominate an infinite volume.
    #[error("hypervolume: point {index} has an objective at minus infinity, which dominates an infinite volume; drop it or fix the model")]
    UnboundedPoint {
        /// 0-based point index.
        index: usize,
    },
    /// More objectives than the exact algorithms here handle.
    #[error("hypervolume of {objectives} objectives is not implemented (exact for 1 to 3); reduce the objectives or estimate it by Monte Carlo")]
    TooManyObjectives {
        /// Objectives asked for.
        objectives: usize,
    },
    /// A benchmark problem name not known.
    #[error("unknown benchmark problem '{name}'; expected one of zdt1, zdt2, zdt3, dtlz2")]
    UnknownProblem {
        /// The name given.
        name: String,
    },
}
