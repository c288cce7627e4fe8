//! A problem with a spec and where it is: the file, or the line of the
//! `[[table]]` at fault. [`SpecProblem`] is what a check finds;
//! [`SpecError`] is what [`super::Spec::load`] returns, a type a caller
//! can match (a spec to fix, or a file that cannot be read).

use std::path::{Path, PathBuf};

use acq_error::AcqError;

/// Why a spec was refused.
#[derive(Debug, thiserror::Error)]
pub enum SpecError {
    /// The spec asks for something it cannot have; `line` is that of the
    /// `[[table]]` at fault, when the problem is in one.
    #[error("{}{}: {message}", path.display(), line.map(|l| format!(":{l}")).unwrap_or_default())]
    Invalid {
        path: PathBuf,
        line: Option<usize>,
        message: String,
    },
    /// The spec or a file it names cannot be read, or is not what its
    /// format says.
    #[error(transparent)]
    Input(#[from] AcqError),
}

/// A spec to fix is a configuration error (exit 2); a file that cannot be
/// read keeps its own kind.
impl From<SpecError> for AcqError {
    fn from(error: SpecError) -> Self {
        match error {
            SpecError::Input(error) => error,
            invalid => AcqError::Config(invalid.to_string()),
        }
    }
}

/// A problem with a spec, and where it is.
#[derive(Debug)]
pub struct SpecProblem {
    /// The `[[table]]` header and which of them (0-based), when the problem
    /// is in one.
    table: Option<(&'static str, usize)>,
    /// A key of a `[table]` (its header, the key), when the problem is in one.
    key: Option<(&'static str, String)>,
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
            key: None,
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

    /// A problem with `key` of the `header` table (`[holds.observe]`).
    pub fn key(header: &'static str, key: &str, message: impl Into<String>) -> Self {
        SpecProblem {
            key: Some((header, key.to_string())),
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
    pub fn located(self, path: &Path, text: &str) -> SpecError {
        if let Some(error) = self.malformed_input {
            return SpecError::Input(error);
        }
        SpecError::Invalid {
            path: path.to_path_buf(),
            line: match (self.table, &self.key) {
                (Some((header, index)), _) => Some(table_line(text, header, index)),
                (None, Some((header, key))) => Some(key_line(text, header, key)),
                (None, None) => None,
            },
            message: self.message,
        }
    }
}

/// The 1-based line of `key` in the `[header]` table: the first line
/// after the header that sets it (bare or quoted), else the header's;
/// without the header, the first line that sets `name.key` or the key.
fn key_line(text: &str, header: &str, key: &str) -> usize {
    let sets = |line: &str, key: &str| {
        let line = line.trim_start();
        [key.to_string(), format!("\"{key}\"")].iter().any(|k| {
            line.strip_prefix(k.as_str())
                .is_some_and(|rest| rest.trim_start().starts_with('='))
        })
    };
    let lines: Vec<&str> = text.lines().collect();
    let dotted = format!(
        "{}.{key}",
        header
            .trim_start_matches('[')
            .trim_end_matches(']')
            .rsplit('.')
            .next()
            .unwrap_or("")
    );
    match lines.iter().position(|line| line.trim() == header) {
        Some(start) => lines[start + 1..]
            .iter()
            .take_while(|line| !line.trim_start().starts_with('['))
            .position(|line| sets(line, key))
            .map_or(start + 1, |offset| start + offset + 2),
        None => lines
            .iter()
            .position(|line| sets(line, &dotted) || sets(line, key))
            .map_or(1, |index| index + 1),
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
