//! The algorithms' integration tests, one module per algorithm, in one binary
//! (one link of the crate instead of one per file).

mod bo;
mod doe;
mod evaluation;
mod gp;
mod moo;
mod multi_fidelity;
mod optim;
mod sobol_indices;
mod surrogate;
mod topsis;
mod trust_region;
