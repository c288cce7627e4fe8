//! A cylinder's net force from its two chamber pressures, as `acq budget
//! --cylinder` states it: its budget by the law of propagation, and the
//! same checked by Monte Carlo (JCGM 101) through the exact law.

use acq_metrology::budget::{Budget, Contribution};
use acq_metrology::monte_carlo::{propagate, InputDistribution, MonteCarloResult};
use acq_rig::Rig;

use super::run::net_force_quantity;
use super::uncertainty::{
    diameter_parts, kn_per_bar, propagated, value_budget, ValueBudget, ACCURACY_CLASS,
    GAUGE_FACTOR, HYSTERESIS, NONLINEARITY, REPEATABILITY, RESOLUTION, TEMPERATURE_SPAN,
    TEMPERATURE_ZERO, ZERO_RETURN,
};

/// A cylinder's net force (kN) at chamber pressures `head_bar` and
/// `rod_bar` with its budget: both pressures' budgets through their
/// chambers' areas and the diameters' tolerances (`acq budget
/// --cylinder`). `None` when the rig has no such cylinder.
pub fn net_force_budget(
    rig: &Rig,
    cylinder: &str,
    head_bar: f64,
    rod_bar: f64,
) -> Option<ValueBudget> {
    let cylinder = rig.cylinders.iter().find(|c| c.name == cylinder)?;
    let (head, rod) = (
        &rig.sensors[cylinder.head_sensor],
        &rig.sensors[cylinder.rod_sensor],
    );
    let (head_kn_per_bar, rod_kn_per_bar) = kn_per_bar(cylinder);
    let contributions = propagated(
        &value_budget(head, head_bar).budget,
        head_kn_per_bar,
        &head.name,
    )
    .chain(propagated(
        &value_budget(rod, rod_bar).budget,
        -rod_kn_per_bar,
        &rod.name,
    ))
    .chain(diameter_parts(cylinder, head_bar, rod_bar))
    .collect();
    Some(ValueBudget {
        sensor: net_force_quantity(&cylinder.name),
        unit: "kN".to_string(),
        value: cylinder.bore.net_force_kn(head_bar, rod_bar),
        reading: None,
        budget: Budget { contributions },
    })
}

/// The pressures' sources whose limits are rectangular (data sheets,
/// rounding, a drift between two readings); the rest are normal, or
/// Student's t with their degrees of freedom. (The diameters are drawn
/// as inputs of their own, rectangular within their tolerances.)
fn is_rectangular(source: &str) -> bool {
    [
        ACCURACY_CLASS,
        RESOLUTION,
        TEMPERATURE_ZERO,
        TEMPERATURE_SPAN,
        GAUGE_FACTOR,
        ZERO_RETURN,
        NONLINEARITY,
        HYSTERESIS,
        REPEATABILITY,
    ]
    .contains(&source)
}

/// The net force's distribution by Monte Carlo (JCGM 101), every source
/// of both pressures and both diameters drawn as its own input, through
/// the exact law `F = (p_h - p_r) pi D^2 / 4 + p_r pi d^2 / 4`: the check
/// of the first-order law, which takes the force as linear in the
/// diameters and sums the sources' variances as if the result were normal.
pub fn net_force_monte_carlo(
    rig: &Rig,
    cylinder: &str,
    head_bar: f64,
    rod_bar: f64,
    draws: usize,
) -> Option<MonteCarloResult> {
    let cylinder = rig.cylinders.iter().find(|c| c.name == cylinder)?;
    let distribution = |c: &Contribution| {
        let u = (c.standard_uncertainty * c.sensitivity).abs();
        match c.dof {
            _ if is_rectangular(&c.source) => InputDistribution::Rectangular {
                mean: 0.0,
                half_width: u * 3f64.sqrt(),
            },
            Some(dof) => InputDistribution::StudentT {
                mean: 0.0,
                standard_uncertainty: u,
                dof,
            },
            None => InputDistribution::Normal {
                mean: 0.0,
                standard_uncertainty: u,
            },
        }
    };
    let head = value_budget(&rig.sensors[cylinder.head_sensor], head_bar).budget;
    let rod = value_budget(&rig.sensors[cylinder.rod_sensor], rod_bar).budget;
    let mut inputs: Vec<InputDistribution> = head.contributions.iter().map(distribution).collect();
    let head_inputs = inputs.len();
    inputs.extend(rod.contributions.iter().map(distribution));
    let pressure_inputs = inputs.len();
    for (diameter, tolerance) in [
        (cylinder.bore.bore_diameter_mm, cylinder.bore_tolerance_mm),
        (cylinder.bore.rod_diameter_mm, cylinder.rod_tolerance_mm),
    ] {
        inputs.push(InputDistribution::Rectangular {
            mean: diameter,
            half_width: tolerance,
        });
    }
    let quarter_pi = std::f64::consts::PI / 4.0;
    let model = |x: &[f64]| {
        let p_head = head_bar + x[..head_inputs].iter().sum::<f64>();
        let p_rod = rod_bar + x[head_inputs..pressure_inputs].iter().sum::<f64>();
        let (bore, rod) = (x[pressure_inputs], x[pressure_inputs + 1]);
        1e-4 * ((p_head - p_rod) * quarter_pi * bore * bore + p_rod * quarter_pi * rod * rod)
    };
    propagate(&inputs, model, draws, 1)
}
