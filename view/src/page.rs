//! The page: one HTML skeleton, one script, one style sheet, and uPlot
//! (vendored, MIT: `assets/uplot/LICENSE`, served at `/uplot-license.txt`).
//! Everything is compiled into acq; the page loads nothing from elsewhere.
//!
//! Names from rig and DBC files never enter the HTML: the script puts them
//! into the page as text. The only values written into the skeleton are the
//! session names (escaped) and the token (hex).

use acq_report::document::escape as escape_html;

pub const APP_JS: &str = include_str!("../assets/app.js");
pub const APP_CSS: &str = include_str!("../assets/app.css");
pub const UPLOT_JS: &str = include_str!("../assets/uplot/uPlot.iife.min.js");
pub const UPLOT_CSS: &str = include_str!("../assets/uplot/uPlot.min.css");
pub const UPLOT_LICENSE: &str = include_str!("../assets/uplot/LICENSE");

/// The page for the sessions named; `token` is added to every address.
pub fn html(session_names: &[String], token: Option<&str>) -> String {
    let suffix = token.map_or(String::new(), |t| format!("?token={}", escape_html(t)));
    let title = escape_html(&session_names.join(", "));
    format!(
        "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">\n\
         <meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n\
         <meta name=\"acq-token\" content=\"{token}\">\n\
         <title>acq view: {title}</title>\n\
         <link rel=\"icon\" href=\"data:,\">\n\
         <link rel=\"stylesheet\" href=\"/uplot.css{suffix}\">\n\
         <link rel=\"stylesheet\" href=\"/app.css{suffix}\">\n\
         <script src=\"/uplot.js{suffix}\" defer></script>\n\
         <script src=\"/app.js{suffix}\" defer></script>\n\
         </head>\n<body>\n\
         <header><h1>acq view</h1><span id=\"connection\">connecting</span></header>\n\
         <div id=\"banner\" hidden></div>\n\
         <section id=\"study\" hidden></section>\n\
         <main id=\"sessions\"></main>\n\
         <footer>Plots: <a href=\"/uplot-license.txt{suffix}\">uPlot</a> (MIT). \
         Drag across a plot to zoom; the recording is not touched by anything on this page.</footer>\n\
         </body></html>\n",
        token = escape_html(token.unwrap_or("")),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hostile_names_are_escaped() {
        let page = html(
            &["<script>alert(1)</script>\"'</style>&".to_string()],
            Some("00ff"),
        );
        assert!(!page.contains("<script>alert"), "{page}");
        assert!(!page.contains("</style>\"'"), "{page}");
        assert!(
            page.contains("&lt;script&gt;alert(1)&lt;/script&gt;&quot;&#39;&lt;/style&gt;&amp;")
        );
        assert!(page.contains("/app.js?token=00ff"));
    }
}
