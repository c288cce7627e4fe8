//! What is wrong with a rig file: every problem, each with its line.

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
