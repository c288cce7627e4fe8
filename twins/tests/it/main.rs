//! The twins' integration tests, one module per twin or check, in one binary
//! (one link of the crate instead of one per file).

mod excavator;
mod gtn_material;
mod inclinations;
mod pose_fit;
mod tensile_bar;
mod tensile_sensitivity;
