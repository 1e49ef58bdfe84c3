//! The report's "Designed runs" section: each pool run that carries the `design.json` of
//! `hydrofit design`, held to its promise. For every parameter the design was for, the
//! standard error the design predicted after the run against the one the model now has with
//! the run among its training runs; the promise is kept when the standard error is at most
//! [`KEPT_WITHIN`] times the prediction. For a design that was to tell two look-alike effects
//! apart, whether the diagnosis now tells them apart.

use super::written::Written;
use crate::diagnose::Diagnosis;
use crate::identify::result::FitResult;
use crate::pool::fusion::run::FusedRun;
use maud::{Markup, PreEscaped, html};

/// The factor within which a predicted standard error counts as achieved.
pub const KEPT_WITHIN: f64 = 1.3;

/// One designed run's check, or None for a run without a design.
pub fn check(run: &FusedRun, fits: &[FitResult], d: Option<&Diagnosis>) -> Option<String> {
    let value = run.meta.design.as_ref()?;
    let name = &run.meta.run;
    let w: Written = match crate::core::lenient::from_str(&value.to_string()) {
        Ok(w) => w,
        Err(e) => {
            let unreadable = html! {
                p {
                    "Run " code { (name) } ": its design.json is not what "
                    code { "hydrofit design" } " writes (" (e.to_string()) "); no check."
                }
            };
            return Some(unreadable.into_string());
        }
    };
    let fit = fits
        .iter()
        .find(|f| f.stage == w.model && f.runs.iter().any(|r| &r.run == name));
    let page = html! {
        h3 { "Run " code { (name) } }
        p { "Designed for model " code { (w.model) } ": " (w.description) "." }
        @match fit {
            Some(f) => { (parameters(&w, f)) },
            // A run designed to tell two effects apart is held out: its promise is the
            // diagnosis's.
            None if w.separates.is_some() => {},
            None => {
                p.warn {
                    "Model " code { (w.model) } " did not train on this run (is its role "
                    code { "train" } "?): its prediction cannot be checked."
                }
            },
        }
        @if let (Some(s), Some(d)) = (&w.separates, d) { (separated(s, d)) }
    };
    Some(page.into_string())
}

/// Whether the diagnosis now tells apart the two effects a design was to separate.
fn separated(s: &super::written::Separation, d: &Diagnosis) -> Markup {
    // Named from the table (a closed form discovery found in an effect's form is not
    // the effect named), and not listed with the other as its look-alike.
    let told = |a: &str, b: &str| {
        d.effects.iter().any(|f| {
            f.name == a && super::separate::named(f) && !f.alike.iter().any(|x| x.name == b)
        })
    };
    let named = |a: &str| (d.effects.iter()).any(|f| f.name == a && super::separate::named(f));
    let verdict = if let Some(b) = &s.beside {
        let listed = (d.effects.iter()).any(|f| f.possibly_beside.iter().any(|x| x.name == *b));
        if named(b) && named(&s.kept) {
            format!("the diagnosis now names {b} beside {}", s.kept)
        } else if named(&s.kept) && !listed {
            format!(
                "the diagnosis now names {} alone, nothing beside it",
                s.kept
            )
        } else {
            format!(
                "the diagnosis still cannot say whether {b} is beside {}: these runs do not tell",
                s.kept
            )
        }
    } else if told(&s.kept, &s.alike) {
        format!("the diagnosis now names {} alone", s.kept)
    } else if told(&s.alike, &s.kept) {
        format!("the diagnosis now names {} alone", s.alike)
    } else {
        "the diagnosis names neither of them alone: these runs still do not tell them apart".into()
    };
    html! {
        p {
            "It was to tell " (s.kept) " from " (s.alike) " (predicted difference "
            (format!("{:.1}", s.designed)) " times the noise floor, the recorded runs "
            (format!("{:.1}", s.recorded)) "): " (verdict) "."
        }
    }
}

/// Each parameter the design was for: its standard error before, as predicted after, and now,
/// and whether the promise was kept.
fn parameters(w: &Written, f: &FitResult) -> Markup {
    let rows: Vec<(&super::written::Row, f64, bool)> = w
        .parameters
        .iter()
        .filter(|r| r.target)
        .map(|r| {
            let now = f
                .fit
                .parameters
                .iter()
                .find(|p| p.name == r.name)
                .map_or(f64::NAN, |p| p.stderr);
            (r, now, now <= KEPT_WITHIN * r.predicted_after)
        })
        .collect();
    let kept = rows.iter().filter(|(_, _, ok)| *ok).count();
    html! {
        p {
            "The promise kept for " (kept) " of " (rows.len())
            " parameters (a standard error at most " (KEPT_WITHIN) " times the prediction):"
        }
        table {
            tr {
                th { "parameter" } th { "standard error before" } th { "predicted after" }
                th { "now" } th {}
            }
            @for (r, now, ok) in &rows {
                tr {
                    td { (r.name) }
                    td { (format!("{:.4}", r.stderr_now)) }
                    td { (format!("{:.4}", r.predicted_after)) }
                    td { (format!("{now:.4}")) }
                    td { @if *ok { "kept" } @else { span.warn { "not kept" } } }
                }
            }
        }
    }
}

/// The section, empty when no run was designed.
pub fn section(runs: &[FusedRun], fits: &[FitResult], d: Option<&Diagnosis>) -> Markup {
    let checks: Vec<String> = runs.iter().filter_map(|r| check(r, fits, d)).collect();
    if checks.is_empty() {
        return Markup::default();
    }
    html! {
        h2 id="designed" { "Designed runs" }
        p {
            "Runs proposed by " code { "hydrofit design" }
            ", held to what it predicted they would buy."
        }
        @for c in &checks { (PreEscaped(c)) }
    }
}
