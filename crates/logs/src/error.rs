//! A damaged or unexpected log, said with where in the file it is and what to do.

use std::fmt;
use std::path::PathBuf;

/// An error reading a log: the file, the byte offset where the damage or mismatch is (when
/// there is one), what was found, and how to fix it.
#[derive(Debug, Clone, PartialEq)]
pub struct LogError {
    pub path: PathBuf,
    /// Byte offset in the file of the record (or chunk) that could not be read.
    pub offset: Option<u64>,
    /// What is wrong, in words ("chunk 3: bz2 data is damaged").
    pub what: String,
    /// What a user can do about it; empty when there is nothing to add.
    pub fix: String,
}

impl LogError {
    pub fn new(path: impl Into<PathBuf>, what: impl Into<String>) -> LogError {
        LogError {
            path: path.into(),
            offset: None,
            what: what.into(),
            fix: String::new(),
        }
    }

    pub fn at(mut self, offset: u64) -> LogError {
        self.offset = Some(offset);
        self
    }

    pub fn fix(mut self, fix: impl Into<String>) -> LogError {
        self.fix = fix.into();
        self
    }
}

impl fmt::Display for LogError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.path.display())?;
        if let Some(o) = self.offset {
            write!(f, " (byte {o})")?;
        }
        write!(f, ": {}", self.what)?;
        if !self.fix.is_empty() {
            write!(f, "\n  fix: {}", self.fix)?;
        }
        Ok(())
    }
}

impl std::error::Error for LogError {}
