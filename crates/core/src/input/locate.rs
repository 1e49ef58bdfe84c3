//! Maps a key path in `pipeline.yaml` (`stages.fit.settings.method`) to its line and column,
//! so that errors found after parsing still point at the text a person has to change.

use std::collections::BTreeMap;

#[derive(Debug, Default)]
pub struct KeyIndex {
    keys: BTreeMap<String, (usize, usize)>,
}

impl KeyIndex {
    /// Indexes block-style mapping keys by indentation (flow mappings resolve to their parent).
    pub fn new(text: &str) -> KeyIndex {
        let mut keys = BTreeMap::new();
        let mut stack: Vec<(usize, String)> = Vec::new();
        for (i, raw) in text.lines().enumerate() {
            let mut indent = raw.len() - raw.trim_start().len();
            let mut body = raw.trim_start();
            if body.starts_with('#') || body.is_empty() {
                continue;
            }
            while let Some(rest) = body.strip_prefix("- ") {
                indent += 2;
                body = rest.trim_start();
            }
            let Some(key) = leading_key(body) else {
                continue;
            };
            while stack.last().is_some_and(|(ind, _)| *ind >= indent) {
                stack.pop();
            }
            stack.push((indent, key));
            let path = stack
                .iter()
                .map(|(_, k)| k.as_str())
                .collect::<Vec<_>>()
                .join(".");
            keys.entry(path).or_insert((i + 1, indent + 1));
        }
        KeyIndex { keys }
    }

    /// Line and column of `path`, or of its longest indexed prefix.
    pub fn find(&self, path: &str) -> Option<(usize, usize)> {
        let mut p = path;
        loop {
            if let Some(loc) = self.keys.get(p) {
                return Some(*loc);
            }
            p = &p[..p.rfind('.')?];
        }
    }
}

fn leading_key(body: &str) -> Option<String> {
    let (quote, rest) = match body.chars().next()? {
        q @ ('"' | '\'') => (Some(q), &body[1..]),
        _ => (None, body),
    };
    let end = match quote {
        Some(q) => rest.find(q)?,
        None => rest.find(':')?,
    };
    let key = &rest[..end];
    let after = &rest[end + usize::from(quote.is_some())..];
    let after = after.strip_prefix(':')?;
    let plain = quote.is_some()
        || key
            .chars()
            .all(|c| c.is_alphanumeric() || "_-. ".contains(c));
    (plain && (after.is_empty() || after.starts_with(' '))).then(|| key.trim().to_string())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn finds_nested_keys() {
        let text = "vehicle:\n  mass_kg: 3\nstages:\n  fit:\n    kind: fit\n    settings:\n      method: ols\n  cfd:\n    inputs:\n      - \"a/*.csv\"\n";
        let idx = KeyIndex::new(text);
        assert_eq!(idx.find("stages.fit.settings.method"), Some((7, 7)));
        assert_eq!(idx.find("stages.cfd.inputs"), Some((9, 5)));
        assert_eq!(idx.find("stages.fit.settings.nothing"), Some((6, 5)));
        assert_eq!(idx.find("vehicle.mass_kg"), Some((2, 3)));
    }
}
