//! Reports: what a person reads after a run.
//!
//! - [`document`]: a report as headings, paragraphs, lists, tables and SVG
//!   figures, rendered to Markdown and to one self-contained HTML page.
//! - [`number`]: numbers to significant figures, as every report prints them.
//! - [`plot`]: SVG line charts and panel grids (see ARCHITECTURE.md for why
//!   they are written here rather than with a charting crate).
//!
//! A leaf: it knows nothing of what it reports and depends on no other crate
//! of the workspace.

pub mod document;
pub mod number;
pub mod plot;
