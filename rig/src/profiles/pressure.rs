//! Hydraulic pressure transducers on cylinder chambers, and the net force a
//! cylinder exerts from the pressures in its head and rod chambers.

use super::linear::{unknown_unit, Linear, ProfileError};

pub const OUTPUT_UNIT: &str = "bar";
pub const INPUT_UNITS: &[&str] = &["bar", "mbar", "kPa", "MPa", "psi"];

/// Conversion from the transducer's unit to bar.
pub fn to_bar(unit: &str) -> Result<Linear, ProfileError> {
    let gain = match unit {
        "bar" => 1.0,
        "mbar" => 1e-3,
        "kPa" => 1e-2,
        "MPa" => 10.0,
        // 1 psi = 6894.757293168 Pa (exact from the inch-pound definitions).
        "psi" => 6894.757293168 / 1e5,
        _ => return Err(unknown_unit(unit, "pressure", INPUT_UNITS)),
    };
    Ok(Linear::scale(gain))
}

/// Which side of the piston a transducer sits on.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Deserialize, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Chamber {
    /// Head (piston, cap) side: full bore area; pressure here extends the rod.
    Head,
    /// Rod side: annulus area; pressure here retracts the rod.
    Rod,
}

/// Bore and rod diameters of a hydraulic cylinder.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CylinderBore {
    pub bore_diameter_mm: f64,
    pub rod_diameter_mm: f64,
}

impl CylinderBore {
    pub fn new(bore_diameter_mm: f64, rod_diameter_mm: f64) -> Result<Self, ProfileError> {
        if !(bore_diameter_mm > 0.0 && bore_diameter_mm.is_finite()) {
            return Err(ProfileError::Invalid(format!(
                "bore diameter must be a positive number of mm, got {bore_diameter_mm}"
            )));
        }
        if !(rod_diameter_mm > 0.0 && rod_diameter_mm < bore_diameter_mm) {
            return Err(ProfileError::Invalid(format!(
                "rod diameter must be positive and smaller than the bore ({bore_diameter_mm} mm), got {rod_diameter_mm}"
            )));
        }
        Ok(CylinderBore {
            bore_diameter_mm,
            rod_diameter_mm,
        })
    }

    /// Piston area on the head side, mm^2.
    pub fn head_area_mm2(&self) -> f64 {
        std::f64::consts::PI / 4.0 * self.bore_diameter_mm.powi(2)
    }

    /// Annulus area on the rod side, mm^2.
    pub fn annulus_area_mm2(&self) -> f64 {
        std::f64::consts::PI / 4.0 * (self.bore_diameter_mm.powi(2) - self.rod_diameter_mm.powi(2))
    }

    /// Net axial force on the rod, kN, positive when it pushes (extends):
    /// `p_head * A_head - p_rod * A_annulus`.
    pub fn net_force_kn(&self, head_pressure_bar: f64, rod_pressure_bar: f64) -> f64 {
        // 1 bar = 0.1 N/mm^2; N -> kN.
        (head_pressure_bar * self.head_area_mm2() - rod_pressure_bar * self.annulus_area_mm2())
            * 0.1
            / 1000.0
    }

    /// The pressure in the loaded chamber that alone balances `force_kn`
    /// (head side when pushing, rod side when pulling), bar, with the chamber.
    pub fn loaded_chamber_pressure_bar(&self, force_kn: f64) -> (Chamber, f64) {
        if force_kn >= 0.0 {
            (
                Chamber::Head,
                force_kn * 1000.0 / self.head_area_mm2() / 0.1,
            )
        } else {
            (
                Chamber::Rod,
                -force_kn * 1000.0 / self.annulus_area_mm2() / 0.1,
            )
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn units_convert_to_bar() {
        assert_eq!(to_bar("MPa").unwrap().apply(19.346), 193.46);
        assert!((to_bar("psi").unwrap().apply(1000.0) - 68.94757293168).abs() < 1e-12);
        assert!(to_bar("atm").unwrap_err().to_string().contains("bar, mbar"));
    }

    #[test]
    fn net_force_by_hand() {
        // Bore 100 mm, rod 50 mm: A_head = 7853.98 mm^2, A_annulus = 5890.49 mm^2.
        let cylinder = CylinderBore::new(100.0, 50.0).unwrap();
        let force = cylinder.net_force_kn(200.0, 10.0);
        let by_hand = (200.0 * 7853.981633974483 - 10.0 * 5890.486225480862) * 0.1 / 1000.0;
        assert!((force - by_hand).abs() < 1e-12, "{force} vs {by_hand}");
        assert!((force - 151.18).abs() < 0.01);
        let (chamber, pressure) = cylinder.loaded_chamber_pressure_bar(force);
        assert_eq!(chamber, Chamber::Head);
        assert!((cylinder.net_force_kn(pressure, 0.0) - force).abs() < 1e-12);
        let (chamber, pressure) = cylinder.loaded_chamber_pressure_bar(-20.0);
        assert_eq!(chamber, Chamber::Rod);
        assert!((cylinder.net_force_kn(0.0, pressure) + 20.0).abs() < 1e-12);
        assert!(CylinderBore::new(50.0, 60.0).is_err());
    }
}
