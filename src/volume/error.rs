//! The one error type of loading: which source failed and why, in one line.

use std::fmt;

/// Why a volume could not be loaded. Displays as one line, `SOURCE: PROBLEM`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct LoadError {
    /// The file path or volume spec the user gave.
    pub source: String,
    /// What is wrong with it, as one sentence without a trailing period.
    pub problem: String,
}

impl LoadError {
    /// An error about `source` (a path or a spec) with a one-line `problem`.
    pub fn new(source: impl fmt::Display, problem: impl Into<String>) -> Self {
        let problem: String = problem.into();
        // Errors must stay on one line, whatever a nested error printed.
        let problem = problem.replace(['\n', '\r'], " ");
        Self {
            source: source.to_string(),
            problem,
        }
    }
}

impl fmt::Display for LoadError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: {}", self.source, self.problem)
    }
}

impl std::error::Error for LoadError {}

/// Short form used inside loaders: `Err(problem)` with the source added by the caller.
pub(crate) type Problem = String;
