//! Reading a text input the same way everywhere: a folder where a file belongs is an error,
//! the text must be UTF-8, a byte-order mark (Excel and many loggers write one) is dropped,
//! and a last line without its newline is known, so a table can leave out a row a logger may
//! have been cut off in the middle of (`4.49034339e-1,1.1` is a number, but maybe not the one
//! that was being written). Echoes of input in messages are clipped.

pub mod locate;

use crate::diag::InputError;
pub use crate::diag::clip;

/// No data value of a vehicle log (sensor, command) or a DFBI export (force, velocity,
/// acceleration) comes near this in SI units or the export's; beyond it a value is damaged
/// (a cut-off or merged number), not measured. Times are exempt: a time may be a Unix stamp
/// in microseconds.
pub const PLAUSIBLE: f64 = 1e9;
use std::path::Path;

/// An input file's text, its byte-order mark removed.
#[derive(Debug, Clone, PartialEq)]
pub struct Text {
    pub text: String,
    /// The file does not end with a newline: its last line may have been cut off.
    pub unterminated: bool,
}

impl Text {
    pub fn new(raw: &str) -> Text {
        let text = raw.strip_prefix('\u{feff}').unwrap_or(raw).to_string();
        let unterminated = !text.is_empty() && !text.ends_with('\n');
        Text { text, unterminated }
    }

    /// The text up to its last newline (all of it when it ends with one), and, when a line
    /// was left out, the note that says so. For tables whose rows are data: a row that may be
    /// torn is left out rather than read as a value it perhaps never had.
    pub fn complete_lines(&self, shown: &str) -> (&str, Option<String>) {
        if !self.unterminated {
            return (&self.text, None);
        }
        let cut = self.text.rfind('\n').map_or(0, |i| i + 1);
        let last = self.text[cut..].trim();
        if last.is_empty() || cut == 0 {
            // Only one line (a header at most), or trailing blanks: nothing to leave out.
            return (&self.text, None);
        }
        let line = self.text[..cut].lines().count() + 1;
        (
            &self.text[..cut],
            Some(format!(
                "{shown}:{line}: the last line has no newline and may have been cut off while it was written (`{}`): left out; end the file with a newline if it is complete",
                clip(last, 60)
            )),
        )
    }
}

/// Reads `rel` (relative to `root`, shown as `rel` in messages) as text. `kind` says what the
/// file should be, for the fix ("export the log as CSV text").
pub fn read(root: &Path, rel: &str, fix: &str) -> Result<Text, InputError> {
    read_path(&root.join(rel), rel, fix)
}

/// As [`read`], for a path shown as `shown`.
pub fn read_path(path: &Path, shown: &str, fix: &str) -> Result<Text, InputError> {
    if path.is_dir() {
        return Err(InputError::file(
            shown,
            "is a folder, where a file is expected",
            "rename or remove the folder; the file it stands in for is read from this path",
        ));
    }
    let bytes = std::fs::read(path).map_err(|e| {
        InputError::file(
            shown,
            format!("cannot read: {e}"),
            "check that the file exists and its permissions",
        )
    })?;
    let text = String::from_utf8(bytes).map_err(|e| {
        let at = e.utf8_error().valid_up_to();
        let bytes = e.as_bytes();
        let line = bytes[..at].iter().filter(|&&b| b == b'\n').count() + 1;
        InputError::file(shown, format!("not UTF-8 text (byte {at} is invalid)"), fix)
            .at(line, None)
    })?;
    Ok(Text::new(&text))
}

/// Line and column of the second block-style occurrence of `key`, at the same indentation
/// as the first, from line `from` on.
fn repeated_key_line(text: &str, from: usize, key: &str) -> Option<(usize, usize)> {
    let mut first_indent = None;
    for (i, raw) in text.lines().enumerate().skip(from.saturating_sub(1)) {
        let body = raw.trim_start().trim_start_matches("- ");
        let indent = raw.len() - body.len();
        let bare = body.strip_prefix(key).is_some_and(|r| r.starts_with(':'));
        let quoted = [format!("\"{key}\":"), format!("'{key}':")]
            .iter()
            .any(|q| body.starts_with(q.as_str()));
        if !(bare || quoted) {
            continue;
        }
        match first_indent {
            None => first_indent = Some(indent),
            Some(f) if f == indent => return Some((i + 1, indent + 1)),
            Some(_) => {}
        }
    }
    None
}

/// The line, column (1-based, in characters) and character of the first control character
/// YAML refuses (all but tab, line feed and carriage return).
fn control_character(text: &str) -> Option<(usize, usize, char)> {
    text.lines().enumerate().find_map(|(i, l)| {
        l.chars()
            .enumerate()
            .find(|(_, c)| c.is_control() && !matches!(c, '\t' | '\r'))
            .map(|(k, c)| (i + 1, k + 1, c))
    })
}

/// The line of the marker (`---`, or `...` then anything) that starts a second document.
fn second_document(text: &str) -> Option<usize> {
    let mut content = false;
    for (i, l) in text.lines().enumerate() {
        let t = l.trim_end();
        if t == "---" || t.starts_with("--- ") || t == "..." {
            if content {
                return Some(i + 1);
            }
            continue;
        }
        if !t.trim_start().is_empty() && !t.trim_start().starts_with('#') {
            content = true;
        }
    }
    None
}

/// Parses YAML after checking that no mapping repeats a key (serde keeps the last of a map's
/// repeated keys without a word). `path` names the file in messages, `fix` says what it takes.
pub fn yaml<T: serde::de::DeserializeOwned>(
    path: &str,
    text: &str,
    fix: &str,
) -> Result<T, InputError> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    if let Some((line, col, c)) = control_character(text) {
        return Err(InputError::file(
            path,
            format!(
                "a control character (U+{:04X}) that YAML does not allow: the file is damaged or is not text",
                c as u32
            ),
            "remove the character (an editor shows it), or restore the file",
        )
        .at(line, Some(col))
        .with_source(text));
    }
    let located = |e: serde_yaml_ng::Error, fix: &str| {
        let msg = e.to_string();
        let msg = msg
            .rfind(" at line ")
            .map_or(msg.as_str(), |i| &msg[..i])
            .replace(
                "expected a YAML tag starting with '!'",
                "expected one word (one of the names the key takes), not a list or a mapping",
            );
        if msg.contains("more than one document") {
            let err = InputError::file(
                path,
                "a second YAML document starts here: the file holds one",
                "remove the `---` line (and merge the two parts into one mapping), or the part after it",
            );
            return match second_document(text) {
                Some(l) => err.at(l, Some(1)).with_source(text),
                None => err,
            };
        }
        let mut err = InputError::file(path, clip(&msg, 300), fix);
        if let Some(l) = e.location() {
            err = err.at(l.line(), Some(l.column())).with_source(text);
        }
        err
    };
    serde_yaml_ng::from_str::<serde_yaml_ng::Value>(text).map_err(|e| {
        let msg = e.to_string();
        let Some(key) = msg
            .split("duplicate entry with key ")
            .nth(1)
            .and_then(|s| s.split('"').nth(1))
            .map(str::to_string)
        else {
            return located(e, fix);
        };
        let from = e.location().map_or(1, |l| l.line());
        let err = located(
            e,
            "a key may appear once in each mapping: remove or rename one of them",
        );
        match repeated_key_line(text, from, &key) {
            Some((l, c)) => err.at(l, Some(c)).with_source(text),
            None => err,
        }
    })?;
    serde_yaml_ng::from_str(text).map_err(|e| located(e, fix))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_byte_order_mark_is_dropped_and_a_torn_line_left_out() {
        let t = Text::new("\u{feff}t,x\n0,1\n1,2.5e");
        assert!(t.unterminated);
        let (body, note) = t.complete_lines("a.csv");
        assert_eq!(body, "t,x\n0,1\n");
        assert!(note.unwrap().starts_with("a.csv:3: the last line"));
        let whole = Text::new("t,x\n0,1\n");
        assert_eq!(whole.complete_lines("a.csv"), ("t,x\n0,1\n", None));
    }

    #[test]
    fn run_yaml_shapes_are_errors_with_their_line() {
        #[derive(serde::Deserialize, Debug)]
        #[serde(rename_all = "snake_case")]
        enum Role {
            Train,
        }
        #[derive(serde::Deserialize, Debug)]
        struct M {
            #[allow(dead_code)]
            role: Role,
            #[serde(default)]
            #[allow(dead_code)]
            description: String,
        }
        let e = yaml::<M>("run.yaml", "role: [train]\n", "fix").unwrap_err();
        let s = e.to_string();
        assert!(
            s.contains("not a list or a mapping") && !s.contains("YAML tag"),
            "{s}"
        );
        assert_eq!(e.line, Some(1));
        let e = yaml::<M>(
            "run.yaml",
            "# a run\nrole: train\n---\nrole: train\n",
            "fix",
        )
        .unwrap_err();
        assert!(e.to_string().contains("second YAML document"), "{e}");
        assert_eq!(e.line, Some(3));
        // A leading `---` is one document.
        assert!(yaml::<M>("run.yaml", "---\nrole: train\n", "fix").is_ok());
        let e = yaml::<M>("run.yaml", "role: train\ndescription: a\u{0}b\n", "fix").unwrap_err();
        assert!(e.to_string().contains("U+0000"), "{e}");
        assert_eq!((e.line, e.col), (Some(2), Some(15)));
    }

    #[test]
    fn repeated_yaml_keys_are_an_error_with_their_line() {
        #[derive(serde::Deserialize, Debug)]
        struct S {
            #[allow(dead_code)]
            m: std::collections::BTreeMap<String, f64>,
        }
        let e = yaml::<S>("p.yaml", "m:\n  a: 1\n  a: 2\n", "fix").unwrap_err();
        assert_eq!(e.line, Some(3), "{e}");
        assert!(e.to_string().contains("duplicate"), "{e}");
        assert!(yaml::<S>("p.yaml", "\u{feff}m:\n  a: 1\n", "fix").is_ok());
    }

    #[test]
    fn a_folder_is_not_a_file_and_echoes_are_clipped() {
        let d = tempfile::tempdir().unwrap();
        std::fs::create_dir(d.path().join("imu.csv")).unwrap();
        let e = read(d.path(), "imu.csv", "").unwrap_err();
        assert!(e.what.contains("folder"), "{e}");
        let long = "x".repeat(10_000);
        assert!(clip(&long, 80).len() < 120);
    }
}
