//! The geometry file (`data/excavator/dx55.toml`): pins, masses, cylinders,
//! box sections and gauge locations of one front attachment.
//!
//! Every body has its own frame: the boom's origin is the foot pin A with x
//! toward the arm pin B; the arm's origin is B with x toward the bucket pin
//! G; the bucket's origin is G with x toward the tip J. Base coordinates are
//! the machine's: Y forward, Z up, origin A. All lengths in metres unless the
//! name says otherwise.

use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::plane_frame::BoxSection;

/// A point in a body frame, metres.
pub type PointM = [f64; 2];

#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct Geometry {
    pub name: String,
    pub material: Material,
    pub base: Base,
    pub boom: Boom,
    pub arm: Arm,
    pub bucket: Bucket,
    pub side_link: Link,
    pub connecting_link: Link,
    pub cylinder: Cylinders,
    #[serde(rename = "gauge")]
    pub gauges: Vec<Gauge>,
    /// Pose solutions closer than this to a dead centre are refused.
    pub dead_centre_margin_deg: f64,
    /// The pressure the relief valves open at: a loaded chamber above it
    /// means the machine could not hold that load.
    pub relief_pressure_bar: Option<f64>,
}

#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct Material {
    pub name: String,
    pub youngs_modulus_gpa: f64,
    pub poisson_ratio: f64,
    pub yield_strength_mpa: f64,
    pub density_kg_m3: f64,
    pub gravity_m_s2: f64,
}

/// The fixed base (swing frame), in machine coordinates.
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct Base {
    /// C: the boom cylinder's barrel pin.
    pub boom_cylinder_pin_m: PointM,
    /// A's height above the ground the machine stands on (for the working
    /// envelope).
    pub foot_pin_above_ground_m: Option<f64>,
    /// A's distance ahead of the swing axis (for the working envelope).
    pub foot_pin_ahead_of_swing_axis_m: Option<f64>,
}

/// A flexible body: a box-section centreline (a polyline through the
/// pins it carries) with sections given at stations along it.
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct Structure {
    /// Polyline vertices in the body frame; pins on it become nodes.
    pub centreline_m: Vec<PointM>,
    /// Sections at arc-length stations (m from the first vertex), linearly
    /// blended in between; the first at 0, the last at the full length.
    pub section: Vec<Station>,
    /// Finite elements are at most this long.
    pub element_length_m: f64,
    /// Pin bosses, brackets, plates: masses the box section does not hold.
    #[serde(default)]
    pub attached_mass: Vec<PointMass>,
}

#[derive(Debug, Clone, Copy, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct Station {
    pub station_m: f64,
    pub height_m: f64,
    pub width_m: f64,
    pub flange_thickness_m: f64,
    pub web_thickness_m: f64,
}

impl Station {
    pub fn section(&self) -> BoxSection {
        BoxSection {
            height_m: self.height_m,
            width_m: self.width_m,
            flange_thickness_m: self.flange_thickness_m,
            web_thickness_m: self.web_thickness_m,
        }
    }
}

#[derive(Debug, Clone, Copy, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct PointMass {
    pub at_m: PointM,
    pub mass_kg: f64,
}

#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct Boom {
    /// B, on the x axis by definition of the frame.
    pub arm_pin_m: PointM,
    /// D: the boom cylinder's rod pin.
    pub boom_cylinder_pin_m: PointM,
    /// E: the arm cylinder's barrel pin.
    pub arm_cylinder_pin_m: PointM,
    pub structure: Structure,
}

#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct Arm {
    /// G, on the x axis by definition of the frame.
    pub bucket_pin_m: PointM,
    /// F: the arm cylinder's rod pin (on the arm's tail).
    pub arm_cylinder_pin_m: PointM,
    /// H: the bucket cylinder's barrel pin.
    pub bucket_cylinder_pin_m: PointM,
    /// I: the side link's pin.
    pub side_link_pin_m: PointM,
    pub structure: Structure,
}

#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct Bucket {
    /// J, on the x axis by definition of the frame.
    pub tip_m: PointM,
    /// L: the connecting link's pin.
    pub link_pin_m: PointM,
    pub mass_kg: f64,
    pub centre_of_mass_m: PointM,
}

/// A rigid link between two pins, its centre of mass halfway.
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct Link {
    pub length_m: f64,
    pub mass_kg: f64,
}

#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct Cylinders {
    pub boom: Cylinder,
    pub arm: Cylinder,
    pub bucket: Cylinder,
}

#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct Cylinder {
    pub bore_mm: f64,
    pub rod_mm: f64,
    /// Pin-to-pin length at zero stroke.
    pub retracted_length_m: f64,
    /// Strokes the cylinder has, mm.
    pub stroke_range_mm: [f64; 2],
    pub barrel_mass_kg: f64,
    /// Barrel centre of mass, measured from the barrel pin along the axis.
    pub barrel_centre_from_pin_m: f64,
    pub rod_mass_kg: f64,
    /// Rod (with piston) centre of mass, measured from the rod pin along the axis.
    pub rod_centre_from_pin_m: f64,
}

impl Cylinder {
    pub fn head_area_m2(&self) -> f64 {
        std::f64::consts::PI / 4.0 * (self.bore_mm * 1e-3).powi(2)
    }

    pub fn annulus_area_m2(&self) -> f64 {
        std::f64::consts::PI / 4.0 * ((self.bore_mm * 1e-3).powi(2) - (self.rod_mm * 1e-3).powi(2))
    }
}

/// Which flexible body a gauge sits on.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Member {
    Boom,
    Arm,
}

/// Where on the box section a uniaxial gauge (along the member axis) sits.
/// `top` is the flange on the body frame's +y side of the centreline.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Face {
    Top,
    Bottom,
    /// A web, at `offset_m` above the section's centre (0: the neutral axis).
    LeftSide,
    RightSide,
}

#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct Gauge {
    /// Measuring point number, 1..=18.
    pub point: u32,
    pub member: Member,
    /// Arc length along the member's centreline, m.
    pub station_m: f64,
    pub face: Face,
    /// Height of a side gauge above the section centre, m.
    #[serde(default)]
    pub offset_m: f64,
}

/// The shipped DX55-class geometry, `data/excavator/dx55.toml`.
pub const DX55_TOML: &str = include_str!("../../../data/excavator/dx55.toml");

impl Geometry {
    /// The shipped DX55-class geometry.
    pub fn dx55() -> Geometry {
        Geometry::parse(DX55_TOML).expect("the shipped geometry is valid (tested)")
    }

    /// Reads and checks a geometry file; errors name the file and what is wrong.
    pub fn load(path: &Path) -> Result<Geometry, String> {
        let text = std::fs::read_to_string(path)
            .map_err(|e| format!("cannot read geometry {}: {e}", path.display()))?;
        Geometry::parse(&text).map_err(|e| format!("{}: {e}", path.display()))
    }

    pub fn parse(text: &str) -> Result<Geometry, String> {
        let geometry: Geometry = toml::from_str(text).map_err(|e| e.to_string())?;
        geometry.validate()?;
        Ok(geometry)
    }

    fn validate(&self) -> Result<(), String> {
        let positive = |name: &str, value: f64| {
            if value.is_finite() && value > 0.0 {
                Ok(())
            } else {
                Err(format!("{name} must be positive and finite, got {value}"))
            }
        };
        let m = &self.material;
        positive("material.youngs_modulus_gpa", m.youngs_modulus_gpa)?;
        positive("material.density_kg_m3", m.density_kg_m3)?;
        positive("material.gravity_m_s2", m.gravity_m_s2)?;
        positive("material.yield_strength_mpa", m.yield_strength_mpa)?;
        if !(0.0..0.5).contains(&m.poisson_ratio) {
            return Err(format!(
                "material.poisson_ratio must be in [0, 0.5), got {}",
                m.poisson_ratio
            ));
        }
        if self.boom.arm_pin_m[1] != 0.0 || self.boom.arm_pin_m[0] <= 0.0 {
            return Err("boom.arm_pin_m must lie on the boom frame's +x axis: [length, 0]".into());
        }
        if self.arm.bucket_pin_m[1] != 0.0 || self.arm.bucket_pin_m[0] <= 0.0 {
            return Err("arm.bucket_pin_m must lie on the arm frame's +x axis: [length, 0]".into());
        }
        if self.bucket.tip_m[1] != 0.0 || self.bucket.tip_m[0] <= 0.0 {
            return Err("bucket.tip_m must lie on the bucket frame's +x axis: [length, 0]".into());
        }
        positive("bucket.mass_kg", self.bucket.mass_kg)?;
        for (name, link) in [
            ("side_link", &self.side_link),
            ("connecting_link", &self.connecting_link),
        ] {
            positive(&format!("{name}.length_m"), link.length_m)?;
            positive(&format!("{name}.mass_kg"), link.mass_kg)?;
        }
        for (name, cylinder) in self.cylinders() {
            positive(&format!("cylinder.{name}.bore_mm"), cylinder.bore_mm)?;
            positive(&format!("cylinder.{name}.rod_mm"), cylinder.rod_mm)?;
            if cylinder.rod_mm >= cylinder.bore_mm {
                return Err(format!(
                    "cylinder.{name}: rod_mm {} must be smaller than bore_mm {}",
                    cylinder.rod_mm, cylinder.bore_mm
                ));
            }
            positive(
                &format!("cylinder.{name}.retracted_length_m"),
                cylinder.retracted_length_m,
            )?;
            let [low, high] = cylinder.stroke_range_mm;
            if !(low.is_finite() && high.is_finite() && low >= 0.0 && low < high) {
                return Err(format!("cylinder.{name}.stroke_range_mm must be [low, high] with 0 <= low < high, got [{low}, {high}]"));
            }
        }
        for (name, structure) in [("boom", &self.boom.structure), ("arm", &self.arm.structure)] {
            structure.validate(name)?;
        }
        let mut seen = std::collections::BTreeSet::new();
        for gauge in &self.gauges {
            if !seen.insert(gauge.point) {
                return Err(format!("gauge point {} is declared twice", gauge.point));
            }
            let structure = match gauge.member {
                Member::Boom => &self.boom.structure,
                Member::Arm => &self.arm.structure,
            };
            let length = structure.length_m();
            if !(0.0..=length).contains(&gauge.station_m) {
                return Err(format!(
                    "gauge point {}: station_m {} is outside its member's centreline (0 to {length:.3} m)",
                    gauge.point, gauge.station_m
                ));
            }
        }
        for (name, value) in [
            (
                "base.foot_pin_above_ground_m",
                self.base.foot_pin_above_ground_m,
            ),
            (
                "base.foot_pin_ahead_of_swing_axis_m",
                self.base.foot_pin_ahead_of_swing_axis_m,
            ),
            ("relief_pressure_bar", self.relief_pressure_bar),
        ] {
            if let Some(value) = value {
                positive(name, value)?;
            }
        }
        if !(self.dead_centre_margin_deg > 0.0 && self.dead_centre_margin_deg < 45.0) {
            return Err("dead_centre_margin_deg must be between 0 and 45".into());
        }
        Ok(())
    }

    pub fn cylinders(&self) -> [(&'static str, &Cylinder); 3] {
        [
            ("bucket", &self.cylinder.bucket),
            ("arm", &self.cylinder.arm),
            ("boom", &self.cylinder.boom),
        ]
    }

    pub fn youngs_modulus_pa(&self) -> f64 {
        self.material.youngs_modulus_gpa * 1e9
    }
}

impl Structure {
    /// Arc length of the centreline, m.
    pub fn length_m(&self) -> f64 {
        self.centreline_m
            .windows(2)
            .map(|pair| (pair[1][0] - pair[0][0]).hypot(pair[1][1] - pair[0][1]))
            .sum()
    }

    /// The section at an arc-length station (blended between stations).
    pub fn section_at(&self, station_m: f64) -> BoxSection {
        let stations = &self.section;
        let after = stations.partition_point(|s| s.station_m < station_m);
        if after == 0 {
            return stations[0].section();
        }
        if after == stations.len() {
            return stations[after - 1].section();
        }
        let (a, b) = (&stations[after - 1], &stations[after]);
        let t = (station_m - a.station_m) / (b.station_m - a.station_m);
        a.section().linear_blend(&b.section(), t)
    }

    fn validate(&self, name: &str) -> Result<(), String> {
        if self.centreline_m.len() < 2 {
            return Err(format!(
                "{name}.structure.centreline_m needs at least 2 points"
            ));
        }
        if !(self.element_length_m.is_finite() && self.element_length_m > 0.0) {
            return Err(format!(
                "{name}.structure.element_length_m must be positive"
            ));
        }
        let length = self.length_m();
        let stations = &self.section;
        if stations.is_empty() || stations[0].station_m != 0.0 {
            return Err(format!(
                "{name}.structure.section must start at station_m = 0"
            ));
        }
        if stations
            .windows(2)
            .any(|pair| pair[1].station_m <= pair[0].station_m)
        {
            return Err(format!("{name}.structure.section stations must increase"));
        }
        let last = stations[stations.len() - 1].station_m;
        if (last - length).abs() > 1e-3 {
            return Err(format!(
                "{name}.structure.section must end at the centreline's length {length:.4} m, ends at {last}"
            ));
        }
        for station in stations {
            station
                .section()
                .validate()
                .map_err(|e| format!("{name}.structure.section at {} m: {e}", station.station_m))?;
        }
        Ok(())
    }
}

impl Geometry {
    /// Where a pin of the boom or arm moved from `before`, its centreline
    /// vertex and attached mass (the boss around it) move along: a pin's
    /// lug goes where the pin goes. When that changes the centreline's
    /// length, the section stations and the member's gauges keep their
    /// share of it.
    pub fn carry_pins(&mut self, before: &Geometry) {
        fn carry(structure: &mut Structure, pins: &[(PointM, PointM)]) -> f64 {
            let length_before = structure.length_m();
            for &(old, new) in pins {
                if old == new {
                    continue;
                }
                for vertex in &mut structure.centreline_m {
                    if *vertex == old {
                        *vertex = new;
                    }
                }
                for mass in &mut structure.attached_mass {
                    if mass.at_m == old {
                        mass.at_m = new;
                    }
                }
            }
            let stretch = structure.length_m() / length_before;
            if stretch != 1.0 {
                for station in &mut structure.section {
                    station.station_m *= stretch;
                }
            }
            stretch
        }
        let boom_pins = [
            (before.boom.arm_pin_m, self.boom.arm_pin_m),
            (
                before.boom.boom_cylinder_pin_m,
                self.boom.boom_cylinder_pin_m,
            ),
            (before.boom.arm_cylinder_pin_m, self.boom.arm_cylinder_pin_m),
        ];
        let boom_stretch = carry(&mut self.boom.structure, &boom_pins);
        let arm_pins = [
            (before.arm.bucket_pin_m, self.arm.bucket_pin_m),
            (before.arm.arm_cylinder_pin_m, self.arm.arm_cylinder_pin_m),
            (
                before.arm.bucket_cylinder_pin_m,
                self.arm.bucket_cylinder_pin_m,
            ),
            (before.arm.side_link_pin_m, self.arm.side_link_pin_m),
        ];
        let arm_stretch = carry(&mut self.arm.structure, &arm_pins);
        for gauge in &mut self.gauges {
            gauge.station_m *= match gauge.member {
                Member::Boom => boom_stretch,
                Member::Arm => arm_stretch,
            };
        }
    }
}

/// A number of the geometry that only weighs: a mass or the bucket's centre
/// of mass. It sets loads, never the boom's or arm's stiffness or the
/// linkage, so a built twin can be re-weighed
/// ([`crate::excavator::Excavator::with_masses`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum MassNumber {
    BucketMass,
    BucketCentreOfMass(usize),
    SideLinkMass,
    ConnectingLinkMass,
    Attached { member: Member, index: usize },
    CylinderBarrel(CylinderKey),
    CylinderRod(CylinderKey),
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum CylinderKey {
    Boom,
    Arm,
    Bucket,
}

impl MassNumber {
    fn of(path: &str) -> Option<MassNumber> {
        use Step::{Index, Key};
        let cylinder = |name: &str| match name {
            "boom" => Some(CylinderKey::Boom),
            "arm" => Some(CylinderKey::Arm),
            "bucket" => Some(CylinderKey::Bucket),
            _ => None,
        };
        Some(match key_path(path).ok()?.as_slice() {
            [Key("bucket"), Key("mass_kg")] => MassNumber::BucketMass,
            [Key("bucket"), Key("centre_of_mass_m"), Index(i)] if *i < 2 => {
                MassNumber::BucketCentreOfMass(*i)
            }
            [Key("side_link"), Key("mass_kg")] => MassNumber::SideLinkMass,
            [Key("connecting_link"), Key("mass_kg")] => MassNumber::ConnectingLinkMass,
            [Key(member), Key("structure"), Key("attached_mass"), Index(index), Key("mass_kg")] => {
                MassNumber::Attached {
                    member: match *member {
                        "boom" => Member::Boom,
                        "arm" => Member::Arm,
                        _ => return None,
                    },
                    index: *index,
                }
            }
            [Key("cylinder"), Key(name), Key("barrel_mass_kg")] => {
                MassNumber::CylinderBarrel(cylinder(name)?)
            }
            [Key("cylinder"), Key(name), Key("rod_mass_kg")] => {
                MassNumber::CylinderRod(cylinder(name)?)
            }
            _ => return None,
        })
    }
}

/// Whether the number at `path` only weighs (a mass or the bucket's centre
/// of mass): see [`Geometry::set_mass_number`].
pub fn is_mass_number(path: &str) -> bool {
    MassNumber::of(path).is_some()
}

impl Geometry {
    /// Sets the number at `path` if it only weighs ([`is_mass_number`]).
    /// `None` when `path` names another number; an error when the value
    /// is not one the file could hold or the mass is not in the file.
    pub fn set_mass_number(&mut self, path: &str, value: f64) -> Option<Result<(), String>> {
        let number = MassNumber::of(path)?;
        // Masses the file's check wants positive; the others finite.
        let positive = matches!(
            number,
            MassNumber::BucketMass | MassNumber::SideLinkMass | MassNumber::ConnectingLinkMass
        );
        fn cylinder(geometry: &mut Geometry, key: CylinderKey) -> &mut Cylinder {
            match key {
                CylinderKey::Boom => &mut geometry.cylinder.boom,
                CylinderKey::Arm => &mut geometry.cylinder.arm,
                CylinderKey::Bucket => &mut geometry.cylinder.bucket,
            }
        }
        let slot: &mut f64 = match number {
            MassNumber::BucketMass => &mut self.bucket.mass_kg,
            MassNumber::BucketCentreOfMass(i) => &mut self.bucket.centre_of_mass_m[i],
            MassNumber::SideLinkMass => &mut self.side_link.mass_kg,
            MassNumber::ConnectingLinkMass => &mut self.connecting_link.mass_kg,
            MassNumber::Attached { member, index } => {
                let structure = match member {
                    Member::Boom => &mut self.boom.structure,
                    Member::Arm => &mut self.arm.structure,
                };
                match structure.attached_mass.get_mut(index) {
                    Some(mass) => &mut mass.mass_kg,
                    None => return Some(Err(format!("the geometry has no number at {path:?}"))),
                }
            }
            MassNumber::CylinderBarrel(key) => &mut cylinder(self, key).barrel_mass_kg,
            MassNumber::CylinderRod(key) => &mut cylinder(self, key).rod_mass_kg,
        };
        Some(if !value.is_finite() || (positive && value <= 0.0) {
            Err(format!(
                "{path} must be {} and finite, got {value}",
                if positive { "positive" } else { "a number" }
            ))
        } else {
            *slot = value;
            Ok(())
        })
    }
}

/// A geometry file kept as its TOML table, so any of its numbers can be set
/// by key path: `bucket.mass_kg`, `base.boom_cylinder_pin_m[1]`,
/// `gauge[2].station_m` (the file's own names; arrays indexed from 0). A
/// boom or arm pin set this way carries its centreline vertex and its boss
/// (the attached mass at it) along ([`Geometry::carry_pins`]).
#[derive(Debug, Clone)]
pub struct GeometryTemplate {
    /// The file as written, comments and all.
    text: String,
    table: toml::Table,
    /// The file as it is, where moved pins are carried from.
    unchanged: Geometry,
}

/// Every number under `value`, by key path from `path`.
fn numbers_of(value: &toml::Value, path: String, out: &mut Vec<(String, f64)>) {
    match value {
        toml::Value::Float(x) => out.push((path, *x)),
        toml::Value::Integer(i) => out.push((path, *i as f64)),
        toml::Value::Table(table) => {
            for (key, inner) in table {
                let path = if path.is_empty() {
                    key.clone()
                } else {
                    format!("{path}.{key}")
                };
                numbers_of(inner, path, out);
            }
        }
        toml::Value::Array(array) => {
            for (index, inner) in array.iter().enumerate() {
                numbers_of(inner, format!("{path}[{index}]"), out);
            }
        }
        _ => {}
    }
}

/// One step of a key path.
enum Step<'a> {
    Key(&'a str),
    Index(usize),
}

fn key_path(path: &str) -> Result<Vec<Step<'_>>, String> {
    let mut steps = Vec::new();
    for part in path.split('.') {
        let (key, mut rest) = part.split_once('[').map_or((part, ""), |(k, r)| (k, r));
        if key.is_empty() {
            return Err(format!("{path:?}: an empty name in the key path"));
        }
        steps.push(Step::Key(key));
        while !rest.is_empty() {
            let (index, after) = rest
                .split_once(']')
                .ok_or_else(|| format!("{path:?}: a '[' without its ']'"))?;
            steps.push(Step::Index(
                index
                    .parse()
                    .map_err(|_| format!("{path:?}: [{index}] is no array index"))?,
            ));
            rest = after.strip_prefix('[').unwrap_or(after);
            if !after.is_empty() && !after.starts_with('[') {
                return Err(format!("{path:?}: unexpected {after:?} after an index"));
            }
        }
    }
    Ok(steps)
}

impl GeometryTemplate {
    /// A geometry file's text; it must itself be a valid geometry.
    pub fn parse(text: &str) -> Result<GeometryTemplate, String> {
        let unchanged = Geometry::parse(text)?;
        let table = toml::from_str(text).map_err(|e| e.to_string())?;
        Ok(GeometryTemplate {
            text: text.to_string(),
            table,
            unchanged,
        })
    }

    /// The shipped DX55-class geometry.
    pub fn dx55() -> GeometryTemplate {
        GeometryTemplate::parse(DX55_TOML).expect("the shipped geometry is valid (tested)")
    }

    fn number_at<'a>(
        table: &'a mut toml::Table,
        path: &str,
    ) -> Result<&'a mut toml::Value, String> {
        let steps = key_path(path)?;
        let missing = || format!("the geometry has no number at {path:?}");
        let Some((Step::Key(first), rest)) = steps.split_first() else {
            return Err(missing());
        };
        let mut value: &mut toml::Value = table.get_mut(*first).ok_or_else(missing)?;
        for step in rest {
            value = match (value, step) {
                (toml::Value::Table(t), Step::Key(key)) => t.get_mut(*key),
                (toml::Value::Array(a), Step::Index(i)) => a.get_mut(*i),
                _ => None,
            }
            .ok_or_else(missing)?;
        }
        match value {
            v @ (toml::Value::Float(_) | toml::Value::Integer(_)) => Ok(v),
            _ => Err(missing()),
        }
    }

    /// The file as written.
    pub fn text(&self) -> &str {
        &self.text
    }

    /// Every number of the file that `geometry` (made from this template)
    /// has changed, by key path, with its new value.
    pub fn changed_numbers(&self, geometry: &Geometry) -> Result<Vec<(String, f64)>, String> {
        let written = toml::Value::try_from(geometry).map_err(|e| e.to_string())?;
        let mut before = Vec::new();
        numbers_of(
            &toml::Value::Table(self.table.clone()),
            String::new(),
            &mut before,
        );
        let mut after = Vec::new();
        numbers_of(&written, String::new(), &mut after);
        let after: std::collections::HashMap<String, f64> = after.into_iter().collect();
        Ok(before
            .into_iter()
            .filter_map(|(path, old)| {
                let new = *after.get(&path)?;
                (new.to_bits() != old.to_bits()).then_some((path, new))
            })
            .collect())
    }

    /// The number at a key path.
    pub fn value(&self, path: &str) -> Result<f64, String> {
        let mut table = self.table.clone();
        let value = Self::number_at(&mut table, path)?;
        Ok(value
            .as_float()
            .or_else(|| value.as_integer().map(|i| i as f64))
            .unwrap_or(f64::NAN))
    }

    /// The geometry with the numbers at these key paths replaced; checked
    /// like a file.
    pub fn with(&self, values: &[(&str, f64)]) -> Result<Geometry, String> {
        let mut table = self.table.clone();
        for &(path, number) in values {
            *Self::number_at(&mut table, path)? = toml::Value::Float(number);
        }
        let mut geometry: Geometry = toml::Value::Table(table)
            .try_into()
            .map_err(|e: toml::de::Error| e.to_string())?;
        geometry.carry_pins(&self.unchanged);
        geometry.validate()?;
        Ok(geometry)
    }
}
