//! A tensile test's force-displacement curve from the load cell and the
//! extensometer, as the test files calibration reads.
//!
//! 1. Pairing: each force sample with the displacement read (linearly) at
//!    its time; a force sample with no displacement within 3 periods on
//!    either side is dropped.
//! 2. Zero: the median force and displacement over the preload, the points
//!    before the force first reaches 5 % of its maximum (less the last
//!    fifth of them, where the load is already rising). Without 5 preload
//!    points the first point is the zero, and the notes say so.
//! 3. Start: the curve starts at the origin (0, 0) as the test files do,
//!    then the first point whose force is 1 % of the maximum or more; the
//!    preload noise around zero is dropped (a curve MAPE divides by it).
//! 4. Fracture: the first step after the maximum that falls by a third of
//!    10 % of the maximum at once and by 10 % within 3 samples; the curve
//!    ends at the point before that step. No point is smoothed or moved,
//!    so the maximum is exactly the measured one.
//!
//! Columns as in the test files (data/tensile/): DISPLACEMENT [mm],
//! FORCE [kN], STRAIN = u / gauge length, STRESS = F / area [MPa],
//! TRUE_STRAIN = ln(1 + STRAIN), TRUE_STRESS = STRESS (1 + STRAIN) [MPa],
//! the true values only up to the maximum force (empty after it: the
//! deformation is no longer uniform).

use std::path::Path;

use acq_error::Result;
use acq_io::output::Output;
use acq_io::output::{refuse_mf4_table, TableFormat};
use acq_io::parquet_table::{ArrowSink, ColumnSpec, ColumnType, ParquetTable};
use acq_rig::Specimen;

/// Header of the curve file, as in the test files.
pub const CURVE_HEADER: &str = "DISPLACEMENT,FORCE,STRAIN,STRESS,TRUE_STRAIN,TRUE_STRESS";

/// Force drop (fraction of the maximum) within [`FRACTURE_SAMPLES`] that marks fracture.
pub const FRACTURE_DROP_FRACTION: f64 = 0.10;
pub const FRACTURE_SAMPLES: usize = 3;
const PRELOAD_FRACTION: f64 = 0.05;
const START_FRACTION: f64 = 0.01;

/// One point of the curve.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CurvePoint {
    pub displacement_mm: f64,
    pub force_kn: f64,
}

/// The extracted curve and how it was made.
#[derive(Clone, Debug, PartialEq)]
pub struct TensileCurve {
    /// From the origin to the last point before fracture, zeroed.
    pub points: Vec<CurvePoint>,
    /// Index of the maximum force in `points`.
    pub max_index: usize,
    pub force_zero_kn: f64,
    pub displacement_zero_mm: f64,
    /// Zeroed displacement at which the force dropped, if it did.
    pub fracture_displacement_mm: Option<f64>,
    /// Paired points dropped after fracture.
    pub after_fracture: usize,
    /// Force samples without a displacement near them.
    pub unpaired: usize,
    pub notes: Vec<String>,
}

/// Linear reading of a sorted series at `t`, if samples lie within
/// `max_gap_ns` on both sides.
fn read_at(series: &[(i64, f64)], t: i64, max_gap_ns: i64) -> Option<f64> {
    let i = series.partition_point(|&(ts, _)| ts < t);
    if i < series.len() && series[i].0 == t {
        return Some(series[i].1);
    }
    if i == 0 || i == series.len() {
        return None;
    }
    let (t0, v0) = series[i - 1];
    let (t1, v1) = series[i];
    if t1 - t0 > 2 * max_gap_ns || t - t0 > max_gap_ns || t1 - t > max_gap_ns {
        return None;
    }
    Some(v0 + (v1 - v0) * (t - t0) as f64 / (t1 - t0) as f64)
}

fn median(values: &mut [f64]) -> f64 {
    values.sort_by(f64::total_cmp);
    values[values.len() / 2]
}

/// Extracts the curve from force and displacement samples (sorted by time).
pub fn extract_curve(
    force: &[(i64, f64)],
    displacement: &[(i64, f64)],
    displacement_max_gap_ns: i64,
) -> std::result::Result<TensileCurve, String> {
    let mut unpaired = 0;
    let paired: Vec<CurvePoint> = force
        .iter()
        .filter_map(
            |&(t, f)| match read_at(displacement, t, displacement_max_gap_ns) {
                Some(u) => Some(CurvePoint {
                    displacement_mm: u,
                    force_kn: f,
                }),
                None => {
                    unpaired += 1;
                    None
                }
            },
        )
        .collect();
    if paired.len() < 10 {
        return Err(format!(
            "only {} force samples have a displacement beside them; is the extensometer in the recording?",
            paired.len()
        ));
    }
    let mut notes = Vec::new();
    let raw_max = paired
        .iter()
        .map(|p| p.force_kn)
        .fold(f64::NEG_INFINITY, f64::max);
    let first_loaded = paired
        .iter()
        .position(|p| p.force_kn - paired[0].force_kn.min(0.0) >= PRELOAD_FRACTION * raw_max)
        .unwrap_or(0);
    let preload = &paired[..first_loaded * 4 / 5];
    let (force_zero_kn, displacement_zero_mm) = if preload.len() >= 5 {
        (
            median(&mut preload.iter().map(|p| p.force_kn).collect::<Vec<_>>()),
            median(
                &mut preload
                    .iter()
                    .map(|p| p.displacement_mm)
                    .collect::<Vec<_>>(),
            ),
        )
    } else {
        notes.push("no preload before the load rises: zeroed at the first point".into());
        (paired[0].force_kn, paired[0].displacement_mm)
    };
    let zeroed: Vec<CurvePoint> = paired
        .iter()
        .map(|p| CurvePoint {
            displacement_mm: p.displacement_mm - displacement_zero_mm,
            force_kn: p.force_kn - force_zero_kn,
        })
        .collect();
    let (max_at, max_force) = zeroed
        .iter()
        .enumerate()
        .map(|(i, p)| (i, p.force_kn))
        .fold((0, f64::NEG_INFINITY), |best, (i, f)| {
            if f > best.1 {
                (i, f)
            } else {
                best
            }
        });
    if max_force <= 0.0 {
        return Err(
            "the force never rises above its zero: is the load cell the force sensor?".into(),
        );
    }
    let start = zeroed
        .iter()
        .position(|p| p.force_kn >= START_FRACTION * max_force)
        .unwrap_or(0);
    // Fracture: the first drop of more than 10 % of the maximum within 3 samples.
    let drop = FRACTURE_DROP_FRACTION * max_force;
    // It starts with one steep step (a third of that at least), which the
    // gradual fall of necking never makes.
    let fracture = (max_at + 1..zeroed.len()).find(|&i| {
        let before = zeroed[i - 1].force_kn;
        before - zeroed[i].force_kn > drop / FRACTURE_SAMPLES as f64
            && zeroed[i..(i + FRACTURE_SAMPLES).min(zeroed.len())]
                .iter()
                .any(|p| before - p.force_kn > drop)
    });
    let end = match fracture {
        Some(i) => i,
        None => {
            notes.push(
                "no fracture (final force drop) found: the curve runs to the end of the recording"
                    .into(),
            );
            zeroed.len()
        }
    };
    let mut points = Vec::with_capacity(end - start + 1);
    points.push(CurvePoint {
        displacement_mm: 0.0,
        force_kn: 0.0,
    });
    points.extend_from_slice(&zeroed[start..end]);
    Ok(TensileCurve {
        max_index: max_at - start + 1,
        points,
        force_zero_kn,
        displacement_zero_mm,
        fracture_displacement_mm: fracture.map(|i| zeroed[i - 1].displacement_mm),
        after_fracture: zeroed.len() - end,
        unpaired,
        notes,
    })
}

/// Writes the curve with the test files' columns: CSV, or Parquet for a
/// `.parquet` path (units in the column metadata).
/// The curve's columns as Parquet and Arrow tables give them: the CSV's,
/// with units.
fn curve_columns() -> Vec<ColumnSpec> {
    CURVE_HEADER
        .split(',')
        .zip(["mm", "kN", "", "MPa", "", "MPa"])
        .map(|(name, unit)| {
            ColumnSpec::new(name, ColumnType::Float)
                .unit(unit)
                .nullable()
        })
        .collect()
}

/// The curve's rows into `table`, which is then finished: true strain and
/// stress only up to the maximum force (uniform elongation).
fn fill_curve(mut table: ParquetTable, curve: &TensileCurve, specimen: &Specimen) -> Result<()> {
    for (i, p) in curve.points.iter().enumerate() {
        let strain = p.displacement_mm / specimen.gauge_length_mm;
        let stress = p.force_kn * 1000.0 / specimen.area_mm2();
        let uniform = i <= curve.max_index;
        table.float(0, Some(p.displacement_mm));
        table.float(1, Some(p.force_kn));
        table.float(2, Some(strain));
        table.float(3, Some(stress));
        table.float(4, uniform.then(|| (1.0 + strain).ln()));
        table.float(5, uniform.then_some(stress * (1.0 + strain)));
        table.end_row()?;
    }
    table.finish().map(|_| ())
}

/// The curve `acq extract --tensile -o FILE.parquet` writes, as Arrow
/// record batches handed to `sink`.
pub fn curve_to_arrow(
    curve: &TensileCurve,
    specimen: &Specimen,
    sink: Box<dyn ArrowSink>,
) -> Result<()> {
    fill_curve(
        ParquetTable::to_arrow(&curve_columns(), &[], sink)?,
        curve,
        specimen,
    )
}

pub fn write_curve(path: &Path, curve: &TensileCurve, specimen: &Specimen) -> Result<()> {
    refuse_mf4_table(path, "curve")?;
    let mut output = Output::create_complete_only(path)?;
    if TableFormat::of(path) == TableFormat::Parquet {
        let table = ParquetTable::new(output, &curve_columns(), &[])?;
        return fill_curve(table, curve, specimen);
    }
    let mut text = String::with_capacity(96 * (curve.points.len() + 1));
    text.push_str(CURVE_HEADER);
    text.push('\n');
    let mut buffer = ryu::Buffer::new();
    for (i, p) in curve.points.iter().enumerate() {
        let strain = p.displacement_mm / specimen.gauge_length_mm;
        let stress = p.force_kn * 1000.0 / specimen.area_mm2();
        let mut fields = vec![p.displacement_mm, p.force_kn, strain, stress];
        if i <= curve.max_index {
            fields.push((1.0 + strain).ln());
            fields.push(stress * (1.0 + strain));
        }
        for (k, v) in fields.iter().enumerate() {
            if k > 0 {
                text.push(',');
            }
            text.push_str(buffer.format(*v));
        }
        if i > curve.max_index {
            text.push_str(",,");
        }
        text.push('\n');
    }
    output.buffer.extend_from_slice(text.as_bytes());
    output.finish()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn zeroes_trims_at_the_drop_and_keeps_the_maximum() {
        // Preload 1 s at offset (0.3 kN, 0.02 mm), then a hump to 7.46 kN,
        // then fracture: the force falls to 0 in two samples.
        let period = 20_000_000;
        let mut force = Vec::new();
        let mut displacement = Vec::new();
        for i in 0..400i64 {
            let t = i * period;
            let u = if i < 50 { 0.0 } else { (i - 50) as f64 * 0.01 };
            let f = match i {
                i if i < 50 => 0.0,
                i if i < 300 => 7.46 * (1.0 - ((u - 1.25) / 1.25).powi(2)) + 2.0 * (u / 2.5),
                300 => 2.0,
                _ => 0.0,
            };
            force.push((t, f + 0.3));
            displacement.push((t + period / 2, u + 0.02));
        }
        let curve = extract_curve(&force, &displacement, 3 * period).unwrap();
        assert!((curve.force_zero_kn - 0.3).abs() < 1e-12);
        assert!((curve.displacement_zero_mm - 0.02).abs() < 1e-12);
        assert_eq!(
            curve.points[0],
            CurvePoint {
                displacement_mm: 0.0,
                force_kn: 0.0
            }
        );
        let last = curve.points.last().unwrap();
        // The last point before the steep step: i = 300 (2.0 kN -> 0).
        assert!((last.displacement_mm - 2.50).abs() < 0.006, "{last:?}");
        assert!((last.force_kn - 2.0).abs() < 1e-12, "{last:?}");
        let max_raw = force.iter().map(|f| f.1).fold(0.0, f64::max) - 0.3;
        assert_eq!(curve.points[curve.max_index].force_kn, max_raw);
        assert_eq!(curve.after_fracture, 99);
        assert!(curve.notes.is_empty(), "{:?}", curve.notes);
    }

    #[test]
    fn refuses_a_recording_without_displacement() {
        let force: Vec<(i64, f64)> = (0..100).map(|i| (i * 10, 1.0)).collect();
        assert!(extract_curve(&force, &[], 30)
            .unwrap_err()
            .contains("extensometer"));
    }
}
