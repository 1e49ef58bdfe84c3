//! Errors about a user's input file: where (file, line, column), what was expected, how to fix it.

use std::fmt;

/// A stage's executor cannot run on this machine (a cluster that does not answer): the build
/// adds to the message why the instance had to run at all, which says whether it can be
/// avoided (restore the input) or must run elsewhere.
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct ExecutorUnavailable(pub String);

/// A problem in an input file, printed as `path:line:col: what`, the offending line with a
/// caret under the column, and a `help:` line saying what to change.
#[derive(Debug, Clone, PartialEq)]
pub struct InputError {
    pub path: String,
    pub line: Option<usize>,
    pub col: Option<usize>,
    pub what: String,
    pub fix: String,
    /// The text of the offending line, shown under the message.
    pub snippet: Option<String>,
}

impl InputError {
    pub fn file(
        path: impl Into<String>,
        what: impl Into<String>,
        fix: impl Into<String>,
    ) -> InputError {
        InputError {
            path: path.into(),
            line: None,
            col: None,
            what: what.into(),
            fix: fix.into(),
            snippet: None,
        }
    }

    pub fn at(mut self, line: usize, col: Option<usize>) -> InputError {
        self.line = Some(line);
        self.col = col;
        self
    }

    /// Attach the source line `line` (1-based) of `text` as the snippet.
    pub fn with_source(mut self, text: &str) -> InputError {
        if let Some(l) = self.line {
            self.snippet = text
                .lines()
                .nth(l.saturating_sub(1))
                .map(|s| s.trim_end_matches('\r').to_string());
        }
        self
    }
}

impl fmt::Display for InputError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", clip(&self.path, 500))?;
        if let Some(l) = self.line {
            write!(f, ":{l}")?;
            if let Some(c) = self.col {
                write!(f, ":{c}")?;
            }
        }
        // Messages may quote input; none needs more than this to say what is wrong.
        write!(f, ": {}", clip(&self.what, 2000))?;
        if let Some(s) = &self.snippet {
            let shown: String = s.chars().take(160).collect();
            write!(f, "\n    | {shown}")?;
            if let Some(c) = self.col.filter(|c| *c <= 160) {
                write!(f, "\n    | {}^", " ".repeat(c.saturating_sub(1)))?;
            }
        }
        if !self.fix.is_empty() {
            write!(f, "\n  help: {}", clip(&self.fix, 2000))?;
        }
        Ok(())
    }
}

impl std::error::Error for InputError {}

/// Edit distance counting a swap of neighbours as one edit (optimal string alignment), for
/// "did you mean" suggestions: `cdf` is one typo away from `cfd`.
pub fn edit_distance(a: &str, b: &str) -> usize {
    let (a, b): (Vec<char>, Vec<char>) = (a.chars().collect(), b.chars().collect());
    let mut d = vec![vec![0usize; b.len() + 1]; a.len() + 1];
    for (i, row) in d.iter_mut().enumerate() {
        row[0] = i;
    }
    for (j, cell) in d[0].iter_mut().enumerate() {
        *cell = j;
    }
    for i in 1..=a.len() {
        for j in 1..=b.len() {
            let cost = usize::from(a[i - 1] != b[j - 1]);
            d[i][j] = (d[i - 1][j] + 1)
                .min(d[i][j - 1] + 1)
                .min(d[i - 1][j - 1] + cost);
            if i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1] {
                d[i][j] = d[i][j].min(d[i - 2][j - 2] + 1);
            }
        }
    }
    d[a.len()][b.len()]
}

/// The candidate closest to `word`, if it is close enough to be a plausible typo.
pub fn nearest<'a>(word: &str, candidates: impl IntoIterator<Item = &'a str>) -> Option<&'a str> {
    candidates
        .into_iter()
        .map(|c| (edit_distance(&word.to_lowercase(), &c.to_lowercase()), c))
        .filter(|(d, c)| *d <= (c.len().max(word.len()) / 2).max(1))
        .min_by_key(|(d, _)| *d)
        .map(|(_, c)| c)
}

/// `s` cut to at most `n` characters, saying how much was left out.
pub fn clip(s: &str, n: usize) -> String {
    let count = s.chars().count();
    if count <= n {
        return s.to_string();
    }
    let head: String = s.chars().take(n).collect();
    format!("{head}... ({} more characters)", count - n)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shows_line_and_caret() {
        let e = InputError::file("a.csv", "bad number", "fix it")
            .at(2, Some(3))
            .with_source("x\nab?c\n");
        assert_eq!(
            e.to_string(),
            "a.csv:2:3: bad number\n    | ab?c\n    |   ^\n  help: fix it"
        );
    }

    #[test]
    fn suggests_close_names() {
        assert_eq!(nearest("sttages", ["vehicle", "stages"]), Some("stages"));
        assert_eq!(nearest("zzz", ["vehicle", "stages"]), None);
        assert_eq!(nearest("cdf", ["cfd", "fit", "report"]), Some("cfd"));
    }
}
