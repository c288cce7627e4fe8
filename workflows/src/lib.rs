//! The studies a test engineer runs on measured values and models, each
//! writing its files and its report.
//!
//! - [`calibrate`]: `acq calibrate excavator|gtn|external`, the engine of
//!   `acq-algorithms` on a twin or on a user's solver run as a command.
//! - [`sensitivity`]: one-at-a-time sweeps of a model's outputs (model-agnostic).
//! - [`tensile_model`]: the GTN twin set up from a test and scored on it.
//! - [`tensile_report`]: the reports of `acq tensile-props` and `acq twin gtn`.
//! - [`excavator_report`]: the report of `acq twin excavator`.
//! - [`twin_excavator`], [`twin_gtn`]: `acq twin excavator|gtn` and
//!   `acq sensitivity excavator`, a twin run at given inputs.
//! - [`virtual_rig`]: a rig's hold levels from the excavator twin at a
//!   stated geometry (a known truth for `acq simulate`).
//!
//! Sits at the end of the data flow: it reads measured values (`acq-analysis`),
//! runs twins (`acq-twins`) and the engine (`acq-algorithms`) and writes reports
//! (`acq-report`). It knows nothing of CAN or live buses, nor of the command
//! line: each command takes an options struct with its defaults.

pub mod abaqus_material;
pub mod calibrate;
pub mod excavator_report;
pub mod mesh_convergence;
pub mod rig_study;
pub mod sensitivity;
pub mod tensile_model;
pub mod tensile_report;
pub mod twin_excavator;
pub mod twin_gtn;
pub mod virtual_rig;
