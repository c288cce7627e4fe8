//! The model a spec calibrates, as checked: a user's solver run as a
//! command, a built-in twin, or a model its caller brings.
//!
//! The study knows no twin: which built-in models a spec may name, which
//! of the spec's keys each reads, and its units come from the crate that
//! runs them, through [`BuiltinModels`] (acq-workflows'
//! `calibrate::models`), handed to [`super::Spec::load`].

use super::schema::{CurveSpec, ModelName, SpecFile};

/// The model a spec calibrates.
#[derive(Debug)]
pub enum ModelKind {
    /// A user's solver, run as a command once per run.
    Command(CommandSpec),
    /// A built-in twin, as its registry checked it.
    Builtin(BuiltinModel),
    /// A model the caller brings (a Python function, through the Python
    /// package): the spec's command, if it has one, is not run.
    Given,
}

/// A built-in model named by a spec: what the study needs of it, and the
/// keys it is set up from, for its registry to build it.
#[derive(Clone, Debug)]
pub struct BuiltinModel {
    /// `model = "NAME"`.
    pub name: ModelName,
    /// The spec's keys the model is set up from, as written (files next
    /// to the spec).
    pub keys: BuiltinKeys,
    /// The unit of the element size a mesh study gives it.
    pub element_size_unit: &'static str,
    /// The units (x, y) of the curve it gives, observed by the curve's
    /// name in a case's measured table; `None` when it gives none.
    pub curve_units: Option<[&'static str; 2]>,
}

/// The keys of a spec that built-in models read ([`SpecFile`]'s
/// `geometry`, `refit_poses` and `test`).
#[derive(Clone, Debug, Default)]
pub struct BuiltinKeys {
    pub geometry: Option<String>,
    pub refit_poses: bool,
    pub test: Option<String>,
}

impl BuiltinKeys {
    pub fn of(file: &SpecFile) -> BuiltinKeys {
        BuiltinKeys {
            geometry: file.geometry.clone(),
            refit_poses: file.refit_poses,
            test: file.test.clone(),
        }
    }
}

/// Whose model reads a spec's keys.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum KeyReader {
    /// A user's solver (`command`).
    Command,
    /// A model the caller brings.
    Given,
    /// A built-in model.
    Builtin(ModelName),
}

/// The built-in models a spec may name, from the crate that runs them.
pub trait BuiltinModels {
    /// A key that belongs to a built-in model, in a spec whose model
    /// (`reader`) does not read it: what to do about it.
    fn misplaced_key(&self, file: &SpecFile, reader: KeyReader) -> Option<String>;

    /// The built-in model `name`, its own keys checked against the spec.
    fn resolve(&self, name: ModelName, file: &SpecFile) -> Result<BuiltinModel, String>;
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
