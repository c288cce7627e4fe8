//! The calibration's algorithms: everything between a loss and a chosen parameter set
//! (designs, surrogates, optimisers, samplers). A study (`acq-study`) puts them to work
//! on a model; here there is none.
//!
//! It knows nothing of CAN, recordings or any particular twin: a model is a function from
//! a parameter vector (inside box bounds) to outputs. One module per concept:
//!
//! - `evaluation`: the `Simulator` trait, parallel runs, the evaluation log and resume.
//! - `doe`: designs of experiments (Latin hypercube, Sobol, two-level orthogonal arrays,
//!   full factorial, a user CSV).
//! - `optim`: bounded L-BFGS, the local optimiser under the GP fit and the acquisition.
//! - `gp`: Gaussian-process regression (SE and Matern kernels, ARD, marginal-likelihood fit).
//! - `surrogate`: polynomial and RBF surrogates, and the comparison by held-out RMSE.
//! - `moo`: NSGA-II, hypervolume, the ZDT/DTLZ benchmark problems; `topsis` and `minimax`:
//!   the pick of one front point.
//! - `least_squares`: bounded Levenberg-Marquardt, for cheap smooth models.
//! - `bo`: Bayesian optimisation that minimises a loss (LCB, EI, log-EI; batches);
//!   `trust_region`: its local Gauss-Newton steps when runs return residuals.
//! - `multi_fidelity`: a cheap and an expensive level of one model (a coarse and a fine
//!   mesh): co-kriging over both, and the next run and its level by expected gain per second.
//! - `sobol_indices`: variance-based sensitivity on a cheap function (a surrogate).
//! - `mcmc`: draws from a posterior (adaptive random-walk Metropolis in free coordinates,
//!   chains in parallel) and their summaries.
//! - `chain_diagnostics`: whether Markov chains have mixed (rank-normalised split R-hat,
//!   bulk ESS), as ArviZ computes them.
//! - `next_point`: which test point to run next (expected information gain of a
//!   linear-Gaussian measurement, Bayesian D-optimality) and what it would narrow.
//! - `training_data`: the shape and finiteness check every fitted model runs first.

pub mod bo;
pub mod chain_diagnostics;
pub mod doe;
pub mod evaluation;
pub mod gp;
pub mod least_squares;
pub mod mcmc;
pub mod minimax;
pub mod moo;
pub mod multi_fidelity;
pub mod next_point;
pub mod optim;
pub mod sobol_indices;
pub mod surrogate;
pub mod topsis;
pub mod training_data;
pub mod trust_region;
