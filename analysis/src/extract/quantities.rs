//! What a rig's holds carry, as the analysis stage names it: every
//! quantity `acq extract` writes (each sensor, and each cylinder's net
//! force and loaded chamber pressure) with its unit, kind, measuring
//! point and stated range, and each cylinder's chambers and areas. A
//! study reads a rig through this, knowing nothing of buses or frames.

use acq_rig::profiles::SensorKind;
use acq_rig::Rig;

use super::run::{loaded_pressure_quantity, net_force_quantity};
use super::uncertainty::value_budget;

/// What `sensor`'s record gives a value at the middle of its range (0
/// without one); `None` without a record.
fn stated_uncertainty(sensor: &acq_rig::Sensor) -> Option<f64> {
    let middle = sensor.range.map_or(0.0, |[low, high]| 0.5 * (low + high));
    let budget = value_budget(sensor, middle).budget;
    let u = budget.combined();
    (!budget.contributions.is_empty() && u > 0.0).then_some(u)
}

/// One quantity of a hold.
#[derive(Clone, Debug, PartialEq)]
pub struct HoldQuantity {
    pub name: String,
    pub unit: String,
    /// The sensor kind, for a sensor's own reading (`None` for a
    /// cylinder's derived values).
    pub kind: Option<SensorKind>,
    /// The measuring point a strain sensor sits at (`location`).
    pub location: Option<u32>,
    /// The full scale the rig file states, in the unit.
    pub range: Option<[f64; 2]>,
    /// The standard uncertainty the rig's sensor records give a value of
    /// it before any hold is seen (the data sheets and certificates at the
    /// middle of the range, or at 0 without one; a net force through its
    /// areas); `None` where no record says.
    pub stated_uncertainty: Option<f64>,
}

/// A cylinder: its chambers' sensors and areas as the rig file states them.
#[derive(Clone, Debug, PartialEq)]
pub struct CylinderQuantities {
    pub name: String,
    pub head: String,
    pub rod: String,
    pub head_area_m2: f64,
    pub annulus_area_m2: f64,
}

/// What a rig's holds carry.
#[derive(Clone, Debug, PartialEq)]
pub struct RigQuantities {
    pub quantities: Vec<HoldQuantity>,
    pub cylinders: Vec<CylinderQuantities>,
}

impl RigQuantities {
    pub fn of(rig: &Rig) -> RigQuantities {
        let mut quantities: Vec<HoldQuantity> = rig
            .sensors
            .iter()
            .map(|s| HoldQuantity {
                name: s.name.clone(),
                unit: s.unit().to_string(),
                kind: Some(s.kind),
                location: s.location,
                range: s.range,
                stated_uncertainty: stated_uncertainty(s),
            })
            .collect();
        for cylinder in &rig.cylinders {
            let (head, rod) = (
                stated_uncertainty(&rig.sensors[cylinder.head_sensor]),
                stated_uncertainty(&rig.sensors[cylinder.rod_sensor]),
            );
            // kN per bar: mm^2 x 0.1 N/mm^2 per bar / 1000.
            let net_force = head.zip(rod).map(|(head, rod)| {
                (cylinder.bore.head_area_mm2() * 1e-4 * head)
                    .hypot(cylinder.bore.annulus_area_mm2() * 1e-4 * rod)
            });
            for (name, unit, stated_uncertainty) in [
                (net_force_quantity(&cylinder.name), "kN", net_force),
                (
                    loaded_pressure_quantity(&cylinder.name),
                    "bar",
                    head.zip(rod).map(|(h, r)| h.max(r)),
                ),
            ] {
                quantities.push(HoldQuantity {
                    name,
                    unit: unit.to_string(),
                    kind: None,
                    location: None,
                    range: None,
                    stated_uncertainty,
                });
            }
        }
        RigQuantities {
            quantities,
            cylinders: rig
                .cylinders
                .iter()
                .map(|c| CylinderQuantities {
                    name: c.name.clone(),
                    head: rig.sensors[c.head_sensor].name.clone(),
                    rod: rig.sensors[c.rod_sensor].name.clone(),
                    head_area_m2: c.bore.head_area_mm2() * 1e-6,
                    annulus_area_m2: c.bore.annulus_area_mm2() * 1e-6,
                })
                .collect(),
        }
    }

    pub fn get(&self, name: &str) -> Option<&HoldQuantity> {
        self.quantities.iter().find(|q| q.name == name)
    }

    /// The strain sensors with a measuring point: `(name, point)`.
    pub fn gauges(&self) -> Vec<(String, u32)> {
        self.quantities
            .iter()
            .filter(|q| q.kind == Some(SensorKind::Strain))
            .filter_map(|q| Some((q.name.clone(), q.location?)))
            .collect()
    }
}
