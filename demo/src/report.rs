//! The demo's report: the sessions (sensors, rates, gaps, flags), the
//! measured values, the calibrations with their plots. One document, written
//! as `report.md` and as the self-contained `report.html`.

use std::path::Path;

use acq_error::{AcqError, Result};
use acq_io::output::Output;
use acq_report::document::{Document, Figure, Table};
use acq_report::plot::{chart_svg, grid_svg, Chart, Series};

use super::{Analysis, SessionResult, Step};

fn largest(values: &[f64]) -> f64 {
    values.iter().fold(0.0f64, |a, &b| a.max(b))
}

fn optional(value: Option<f64>, digits: usize) -> String {
    value.map_or_else(String::new, |v| format!("{v:.digits$}"))
}

pub fn build(
    results: &[SessionResult],
    steps: &[Step],
    bus: &str,
    wall_s: f64,
    out: &Path,
) -> Result<Document> {
    let mut doc = Document::new();
    doc.heading(1, "acq demo: from recorded CAN sessions to calibrated twins")
        .paragraph(format!(
            "The three shipped sessions (`fixtures/sessions/`: two load cases of a DX55-class excavator \
             front attachment and a tensile test of a P91 round bar) were played on {bus} in real time, \
             recorded again, aligned, extracted and used to calibrate the excavator twin and the GTN \
             damage model of the bar. {:.1} s in all.",
            wall_s
        ));

    at_a_glance(&mut doc, results, steps);
    sessions_table(&mut doc, results);
    for r in results {
        session_section(&mut doc, r, out)?;
    }
    measured_values(&mut doc, results);
    measurement_chain(&mut doc, results);
    // Calibrations.
    for r in results {
        let directory = format!("{}/calibration", r.name);
        doc.heading(2, format!("Calibration: {}", r.name)).paragraph(format!(
            "Run directory `{directory}`: every model run in `evaluations.csv`, the fixed numbers in \
             `summary.json`, this section as `report.md` / `report.html`."
        ));
        let report = match &r.analysis {
            Analysis::Excavator { calibration, .. } => &calibration.report,
            Analysis::Tensile { calibration, .. } => &calibration.report,
        };
        doc.include(report, 2, &directory);
    }
    Ok(doc)
}

/// The results at a glance, and where the time went.
fn at_a_glance(doc: &mut Document, results: &[SessionResult], steps: &[Step]) {
    doc.heading(2, "Results at a glance");
    let mut table = Table::new(&[
        "session",
        "twin",
        "calibrated against",
        "before",
        "after",
        "model runs",
    ]);
    for r in results {
        match &r.analysis {
            Analysis::Excavator { calibration, .. } => table.row(vec![
                r.name.clone(),
                "excavator front attachment".into(),
                format!(
                    "3 loaded-chamber pressures, tip force {:.2} kN (measured)",
                    calibration.force_kn
                ),
                format!(
                    "largest error {:.2} %",
                    largest(&calibration.errors_initial_pct)
                ),
                format!(
                    "largest error {:.2} %",
                    largest(&calibration.errors_optimal_pct)
                ),
                calibration.evaluations.to_string(),
            ]),
            Analysis::Tensile { curve, calibration } => table.row(vec![
                r.name.clone(),
                "GTN tensile bar (6x30 elements)".into(),
                format!(
                    "force-displacement curve, {} points",
                    curve.curve.points.len()
                ),
                "L12 start".into(),
                format!("MAPE {:.3} %", calibration.best_mape_pct),
                calibration.evaluations.to_string(),
            ]),
        }
    }
    doc.table(table);
    let mut table = Table::new(&["step", "wall time [s]"]);
    for step in steps {
        table.row(vec![step.name.clone(), format!("{:.2}", step.wall_s)]);
    }
    doc.paragraph("Where the time went:").table(table);
}

/// Each session's duration, frames and interfaces.
fn sessions_table(doc: &mut Document, results: &[SessionResult]) {
    doc.heading(2, "Sessions");
    let mut table = Table::new(&[
        "session",
        "duration [s]",
        "frames sent",
        "frames recorded",
        "dropped by the kernel",
        "replay timing error p99 [us]",
        "sensors",
        "interfaces",
    ]);
    for r in results {
        let info = &r.session.session;
        let duration = info
            .stopped_unix_ns
            .map(|stop| (stop - info.started_unix_ns) as f64 / 1e9);
        table.row(vec![
            r.name.clone(),
            optional(duration, 1),
            r.played
                .as_ref()
                .map_or_else(String::new, |p| p.frames_sent.to_string()),
            info.frames.to_string(),
            info.dropped_by_kernel.to_string(),
            r.played
                .as_ref()
                .and_then(|p| p.timing_error_us)
                .map_or_else(String::new, |(_, p99, _)| format!("{p99:.0}")),
            r.session.sensor.len().to_string(),
            r.session
                .interface
                .iter()
                .map(|i| {
                    format!(
                        "{} ({} frames, {} error frames)",
                        i.name, i.frames, i.error_frames
                    )
                })
                .collect::<Vec<_>>()
                .join(", "),
        ]);
    }
    doc.table(table);
}

/// The measured values of every excavator hold.
fn measured_values(doc: &mut Document, results: &[SessionResult]) {
    for r in results {
        if let Analysis::Excavator { holds, .. } = &r.analysis {
            doc.heading(2, format!("Measured values: {}", r.name));
            for window in &holds.windows {
                doc.paragraph(format!(
                    "Hold `{}` from {:.2} s to {:.2} s after the session start (found on the load `{}`); \
                     file `{}/measured.csv`.",
                    window.name,
                    (window.start_ns - holds.t0_ns) as f64 / 1e9,
                    (window.end_ns - holds.t0_ns) as f64 / 1e9,
                    holds.load_sensor,
                    r.name
                ));
                let mut table = Table::new(&[
                    "quantity",
                    "unit",
                    "mean",
                    "std",
                    "n",
                    "n_eff",
                    "95 % interval",
                    "u_c",
                    "k",
                    "U95",
                    "flags",
                    "note",
                ]);
                for v in holds.values.iter().filter(|v| v.window == window.name) {
                    let s = &v.stats;
                    table.row(vec![
                        v.quantity.clone(),
                        v.unit.clone(),
                        optional(s.mean, 3),
                        optional(s.std, 3),
                        s.n.to_string(),
                        format!("{:.0}", s.n_eff),
                        match (s.mean, s.ci95_half_width) {
                            (Some(m), Some(h)) => format!("{:.3} .. {:.3}", m - h, m + h),
                            _ => String::new(),
                        },
                        optional(v.u_c, 4),
                        optional(v.k, 3),
                        optional(v.expanded_95(), 4),
                        v.flags.join(";"),
                        v.note.clone(),
                    ]);
                }
                doc.table(table);
            }
        }
    }
}

/// Each excavator session's measurement chain: where each sensor's
/// calibration comes from (against the day it was recorded), and each
/// hold's budget as a metrology lab presents it: every source's part of the
/// value's uncertainty, its degrees of freedom, its share of the variance
/// and whether it is the same in every hold (shared by a sensor).
fn measurement_chain(doc: &mut Document, results: &[SessionResult]) {
    for r in results {
        let Analysis::Excavator { holds, .. } = &r.analysis else {
            continue;
        };
        let recorded_on = r.session.session.started_utc.get(..10).unwrap_or("");
        doc.heading(2, format!("Measurement chain: {}", r.name));
        doc.paragraph(format!(
            "Each sensor's calibration as the session's rig copy states it, on the day it was recorded ({recorded_on}):"
        ));
        let mut traceability = Table::new(&["calibration"]);
        for line in r.recording.rig.calibration_status(recorded_on) {
            traceability.row(vec![line]);
        }
        doc.table(traceability);
        let mut table = Table::new(&[
            "hold",
            "quantity",
            "value",
            "source",
            "its part of u",
            "dof",
            "share of the variance",
            "same in every hold",
        ]);
        // Past ten thousand the coverage factor is the normal's to 1e-4.
        let dof_text = |dof: Option<f64>| match dof {
            None => "inf".to_string(),
            Some(d) if d > 1e4 => "> 10^4".to_string(),
            Some(d) => format!("{d:.0}"),
        };
        let has_type_b = |v: &&acq_analysis::extract::measured::MeasuredValue| {
            v.budget.contributions.iter().any(|c| c.dof.is_none())
        };
        for v in holds.values.iter().filter(has_type_b) {
            let budget = &v.budget;
            for (c, share) in budget.contributions.iter().zip(budget.variance_shares()) {
                table.row(vec![
                    v.window.clone(),
                    v.quantity.clone(),
                    format!("{} {}", optional(v.stats.mean, 3), v.unit),
                    c.source.clone(),
                    format!("{:.4} {}", c.in_result(), v.unit),
                    dof_text(c.dof),
                    format!("{:.1} %", 100.0 * share),
                    c.shared_by
                        .clone()
                        .map_or("no".into(), |by| format!("yes ({by})")),
                ]);
            }
            table.row(vec![
                v.window.clone(),
                v.quantity.clone(),
                String::new(),
                "combined".into(),
                format!("u_c {} {}", optional(v.u_c, 4), v.unit),
                dof_text(budget.effective_dof()),
                format!(
                    "k {}, U95 {}",
                    optional(v.k, 3),
                    optional(v.expanded_95(), 4)
                ),
                String::new(),
            ]);
        }
        doc.paragraph(concat!(
            "Each value's budget (JCGM 100) where its sensors have a record: the readings' ",
            "scatter (Type A) with each sensor's certificate, accuracy class and resolution ",
            "(Type B); a net force's through both chambers' areas. A part the same in every hold ",
            "is its sensor's: averaging holds does not reduce it, and every posterior takes it ",
            "as one error per sensor. The other values' uncertainty is their scatter alone."
        ));
        doc.table(table);
    }
}

/// One session: its sensors with rates, gaps and flags, and a plot.
fn session_section(doc: &mut Document, r: &SessionResult, out: &Path) -> Result<()> {
    let rig = &r.recording.rig;
    doc.heading(3, format!("Session {}", r.name))
        .paragraph(format!(
        "Recorded in `{}`; rig {} ({} buses, {} sensors). Aligned on 100 rows per second, a sensor \
         silent for more than 3 of its periods is a gap: `{}/aligned.csv`, {} rows.",
        r.dir.display(),
        rig.name,
        rig.buses.len(),
        rig.sensors.len(),
        r.name,
        r.aligned.rows
    ));
    let mut table = Table::new(&[
        "sensor",
        "kind",
        "unit",
        "bus",
        "protocol",
        "expected [Hz]",
        "observed [Hz]",
        "samples",
        "gaps",
        "longest gap [s]",
    ]);
    for sensor in &rig.sensors {
        let record = r.session.sensor.iter().find(|s| s.name == sensor.name);
        let stats = r
            .aligned
            .sensors
            .iter()
            .position(|s| *s == sensor.name)
            .map(|i| &r.aligned.channels[i]);
        table.row(vec![
            sensor.name.clone(),
            sensor.kind.name().to_string(),
            sensor.unit().to_string(),
            rig.buses[sensor.bus].name.clone(),
            sensor.source.protocol().to_string(),
            format!("{}", sensor.rate_hz),
            optional(record.map(|s| s.observed_rate_hz), 2),
            record.map_or_else(String::new, |s| s.samples.to_string()),
            stats.map_or_else(String::new, |s| s.gaps.to_string()),
            stats.map_or_else(String::new, |s| {
                if s.gaps > 0 {
                    format!("{:.3}", s.longest_gap_ns as f64 / 1e9)
                } else {
                    String::new()
                }
            }),
        ]);
    }
    doc.table(table);
    let problems = r.aligned.problems();
    if problems.is_empty() {
        doc.paragraph("Alignment: no sensor missing, no gap, no sample out of order.");
    } else {
        doc.paragraph("Alignment found:").list(problems);
    }
    if let Analysis::Excavator { holds, .. } = &r.analysis {
        let flagged: Vec<String> = holds
            .values
            .iter()
            .filter(|v| !v.flags.is_empty())
            .map(|v| {
                format!(
                    "{} in {}: `{}`: {}",
                    v.quantity,
                    v.window,
                    v.flags.join(";"),
                    v.note
                )
            })
            .collect();
        if flagged.is_empty() {
            doc.paragraph("Flagged values: none.");
        } else {
            doc.paragraph("Flagged values (not fit to use; the calibration does not use them):")
                .list(flagged);
        }
    }
    if let Some(figure) = signals_figure(r, out)? {
        doc.figure(figure);
    }
    Ok(())
}

/// The columns `names` ("name [unit]") of an aligned file, as (time, value).
fn aligned_columns(path: &Path, names: &[&str]) -> Result<Vec<Vec<(f64, f64)>>> {
    let text = std::fs::read_to_string(path).map_err(|e| AcqError::open(path, e))?;
    let mut lines = text.lines().filter(|l| !l.starts_with('#'));
    let header: Vec<&str> = lines.next().unwrap_or("").split(',').collect();
    let columns: Vec<Option<usize>> = names
        .iter()
        .map(|n| header.iter().position(|h| h.starts_with(&format!("{n} ["))))
        .collect();
    let mut series = vec![Vec::new(); names.len()];
    // Every 5th row (20 per second) is plenty for a plot.
    for line in lines.step_by(5) {
        let cells: Vec<&str> = line.split(',').collect();
        let Some(time) = cells.first().and_then(|t| t.parse::<f64>().ok()) else {
            continue;
        };
        for (column, points) in columns.iter().zip(&mut series) {
            if let Some(value) = column
                .and_then(|c| cells.get(c))
                .and_then(|v| v.parse::<f64>().ok())
            {
                points.push((time, value));
            }
        }
    }
    Ok(series)
}

/// Load and main channels over the session.
fn signals_figure(r: &SessionResult, out: &Path) -> Result<Option<Figure>> {
    let aligned = out.join(&r.name).join("aligned.csv");
    let panels: Vec<(&str, &str, Vec<&str>)> = match r.analysis {
        Analysis::Excavator { .. } => vec![
            ("load at the bucket tip", "force [kN]", vec!["tip_force"]),
            (
                "head-chamber pressures",
                "pressure [bar]",
                vec![
                    "bucket_head_pressure",
                    "arm_head_pressure",
                    "boom_head_pressure",
                ],
            ),
        ],
        Analysis::Tensile { .. } => vec![
            ("load cell", "force [kN]", vec!["load"]),
            ("extensometer", "displacement [mm]", vec!["extension"]),
        ],
    };
    let mut charts = Vec::new();
    for (title, axis, names) in panels {
        let series = aligned_columns(&aligned, &names)?;
        let mut chart = Chart::new(title, "time from the session start [s]", axis);
        for (name, points) in names.iter().zip(series) {
            if !points.is_empty() {
                chart = chart.with_series(Series::new(*name, points));
            }
        }
        charts.push(chart);
    }
    if charts.is_empty() {
        return Ok(None);
    }
    let title = format!("{}: signals on the aligned time base", r.name);
    let svg = if charts.len() == 1 {
        chart_svg(&charts[0], 720.0, 360.0)
    } else {
        grid_svg(&title, &charts, 2, 460.0, 320.0)
    };
    Ok(Some(Figure {
        file: format!("{}/signals.svg", r.name),
        caption: title,
        svg,
    }))
}

/// Writes the figures, `report.md` and `report.html` into `out`.
pub fn write(out: &Path, doc: &Document) -> Result<()> {
    for figure in doc.figures() {
        Output::write_complete(&out.join(&figure.file), figure.svg.as_bytes())?;
    }
    Output::write_complete(&out.join("report.md"), doc.to_markdown().as_bytes())?;
    Output::write_complete(
        &out.join("report.html"),
        doc.to_html("acq demo report").as_bytes(),
    )
}
