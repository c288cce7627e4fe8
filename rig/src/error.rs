//! What is wrong with a rig file: every problem, each with its line, as
//! loading finds them ([`RigFindings`]) and as the caller gets them.

use std::path::PathBuf;

/// One thing wrong in a rig file.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct RigProblem {
    /// 1-based line, when known.
    pub line: Option<usize>,
    pub message: String,
}

/// A rig file that cannot be used, with every problem found.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct RigError {
    pub path: PathBuf,
    pub problems: Vec<RigProblem>,
}

impl std::fmt::Display for RigError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let count = self.problems.len();
        write!(
            f,
            "{} has {count} problem{}:",
            self.path.display(),
            if count == 1 { "" } else { "s" }
        )?;
        for problem in &self.problems {
            match problem.line {
                Some(line) => write!(f, "\n  {}:{line}: {}", self.path.display(), problem.message)?,
                None => write!(f, "\n  {}: {}", self.path.display(), problem.message)?,
            }
        }
        Ok(())
    }
}

impl std::error::Error for RigError {}

/// What reading a rig file found: each problem with its line, and the
/// warnings of its DBC files (entries they skip).
pub(crate) struct RigFindings<'t> {
    pub(crate) text: &'t str,
    pub(crate) problems: Vec<RigProblem>,
    pub(crate) warnings: Vec<String>,
}

impl RigFindings<'_> {
    pub(crate) fn report(&mut self, line: usize, message: String) {
        self.problems.push(RigProblem {
            line: Some(line),
            message,
        });
    }
}
