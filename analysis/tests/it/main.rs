//! acq-analysis's integration tests, one module each, in one binary (one
//! link of the crate instead of one per file).

mod curve_metrics;
mod live_holds;
