//! Case files: one test case of the stress test, with its uncertain inputs
//! as bounds (nominal = the middle), the tip force, and optionally what was
//! measured. The format is fixed (checks outside the repository use it):
//!
//! ```toml
//! name = "case1"
//! force_kN = 40.6
//! [bounds]                      # [lower, upper]; nominal = middle
//! bucket_stroke_mm = [116, 126]
//! arm_stroke_mm = [205, 215]
//! boom_stroke_mm = [462, 472]
//! force_angle_deg = [-15, -5]
//! force_kN = [36, 44]           # optional: the load is uncertain too
//! [measured]                    # optional: loaded-chamber pressure, bar
//! bucket_bar = 116.89
//! arm_bar = 193.46
//! boom_bar = 73.35
//! [measured_points]             # optional: pose, m
//! B = [2.937, 0.626]
//! G = [4.116, -0.450]
//! J = [4.946, -1.076]
//! ```

use std::path::Path;

use serde::Deserialize;

use super::inputs::{CylinderName, Inputs, Strokes};

/// The published Cases 1 and 2 as shipped (`data/excavator/case*.toml`).
pub const CASE1_TOML: &str = include_str!("../../../data/excavator/case1.toml");
pub const CASE2_TOML: &str = include_str!("../../../data/excavator/case2.toml");

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CaseFile {
    pub name: String,
    #[serde(rename = "force_kN")]
    pub force_kn: f64,
    pub bounds: Bounds,
    pub measured: Option<MeasuredPressures>,
    pub measured_points: Option<MeasuredPoints>,
}

/// The uncertain inputs, each `[lower, upper]`.
#[derive(Debug, Clone, Copy, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Bounds {
    pub bucket_stroke_mm: [f64; 2],
    pub arm_stroke_mm: [f64; 2],
    pub boom_stroke_mm: [f64; 2],
    pub force_angle_deg: [f64; 2],
    /// When the load magnitude is uncertain (an unweighed bucket, an
    /// unpublished load): it is then calibrated like the strokes, starting
    /// from the case's `force_kN`.
    #[serde(rename = "force_kN")]
    pub force_kn: Option<[f64; 2]>,
}

/// The model's uncertain inputs, in the order calibration and sensitivity use.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum UncertainInput {
    BucketStroke,
    ArmStroke,
    BoomStroke,
    ForceAngle,
}

impl UncertainInput {
    pub const ALL: [UncertainInput; 4] = [
        UncertainInput::BucketStroke,
        UncertainInput::ArmStroke,
        UncertainInput::BoomStroke,
        UncertainInput::ForceAngle,
    ];

    pub fn name(self) -> &'static str {
        match self {
            UncertainInput::BucketStroke => "bucket_stroke_mm",
            UncertainInput::ArmStroke => "arm_stroke_mm",
            UncertainInput::BoomStroke => "boom_stroke_mm",
            UncertainInput::ForceAngle => "force_angle_deg",
        }
    }

    pub fn unit(self) -> &'static str {
        match self {
            UncertainInput::ForceAngle => "deg",
            _ => "mm",
        }
    }

    /// Sets this input in `inputs`.
    pub fn apply(self, inputs: &mut Inputs, value: f64) {
        match self {
            UncertainInput::BucketStroke => inputs.strokes.set(CylinderName::Bucket, value),
            UncertainInput::ArmStroke => inputs.strokes.set(CylinderName::Arm, value),
            UncertainInput::BoomStroke => inputs.strokes.set(CylinderName::Boom, value),
            UncertainInput::ForceAngle => inputs.tip_force_angle_deg = value,
        }
    }
}

impl Bounds {
    pub fn get(&self, input: UncertainInput) -> [f64; 2] {
        match input {
            UncertainInput::BucketStroke => self.bucket_stroke_mm,
            UncertainInput::ArmStroke => self.arm_stroke_mm,
            UncertainInput::BoomStroke => self.boom_stroke_mm,
            UncertainInput::ForceAngle => self.force_angle_deg,
        }
    }

    pub fn nominal(&self, input: UncertainInput) -> f64 {
        let [low, high] = self.get(input);
        0.5 * (low + high)
    }
}

#[derive(Debug, Clone, Copy, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MeasuredPressures {
    pub bucket_bar: f64,
    pub arm_bar: f64,
    pub boom_bar: f64,
}

impl MeasuredPressures {
    pub fn get(&self, name: CylinderName) -> f64 {
        match name {
            CylinderName::Bucket => self.bucket_bar,
            CylinderName::Arm => self.arm_bar,
            CylinderName::Boom => self.boom_bar,
        }
    }
}

#[derive(Debug, Clone, Copy, Deserialize)]
#[serde(deny_unknown_fields)]
#[allow(non_snake_case)] // the points' names in the published test
pub struct MeasuredPoints {
    pub B: [f64; 2],
    pub G: [f64; 2],
    pub J: [f64; 2],
}

impl CaseFile {
    /// Reads and checks a case file; errors name the file and the problem.
    pub fn load(path: &Path) -> Result<CaseFile, String> {
        let text = std::fs::read_to_string(path)
            .map_err(|e| format!("cannot read case file {}: {e}", path.display()))?;
        CaseFile::parse(&text).map_err(|e| format!("{}: {e}", path.display()))
    }

    pub fn parse(text: &str) -> Result<CaseFile, String> {
        let case: CaseFile = toml::from_str(text).map_err(|e| e.to_string())?;
        super::inputs::check_tip_force_kn(case.force_kn).map_err(|e| format!("force_kN: {e}"))?;
        for input in UncertainInput::ALL {
            let [low, high] = case.bounds.get(input);
            if !(low.is_finite() && high.is_finite() && low <= high) {
                return Err(format!(
                    "bounds.{} must be [lower, upper] with lower <= upper, got [{low}, {high}]",
                    input.name()
                ));
            }
        }
        if let Some([low, high]) = case.bounds.force_kn {
            for force in [low, high] {
                super::inputs::check_tip_force_kn(force)
                    .map_err(|e| format!("bounds.force_kN: {e}"))?;
            }
            if !(low < high && (low..=high).contains(&case.force_kn)) {
                return Err(format!(
                    "bounds.force_kN must be [lower, upper] with lower < upper around force_kN = {}, got [{low}, {high}]",
                    case.force_kn
                ));
            }
        }
        Ok(case)
    }

    /// The as-tested inputs: every bound's middle.
    pub fn nominal(&self) -> Inputs {
        let mut inputs = Inputs {
            strokes: Strokes {
                bucket_mm: 0.0,
                arm_mm: 0.0,
                boom_mm: 0.0,
            },
            tip_force_kn: self.force_kn,
            tip_force_angle_deg: 0.0,
        };
        for input in UncertainInput::ALL {
            input.apply(&mut inputs, self.bounds.nominal(input));
        }
        inputs
    }
}
