//! The built-in models a spec may name (`model = "excavator"`, `"gtn"`):
//! which of the spec's keys each reads, its units, and how it is built.
//! The study checks a spec against [`BUILTIN_MODELS`] and knows no twin
//! itself; `calibrate external`, `mesh-study` and the study at the rig
//! build a spec's model here, once.
//!
//! A new built-in model: a `ModelName` in the spec's schema
//! (`acq_study::spec::schema`), its keys and units in [`BuiltinRegistry`],
//! and its construction in [`build`].

use std::path::Path;

use acq_error::{AcqError, Result};
use acq_study::spec::schema::{ModelName, SpecFile};
use acq_study::spec::{BuiltinKeys, BuiltinModel, BuiltinModels, KeyReader};
use acq_study::study::Study;
use acq_study::study_runner::check_at_nominal;

use super::builtin::{ExcavatorModel, GtnModel};
use acq_twins::excavator::geometry::GeometryTemplate;

/// acq's built-in models, as a spec's check and its run see them.
pub struct BuiltinRegistry;

/// The registry every spec of acq is loaded with.
pub const BUILTIN_MODELS: BuiltinRegistry = BuiltinRegistry;

impl BuiltinModels for BuiltinRegistry {
    fn misplaced_key(&self, file: &SpecFile, reader: KeyReader) -> Option<String> {
        if file.test.is_some() && reader != KeyReader::Builtin(ModelName::Gtn) {
            return Some(
                "test belongs to model = \"gtn\": the tensile test the GTN twin is set up from"
                    .into(),
            );
        }
        file.geometry.as_ref()?;
        let why = match reader {
            KeyReader::Given => "a model given to the study reads its own",
            KeyReader::Command => "a command reads its own files",
            KeyReader::Builtin(ModelName::Gtn) => "the GTN twin takes its specimen from test",
            KeyReader::Builtin(_) => return None,
        };
        Some(format!("geometry belongs to model = \"excavator\"; {why}"))
    }

    fn resolve(
        &self,
        name: ModelName,
        file: &SpecFile,
    ) -> std::result::Result<BuiltinModel, String> {
        let keys = BuiltinKeys::of(file);
        match name {
            ModelName::Excavator if !file.curves.is_empty() => Err(
                "the excavator twin gives no curves; observe its numbers by key path (pressure_bar.boom)".into(),
            ),
            // The frames' element length, in the geometry's metres.
            ModelName::Excavator => Ok(BuiltinModel {
                name,
                keys,
                element_size_unit: "m",
                curve_units: None,
            }),
            ModelName::Gtn if !file.curves.is_empty() => Err(
                "the GTN twin's curve is force_displacement: observe it in a case's measured table (force_displacement = { file = \"test.csv\", x = \"DISPLACEMENT\", y = \"FORCE\" }), not as a [[curve]]".into(),
            ),
            ModelName::Gtn if keys.test.is_none() => Err(
                "model = \"gtn\" needs test = \"FILE.csv\": the tensile test (next to the spec) whose flow curve, specimen and last displacement the twin takes".into(),
            ),
            // The specimen's millimetres; its force-displacement curve in
            // mm and kN.
            ModelName::Gtn => Ok(BuiltinModel {
                name,
                keys,
                element_size_unit: "mm",
                curve_units: Some(["mm", "kN"]),
            }),
            ModelName::Command => Err("a command is not a built-in model".into()),
        }
    }
}

/// A built-in model, built from the spec's keys and checked against the
/// study before any run (a twin is cheap: every case is tried at the
/// nominal point, so a wrong name is refused at once). Problems are in the
/// spec's words (`in_spec`).
pub enum Built {
    Excavator(Box<ExcavatorModel>),
    Gtn(Box<GtnModel>),
}

pub fn build(
    builtin: &BuiltinModel,
    spec_directory: &Path,
    study: &Study,
    in_spec: impl Fn(String) -> AcqError,
) -> Result<Built> {
    let keys = &builtin.keys;
    match builtin.name {
        ModelName::Excavator => {
            let template = geometry_template(spec_directory, keys.geometry.as_deref())?;
            let model = ExcavatorModel::new(template, keys.refit_poses)
                .map_err(|e| in_spec(format!("geometry: {e}")))?;
            check_at_nominal(study, &model).map_err(&in_spec)?;
            Ok(Built::Excavator(Box::new(model)))
        }
        ModelName::Gtn => {
            let test = keys.test.as_deref().unwrap_or_default();
            let model = GtnModel::of_test(&spec_directory.join(test))?;
            model.check_inputs(study).map_err(&in_spec)?;
            Ok(Built::Gtn(Box::new(model)))
        }
        ModelName::Command => Err(in_spec("a command is not a built-in model".into())),
    }
}

/// The excavator's geometry file named by a spec (relative to its
/// directory), else the shipped one.
pub(crate) fn geometry_template(
    spec_directory: &std::path::Path,
    geometry: Option<&str>,
) -> Result<GeometryTemplate> {
    match geometry {
        Some(file) => {
            let path = spec_directory.join(file);
            let text = acq_io::input::read_text(&path).map_err(|e| AcqError::open(&path, e))?;
            acq_io::input::note_input(&path);
            GeometryTemplate::parse(&text)
                .map_err(|e| AcqError::Config(format!("{}: {e}", path.display())))
        }
        None => Ok(GeometryTemplate::dx55()),
    }
}
