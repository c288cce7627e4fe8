//! A problem with a spec and where it is: the file, or the line of the
//! `[[table]]` at fault.

use std::path::Path;

use acq_io::error::AcqError;

/// A problem with a spec, and where it is.
#[derive(Debug)]
pub struct SpecProblem {
    /// The `[[table]]` header and which of them (0-based), when the problem
    /// is in one.
    table: Option<(&'static str, usize)>,
    message: String,
    /// A measured file that cannot be read as data (exit code 3), rather
    /// than a spec that asks for the wrong thing (2).
    malformed_input: Option<AcqError>,
}

impl SpecProblem {
    /// A problem with the spec as a whole.
    pub fn file(message: impl Into<String>) -> Self {
        SpecProblem {
            table: None,
            message: message.into(),
            malformed_input: None,
        }
    }

    /// A problem in the `index`-th `header` table (`[[case]]`).
    pub fn table(header: &'static str, index: usize, message: impl Into<String>) -> Self {
        SpecProblem {
            table: Some((header, index)),
            ..SpecProblem::file(message)
        }
    }

    /// A file the spec names that cannot be read: its own error.
    pub fn malformed(error: AcqError) -> Self {
        SpecProblem {
            malformed_input: Some(error),
            ..SpecProblem::file(String::new())
        }
    }

    /// The error to report for the spec at `path` with `text`.
    pub fn located(self, path: &Path, text: &str) -> AcqError {
        if let Some(error) = self.malformed_input {
            return error;
        }
        let line = self
            .table
            .map(|(header, index)| format!(":{}", table_line(text, header, index)))
            .unwrap_or_default();
        AcqError::Config(format!("{}{line}: {}", path.display(), self.message))
    }
}

/// The 1-based line of the `index`-th `[[header]]` table in a spec.
fn table_line(text: &str, header: &str, index: usize) -> usize {
    text.lines()
        .enumerate()
        .filter(|(_, line)| line.trim() == header)
        .nth(index)
        .map_or(1, |(number, _)| number + 1)
}
