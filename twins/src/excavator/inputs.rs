//! What one evaluation of the twin takes (strokes, tip force) and how it can
//! fail. Every other module of the twin uses these; they use none of them.

use std::fmt;

use nalgebra::Vector2;

/// The three hydraulic cylinders.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum CylinderName {
    Bucket,
    Arm,
    Boom,
}

impl CylinderName {
    pub const ALL: [CylinderName; 3] =
        [CylinderName::Bucket, CylinderName::Arm, CylinderName::Boom];

    pub fn index(self) -> usize {
        self as usize
    }

    pub fn as_str(self) -> &'static str {
        match self {
            CylinderName::Bucket => "bucket",
            CylinderName::Arm => "arm",
            CylinderName::Boom => "boom",
        }
    }
}

impl fmt::Display for CylinderName {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

/// Cylinder strokes, mm (extension from fully retracted).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Strokes {
    pub bucket_mm: f64,
    pub arm_mm: f64,
    pub boom_mm: f64,
}

impl Strokes {
    pub fn get(&self, name: CylinderName) -> f64 {
        match name {
            CylinderName::Bucket => self.bucket_mm,
            CylinderName::Arm => self.arm_mm,
            CylinderName::Boom => self.boom_mm,
        }
    }

    pub fn set(&mut self, name: CylinderName, stroke_mm: f64) {
        match name {
            CylinderName::Bucket => self.bucket_mm = stroke_mm,
            CylinderName::Arm => self.arm_mm = stroke_mm,
            CylinderName::Boom => self.boom_mm = stroke_mm,
        }
    }
}

/// The model's inputs: strokes and the external load on the bucket tip.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Inputs {
    pub strokes: Strokes,
    /// Magnitude of the force the bucket tip receives, kN.
    pub tip_force_kn: f64,
    /// Its direction, degrees from +Y (forward) toward +Z (up).
    pub tip_force_angle_deg: f64,
}

/// The largest tip force the twin takes, kN: far beyond any excavator of
/// this class (a DX55's breakout force is about 40 kN), small enough that the
/// statics stay finite. A larger number is a unit mistake.
pub const MAX_TIP_FORCE_KN: f64 = 10_000.0;

/// Checks a tip force: finite, >= 0 (its direction is the angle), at most
/// [`MAX_TIP_FORCE_KN`]. Shared by case files and single runs.
pub fn check_tip_force_kn(force_kn: f64) -> Result<(), TwinError> {
    if force_kn.is_finite() && (0.0..=MAX_TIP_FORCE_KN).contains(&force_kn) {
        Ok(())
    } else {
        Err(TwinError::InvalidInput(format!(
            "the tip force must be from 0 to {MAX_TIP_FORCE_KN} kN (its direction is the angle), got {force_kn:?}"
        )))
    }
}

impl Inputs {
    /// Every input finite, the tip force in its range.
    pub fn check(&self) -> Result<(), TwinError> {
        for (name, value) in [
            ("bucket stroke", self.strokes.bucket_mm),
            ("arm stroke", self.strokes.arm_mm),
            ("boom stroke", self.strokes.boom_mm),
            ("tip force angle", self.tip_force_angle_deg),
        ] {
            if !value.is_finite() {
                return Err(TwinError::InvalidInput(format!(
                    "{name} must be a finite number, got {value}"
                )));
            }
        }
        check_tip_force_kn(self.tip_force_kn)
    }

    /// The tip force as a vector in the (Y, Z) plane, N.
    pub fn tip_force_n(&self) -> Vector2<f64> {
        let angle = self.tip_force_angle_deg.to_radians();
        Vector2::new(angle.cos(), angle.sin()) * (self.tip_force_kn * 1e3)
    }
}

#[derive(Debug, Clone, PartialEq)]
pub enum TwinError {
    StrokeOutOfRange {
        cylinder: CylinderName,
        stroke_mm: f64,
        range_mm: [f64; 2],
    },
    /// The linkage cannot close, or closes at (or near) a dead centre.
    DeadCentre {
        cylinder: CylinderName,
        stroke_mm: f64,
    },
    InvalidInput(String),
    Geometry(String),
}

impl fmt::Display for TwinError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            TwinError::StrokeOutOfRange { cylinder, stroke_mm, range_mm } => write!(
                f,
                "{cylinder} cylinder stroke {stroke_mm} mm is outside its range {} to {} mm",
                range_mm[0], range_mm[1]
            ),
            TwinError::DeadCentre { cylinder, stroke_mm } => write!(
                f,
                "{cylinder} cylinder stroke {stroke_mm} mm: the linkage cannot be assembled there, or only at a dead centre; \
                 choose a stroke away from it"
            ),
            TwinError::InvalidInput(message) | TwinError::Geometry(message) => f.write_str(message),
        }
    }
}

impl std::error::Error for TwinError {}
