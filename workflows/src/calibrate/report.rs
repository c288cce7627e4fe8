//! What a calibration leaves for its reader: the report (Markdown and HTML)
//! and the plots (Pareto front with the pick, loss per evaluation).

use std::path::Path;

use acq_io::error::Result;
use acq_io::output::Output;
use acq_report::document::Document;
use acq_report::plot::{chart_svg, grid_svg, Chart, Series, SeriesStyle};

use super::run_directory::RunDirectory;

/// Writes a whole file (appears under its name only when complete).
pub fn write_text(path: &Path, text: &str) -> Result<()> {
    Output::write_complete(path, text.as_bytes())
}

/// Writes a report into its run directory: every figure as its SVG file,
/// `report.md` (figures linked) and `report.html` (one page, figures inline).
pub fn write_report(directory: &RunDirectory, report: &Document, title: &str) -> Result<()> {
    for figure in report.figures() {
        write_text(&directory.file(&figure.file), &figure.svg)?;
    }
    write_text(&directory.file("report.md"), &report.to_markdown())?;
    write_text(&directory.file("report.html"), &report.to_html(title))
}

/// The Pareto front as scatter plots of each pair of objectives, the pick
/// marked. One chart for two objectives, three for three.
pub fn pareto_svg(title: &str, names: &[&str], front: &[Vec<f64>], pick: usize) -> String {
    let objectives = names.len();
    let pairs: Vec<(usize, usize)> = (0..objectives)
        .flat_map(|a| (a + 1..objectives).map(move |b| (a, b)))
        .collect();
    let charts: Vec<Chart> = pairs
        .iter()
        .map(|&(a, b)| {
            let points = front.iter().map(|f| (f[a], f[b])).collect();
            let chosen = front
                .get(pick)
                .map(|f| vec![(f[a], f[b])])
                .unwrap_or_default();
            Chart::new(format!("{} vs {}", names[b], names[a]), names[a], names[b])
                .with_series(Series::new("Pareto front", points).with_style(SeriesStyle::Markers))
                .with_series(Series::new("pick", chosen).with_style(SeriesStyle::Markers))
        })
        .collect();
    if charts.len() == 1 {
        chart_svg(&charts[0], 640.0, 440.0)
    } else {
        grid_svg(title, &charts, charts.len().min(3), 420.0, 340.0)
    }
}
