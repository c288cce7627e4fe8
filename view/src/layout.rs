//! A page's layout as a file (`--layout FILE`): which signals go in which
//! plot, in order. The page builds its plots from it instead of one plot
//! per sensor kind, and its "Save layout" button writes the plots as they
//! are now in the same form, so a layout arranged once is loaded again.
//!
//! ```json
//! { "format": 1,
//!   "plots": [ { "title": "boom", "signals": ["boom_head_pressure", "sg09"] },
//!              { "title": "pull", "xy": ["extension", "load"] } ] }
//! ```
//!
//! A signal is a rig sensor's name; a plot lists those of every session
//! that has them (one layout serves the excavator's sessions alike).

use serde::{Deserialize, Serialize};

/// The layout's format; a file of another is refused.
pub const FORMAT: u32 = 1;
/// At most this many plots, and signals in one: far above a screen's worth,
/// far below what would slow the page.
pub const MAX_PLOTS: usize = 64;
pub const MAX_SIGNALS: usize = 256;
/// A layout file is small; a larger one is not a layout.
pub const MAX_BYTES: usize = 1 << 20;

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Layout {
    pub format: u32,
    pub plots: Vec<PlotLayout>,
}

/// One plot: signals over time, or (`xy`) one signal against another.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PlotLayout {
    pub title: String,
    #[serde(default)]
    pub signals: Vec<String>,
    /// `[x, y]`: the second signal against the first.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub xy: Option<[String; 2]>,
}

impl Layout {
    /// A layout from a file's text, checked against the signals the
    /// sessions have (`known`); errors say what to fix, with the line.
    pub fn parse(text: &str, known: &[&str]) -> Result<Layout, String> {
        if text.len() > MAX_BYTES {
            return Err(format!(
                "{} bytes; a layout is at most {MAX_BYTES} (is it the right file?)",
                text.len()
            ));
        }
        let layout: Layout = serde_json::from_str(text).map_err(|e| {
            format!(
                "line {}: {e}; expected {{\"format\": {FORMAT}, \"plots\": [{{\"title\": ..., \"signals\": [...]}}]}} as the page's Save layout writes it",
                e.line()
            )
        })?;
        if layout.format != FORMAT {
            return Err(format!(
                "format {}: this acq reads layouts of format {FORMAT}; save the layout again from the page",
                layout.format
            ));
        }
        if layout.plots.is_empty() || layout.plots.len() > MAX_PLOTS {
            return Err(format!(
                "{} plots; give 1 to {MAX_PLOTS}",
                layout.plots.len()
            ));
        }
        for (k, plot) in layout.plots.iter().enumerate() {
            let which = format!("plot {} ({:?})", k + 1, plot.title);
            if plot.signals.len() > MAX_SIGNALS {
                return Err(format!(
                    "{which}: {} signals; give at most {MAX_SIGNALS}",
                    plot.signals.len()
                ));
            }
            if plot.xy.is_some() && !plot.signals.is_empty() {
                return Err(format!(
                    "{which}: give either signals (over time) or xy (one against another), not both"
                ));
            }
            let mut named = plot.signals.iter().chain(plot.xy.iter().flatten());
            if let Some(unknown) = named.find(|s| !known.contains(&s.as_str())) {
                return Err(format!(
                    "{which}: no session has a signal {unknown:?}; the signals are {}",
                    known.join(", ")
                ));
            }
        }
        Ok(layout)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const KNOWN: [&str; 3] = ["load", "extension", "crosshead"];

    #[test]
    fn a_layout_round_trips_and_mistakes_are_named() {
        let text = r#"{"format": 1, "plots": [{"title": "pull", "signals": ["load", "extension"]}, {"title": "curve", "xy": ["extension", "load"]}]}"#;
        let layout = Layout::parse(text, &KNOWN).unwrap();
        assert_eq!(layout.plots[0].signals, ["load", "extension"]);
        let again = Layout::parse(&serde_json::to_string(&layout).unwrap(), &KNOWN).unwrap();
        assert_eq!(again, layout);
        for (text, says) in [
            (
                r#"{"format": 1, "plots": [{"title": "x", "signals": ["lode"]}]}"#,
                "no session has a signal \"lode\"; the signals are load, extension, crosshead",
            ),
            (
                r#"{"format": 2, "plots": [{"title": "x", "signals": []}]}"#,
                "format 2",
            ),
            (r#"{"format": 1, "plots": []}"#, "0 plots"),
            (
                "{\"format\": 1,\n\"plots\": [{\"title\": \"x\", \"colour\": 3}]}",
                "line 2",
            ),
            ("not json", "line 1"),
            (
                r#"{"format": 1, "plots": [{"title": "x", "xy": ["load", "strain"]}]}"#,
                "no session has a signal \"strain\"",
            ),
            (
                r#"{"format": 1, "plots": [{"title": "x", "signals": ["load"], "xy": ["load", "extension"]}]}"#,
                "not both",
            ),
        ] {
            let error = Layout::parse(text, &KNOWN).unwrap_err();
            assert!(error.contains(says), "{text}: {error}");
        }
    }
}
