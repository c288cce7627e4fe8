//! What a calibration leaves for its reader: Markdown tables and the plots
//! (Pareto front with the pick, loss per evaluation).

use std::path::Path;

use crate::error::Result;
use crate::output::Output;
use crate::plot::{chart_svg, grid_svg, Chart, Series, SeriesStyle};

/// Writes a whole file (appears under its name only when complete).
pub fn write_text(path: &Path, text: &str) -> Result<()> {
    Output::write_complete(path, text.as_bytes())
}

/// A Markdown table built row by row.
pub struct MarkdownTable {
    header: Vec<String>,
    rows: Vec<Vec<String>>,
}

impl MarkdownTable {
    pub fn new(header: &[&str]) -> Self {
        MarkdownTable {
            header: header.iter().map(|h| h.to_string()).collect(),
            rows: Vec::new(),
        }
    }

    pub fn row(&mut self, cells: Vec<String>) {
        self.rows.push(cells);
    }

    pub fn render(&self) -> String {
        let line = |cells: &[String]| format!("| {} |\n", cells.join(" | "));
        let mut text = line(&self.header);
        text.push_str(&line(&vec!["---".to_string(); self.header.len()]));
        for row in &self.rows {
            text.push_str(&line(row));
        }
        text
    }
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
                .with_series(Series::new("TOPSIS pick", chosen).with_style(SeriesStyle::Markers))
        })
        .collect();
    if charts.len() == 1 {
        chart_svg(&charts[0], 640.0, 440.0)
    } else {
        grid_svg(title, &charts, charts.len().min(3), 420.0, 340.0)
    }
}
