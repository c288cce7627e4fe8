//! A calibration study, from its spec to its report: the engine of
//! `acq-algorithms` run on any model that implements [`study::Model`].
//!
//! Every study goes one way: a preset (in `acq-workflows`) or a spec
//! ([`spec`]) builds a [`study::Study`] and a model (a built-in twin, or a
//! user's solver, [`command_model`], run where an `acq_exec` executor
//! says) and hands them to the one runner, [`study_runner`], with a
//! [`method`] (Bayesian optimisation through [`search`], [`surrogate_moo`],
//! or least squares). The runner logs every model run in `evaluations.csv`
//! ([`run_directory`]; resumable; a model's curve slopes beside it,
//! [`part_slopes`]), checks the validation cases, runs the
//! [`identifiability`] analysis, samples the [`posterior`] when asked, and
//! writes `summary.json` ([`summary`]) and the report ([`report`], with the
//! measured values' budgets from [`measurement_report`]); a
//! preset adds its own through [`extras`]. Progress goes to stderr
//! ([`progress`]). [`saved_emulator`] keeps a user's solver as GPs for a
//! study at the rig. [`mesh_study`] runs a spec's model at several element
//! sizes and gives each output's grid convergence, the `u_num` of V&V 20.
//!
//! Every table, the terminal and `summary.json` read one [`verdict`] per
//! parameter.
//!
//! Knows nothing of twins, CAN or the command line: a model is a trait, and
//! what it computes is named outputs.

pub mod command_model;
pub mod error;
pub mod extras;
pub mod identifiability;
pub mod measurement_report;
pub mod mesh_study;
pub mod method;
pub mod outcome;
pub mod part_slopes;
pub mod posterior;
pub mod progress;
pub mod report;
pub mod run_directory;
pub mod saved_emulator;
pub mod search;
mod shared_runs;
pub mod simulator;
pub mod spec;
pub mod study;
pub mod study_runner;
pub mod summary;
pub mod surrogate_moo;
pub mod verdict;
