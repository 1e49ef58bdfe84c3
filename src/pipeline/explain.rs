//! Why an instance would run: the difference between the fields it was last built with and
//! the fields it has now, in words.

use super::cache::Record;
use super::key::Fields;

fn short(v: &str) -> String {
    if v.len() == 64 && v.chars().all(|c| c.is_ascii_hexdigit()) {
        v[..12].to_string()
    } else {
        v.to_string()
    }
}

/// Reasons, most specific first. `None` for `prev` means the instance was never built.
pub fn reasons(prev: Option<&Record>, cur: &Fields) -> Vec<String> {
    let Some(prev) = prev else {
        let inputs: Vec<&str> = cur
            .0
            .iter()
            .filter_map(|(n, _)| n.strip_prefix("input "))
            .collect();
        return vec![match inputs.as_slice() {
            [one] => format!("new input {one} (never built)"),
            [] => "never built".to_string(),
            many => format!("never built ({} inputs)", many.len()),
        }];
    };
    let mut out = Vec::new();
    for (n, v) in &cur.0 {
        match prev.fields.get(n) {
            None => out.push(match n.split_once(' ') {
                Some(("input", p)) => format!("new input {p}"),
                Some(("upstream", u)) => format!("new upstream {u}"),
                _ => format!("{n} set to {v}"),
            }),
            Some(old) if old != v => out.push(match n.split_once(' ') {
                Some(("input", p)) => {
                    format!("input {p} changed (blake3 {} -> {})", short(old), short(v))
                }
                Some(("upstream", u)) => format!("upstream {u} changed"),
                _ => format!("{n} changed: {old} -> {v}"),
            }),
            _ => {}
        }
    }
    for (n, _) in &prev.fields.0 {
        if cur.get(n).is_none() {
            out.push(match n.split_once(' ') {
                Some(("input", p)) => format!("input {p} was removed"),
                Some(("upstream", u)) => format!("upstream {u} was removed"),
                _ => format!("{n} was removed"),
            });
        }
    }
    if out.is_empty() {
        out.push("its last result was built without an upstream that had failed, or is missing from the cache (.hydrofit was cleaned or edited)".into());
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn f(pairs: &[(&str, &str)]) -> Fields {
        Fields(
            pairs
                .iter()
                .map(|(a, b)| (a.to_string(), b.to_string()))
                .collect(),
        )
    }

    #[test]
    fn names_what_changed() {
        let prev = Record {
            id: "fit".into(),
            key: "k".into(),
            fields: f(&[
                ("setting.method", "\"ols\""),
                ("upstream cfd[a]", "1"),
                ("upstream cfd[b]", "2"),
            ]),
        };
        let cur = f(&[
            ("setting.method", "\"tls\""),
            ("upstream cfd[a]", "1"),
            ("upstream cfd[c]", "3"),
        ]);
        assert_eq!(
            reasons(Some(&prev), &cur),
            [
                "setting.method changed: \"ols\" -> \"tls\"",
                "new upstream cfd[c]",
                "upstream cfd[b] was removed"
            ]
        );
        assert_eq!(
            reasons(None, &f(&[("input cases/a.csv", "h")])),
            ["new input cases/a.csv (never built)"]
        );
    }
}
