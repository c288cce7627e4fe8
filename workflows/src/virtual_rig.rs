//! A virtual rig driven by the excavator twin: what each sensor of the rig
//! reads in a steady hold at a test point (a pose from the links'
//! inclinations, a tip force and its direction), computed by the twin at a
//! stated geometry. `acq simulate` plays these levels, so that what is
//! learnt from the recording can be checked against a known truth.
//!
//! The rig comes as names only (the twin knows nothing of CAN): which
//! sensor reads the tip force, which inclinometer which link, which gauge
//! which measuring point, which pressure sensors which cylinder's chambers.
//! A cylinder's unloaded chamber keeps its back pressure (given); the
//! loaded one reads what balances the twin's axial force against it over
//! the instrumented cylinder's areas (the rig file's bore and rod), so
//! that the net force `acq extract` computes from both chambers is the
//! twin's axial force whatever bore the twin's geometry has.

use std::collections::BTreeMap;

use acq_analysis::extract::quantities::RigQuantities;
use acq_twins::excavator::geometry::Geometry;
use acq_twins::excavator::inclinations::Inclinations;
use acq_twins::excavator::{Chamber, CylinderName, Excavator, Inputs};

/// A cylinder's two pressure sensors, by name, and its areas as the rig
/// file states them.
#[derive(Clone, Debug, PartialEq)]
pub struct CylinderSensors {
    pub cylinder: CylinderName,
    pub head: String,
    pub rod: String,
    pub head_area_m2: f64,
    pub annulus_area_m2: f64,
}

/// The rig's sensors the twin can drive, by name.
#[derive(Clone, Debug, PartialEq)]
pub struct RigSensors {
    pub tip_force: String,
    /// The inclinometers on the boom (A->B), the arm (B->G), the bucket (G->J).
    pub inclinometers: [String; 3],
    /// Each strain gauge and its measuring point.
    pub gauges: Vec<(String, u32)>,
    pub cylinders: Vec<CylinderSensors>,
}

impl RigSensors {
    /// The sensors of a rig the twin drives: `tip_force` and the three
    /// `inclinometers` (boom, arm, bucket) by name, every strain sensor
    /// with a measuring point, and every cylinder named after one of the
    /// twin's (bucket, arm, boom).
    pub fn of_rig(rig: &RigQuantities, tip_force: &str, inclinometers: [&str; 3]) -> RigSensors {
        RigSensors {
            tip_force: tip_force.to_string(),
            inclinometers: inclinometers.map(str::to_string),
            gauges: rig.gauges(),
            cylinders: rig
                .cylinders
                .iter()
                .filter_map(|c| {
                    let cylinder = CylinderName::ALL
                        .into_iter()
                        .find(|name| name.as_str() == c.name)?;
                    Some(CylinderSensors {
                        cylinder,
                        head: c.head.clone(),
                        rod: c.rod.clone(),
                        head_area_m2: c.head_area_m2,
                        annulus_area_m2: c.annulus_area_m2,
                    })
                })
                .collect(),
        }
    }
}

/// One condition of a test: where the attachment stands and what it holds.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TestPoint {
    pub inclinations: Inclinations,
    pub tip_force_kn: f64,
    /// Degrees from +Y (forward) toward +Z (up).
    pub tip_force_angle_deg: f64,
}

/// Every driven sensor's level in a hold at `point`, in its unit (kN,
/// degrees, MPa, bar). `back_pressure_bar`: each pressure sensor's level
/// when its chamber is not the loaded one (0 if not given).
pub fn hold_levels(
    geometry: &Geometry,
    rig: &RigSensors,
    back_pressure_bar: &BTreeMap<String, f64>,
    point: &TestPoint,
) -> Result<BTreeMap<String, f64>, String> {
    let strokes = point
        .inclinations
        .strokes(geometry)
        .map_err(|e| e.to_string())?;
    let twin = Excavator::new(geometry.clone()).map_err(|e| e.to_string())?;
    let evaluation = twin
        .evaluate(&Inputs {
            strokes,
            tip_force_kn: point.tip_force_kn,
            tip_force_angle_deg: point.tip_force_angle_deg,
        })
        .map_err(|e| e.to_string())?;
    let mut levels = BTreeMap::new();
    levels.insert(rig.tip_force.clone(), point.tip_force_kn);
    let seen = Inclinations::of(&evaluation.pose);
    for (name, value) in
        rig.inclinometers
            .iter()
            .zip([seen.boom_deg, seen.arm_deg, seen.bucket_deg])
    {
        levels.insert(name.clone(), value);
    }
    for (name, point_number) in &rig.gauges {
        let reading = evaluation
            .gauges
            .iter()
            .find(|g| g.point == *point_number)
            .ok_or_else(|| {
                format!("gauge {name}: the twin has no measuring point {point_number}")
            })?;
        levels.insert(name.clone(), reading.stress_mpa);
    }
    for sensors in &rig.cylinders {
        let result = evaluation.cylinder(sensors.cylinder);
        let back = |name: &str| back_pressure_bar.get(name).copied().unwrap_or(0.0);
        // Net force (N) = p_head A_head - p_rod A_annulus, with the
        // unloaded chamber at its back pressure.
        let force_n = result.axial_force_kn * 1e3;
        let (head_bar, rod_bar) = match result.loaded_chamber {
            Chamber::Head => {
                let rod_bar = back(&sensors.rod);
                let head_pa =
                    (force_n + rod_bar * 1e5 * sensors.annulus_area_m2) / sensors.head_area_m2;
                (head_pa * 1e-5, rod_bar)
            }
            Chamber::Rod => {
                let head_bar = back(&sensors.head);
                let rod_pa =
                    (head_bar * 1e5 * sensors.head_area_m2 - force_n) / sensors.annulus_area_m2;
                (head_bar, rod_pa * 1e-5)
            }
        };
        levels.insert(sensors.head.clone(), head_bar);
        levels.insert(sensors.rod.clone(), rod_bar);
    }
    Ok(levels)
}

/// The `[twin]` table of an `acq simulate` scenario: the virtual rig
/// driven by the excavator twin at a stated (hidden) truth, one hold per
/// test point.
///
/// ```toml
/// [twin]
/// study = "study.toml"      # a study at the rig: which sensor reads the
///                           # load and which inclinometer which link, the
///                           # geometry file, the load's direction
/// truth = { "bucket.mass_kg" = 215.0 }   # geometry numbers as they really are
/// back_pressure_bar = 5.0   # each unloaded chamber [default 0]
/// [[twin.point]]            # one hold each, in order
/// boom_inclination_deg = 20.0
/// arm_inclination_deg = -60.0
/// bucket_inclination_deg = -90.0
/// force_kN = 30.0
/// # force_angle_deg = -10.0 (default: the study's fixed input)
/// # hold_s = 6.0            (default: the timeline's)
/// ```
///
/// The table becomes a `[[hold]]` per point with every driven sensor's
/// level, and a `[sensor.NAME]` for each driven sensor the scenario does
/// not describe itself: idle at the back pressure (pressures), the first
/// point's angle (inclinometers) or 0, with a noise of 0.3 bar, 0.05 kN,
/// 0.02 deg or 0.5 MPa (typical transducers' reading noise).
#[derive(Debug, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TwinScenario {
    pub study: String,
    #[serde(default)]
    pub truth: BTreeMap<String, f64>,
    #[serde(default)]
    pub back_pressure_bar: f64,
    #[serde(default, rename = "point")]
    pub points: Vec<BTreeMap<String, f64>>,
}

/// A reading's noise by unit, when the scenario gives none.
fn typical_noise(unit: &str) -> f64 {
    match unit {
        "bar" => 0.3,
        "kN" => 0.05,
        "deg" => 0.02,
        _ => 0.5,
    }
}

/// A scenario's text with its `[twin]` table expanded into holds (see
/// [`TwinScenario`]); `None` without one. `directory`: where the
/// scenario's relative paths start.
pub fn expand_twin_scenario(
    text: &str,
    directory: &std::path::Path,
    rig: &RigQuantities,
) -> Result<Option<String>, String> {
    let mut table: toml::Table = toml::from_str(text).map_err(|e| e.to_string())?;
    let Some(twin) = take_twin_scenario(&mut table)? else {
        return Ok(None);
    };
    let study_path = directory.join(&twin.study);
    let study = crate::rig_study::RigStudy::load_without_candidates(&study_path, rig)
        .map_err(|e| format!("[twin] study: {e}"))?;
    let sensors = sensors_the_study_reads(&study, rig)?;
    let truth: Vec<(&str, f64)> = twin.truth.iter().map(|(k, v)| (k.as_str(), *v)).collect();
    let geometry = study
        .geometry
        .as_ref()
        .ok_or("[twin] drives the excavator twin; the study's model is an emulator")?
        .with(&truth)
        .map_err(|e| format!("[twin] truth: {e}"))?;
    let angle = study
        .mapping
        .fixed_inputs()
        .find(|(name, _)| *name == "force_angle_deg")
        .map(|(_, x)| x);
    let back: BTreeMap<String, f64> = sensors
        .cylinders
        .iter()
        .flat_map(|c| [c.head.clone(), c.rod.clone()])
        .map(|name| (name, twin.back_pressure_bar))
        .collect();
    let mut holds = Vec::new();
    let mut first_levels = None;
    for (k, point) in twin.points.iter().enumerate() {
        let here = |message: String| format!("[[twin.point]] {}: {message}", k + 1);
        let test_point = test_point_of(point, angle).map_err(here)?;
        let levels = hold_levels(&geometry, &sensors, &back, &test_point).map_err(here)?;
        holds.push(hold_of(point, &levels));
        first_levels.get_or_insert(levels);
    }
    let first_levels = first_levels.expect("at least one point");
    describe_undescribed_sensors(&mut table, &first_levels, rig, &back, &sensors)?;
    table.insert("hold".into(), toml::Value::Array(holds));
    toml::to_string(&table).map(Some).map_err(|e| e.to_string())
}

/// Takes the `[twin]` table out of a scenario and checks it: at least one
/// point, no `[[hold]]` beside it, a back pressure of at least 0 bar.
fn take_twin_scenario(table: &mut toml::Table) -> Result<Option<TwinScenario>, String> {
    let Some(twin) = table.remove("twin") else {
        return Ok(None);
    };
    let twin: TwinScenario = twin.try_into().map_err(|e| format!("[twin]: {e}"))?;
    if twin.points.is_empty() {
        return Err("[twin]: no [[twin.point]]; give the test points to hold, one each".into());
    }
    if table.contains_key("hold") {
        return Err("[twin] sets the holds: leave out [[hold]]".into());
    }
    if !(twin.back_pressure_bar.is_finite() && twin.back_pressure_bar >= 0.0) {
        return Err(format!(
            "[twin] back_pressure_bar = {}: expected a number >= 0",
            twin.back_pressure_bar
        ));
    }
    Ok(Some(twin))
}

/// The rig's sensors the twin drives: the inclinometers and the tip force
/// are those the study's holds read the pose and load from.
fn sensors_the_study_reads(
    study: &crate::rig_study::RigStudy,
    rig: &RigQuantities,
) -> Result<RigSensors, String> {
    let quantity_of = |input: &str| {
        study
            .mapping
            .measured_inputs()
            .find(|(name, _)| *name == input)
            .map(|(_, from)| from.quantity.clone())
            .ok_or_else(|| {
                format!(
                    "[twin]: the study measures no {input} in a hold; the virtual rig drives the pose and load its [holds.inputs] read"
                )
            })
    };
    let inclinometers = [
        quantity_of("boom_inclination_deg")?,
        quantity_of("arm_inclination_deg")?,
        quantity_of("bucket_inclination_deg")?,
    ];
    let tip_force = quantity_of("force_kN")?;
    Ok(RigSensors::of_rig(
        rig,
        &tip_force,
        [&inclinometers[0], &inclinometers[1], &inclinometers[2]],
    ))
}

/// One `[[twin.point]]` as a test point; `angle`: the study's fixed force
/// angle, used where the point gives none.
fn test_point_of(point: &BTreeMap<String, f64>, angle: Option<f64>) -> Result<TestPoint, String> {
    let known = [
        "boom_inclination_deg",
        "arm_inclination_deg",
        "bucket_inclination_deg",
        "force_kN",
        "force_angle_deg",
        "hold_s",
    ];
    if let Some(key) = point.keys().find(|key| !known.contains(&key.as_str())) {
        return Err(format!(
            "unknown key {key:?}; it takes {}",
            known.join(", ")
        ));
    }
    let value = |name: &str| {
        point
            .get(name)
            .copied()
            .ok_or_else(|| format!("give {name}"))
    };
    Ok(TestPoint {
        inclinations: Inclinations {
            boom_deg: value("boom_inclination_deg")?,
            arm_deg: value("arm_inclination_deg")?,
            bucket_deg: value("bucket_inclination_deg")?,
        },
        tip_force_kn: value("force_kN")?,
        tip_force_angle_deg: match point.get("force_angle_deg").copied().or(angle) {
            Some(angle) => angle,
            None => return Err("give force_angle_deg (the study fixes none)".into()),
        },
    })
}

/// A `[[hold]]` of the scenario: the point's `hold_s`, if any, and every
/// driven sensor's level.
fn hold_of(point: &BTreeMap<String, f64>, levels: &BTreeMap<String, f64>) -> toml::Value {
    let mut hold = toml::Table::new();
    if let Some(hold_s) = point.get("hold_s") {
        hold.insert("hold_s".into(), toml::Value::Float(*hold_s));
    }
    hold.insert(
        "level".into(),
        toml::Value::Table(
            levels
                .iter()
                .map(|(k, v)| (k.clone(), toml::Value::Float(*v)))
                .collect(),
        ),
    );
    toml::Value::Table(hold)
}

/// A `[sensor.NAME]` for each driven sensor the scenario does not describe:
/// idle at its back pressure (a pressure sensor), at the first hold's level
/// (an inclinometer) or at 0, its hold level the first hold's, and the
/// typical noise of its unit.
fn describe_undescribed_sensors(
    table: &mut toml::Table,
    first_levels: &BTreeMap<String, f64>,
    rig: &RigQuantities,
    back: &BTreeMap<String, f64>,
    sensors: &RigSensors,
) -> Result<(), String> {
    let described = table
        .entry("sensor")
        .or_insert_with(|| toml::Value::Table(toml::Table::new()))
        .as_table_mut()
        .ok_or("sensor: expected tables [sensor.NAME]")?;
    for (name, level) in first_levels {
        if described.contains_key(name) {
            continue;
        }
        let unit = rig.get(name).map_or("", |q| &q.unit);
        let idle = match back.get(name) {
            Some(pressure) => *pressure,
            None if sensors.inclinometers.contains(name) => *level,
            None => 0.0,
        };
        let mut sensor = toml::Table::new();
        sensor.insert("idle".into(), toml::Value::Float(idle));
        sensor.insert("hold".into(), toml::Value::Float(*level));
        sensor.insert("noise".into(), toml::Value::Float(typical_noise(unit)));
        described.insert(name.clone(), toml::Value::Table(sensor));
    }
    Ok(())
}

/// What `acq extract` gives for a hold in which every sensor of `rig` with
/// a level in `levels` is read `samples` times with independent noise of a
/// typical transducer (0.3 bar, 0.05 kN, 0.02 deg, 0.5 MPa): each mean off
/// by its standard error, each cylinder's net force from its chambers'
/// means over the rig's areas. For studies of the loop that need many
/// holds fast (the benchmark of the next test point): a recording played
/// on a bus gives the same within its statistics (tests/rig_study.rs plays
/// one).
pub fn synthetic_hold(
    rig: &RigQuantities,
    levels: &BTreeMap<String, f64>,
    samples: usize,
    rng: &mut impl rand::Rng,
) -> Vec<acq_analysis::extract::measured::MeasuredValue> {
    use acq_analysis::extract::measured::MeasuredValue;
    use acq_analysis::extract::stats::WindowStats;
    use rand_distr::{Distribution, StandardNormal};

    let n = samples.max(2) as f64;
    let value = |quantity: &str, unit: &str, mean: f64, std: f64| MeasuredValue {
        window: "hold".into(),
        start_s: 0.0,
        end_s: 0.0,
        quantity: quantity.into(),
        unit: unit.into(),
        stats: WindowStats {
            n: n as u64,
            mean: Some(mean),
            std: Some(std),
            n_eff: n,
            lag1_autocorrelation: 0.0,
            ci95_half_width: Some(1.96 * std / n.sqrt()),
        },
        flags: Vec::new(),
        note: String::new(),
        // The synthetic hold's scatter is its only uncertainty.
        budget: Default::default(),
        u_c: None,
        k: None,
    };
    let mut values: Vec<MeasuredValue> = Vec::new();
    for q in &rig.quantities {
        if let Some(level) = levels.get(&q.name) {
            let std = typical_noise(&q.unit);
            let error: f64 = StandardNormal.sample(rng);
            values.push(value(&q.name, &q.unit, level + std / n.sqrt() * error, std));
        }
    }
    let mean_of = |values: &[MeasuredValue], name: &str| {
        values
            .iter()
            .find(|v| v.quantity == name)
            .and_then(|v| v.stats.mean)
    };
    for cylinder in &rig.cylinders {
        let (Some(head), Some(rod)) = (
            mean_of(&values, &cylinder.head),
            mean_of(&values, &cylinder.rod),
        ) else {
            continue;
        };
        // kN: bar x 1e5 Pa x m^2 / 1e3.
        let net = (head * cylinder.head_area_m2 - rod * cylinder.annulus_area_m2) * 1e2;
        let std =
            typical_noise("bar") * 1e2 * cylinder.head_area_m2.hypot(cylinder.annulus_area_m2);
        values.push(value(
            &acq_analysis::extract::run::net_force_quantity(&cylinder.name),
            "kN",
            net,
            std,
        ));
    }
    values
}
