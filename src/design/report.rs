//! The report's "Designed runs" section: each pool run that carries the `design.json` of
//! `hydrofit design`, held to its promise. For every parameter the design was for, the
//! standard error the design predicted after the run against the one the model now has with
//! the run among its training runs; the promise is kept when the standard error is at most
//! [`KEPT_WITHIN`] times the prediction. For a design that was to tell two look-alike effects
//! apart, whether the diagnosis now tells them apart.

use super::written::Written;
use crate::core::html::esc;
use crate::diagnose::Diagnosis;
use crate::identify::result::FitResult;
use crate::pool::fusion::run::FusedRun;
use std::fmt::Write as _;

/// The factor within which a predicted standard error counts as achieved.
pub const KEPT_WITHIN: f64 = 1.3;

/// One designed run's check, or None for a run without a design.
pub fn check(run: &FusedRun, fits: &[FitResult], d: Option<&Diagnosis>) -> Option<String> {
    let value = run.meta.design.as_ref()?;
    let name = &run.meta.run;
    let w: Written = match crate::core::lenient::from_str(&value.to_string()) {
        Ok(w) => w,
        Err(e) => {
            return Some(format!(
                "<p>Run <code>{}</code>: its design.json is not what <code>hydrofit design</code> writes ({}); no check.</p>\n",
                esc(name),
                esc(&e.to_string())
            ));
        }
    };
    let mut h = format!(
        "<h3>Run <code>{}</code></h3>\n<p>Designed for model <code>{}</code>: {}.</p>\n",
        esc(name),
        esc(&w.model),
        esc(&w.description)
    );
    match fits
        .iter()
        .find(|f| f.stage == w.model && f.runs.iter().any(|r| &r.run == name))
    {
        Some(f) => parameters(&mut h, &w, f),
        // A run designed to tell two effects apart is held out: its promise is the diagnosis's.
        None if w.separates.is_some() => {}
        None => h.push_str(&format!(
            "<p class=\"warn\">Model <code>{}</code> did not train on this run (is its role <code>train</code>?): its prediction cannot be checked.</p>\n",
            esc(&w.model)
        )),
    }
    if let (Some(s), Some(d)) = (&w.separates, d) {
        // Named from the table (a closed form discovery found in an effect's form is not
        // the effect named), and not listed with the other as its look-alike.
        let told = |a: &str, b: &str| {
            d.effects.iter().any(|f| {
                f.name == a && super::separate::named(f) && !f.alike.iter().any(|x| x.name == b)
            })
        };
        let verdict = if told(&s.kept, &s.alike) {
            format!("the diagnosis now names {} alone", s.kept)
        } else if told(&s.alike, &s.kept) {
            format!("the diagnosis now names {} alone", s.alike)
        } else {
            "the diagnosis names neither of them alone: these runs still do not tell them apart"
                .into()
        };
        let _ = writeln!(
            h,
            "<p>It was to tell {} from {} (predicted difference {:.1} times the noise floor, the recorded runs {:.1}): {}.</p>",
            esc(&s.kept),
            esc(&s.alike),
            s.designed,
            s.recorded,
            esc(&verdict)
        );
    }
    Some(h)
}

fn parameters(h: &mut String, w: &Written, f: &FitResult) {
    let rows: Vec<_> = w.parameters.iter().filter(|r| r.target).collect();
    let mut kept = 0;
    let mut body = String::new();
    for r in &rows {
        let now = f
            .fit
            .parameters
            .iter()
            .find(|p| p.name == r.name)
            .map_or(f64::NAN, |p| p.stderr);
        let ok = now <= KEPT_WITHIN * r.predicted_after;
        kept += usize::from(ok);
        let _ = writeln!(
            body,
            "<tr><td>{}</td><td>{:.4}</td><td>{:.4}</td><td>{:.4}</td><td>{}</td></tr>",
            esc(&r.name),
            r.stderr_now,
            r.predicted_after,
            now,
            if ok {
                "kept"
            } else {
                "<span class=\"warn\">not kept</span>"
            }
        );
    }
    let _ = writeln!(
        h,
        "<p>The promise kept for {kept} of {} parameters (a standard error at most {KEPT_WITHIN} times the prediction):</p>\n<table><tr><th>parameter</th><th>standard error before</th><th>predicted after</th><th>now</th><th></th></tr>\n{body}</table>",
        rows.len()
    );
}

/// The section, empty when no run was designed.
pub fn section(runs: &[FusedRun], fits: &[FitResult], d: Option<&Diagnosis>) -> String {
    let checks: Vec<String> = runs.iter().filter_map(|r| check(r, fits, d)).collect();
    if checks.is_empty() {
        return String::new();
    }
    format!(
        "<h2 id=\"designed\">Designed runs</h2>\n<p>Runs proposed by <code>hydrofit design</code>, held to what it predicted they would buy.</p>\n{}",
        checks.concat()
    )
}
