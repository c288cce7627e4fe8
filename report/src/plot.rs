//! Dependency-free SVG line charts for engineers.
//!
//! Used by `acq sensitivity` (one-at-a-time sweeps: a grid of small panels,
//! one per model output, one line per swept input, see [`grid_svg`]) and by
//! the HTML test report (force-displacement curves measured vs simulated,
//! convergence histories, Pareto fronts as scatter, see [`chart_svg`]).
//!
//! Every chart gets linear axes with "nice" 1-2-5 ticks whose labels carry no
//! float noise (`0.3`, never `0.30000000000000004`; scientific notation for
//! very large or very small magnitudes), axis labels (put the unit in them:
//! `"force [kN]"`), a title, a legend, the Okabe-Ito colour-blind-safe palette
//! with a distinct marker shape per series, optional dashed lines and
//! markers, and labelled horizontal reference lines ("measured 116.9 bar").
//!
//! The output is a standalone SVG document: well-formed XML with `xmlns`,
//! `viewBox`, `width` and `height`, and no XML declaration, so the same string
//! can be saved as a `.svg` file or inlined into HTML. It uses no `id`s, so
//! several charts inlined into one page cannot collide. Coordinates are
//! written with at most two decimals to keep files small.
//!
//! No input panics: non-finite values are skipped and split a line into
//! segments (a visible gap), empty and degenerate ranges are padded, sizes
//! are clamped, and all text is XML-escaped (characters XML cannot carry are
//! dropped).
//!
//! Deliberately not done: log, date or secondary axes; bars, histograms and
//! colour maps; interactivity; real text measurement (widths are estimated
//! from the character count, so long titles and labels are cut with an
//! ellipsis rather than laid out exactly); label collision avoidance; and
//! decimation (every finite point is written, so thin out huge series before
//! plotting). Values beyond ±1e300 are drawn off-scale.

use std::fmt::{self, Write};

/// `write!` into a `String`, which cannot fail.
macro_rules! w {
    ($out:expr, $($arg:tt)*) => {{
        let _ = write!($out, $($arg)*);
    }};
}

/// Okabe-Ito, ordered so the first colours contrast best on white (the
/// yellow comes last for that reason).
const PALETTE: [&str; 8] = [
    "#0072B2", "#D55E00", "#009E73", "#CC79A7", "#E69F00", "#56B4E9", "#000000", "#F0E442",
];
/// Dash patterns for lines once the palette has been used up, so the ninth
/// series is not mistaken for the first.
const REPEAT_DASHES: [&str; 2] = ["2 3", "10 3 2 3"];
const DASHED: &str = "6 4";

const FONT_FAMILY: &str = "Helvetica, Arial, sans-serif";
const FONT_TICK: f64 = 10.0;
const FONT_LABEL: f64 = 11.0;
const FONT_TITLE: f64 = 13.0;
const FONT_GRID_TITLE: f64 = 16.0;
/// Average advance of a sans-serif glyph in em; a slight overestimate, so
/// estimated text rather overflows its budget on paper than on screen.
const CHAR_WIDTH: f64 = 0.6;

const PAD: f64 = 6.0;
const TICK_LEN: f64 = 4.0;
const LINE_WIDTH: f64 = 1.6;
const MARKER_RADIUS: f64 = 3.0;
const LEGEND_ROW: f64 = 16.0;
const LEGEND_SWATCH: f64 = 22.0;
const LEGEND_GAP: f64 = 14.0;
/// The data area is clipped this far outside the frame, so markers and
/// line caps on the axis limits are drawn whole.
const CLIP_MARGIN: f64 = MARKER_RADIUS + 2.0;
const MIN_PLOT: f64 = 10.0;
const MIN_SIZE: f64 = 60.0;
const MAX_SIZE: f64 = 100_000.0;

/// Pixel coordinates are clamped to this, so a point far off-scale still
/// writes a short number (it is clipped away anyway).
const PX_LIMIT: f64 = 1e6;
/// Data magnitudes beyond this are treated as off-scale, which keeps every
/// tick and span finite.
const MAGNITUDE_LIMIT: f64 = 1e300;
/// Spans below this (absolute, or relative to the values) cannot be ticked
/// meaningfully, so they are padded as if all values were equal.
const TINY_SPAN: f64 = 1e-280;
const TINY_RELATIVE_SPAN: f64 = 1e-9;
/// [`nice_ticks`] needs at least 3 ticks to cover a range around zero with a
/// 1-2-5 step (-1, 0, 1); more than a few hundred is never useful.
const MIN_TICKS: usize = 3;
const MAX_TICKS: usize = 500;

/// How a series is drawn.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum SeriesStyle {
    #[default]
    Line,
    Dashed,
    /// Points only, for scatter plots such as Pareto fronts.
    Markers,
    LineAndMarkers,
}

impl SeriesStyle {
    fn has_line(self) -> bool {
        !matches!(self, SeriesStyle::Markers)
    }

    fn has_markers(self) -> bool {
        matches!(self, SeriesStyle::Markers | SeriesStyle::LineAndMarkers)
    }
}

/// One named set of points.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Series {
    /// Legend text; a blank name keeps the series out of the legend.
    pub name: String,
    /// `(x, y)` in drawing order, which is kept (hysteresis loops and Pareto
    /// fronts need it). A point with a non-finite coordinate leaves a gap.
    pub points: Vec<(f64, f64)>,
    pub style: SeriesStyle,
}

impl Series {
    /// A solid line through `points`.
    pub fn new(name: impl Into<String>, points: Vec<(f64, f64)>) -> Self {
        Series {
            name: name.into(),
            points,
            style: SeriesStyle::Line,
        }
    }

    pub fn with_style(mut self, style: SeriesStyle) -> Self {
        self.style = style;
        self
    }
}

/// A labelled horizontal line at `y = value`, e.g. a measured target.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ReferenceLine {
    pub value: f64,
    pub label: String,
}

impl ReferenceLine {
    pub fn new(value: f64, label: impl Into<String>) -> Self {
        ReferenceLine {
            value,
            label: label.into(),
        }
    }
}

/// One panel: title, axis labels (with units), series and reference lines.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Chart {
    pub title: String,
    pub x_label: String,
    pub y_label: String,
    pub series: Vec<Series>,
    /// Fixed x limits; `None` (or an unusable range) fits the data and
    /// widens it to the outer ticks.
    pub x_range: Option<(f64, f64)>,
    /// Fixed y limits, as `x_range`. Reference lines count as data when
    /// fitting.
    pub y_range: Option<(f64, f64)>,
    pub reference_lines: Vec<ReferenceLine>,
}

impl Chart {
    pub fn new(
        title: impl Into<String>,
        x_label: impl Into<String>,
        y_label: impl Into<String>,
    ) -> Self {
        Chart {
            title: title.into(),
            x_label: x_label.into(),
            y_label: y_label.into(),
            ..Chart::default()
        }
    }

    pub fn with_series(mut self, series: Series) -> Self {
        self.series.push(series);
        self
    }

    pub fn with_x_range(mut self, low: f64, high: f64) -> Self {
        self.x_range = Some((low, high));
        self
    }

    pub fn with_y_range(mut self, low: f64, high: f64) -> Self {
        self.y_range = Some((low, high));
        self
    }

    pub fn with_reference_line(mut self, value: f64, label: impl Into<String>) -> Self {
        self.reference_lines.push(ReferenceLine::new(value, label));
        self
    }

    /// Points that can be drawn: both coordinates finite.
    fn finite_points(&self) -> impl Iterator<Item = (f64, f64)> + '_ {
        self.series
            .iter()
            .flat_map(|s| s.points.iter().copied())
            .filter(|(x, y)| x.is_finite() && y.is_finite())
    }
}

/// One chart as a standalone SVG document of `width_px` x `height_px`
/// (clamped to 60..=100000; a non-finite size falls back to 640 x 400).
pub fn chart_svg(chart: &Chart, width_px: f64, height_px: f64) -> String {
    let width = sanitize_size(width_px, 640.0);
    let height = sanitize_size(height_px, 400.0);
    let mut out = String::new();
    open_document(&mut out, width, height, &chart.title);
    draw_panel(&mut out, chart, (0.0, 0.0), (width, height), true);
    out.push_str("</svg>\n");
    out
}

/// Small multiples: `charts` in a grid of `columns` columns (0 counts as 1)
/// of `panel_width_px` x `panel_height_px` panels under one overall `title`.
///
/// If every chart has the same series (names and styles, in the same order,
/// hence the same colours), one shared legend goes under the title;
/// otherwise each panel carries its own.
pub fn grid_svg(
    title: &str,
    charts: &[Chart],
    columns: usize,
    panel_width_px: f64,
    panel_height_px: f64,
) -> String {
    let panels: Vec<Option<&Chart>> = charts.iter().map(Some).collect();
    panels_svg(title, &panels, columns, panel_width_px, panel_height_px)
}

/// [`grid_svg`] with empty places: a `None` leaves its panel blank (the
/// upper triangle of a corner plot). The shared legend, if any, is that of
/// the charts present.
pub fn sparse_grid_svg(
    title: &str,
    charts: &[Option<Chart>],
    columns: usize,
    panel_width_px: f64,
    panel_height_px: f64,
) -> String {
    let panels: Vec<Option<&Chart>> = charts.iter().map(Option::as_ref).collect();
    panels_svg(title, &panels, columns, panel_width_px, panel_height_px)
}

fn panels_svg(
    title: &str,
    charts: &[Option<&Chart>],
    columns: usize,
    panel_width_px: f64,
    panel_height_px: f64,
) -> String {
    let panel_width = sanitize_size(panel_width_px, 320.0);
    let panel_height = sanitize_size(panel_height_px, 240.0);
    let columns = columns.clamp(1, charts.len().max(1));
    let rows = charts.len().div_ceil(columns);
    let width = columns as f64 * panel_width;

    let present: Vec<&Chart> = charts.iter().flatten().copied().collect();
    let shared = shared_series(&present);
    let title_height = if title.trim().is_empty() {
        0.0
    } else {
        PAD + FONT_GRID_TITLE + 6.0
    };
    let legend = shared
        .map(|series| layout_legend(series, width - 2.0 * PAD))
        .unwrap_or_default();
    let header = title_height + legend.height();
    let height = (header + rows as f64 * panel_height).max(MIN_SIZE);

    let mut out = String::new();
    open_document(&mut out, width, height, title);
    if title_height > 0.0 {
        let (text, _) = fit_text(title, FONT_GRID_TITLE, width - 2.0 * PAD);
        w!(
            out,
            "<text class=\"title\" x=\"{}\" y=\"{}\" text-anchor=\"middle\" font-size=\"{FONT_GRID_TITLE}\" font-weight=\"bold\">{text}</text>\n",
            Px(width / 2.0),
            Px(PAD + FONT_GRID_TITLE)
        );
    }
    if shared.is_some() {
        draw_legend(&mut out, &legend, PAD, title_height);
    }
    for (i, chart) in charts.iter().enumerate() {
        let Some(chart) = chart else {
            continue;
        };
        let (column, row) = (i % columns, i / columns);
        let origin = (
            column as f64 * panel_width,
            header + row as f64 * panel_height,
        );
        draw_panel(
            &mut out,
            chart,
            origin,
            (panel_width, panel_height),
            shared.is_none(),
        );
    }
    out.push_str("</svg>\n");
    out
}

/// Tick values at multiples of a 1-2-5 step (1, 2, 5, 10, 20, ...) that
/// cover `low..=high` (first tick <= low, last >= high), as few as needed
/// but no more than `max_ticks` (clamped to 3..=500: a range around zero
/// needs three).
///
/// The arguments may come in either order. Equal values are padded by 10 %
/// (zero to -1..1); a non-finite bound is ignored (both: 0..1); magnitudes
/// are clamped to ±1e300. Ticks are computed so that they print without
/// float noise: `nice_ticks(0.0, 1.0, 6)` gives exactly `0, 0.2, .., 1`.
pub fn nice_ticks(low: f64, high: f64, max_ticks: usize) -> Vec<f64> {
    let max_ticks = max_ticks.clamp(MIN_TICKS, MAX_TICKS);
    let (low, high) = tick_range(low, high);
    let span = high - low;
    // Start from the decade of the step that `max_ticks` evenly spaced ticks
    // would have and widen until the count fits. Terminates: once the step
    // exceeds both |low| and |high| at most three ticks are needed.
    let start = (span / (max_ticks - 1) as f64).log10().floor() as i32;
    for exponent in start..start + 40 {
        for mantissa in [1.0, 2.0, 5.0] {
            let step = tick_value(1.0, mantissa, exponent);
            // The tolerance keeps a step that is 1.0000000000000002 times
            // too small from adding a tick, but may leave an end a hair
            // short of the range: then that end moves out by one step.
            let mut first = (low / step + 1e-9).floor();
            let mut last = (high / step - 1e-9).ceil().max(first + 1.0);
            if tick_value(first, mantissa, exponent) > low {
                first -= 1.0;
            }
            if tick_value(last, mantissa, exponent) < high {
                last += 1.0;
            }
            let count = last - first + 1.0;
            if count <= max_ticks as f64 {
                return (0..count as usize)
                    .map(|i| tick_value(first + i as f64, mantissa, exponent))
                    .collect();
            }
        }
    }
    vec![low, high]
}

/// Labels for tick values: the fewest decimals that tell the ticks apart
/// (the same for all, `0.0 0.5 1.0`), switching to scientific notation
/// (`2.5e-7`, `1e9`) below 1e-3 or from 1e6. Non-finite values get an empty
/// label.
pub fn format_ticks(ticks: &[f64]) -> Vec<String> {
    let ticks: Vec<f64> = ticks
        .iter()
        .map(|&t| if t == 0.0 { 0.0 } else { t })
        .collect();
    let finite = || ticks.iter().copied().filter(|t| t.is_finite());
    let max_abs = finite().fold(0.0_f64, |m, t| m.max(t.abs()));
    let min_gap = finite()
        .zip(finite().skip(1))
        .map(|(a, b)| (b - a).abs())
        .filter(|gap| *gap > 0.0)
        .fold(f64::INFINITY, f64::min);
    let resolution = if min_gap.is_finite() {
        min_gap
    } else if max_abs > 0.0 {
        max_abs
    } else {
        1.0
    };
    let scientific = max_abs >= 1e6 || (max_abs > 0.0 && max_abs < 1e-3);
    // A label is good enough when it reads back within a thousandth of the
    // tick spacing: noise digits beyond that are dropped.
    let reads_back = |tick: f64, label: &str| {
        !tick.is_finite()
            || label
                .parse::<f64>()
                .is_ok_and(|v| (v - tick).abs() <= resolution * 1e-3)
    };
    for digits in 0..=17 {
        let labels: Vec<String> = ticks
            .iter()
            .map(|&t| format_number(t, digits, scientific))
            .collect();
        if ticks.iter().zip(&labels).all(|(&t, l)| reads_back(t, l)) {
            return labels;
        }
    }
    ticks
        .iter()
        .map(|t| {
            if t.is_finite() {
                format!("{t:e}")
            } else {
                String::new()
            }
        })
        .collect()
}

fn format_number(value: f64, digits: usize, scientific: bool) -> String {
    if !value.is_finite() {
        return String::new();
    }
    if !scientific {
        return format!("{value:.digits$}");
    }
    if value == 0.0 {
        return "0".to_string();
    }
    // Trailing zeros of the mantissa say nothing here: "1e-6", not "1.0e-6".
    let text = format!("{value:.digits$e}");
    match text.split_once('e') {
        Some((mantissa, exponent)) if mantissa.contains('.') => {
            let mantissa = mantissa.trim_end_matches('0').trim_end_matches('.');
            format!("{mantissa}e{exponent}")
        }
        _ => text,
    }
}

/// The finite, ordered, non-degenerate range that ticks are computed for.
fn tick_range(a: f64, b: f64) -> (f64, f64) {
    let clamp = |v: f64| v.clamp(-MAGNITUDE_LIMIT, MAGNITUDE_LIMIT);
    let (low, high) = match (a.is_finite(), b.is_finite()) {
        (true, true) => (clamp(a.min(b)), clamp(a.max(b))),
        (true, false) => (clamp(a), clamp(a)),
        (false, true) => (clamp(b), clamp(b)),
        (false, false) => return (0.0, 1.0),
    };
    if !is_degenerate(low, high) {
        return (low, high);
    }
    let centre = low / 2.0 + high / 2.0;
    if centre.abs() < TINY_SPAN * 10.0 {
        (-1.0, 1.0)
    } else {
        let pad = centre.abs() * 0.1;
        (centre - pad, centre + pad)
    }
}

fn is_degenerate(low: f64, high: f64) -> bool {
    let span = high - low;
    let magnitude = low.abs().max(high.abs());
    // Written so that a NaN span also counts as degenerate.
    let tickable = span > TINY_SPAN && span > TINY_RELATIVE_SPAN * magnitude;
    !tickable
}

/// `index * mantissa * 10^exponent` rounded once, to the double nearest
/// the decimal value: 0.3 for 3 x 0.1, where multiplying by 0.1 would give
/// 0.30000000000000004 (and powers of ten beyond 1e22 are inexact anyway).
fn tick_value(index: f64, mantissa: f64, exponent: i32) -> f64 {
    // `index * mantissa` is a small integer, exact and printed without an
    // exponent, so this is an exact decimal literal; parsing rounds correctly.
    let value = format!("{}e{exponent}", index * mantissa)
        .parse::<f64>()
        .unwrap_or(0.0);
    if value == 0.0 {
        0.0 // not -0, which would print as "-0.0"
    } else {
        value
    }
}

fn sanitize_size(size: f64, default: f64) -> f64 {
    if size.is_finite() {
        size.clamp(MIN_SIZE, MAX_SIZE)
    } else {
        default
    }
}

/// A pixel coordinate: two decimals at most, no trailing zeros, no `-0`.
#[derive(Clone, Copy)]
struct Px(f64);

impl fmt::Display for Px {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let v = if self.0.is_nan() {
            0.0
        } else {
            self.0.clamp(-PX_LIMIT, PX_LIMIT)
        };
        // The shortest representation of the double nearest to a two-decimal
        // value is that value, so this prints "12.35", never "12.350000001".
        let rounded = (v * 100.0).round() / 100.0;
        let rounded = if rounded == 0.0 { 0.0 } else { rounded };
        write!(f, "{rounded}")
    }
}

/// Linear map from data to pixels; `range` may run backwards (y grows down).
#[derive(Clone, Copy, Debug)]
struct Scale {
    domain: (f64, f64),
    range: (f64, f64),
}

impl Scale {
    fn map(&self, value: f64) -> f64 {
        let (d0, d1) = self.domain;
        let (r0, r1) = self.range;
        r0 + (value - d0) / (d1 - d0) * (r1 - r0)
    }
}

#[derive(Clone, Copy, Debug, PartialEq)]
struct Rect {
    left: f64,
    top: f64,
    width: f64,
    height: f64,
}

impl Rect {
    fn right(&self) -> f64 {
        self.left + self.width
    }

    fn bottom(&self) -> f64 {
        self.top + self.height
    }
}

/// An axis: its data limits (`lo < hi`, both finite), ticks and labels.
#[derive(Clone, Debug)]
struct Axis {
    lo: f64,
    hi: f64,
    ticks: Vec<f64>,
    labels: Vec<String>,
}

impl Axis {
    /// Fixed limits if usable, else the data extent widened to the outer
    /// ticks (0..1 without data).
    fn new(extent: Option<(f64, f64)>, fixed: Option<(f64, f64)>, max_ticks: usize) -> Axis {
        let usable = |(a, b): (f64, f64)| {
            a.is_finite()
                && b.is_finite()
                && a.abs().max(b.abs()) <= MAGNITUDE_LIMIT
                && !is_degenerate(a.min(b), a.max(b))
        };
        let (lo, hi, ticks) = match fixed.filter(|&r| usable(r)) {
            Some((a, b)) => {
                let (lo, hi) = (a.min(b), a.max(b));
                let slack = (hi - lo) * 1e-9;
                let ticks = nice_ticks(lo, hi, max_ticks)
                    .into_iter()
                    .filter(|t| (lo - slack..=hi + slack).contains(t))
                    .collect();
                (lo, hi, ticks)
            }
            None => {
                let (lo, hi) = extent.unwrap_or((0.0, 1.0));
                let ticks = nice_ticks(lo, hi, max_ticks);
                let (first, last) = (ticks[0], ticks[ticks.len() - 1]);
                (first, last, ticks)
            }
        };
        let labels = format_ticks(&ticks);
        Axis {
            lo,
            hi,
            ticks,
            labels,
        }
    }

    fn max_label_width(&self) -> f64 {
        self.labels
            .iter()
            .map(|l| text_width(l, FONT_TICK))
            .fold(0.0, f64::max)
    }
}

fn extent(values: impl Iterator<Item = f64>) -> Option<(f64, f64)> {
    values
        .filter(|v| v.is_finite())
        .fold(None, |acc, v| match acc {
            None => Some((v, v)),
            Some((lo, hi)) => Some((f64::min(lo, v), f64::max(hi, v))),
        })
}

/// Where everything of one panel goes, in panel pixels.
struct Layout {
    width: f64,
    height: f64,
    plot: Rect,
    x: Axis,
    y: Axis,
    legend: Legend,
    /// Escaped and cut to fit.
    title: String,
    x_label: String,
    y_label: String,
}

impl Layout {
    fn new(chart: &Chart, width: f64, height: f64, with_legend: bool) -> Layout {
        let (title, _) = fit_text(&chart.title, FONT_TITLE, width - 2.0 * PAD);
        let title_height = if title.is_empty() {
            PAD
        } else {
            PAD + FONT_TITLE + 4.0
        };
        let legend = if with_legend {
            layout_legend(&chart.series, width - 2.0 * PAD)
        } else {
            Legend::default()
        };
        let x_label_height = if chart.x_label.trim().is_empty() {
            0.0
        } else {
            FONT_LABEL + 6.0
        };
        // Half the top y tick label sticks out above the frame.
        let top = title_height + FONT_TICK / 2.0 + 2.0;
        let bottom = height - PAD - legend.height() - x_label_height - (TICK_LEN + FONT_TICK + 4.0);
        let plot_height = (bottom - top).max(MIN_PLOT);

        let y_extent = extent(
            chart
                .finite_points()
                .map(|(_, y)| y)
                .chain(chart.reference_lines.iter().map(|r| r.value)),
        );
        let y = Axis::new(y_extent, chart.y_range, tick_budget(plot_height, 25.0));
        let y_label_width = if chart.y_label.trim().is_empty() {
            0.0
        } else {
            FONT_LABEL + 6.0
        };
        let left = PAD + y_label_width + y.max_label_width() + TICK_LEN + 3.0;

        // The x labels depend on the plot width, and the right margin on the
        // last label: estimate with a typical margin, then settle it.
        let x_extent = extent(chart.finite_points().map(|(x, _)| x));
        let estimated_width = (width - left - PAD - 12.0).max(MIN_PLOT);
        let mut budget = tick_budget(estimated_width, 50.0);
        let x = loop {
            let axis = Axis::new(x_extent, chart.x_range, budget);
            let needed: f64 = axis
                .labels
                .iter()
                .map(|l| text_width(l, FONT_TICK) + 8.0)
                .sum();
            if needed <= estimated_width || budget <= MIN_TICKS {
                break axis;
            }
            budget -= 1;
        };
        let last_label = x.labels.last().map_or(0.0, |l| text_width(l, FONT_TICK));
        let right = PAD.max(last_label / 2.0 + 2.0);
        let plot = Rect {
            left,
            top,
            width: (width - left - right).max(MIN_PLOT),
            height: plot_height,
        };

        let (x_label, _) = fit_text(&chart.x_label, FONT_LABEL, plot.width);
        let (y_label, _) = fit_text(&chart.y_label, FONT_LABEL, plot.height);
        Layout {
            width,
            height,
            plot,
            x,
            y,
            legend,
            title,
            x_label,
            y_label,
        }
    }

    fn x_scale(&self) -> Scale {
        Scale {
            domain: (self.x.lo, self.x.hi),
            range: (self.plot.left, self.plot.right()),
        }
    }

    fn y_scale(&self) -> Scale {
        Scale {
            domain: (self.y.lo, self.y.hi),
            range: (self.plot.bottom(), self.plot.top),
        }
    }
}

/// How many ticks fit along `length` pixels at about `spacing` apart.
fn tick_budget(length: f64, spacing: f64) -> usize {
    ((length / spacing) as usize).clamp(MIN_TICKS, 10)
}

fn open_document(out: &mut String, width: f64, height: f64, title: &str) {
    let (w, h) = (Px(width), Px(height));
    w!(
        out,
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{w}\" height=\"{h}\" viewBox=\"0 0 {w} {h}\" font-family=\"{FONT_FAMILY}\" font-size=\"{FONT_LABEL}\">\n"
    );
    let title = escape(title.trim());
    if !title.is_empty() {
        w!(out, "<title>{title}</title>\n");
    }
    // An explicit background keeps the chart readable in dark-mode viewers.
    w!(out, "<rect width=\"{w}\" height=\"{h}\" fill=\"#fff\"/>\n");
}

fn draw_panel(
    out: &mut String,
    chart: &Chart,
    origin: (f64, f64),
    size: (f64, f64),
    with_legend: bool,
) {
    let layout = Layout::new(chart, size.0, size.1, with_legend);
    let plot = layout.plot;
    let (xs, ys) = (layout.x_scale(), layout.y_scale());
    w!(
        out,
        "<g class=\"panel\" transform=\"translate({},{})\">\n",
        Px(origin.0),
        Px(origin.1)
    );
    if !layout.title.is_empty() {
        w!(
            out,
            "<text class=\"title\" x=\"{}\" y=\"{}\" text-anchor=\"middle\" font-size=\"{FONT_TITLE}\" font-weight=\"bold\">{}</text>\n",
            Px(layout.width / 2.0),
            Px(PAD + FONT_TITLE),
            layout.title
        );
    }
    draw_axes(out, &layout, &xs, &ys);

    // Data is drawn inside a nested <svg>, which clips to its viewport
    // without needing a clipPath id (ids collide when charts are inlined).
    let clip = Rect {
        left: plot.left - CLIP_MARGIN,
        top: plot.top - CLIP_MARGIN,
        width: plot.width + 2.0 * CLIP_MARGIN,
        height: plot.height + 2.0 * CLIP_MARGIN,
    };
    let (cx, cy, cw, ch) = (Px(clip.left), Px(clip.top), Px(clip.width), Px(clip.height));
    w!(
        out,
        "<svg x=\"{cx}\" y=\"{cy}\" width=\"{cw}\" height=\"{ch}\" viewBox=\"{cx} {cy} {cw} {ch}\" overflow=\"hidden\">\n"
    );
    let references: Vec<(f64, &str)> = chart
        .reference_lines
        .iter()
        .filter(|r| r.value.is_finite())
        .map(|r| (ys.map(r.value), r.label.as_str()))
        .filter(|(y, _)| (plot.top - 0.5..=plot.bottom() + 0.5).contains(y))
        .collect();
    for &(y, _) in &references {
        w!(
            out,
            "<line class=\"reference\" x1=\"{}\" y1=\"{y}\" x2=\"{}\" y2=\"{y}\" stroke=\"#555\" stroke-dasharray=\"2 3\"/>\n",
            Px(plot.left),
            Px(plot.right()),
            y = Px(y)
        );
    }
    for (index, series) in chart.series.iter().enumerate() {
        draw_series(out, index, series, &xs, &ys);
    }
    out.push_str("</svg>\n");

    // Reference labels go over the data, on a translucent backing.
    for &(y, label) in &references {
        let (text, text_w) = fit_text(label, FONT_TICK, plot.width - 8.0);
        if text.is_empty() {
            continue;
        }
        let above = y - FONT_TICK - 3.0 >= plot.top;
        let baseline = if above { y - 3.0 } else { y + FONT_TICK + 2.0 };
        let x = plot.right() - 4.0;
        w!(
            out,
            "<rect x=\"{}\" y=\"{}\" width=\"{}\" height=\"{}\" fill=\"#fff\" fill-opacity=\"0.75\"/>\n",
            Px(x - text_w - 1.0),
            Px(baseline - FONT_TICK + 1.0),
            Px(text_w + 2.0),
            Px(FONT_TICK + 1.0)
        );
        w!(
            out,
            "<text x=\"{}\" y=\"{}\" text-anchor=\"end\" font-size=\"{FONT_TICK}\" fill=\"#333\">{text}</text>\n",
            Px(x),
            Px(baseline)
        );
    }
    if chart.finite_points().next().is_none() {
        w!(
            out,
            "<text x=\"{}\" y=\"{}\" text-anchor=\"middle\" fill=\"#888\">no data</text>\n",
            Px(plot.left + plot.width / 2.0),
            Px(plot.top + plot.height / 2.0)
        );
    }

    if !layout.x_label.is_empty() {
        w!(
            out,
            "<text x=\"{}\" y=\"{}\" text-anchor=\"middle\">{}</text>\n",
            Px(plot.left + plot.width / 2.0),
            Px(plot.bottom() + TICK_LEN + FONT_TICK + 4.0 + FONT_LABEL),
            layout.x_label
        );
    }
    if !layout.y_label.is_empty() {
        w!(
            out,
            "<text transform=\"translate({},{}) rotate(-90)\" text-anchor=\"middle\">{}</text>\n",
            Px(PAD + FONT_LABEL),
            Px(plot.top + plot.height / 2.0),
            layout.y_label
        );
    }
    let legend_top = layout.height - PAD - layout.legend.rows as f64 * LEGEND_ROW;
    draw_legend(out, &layout.legend, PAD, legend_top);
    out.push_str("</g>\n");
}

/// Grid lines, frame, tick marks and tick labels.
fn draw_axes(out: &mut String, layout: &Layout, xs: &Scale, ys: &Scale) {
    let plot = layout.plot;
    let x_ticks: Vec<f64> = layout.x.ticks.iter().map(|&t| xs.map(t)).collect();
    let y_ticks: Vec<f64> = layout.y.ticks.iter().map(|&t| ys.map(t)).collect();

    let mut grid = String::new();
    let mut marks = String::new();
    for &x in &x_ticks {
        w!(grid, "M{},{}V{}", Px(x), Px(plot.top), Px(plot.bottom()));
        w!(marks, "M{},{}v{TICK_LEN}", Px(x), Px(plot.bottom()));
    }
    for &y in &y_ticks {
        w!(grid, "M{},{}H{}", Px(plot.left), Px(y), Px(plot.right()));
        w!(marks, "M{},{}h-{TICK_LEN}", Px(plot.left), Px(y));
    }
    if !grid.is_empty() {
        w!(
            out,
            "<path d=\"{grid}\" fill=\"none\" stroke=\"#e6e6e6\"/>\n"
        );
        w!(out, "<path d=\"{marks}\" fill=\"none\" stroke=\"#888\"/>\n");
    }
    w!(
        out,
        "<rect x=\"{}\" y=\"{}\" width=\"{}\" height=\"{}\" fill=\"none\" stroke=\"#888\"/>\n",
        Px(plot.left),
        Px(plot.top),
        Px(plot.width),
        Px(plot.height)
    );

    w!(out, "<g font-size=\"{FONT_TICK}\" fill=\"#333\">\n");
    for (&x, label) in x_ticks.iter().zip(&layout.x.labels) {
        w!(
            out,
            "<text x=\"{}\" y=\"{}\" text-anchor=\"middle\">{label}</text>\n",
            Px(x),
            Px(plot.bottom() + TICK_LEN + FONT_TICK + 1.0)
        );
    }
    for (&y, label) in y_ticks.iter().zip(&layout.y.labels) {
        w!(
            out,
            "<text x=\"{}\" y=\"{}\" dy=\"0.35em\" text-anchor=\"end\">{label}</text>\n",
            Px(plot.left - TICK_LEN - 3.0),
            Px(y)
        );
    }
    out.push_str("</g>\n");
}

fn colour(index: usize) -> &'static str {
    PALETTE[index % PALETTE.len()]
}

/// Extra stroke attributes of a series line: dashed if asked for, and a
/// dash pattern per round through the palette.
fn dash_attribute(index: usize, style: SeriesStyle) -> String {
    let round = index / PALETTE.len();
    let pattern = match style {
        SeriesStyle::Dashed => Some(DASHED),
        _ if round > 0 => Some(REPEAT_DASHES[(round - 1) % REPEAT_DASHES.len()]),
        _ => None,
    };
    pattern.map_or(String::new(), |p| format!(" stroke-dasharray=\"{p}\""))
}

fn draw_series(out: &mut String, index: usize, series: &Series, xs: &Scale, ys: &Scale) {
    let colour = colour(index);
    out.push_str("<g class=\"series\">");
    let name = escape(series.name.trim());
    if !name.is_empty() {
        // Shown as a tooltip by browsers.
        w!(out, "<title>{name}</title>");
    }
    if series.style.has_line() {
        let d = line_path(&series.points, xs, ys);
        if !d.is_empty() {
            w!(
                out,
                "<path d=\"{d}\" fill=\"none\" stroke=\"{colour}\" stroke-width=\"{LINE_WIDTH}\" stroke-linejoin=\"round\" stroke-linecap=\"round\"{}/>",
                dash_attribute(index, series.style)
            );
        }
    }
    if series.style.has_markers() {
        let mut d = String::new();
        for (x, y) in series.points.iter().copied() {
            if x.is_finite() && y.is_finite() {
                push_marker(&mut d, index, xs.map(x), ys.map(y));
            }
        }
        if !d.is_empty() {
            w!(out, "<path d=\"{d}\" fill=\"{colour}\"/>");
        }
    }
    out.push_str("</g>\n");
}

/// Path data through `points`, starting a new subpath (`M`) after every
/// non-finite point so missing data shows as a gap rather than a bridge.
fn line_path(points: &[(f64, f64)], xs: &Scale, ys: &Scale) -> String {
    let mut d = String::new();
    let mut segment_len = 0;
    // A lone point between gaps would draw nothing; a zero-length segment
    // with a round cap shows it as a dot.
    let end_segment = |d: &mut String, len: usize| {
        if len == 1 {
            d.push_str("h0");
        }
    };
    for &(x, y) in points {
        if !(x.is_finite() && y.is_finite()) {
            end_segment(&mut d, segment_len);
            segment_len = 0;
            continue;
        }
        let command = if segment_len == 0 { 'M' } else { 'L' };
        w!(d, "{command}{},{}", Px(xs.map(x)), Px(ys.map(y)));
        segment_len += 1;
    }
    end_segment(&mut d, segment_len);
    d
}

/// Appends one marker as a closed subpath; the shape cycles with the series
/// (circle, square, triangle, diamond) so colour is not the only cue.
fn push_marker(d: &mut String, index: usize, x: f64, y: f64) {
    let r = MARKER_RADIUS;
    match index % 4 {
        0 => w!(
            d,
            "M{},{}a{r},{r} 0 1,0 {},0a{r},{r} 0 1,0 -{},0",
            Px(x - r),
            Px(y),
            2.0 * r,
            2.0 * r
        ),
        // Squares look bigger than circles of the same radius.
        1 => {
            let s = r * 0.9;
            w!(
                d,
                "M{},{}h{}v{}h-{}z",
                Px(x - s),
                Px(y - s),
                Px(2.0 * s),
                Px(2.0 * s),
                Px(2.0 * s)
            )
        }
        2 => w!(
            d,
            "M{},{}l{},{}h-{}z",
            Px(x),
            Px(y - 1.2 * r),
            Px(1.2 * r),
            Px(2.1 * r),
            Px(2.4 * r)
        ),
        _ => {
            let s = Px(1.25 * r);
            w!(
                d,
                "M{},{}l{s},{s}l-{s},{s}l-{s},-{s}z",
                Px(x),
                Px(y - 1.25 * r)
            )
        }
    }
}

/// Legend entries placed in centred rows.
#[derive(Clone, Debug, Default)]
struct Legend {
    entries: Vec<LegendEntry>,
    rows: usize,
}

#[derive(Clone, Debug)]
struct LegendEntry {
    index: usize,
    style: SeriesStyle,
    /// Escaped and cut to fit.
    label: String,
    /// Offset of the swatch from the legend's left edge.
    x: f64,
    row: usize,
}

impl Legend {
    fn height(&self) -> f64 {
        self.rows as f64 * LEGEND_ROW
    }
}

/// Fills rows of `width` pixels left to right with the named series.
fn layout_legend(series: &[Series], width: f64) -> Legend {
    let mut legend = Legend::default();
    let mut row_widths: Vec<f64> = Vec::new();
    for (index, s) in series.iter().enumerate() {
        let (label, text_w) = fit_text(&s.name, FONT_LABEL, width - LEGEND_SWATCH - 4.0);
        if label.is_empty() {
            continue;
        }
        let item_width = LEGEND_SWATCH + 4.0 + text_w + LEGEND_GAP;
        let fits_row = row_widths
            .last()
            .is_some_and(|used| used + item_width - LEGEND_GAP <= width);
        if !fits_row {
            row_widths.push(0.0);
        }
        let row = row_widths.len() - 1;
        legend.entries.push(LegendEntry {
            index,
            style: s.style,
            label,
            x: row_widths[row],
            row,
        });
        row_widths[row] += item_width;
    }
    for entry in &mut legend.entries {
        let used = row_widths[entry.row] - LEGEND_GAP;
        entry.x += ((width - used) / 2.0).max(0.0);
    }
    legend.rows = row_widths.len();
    legend
}

fn draw_legend(out: &mut String, legend: &Legend, left: f64, top: f64) {
    if legend.entries.is_empty() {
        return;
    }
    out.push_str("<g class=\"legend\">\n");
    for entry in &legend.entries {
        let x = left + entry.x;
        let y = top + (entry.row as f64 + 0.5) * LEGEND_ROW;
        let colour = colour(entry.index);
        if entry.style.has_line() {
            w!(
                out,
                "<path d=\"M{},{}h{LEGEND_SWATCH}\" fill=\"none\" stroke=\"{colour}\" stroke-width=\"{LINE_WIDTH}\"{}/>",
                Px(x),
                Px(y),
                dash_attribute(entry.index, entry.style)
            );
        }
        if entry.style.has_markers() {
            let mut d = String::new();
            push_marker(&mut d, entry.index, x + LEGEND_SWATCH / 2.0, y);
            w!(out, "<path d=\"{d}\" fill=\"{colour}\"/>");
        }
        w!(
            out,
            "<text x=\"{}\" y=\"{}\" dy=\"0.35em\">{}</text>\n",
            Px(x + LEGEND_SWATCH + 4.0),
            Px(y),
            entry.label
        );
    }
    out.push_str("</g>\n");
}

/// The series whose legend serves every panel: all charts name the same
/// series with the same styles in the same order (so colours agree too).
fn shared_series<'c>(charts: &[&'c Chart]) -> Option<&'c [Series]> {
    let first = *charts.first()?;
    let key = |chart: &Chart| {
        chart
            .series
            .iter()
            .map(|s| (s.name.trim().to_owned(), s.style))
            .collect::<Vec<_>>()
    };
    let first_key = key(first);
    let any_named = first_key.iter().any(|(name, _)| !name.is_empty());
    (any_named && charts.iter().all(|c| key(c) == first_key)).then_some(first.series.as_slice())
}

fn text_width(text: &str, font_size: f64) -> f64 {
    text.chars().count() as f64 * font_size * CHAR_WIDTH
}

/// `text` XML-escaped and, if its estimated width exceeds `max_width`, cut
/// with an ellipsis; also returns the estimated width.
fn fit_text(text: &str, font_size: f64, max_width: f64) -> (String, f64) {
    let chars: Vec<char> = text.trim().chars().filter_map(xml_char).collect();
    let per_char = font_size * CHAR_WIDTH;
    // Saturating cast: a negative or NaN budget fits nothing.
    let fits = (max_width / per_char) as usize;
    let kept: String = if chars.len() <= fits {
        chars.iter().collect()
    } else if fits == 0 {
        String::new()
    } else {
        let mut cut: String = chars[..fits - 1].iter().collect();
        cut.push('…');
        cut
    };
    let width = text_width(&kept, font_size);
    (escape(&kept), width)
}

/// The character as XML 1.0 can carry it: layout whitespace as a space,
/// other control characters and non-characters not at all.
fn xml_char(c: char) -> Option<char> {
    match c {
        '\t' | '\n' | '\r' => Some(' '),
        '\u{20}'..='\u{D7FF}' | '\u{E000}'..='\u{FFFD}' | '\u{10000}'..='\u{10FFFF}' => Some(c),
        _ => None,
    }
}

/// Text safe both as element content and inside a quoted attribute.
fn escape(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for c in text.chars().filter_map(xml_char) {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&apos;"),
            c => out.push(c),
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// A small well-formedness checker: balanced tags, quoted and unique
    /// attributes, known entities, no stray `<`, exactly one root element.
    fn check_xml(doc: &str) -> Result<(), String> {
        let bytes = doc.as_bytes();
        let mut stack: Vec<&str> = Vec::new();
        let mut roots = 0;
        let mut i = 0;
        let find = |from: usize, pat: &str| {
            doc[from..]
                .find(pat)
                .map(|p| from + p)
                .ok_or_else(|| format!("unterminated construct at byte {from}"))
        };
        let name_end = |from: usize| {
            doc[from..]
                .find(|c: char| c.is_whitespace() || matches!(c, '/' | '>' | '=' | '<'))
                .map_or(doc.len(), |p| from + p)
        };
        while i < bytes.len() {
            if bytes[i] != b'<' {
                let end = doc[i..].find('<').map_or(doc.len(), |p| i + p);
                let text = &doc[i..end];
                check_entities(text)?;
                if stack.is_empty() && !text.trim().is_empty() {
                    return Err(format!("text outside the root: {text:?}"));
                }
                i = end;
                continue;
            }
            if doc[i..].starts_with("<!--") {
                i = find(i, "-->")? + 3;
                continue;
            }
            if doc[i..].starts_with("<?") {
                i = find(i, "?>")? + 2;
                continue;
            }
            if doc[i..].starts_with("</") {
                let end = find(i, ">")?;
                let name = doc[i + 2..end].trim_end();
                match stack.pop() {
                    Some(open) if open == name => {}
                    open => return Err(format!("</{name}> closes {open:?} at byte {i}")),
                }
                i = end + 1;
                continue;
            }
            let start = i + 1;
            let end = name_end(start);
            let name = &doc[start..end];
            if name.is_empty() {
                return Err(format!("stray '<' at byte {i}"));
            }
            if stack.is_empty() {
                roots += 1;
            }
            i = end;
            let mut attributes: Vec<&str> = Vec::new();
            loop {
                let before = i;
                while i < bytes.len() && bytes[i].is_ascii_whitespace() {
                    i += 1;
                }
                match bytes.get(i) {
                    None => return Err(format!("unterminated <{name}>")),
                    Some(b'/') => {
                        if bytes.get(i + 1) != Some(&b'>') {
                            return Err(format!("bad self-closing <{name}>"));
                        }
                        i += 2;
                        break;
                    }
                    Some(b'>') => {
                        stack.push(name);
                        i += 1;
                        break;
                    }
                    Some(_) => {
                        if i == before {
                            return Err(format!("no space before attribute in <{name}>"));
                        }
                        let attr_end = name_end(i);
                        let attr = &doc[i..attr_end];
                        if attr.is_empty() || bytes.get(attr_end) != Some(&b'=') {
                            return Err(format!("bad attribute {attr:?} in <{name}>"));
                        }
                        if attributes.contains(&attr) {
                            return Err(format!("duplicate attribute {attr} in <{name}>"));
                        }
                        attributes.push(attr);
                        let quote = match bytes.get(attr_end + 1) {
                            Some(&q) if q == b'"' || q == b'\'' => q as char,
                            _ => return Err(format!("unquoted {attr} in <{name}>")),
                        };
                        let value_end =
                            doc[attr_end + 2..]
                                .find(quote)
                                .map(|p| attr_end + 2 + p)
                                .ok_or_else(|| format!("unterminated {attr} in <{name}>"))?;
                        let value = &doc[attr_end + 2..value_end];
                        if value.contains('<') {
                            return Err(format!("'<' in {attr} of <{name}>"));
                        }
                        check_entities(value)?;
                        i = value_end + 1;
                    }
                }
            }
        }
        if let Some(open) = stack.last() {
            return Err(format!("<{open}> never closed"));
        }
        if roots != 1 {
            return Err(format!("{roots} root elements"));
        }
        Ok(())
    }

    fn check_entities(text: &str) -> Result<(), String> {
        for (at, _) in text.match_indices('&') {
            let rest = &text[at + 1..];
            let entity = rest
                .find(';')
                .map(|end| &rest[..end])
                .ok_or_else(|| format!("bare '&' in {text:?}"))?;
            let known = matches!(entity, "amp" | "lt" | "gt" | "quot" | "apos")
                || entity
                    .strip_prefix("#x")
                    .is_some_and(|h| !h.is_empty() && h.chars().all(|c| c.is_ascii_hexdigit()))
                || entity
                    .strip_prefix('#')
                    .is_some_and(|d| !d.is_empty() && d.chars().all(|c| c.is_ascii_digit()));
            if !known {
                return Err(format!("unknown entity &{entity}; in {text:?}"));
            }
        }
        Ok(())
    }

    #[test]
    fn the_xml_checker_rejects_malformed_documents() {
        assert!(check_xml(r#"<svg a="1"><g/><text>x &amp; y</text></svg>"#).is_ok());
        for bad in [
            "<svg><g></svg>",
            "<svg></g></svg>",
            "<svg><g>",
            "<svg/><svg/>",
            "<svg a=1/>",
            r#"<svg a="1" a="2"/>"#,
            r#"<svg a="x<y"/>"#,
            "<svg>a & b</svg>",
            "<svg>a < b</svg>",
            "<svg>&nbsp;</svg>",
            r#"<svg a="1"b="2"/>"#,
            "text<svg/>",
        ] {
            assert!(check_xml(bad).is_err(), "accepted {bad}");
        }
    }

    fn assert_clean(svg: &str) {
        if let Err(e) = check_xml(svg) {
            panic!("not well-formed: {e}\n{svg}");
        }
        assert!(!svg.contains("NaN"), "NaN in\n{svg}");
        assert!(!svg.contains("inf"), "inf in\n{svg}");
        assert!(svg.starts_with("<svg xmlns=\"http://www.w3.org/2000/svg\""));
        for attribute in ["viewBox=\"0 0 ", "width=\"", "height=\""] {
            assert!(svg.contains(attribute), "{attribute} missing");
        }
    }

    /// The `d` attributes of the series line paths, in order.
    fn line_paths(svg: &str) -> Vec<&str> {
        svg.split("<g class=\"series\">")
            .skip(1)
            .filter_map(|group| {
                let group = &group[..group.find("</g>").unwrap()];
                let at = group.find("fill=\"none\"")?;
                let d = &group[..at];
                let start = d.rfind("d=\"")? + 3;
                Some(&d[start..d[start..].find('"')? + start])
            })
            .collect()
    }

    fn ramp(n: usize) -> Vec<(f64, f64)> {
        (0..n).map(|i| (i as f64, (i * i) as f64)).collect()
    }

    fn force_chart() -> Chart {
        Chart::new("Force vs displacement", "displacement [mm]", "force [kN]")
            .with_series(Series::new("measured", ramp(20)))
            .with_series(
                Series::new(
                    "simulated",
                    ramp(20).iter().map(|&(x, y)| (x, y * 1.1)).collect(),
                )
                .with_style(SeriesStyle::Dashed),
            )
            .with_reference_line(116.9, "measured 116.9 bar")
    }

    #[test]
    fn unit_interval_ticks_are_exact_decimals() {
        let ticks = nice_ticks(0.0, 1.0, 6);
        assert_eq!(ticks, [0.0, 0.2, 0.4, 0.6, 0.8, 1.0]);
        let shown: Vec<String> = ticks.iter().map(|t| t.to_string()).collect();
        assert_eq!(shown, ["0", "0.2", "0.4", "0.6", "0.8", "1"]);
        assert_eq!(
            format_ticks(&ticks),
            ["0.0", "0.2", "0.4", "0.6", "0.8", "1.0"]
        );
        // Ticks with a step of 0.1 must not pick up 0.30000000000000004.
        let tenths = nice_ticks(0.0, 0.7, 8);
        assert_eq!(tenths, [0.0, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7]);
    }

    #[test]
    fn ticks_cover_the_range_with_1_2_5_steps() {
        let cases = [
            (-3.7, 12.2, 6),
            (-3.7, 12.2, 10),
            (0.013, 0.0171, 5),
            (-250.0, -17.0, 7),
            (1e-7, 3.2e-6, 5),
            (2e9, 7.5e9, 6),
            (99.5, 100.5, 4),
            (-1e300, 1e300, 5),
        ];
        for (low, high, max) in cases {
            let ticks = nice_ticks(low, high, max);
            assert!(ticks.len() >= 2 && ticks.len() <= max, "{ticks:?}");
            assert!(
                ticks[0] <= low && *ticks.last().unwrap() >= high,
                "{ticks:?}"
            );
            let step = ticks[1] - ticks[0];
            for pair in ticks.windows(2) {
                let gap = pair[1] - pair[0];
                assert!((gap - step).abs() <= step * 1e-9, "uneven {ticks:?}");
            }
            let mantissa = step / 10f64.powf(step.log10().floor());
            assert!(
                [1.0, 2.0, 5.0, 10.0]
                    .iter()
                    .any(|m| (mantissa - m).abs() < 1e-6),
                "step {step} of {ticks:?}"
            );
        }
        assert_eq!(nice_ticks(-3.7, 12.2, 6), [-5.0, 0.0, 5.0, 10.0, 15.0]);
    }

    #[test]
    fn equal_reversed_and_non_finite_bounds_give_sensible_ticks() {
        for v in [5.0, 0.0, -2.5, 116.9, 1e-12, 3e12] {
            let ticks = nice_ticks(v, v, 6);
            assert!(ticks.len() >= 2, "{v}: {ticks:?}");
            assert!(ticks[0] < v && v < *ticks.last().unwrap(), "{v}: {ticks:?}");
        }
        assert_eq!(nice_ticks(5.0, 5.0, 6), [4.5, 5.0, 5.5]);
        assert_eq!(nice_ticks(0.0, 0.0, 6), [-1.0, -0.5, 0.0, 0.5, 1.0]);
        assert_eq!(nice_ticks(0.0, 0.0, 3), [-1.0, 0.0, 1.0]);
        assert_eq!(nice_ticks(1.0, 0.0, 6), nice_ticks(0.0, 1.0, 6));
        assert_eq!(nice_ticks(12.2, -3.7, 6), nice_ticks(-3.7, 12.2, 6));
        assert_eq!(
            nice_ticks(f64::NAN, f64::INFINITY, 6),
            nice_ticks(0.0, 1.0, 6)
        );
        assert_eq!(nice_ticks(f64::NAN, 5.0, 6), nice_ticks(5.0, 5.0, 6));
        // Too few ticks asked for: still a covering set.
        let ticks = nice_ticks(-0.5, 0.5, 0);
        assert!(ticks.len() == 3 && ticks[0] <= -0.5 && ticks[2] >= 0.5);
        // Beyond the magnitude limit: clamped, padded, still covering.
        let ticks = nice_ticks(f64::MIN, f64::MIN, 0);
        assert!(
            ticks.len() == 3 && ticks[0] <= -1e300 && ticks[2] >= -1e300,
            "{ticks:?}"
        );
        // Subnormal span: padded rather than divided by zero.
        let ticks = nice_ticks(0.0, 5e-324, 6);
        assert!(ticks.iter().all(|t| t.is_finite()) && ticks.len() >= 2);
    }

    #[test]
    fn tick_labels_switch_to_scientific_for_extreme_magnitudes() {
        assert_eq!(
            format_ticks(&nice_ticks(0.0, 1e-6, 6)),
            ["0", "2e-7", "4e-7", "6e-7", "8e-7", "1e-6"]
        );
        assert_eq!(format_ticks(&[0.0, 5e7, 1e8]), ["0", "5e7", "1e8"]);
        assert_eq!(format_ticks(&[1e6, 1.5e6]), ["1e6", "1.5e6"]);
        assert_eq!(format_ticks(&[0.1 + 0.2, 0.4]), ["0.3", "0.4"]);
        assert_eq!(format_ticks(&[-20.0, 0.0, 20.0]), ["-20", "0", "20"]);
        assert_eq!(format_ticks(&[-0.0]), ["0"]);
        assert_eq!(format_ticks(&[f64::NAN, 1.0]), ["", "1"]);
    }

    #[test]
    fn scale_maps_data_to_pixels() {
        let x = Scale {
            domain: (0.0, 10.0),
            range: (50.0, 450.0),
        };
        assert_eq!(x.map(0.0), 50.0);
        assert_eq!(x.map(2.5), 150.0);
        assert_eq!(x.map(10.0), 450.0);
        let y = Scale {
            domain: (-100.0, 100.0),
            range: (300.0, 20.0),
        };
        assert_eq!(y.map(-100.0), 300.0);
        assert_eq!(y.map(0.0), 160.0);
        assert_eq!(y.map(50.0), 90.0);
    }

    #[test]
    fn a_point_lands_on_its_pixel_in_the_svg() {
        let chart = Chart::new("t", "x", "y")
            .with_x_range(0.0, 10.0)
            .with_y_range(0.0, 100.0)
            .with_series(Series::new("s", vec![(0.0, 0.0), (5.0, 25.0)]));
        let layout = Layout::new(&chart, 400.0, 300.0, true);
        let p = layout.plot;
        let expected = format!(
            "M{},{}L{},{}",
            Px(p.left),
            Px(p.bottom()),
            Px(p.left + p.width / 2.0),
            Px(p.bottom() - p.height / 4.0)
        );
        assert_eq!(line_paths(&chart_svg(&chart, 400.0, 300.0)), [expected]);
        assert!(p.left > 0.0 && p.right() < 400.0 && p.top > 0.0 && p.bottom() < 300.0);
    }

    #[test]
    fn pixel_numbers_are_short() {
        assert_eq!(Px(12.345678).to_string(), "12.35");
        assert_eq!(Px(3.0).to_string(), "3");
        assert_eq!(Px(-0.001).to_string(), "0");
        assert_eq!(Px(f64::NAN).to_string(), "0");
        assert_eq!(Px(f64::INFINITY).to_string(), "1000000");
    }

    #[test]
    fn charts_are_well_formed_xml() {
        let hostile = r#"a<b & "c" 'd' > e"#;
        let charts = [
            force_chart(),
            Chart::default(),
            Chart::new(hostile, hostile, hostile)
                .with_series(Series::new(hostile, ramp(3)))
                .with_reference_line(1.0, hostile),
            Chart::new("empty series", "x", "y").with_series(Series::new("none", vec![])),
            Chart::new("one point", "x", "y")
                .with_series(Series::new("p", vec![(1.0, 2.0)]).with_style(SeriesStyle::Markers)),
            Chart::new("flat", "x", "y")
                .with_series(Series::new("c", vec![(0.0, 3.0), (1.0, 3.0)])),
            Chart::new("negative", "x", "y")
                .with_series(Series::new("n", vec![(-5.0, -1e-6), (-1.0, -3e-6)])),
            Chart::new("fixed", "x", "y")
                .with_x_range(2.0, 2.0)
                .with_y_range(f64::NAN, 1.0)
                .with_series(Series::new("f", ramp(5)).with_style(SeriesStyle::LineAndMarkers)),
            Chart::new("control\u{0}chars\u{1b}", "tab\there", "")
                .with_series(Series::new("\u{FFFF}", ramp(2))),
        ];
        for chart in &charts {
            for (w, h) in [(640.0, 400.0), (200.0, 150.0), (1.0, f64::NAN)] {
                assert_clean(&chart_svg(chart, w, h));
            }
        }
        let svg = chart_svg(&charts[2], 640.0, 400.0);
        assert!(svg.contains("a&lt;b &amp; &quot;c&quot; &apos;d&apos; &gt; e"));
        assert!(!svg.contains(hostile));
        assert_clean(&grid_svg(hostile, &charts, 3, 300.0, 220.0));
        assert!(!chart_svg(&charts[8], 640.0, 400.0).contains('\u{0}'));
    }

    #[test]
    fn every_series_gets_its_own_colour_and_many_series_get_dashes() {
        let mut chart = Chart::new("many", "x", "y");
        for i in 0..10 {
            chart = chart.with_series(Series::new(format!("s{i}"), ramp(3)));
        }
        let svg = chart_svg(&chart, 800.0, 500.0);
        assert_clean(&svg);
        for colour in PALETTE {
            assert!(svg.contains(&format!("stroke=\"{colour}\"")), "{colour}");
        }
        assert!(svg.contains("stroke-dasharray=\"2 3\""));
        assert_eq!(svg.matches("<g class=\"legend\">").count(), 1);
    }

    #[test]
    fn non_finite_points_break_the_line() {
        let chart = Chart::new("gap", "x", "y").with_series(Series::new(
            "g",
            vec![
                (0.0, 0.0),
                (1.0, 1.0),
                (2.0, f64::NAN),
                (3.0, 3.0),
                (4.0, 4.0),
            ],
        ));
        let svg = chart_svg(&chart, 400.0, 300.0);
        assert_clean(&svg);
        let paths = line_paths(&svg);
        assert_eq!(paths.len(), 1);
        assert_eq!(paths[0].matches('M').count(), 2, "{}", paths[0]);
        assert_eq!(paths[0].matches('L').count(), 2, "{}", paths[0]);

        // Infinities too, and a point alone between gaps still shows.
        let chart = Chart::new("gaps at ±∞", "x", "y").with_series(Series::new(
            "g",
            vec![
                (0.0, 0.0),
                (1.0, f64::INFINITY),
                (2.0, 2.0),
                (f64::NEG_INFINITY, 3.0),
                (4.0, 4.0),
                (5.0, 5.0),
            ],
        ));
        let svg = chart_svg(&chart, 400.0, 300.0);
        assert_clean(&svg);
        let path = line_paths(&svg)[0];
        assert_eq!(path.matches('M').count(), 3, "{path}");
        assert_eq!(path.matches("h0").count(), 2, "{path}");
    }

    #[test]
    fn empty_chart_says_no_data() {
        let svg = chart_svg(&Chart::new("nothing", "x", "y"), 400.0, 300.0);
        assert_clean(&svg);
        assert!(svg.contains(">no data</text>"));
        assert!(!svg.contains("class=\"legend\""));
        let svg = chart_svg(&force_chart(), 400.0, 300.0);
        assert!(!svg.contains("no data"));
    }

    #[test]
    fn grid_has_one_panel_per_chart_and_one_shared_legend() {
        let charts: Vec<Chart> = (0..5)
            .map(|i| {
                Chart::new(format!("output {i}"), "change [%]", "value")
                    .with_series(Series::new("stiffness", ramp(5)))
                    .with_series(Series::new("damping", ramp(4)).with_style(SeriesStyle::Dashed))
            })
            .collect();
        let svg = grid_svg("Sensitivity", &charts, 2, 300.0, 200.0);
        assert_clean(&svg);
        assert_eq!(svg.matches("<g class=\"panel\"").count(), 5);
        assert_eq!(svg.matches("<g class=\"legend\">").count(), 1);
        assert_eq!(svg.matches(">stiffness</text>").count(), 1);
        assert!(svg.contains("width=\"600\""));
        // Rows: 3 of 200 px under the header.
        assert!(svg.contains("translate(0,") && svg.contains("translate(300,"));

        // Different series per panel: a legend in each.
        let mut mixed = charts.clone();
        mixed[3].series[1].name = "mass".into();
        let svg = grid_svg("Sensitivity", &mixed, 0, 300.0, 200.0);
        assert_clean(&svg);
        assert_eq!(svg.matches("<g class=\"panel\"").count(), 5);
        assert_eq!(svg.matches("<g class=\"legend\">").count(), 5);
        // Zero columns means one: every panel at x = 0.
        assert_eq!(svg.matches("translate(0,").count(), 5);

        let svg = grid_svg("", &[], 3, 300.0, 200.0);
        assert_clean(&svg);
        assert_eq!(svg.matches("<g class=\"panel\"").count(), 0);
    }

    fn any_value() -> impl Strategy<Value = f64> {
        prop_oneof![
            proptest::num::f64::ANY,
            Just(f64::NAN),
            Just(f64::INFINITY),
            Just(f64::NEG_INFINITY),
            Just(f64::MAX),
            Just(f64::MIN),
            Just(f64::MIN_POSITIVE),
            Just(5e-324),
            Just(0.0),
            -1e3..1e3f64,
            -1e-300..1e-300f64,
        ]
    }

    fn any_style() -> impl Strategy<Value = SeriesStyle> {
        prop_oneof![
            Just(SeriesStyle::Line),
            Just(SeriesStyle::Dashed),
            Just(SeriesStyle::Markers),
            Just(SeriesStyle::LineAndMarkers),
        ]
    }

    /// Text that cannot spell "NaN" or "inf" by itself but has every XML
    /// special character.
    const TEXT: &str = "[<>&\"' a-eA-E0-9]{0,30}";

    fn any_chart() -> impl Strategy<Value = Chart> {
        let series = (
            TEXT,
            proptest::collection::vec((any_value(), any_value()), 0..30),
            any_style(),
        )
            .prop_map(|(name, points, style)| Series {
                name,
                points,
                style,
            });
        (
            (TEXT, TEXT, TEXT),
            proptest::collection::vec(series, 0..4),
            proptest::option::of((any_value(), any_value())),
            proptest::option::of((any_value(), any_value())),
            proptest::collection::vec((any_value(), TEXT), 0..3),
        )
            .prop_map(
                |((title, x_label, y_label), series, x_range, y_range, refs)| Chart {
                    title,
                    x_label,
                    y_label,
                    series,
                    x_range,
                    y_range,
                    reference_lines: refs
                        .into_iter()
                        .map(|(value, label)| ReferenceLine { value, label })
                        .collect(),
                },
            )
    }

    proptest! {
        #[test]
        fn any_chart_gives_clean_svg(chart in any_chart(), w in any_value(), h in any_value()) {
            let svg = chart_svg(&chart, w, h);
            prop_assert!(check_xml(&svg).is_ok(), "{:?}\n{}", check_xml(&svg), svg);
            prop_assert!(!svg.contains("NaN") && !svg.contains("inf"), "{}", svg);
        }

        #[test]
        fn any_grid_gives_clean_svg(
            charts in proptest::collection::vec(any_chart(), 0..5),
            columns in 0usize..4,
            title in TEXT,
            w in any_value(),
            h in any_value(),
        ) {
            let svg = grid_svg(&title, &charts, columns, w, h);
            prop_assert!(check_xml(&svg).is_ok(), "{:?}\n{}", check_xml(&svg), svg);
            prop_assert!(!svg.contains("NaN") && !svg.contains("inf"), "{}", svg);
            prop_assert_eq!(svg.matches("<g class=\"panel\"").count(), charts.len());
        }

        #[test]
        fn any_text_is_escaped(text in any::<String>()) {
            let chart = Chart::new(text.clone(), text.clone(), text.clone())
                .with_series(Series::new(text.clone(), ramp(3)))
                .with_reference_line(1.0, text.clone());
            let svg = grid_svg(&text, &[chart.clone(), chart], 2, 300.0, 200.0);
            prop_assert!(check_xml(&svg).is_ok(), "{:?}\n{}", check_xml(&svg), svg);
            prop_assert!(!svg.chars().any(|c| c.is_control() && c != '\n'));
        }

        #[test]
        fn any_bounds_give_covering_finite_ticks(low in any_value(), high in any_value(), max in 0usize..40) {
            let ticks = nice_ticks(low, high, max);
            prop_assert!(ticks.len() >= 2 && ticks.len() <= max.clamp(MIN_TICKS, MAX_TICKS));
            prop_assert!(ticks.iter().all(|t| t.is_finite()));
            prop_assert!(ticks.windows(2).all(|p| p[0] < p[1]));
            let (lo, hi) = tick_range(low, high);
            prop_assert!(ticks[0] <= lo && hi <= ticks[ticks.len() - 1], "{:?} for {}..{}", ticks, lo, hi);
            let labels = format_ticks(&ticks);
            prop_assert!(labels.iter().all(|l| !l.is_empty() && l.len() < 24), "{:?}", labels);
        }
    }
}
