//! `acq budget RIG --sensor NAME --at VALUE [--json]`: the uncertainty
//! budget of one value of a sensor as the rig states it (no session); with
//! `--cylinder NAME --head BAR --rod BAR` a cylinder's net force, checked
//! by Monte Carlo with `--monte-carlo DRAWS`.

use std::path::PathBuf;

use acq_analysis::extract::net_force::{net_force_budget, net_force_monte_carlo};
use acq_analysis::extract::uncertainty::value_budget;
use acq_error::{AcqError, Result};
use acq_io::input::load_rig;
use acq_metrology::budget::LEVEL_95;
use acq_metrology::monte_carlo::MonteCarloResult;
use clap::Args;

#[derive(Args, Debug)]
pub struct BudgetArgs {
    /// The rig file that states the sensor's certificate and data sheet.
    #[arg(value_name = "RIG.toml")]
    pub rig: PathBuf,
    /// The sensor's name in the rig.
    #[arg(
        long,
        value_name = "NAME",
        required_unless_present = "cylinder",
        requires = "at"
    )]
    pub sensor: Option<String>,
    /// The value, in the sensor's unit (bar, kN, MPa for a strain gauge read as stress, ...).
    #[arg(long, value_name = "VALUE", requires = "sensor")]
    pub at: Option<f64>,
    /// A rig cylinder: the budget of its net force (kN) at --head and --rod.
    #[arg(long, value_name = "NAME", conflicts_with = "sensor", requires_all = ["head", "rod"])]
    pub cylinder: Option<String>,
    /// The head chamber's pressure, bar.
    #[arg(long, value_name = "BAR", requires = "cylinder")]
    pub head: Option<f64>,
    /// The rod chamber's pressure, bar.
    #[arg(long, value_name = "BAR", requires = "cylinder")]
    pub rod: Option<f64>,
    /// Check the net force's budget by Monte Carlo (JCGM 101) with this
    /// many draws: every source drawn from its own distribution through
    /// the exact law.
    #[arg(long, value_name = "DRAWS", requires = "cylinder", value_parser = clap::value_parser!(u64).range(1000..=10_000_000))]
    pub monte_carlo: Option<u64>,
    /// Print one JSON object instead of the table.
    #[arg(long)]
    pub json: bool,
}

pub fn run_budget(args: BudgetArgs) -> Result<()> {
    let rig = load_rig(&args.rig)?;
    if let Some(cylinder) = &args.cylinder {
        return run_net_force(&args, &rig, cylinder);
    }
    let (Some(name), Some(at)) = (&args.sensor, args.at) else {
        return Err(AcqError::Config(
            "give --sensor NAME --at VALUE, or --cylinder NAME --head BAR --rod BAR".into(),
        ));
    };
    let Some(sensor) = rig.sensors.iter().find(|s| &s.name == name) else {
        let known: Vec<&str> = rig.sensors.iter().map(|s| s.name.as_str()).collect();
        return Err(AcqError::Config(format!(
            "{}: no sensor '{name}' (sensors: {})",
            args.rig.display(),
            known.join(", ")
        )));
    };
    if !at.is_finite() {
        return Err(AcqError::Config(format!(
            "--at {at}: give a finite value in {}",
            sensor.unit()
        )));
    }
    within_range(sensor, "--at", at)?;
    let budget = value_budget(sensor, at);
    if budget.reading.is_none()
        && matches!(
            sensor.conversion,
            acq_rig::profiles::Conversion::Polynomial(_)
        )
    {
        return Err(AcqError::Config(format!(
            "--at {shown}: no reading gives {shown} {} through {}'s certificate polynomial; give a value its readings reach (a `range` in the rig file has it checked)",
            sensor.unit(),
            sensor.name,
            shown = shown(at),
        )));
    }
    a_number(&budget, &format!("--at {}", shown(at)))?;
    print_budget(&budget, args.json, None);
    Ok(())
}

/// A number as a user reads it: `1e308`, not 309 digits.
fn shown(value: f64) -> String {
    if value != 0.0 && !(1e-6..1e15).contains(&value.abs()) {
        format!("{value:e}")
    } else {
        format!("{value}")
    }
}

/// No budget without a number: one that overflows at an extreme value is
/// refused, never printed with a null that a script would read as none.
fn a_number(value: &acq_analysis::extract::uncertainty::ValueBudget, option: &str) -> Result<()> {
    let combined = value.budget.combined();
    if combined.is_finite() && value.value.is_finite() {
        return Ok(());
    }
    Err(AcqError::Config(format!(
        "{option}: the budget at this value is not a number (u_c = {combined}); give a value the sensor reads, within its range"
    )))
}

/// A value within the range the rig file states for `sensor` (its full
/// scale): beyond it neither its certificate nor its data sheet says
/// anything, and a budget there would be a number with nothing behind it.
fn within_range(sensor: &acq_rig::Sensor, option: &str, value: f64) -> Result<()> {
    match sensor.range {
        Some([low, high]) if !(low..=high).contains(&value) => Err(AcqError::Config(format!(
            "{option} {}: outside {}'s range, {low} to {high} {} (the rig file's); its certificate and data sheet say nothing there",
            shown(value),
            sensor.name,
            sensor.unit()
        ))),
        _ => Ok(()),
    }
}

/// `--cylinder`: the net force's budget, and its Monte Carlo check.
fn run_net_force(args: &BudgetArgs, rig: &acq_rig::Rig, cylinder: &str) -> Result<()> {
    let (head, rod) = (args.head.unwrap_or(f64::NAN), args.rod.unwrap_or(f64::NAN));
    if !(head.is_finite() && rod.is_finite()) {
        return Err(AcqError::Config(format!(
            "--head {head} --rod {rod}: give both chambers' pressures in bar"
        )));
    }
    if let Some(known) = rig.cylinders.iter().find(|c| c.name == *cylinder) {
        within_range(&rig.sensors[known.head_sensor], "--head", head)?;
        within_range(&rig.sensors[known.rod_sensor], "--rod", rod)?;
    }
    let Some(value) = net_force_budget(rig, cylinder, head, rod) else {
        let known: Vec<&str> = rig.cylinders.iter().map(|c| c.name.as_str()).collect();
        return Err(AcqError::Config(format!(
            "{}: no cylinder '{cylinder}' (cylinders: {})",
            args.rig.display(),
            if known.is_empty() {
                "none".to_string()
            } else {
                known.join(", ")
            }
        )));
    };
    a_number(
        &value,
        &format!("--head {} --rod {}", shown(head), shown(rod)),
    )?;
    let monte_carlo = args
        .monte_carlo
        .and_then(|draws| net_force_monte_carlo(rig, cylinder, head, rod, draws as usize));
    print_budget(&value, args.json, monte_carlo.as_ref());
    Ok(())
}

/// The budget as JSON or as a table, with the Monte Carlo check if any.
fn print_budget(
    value: &acq_analysis::extract::uncertainty::ValueBudget,
    json: bool,
    monte_carlo: Option<&MonteCarloResult>,
) {
    let budget = &value.budget;
    let (combined, dof, k) = (
        budget.combined(),
        budget.effective_dof(),
        budget.coverage_factor(LEVEL_95),
    );
    if json {
        let contributions: serde_json::Map<String, serde_json::Value> = budget
            .contributions
            .iter()
            .map(|c| {
                (
                    c.source.clone(),
                    serde_json::json!({"u": c.in_result(), "dof": c.dof}),
                )
            })
            .collect();
        let mut json = serde_json::json!({
            "sensor": value.sensor,
            "unit": value.unit,
            "value": value.value,
            "u_c": combined,
            "dof": dof,
            "k": k,
            "U95": k * combined,
            "contributions": contributions,
        });
        if let Some(mc) = monte_carlo {
            json["monte_carlo"] = serde_json::json!({
                "draws": mc.draws,
                "mean": mc.mean,
                "u": mc.standard_uncertainty,
                "interval_95": mc.interval_95,
            });
        }
        println!("{json}");
        return;
    }
    print!("{}", budget_table(value, combined, dof, k));
    if let Some(mc) = monte_carlo {
        let half = (mc.interval_95[1] - mc.interval_95[0]) / 2.0;
        println!(
            "Monte Carlo (JCGM 101, {} draws): mean {:.6}, u {:.6} ({:+.2} % of u_c), 95 % interval [{:.6}, {:.6}], half-width {:.6} ({:+.2} % of U95)",
            mc.draws,
            mc.mean,
            mc.standard_uncertainty,
            100.0 * (mc.standard_uncertainty / combined - 1.0),
            mc.interval_95[0],
            mc.interval_95[1],
            half,
            100.0 * (half / (k * combined) - 1.0)
        );
    }
}

/// The budget as a metrology lab presents it: each source's standard
/// uncertainty, its degrees of freedom and its share of the variance.
fn budget_table(
    value: &acq_analysis::extract::uncertainty::ValueBudget,
    combined: f64,
    dof: Option<f64>,
    k: f64,
) -> String {
    let unit = &value.unit;
    let dof_text = |dof: Option<f64>| dof.map_or("inf".to_string(), |d| format!("{d:.1}"));
    let mut text = format!(
        "{} at {} {unit}",
        value.sensor,
        acq_report::number::plain(value.value, 6)
    );
    if let Some(reading) = value.reading {
        text.push_str(&format!(" (channel reading {reading:.6})"));
    }
    text.push('\n');
    if value.budget.contributions.is_empty() {
        text.push_str("no certificate, accuracy or resolution in the rig: the uncertainty is the readings' scatter only (a hold's, in acq extract)\n");
        return text;
    }
    let width = value
        .budget
        .contributions
        .iter()
        .map(|c| c.source.len())
        .max()
        .unwrap_or(0)
        .max(20);
    text.push_str(&format!(
        "{:<width$} {:>14} {:>8} {:>8}\n",
        "source",
        format!("u ({unit})"),
        "dof",
        "share"
    ));
    for (contribution, share) in value
        .budget
        .contributions
        .iter()
        .zip(value.budget.variance_shares())
    {
        text.push_str(&format!(
            "{:<width$} {:>14.6} {:>8} {:>7.1}%\n",
            contribution.source,
            contribution.in_result(),
            dof_text(contribution.dof),
            100.0 * share
        ));
    }
    text.push_str(&format!(
        "combined u_c = {combined:.6} {unit}, {} degrees of freedom, k = {k:.3}, U95 = {:.6} {unit}\n",
        dof_text(dof),
        k * combined
    ));
    text
}
