//! The estimator comparison (seed 001 Table 2, reproduced on this project's data).

use super::html::esc;
use crate::estimate::comparison::Comparison;
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
    if let [first, second, ..] = by_truth.as_slice() {
        let _ = write!(
            out,
            "Closest to the known parameters: {} (worst parameter off by {:.2} %), then {} ({:.2} %); last: {} ({:.2} %). ",
            first.1.label,
            first.0,
            second.1.label,
            second.0,
            by_truth.last().unwrap().1.label,
            by_truth.last().unwrap().0
        );
    }
    let mut by_pool: Vec<_> = c
        .rows
        .iter()
        .filter_map(|r| Some((r.pool_nmae?, r)))
        .collect();
    by_pool.sort_by(|a, b| a.0.total_cmp(&b.0));
    if let [first, .., last] = by_pool.as_slice() {
        let _ = write!(
            out,
            "On the held-out pool runs ({}) the best is {} (mean NMAE {:.3}) and the worst {} ({:.3}); the spread between methods is small next to what the CFD model misses there.",
            c.pool_runs.join(", "),
            first.1.label,
            first.0,
            last.1.label,
            last.0
        );
    }
    out
}

pub fn section(c: &Comparison) -> String {
    let mut h = String::new();
    let names: Vec<String> = c
        .rows
        .iter()
        .find(|r| !r.parameters.is_empty())
        .map_or(vec![], |r| {
            r.parameters.iter().map(|p| p.name.clone()).collect()
        });
    let _ = writeln!(
        h,
        "<h2 id=\"comparison\">Estimators compared (seed 001, Table 2)</h2>\n<p>Every method on the same {} equation rows from {} CFD cases. Each cell: value and, where the truth is known, its error. Time is wall-clock on this machine; evaluations count objective calls.</p>\n<p><b>{}</b></p>",
        c.samples,
        c.cases,
        esc(&verdict(c))
    );
    h.push_str("<table><tr><th>method</th>");
    for n in &names {
        let _ = write!(h, "<th>{}</th>", esc(n));
    }
    h.push_str(
        "<th>worst error</th><th>pool NMAE</th><th>time (s)</th><th>evaluations</th></tr>\n",
    );
    for r in &c.rows {
        let _ = write!(h, "<tr><td><code>{}</code></td>", esc(&r.label));
        if let Some(e) = &r.error {
            let _ = write!(
                h,
                "<td colspan=\"{}\" class=\"warn\">{}</td>",
                names.len(),
                esc(e)
            );
        } else {
            for p in &r.parameters {
                let err = r.error_pct.get(&p.name).map_or(String::new(), |e| {
                    format!("<br><span class=\"small\">{e:+.2} %</span>")
                });
                let _ = write!(h, "<td>{:.3}{err}</td>", p.value);
            }
        }
        let _ = writeln!(
            h,
            "<td>{}</td><td>{}</td><td>{:.3}</td><td>{}</td></tr>",
            pct(r.max_abs_error_pct),
            r.pool_nmae.map_or("–".into(), |v| format!("{v:.3}")),
            r.seconds,
            r.evaluations.map_or("–".into(), |e| e.to_string())
        );
    }
    h.push_str("</table>\n");
    h
}
