//! `acq budget RIG --sensor NAME --at VALUE [--json]`: the uncertainty
//! budget of one value of a sensor as the rig states it (no session).

use std::path::PathBuf;

use acq_analysis::extract::budget::value_budget;
use acq_io::error::{AcqError, Result};
use acq_io::input::load_rig;
use acq_metrology::budget::LEVEL_95;
use clap::Args;

#[derive(Args, Debug)]
pub struct BudgetArgs {
    /// The rig file that states the sensor's certificate and data sheet.
    #[arg(value_name = "RIG.toml")]
    pub rig: PathBuf,
    /// The sensor's name in the rig.
    #[arg(long, value_name = "NAME")]
    pub sensor: String,
    /// The value, in the sensor's unit (bar, kN, µε, ...).
    #[arg(long, value_name = "VALUE")]
    pub at: f64,
    /// Print one JSON object instead of the table.
    #[arg(long)]
    pub json: bool,
}

pub fn run_budget(args: BudgetArgs) -> Result<()> {
    let rig = load_rig(&args.rig)?;
    let Some(sensor) = rig.sensors.iter().find(|s| s.name == args.sensor) else {
        let known: Vec<&str> = rig.sensors.iter().map(|s| s.name.as_str()).collect();
        return Err(AcqError::Config(format!(
            "{}: no sensor '{}' (sensors: {})",
            args.rig.display(),
            args.sensor,
            known.join(", ")
        )));
    };
    if !args.at.is_finite() {
        return Err(AcqError::Config(format!(
            "--at {}: give a finite value in {}",
            args.at,
            sensor.unit()
        )));
    }
    let value = value_budget(sensor, args.at);
    let budget = &value.budget;
    let (combined, dof, k) = (
        budget.combined(),
        budget.effective_dof(),
        budget.coverage_factor(LEVEL_95),
    );
    if args.json {
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
        let json = serde_json::json!({
            "sensor": value.sensor,
            "unit": value.unit,
            "value": value.value,
            "u_c": combined,
            "dof": dof,
            "k": k,
            "U95": k * combined,
            "contributions": contributions,
        });
        println!("{json}");
        return Ok(());
    }
    print!("{}", budget_table(&value, combined, dof, k));
    Ok(())
}

/// The budget as a metrology lab presents it: each source's standard
/// uncertainty, its degrees of freedom and its share of the variance.
fn budget_table(
    value: &acq_analysis::extract::budget::ValueBudget,
    combined: f64,
    dof: Option<f64>,
    k: f64,
) -> String {
    let unit = value.unit;
    let dof_text = |dof: Option<f64>| dof.map_or("inf".to_string(), |d| format!("{d:.1}"));
    let mut text = format!("{} at {} {unit}", value.sensor, value.value);
    if let Some(reading) = value.reading {
        text.push_str(&format!(" (channel reading {reading:.6})"));
    }
    text.push('\n');
    if value.budget.contributions.is_empty() {
        text.push_str("no certificate, accuracy or resolution in the rig: the uncertainty is the readings' scatter only (a hold's, in acq extract)\n");
        return text;
    }
    text.push_str(&format!(
        "{:<20} {:>14} {:>8} {:>8}\n",
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
            "{:<20} {:>14.6} {:>8} {:>7.1}%\n",
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
