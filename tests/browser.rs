//! The headless-Chromium page check (tests/common/browser.rs) against small
//! pages with known faults: each check must see its fault, and a clean page
//! must come out clean. Needs Chromium; without it these fail with how to
//! install it (scripts/test installs it).

mod common;
use common::browser::{check_page, PageCheck, TableCheck};
use std::path::PathBuf;

/// Writes `body` as a complete page into a fresh temp dir and checks it.
fn check(title: &str, body: &str) -> (PageCheck, tempfile::TempDir) {
    let dir = tempfile::tempdir().unwrap();
    let path: PathBuf = dir.path().join("page.html");
    let html = format!(
        "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">\
         <title>{title}</title></head>\n<body>\n{body}\n</body></html>\n"
    );
    std::fs::write(&path, html).unwrap();
    let started = std::time::Instant::now();
    let page = check_page(&path).unwrap_or_else(|e| panic!("browser check failed: {e}"));
    // Shown on failure (or with --nocapture).
    eprintln!("{title}: {:.2?}\n{page:#?}", started.elapsed());
    (page, dir)
}

const TWO_TABLES: &str = r#"
<h1>Report</h1>
<table id="a">
  <thead><tr><th>Signal</th><th>Value</th></tr></thead>
  <tbody><tr><td>rpm</td><td>1</td></tr><tr><td>bar</td><td>2</td></tr><tr><td>degC</td><td>3</td></tr></tbody>
</table>
<table id="b">
  <tr><th> Case
     name </th><th>Result</th></tr>
  <tr><td>case1</td><td>ok</td></tr>
</table>
<svg width="120" height="40" viewBox="0 0 120 40"><polyline points="0,40 60,0 120,20" fill="none" stroke="black"/></svg>
"#;

#[test]
fn clean_page_has_no_console_errors_and_everything_visible() {
    let (page, _dir) = check("Clean report", TWO_TABLES);
    assert_eq!(page.console_errors, Vec::<String>::new());
    assert_eq!(page.title, "Clean report");
    assert_eq!(
        page.tables,
        vec![
            TableCheck {
                visible: true,
                body_rows: 3,
                first_header: "Signal".into()
            },
            // Bare <tr>s land in an implied <tbody>, header row included.
            TableCheck {
                visible: true,
                body_rows: 2,
                first_header: "Case name".into()
            },
        ]
    );
    assert_eq!(page.visible_svgs, 1);
}

#[test]
fn missing_image_is_a_console_error() {
    let (page, _dir) = check(
        "Missing image",
        r#"<p>x</p><img src="missing.png" alt="plot">"#,
    );
    assert!(
        page.console_errors
            .iter()
            .any(|e| e.contains("Failed to load resource") && e.contains("missing.png")),
        "{:#?}",
        page.console_errors
    );
}

#[test]
fn uncaught_exception_is_a_console_error() {
    let (page, _dir) = check(
        "Throws",
        "<table><tr><td>1</td></tr></table><script>undefinedFunction()</script>",
    );
    assert!(
        page.console_errors
            .iter()
            .any(|e| e.contains("Uncaught") && e.contains("undefinedFunction")),
        "{:#?}",
        page.console_errors
    );
    // The page still rendered.
    assert_eq!(page.tables.len(), 1);
    assert!(page.tables[0].visible);
}

#[test]
fn hidden_table_and_hidden_svg_are_reported_not_visible() {
    let (page, _dir) = check(
        "Hidden",
        r#"<table><tr><td>shown</td></tr></table>
           <table style="display:none"><tr><td>a</td></tr><tr><td>b</td></tr></table>
           <table style="visibility:hidden"><tr><td>c</td></tr></table>
           <div style="display:none"><svg width="50" height="50"><rect width="50" height="50"/></svg></div>
           <svg width="0" height="0"></svg>"#,
    );
    let visible: Vec<bool> = page.tables.iter().map(|t| t.visible).collect();
    assert_eq!(visible, [true, false, false]);
    // Row counts come from the DOM, rendered or not.
    assert_eq!(page.tables[1].body_rows, 2);
    assert_eq!(page.visible_svgs, 0);
    assert_eq!(page.console_errors, Vec::<String>::new());
}

#[test]
fn console_error_and_warning_are_reported_but_log_is_not() {
    let (page, _dir) = check(
        "Console",
        r#"<script>console.log("just logging"); console.info("fyi");
           console.error("broken", 42); console.warn("careful");</script>"#,
    );
    assert_eq!(page.console_errors.len(), 2, "{:#?}", page.console_errors);
    assert!(page.console_errors[0].starts_with("error [console] broken 42"));
    assert!(page.console_errors[1].starts_with("warning [console] careful"));
}

#[test]
fn network_resources_are_refused() {
    // The report must be self-contained: anything off the machine fails.
    let (page, _dir) = check(
        "Network",
        r#"<link rel="stylesheet" href="https://cdn.example.com/style.css">"#,
    );
    assert!(
        page.console_errors
            .iter()
            .any(|e| e.contains("Failed to load resource") && e.contains("cdn.example.com")),
        "{:#?}",
        page.console_errors
    );
}

#[test]
fn missing_file_is_an_error_not_a_blank_page() {
    let dir = tempfile::tempdir().unwrap();
    let err = check_page(&dir.path().join("nope.html")).unwrap_err();
    assert!(err.contains("nope.html"), "{err}");
}
