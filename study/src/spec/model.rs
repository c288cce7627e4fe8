//! The model a spec calibrates, as checked: a user's solver run as a
//! command, a built-in twin, or a model its caller brings.

use super::schema::CurveSpec;

/// The model a spec calibrates.
#[derive(Debug)]
pub enum ModelKind {
    /// A user's solver, run as a command once per run.
    Command(CommandSpec),
    /// The built-in excavator twin, with its geometry file (next to the
    /// spec) and whether changed geometry re-fits the published poses.
    Excavator {
        geometry: Option<String>,
        refit_poses: bool,
    },
    /// The built-in GTN tensile twin, set up from a tensile test (a CSV
    /// next to the spec).
    Gtn { test: String },
    /// A model the caller brings (a Python function, through the Python
    /// package): the spec's command, if it has one, is not run.
    Given,
}

/// How a user's solver is run and read.
#[derive(Clone, Debug)]
pub struct CommandSpec {
    /// Program and arguments; placeholders `{params}`, `{out}`, `{dir}`, `{NAME}`.
    pub command: Vec<String>,
    /// The file of scalar outputs, in the run directory ("" for none).
    pub output_file: String,
    pub link_files: Vec<String>,
    pub copy_files: Vec<String>,
    pub timeout_s: f64,
    pub retries: u32,
    /// The curves the solver writes.
    pub curves: Vec<CurveSpec>,
}
