//! The measured-values file: what `acq extract` writes and `acq calibrate`
//! reads. One CSV row per window and quantity:
//!
//! ```text
//! window,start_s,end_s,quantity,unit,mean,std,n,n_eff,ci95_low,ci95_high,u_c,k,U95,shared,flags,note
//! hold1,4.5,11.5,bucket_head_pressure,bar,116.893,0.301,700,700,116.871,116.915,1.1557,1.96,2.2651,bucket_head_pressure=1.1547,,
//! hold1,4.5,11.5,sg03,MPa,17.83,0.15,700,700,17.82,17.84,0.0057,1.963,0.0112,,pair:sg04,"differs from sg04 (75.46 MPa) by 76 %"
//! ```
//!
//! - `start_s`, `end_s`: seconds from the session start (reference clock).
//! - `quantity`: a rig sensor, or a derived quantity of a rig cylinder:
//!   `<cylinder>_net_force` (kN, head area x head pressure - annulus area x
//!   rod pressure) and `<cylinder>_loaded_pressure` (bar: the head chamber
//!   when the cylinder pushes, the rod chamber when it pulls).
//! - `std`: sample standard deviation; `n`: samples; `n_eff`: n corrected
//!   for lag-1 autocorrelation; `ci95_*`: Student-t 95 % interval of the
//!   mean with n_eff - 1 degrees of freedom. Empty when undefined (n < 2).
//! - `u_c`, `k`, `U95`: the value's combined standard uncertainty
//!   (JCGM 100): the readings' scatter (Type A, `std / sqrt(n_eff)` with
//!   `n_eff - 1` degrees of freedom) with the sensor's certificate,
//!   accuracy and resolution at the mean (Type B, [`crate::extract::uncertainty`]); a
//!   derived quantity's from its sensors' by propagation. `k` is Student's
//!   t for 95 % at the effective degrees of freedom, `U95 = k u_c`.
//! - `shared`: the parts of `u_c` that are the same in every hold recorded
//!   with the same sensor (its certificate and accuracy class: averaging
//!   holds does not reduce them), `;`-separated `sensor=effect`, the effect
//!   `c u` signed and in the value's unit (a net force's rod pressure
//!   counts negative). A posterior treats each sensor's as one error.
//!   Files written before these columns are read as before, without them.
//! - `flags`: empty when the value is fit to use, else `;`-separated codes:
//!   `no_samples`, `few_samples` (n_eff < 2), `stuck`, `saturated`, `noisy`,
//!   `pair:<partner>`. `note` says why in words.

use std::path::Path;

use acq_error::{AcqError, Result};
use acq_io::input::read_csv_records_of_any;
use acq_io::output::{csv_field, Output};
use acq_io::output::{refuse_mf4_table, TableFormat};
use acq_io::parquet_table::{ArrowSink, ColumnSpec, ColumnType, FileLayout, ParquetTable};

use acq_metrology::budget::{Budget, Contribution, SharedError, LEVEL_95};

use crate::extract::stats::WindowStats;

/// The header of the measured-values file.
pub const MEASURED_HEADER: &str =
    "window,start_s,end_s,quantity,unit,mean,std,n,n_eff,ci95_low,ci95_high,u_c,k,U95,shared,flags,note";

/// The header of files written before the shared errors' column.
const MEASURED_HEADER_WITHOUT_SHARED: &str =
    "window,start_s,end_s,quantity,unit,mean,std,n,n_eff,ci95_low,ci95_high,u_c,k,U95,flags,note";

/// The header of files written before the uncertainty budget's columns.
const MEASURED_HEADER_WITHOUT_BUDGET: &str =
    "window,start_s,end_s,quantity,unit,mean,std,n,n_eff,ci95_low,ci95_high,flags,note";

/// Which of a measured value's uncertainty a calibration takes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum UncertaintyBasis {
    /// Its budget, `u_c`: the readings' scatter with its sensors'
    /// certificates, accuracy and resolution, each sensor's part shared
    /// by every value it gave.
    #[default]
    Budget,
    /// The readings' scatter in the hold alone (the standard error of the
    /// mean), each value independent: what calibrations took before
    /// budgets, and what a value without one has anyway.
    ReadingsScatter,
}

/// One quantity in one window.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct MeasuredValue {
    pub window: String,
    pub start_s: f64,
    pub end_s: f64,
    pub quantity: String,
    pub unit: String,
    pub stats: WindowStats,
    pub flags: Vec<String>,
    pub note: String,
    /// What the value's uncertainty is made of: every source for a value
    /// just extracted; for one read from a file, its shared sources only
    /// (the file keeps `u_c`, `k` and those; so does serde).
    #[serde(with = "shared_parts", default)]
    pub budget: Budget,
    /// The combined standard uncertainty and the coverage factor for
    /// 95 %: the budget's, or the file's.
    #[serde(default)]
    pub u_c: Option<f64>,
    #[serde(default)]
    pub k: Option<f64>,
}

impl MeasuredValue {
    /// The value with `budget` as what its uncertainty is made of.
    pub fn with_budget(mut self, budget: Budget) -> Self {
        if budget.contributions.is_empty() {
            (self.u_c, self.k) = (None, None);
        } else {
            self.u_c = Some(budget.combined());
            self.k = Some(budget.coverage_factor(LEVEL_95));
        }
        self.budget = budget;
        self
    }

    /// `U95 = k u_c`.
    pub fn expanded_95(&self) -> Option<f64> {
        self.u_c.zip(self.k).map(|(u, k)| u * k)
    }

    /// The value's standard uncertainty as `basis` takes it, with the
    /// parts of it that recur in other values (its sensors'); `None`
    /// without a spread (fewer than 2 samples and no budget). The budget
    /// falls back to the readings' scatter where the file has none.
    pub fn standard_uncertainty(&self, basis: UncertaintyBasis) -> Option<(f64, Vec<SharedError>)> {
        let scatter = || {
            self.stats
                .std_of_mean()
                .or(self.stats.std)
                .map(|u| (u, Vec::new()))
        };
        match (basis, self.u_c) {
            (UncertaintyBasis::Budget, Some(u_c)) if u_c > 0.0 && u_c.is_finite() => {
                Some((u_c, self.budget.shared_errors()))
            }
            _ => scatter(),
        }
    }

    /// Fit to be used: a mean and no flag.
    pub fn is_usable(&self) -> bool {
        self.stats.mean.is_some() && self.flags.is_empty()
    }
}

fn number(out: &mut String, value: Option<f64>) {
    if let Some(v) = value.filter(|v| v.is_finite()) {
        let mut buffer = ryu::Buffer::new();
        out.push_str(buffer.format(v));
    }
}

/// Writes the file (complete-only: a crash leaves no half file): CSV, or
/// Parquet for a `.parquet` path.
pub fn write_measured(path: &Path, values: &[MeasuredValue]) -> Result<()> {
    refuse_mf4_table(path, "measured values")?;
    let mut output = Output::create_complete_only(path)?;
    if TableFormat::of(path) == TableFormat::Parquet {
        return write_measured_parquet(output, values);
    }
    let mut text = String::with_capacity(128 * (values.len() + 1));
    text.push_str(MEASURED_HEADER);
    text.push('\n');
    for v in values {
        let s = &v.stats;
        text.push_str(&csv_field(&v.window));
        text.push(',');
        number(&mut text, Some(v.start_s));
        text.push(',');
        number(&mut text, Some(v.end_s));
        text.push(',');
        text.push_str(&csv_field(&v.quantity));
        text.push(',');
        text.push_str(&csv_field(&v.unit));
        text.push(',');
        number(&mut text, s.mean);
        text.push(',');
        number(&mut text, s.std);
        text.push(',');
        text.push_str(&s.n.to_string());
        text.push(',');
        number(&mut text, (s.n > 0).then_some(s.n_eff));
        let half = s.ci95_half_width;
        text.push(',');
        number(&mut text, s.mean.zip(half).map(|(m, h)| m - h));
        text.push(',');
        number(&mut text, s.mean.zip(half).map(|(m, h)| m + h));
        text.push(',');
        number(&mut text, v.u_c);
        text.push(',');
        number(&mut text, v.k);
        text.push(',');
        number(&mut text, v.expanded_95());
        text.push(',');
        text.push_str(&csv_field(&shared_text(&v.budget.shared_errors())));
        text.push(',');
        text.push_str(&csv_field(&v.flags.join(";")));
        text.push(',');
        text.push_str(&csv_field(&v.note));
        text.push('\n');
    }
    output.buffer.extend_from_slice(text.as_bytes());
    output.finish()
}

/// The measured values as Parquet: the CSV's columns; a statistic that is
/// not a finite number is null (an empty cell in the CSV). The values'
/// units differ per row, so they stay in the `unit` column.
fn write_measured_parquet(output: Output, values: &[MeasuredValue]) -> Result<()> {
    let mut table = ParquetTable::new(output, &measured_columns(), &[])?;
    fill_measured(&mut table, values, &[], false)?;
    table.finish().map(|_| ())
}

/// The measured values as Parquet, each row led by the `(column, value)`
/// pairs of `within` (the session and file a campaign's table holds them
/// under), then the CSV's columns, then `row`: the value's place in the
/// file, so that a query gives them back in `acq extract`'s order.
pub fn write_measured_parquet_within(
    output: Output,
    values: &[MeasuredValue],
    within: &[(&str, &str)],
) -> Result<()> {
    let mut columns: Vec<ColumnSpec> = within
        .iter()
        .map(|(name, _)| ColumnSpec::new(*name, ColumnType::Text))
        .collect();
    columns.extend(measured_columns());
    columns.push(ColumnSpec::new("row", ColumnType::Integer));
    let mut table = ParquetTable::with_layout(output, &columns, &[], FileLayout::FOR_EVERY_ENGINE)?;
    fill_measured(&mut table, values, within, true)?;
    table.finish().map(|_| ())
}

/// The measured values `acq extract -o FILE.parquet` writes, as Arrow
/// record batches handed to `sink`.
pub fn measured_to_arrow(values: &[MeasuredValue], sink: Box<dyn ArrowSink>) -> Result<()> {
    let mut table = ParquetTable::to_arrow(&measured_columns(), &[], sink)?;
    fill_measured(&mut table, values, &[], false)?;
    table.finish().map(|_| ())
}

/// The CSV's columns, with units where they are fixed.
fn measured_columns() -> Vec<ColumnSpec> {
    let float = |name: &str| ColumnSpec::new(name, ColumnType::Float).nullable();
    let text = |name: &str| ColumnSpec::new(name, ColumnType::Text);
    let columns = [
        text("window"),
        float("start_s").unit("s"),
        float("end_s").unit("s"),
        text("quantity"),
        text("unit"),
        float("mean"),
        float("std"),
        ColumnSpec::new("n", ColumnType::Integer),
        float("n_eff"),
        float("ci95_low"),
        float("ci95_high"),
        float("u_c"),
        float("k"),
        float("U95"),
        text("shared"),
        text("flags"),
        text("note"),
    ];
    debug_assert_eq!(
        columns.iter().map(|c| c.name.as_str()).collect::<Vec<_>>(),
        MEASURED_HEADER.split(',').collect::<Vec<_>>()
    );
    columns.to_vec()
}

/// The values' rows into `table`, each led by the values of `within` and,
/// when `numbered`, ended by its index.
fn fill_measured(
    table: &mut ParquetTable,
    values: &[MeasuredValue],
    within: &[(&str, &str)],
    numbered: bool,
) -> Result<()> {
    let finite = |v: Option<f64>| v.filter(|v| v.is_finite());
    for (row, v) in values.iter().enumerate() {
        for (column, (_, value)) in within.iter().enumerate() {
            table.text(column, Some(value));
        }
        let o = within.len();
        let s = &v.stats;
        let half = s.ci95_half_width;
        table.text(o, Some(&v.window));
        table.float(o + 1, finite(Some(v.start_s)));
        table.float(o + 2, finite(Some(v.end_s)));
        table.text(o + 3, Some(&v.quantity));
        table.text(o + 4, Some(&v.unit));
        table.float(o + 5, finite(s.mean));
        table.float(o + 6, finite(s.std));
        table.integer(o + 7, Some(i64::try_from(s.n).unwrap_or(i64::MAX)));
        table.float(o + 8, finite((s.n > 0).then_some(s.n_eff)));
        table.float(o + 9, finite(s.mean.zip(half).map(|(m, h)| m - h)));
        table.float(o + 10, finite(s.mean.zip(half).map(|(m, h)| m + h)));
        table.float(o + 11, finite(v.u_c));
        table.float(o + 12, finite(v.k));
        table.float(o + 13, finite(v.expanded_95()));
        table.text(o + 14, Some(&shared_text(&v.budget.shared_errors())));
        table.text(o + 15, Some(&v.flags.join(";")));
        table.text(o + 16, Some(&v.note));
        if numbered {
            table.integer(o + 17, i64::try_from(row).ok());
        }
        table.end_row()?;
    }
    Ok(())
}

/// A budget through serde as its shared parts, `[(source, effect)]` (what
/// a posterior needs beyond `u_c`), read back as
/// [`shared_budget`]'s: one shared contribution per source.
mod shared_parts {
    use acq_metrology::budget::Budget;

    pub fn serialize<S: serde::Serializer>(budget: &Budget, to: S) -> Result<S::Ok, S::Error> {
        use serde::Serialize;
        let parts: Vec<(String, f64)> = budget
            .shared_errors()
            .into_iter()
            .map(|s| (s.source, s.effect))
            .collect();
        parts.serialize(to)
    }

    pub fn deserialize<'de, D: serde::Deserializer<'de>>(from: D) -> Result<Budget, D::Error> {
        use serde::Deserialize;
        let parts = Vec::<(String, f64)>::deserialize(from)?;
        Ok(super::budget_of_shared(parts))
    }
}

/// A budget of shared parts alone: one contribution per source, its sign
/// the sensitivity's.
fn budget_of_shared(parts: Vec<(String, f64)>) -> Budget {
    Budget {
        contributions: parts
            .into_iter()
            .map(|(source, effect)| Contribution {
                sensitivity: if effect < 0.0 { -1.0 } else { 1.0 },
                ..Contribution::direct(&source, effect.abs(), None).shared_by(&source)
            })
            .collect(),
    }
}

/// The `shared` column: `source=effect;...`.
fn shared_text(shared: &[SharedError]) -> String {
    let mut buffer = ryu::Buffer::new();
    shared
        .iter()
        .filter(|s| s.effect.is_finite())
        .map(|s| format!("{}={}", s.source, buffer.format(s.effect)))
        .collect::<Vec<_>>()
        .join(";")
}

/// The budget a `shared` column gives: one shared contribution per source
/// (sensitivity 1, its sign on the uncertainty's side kept as the
/// sensitivity's); the part of the text that is not a `source=number`
/// when it is not.
fn shared_budget(text: &str) -> std::result::Result<Budget, String> {
    let parts = text
        .split(';')
        .filter(|part| !part.trim().is_empty())
        .map(|part| {
            let (source, effect) = part.split_once('=').ok_or_else(|| part.to_string())?;
            let effect: f64 = effect
                .trim()
                .parse()
                .ok()
                .filter(|e: &f64| e.is_finite())
                .ok_or_else(|| part.to_string())?;
            let source = source.trim();
            if source.is_empty() {
                return Err(part.to_string());
            }
            Ok((source.to_string(), effect))
        })
        .collect::<std::result::Result<Vec<_>, String>>()?;
    Ok(budget_of_shared(parts))
}

/// Reads a measured-values file; errors name the file and line.
pub fn read_measured(path: &Path) -> Result<Vec<MeasuredValue>> {
    let columns: Vec<&str> = MEASURED_HEADER.split(',').collect();
    let without_shared: Vec<&str> = MEASURED_HEADER_WITHOUT_SHARED.split(',').collect();
    let older: Vec<&str> = MEASURED_HEADER_WITHOUT_BUDGET.split(',').collect();
    let in_sessions: Vec<&str> = std::iter::once("session")
        .chain(columns.iter().copied())
        .collect();
    let (which, records) =
        read_csv_records_of_any(path, &[&columns, &without_shared, &older, &in_sessions])?;
    // A campaign's table (`acq lake extract`): each row under its session
    // first, its window then named `session/window`.
    let (which, by_session) = match which {
        3 => (0, true),
        other => (other, false),
    };
    // Where the flags and the note are: after the budget's columns, or
    // where they were before them.
    let (has_budget, has_shared) = (which <= 1, which == 0);
    let (flags_at, note_at) = match which {
        0 => (15, 16),
        1 => (14, 15),
        _ => (11, 12),
    };
    let mut values: Vec<MeasuredValue> = Vec::new();
    // (window, quantity) -> the line it was first given on.
    let mut seen: std::collections::HashMap<(String, String), u64> = Default::default();
    for (line, record) in records {
        let (record, window) = if by_session {
            let window = format!("{}/{}", &record[0], &record[1]);
            (record.iter().skip(1).collect::<csv::StringRecord>(), window)
        } else {
            let window = record[0].to_string();
            (record, window)
        };
        let key = (window.clone(), record[3].to_string());
        if let Some(first) = seen.insert(key.clone(), line) {
            return Err(AcqError::Malformed(format!(
                "{}:{line}: {} in window {} is given again (first on line {first}); keep one row per quantity and window",
                path.display(),
                key.1,
                key.0
            )));
        }
        let bad = |what: &str, text: &str| {
            AcqError::Malformed(format!(
                "{}:{line}: expected {what}, found '{text}'",
                path.display()
            ))
        };
        let optional = |index: usize, what: &str| -> Result<Option<f64>> {
            let text = &record[index];
            if text.is_empty() {
                return Ok(None);
            }
            text.parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .map(Some)
                .ok_or_else(|| bad(what, text))
        };
        let required = |index: usize, what: &str| -> Result<f64> {
            optional(index, what)?.ok_or_else(|| bad(what, &record[index]))
        };
        let mean = optional(5, "the mean (a number or empty)")?;
        let low = optional(9, "ci95_low (a number or empty)")?;
        let high = optional(10, "ci95_high (a number or empty)")?;
        let n = record[7]
            .parse::<u64>()
            .map_err(|_| bad("n, a count", &record[7]))?;
        values.push(MeasuredValue {
            window,
            start_s: required(1, "start_s in seconds")?,
            end_s: required(2, "end_s in seconds")?,
            quantity: record[3].to_string(),
            unit: record[4].to_string(),
            stats: WindowStats {
                n,
                mean,
                std: optional(6, "std (a number or empty)")?,
                n_eff: optional(8, "n_eff (a number or empty)")?.unwrap_or(0.0),
                lag1_autocorrelation: 0.0,
                ci95_half_width: low.zip(high).map(|(l, h)| 0.5 * (h - l)),
            },
            flags: record[flags_at]
                .split(';')
                .filter(|f| !f.is_empty())
                .map(str::to_string)
                .collect(),
            note: record[note_at].to_string(),
            budget: if has_shared {
                shared_budget(&record[14]).map_err(|text| {
                    bad("shared errors as sensor=effect;... (a number each)", &text)
                })?
            } else {
                Budget::default()
            },
            u_c: if has_budget {
                optional(11, "u_c (a number or empty)")?
            } else {
                None
            },
            k: if has_budget {
                optional(12, "k (a number or empty)")?
            } else {
                None
            },
        });
    }
    Ok(values)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_keeps_every_field() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("measured.csv");
        let values = vec![
            MeasuredValue {
                window: "hold1".into(),
                start_s: 4.5,
                end_s: 11.5,
                quantity: "sg03".into(),
                unit: "MPa".into(),
                stats: WindowStats {
                    n: 700,
                    mean: Some(17.83),
                    std: Some(0.15),
                    n_eff: 650.5,
                    lag1_autocorrelation: 0.0,
                    ci95_half_width: Some(0.0115),
                },
                flags: vec!["pair:sg04".into(), "noisy".into()],
                note: "differs from sg04, by 76 %".into(),
                budget: Budget::default(),
                u_c: None,
                k: None,
            }
            .with_budget(Budget {
                contributions: vec![
                    acq_metrology::budget::Contribution::direct(
                        "readings_scatter",
                        0.0059,
                        Some(649.5),
                    ),
                    acq_metrology::budget::Contribution::direct("accuracy_class", 0.1, None)
                        .shared_by("sg03"),
                    Contribution {
                        sensitivity: -2.0,
                        ..Contribution::direct("calibration_curve", 0.02, None).shared_by("sg04")
                    },
                ],
            }),
            MeasuredValue {
                window: "hold1".into(),
                start_s: 4.5,
                end_s: 11.5,
                quantity: "dead".into(),
                unit: "bar".into(),
                stats: WindowStats::default(),
                flags: vec!["no_samples".into()],
                note: String::new(),
                budget: Budget::default(),
                u_c: None,
                k: None,
            },
        ];
        write_measured(&path, &values).unwrap();
        assert!(!dir.path().join("measured.csv.partial").exists());
        let back = read_measured(&path).unwrap();
        assert_eq!(back.len(), 2);
        assert_eq!(back[0].flags, values[0].flags);
        assert_eq!(back[0].note, values[0].note);
        assert_eq!(back[0].stats.mean, Some(17.83));
        assert!((back[0].stats.ci95_half_width.unwrap() - 0.0115).abs() < 1e-12);
        assert_eq!(back[1].stats.mean, None);
        assert!(!back[1].is_usable());
        // The budget's u_c and k round-trip (shortest round-trip text); its
        // sources stay with the run that computed them.
        assert_eq!((back[0].u_c, back[0].k), (values[0].u_c, values[0].k));
        assert_eq!(back[0].expanded_95(), values[0].expanded_95());
        assert_eq!((back[1].u_c, back[1].k), (None, None));
        // The shared parts come back, each sensor's with its sign.
        assert_eq!(
            back[0].budget.shared_errors(),
            values[0].budget.shared_errors()
        );
        assert_eq!(back[0].budget.shared_errors()[1].effect, -0.04);
        assert!(back[1].budget.shared_errors().is_empty());
        let text = std::fs::read_to_string(&path).unwrap();
        assert!(!text.contains("NaN"));
    }

    #[test]
    fn a_file_written_before_the_budget_columns_reads_as_before() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("measured.csv");
        std::fs::write(
            &path,
            format!("{MEASURED_HEADER_WITHOUT_BUDGET}\nhold1,0,1,p,bar,10,0.5,100,100,9.9,10.1,stuck,a note\n"),
        )
        .unwrap();
        let back = read_measured(&path).unwrap();
        assert_eq!(back[0].stats.mean, Some(10.0));
        assert_eq!(back[0].flags, vec!["stuck".to_string()]);
        assert_eq!(back[0].note, "a note");
        assert_eq!(back[0].u_c, None);
    }

    proptest::proptest! {
        /// Whatever follows the header, reading returns values or an error
        /// naming the file; it never panics and never yields a NaN.
        #[test]
        fn any_text_reads_or_fails_cleanly(body in "[a-z0-9,.;\"\\n -]{0,300}") {
            let dir = tempfile::tempdir().unwrap();
            let path = dir.path().join("m.csv");
            std::fs::write(&path, format!("{MEASURED_HEADER}\n{body}")).unwrap();
            match read_measured(&path) {
                Ok(values) => {
                    for v in values {
                        proptest::prop_assert!(v.stats.mean.is_none_or(f64::is_finite));
                    }
                }
                Err(e) => proptest::prop_assert!(e.to_string().contains("m.csv")),
            }
        }
    }

    #[test]
    fn a_bad_number_names_file_and_line() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("m.csv");
        std::fs::write(
            &path,
            format!("{MEASURED_HEADER}\nhold1,1,2,p,bar,1.0,0.1,10,10,0.9,1.1,0.03,2.26,0.07,p=0.02,,\nhold1,1,2,q,bar,abc,0.1,10,10,,,,,,,,\n"),
        )
        .unwrap();
        let error = read_measured(&path).unwrap_err().to_string();
        assert!(error.contains("m.csv:3"), "{error}");
        assert!(error.contains("'abc'"), "{error}");
        std::fs::write(
            &path,
            format!("{MEASURED_HEADER}\nhold1,1,2,p,bar,1.0,0.1,10,10,0.9,1.1,0.03,2.26,0.07,p=a lot,,\n"),
        )
        .unwrap();
        let error = read_measured(&path).unwrap_err().to_string();
        assert!(
            error.contains("m.csv:2") && error.contains("'p=a lot'"),
            "{error}"
        );
    }
}
