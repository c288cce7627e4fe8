//! acq-can's integration tests, one module per format or protocol, in one
//! binary (one link of the crate instead of one per file).

mod asc;
mod common;
mod golden_cantools;
mod log_roundtrip;
mod mf4;
mod opendbc;
mod truncation;
