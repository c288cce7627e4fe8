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
