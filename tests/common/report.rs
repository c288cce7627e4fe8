//! Every report a test reads is first checked as its reader would see it:
//! the HTML page shows no Markdown as text (`**`) and prints no number
//! with more than 8 significant digits (a raw float such as
//! 116.88459379999991 says nothing its first four digits do not).

use std::path::Path;

/// The run directory's report.md, after checking its report.html.
pub fn read(run_dir: &Path) -> String {
    let html = std::fs::read_to_string(run_dir.join("report.html"))
        .unwrap_or_else(|e| panic!("{}/report.html: {e}", run_dir.display()));
    check_html(&html, &run_dir.join("report.html").display().to_string());
    std::fs::read_to_string(run_dir.join("report.md")).unwrap()
}

/// Panics naming `what` if the page's text (its tags, figures' markup
/// included, taken off) shows `**` or a long number.
pub fn check_html(html: &str, what: &str) {
    let text = text_of(html);
    if let Some(at) = text.find("**") {
        panic!(
            "{what}: Markdown shown as text: ...{}...",
            around(&text, at)
        );
    }
    let long = long_numbers(&text);
    assert!(
        long.is_empty(),
        "{what}: numbers with more than 8 significant digits: {long:?}"
    );
}

/// The text between the tags, entities for `&`, `<` and `>` decoded.
fn text_of(html: &str) -> String {
    let mut text = String::with_capacity(html.len());
    let mut in_tag = false;
    for c in html.chars() {
        match c {
            '<' => in_tag = true,
            '>' if in_tag => {
                in_tag = false;
                text.push(' ');
            }
            c if !in_tag => text.push(c),
            _ => {}
        }
    }
    text.replace("&lt;", "<")
        .replace("&gt;", ">")
        .replace("&amp;", "&")
}

fn around(text: &str, at: usize) -> String {
    text.chars()
        .skip(text[..at].chars().count().saturating_sub(40))
        .take(80)
        .collect()
}

/// Decimal numbers (a point and digits after it) whose digits, leading
/// zeros aside, number more than 8. A version or an address (`1.5.0`,
/// `127.0.0.1`) is not a number.
pub fn long_numbers(text: &str) -> Vec<String> {
    let bytes = text.as_bytes();
    let mut found = Vec::new();
    let mut i = 0;
    while i < bytes.len() {
        let starts = bytes[i].is_ascii_digit()
            && (i == 0 || !(bytes[i - 1].is_ascii_alphanumeric() || bytes[i - 1] == b'.'));
        if !starts {
            i += 1;
            continue;
        }
        let mut end = i;
        while end < bytes.len() && bytes[end].is_ascii_digit() {
            end += 1;
        }
        let has_fraction =
            end + 1 < bytes.len() && bytes[end] == b'.' && bytes[end + 1].is_ascii_digit();
        if !has_fraction {
            i = end;
            continue;
        }
        end += 1;
        while end < bytes.len() && bytes[end].is_ascii_digit() {
            end += 1;
        }
        let version =
            end + 1 < bytes.len() && bytes[end] == b'.' && bytes[end + 1].is_ascii_digit();
        let number = &text[i..end];
        let digits = number
            .chars()
            .filter(char::is_ascii_digit)
            .skip_while(|d| *d == '0')
            .count();
        if !version && digits > 8 {
            found.push(number.to_string());
        }
        i = end;
    }
    found
}
