//! The estimator comparison (seed 001 Table 2, reproduced on this project's data).

use crate::compare::artifact::Comparison;
use maud::{Markup, html};
use std::fmt::Write as _;

fn pct(x: Option<f64>) -> String {
    x.map_or("–".into(), |v| format!("{v:.2} %"))
}

/// Which method wins and by how much, in words: whatever the numbers say.
pub fn verdict(c: &Comparison) -> String {
    let mut by_truth: Vec<_> = c
        .rows
        .iter()
        .filter_map(|r| Some((r.max_abs_error_pct?, r)))
        .collect();
    by_truth.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut out = String::new();
    if let [first, second, rest @ ..] = by_truth.as_slice() {
        let _ = write!(
            out,
            "Closest to the known parameters: {} (worst parameter off by {:.2} %), then {} ({:.2} %)",
            first.1.label, first.0, second.1.label, second.0
        );
        if let Some(last) = rest.last() {
            let _ = write!(out, "; last: {} ({:.2} %)", last.1.label, last.0);
        }
        out.push_str(". ");
    }
    let mut by_pool: Vec<_> = c
        .rows
        .iter()
        .filter_map(|r| Some((r.pool_nmae?, r)))
        .collect();
    by_pool.sort_by(|a, b| a.0.total_cmp(&b.0));
    if let [first, .., last] = by_pool.as_slice() {
        let runs = c.pool_runs.join(", ");
        // Below the printed precision, "best" and "worst" would name a difference nobody can see.
        if last.0 - first.0 < 0.0005 {
            let _ = write!(
                out,
                "On the held-out pool runs ({runs}) every method scores the same mean NMAE, {:.3}, to three decimals.",
                first.0
            );
        } else {
            let _ = write!(
                out,
                "On the held-out pool runs ({runs}) the best is {} (mean NMAE {:.3}) and the worst {} ({:.3}), {:.0} % above the best.",
                first.1.label,
                first.0,
                last.1.label,
                last.0,
                100.0 * (last.0 / first.0 - 1.0)
            );
        }
    }
    out
}

pub fn section(c: &Comparison) -> Markup {
    let names: Vec<String> = c
        .rows
        .iter()
        .find(|r| !r.parameters.is_empty())
        .map_or(vec![], |r| {
            r.parameters.iter().map(|p| p.name.clone()).collect()
        });
    html! {
        h2 id="comparison" { "Estimators compared (seed 001, Table 2)" }
        p {
            "Every method on the same " (c.samples) " equation rows from " (c.cases)
            " CFD cases. Each cell: value and, where the truth is known, its error. Time is wall-clock on this machine; evaluations count objective calls."
        }
        p { b { (verdict(c)) } }
        table {
            tr {
                th { "method" }
                @for n in &names { th { (n) } }
                th { "worst error" } th { "pool NMAE" } th { "time (s)" } th { "evaluations" }
            }
            @for r in &c.rows {
                tr {
                    td { code { (r.label) } }
                    @if let Some(e) = &r.error {
                        td colspan=(names.len()) class="warn" { (e) }
                    } @else {
                        @for p in &r.parameters {
                            td {
                                (format!("{:.3}", p.value))
                                @if let Some(e) = r.error_pct.get(&p.name) {
                                    br;
                                    span class="small" { (format!("{e:+.2} %")) }
                                }
                            }
                        }
                    }
                    td { (pct(r.max_abs_error_pct)) }
                    td { (r.pool_nmae.map_or("–".into(), |v| format!("{v:.3}"))) }
                    td { (format!("{:.3}", r.seconds)) }
                    td { (r.evaluations.map_or("–".into(), |e| e.to_string())) }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::compare::artifact::Row;

    fn row(label: &str, truth: f64, nmae: f64) -> Row {
        Row {
            label: label.into(),
            settings: serde_json::Value::Null,
            parameters: vec![],
            error_pct: Default::default(),
            max_abs_error_pct: Some(truth),
            pool_nmae: Some(nmae),
            seconds: 0.0,
            evaluations: None,
            error: None,
        }
    }

    fn comparison(rows: Vec<Row>) -> Comparison {
        Comparison {
            rows,
            samples: 0,
            cases: 0,
            pool_runs: vec!["mixed".into()],
        }
    }

    #[test]
    fn a_tie_is_called_a_tie_and_a_spread_is_measured() {
        let tie = verdict(&comparison(vec![
            row("ols", 1.47, 0.0661),
            row("qpso (l1)", 0.99, 0.0662),
        ]));
        assert!(
            tie.contains("every method scores the same mean NMAE, 0.066")
                && !tie.contains("the worst")
                && !tie.contains("last:"),
            "{tie}"
        );
        let spread = verdict(&comparison(vec![
            row("ols", 1.47, 0.050),
            row("ga (l2)", 1.46, 0.060),
        ]));
        assert!(
            spread.contains("the best is ols (mean NMAE 0.050) and the worst ga (l2) (0.060), 20 % above the best"),
            "{spread}"
        );
    }
}
