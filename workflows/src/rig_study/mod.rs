//! A study at the rig (`acq record --study`, `acq view SESSION_DIR
//! --study`): a calibration spec whose cases are a recording's holds. After
//! each hold the posterior of the parameters is sampled again, each
//! parameter's interval is set against its prior's and judged, and of the
//! conditions the operator can set the one expected to narrow the
//! posterior most is named.
//!
//! The file is a spec ([`acq_study::spec`]: `model`, `geometry`,
//! `[[parameter]]` with priors, `[posterior]`) without `[[case]]`; its
//! model is the excavator twin, or a user's solver through the emulator an
//! earlier study of it saved (`[emulator] load`,
//! [`acq_study::saved_emulator`]); plus
//! - `[holds]` ([`mapping`]): which hold quantities are the model's inputs
//!   (with their spread as input uncertainty) and which its observations;
//! - `[candidates]` ([`candidates`]): the conditions to choose from.
//!
//! - [`update`]: the holds so far as a study, its posterior, the verdicts;
//! - [`next`]: the next test point (expected information gain on the model
//!   linearised at the posterior mean, [`acq_algorithms::next_point`]);
//! - [`tracker`]: hold by hold, what the page and the terminal show;
//! - [`offline`]: `acq calibrate rig`, the same over recorded sessions.
//!
//! Everything is a function of the holds and the file: the same holds give
//! the same posterior live and offline (the chains start from the
//! parameters' nominal values with the `[posterior]` seed).

use std::path::{Path, PathBuf};

use acq_analysis::extract::quantities::RigQuantities;

use crate::calibrate::builtin::ExcavatorModel;
use crate::calibrate::models::geometry_template;
use acq_study::posterior::PosteriorSettings;
use acq_study::saved_emulator::{EmulatedModel, EmulatorFileError, SavedEmulator};
use acq_study::spec::assemble::parameters;
use acq_study::spec::schema::{EmulatorSpec, HoldsSpec, ModelName, SpecFile};
use acq_study::spec::{checks, read_spec_file, spec_directory, SpecError, SpecProblem};
use acq_study::study::{Model, StudyParameter};

pub mod candidates;
pub mod mapping;
pub mod next;
pub mod offline;
pub mod shared;
pub mod tracker;
pub mod update;

use candidates::Candidates;
use mapping::HoldMapping;

/// A checked study at the rig.
pub struct RigStudy {
    pub path: PathBuf,
    pub mapping: HoldMapping,
    pub candidates: Candidates,
    /// Shared by every hold, with their priors.
    pub parameters: Vec<StudyParameter>,
    pub settings: PosteriorSettings,
    /// The twin's geometry file, before any parameter changes it (`None`
    /// for an emulated model).
    pub geometry: Option<acq_twins::excavator::geometry::GeometryTemplate>,
    /// Each observation's model error, standard (an emulator's error at
    /// runs it has not seen; 0 for the twin itself), in `[holds.observe]`'s
    /// order: added to the hold's uncertainty.
    pub model_error_sd: Vec<f64>,
    /// Each observation's standard uncertainty as the rig's sensor records
    /// state it (`None` where none does), in `[holds.observe]`'s order: what
    /// the first hold is expected to have.
    pub stated_noise: Vec<Option<f64>>,
    model: Box<dyn Model + Send>,
}

impl RigStudy {
    /// Reads and checks a study file against `rig` before anything is
    /// recorded: every quantity it names is one the rig's holds carry,
    /// every candidate lies in the rig's stated ranges and the model runs
    /// at the nominal parameters there. Errors name the file and line.
    pub fn load(path: &Path, rig: &RigQuantities) -> Result<RigStudy, SpecError> {
        Self::load_with(path, rig, true)
    }

    /// [`RigStudy::load`] without its candidates (none are read or run):
    /// what the virtual rig needs of a study, its mapping and model.
    pub fn load_without_candidates(
        path: &Path,
        rig: &RigQuantities,
    ) -> Result<RigStudy, SpecError> {
        Self::load_with(path, rig, false)
    }

    fn load_with(
        path: &Path,
        rig: &RigQuantities,
        with_candidates: bool,
    ) -> Result<RigStudy, SpecError> {
        let (text, file) = read_spec_file(path)?;
        let located = |problem: SpecProblem| problem.located(path, &text);
        let (holds, emulator) = what_the_rig_runs(&file).map_err(located)?;
        let parameters = rig_parameters(&file).map_err(located)?;
        let mapping = HoldMapping::parse(holds).map_err(located)?;
        mapping.check_quantities(rig).map_err(located)?;
        for (name, _) in &mapping.inputs {
            if let Some(index) = file.parameters.iter().position(|p| &p.name == name) {
                return Err(located(SpecProblem::table(
                    "[[parameter]]",
                    index,
                    format!("{name} is also an input in [holds.inputs]; a value is either measured or calibrated"),
                )));
            }
        }
        let directory = spec_directory(path);
        let (model, geometry, model_error_sd) =
            the_model(&directory, &file, emulator.as_deref(), &mapping, &located)?;
        let settings = file
            .posterior
            .as_ref()
            .map(|p| p.settings())
            .unwrap_or_default();
        let stated_noise = mapping
            .observations
            .iter()
            .map(|(_, from)| {
                rig.quantities
                    .iter()
                    .find(|q| q.name == from.quantity)
                    .and_then(|q| q.stated_uncertainty)
            })
            .collect();
        let mut study = RigStudy {
            path: path.to_path_buf(),
            stated_noise,
            mapping,
            candidates: Candidates::default(),
            parameters,
            settings,
            geometry,
            model_error_sd,
            model,
        };
        if with_candidates {
            study.attach_candidates(&file, rig).map_err(located)?;
        }
        Ok(study)
    }

    /// `[candidates]`, each checked for reach: the model runs at the
    /// nominal parameters there, so a wrong input or output name is refused
    /// now, not after the first hold.
    fn attach_candidates(
        &mut self,
        file: &SpecFile,
        rig: &RigQuantities,
    ) -> Result<(), SpecProblem> {
        let nominal_inputs: Vec<(String, f64)> = self
            .mapping
            .fixed_inputs()
            .map(|(name, x)| (name.to_string(), x))
            .collect();
        let parameter_names: Vec<String> = self
            .parameters
            .iter()
            .map(|p| p.search.name.clone())
            .collect();
        let range_of = |quantity: &str| rig.get(quantity).and_then(|q| q.range);
        let runs = |candidate: &[(String, f64)]| {
            let mut inputs = nominal_inputs.clone();
            inputs.extend_from_slice(candidate);
            self.outputs_at(&self.nominal(), &inputs).map(|_| ())
        };
        let candidates = candidates::candidates(
            &file.candidates,
            &self.mapping,
            &parameter_names,
            &range_of,
            &runs,
        )?;
        self.candidates = candidates;
        self.check_names()
    }

    /// Each parameter's nominal value.
    pub fn nominal(&self) -> Vec<f64> {
        self.parameters.iter().map(|p| p.nominal).collect()
    }

    /// The observed outputs (in `[holds.observe]`'s order) at parameter
    /// values `theta` and the inputs `inputs` (by name).
    pub fn outputs_at(&self, theta: &[f64], inputs: &[(String, f64)]) -> Result<Vec<f64>, String> {
        let (all, outputs) = self.run_of(theta, inputs);
        Ok(self.model.run(&all, &outputs, &[])?.scalars)
    }

    /// The model's own standard error of each observed output at `theta`
    /// and `inputs` (an emulator's; zeros for the twin itself).
    pub fn own_error_at(&self, theta: &[f64], inputs: &[(String, f64)]) -> Vec<f64> {
        let (all, outputs) = self.run_of(theta, inputs);
        self.model
            .own_error_sd(&all, &outputs)
            .unwrap_or_else(|| vec![0.0; outputs.len()])
    }

    /// A run's inputs (the parameters by the model's names, then `inputs`)
    /// and the outputs it observes.
    fn run_of(&self, theta: &[f64], inputs: &[(String, f64)]) -> (Vec<(String, f64)>, Vec<&str>) {
        let mut all: Vec<(String, f64)> = self
            .parameters
            .iter()
            .zip(theta)
            .map(|(p, &x)| (p.input.clone(), x))
            .collect();
        all.extend_from_slice(inputs);
        let outputs = self
            .mapping
            .observations
            .iter()
            .map(|(name, _)| name.as_str())
            .collect();
        (all, outputs)
    }

    /// The model itself, for the study of the holds.
    pub fn model(&self) -> &dyn Model {
        self.model.as_ref()
    }

    /// The model's inputs and outputs as `[holds]` names them exist: it
    /// runs at the nominal parameters with every measured input at a
    /// candidate's value (or, without candidates, the error says which
    /// name is wrong unless it is only the pose).
    fn check_names(&self) -> Result<(), SpecProblem> {
        let mut inputs: Vec<(String, f64)> = self
            .mapping
            .fixed_inputs()
            .map(|(name, x)| (name.to_string(), x))
            .collect();
        let at = match self.candidates.points.first() {
            Some(point) => {
                inputs.extend(self.candidates.names.iter().cloned().zip(point.clone()));
                "the first candidate"
            }
            // Without candidates the twin's pose in the middle of its
            // strokes, so that a name it does not have is refused now and
            // not by every hold ("not used").
            None => match self.probe_inputs() {
                Some(probe) => {
                    inputs.extend(probe);
                    "a pose in the middle of its strokes"
                }
                None => return Ok(()),
            },
        };
        self.outputs_at(&self.nominal(), &inputs)
            .map(|_| ())
            .map_err(|e| {
                SpecProblem::file(format!(
                    "[holds]: at the nominal parameters and {at} the model says: {e}"
                ))
            })
    }

    /// The measured inputs at the excavator twin's pose with every stroke
    /// in the middle of its range (10 kN, angle 0): a point every twin
    /// reaches. An input the twin has no value for here gets 1, so that the
    /// twin names it. `None` for a model without the twin's geometry.
    fn probe_inputs(&self) -> Option<Vec<(String, f64)>> {
        use acq_twins::excavator::inclinations::Inclinations;
        use acq_twins::excavator::{CylinderName, Excavator, Strokes};
        let geometry = self.geometry.as_ref()?.with(&[]).ok()?;
        let mut strokes = Strokes {
            bucket_mm: 0.0,
            arm_mm: 0.0,
            boom_mm: 0.0,
        };
        for name in CylinderName::ALL {
            let [low, high] = geometry.cylinder(name).stroke_range_mm;
            strokes.set(name, 0.5 * (low + high));
        }
        let pose = Excavator::new(geometry).ok()?.pose(&strokes).ok()?;
        let inclinations = Inclinations::of(&pose);
        let fixed: Vec<&str> = self.mapping.fixed_inputs().map(|(name, _)| name).collect();
        Some(
            self.mapping
                .inputs
                .iter()
                .filter(|(name, _)| !fixed.contains(&name.as_str()))
                .map(|(name, _)| {
                    let value = match name.as_str() {
                        "boom_inclination_deg" => inclinations.boom_deg,
                        "arm_inclination_deg" => inclinations.arm_deg,
                        "bucket_inclination_deg" => inclinations.bucket_deg,
                        "bucket_stroke_mm" => strokes.bucket_mm,
                        "arm_stroke_mm" => strokes.arm_mm,
                        "boom_stroke_mm" => strokes.boom_mm,
                        "force_kN" => 10.0,
                        "force_angle_deg" => 0.0,
                        _ => 1.0,
                    };
                    (name.clone(), value)
                })
                .collect(),
        )
    }
}

/// What a study at the rig runs: its `[holds]` (which must be there) and
/// the emulator to load, if any; refused where the file is a study of
/// cases, or names a model the rig cannot run.
fn what_the_rig_runs(file: &SpecFile) -> Result<(&HoldsSpec, Option<String>), SpecProblem> {
    let Some(holds) = &file.holds else {
        return Err(SpecProblem::file(
                "a study at the rig needs a [holds] table: which hold quantities are the model's inputs ([holds.inputs]) and which its observations ([holds.observe])",
            ));
    };
    if let Some(index) = (!file.cases.is_empty()).then_some(0) {
        return Err(SpecProblem::table(
                "[[case]]",
                index,
                "a study at the rig takes its cases from the holds; leave out [[case]] (run a study of them with acq calibrate external)",
            ));
    }
    if !file.outputs.is_empty() || !file.curves.is_empty() {
        return Err(SpecProblem::file(
                "a study at the rig observes what [holds.observe] names; leave out [[output]] and [[curve]]",
            ));
    }
    // The model: the built-in twin, or a user's solver through the
    // emulator an earlier study of it saved (no solver runs at the rig).
    let emulator = match &file.emulator {
            Some(EmulatorSpec { save: Some(_), .. }) => {
                return Err(SpecProblem::key(
                    "[emulator]",
                    "save",
                    "[emulator] save belongs to a study of cases (acq calibrate external); at the rig, load the emulator it saved: load = \"runs/.../emulator.json\"",
                ))
            }
            Some(EmulatorSpec { load: None, .. }) => {
                return Err(SpecProblem::file(
                    "[emulator]: give load = \"PATH\", an emulator saved by an earlier study of the model ([emulator] save)",
                ))
            }
            Some(EmulatorSpec { load: Some(load), .. }) => Some(load.clone()),
            None => None,
        };
    match (&file.model, &emulator) {
            (ModelName::Excavator, Some(_)) => {
                return Err(SpecProblem::key(
                    "[emulator]",
                    "load",
                    "the excavator twin runs at the rig itself; leave out [emulator]",
                ))
            }
            (ModelName::Excavator, None) => {
                checks::model(file, false, &crate::calibrate::models::BUILTIN_MODELS)?;
            }
            (ModelName::Command, None) => {
                return Err(SpecProblem::file(
                    "a user's solver runs at the rig through an emulator saved by an earlier study of it: [emulator] load = \"PATH\" (that study's [emulator] save); or model = \"excavator\"",
                ))
            }
            (ModelName::Command, Some(_)) => {}
            (ModelName::Gtn, _) => {
                return Err(SpecProblem::file(
                    "model = \"gtn\" is the tensile twin of a test; a study at the rig runs the excavator twin (model = \"excavator\") or an emulator of a user's solver ([emulator] load)",
                ))
            }
        }
    Ok((holds, emulator))
}

/// The study's parameters, each shared by every hold.
fn rig_parameters(file: &SpecFile) -> Result<Vec<StudyParameter>, SpecProblem> {
    checks::posterior(file)?;
    if let Some(index) = file.parameters.iter().position(|p| p.case.is_some()) {
        return Err(SpecProblem::table(
                "[[parameter]]",
                index,
                "a parameter of one case has no place at the rig, where every hold is a case; leave out case",
            ));
    }
    let parameters = parameters(file, &[])?;
    if parameters.is_empty() {
        return Err(SpecProblem::file(
            "no [[parameter]]: name what the holds are to find",
        ));
    }
    Ok(parameters)
}

/// The rig's model and its geometry (the built-in twin), or a user's
/// solver through the emulator an earlier study of it saved (no solver
/// runs at the rig), with each observation's model error.
fn the_model(
    directory: &Path,
    file: &SpecFile,
    emulator: Option<&str>,
    mapping: &HoldMapping,
    located: &dyn Fn(SpecProblem) -> SpecError,
) -> Result<RigModel, SpecError> {
    let mut model_error_sd = vec![0.0; mapping.observations.len()];
    let (model, geometry): (Box<dyn Model + Send>, _) = match emulator {
        Some(load) => {
            let emulator = SavedEmulator::load(&directory.join(load)).map_err(|e| {
                    let why = match &e {
                        EmulatorFileError::Read { source, .. }
                            if source.kind() == std::io::ErrorKind::NotFound =>
                        {
                            format!("{e}: run the study that saves it first (acq calibrate external with [emulator] save = \"{load}\"), or give its path relative to this file")
                        }
                        _ => e.to_string(),
                    };
                    located(SpecProblem::key("[emulator]", "load", why))
                })?;
            emulator_takes_the_study(&emulator, file, mapping).map_err(|why| {
                located(SpecProblem::key(
                    "[emulator]",
                    "load",
                    format!("{load}: {why}"),
                ))
            })?;
            for ((name, _), error) in mapping.observations.iter().zip(&mut model_error_sd) {
                if let Some(output) = emulator.outputs.iter().find(|o| &o.name == name) {
                    *error = output.error_sd;
                }
            }
            (Box::new(EmulatedModel { emulator }), None)
        }
        None => {
            let template =
                geometry_template(directory, file.geometry.as_deref()).map_err(SpecError::Input)?;
            let model = ExcavatorModel::new(template.clone(), file.refit_poses)
                .map_err(|e| located(SpecProblem::file(format!("geometry: {e}"))))?;
            (Box::new(model), Some(template))
        }
    };
    Ok((model, geometry, model_error_sd))
}

/// Every parameter of the study and every measured input of its holds is
/// a column of the emulator: one it does not take would be accepted and
/// never learnt (a parameter), or ignored in every hold (an input).
fn emulator_takes_the_study(
    emulator: &SavedEmulator,
    file: &SpecFile,
    mapping: &HoldMapping,
) -> Result<(), String> {
    let columns: Vec<&str> = emulator.columns.iter().map(|c| c.name.as_str()).collect();
    let wanted = file
        .parameters
        .iter()
        .map(|p| (p.name.as_str(), "[[parameter]]"))
        .chain(
            mapping
                .measured_inputs()
                .map(|(name, _)| (name, "[holds.inputs]")),
        );
    for (name, table) in wanted {
        if !columns.contains(&name) {
            return Err(format!(
                "{table} {name:?}: the emulator takes no {name:?}, so no hold could tell anything of it; it takes {} (those of the study that saved it): leave {name:?} out, or save the emulator again from a study that has it",
                columns.join(", ")
            ));
        }
    }
    Ok(())
}

/// A rig's model, its geometry when it is the twin, and each
/// observation's model error.
type RigModel = (
    Box<dyn Model + Send>,
    Option<acq_twins::excavator::geometry::GeometryTemplate>,
    Vec<f64>,
);
