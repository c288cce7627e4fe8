//! `[[row]] sensors = ["sg07", "sg08", "sg09", "sg10"]`: sensors of one
//! kind in order along one member (gauges along a flange), where each is
//! expected near the line through its neighbours. Only a row the rig file
//! declares is checked: a sensor's `location` number alone says nothing of
//! which sensors are neighbours on the structure (the excavator's gauges
//! jump between boom and arm).

use serde::Deserialize;
use toml::Spanned;

use super::lines::line_of;
use crate::profiles::SensorKind;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RowFile {
    sensors: Vec<String>,
}

/// Sensors in order along one member.
#[derive(Clone, Debug, PartialEq)]
pub struct SensorRow {
    /// Sensor indices, in order along the member.
    pub sensors: Vec<usize>,
    pub line: usize,
}

/// The rig's rows, each checked: at least three sensors, all of one kind,
/// none twice. `sensors` are the rig's names and kinds, `text` the rig
/// file's (for line numbers); the problems come back with their lines.
pub(super) fn read_rows(
    entries: &[Spanned<RowFile>],
    sensors: &[(&str, SensorKind)],
    text: &str,
) -> (Vec<SensorRow>, Vec<(usize, String)>) {
    let mut rows = Vec::new();
    let mut problems = Vec::new();
    for spanned in entries {
        let line = line_of(text, spanned.span().start);
        let names = &spanned.get_ref().sensors;
        if names.len() < 3 {
            problems.push((
                line,
                format!(
                    "row: {} sensor(s); a row needs three or more in order along the member (two that should agree are a [[pair]])",
                    names.len()
                ),
            ));
            continue;
        }
        let mut found = Vec::with_capacity(names.len());
        for name in names {
            match sensors.iter().position(|(s, _)| s == name) {
                Some(index) if found.contains(&index) => {
                    problems.push((line, format!("row: '{name}' is in it twice")))
                }
                Some(index) => found.push(index),
                None => problems.push((line, format!("row: no sensor named '{name}'"))),
            }
        }
        if found.len() != names.len() {
            continue;
        }
        let kind = sensors[found[0]].1;
        if let Some(&other) = found.iter().find(|&&k| sensors[k].1 != kind) {
            problems.push((
                line,
                format!(
                    "row: '{}' measures {} but '{}' measures {}; a row compares like with like",
                    sensors[found[0]].0,
                    kind.name(),
                    sensors[other].0,
                    sensors[other].1.name()
                ),
            ));
            continue;
        }
        rows.push(SensorRow {
            sensors: found,
            line,
        });
    }
    (rows, problems)
}
