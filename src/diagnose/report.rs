//! The report's section on the missing-physics diagnosis: the verdict, each effect with its
//! parameters, evidence and held-out error before and after, where the mismatch is, and every
//! hypothesis tested.

use crate::diagnose::{Diagnosis, Figure};
use maud::{Markup, PreEscaped, html};
use std::collections::BTreeMap;

/// NMAE per DOF as `DOF value` pairs.
fn nmae(m: &BTreeMap<crate::core::dof::Dof, f64>) -> String {
    m.iter()
        .map(|(d, v)| format!("{d} {v:.3}"))
        .collect::<Vec<_>>()
        .join(", ")
}

/// Fitted parameters as `name = value` pairs.
fn parameters(p: &BTreeMap<String, f64>) -> String {
    p.iter()
        .map(|(k, v)| format!("{k} = {v:.3}"))
        .collect::<Vec<_>>()
        .join(", ")
}

/// The diagnosis section: the verdict and criteria, then (unless the model diverged) what was
/// not tested or refused, the errors before and after, the effects, where the model misses,
/// the evidence figures and every hypothesis tested.
pub fn section(d: &Diagnosis, figures: &[Figure]) -> Markup {
    html! {
        (intro(d))
        @if !d.diverged.is_empty() {
            p.warn { "The model diverges on: " (d.diverged.join(", ")) ". Nothing was diagnosed." }
        } @else {
            (untested(d))
            (refused(d))
            (cost_table(d))
            (effects_table(d))
            (candidates(d))
            (reestimated_parameters(d))
            (mismatch_table(d))
            (regimes_table(d))
            @for f in figures {
                figure { (PreEscaped(&f.svg)) figcaption { (f.caption) } }
            }
            (hypotheses(d))
        }
    }
}

/// The heading, the verdict, and how effects were fitted and judged.
fn intro(d: &Diagnosis) -> Markup {
    html! {
        h2 id="diagnosis" { "Why the pool runs and the model differ" }
        p { b { (d.verdict) } }
        p {
            "Model diagnosed: " code { (d.baseline.model) }
            ". Effects are fitted on the training runs (" (d.runs.train.join(", "))
            ") by output error and judged on the held-out runs (" (d.runs.validate.join(", "))
            ") only. Error cost: sum over DOFs of mean squared velocity error / mean squared velocity; noise floor "
            (format!("{:.4}", d.baseline.noise_cost))
            " (the fused velocities' own variance). An effect is kept when it lowers the held-out cost by at least "
            (format!("{:.0}", 100.0 * d.criteria.min_gain)) " % plus "
            (format!("{:.0}", 100.0 * d.criteria.gain_per_parameter))
            " % per parameter and by more than " (format!("{:.1}", d.criteria.min_noise_multiple))
            "× the noise floor. Took " (format!("{:.1}", d.elapsed_s)) " s."
        }
        (started_from(d))
    }
}

/// Which fits of the vehicle the diagnosis chose between, and how each predicts the held-out
/// runs.
fn started_from(d: &Diagnosis) -> Markup {
    html! {
        @if !d.started_from.is_empty() {
            p {
                "Started from " code { (d.baseline.model) }
                ": of the fits of the vehicle among " code { "from" }
                ", a CFD model when there is one (the physics it leaves out is what is diagnosed; a pool fit absorbs some of it), else the one that predicts the held-out runs best. Set "
                code { "model" } " in the stage's settings to choose. Held out:"
            }
            ul {
                @for s in &d.started_from {
                    li {
                        code { (s.model) } " (" (s.method) "): "
                        @match &s.note {
                            Some(n) => { "not scored: " (n) },
                            None => {
                                "held-out cost " (format!("{:.4}", s.validation_cost))
                                ", NMAE " (nmae(&s.validation_nmae))
                            },
                        }
                        @if s.chosen { " — diagnosed" }
                    }
                }
            }
        }
    }
}

/// The hypotheses not tested, each with what the runs lack for it.
fn untested(d: &Diagnosis) -> Markup {
    html! {
        @if let Some(l) = d.runs.latency_taken_out_s {
            p { (format!("The navigation log runs {l:.2} s behind the depth gauge (measured on the runs that change depth, see the fusion above): that latency is the log's, not physics the model leaves out, and was taken out before the diagnosis (each run's command passed through a first-order lag of {l:.2} s, as the late, low-passed recording shows it)." )) }
        }
        @if !d.runs.dead_reckoned.is_empty() {
            p { "Without a position sensor, the position the tether and wall hypotheses read is dead-reckoned from the navigation log's velocity and heading:" }
            ul {
                @for r in &d.runs.dead_reckoned { li { (r) } }
            }
        }
        @if !d.untested.is_empty() {
            p { "Not tested (the runs lack what these hypotheses need):" }
            ul {
                @for u in &d.untested { li { code { (u.name) } ": " (u.missing) } }
            }
        }
    }
}

/// The hypotheses that helped only by pushing a parameter to its bound, which are not findings.
fn refused(d: &Diagnosis) -> Markup {
    let refused: Vec<&crate::diagnose::Tested> = d
        .hypotheses
        .iter()
        .filter(|t| !t.at_bound.is_empty() && t.gain > 0.0)
        .collect();
    html! {
        @if !refused.is_empty() {
            p { "Not findings — pushed to the bound (the data want more than these effects can give):" }
            ul {
                @for t in refused {
                    li {
                        code { (t.name) } " (round " (t.round) "): " (t.at_bound.join(", "))
                        " at its bound; held-out cost " (format!("{:+.1}", -100.0 * t.gain)) " %"
                    }
                }
            }
        }
    }
}

/// The held-out error of the model as fitted, re-estimated, and with each effect added.
fn cost_table(d: &Diagnosis) -> Markup {
    let r = &d.baseline.reestimated;
    html! {
        table {
            tr { th { "model" } th { "held-out NMAE per DOF" } th { "error cost" } }
            tr {
                td { "model as fitted" }
                td { (nmae(&d.baseline.validation_nmae)) }
                td { (format!("{:.4}", d.baseline.validation_cost)) }
            }
            tr {
                @if r.beside.is_empty() {
                    td { "its parameters re-estimated on the training runs (drift)" }
                } @else {
                    td { "its parameters re-estimated beside " (r.beside.join(" and ")) ", with them" }
                }
                td { (nmae(&r.validation_nmae)) }
                td {
                    (format!("{:.4}", r.validation_cost))
                    @if r.within_noise { " (within noise)" }
                }
            }
            @for e in d.effects.iter().filter(|e| e.name != "unexplained") {
                tr {
                    td { "+ " code { (e.name) } }
                    td { (nmae(&e.validation_nmae_after)) }
                    td { (format!("{:.4}", e.validation_cost_after)) }
                }
            }
        }
    }
}

/// The effects kept: DOFs, parameters, held-out error before and after, and the evidence.
fn effects_table(d: &Diagnosis) -> Markup {
    html! {
        @if !d.effects.is_empty() {
            table {
                tr {
                    th { "effect" } th { "DOFs" } th { "parameters" }
                    th { "held-out NMAE before" } th { "after" } th { "evidence" }
                }
                @for e in &d.effects {
                    tr {
                        td { code { (e.name) } }
                        td { (e.dofs.iter().map(|x| x.name()).collect::<Vec<_>>().join(", ")) }
                        td { (parameters(&e.parameters)) }
                        td { (nmae(&e.validation_nmae_before)) }
                        td { (nmae(&e.validation_nmae_after)) }
                        td { (e.evidence) }
                    }
                }
            }
        }
    }
}

/// The closed forms discovery proposed, one per effect that carries one.
fn candidates(d: &Diagnosis) -> Markup {
    html! {
        @for e in &d.effects {
            @if let Some(c) = &e.candidate {
                @for (i, part) in c.parts().enumerate() { (candidate(part, i > 0)) }
            }
        }
    }
}

/// The closed form discovery proposed for what no named effect explains: the expression, each
/// term with its interval and how often it was selected, and the held-out errors; `beside`
/// for a term found with the ones before it in the model.
fn candidate(c: &crate::diagnose::result::Candidate, beside: bool) -> Markup {
    html! {
        h3 {
            @if beside { "Discovered in " (c.dof) ", beside the terms above" }
            @else { "Discovered beyond the named effects" }
        }
        p {
            "Sparse regression of the residual force on " (c.library_terms)
            " candidate terms (velocities and their products, commands and their lags, position, depth, walls, tether, heading, a constant, and sines at the residual's spectral peaks), kept only where the block-bootstrap resamples and the training runs agree, then proved on the held-out runs:"
        }
        p.verdict {
            code { (c.expression) }
            @if let Some(n) = &c.named_as { " — the form of " code { (n) } }
        }
        table {
            tr {
                th { "term" } th { "coefficient" } th { "95 % interval" } th { "frequency (Hz)" }
                th { "phase (rad)" } th { "selected on resamples" } th { "runs that select it" }
            }
            @for t in &c.terms {
                tr {
                    td { code { (t.term) } }
                    td { (format!("{:.4}", t.coefficient)) }
                    td { (format!("{:.4} to {:.4}", t.interval[0], t.interval[1])) }
                    td { (opt(t.frequency_hz, 3)) }
                    td { (opt(t.phase_rad, 2)) }
                    td { (share(t.selected_share)) }
                    td { (format!("{} of {}", t.runs_selected[0], t.runs_selected[1])) }
                }
            }
        }
        p {
            "Held-out error cost " (format!("{:.4}", c.validation_cost_before)) " → "
            (format!("{:.4}", c.validation_cost_after)) "; held-out NMAE "
            (nmae(&c.validation_nmae_before)) " → " (nmae(&c.validation_nmae_after)) "."
        }
    }
}

/// An optional number to `p` decimals, "-" when absent.
fn opt(x: Option<f64>, p: usize) -> String {
    x.map_or("-".to_string(), |v| format!("{v:.p$}"))
}

/// The model's parameters re-estimated on the training runs, when they were.
fn reestimated_parameters(d: &Diagnosis) -> Markup {
    let ps = &d.baseline.reestimated.parameters;
    html! {
        @if d.baseline.parameters_reestimated {
            @if d.baseline.reestimated.beside.is_empty() {
                p { "Re-estimated parameters:" }
            } @else {
                p { "Parameters re-estimated beside " (d.baseline.reestimated.beside.join(" and ")) " (use these with them):" }
            }
            table {
                tr { @for p in ps { th { (p.name) } } }
                tr {
                    @for p in ps {
                        td {
                            @if p.stderr.is_finite() {
                                (format!("{:.3} ± {:.3}", p.value, p.stderr))
                            } @else {
                                (format!("{:.3}", p.value))
                            }
                        }
                    }
                }
            }
        }
    }
}

/// Where the model misses on the held-out runs: per run and DOF, the share of the error and
/// the worst windows.
fn mismatch_table(d: &Diagnosis) -> Markup {
    html! {
        h3 { "Where the model misses (held-out runs)" }
        table {
            tr { th { "run" } th { "DOF" } th { "share of the error" } th { "worst windows (s)" } }
            @for m in &d.mismatch {
                tr {
                    td { (m.run) }
                    td { (m.dof) }
                    td { (format!("{:.0} %", 100.0 * m.share_of_error)) }
                    td { (windows(&m.windows_s)) }
                }
            }
        }
    }
}

/// Time windows as `from–to` pairs in seconds.
fn windows(w: &[[f64; 2]]) -> String {
    w.iter()
        .map(|w| format!("{:.1}–{:.1}", w[0], w[1]))
        .collect::<Vec<_>>()
        .join(", ")
}

/// The error per regime of motion against the time spent in it. A share under 1 % reads
/// "< 1 %", and a concentration over so little time is not given (a ratio of two shares that
/// both print as 0 % would contradict them).
fn regimes_table(d: &Diagnosis) -> Markup {
    html! {
        table {
            tr { th { "regime" } th { "share of the error" } th { "share of the time" } th { "concentration" } }
            @for r in &d.regimes {
                tr {
                    td { (r.label) }
                    td { (share(r.share_of_error)) }
                    td { (share(r.share_of_time)) }
                    td { (concentration(r.share_of_error, r.share_of_time)) }
                }
            }
        }
    }
}

/// A share as a percentage: "0 %", "< 1 %", "12 %".
fn share(x: f64) -> String {
    if x > 0.0 && x < 0.005 {
        "< 1 %".into()
    } else {
        format!("{:.0} %", 100.0 * x)
    }
}

/// Error share over time share, when the regime covers at least 1 % of the time.
fn concentration(error: f64, time: f64) -> String {
    if time >= 0.01 && error.is_finite() {
        format!("{:.2}", error / time)
    } else {
        "– (under 1 % of the time)".into()
    }
}

/// Every hypothesis tested, round by round, with its costs, gain, score and whether it was kept.
fn hypotheses(d: &Diagnosis) -> Markup {
    html! {
        details {
            summary { "Every hypothesis tested" }
            table {
                tr {
                    th { "round" } th { "effect" } th { "parameters" } th { "training cost" }
                    th { "held-out cost" } th { "gain" } th { "score (ln before/after − penalty)" }
                    th { "kept" }
                }
                @for t in &d.hypotheses {
                    tr {
                        td { (t.round) }
                        td { code { (t.name) } }
                        td { (parameters(&t.parameters)) }
                        td { (format!("{:.4}", t.train_cost)) }
                        td { (format!("{:.4}", t.validation_cost)) }
                        td { (format!("{:+.1} %", 100.0 * t.gain)) }
                        td { (format!("{:+.3}", t.score)) }
                        td { (kept(t)) }
                    }
                }
            }
        }
    }
}

/// Whether a hypothesis was kept, and if not because of a bound, which parameters hit it.
fn kept(t: &crate::diagnose::Tested) -> String {
    if t.accepted {
        "yes".to_string()
    } else if !t.at_bound.is_empty() {
        format!(
            "no: {} pushed to the bound (the data want more than this effect can give)",
            t.at_bound.join(", ")
        )
    } else {
        String::new()
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn a_regime_over_almost_no_time_gets_no_concentration() {
        assert_eq!(super::share(0.004), "< 1 %");
        assert_eq!(super::share(0.0), "0 %");
        assert_eq!(super::share(0.23), "23 %");
        assert_eq!(
            super::concentration(0.0036, 0.004),
            "– (under 1 % of the time)"
        );
        assert_eq!(super::concentration(0.77, 0.5), "1.54");
    }
}
