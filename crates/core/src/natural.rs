//! Names in the order a reader expects: `surge_2N` before `surge_10N` before `surge_100N`.

use std::cmp::Ordering;

/// Compares two names by their runs of digits as numbers and the rest as text, so cases named
/// by their force or speed list in increasing order. Equal numbers written differently
/// (`run_07`, `run_7`) fall back to the text, so the order is total.
pub fn cmp(a: &str, b: &str) -> Ordering {
    let (mut x, mut y) = (chunks(a), chunks(b));
    loop {
        match (x.next(), y.next()) {
            (None, None) => return a.cmp(b),
            (None, Some(_)) => return Ordering::Less,
            (Some(_), None) => return Ordering::Greater,
            (Some(p), Some(q)) => {
                let order = match (digits(p), digits(q)) {
                    (Some(m), Some(n)) => m.len().cmp(&n.len()).then_with(|| m.cmp(n)),
                    _ => p.cmp(q),
                };
                if order != Ordering::Equal {
                    return order;
                }
            }
        }
    }
}

/// `p` without its leading zeros when it is a run of digits.
fn digits(p: &str) -> Option<&str> {
    p.bytes()
        .all(|c| c.is_ascii_digit())
        .then(|| p.trim_start_matches('0'))
}

/// The runs of digits and of everything else, in order.
fn chunks(s: &str) -> impl Iterator<Item = &str> {
    let mut rest = s;
    std::iter::from_fn(move || {
        let first = rest.chars().next()?;
        let digit = first.is_ascii_digit();
        let end = rest
            .char_indices()
            .find(|(_, c)| c.is_ascii_digit() != digit)
            .map_or(rest.len(), |(i, _)| i);
        let (chunk, tail) = rest.split_at(end);
        rest = tail;
        Some(chunk)
    })
}

#[cfg(test)]
mod tests {
    use super::cmp;

    #[test]
    fn numbers_in_names_sort_by_value() {
        let mut names = vec![
            "surge_100N",
            "surge_10N",
            "heave_5N",
            "surge_2N",
            "surge_15N",
            "cylinder_2N_heavy",
            "cylinder_2N",
            "run_07",
            "run_7",
            "run_10",
        ];
        names.sort_by(|a, b| cmp(a, b));
        assert_eq!(
            names,
            [
                "cylinder_2N",
                "cylinder_2N_heavy",
                "heave_5N",
                "run_07",
                "run_7",
                "run_10",
                "surge_2N",
                "surge_10N",
                "surge_15N",
                "surge_100N",
            ]
        );
    }
}
