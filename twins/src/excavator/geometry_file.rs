//! Writing a geometry file whose numbers changed, with where each came
//! from.
//!
//! The file is edited, not regenerated ([`toml_edit`]): every comment, the
//! order and the layout stay, so the published and chosen numbers keep the
//! notes that say so. Each changed number gets its value and a comment
//! naming its provenance (identified by a study with its spread, or fitted
//! to the published poses): after the value for a plain key, or as a line
//! above the key for a number inside an array (a pin's coordinate, an
//! attached mass).

use toml_edit::{DocumentMut, Item, Value};

/// One changed number: its key path (`bucket.mass_kg`,
/// `base.boom_cylinder_pin_m[1]`,
/// `boom.structure.attached_mass[4].mass_kg`), its value, and where it
/// came from (`identified 269 +- 30 kg by data/excavator/identify.toml`).
#[derive(Clone, Debug, PartialEq)]
pub struct ChangedNumber {
    pub path: String,
    pub value: f64,
    pub provenance: String,
}

/// `text` (a geometry file) with each number replaced and annotated, and
/// `header` (comment lines, without `#`) put on top.
pub fn rewrite_geometry_file(
    text: &str,
    header: &[String],
    changes: &[ChangedNumber],
) -> Result<String, String> {
    let mut document: DocumentMut = text.parse().map_err(|e| format!("{e}"))?;
    for change in changes {
        set_number(&mut document, change)?;
    }
    let mut out = String::new();
    for line in header {
        out.push_str(&format!("# {line}\n").replace("# \n", "#\n"));
    }
    if !header.is_empty() {
        out.push_str("#\n");
    }
    out.push_str(&document.to_string());
    Ok(out)
}

/// A number of the file: its shortest round-tripping decimal.
fn number(value: f64) -> Value {
    Value::from(value)
}

fn set_number(document: &mut DocumentMut, change: &ChangedNumber) -> Result<(), String> {
    let missing = || format!("the geometry file has no number at {:?}", change.path);
    // The path's table part (standard tables) and the key that holds the
    // number or the array it is in.
    let parts: Vec<&str> = change.path.split('.').collect();
    let mut table = document.as_table_mut();
    let mut index = 0;
    while index + 1 < parts.len() {
        let part = parts[index];
        match part.split_once('[') {
            // A standard table.
            None if matches!(table.get(part), Some(Item::Table(_))) => {
                table = table
                    .get_mut(part)
                    .and_then(Item::as_table_mut)
                    .expect("checked to be a table");
            }
            // One table of an array of tables (`[[gauge]]`).
            Some((name, rest)) if matches!(table.get(name), Some(Item::ArrayOfTables(_))) => {
                let position: usize = rest.trim_end_matches(']').parse().map_err(|_| missing())?;
                table = table
                    .get_mut(name)
                    .and_then(Item::as_array_of_tables_mut)
                    .and_then(|a| a.get_mut(position))
                    .ok_or_else(missing)?;
            }
            _ => break,
        }
        index += 1;
    }
    let (key, first_index) = match parts[index].split_once('[') {
        Some((key, rest)) => (key, Some(rest)),
        None => (parts[index], None),
    };
    let remainder: Vec<&str> = parts[index + 1..].to_vec();
    if first_index.is_none() && remainder.is_empty() {
        // A plain key: the value, and the provenance after it.
        let item = table.get_mut(key).ok_or_else(missing)?;
        let value = item.as_value_mut().ok_or_else(missing)?;
        if !(value.is_float() || value.is_integer()) {
            return Err(missing());
        }
        *value = number(change.value);
        value
            .decor_mut()
            .set_suffix(format!("  # {}", change.provenance));
        return Ok(());
    }
    // Inside an array (and perhaps an inline table in it): the value, and
    // a comment line above the key.
    let item = table.get_mut(key).ok_or_else(missing)?;
    let mut value: &mut Value = item.as_value_mut().ok_or_else(missing)?;
    // The steps below the key: array indices and inline-table keys.
    let mut steps: Vec<String> = Vec::new();
    let push_indices = |indices: &str, steps: &mut Vec<String>| {
        for index in indices.split('[').filter(|i| !i.is_empty()) {
            steps.push(format!("[{index}"));
        }
    };
    if let Some(rest) = first_index {
        push_indices(rest, &mut steps);
    }
    for part in &remainder {
        match part.split_once('[') {
            Some((name, rest)) => {
                steps.push(name.to_string());
                push_indices(rest, &mut steps);
            }
            None => steps.push(part.to_string()),
        }
    }
    for step in &steps {
        value = if let Some(indices) = step.strip_prefix('[') {
            let position: usize = indices
                .trim_end_matches(']')
                .parse()
                .map_err(|_| missing())?;
            value
                .as_array_mut()
                .and_then(|a| a.get_mut(position))
                .ok_or_else(missing)?
        } else {
            value
                .as_inline_table_mut()
                .and_then(|t| t.get_mut(step))
                .ok_or_else(missing)?
        };
    }
    if !(value.is_float() || value.is_integer()) {
        return Err(missing());
    }
    let decor = value.decor().clone();
    *value = number(change.value);
    *value.decor_mut() = decor;
    let mut key_decor = table.key_mut(key).ok_or_else(missing)?;
    let decor = key_decor.leaf_decor_mut();
    let before = decor
        .prefix()
        .and_then(|p| p.as_str())
        .unwrap_or("")
        .to_string();
    let suffix = &change.path[change.path.find(key).unwrap_or(0) + key.len()..];
    decor.set_prefix(format!("{before}# {key}{suffix}: {}\n", change.provenance));
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    const TEXT: &str = "\
name = \"x\"

[bucket]
# Chosen: a class bucket.
mass_kg = 150.0
tip_m = [1.0, 0.0]   # published

[[gauge]]
station_m = 0.45

[boom.structure]
attached_mass = [
  { at_m = [0.0, 0.0], mass_kg = 25.0 },
]
";

    #[test]
    fn numbers_are_replaced_and_annotated_and_the_rest_kept() {
        let changes = [
            ChangedNumber {
                path: "bucket.mass_kg".into(),
                value: 269.25,
                provenance: "identified, +-30 kg".into(),
            },
            ChangedNumber {
                path: "bucket.tip_m[0]".into(),
                value: 1.5,
                provenance: "fitted".into(),
            },
            ChangedNumber {
                path: "gauge[0].station_m".into(),
                value: 0.5,
                provenance: "stretched".into(),
            },
            ChangedNumber {
                path: "boom.structure.attached_mass[0].at_m[1]".into(),
                value: 0.5,
                provenance: "moved".into(),
            },
            ChangedNumber {
                path: "boom.structure.attached_mass[0].mass_kg".into(),
                value: 40.0,
                provenance: "identified".into(),
            },
        ];
        let out = rewrite_geometry_file(TEXT, &["made by a test".into()], &changes).unwrap();
        assert!(out.starts_with("# made by a test\n#\n"), "{out}");
        assert!(
            out.contains("# Chosen: a class bucket.\nmass_kg = 269.25  # identified, +-30 kg\n"),
            "{out}"
        );
        assert!(
            out.contains("# tip_m[0]: fitted\ntip_m = [1.5, 0.0]   # published"),
            "{out}"
        );
        assert!(
            out.contains("# attached_mass[0].mass_kg: identified\nattached_mass = ["),
            "{out}"
        );
        assert!(out.contains("at_m = [0.0, 0.5], mass_kg = 40.0 }"), "{out}");
        assert!(out.contains("station_m = 0.5  # stretched"), "{out}");
        let parsed: toml::Table = toml::from_str(&out).unwrap();
        assert_eq!(parsed["bucket"]["mass_kg"].as_float(), Some(269.25));
        let missing = ChangedNumber {
            path: "bucket.volume_m3".into(),
            value: 1.0,
            provenance: String::new(),
        };
        assert!(rewrite_geometry_file(TEXT, &[], &[missing]).is_err());
    }
}
