//! A report as a document: headings, paragraphs, lists, tables and SVG
//! figures, rendered both to Markdown (figures as links to their files) and
//! to one self-contained HTML page (figures inline, no script, no network).
//!
//! One model for both, so the Markdown and the HTML of a report never say
//! different things. Text (headings, paragraphs, list items, table cells)
//! is Markdown: `code`, **strong** and *emphasis* render in HTML as they
//! read in the Markdown (CommonMark, through `pulldown-cmark`); raw HTML in
//! it (a parameter's name, a path) is shown as text, never interpreted.

use std::fmt::Write as _;

/// A report under construction.
#[derive(Clone, Debug, Default)]
pub struct Document {
    blocks: Vec<Block>,
}

#[derive(Clone, Debug)]
enum Block {
    Heading { level: usize, text: String },
    Paragraph(String),
    List(Vec<String>),
    Table(Table),
    Figure(Figure),
}

/// A table built row by row; cells are plain text.
#[derive(Clone, Debug)]
pub struct Table {
    header: Vec<String>,
    rows: Vec<Vec<String>>,
}

impl Table {
    pub fn new(header: &[&str]) -> Self {
        Table {
            header: header.iter().map(|h| h.to_string()).collect(),
            rows: Vec::new(),
        }
    }

    pub fn row(&mut self, cells: Vec<String>) {
        self.rows.push(cells);
    }

    pub fn is_empty(&self) -> bool {
        self.rows.is_empty()
    }

    /// The table in Markdown (pipes in cells escaped).
    pub fn to_markdown(&self) -> String {
        let line = |cells: &[String]| {
            let cells: Vec<String> = cells.iter().map(|c| c.replace('|', "\\|")).collect();
            format!("| {} |\n", cells.join(" | "))
        };
        let mut text = line(&self.header);
        text.push_str(&line(&vec!["---".to_string(); self.header.len()]));
        for row in &self.rows {
            text.push_str(&line(row));
        }
        text
    }

    fn to_html(&self, out: &mut String) {
        out.push_str("<table>\n<thead><tr>");
        for cell in &self.header {
            let _ = write!(out, "<th>{}</th>", inline(cell));
        }
        out.push_str("</tr></thead>\n<tbody>\n");
        for row in &self.rows {
            out.push_str("<tr>");
            for cell in row {
                let class = if looks_numeric(cell) {
                    " class=\"num\""
                } else {
                    ""
                };
                let _ = write!(out, "<td{class}>{}</td>", inline(cell));
            }
            out.push_str("</tr>\n");
        }
        out.push_str("</tbody>\n</table>\n");
    }
}

/// A plot: its SVG text, the file it is written to (relative to the
/// document's directory) and a caption.
#[derive(Clone, Debug)]
pub struct Figure {
    pub file: String,
    pub caption: String,
    pub svg: String,
}

impl Document {
    pub fn new() -> Self {
        Document::default()
    }

    pub fn heading(&mut self, level: usize, text: impl Into<String>) -> &mut Self {
        self.blocks.push(Block::Heading {
            level: level.clamp(1, 6),
            text: text.into(),
        });
        self
    }

    pub fn paragraph(&mut self, text: impl Into<String>) -> &mut Self {
        self.blocks.push(Block::Paragraph(text.into()));
        self
    }

    pub fn list(&mut self, items: Vec<String>) -> &mut Self {
        if !items.is_empty() {
            self.blocks.push(Block::List(items));
        }
        self
    }

    pub fn table(&mut self, table: Table) -> &mut Self {
        self.blocks.push(Block::Table(table));
        self
    }

    pub fn figure(&mut self, figure: Figure) -> &mut Self {
        self.blocks.push(Block::Figure(figure));
        self
    }

    /// The figures, to write beside the report.
    pub fn figures(&self) -> impl Iterator<Item = &Figure> {
        self.blocks.iter().filter_map(|b| match b {
            Block::Figure(f) => Some(f),
            _ => None,
        })
    }

    /// Appends `other` with its headings `levels` deeper and its figure files
    /// under `directory` (the sub-report's directory relative to this one).
    pub fn include(&mut self, other: &Document, levels: usize, directory: &str) -> &mut Self {
        for block in &other.blocks {
            self.blocks.push(match block {
                Block::Heading { level, text } => Block::Heading {
                    level: (level + levels).min(6),
                    text: text.clone(),
                },
                Block::Figure(f) => Block::Figure(Figure {
                    file: if directory.is_empty() {
                        f.file.clone()
                    } else {
                        format!("{}/{}", directory.trim_end_matches('/'), f.file)
                    },
                    ..f.clone()
                }),
                other => other.clone(),
            });
        }
        self
    }

    pub fn to_markdown(&self) -> String {
        let mut out = String::new();
        for block in &self.blocks {
            match block {
                Block::Heading { level, text } => {
                    let _ = writeln!(out, "{} {text}\n", "#".repeat(*level));
                }
                Block::Paragraph(text) => {
                    let _ = writeln!(out, "{text}\n");
                }
                Block::List(items) => {
                    for item in items {
                        let _ = writeln!(out, "- {item}");
                    }
                    out.push('\n');
                }
                Block::Table(table) => {
                    out.push_str(&table.to_markdown());
                    out.push('\n');
                }
                Block::Figure(f) => {
                    let _ = writeln!(out, "![{}]({})\n", f.caption, f.file);
                }
            }
        }
        out
    }

    /// One HTML page that needs nothing else: styles and plots inline.
    pub fn to_html(&self, title: &str) -> String {
        let mut out = String::new();
        let _ = write!(
            out,
            "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n\
             <meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n\
             <title>{}</title>\n<style>\n{STYLE}</style>\n</head>\n<body>\n<main>\n",
            escape(title)
        );
        for block in &self.blocks {
            match block {
                Block::Heading { level, text } => {
                    let _ = writeln!(
                        out,
                        "<h{level} id=\"{}\">{}</h{level}>",
                        anchor(text),
                        inline(text)
                    );
                }
                Block::Paragraph(text) => {
                    let _ = writeln!(out, "<p>{}</p>", inline(text));
                }
                Block::List(items) => {
                    out.push_str("<ul>\n");
                    for item in items {
                        let _ = writeln!(out, "<li>{}</li>", inline(item));
                    }
                    out.push_str("</ul>\n");
                }
                Block::Table(table) => {
                    out.push_str("<div class=\"table\">\n");
                    table.to_html(&mut out);
                    out.push_str("</div>\n");
                }
                Block::Figure(f) => {
                    let _ = write!(
                        out,
                        "<figure>\n{}\n<figcaption>{} (<code>{}</code>)</figcaption>\n</figure>\n",
                        inline_svg(&f.svg),
                        escape(&f.caption),
                        escape(&f.file)
                    );
                }
            }
        }
        out.push_str("</main>\n</body>\n</html>\n");
        out
    }
}

const STYLE: &str =
    "body { font-family: 'DejaVu Sans', Arial, sans-serif; color: #222; margin: 0; }
main { max-width: 1100px; margin: 0 auto; padding: 1em 2em 4em; }
h1 { border-bottom: 2px solid #444; padding-bottom: .2em; }
h2 { border-bottom: 1px solid #bbb; margin-top: 2em; }
div.table { overflow-x: auto; margin: .8em 0; }
table { border-collapse: collapse; font-size: 13px; }
th, td { border: 1px solid #ccc; padding: 3px 8px; text-align: left; vertical-align: top; }
th { background: #f0f0f0; }
td.num { text-align: right; font-variant-numeric: tabular-nums; white-space: nowrap; }
tbody tr:nth-child(even) { background: #fafafa; }
code { background: #f3f3f3; padding: 0 3px; }
figure { margin: 1em 0; }
figure svg { max-width: 100%; height: auto; }
figcaption { font-size: 13px; color: #555; }
";

/// An SVG file's text ready to sit in HTML: without an XML declaration.
fn inline_svg(svg: &str) -> &str {
    let text = svg.trim();
    match text.strip_prefix("<?xml") {
        Some(rest) => rest
            .split_once("?>")
            .map_or(text, |(_, after)| after.trim_start()),
        None => text,
    }
}

/// Escapes text for HTML element content and attribute values.
pub fn escape(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for c in text.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&#39;"),
            c => out.push(c),
        }
    }
    out
}

/// Markdown text as inline HTML: its spans (code, strong, emphasis, links)
/// rendered, HTML in it escaped, and the paragraph CommonMark would wrap
/// it in left off (the caller's element holds it). Text a block would
/// start with (`1. `, `- `, `# `) is kept as text: a line of a report is
/// never re-read as a list or a heading.
fn inline(text: &str) -> String {
    use pulldown_cmark::{Event, Parser, Tag, TagEnd};
    let events = Parser::new(text).filter_map(|event| match event {
        // A name or a path that holds markup is text.
        Event::Html(raw) | Event::InlineHtml(raw) => Some(Event::Text(raw)),
        Event::Start(Tag::Paragraph) | Event::End(TagEnd::Paragraph) => None,
        other => Some(other),
    });
    let block_start = |event: &Event<'_>| {
        matches!(
            event,
            Event::Start(
                Tag::List(_)
                    | Tag::Item
                    | Tag::Heading { .. }
                    | Tag::BlockQuote(_)
                    | Tag::CodeBlock(_)
                    | Tag::Table(_)
            ) | Event::Rule
        )
    };
    if Parser::new(text).any(|e| block_start(&e)) {
        return escape(text);
    }
    let mut out = String::new();
    pulldown_cmark::html::push_html(&mut out, events);
    out.trim_end().to_string()
}

/// A heading's id: lower-case letters and digits, dashes between words.
fn anchor(text: &str) -> String {
    let mut id = String::new();
    for c in text.chars() {
        if c.is_ascii_alphanumeric() {
            id.push(c.to_ascii_lowercase());
        } else if !id.ends_with('-') && !id.is_empty() {
            id.push('-');
        }
    }
    id.trim_end_matches('-').to_string()
}

/// A cell that holds a number (with an optional unit or % after it), to
/// right-align in HTML.
fn looks_numeric(cell: &str) -> bool {
    let first = cell.split_whitespace().next().unwrap_or("");
    !first.is_empty() && first.parse::<f64>().is_ok()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> Document {
        let mut doc = Document::new();
        doc.heading(1, "Report <1>")
            .paragraph("Run `acq demo` & look.");
        let mut table = Table::new(&["quantity", "mean [bar]"]);
        table.row(vec!["arm|head".into(), "193.46".into()]);
        doc.table(table);
        doc.figure(Figure {
            file: "loss.svg".into(),
            caption: "loss".into(),
            svg: "<?xml version=\"1.0\"?>\n<svg xmlns=\"http://www.w3.org/2000/svg\"></svg>".into(),
        });
        doc
    }

    #[test]
    fn markdown_links_figures_and_escapes_pipes() {
        let md = sample().to_markdown();
        assert!(md.starts_with("# Report <1>\n"));
        assert!(md.contains("| arm\\|head | 193.46 |"));
        assert!(md.contains("![loss](loss.svg)"));
    }

    #[test]
    fn html_is_escaped_and_inlines_svg_without_declaration() {
        let html = sample().to_html("t & u");
        assert!(html.contains("<title>t &amp; u</title>"));
        assert!(html.contains("<h1 id=\"report-1\">Report &lt;1&gt;</h1>"));
        assert!(html.contains("<p>Run <code>acq demo</code> &amp; look.</p>"));
        assert!(html.contains("<td>arm|head</td><td class=\"num\">193.46</td>"));
        assert!(html.contains("<figure>\n<svg xmlns"));
        assert!(!html.contains("<?xml"));
        assert!(!html.contains("<script"), "no script in a report");
        assert!(
            !html.contains("src=") && !html.contains("<link"),
            "nothing to fetch"
        );
    }

    #[test]
    fn an_included_document_goes_deeper_and_its_figures_under_its_directory() {
        let mut top = Document::new();
        top.heading(1, "All");
        top.include(&sample(), 1, "case1/");
        let md = top.to_markdown();
        assert!(md.contains("## Report <1>"));
        assert!(md.contains("![loss](case1/loss.svg)"));
        assert_eq!(top.figures().count(), 1);
    }

    /// What a report's text says in Markdown reads the same in HTML:
    /// strong and emphasis rendered, markup in names shown as text, a line
    /// that would start a list or a heading left as it is written.
    #[test]
    fn markdown_spans_render_and_markup_stays_text() {
        assert_eq!(
            inline("**Not converged**: sample *longer*"),
            "<strong>Not converged</strong>: sample <em>longer</em>"
        );
        assert_eq!(inline("**no**"), "<strong>no</strong>");
        assert_eq!(
            inline("name <script>alert(1)</script>"),
            "name &lt;script&gt;alert(1)&lt;/script&gt;"
        );
        assert_eq!(inline("1. first"), "1. first");
        assert_eq!(inline("- 3 bar"), "- 3 bar");
        assert_eq!(inline("# not a heading"), "# not a heading");
        assert_eq!(
            inline("k_top and k_side, f_u* and f_c*"),
            "k_top and k_side, f_u* and f_c*"
        );
        assert_eq!(inline("-"), "-");
    }

    #[test]
    fn an_unpaired_backtick_is_kept() {
        assert_eq!(inline("a ` b"), "a ` b");
        assert_eq!(inline("`<x>`"), "<code>&lt;x&gt;</code>");
    }
}
