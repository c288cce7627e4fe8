//! Where each table's files go in the lake, and the names of its parts.
//!
//! Partition values are path segments, `key=value`, as Hive, Spark,
//! DuckDB, Polars and DataFusion read them: a value keeps letters, digits
//! and `-_.`; anything else becomes `_`, so a sensor or device name can
//! never leave its directory or split a partition.

use std::path::{Path, PathBuf};

/// The table of decoded samples: one row per sample.
pub const SAMPLES: &str = "samples";
/// The table of holds found in each source.
pub const HOLDS: &str = "holds";
/// The table of measured values per hold, with their uncertainty budgets.
pub const MEASURED: &str = "measured";
/// The tables a lake holds, by the names queries use.
pub const TABLES: [&str; 3] = [SAMPLES, HOLDS, MEASURED];
/// One JSON entry per source, published last.
pub const MANIFEST_DIR: &str = "_manifest";
/// Files being written; engines skip names that start with `_`.
pub const TMP_DIR: &str = "_tmp";
/// One directory per slice of a backlog ingested as Slurm jobs: its job
/// script, its list of sources, the ingest's output.
pub const SLURM_DIR: &str = "_slurm";

/// `value` as a partition value or file name: path-safe, never empty.
pub fn partition_value(value: &str) -> String {
    let safe: String = value
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || "-_.".contains(c) {
                c
            } else {
                '_'
            }
        })
        .collect();
    match safe.trim_start_matches('.') {
        "" => "_".to_string(),
        rest => rest.to_string(),
    }
}

/// The UTC date of `unix_ns`, `YYYY-MM-DD` (an instant before 1970, a
/// log without absolute time, is dated 1970-01-01).
pub fn utc_date(unix_ns: i64) -> String {
    acq_io::session::utc_text(unix_ns)[..10].to_string()
}

/// The file of source `id` in the samples of `device`'s `sensor` on `date`,
/// relative to the lake.
pub fn samples_file(device: &str, sensor: &str, date: &str, id: &str) -> PathBuf {
    Path::new(SAMPLES)
        .join(format!("device={}", partition_value(device)))
        .join(format!("sensor={}", partition_value(sensor)))
        .join(format!("date={date}"))
        .join(format!("{id}.parquet"))
}

/// The file of source `id` in table `table` (holds, measured) of `device`.
pub fn table_file(table: &str, device: &str, id: &str) -> PathBuf {
    Path::new(table)
        .join(format!("device={}", partition_value(device)))
        .join(format!("{id}.parquet"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dates_match_the_calendar() {
        assert_eq!(utc_date(0), "1970-01-01");
        assert_eq!(utc_date(-1), "1970-01-01");
        // 2000-02-29 (a leap day of a century divisible by 400) and the next day.
        assert_eq!(utc_date(951_782_400_000_000_000), "2000-02-29");
        assert_eq!(utc_date(951_868_800_000_000_000), "2000-03-01");
        // The shipped excavator session: 2026-11-21T21:12:43Z.
        assert_eq!(utc_date(1_795_295_563_542_744_620), "2026-11-21");
        // 2100 is no leap year: 2100-02-28 is followed by 2100-03-01.
        assert_eq!(utc_date(4_107_456_000_000_000_000), "2100-02-28");
        assert_eq!(utc_date(4_107_542_400_000_000_000), "2100-03-01");
    }

    #[test]
    fn partition_values_stay_in_their_directory() {
        assert_eq!(partition_value("boom_head_pressure"), "boom_head_pressure");
        assert_eq!(partition_value("../x=y/z"), "_x_y_z");
        assert_eq!(partition_value(""), "_");
        assert_eq!(partition_value(".."), "_");
        assert_eq!(partition_value("DX55 #2"), "DX55__2");
    }
}
