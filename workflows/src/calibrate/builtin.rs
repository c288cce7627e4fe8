//! The built-in twins as study [`Model`]s: the excavator ([`ExcavatorModel`])
//! and the GTN tensile bar ([`GtnModel`]).
//!
//! The built-in excavator twin as a study [`Model`], so a study spec can
//! calibrate it like a user's solver (`model = "excavator"`): several load
//! cases, shared and per-case parameters, and any number of the geometry
//! file as a parameter.
//!
//! Inputs, by name: the operating inputs, a pose and a load (each a
//! parameter or a case's fixed input), and geometry numbers by their key
//! path in the geometry file (`bucket.mass_kg`,
//! `base.boom_cylinder_pin_m[1]`). The pose is either the strokes
//! (`bucket_stroke_mm`, `arm_stroke_mm`, `boom_stroke_mm`) or the links'
//! inclinations as the rig's inclinometers read them
//! (`boom_inclination_deg`, `arm_inclination_deg`,
//! `bucket_inclination_deg`: the strokes are solved for in the geometry
//! of the run, and kept while no number that moves a pin changes); the
//! load is `force_kN` at `force_angle_deg`. When a geometry number changes, the
//! fitted pose numbers (each cylinder's barrel pin along its rod pin's
//! travel, and its retracted length) are re-fitted to the published poses
//! ([`acq_twins::excavator::pose_fit`]), so Cases 1 and 2 still stand where
//! they were measured.
//!
//! Outputs: any number of `acq twin excavator --json` by key path
//! (`pressure_bar.boom`, `gauge_stress_MPa[3]`, `cylinder_force_kN.arm`,
//! `points.J[1]`); `pressure_over_relief_bar.boom` (how far a loaded
//! chamber is above the geometry's `relief_pressure_bar`, 0 below it: a
//! one-sided plausibility penalty); and numbers of the geometry itself:
//! the working envelope of `--envelope` (`envelope.max_reach_m`) and each
//! cylinder's dead length (`cylinder_dead_length_m.arm`: its retracted
//! length less its longest stroke). A case that observes only these needs
//! no operating inputs.
//!
//! The last few changed geometries' twins and envelopes are kept: the
//! cases of one evaluation share the geometry, so only the first builds it
//! (one geometry per sampler chain at work).

use std::collections::HashMap;
use std::sync::{Arc, Mutex, OnceLock, RwLock};

use acq_twins::excavator::envelope::working_envelope;
use acq_twins::excavator::geometry::{is_mass_number, GeometryTemplate};
use acq_twins::excavator::geometry_file::{rewrite_geometry_file, ChangedNumber};
use acq_twins::excavator::inclinations::Inclinations;
use acq_twins::excavator::pose_fit::{published_poses, refit_poses, ReferencePose};
use acq_twins::excavator::{
    CylinderName, Evaluation, Excavator, Inputs, Measurables, PreparedPose, Strokes,
};
use acq_twins::tensile::mesh::MeshDensity;
use acq_twins::tensile::solver::{Outcome, PullResult};

use crate::excavator_report::{
    envelope_json, evaluation_json, measurable_number, measurables_json,
};
use crate::tensile_model::{GtnInputs, TensileModel, PARAMETER_NAMES};
use acq_study::study::{
    number_at_key_path, numbers_by_key_path, CurveSlopes, Measured, Model, ModelRun, Study,
    StudyParameter,
};

/// The operating inputs the twin takes by name.
pub const OPERATING_INPUTS: [&str; 8] = [
    "bucket_stroke_mm",
    "arm_stroke_mm",
    "boom_stroke_mm",
    "force_angle_deg",
    "force_kN",
    "boom_inclination_deg",
    "arm_inclination_deg",
    "bucket_inclination_deg",
];

/// The pose as the inclinometers give it (instead of the strokes).
pub const INCLINATION_INPUTS: [&str; 3] = [
    "boom_inclination_deg",
    "arm_inclination_deg",
    "bucket_inclination_deg",
];

/// Whether a geometry number can move a pin or a link (so the strokes of
/// a pose given by inclinations change with it): all but masses, centres
/// of mass, the structure's sections and material, and the bores.
fn moves_the_linkage(key_path: &str) -> bool {
    !(key_path.contains("mass_kg")
        || key_path.contains("centre_of_mass")
        || key_path.contains("structure.")
        || key_path.starts_with("material")
        || key_path.ends_with("bore_mm")
        || key_path.ends_with("rod_mm")
        || key_path.starts_with("gauge")
        || key_path.contains("relief_pressure"))
}

/// The excavator twin behind a study.
pub struct ExcavatorModel {
    template: GeometryTemplate,
    /// The twin of the unchanged geometry (most runs change none).
    twin: Arc<Excavator>,
    /// The poses a changed geometry is re-fitted to; `None`: no re-fit.
    poses: Option<[ReferencePose; 2]>,
    /// The unchanged geometry re-fitted to them: what a change of masses
    /// alone re-weighs.
    refitted: OnceLock<Result<Arc<Excavator>, String>>,
    /// The last changed geometries (their key paths and values, the newest
    /// first), their twins, and the numbers of each geometry itself once
    /// asked for: one per sampler chain at work.
    last: Mutex<Vec<Built>>,
    /// Strokes solved from inclinations, by the inclinations and the
    /// numbers that move the linkage (their bits): a study at the rig asks
    /// for the same holds' poses at every step of its sampler.
    /// With the pose's statics factored ([`PreparedPose`]): the same for
    /// every mass.
    poses_solved: RwLock<HashMap<Vec<u64>, Arc<PreparedPose>>>,
}

/// Changed geometries kept: more than the threads that evaluate at once.
const GEOMETRIES_KEPT: usize = 8;

/// How many solved poses are kept before the cache starts again (each
/// holds its factored statics, about 9 kB): a study at the rig has a pose
/// per hold; a search that moves the linkage makes one per run.
const POSES_KEPT: usize = 1024;

/// A twin built for a changed geometry.
struct Built {
    geometry: Vec<(String, f64)>,
    twin: Arc<Excavator>,
    of_geometry: Option<Arc<Numbers>>,
}

/// Outputs by key path.
type Numbers = HashMap<String, f64>;

/// Geometry numbers by key path, as a run changes them.
type Numbered<'a> = Vec<(&'a str, f64)>;

/// The one output of `acq twin excavator --json` that needs every
/// element's stresses rather than the gauges'.
const VON_MISES_KEY: &str = "max_von_mises_MPa";

/// The input a mesh study gives (`[mesh_study] sizes`): the length of the
/// frames' finite elements, m, the same in every frame.
pub const EXCAVATOR_MESH_INPUT: &str = "mesh";
/// What the mesh input sets: each frame's element length.
const FRAME_ELEMENT_LENGTHS: [&str; 2] = [
    "boom.structure.element_length_m",
    "arm.structure.element_length_m",
];

/// The prefixes of the outputs of the geometry itself (no load case):
/// the working envelope, and each cylinder's dead length (its retracted
/// length less its longest stroke: piston, gland and eyes, which a real
/// cylinder needs).
const OF_GEOMETRY: [&str; 2] = ["envelope.", "cylinder_dead_length_m."];

fn of_geometry(name: &str) -> bool {
    OF_GEOMETRY.iter().any(|prefix| name.starts_with(prefix))
}

impl ExcavatorModel {
    /// `refit`: re-fit the pose numbers of a changed geometry to the
    /// published Cases 1 and 2.
    pub fn new(template: GeometryTemplate, refit: bool) -> Result<Self, String> {
        let twin = Excavator::new(template.with(&[])?).map_err(|e| e.to_string())?;
        Ok(ExcavatorModel {
            template,
            twin: Arc::new(twin),
            poses: refit.then(published_poses),
            refitted: OnceLock::new(),
            last: Mutex::new(Vec::new()),
            poses_solved: RwLock::new(HashMap::new()),
        })
    }

    /// The twin of a changed geometry (the unchanged one for none), and
    /// its envelope's numbers if `envelope`.
    fn twin_for(
        &self,
        geometry: &[(&str, f64)],
        envelope: bool,
    ) -> Result<(Arc<Excavator>, Option<Arc<Numbers>>), String> {
        let envelope_of = |twin: &Excavator| -> Result<Arc<Numbers>, String> {
            let envelope = working_envelope(twin.geometry()).map_err(|e| e.to_string())?;
            let mut numbers = numbers_by_key_path(&envelope_json(&envelope));
            for name in CylinderName::ALL {
                let cylinder = twin.geometry().cylinder(name);
                numbers.insert(
                    format!("cylinder_dead_length_m.{name}"),
                    cylinder.retracted_length_m - cylinder.stroke_range_mm[1] * 1e-3,
                );
            }
            Ok(Arc::new(numbers))
        };
        let same = |key: &[(&str, f64)], built: &Built| {
            built.geometry.len() == key.len()
                && built
                    .geometry
                    .iter()
                    .zip(key)
                    .all(|((a, x), (b, y))| a == b && x.to_bits() == y.to_bits())
        };
        let lock = || self.last.lock().unwrap_or_else(|e| e.into_inner());
        let kept = |key: &[(&str, f64)]| {
            lock()
                .iter()
                .find(|built| same(key, built))
                .map(|built| (built.twin.clone(), built.of_geometry.clone()))
        };
        let keep =
            |key: &[(&str, f64)], twin: &Arc<Excavator>, of_geometry: &Option<Arc<Numbers>>| {
                let mut last = lock();
                match last.iter_mut().find(|built| same(key, built)) {
                    Some(built) => {
                        if built.of_geometry.is_none() {
                            built.of_geometry.clone_from(of_geometry);
                        }
                    }
                    None => {
                        last.insert(
                            0,
                            Built {
                                geometry: key.iter().map(|(k, v)| (k.to_string(), *v)).collect(),
                                twin: twin.clone(),
                                of_geometry: of_geometry.clone(),
                            },
                        );
                        last.truncate(GEOMETRIES_KEPT);
                    }
                }
            };
        // Built outside the lock: chains sampled in parallel each build
        // their own point's twin at once. What is returned is what was
        // found or built here, whatever another thread keeps meanwhile.
        let (twin, of_geometry) = match kept(geometry) {
            Some(kept) => kept,
            None if geometry.is_empty() => (self.twin.clone(), None),
            None => {
                // Masses only weigh: the twin of the other numbers is
                // re-weighed, its frames shared (a sampler that moves
                // masses alone never rebuilds them).
                let (masses, others): (Numbered, Numbered) =
                    geometry.iter().partition(|(path, _)| is_mass_number(path));
                let base = match kept(&others) {
                    Some((base, _)) if !others.is_empty() => base,
                    _ if others.is_empty() => match &self.poses {
                        None => self.twin.clone(),
                        Some(poses) => self
                            .refitted
                            .get_or_init(|| {
                                let mut unchanged = self.template.with(&[])?;
                                refit_poses(&mut unchanged, poses)?;
                                Excavator::new(unchanged)
                                    .map(Arc::new)
                                    .map_err(|e| e.to_string())
                            })
                            .clone()?,
                    },
                    _ => {
                        let mut changed = self.template.with(&others)?;
                        if let Some(poses) = &self.poses {
                            refit_poses(&mut changed, poses)?;
                        }
                        let base = Arc::new(Excavator::new(changed).map_err(|e| e.to_string())?);
                        keep(&others, &base, &None);
                        base
                    }
                };
                let twin = if masses.is_empty() {
                    base
                } else {
                    Arc::new(base.with_masses(&masses).map_err(|e| e.to_string())?)
                };
                (twin, None)
            }
        };
        let of_geometry = match of_geometry {
            None if envelope => Some(envelope_of(&twin)?),
            kept => kept,
        };
        keep(geometry, &twin, &of_geometry);
        Ok((twin, of_geometry))
    }
}

impl ExcavatorModel {
    /// The geometry file of a study's calibrated point: the template's
    /// file with every number the study changed replaced and annotated
    /// with where it came from: identified (with its standard uncertainty
    /// and prior, `uncertainties` per search parameter), fitted to the
    /// published poses, or moved with a pin. `None` when the study changes
    /// no geometry number.
    pub fn calibrated_geometry_file(
        &self,
        study: &Study,
        calibrated: &[f64],
        uncertainties: Option<&[f64]>,
        spec: &str,
    ) -> Result<Option<String>, String> {
        let identified: Vec<(usize, &StudyParameter)> = study
            .parameters
            .iter()
            .enumerate()
            .filter(|(_, p)| p.case.is_none() && p.input.contains(['.', '[']))
            .collect();
        if identified.is_empty() {
            return Ok(None);
        }
        let values: Vec<(&str, f64)> = identified
            .iter()
            .map(|&(j, p)| (p.input.as_str(), calibrated[j]))
            .collect();
        let mut geometry = self.template.with(&values)?;
        if let Some(poses) = &self.poses {
            refit_poses(&mut geometry, poses)?;
        }
        let fitted = |path: &str| {
            path.starts_with("base.boom_cylinder_pin_m")
                || path.starts_with("boom.arm_cylinder_pin_m")
                || path.starts_with("arm.bucket_cylinder_pin_m")
                || path.ends_with("retracted_length_m")
        };
        let changes = self
            .template
            .changed_numbers(&geometry)?
            .into_iter()
            .map(|(path, value)| {
                let searched = identified.iter().find(|(_, p)| p.input == path);
                let provenance = match searched {
                    Some(&(j, p)) => {
                        let spread = uncertainties
                            .map(|u| u[j])
                            .filter(|u| u.is_finite())
                            .map_or("spread unknown".to_string(), |u| format!("+- {u:.3}"));
                        let prior = p.prior.map_or(String::new(), |prior| {
                            format!(", prior {} +- {}", prior.value, prior.uncertainty)
                        });
                        let how = if fitted(&path) {
                            format!(
                                "across its rod pin's travel identified ({:.4} {spread}{prior}), along it fitted to the published poses",
                                calibrated[j]
                            )
                        } else {
                            format!("identified, {spread}{prior}")
                        };
                        format!("{how} ({spec})")
                    }
                    None if fitted(&path) => {
                        "fitted to the published poses of Cases 1 and 2".to_string()
                    }
                    None if path.contains("station_m") => {
                        "kept its share of the member's changed length".to_string()
                    }
                    None => "moved with its pin".to_string(),
                };
                ChangedNumber {
                    path,
                    value,
                    provenance,
                }
            })
            .collect::<Vec<_>>();
        let header = vec![
            format!("Written by acq from {spec}: the numbers marked identified or fitted"),
            "are its result; every other number is as in the file it started from,".into(),
            "published or chosen as its note says.".into(),
        ];
        rewrite_geometry_file(self.template.text(), &header, &changes).map(Some)
    }
}

impl ExcavatorModel {
    /// The pose of `pose` (strokes, or inclinations solved for strokes in
    /// `twin`'s geometry; `geometry`: the numbers changed in it) with its
    /// statics factored, cached while no number that moves the linkage
    /// changes.
    fn pose_at(
        &self,
        pose: PoseBy,
        geometry: &[(&str, f64)],
        twin: &Excavator,
    ) -> Result<Arc<PreparedPose>, String> {
        let (tag, values) = match pose {
            PoseBy::Strokes(s) => (0, [s.boom_mm, s.arm_mm, s.bucket_mm]),
            PoseBy::Inclinations(i) => (1, [i.boom_deg, i.arm_deg, i.bucket_deg]),
        };
        let mut key: Vec<u64> = vec![tag];
        key.extend(values.iter().map(|x| x.to_bits()));
        key.extend(
            geometry
                .iter()
                .filter(|(path, _)| moves_the_linkage(path))
                .map(|(_, value)| value.to_bits()),
        );
        let read = self.poses_solved.read().unwrap_or_else(|e| e.into_inner());
        if let Some(prepared) = read.get(&key) {
            return Ok(prepared.clone());
        }
        drop(read);
        let strokes = match pose {
            PoseBy::Strokes(strokes) => strokes,
            PoseBy::Inclinations(inclinations) => inclinations
                .strokes(twin.geometry())
                .map_err(|e| format!("the pose of inclinations {inclinations:?}: {e}"))?,
        };
        let prepared = Arc::new(twin.prepare(&strokes).map_err(|e| e.to_string())?);
        let mut cache = self.poses_solved.write().unwrap_or_else(|e| e.into_inner());
        if cache.len() >= POSES_KEPT {
            cache.clear();
        }
        cache.insert(key, prepared.clone());
        Ok(prepared)
    }
}

/// One run's twin outputs: the full evaluation where the von Mises
/// maximum is asked for, what the transducers see otherwise.
// One lives on the stack per run and none is stored: the size difference
// costs nothing.
#[allow(clippy::large_enum_variant)]
enum TwinOutputs {
    Full(Evaluation),
    Seen(Measurables),
}

impl TwinOutputs {
    /// As `acq twin excavator --json` writes them, with the pressures over
    /// relief where the geometry has a relief pressure.
    fn json(&self) -> serde_json::Value {
        let (mut json, cylinders) = match self {
            TwinOutputs::Full(evaluation) => (evaluation_json(evaluation), &evaluation.cylinders),
            TwinOutputs::Seen(seen) => (measurables_json(seen), &seen.cylinders),
        };
        let relief: serde_json::Map<String, serde_json::Value> = CylinderName::ALL
            .iter()
            .zip(cylinders)
            .filter_map(|(name, c)| c.over_relief_bar.map(|x| (name.to_string(), x.into())))
            .collect();
        if !relief.is_empty() {
            json["pressure_over_relief_bar"] = relief.into();
        }
        json
    }
}

/// How a run gives its pose.
#[derive(Clone, Copy, Debug)]
enum PoseBy {
    Strokes(Strokes),
    Inclinations(Inclinations),
}

impl Model for ExcavatorModel {
    /// About 14 microseconds a run (a changed geometry's re-fit is cached).
    fn is_cheap(&self) -> bool {
        true
    }

    fn run(
        &self,
        inputs: &[(String, f64)],
        scalars: &[&str],
        curves: &[&str],
    ) -> Result<ModelRun, String> {
        if let Some(curve) = curves.first() {
            return Err(format!(
                "the excavator twin gives no curves ({curve:?}); observe numbers of its output by key path"
            ));
        }
        let mut operating: HashMap<&str, f64> = HashMap::new();
        let mut geometry: Vec<(&str, f64)> = Vec::new();
        for (name, value) in inputs {
            if OPERATING_INPUTS.contains(&name.as_str()) {
                operating.insert(name.as_str(), *value);
            } else if name == EXCAVATOR_MESH_INPUT {
                geometry.extend(FRAME_ELEMENT_LENGTHS.map(|path| (path, *value)));
            } else if name.contains(['.', '[']) {
                geometry.push((name.as_str(), *value));
            } else {
                return Err(format!(
                    "the excavator twin takes no input {name:?}: it takes {}, geometry numbers by key path (bucket.mass_kg) and {EXCAVATOR_MESH_INPUT} (the frames' element length, m)",
                    OPERATING_INPUTS.join(", ")
                ));
            }
        }
        let wants_envelope = scalars.iter().any(|name| of_geometry(name));
        let wants_evaluation = scalars.iter().any(|name| !of_geometry(name));
        let (twin, envelope) = self.twin_for(&geometry, wants_envelope)?;
        let outputs = if wants_evaluation {
            let operating_input = |name: &str| -> Result<f64, String> {
                operating.get(name).copied().ok_or_else(|| {
                    format!("the excavator twin needs {name}: make it a parameter or a case input")
                })
            };
            let by_inclinations = INCLINATION_INPUTS
                .iter()
                .any(|name| operating.contains_key(name));
            let pose = if by_inclinations {
                PoseBy::Inclinations(Inclinations {
                    boom_deg: operating_input("boom_inclination_deg")?,
                    arm_deg: operating_input("arm_inclination_deg")?,
                    bucket_deg: operating_input("bucket_inclination_deg")?,
                })
            } else {
                PoseBy::Strokes(Strokes {
                    bucket_mm: operating_input("bucket_stroke_mm")?,
                    arm_mm: operating_input("arm_stroke_mm")?,
                    boom_mm: operating_input("boom_stroke_mm")?,
                })
            };
            let with_strokes = |strokes: Strokes| -> Result<Inputs, String> {
                Ok(Inputs {
                    strokes,
                    tip_force_kn: operating_input("force_kN")?,
                    tip_force_angle_deg: operating_input("force_angle_deg")?,
                })
            };
            // Strokes given are checked before a pose is solved from them.
            if let PoseBy::Strokes(strokes) = pose {
                with_strokes(strokes)?.check().map_err(|e| e.to_string())?;
            }
            let prepared = self.pose_at(pose, &geometry, &twin)?;
            let inputs = with_strokes(prepared.strokes())?;
            // The von Mises maximum scans every element: only when asked.
            Some(if scalars.iter().any(|s| s.starts_with(VON_MISES_KEY)) {
                TwinOutputs::Full(
                    twin.evaluate_at(&prepared, &inputs)
                        .map_err(|e| e.to_string())?,
                )
            } else {
                TwinOutputs::Seen(
                    twin.measurable_at(&prepared, &inputs)
                        .map_err(|e| e.to_string())?,
                )
            })
        } else {
            None
        };
        // The JSON of `acq twin excavator --json` is made only for a number
        // not read directly, and for the error that lists what there is.
        let json = std::cell::OnceCell::new();
        let json_of = || {
            json.get_or_init(|| {
                outputs
                    .as_ref()
                    .map_or(serde_json::Value::Null, TwinOutputs::json)
            })
        };
        let scalars = scalars
            .iter()
            .map(|name| {
                let found = match (&envelope, &outputs) {
                    (Some(envelope), _) if of_geometry(name) => envelope.get(*name).copied(),
                    (_, Some(TwinOutputs::Seen(seen))) => measurable_number(seen, name),
                    _ => None,
                }
                .or_else(|| number_at_key_path(json_of(), name));
                found.ok_or_else(|| {
                    let numbers = numbers_by_key_path(json_of());
                    let mut known: Vec<&str> = numbers
                        .keys()
                        .map(String::as_str)
                        .filter(|k| k.starts_with("pressure_bar") || k.starts_with("cylinder"))
                        .collect();
                    known.sort_unstable();
                    format!(
                        "the excavator twin has no output {name:?}; its outputs are key paths of `acq twin excavator --json`, e.g. {}, and of its envelope (envelope.max_reach_m, envelope.max_digging_depth_m, envelope.max_dump_height_m)",
                        known.join(", ")
                    )
                })
            })
            .collect::<Result<_, _>>()?;
        Ok(ModelRun {
            scalars,
            curves: Vec::new(),
        })
    }
}

/// The built-in GTN tensile twin as a study [`Model`]: the eight GTN
/// parameters by name (`q1`, `q2`, `q3`, `epsN`, `sN`, `fN`, `f0`, `m`),
/// optionally coalescence (`fc` with `fF`) and the element size at the neck
/// (`mesh`, mm) in; the simulated force-displacement curve
/// (`force_displacement`: mm, kN) and the numbers of [`GTN_SCALARS`] out,
/// for the test the model was set up from.
pub struct GtnModel {
    model: TensileModel,
    /// The neck zone of a mesh given as the input `mesh` (None: one diameter).
    neck_zone_mm: Option<f64>,
    /// Runs give the curve's slopes in the parameters ([`Model::gives_slopes`]).
    own_slopes: bool,
}

/// The GTN twin's one curve.
pub const GTN_CURVE: &str = "force_displacement";

/// The optional input that sets the element size at the neck, mm, run by
/// run (the two levels of a multi-fidelity calibration).
pub const GTN_MESH_INPUT: &str = "mesh";

impl GtnModel {
    pub fn new(model: TensileModel) -> Self {
        GtnModel {
            model,
            neck_zone_mm: None,
            own_slopes: true,
        }
    }

    /// Whether runs give the curve's slopes in the parameters (default
    /// yes): without, a search's local steps fit them to the runs, as for
    /// a user's solver.
    pub fn with_own_slopes(mut self, own_slopes: bool) -> Self {
        self.own_slopes = own_slopes;
        self
    }

    /// The twin of the tensile test in `path` (a CSV as `acq twin gtn
    /// --test` reads), at the default mesh: its flow curve, Young's
    /// modulus, specimen and last displacement.
    pub fn of_test(path: &std::path::Path) -> acq_error::Result<Self> {
        use acq_analysis::extract::tensile_props::{
            read_test_csv, tensile_properties, SpecimenGeometry,
        };
        acq_io::input::note_input(path);
        let points = read_test_csv(path)?;
        let properties = tensile_properties(&points, SpecimenGeometry::default())
            .map_err(|e| acq_error::AcqError::Malformed(format!("{}: {e}", path.display())))?;
        Ok(GtnModel::new(TensileModel::new(
            points,
            properties,
            crate::tensile_model::ModelSettings::default(),
        )))
    }

    /// The neck zone of the meshes the input `mesh` asks for.
    pub fn with_neck_zone_mm(mut self, neck_zone_mm: Option<f64>) -> Self {
        self.neck_zone_mm = neck_zone_mm;
        self
    }

    pub fn tensile_model(&self) -> &TensileModel {
        &self.model
    }

    /// The model at the element size `mesh` asks for, or the one it holds.
    fn sized(&self, mesh: Option<f64>) -> Result<std::borrow::Cow<'_, TensileModel>, String> {
        let Some(element_mm) = mesh else {
            return Ok(std::borrow::Cow::Borrowed(&self.model));
        };
        let geometry = &self.model.settings.geometry;
        let density = MeshDensity::by_element_size(geometry, element_mm, self.neck_zone_mm)
            .map_err(|e| format!("input {GTN_MESH_INPUT} = {element_mm} mm: {e}"))?;
        let mut model = self.model.clone();
        model.settings.mesh = density;
        Ok(std::borrow::Cow::Owned(model))
    }

    /// Every case's inputs and observations as a run would take them, at
    /// the nominal point, without pulling the bar (a run at the fine size
    /// costs seconds): a wrong name or a value out of range is refused
    /// before the first run.
    pub fn check_inputs(&self, study: &Study) -> Result<(), String> {
        let nominal = study.nominal();
        for (index, case) in study.cases.iter().enumerate() {
            if case.priors {
                continue;
            }
            let names = |curve: bool| -> Vec<&str> {
                case.observations
                    .iter()
                    .filter(|o| matches!(o.measured, Measured::Curve { .. }) == curve)
                    .map(|o| o.output.as_str())
                    .collect()
            };
            let inputs = study.inputs_of(index, &nominal);
            // The parameters' ranges and the mesh are checked as a run
            // builds its twin; only the pull is left out.
            gtn_run_inputs(&inputs, &names(false), &names(true))
                .and_then(|(gtn, mesh)| self.sized(mesh)?.twin(&gtn).map(|_| ()))
                .map_err(|e| format!("case {}: {e}", case.name))?;
        }
        Ok(())
    }
}

/// A run's inputs, checked against what the twin takes and gives: the
/// parameters and the element size (None: the model's own mesh).
fn gtn_run_inputs(
    inputs: &[(String, f64)],
    scalars: &[&str],
    curves: &[&str],
) -> Result<(GtnInputs, Option<f64>), String> {
    if let Some(name) = scalars.iter().find(|s| !GTN_SCALARS.contains(s)) {
        return Err(format!(
            "the GTN twin gives no scalar {name:?}; it gives {} and the curve {GTN_CURVE}",
            GTN_SCALARS.join(", ")
        ));
    }
    if let Some(name) = curves.iter().find(|c| **c != GTN_CURVE) {
        return Err(format!(
            "the GTN twin has no curve {name:?}; its curve is {GTN_CURVE}"
        ));
    }
    let values = PARAMETER_NAMES
        .iter()
        .map(|name| {
            inputs
                .iter()
                .find(|(input, _)| input == name)
                .map(|(_, v)| *v)
                .ok_or_else(|| {
                    format!("the GTN twin needs {name}: make it a parameter or a case input")
                })
        })
        .collect::<Result<Vec<f64>, String>>()?;
    let optional = [GTN_MESH_INPUT, "fc", "fF"];
    if let Some((name, _)) = inputs
        .iter()
        .find(|(n, _)| !PARAMETER_NAMES.contains(&n.as_str()) && !optional.contains(&n.as_str()))
    {
        return Err(format!(
                "the GTN twin takes no input {name:?}: it takes {}, optionally fc and fF (coalescence) and {GTN_MESH_INPUT} (the element size at the neck, mm)",
                PARAMETER_NAMES.join(", ")
            ));
    }
    let input = |wanted: &str| inputs.iter().find(|(n, _)| n == wanted).map(|(_, v)| *v);
    let mut gtn = GtnInputs::from_values(&values)?;
    gtn.coalescence = match (input("fc"), input("fF")) {
        (Some(critical), Some(failure)) => Some((critical, failure)),
        (None, None) => None,
        _ => return Err("coalescence needs both fc and fF".into()),
    };
    Ok((gtn, input(GTN_MESH_INPUT)))
}

impl Model for GtnModel {
    fn run(
        &self,
        inputs: &[(String, f64)],
        scalars: &[&str],
        curves: &[&str],
    ) -> Result<ModelRun, String> {
        let (gtn, mesh) = gtn_run_inputs(inputs, scalars, curves)?;
        // The study scores the curve itself: the model's own MAPE is not
        // computed twice.
        let result = self.sized(mesh)?.pull(&gtn)?;
        gtn_model_run(&result, scalars, curves)
    }

    /// The twin differentiates its curve in the eight parameters along
    /// with the run (`acq_twins::tensile::sensitivity`).
    fn gives_slopes(&self) -> bool {
        self.own_slopes
    }

    /// The curve's slopes in the eight parameters; none (the search then
    /// fits its own) when the twin could not carry them through the run.
    fn run_with_slopes(
        &self,
        inputs: &[(String, f64)],
        scalars: &[&str],
        curves: &[&str],
    ) -> Result<(ModelRun, Vec<CurveSlopes>), String> {
        let (gtn, mesh) = gtn_run_inputs(inputs, scalars, curves)?;
        let (result, sensitivities) = self.sized(mesh)?.pull_with_sensitivities(&gtn)?;
        let run = gtn_model_run(&result, scalars, curves)?;
        let slopes: CurveSlopes = match sensitivities {
            Ok(sensitivities) => sensitivities
                .parameter_names
                .iter()
                .enumerate()
                .map(|(index, name)| {
                    let by_point = sensitivities
                        .kn_per_unit
                        .iter()
                        .map(|row| row[index])
                        .collect();
                    (name.to_string(), by_point)
                })
                .collect(),
            Err(_) => return Ok((run, Vec::new())),
        };
        Ok((run, curves.iter().map(|_| slopes.clone()).collect()))
    }
}

/// A pull as the study sees it: the scalars asked for, and the force
/// against the displacement for each curve asked for.
fn gtn_model_run(
    result: &PullResult,
    scalars: &[&str],
    curves: &[&str],
) -> Result<ModelRun, String> {
    let curve: Vec<(f64, f64)> = result
        .curve
        .iter()
        .map(|p| (p.displacement_mm, p.force_kn))
        .collect();
    Ok(ModelRun {
        scalars: scalars
            .iter()
            .map(|name| gtn_scalar(result, name))
            .collect::<Result<_, _>>()?,
        curves: curves.iter().map(|_| curve.clone()).collect(),
    })
}

/// The GTN twin's numbers: the maximum force, kN (the largest of the
/// curve's points, as `acq twin gtn` gives it); the displacement it is
/// reached at, mm (the vertex of the parabola through the largest point
/// and its neighbours: the flat peak's points alone would give it only to
/// the output interval); where the bar broke, mm (a run that does not
/// break has none).
pub const GTN_SCALARS: [&str; 3] = [
    "max_force_kn",
    "displacement_at_max_force_mm",
    "fracture_mm",
];

fn gtn_scalar(result: &PullResult, name: &str) -> Result<f64, String> {
    let curve = &result.curve;
    let peak = curve
        .iter()
        .enumerate()
        .max_by(|a, b| a.1.force_kn.total_cmp(&b.1.force_kn))
        .map(|(index, _)| index)
        .ok_or_else(|| "the run gave no curve".to_string());
    match name {
        "max_force_kn" => Ok(curve[peak?].force_kn),
        "displacement_at_max_force_mm" => {
            let peak = peak?;
            let at = |i: usize| (curve[i].displacement_mm, curve[i].force_kn);
            Ok(match (peak.checked_sub(1), curve.get(peak + 1)) {
                (Some(before), Some(_)) => {
                    parabola_vertex_x(at(before), at(peak), at(peak + 1)).unwrap_or(at(peak).0)
                }
                _ => at(peak).0,
            })
        }
        "fracture_mm" => match &result.outcome {
            Outcome::Fractured { displacement_mm } => Ok(*displacement_mm),
            Outcome::ReachedEnd => Err("fracture_mm: the bar did not break before the test's last displacement (GTN fracture needs coalescence: fc and fF)".into()),
            Outcome::NotConverged { displacement_mm, reason } => Err(format!(
                "fracture_mm: the run stopped at {displacement_mm} mm without breaking: {reason}"
            )),
        },
        _ => Err(format!("the GTN twin gives no scalar {name:?}")),
    }
}

/// The x of the vertex of the parabola through three points, if it has
/// one between the outer two (a maximum or minimum, not a straight line).
fn parabola_vertex_x(a: (f64, f64), b: (f64, f64), c: (f64, f64)) -> Option<f64> {
    // Divided differences: y = y_a + s1 (x - x_a) + s2 (x - x_a)(x - x_b).
    let s_ab = (b.1 - a.1) / (b.0 - a.0);
    let s_bc = (c.1 - b.1) / (c.0 - b.0);
    let curvature = (s_bc - s_ab) / (c.0 - a.0);
    let vertex = (a.0 + b.0) / 2.0 - s_ab / (2.0 * curvature);
    (curvature != 0.0 && vertex.is_finite() && vertex >= a.0 && vertex <= c.0).then_some(vertex)
}

#[cfg(test)]
mod tests {
    use acq_twins::excavator::geometry::Geometry;
    use acq_twins::excavator::pose_fit::published_poses;

    use super::*;

    /// The peak of y = 3 - 2 (x - 1.3)^2 from three unevenly spaced
    /// points around it, exactly; three points on a line have none.
    #[test]
    fn a_parabola_s_vertex_is_found_between_its_points() {
        let y = |x: f64| 3.0 - 2.0 * (x - 1.3) * (x - 1.3);
        let vertex = parabola_vertex_x((1.2, y(1.2)), (1.27, y(1.27)), (1.4, y(1.4))).unwrap();
        assert!((vertex - 1.3).abs() < 1e-12, "{vertex}");
        assert_eq!(parabola_vertex_x((0.0, 1.0), (1.0, 2.0), (2.0, 3.0)), None);
    }

    fn inputs(pairs: &[(&str, f64)]) -> Vec<(String, f64)> {
        pairs.iter().map(|(k, v)| (k.to_string(), *v)).collect()
    }

    /// Every number the run reads straight from what the transducers see
    /// is the number at the same key path of `acq twin excavator --json`,
    /// to the bit; paths it does not know (the von Mises maximum, a typo)
    /// are left to the JSON. A load past the relief valve has its
    /// `pressure_over_relief_bar` above zero, read too.
    #[test]
    fn the_numbers_read_directly_are_the_json_s() {
        let twin = Excavator::new(Geometry::dx55()).unwrap();
        for force_kn in [20.0, 400.0] {
            let case = Inputs {
                strokes: Strokes {
                    bucket_mm: 300.0,
                    arm_mm: 400.0,
                    boom_mm: 500.0,
                },
                tip_force_kn: force_kn,
                tip_force_angle_deg: -10.0,
            };
            let prepared = twin.prepare(&case.strokes).unwrap();
            let seen = TwinOutputs::Seen(twin.measurable_at(&prepared, &case).unwrap());
            let TwinOutputs::Seen(measurables) = &seen else {
                unreachable!()
            };
            let numbers = numbers_by_key_path(&seen.json());
            assert!(numbers.len() > 20, "{numbers:?}");
            let over_relief = numbers
                .iter()
                .filter(|(k, _)| k.starts_with("pressure_over_relief_bar"))
                .map(|(_, v)| *v)
                .fold(0.0, f64::max);
            assert_eq!(over_relief > 0.0, force_kn > 100.0, "{over_relief} bar");
            for (path, value) in &numbers {
                assert_eq!(
                    measurable_number(measurables, path).map(f64::to_bits),
                    Some(value.to_bits()),
                    "{path}"
                );
            }
            for path in [
                "max_von_mises_MPa.boom",
                "pressure_bar.stick",
                "pressure_bar",
                "gauge_stress_MPa[99]",
                "gauge_stress_MPa[0][0]",
                "points.A[2]",
                "points.Q[0]",
            ] {
                assert_eq!(measurable_number(measurables, path), None, "{path}");
            }
            let full = TwinOutputs::Full(twin.evaluate_at(&prepared, &case).unwrap());
            assert!(number_at_key_path(&full.json(), "max_von_mises_MPa.boom").unwrap() > 0.0);
        }
    }

    /// A pose by the links' inclinations gives the twin's outputs at the
    /// strokes of that pose: the published Case-1 pose, by its points.
    /// A changed mass (not moving the linkage) keeps the solved strokes
    /// and changes the pressures; a moved pin solves them again.
    #[test]
    fn a_pose_by_inclinations_is_the_pose_by_strokes() {
        let model = ExcavatorModel::new(GeometryTemplate::dx55(), false).unwrap();
        let pose = &published_poses()[0];
        let direction =
            |from: [f64; 2], to: [f64; 2]| (to[1] - from[1]).atan2(to[0] - from[0]).to_degrees();
        let inclinations = Inclinations {
            boom_deg: direction([0.0, 0.0], pose.b),
            arm_deg: direction(pose.b, pose.g),
            bucket_deg: direction(pose.g, pose.j),
        };
        let strokes = inclinations.strokes(&Geometry::dx55()).unwrap();
        let load = [("force_kN", 40.6), ("force_angle_deg", -10.0)];
        let outputs = [
            "pressure_bar.boom",
            "pressure_bar.arm",
            "gauge_stress_MPa[3]",
        ];
        let by_inclinations = |extra: &[(&str, f64)]| {
            let mut pairs = vec![
                ("boom_inclination_deg", inclinations.boom_deg),
                ("arm_inclination_deg", inclinations.arm_deg),
                ("bucket_inclination_deg", inclinations.bucket_deg),
            ];
            pairs.extend_from_slice(&load);
            pairs.extend_from_slice(extra);
            model.run(&inputs(&pairs), &outputs, &[]).unwrap().scalars
        };
        let by_strokes = |extra: &[(&str, f64)]| {
            let mut pairs = vec![
                ("boom_stroke_mm", strokes.boom_mm),
                ("arm_stroke_mm", strokes.arm_mm),
                ("bucket_stroke_mm", strokes.bucket_mm),
            ];
            pairs.extend_from_slice(&load);
            pairs.extend_from_slice(extra);
            model.run(&inputs(&pairs), &outputs, &[]).unwrap().scalars
        };
        assert_eq!(by_inclinations(&[]), by_strokes(&[]));
        let heavier = [("bucket.mass_kg", 400.0)];
        assert_eq!(by_inclinations(&heavier), by_strokes(&heavier));
        assert_ne!(by_inclinations(&heavier), by_inclinations(&[]));
        // A pin moved 5 cm: the same inclinations are other strokes.
        let moved = [("boom.boom_cylinder_pin_m[0]", 1.59)];
        let geometry = GeometryTemplate::dx55().with(&moved).unwrap();
        let moved_strokes = inclinations.strokes(&geometry).unwrap();
        assert!((moved_strokes.boom_mm - strokes.boom_mm).abs() > 1.0);
        let relative = |a: &[f64], b: &[f64]| {
            a.iter()
                .zip(b)
                .map(|(x, y)| ((x - y) / y).abs())
                .fold(0.0, f64::max)
        };
        let pairs = |s: &Strokes| {
            let mut pairs = vec![
                ("boom_stroke_mm", s.boom_mm),
                ("arm_stroke_mm", s.arm_mm),
                ("bucket_stroke_mm", s.bucket_mm),
            ];
            pairs.extend_from_slice(&load);
            pairs.extend_from_slice(&moved);
            pairs
        };
        let expected = model
            .run(&inputs(&pairs(&moved_strokes)), &outputs, &[])
            .unwrap()
            .scalars;
        assert!(relative(&by_inclinations(&moved), &expected) < 1e-9);
    }
}
