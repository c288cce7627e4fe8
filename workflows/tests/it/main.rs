//! acq-workflows' integration tests, one module each, in one binary (one
//! link of the crate instead of one per file).

mod input_properties;
mod rig_study;
