//! The report's section on the missing-physics diagnosis: the verdict, each effect with its
//! parameters, evidence and held-out error before and after, where the mismatch is, and every
//! hypothesis tested.

use crate::core::html::esc;
use crate::diagnose::{Diagnosis, Figure};
use std::collections::BTreeMap;
use std::fmt::Write as _;

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
pub fn section(d: &Diagnosis, figures: &[Figure]) -> String {
    let mut h = String::new();
    intro(&mut h, d);
    if !d.diverged.is_empty() {
        let _ = writeln!(
            h,
            "<p class=\"warn\">The model diverges on: {}. Nothing was diagnosed.</p>",
            esc(&d.diverged.join(", "))
        );
        return h;
    }
    untested(&mut h, d);
    refused(&mut h, d);
    cost_table(&mut h, d);
    effects_table(&mut h, d);
    candidates(&mut h, d);
    reestimated_parameters(&mut h, d);
    mismatch_table(&mut h, d);
    regimes_table(&mut h, d);
    for f in figures {
        let _ = writeln!(
            h,
            "<figure>{}<figcaption>{}</figcaption></figure>",
            f.svg,
            esc(&f.caption)
        );
    }
    hypotheses(&mut h, d);
    h
}

/// The heading, the verdict, and how effects were fitted and judged.
fn intro(h: &mut String, d: &Diagnosis) {
    let _ = writeln!(
        h,
        "<h2 id=\"diagnosis\">Why the pool runs and the model differ</h2>\n<p><b>{}</b></p>\n<p>Model diagnosed: <code>{}</code>. Effects are fitted on the training runs ({}) by output error and judged on the held-out runs ({}) only. Error cost: sum over DOFs of mean squared velocity error / mean squared velocity; noise floor {:.4} (the fused velocities' own variance). An effect is kept when it lowers the held-out cost by at least {:.0} % plus {:.0} % per parameter and by more than {:.1}× the noise floor. Took {:.1} s.</p>",
        esc(&d.verdict),
        esc(&d.baseline.model),
        esc(&d.runs.train.join(", ")),
        esc(&d.runs.validate.join(", ")),
        d.baseline.noise_cost,
        100.0 * d.criteria.min_gain,
        100.0 * d.criteria.gain_per_parameter,
        d.criteria.min_noise_multiple,
        d.elapsed_s
    );
    started_from(h, d);
}

/// Which fits of the vehicle the diagnosis chose between, and how each predicts the held-out
/// runs.
fn started_from(h: &mut String, d: &Diagnosis) {
    if d.started_from.is_empty() {
        return;
    }
    let each: Vec<String> = d
        .started_from
        .iter()
        .map(|s| {
            let score = match &s.note {
                Some(n) => format!("not scored: {}", esc(n)),
                None => format!(
                    "held-out cost {:.4}, NMAE {}",
                    s.validation_cost,
                    nmae(&s.validation_nmae)
                ),
            };
            let chosen = if s.chosen { " — diagnosed" } else { "" };
            format!(
                "<li><code>{}</code> ({}): {score}{chosen}</li>",
                esc(&s.model),
                esc(&s.method)
            )
        })
        .collect();
    let _ = writeln!(
        h,
        "<p>Started from <code>{}</code>: of the fits of the vehicle among <code>from</code>, a CFD model when there is one (the physics it leaves out is what is diagnosed; a pool fit absorbs some of it), else the one that predicts the held-out runs best. Set <code>model</code> in the stage's settings to choose. Held out:</p><ul>\n{}\n</ul>",
        esc(&d.baseline.model),
        each.join("\n")
    );
}

/// The hypotheses not tested, each with what the runs lack for it.
fn untested(h: &mut String, d: &Diagnosis) {
    if !d.runs.dead_reckoned.is_empty() {
        h.push_str("<p>Without a position sensor, the position the tether and wall hypotheses read is dead-reckoned from the navigation log's velocity and heading:</p><ul>\n");
        for r in &d.runs.dead_reckoned {
            let _ = writeln!(h, "<li>{}</li>", esc(r));
        }
        h.push_str("</ul>\n");
    }
    if d.untested.is_empty() {
        return;
    }
    h.push_str("<p>Not tested (the runs lack what these hypotheses need):</p><ul>\n");
    for u in &d.untested {
        let _ = writeln!(
            h,
            "<li><code>{}</code>: {}</li>",
            esc(&u.name),
            esc(&u.missing)
        );
    }
    h.push_str("</ul>\n");
}

/// The hypotheses that helped only by pushing a parameter to its bound, which are not findings.
fn refused(h: &mut String, d: &Diagnosis) {
    let refused: Vec<&crate::diagnose::Tested> = d
        .hypotheses
        .iter()
        .filter(|t| !t.at_bound.is_empty() && t.gain > 0.0)
        .collect();
    if refused.is_empty() {
        return;
    }
    h.push_str("<p>Not findings — pushed to the bound (the data want more than these effects can give):</p><ul>\n");
    for t in refused {
        let _ = writeln!(
            h,
            "<li><code>{}</code> (round {}): {} at its bound; held-out cost {:+.1} %</li>",
            esc(&t.name),
            t.round,
            esc(&t.at_bound.join(", ")),
            -100.0 * t.gain
        );
    }
    h.push_str("</ul>\n");
}

/// The held-out error of the model as fitted, re-estimated, and with each effect added.
fn cost_table(h: &mut String, d: &Diagnosis) {
    h.push_str("<table><tr><th>model</th><th>held-out NMAE per DOF</th><th>error cost</th></tr>\n");
    let _ = writeln!(
        h,
        "<tr><td>model as fitted</td><td>{}</td><td>{:.4}</td></tr>",
        nmae(&d.baseline.validation_nmae),
        d.baseline.validation_cost
    );
    let _ = writeln!(
        h,
        "<tr><td>its parameters re-estimated on the training runs (drift)</td><td>{}</td><td>{:.4}{}</td></tr>",
        nmae(&d.baseline.reestimated.validation_nmae),
        d.baseline.reestimated.validation_cost,
        if d.baseline.reestimated.within_noise {
            " (within noise)"
        } else {
            ""
        }
    );
    for e in d.effects.iter().filter(|e| e.name != "unexplained") {
        let _ = writeln!(
            h,
            "<tr><td>+ <code>{}</code></td><td>{}</td><td>{:.4}</td></tr>",
            esc(&e.name),
            nmae(&e.validation_nmae_after),
            e.validation_cost_after
        );
    }
    h.push_str("</table>\n");
}

/// The effects kept: DOFs, parameters, held-out error before and after, and the evidence.
fn effects_table(h: &mut String, d: &Diagnosis) {
    if d.effects.is_empty() {
        return;
    }
    h.push_str("<table><tr><th>effect</th><th>DOFs</th><th>parameters</th><th>held-out NMAE before</th><th>after</th><th>evidence</th></tr>\n");
    for e in &d.effects {
        let _ = writeln!(
            h,
            "<tr><td><code>{}</code></td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>",
            esc(&e.name),
            e.dofs
                .iter()
                .map(|x| x.name())
                .collect::<Vec<_>>()
                .join(", "),
            esc(&parameters(&e.parameters)),
            nmae(&e.validation_nmae_before),
            nmae(&e.validation_nmae_after),
            esc(&e.evidence)
        );
    }
    h.push_str("</table>\n");
}

/// The closed form discovery proposed for what no named effect explains: the expression, each
/// term with its interval and how often it was selected, and the held-out errors.
fn candidates(h: &mut String, d: &Diagnosis) {
    for e in &d.effects {
        let Some(c) = &e.candidate else {
            continue;
        };
        let _ = writeln!(
            h,
            "<h3>Discovered beyond the named effects</h3>\n<p>Sparse regression of the residual force on {} candidate terms (velocities and their products, commands and their lags, position, depth, walls, tether, heading, a constant, and sines at the residual's spectral peaks), kept only where the block-bootstrap resamples and the training runs agree, then proved on the held-out runs:</p>\n<p class=\"verdict\"><code>{}</code>{}</p>",
            c.library_terms,
            esc(&c.expression),
            c.named_as.as_ref().map_or(String::new(), |n| format!(
                " — the form of <code>{}</code>",
                esc(n)
            ))
        );
        h.push_str("<table><tr><th>term</th><th>coefficient</th><th>95 % interval</th><th>frequency (Hz)</th><th>phase (rad)</th><th>selected on resamples</th><th>runs that select it</th></tr>\n");
        for t in &c.terms {
            let opt = |x: Option<f64>, p: usize| x.map_or("-".to_string(), |v| format!("{v:.p$}"));
            let _ = writeln!(
                h,
                "<tr><td><code>{}</code></td><td>{:.4}</td><td>{:.4} to {:.4}</td><td>{}</td><td>{}</td><td>{}</td><td>{} of {}</td></tr>",
                esc(&t.term),
                t.coefficient,
                t.interval[0],
                t.interval[1],
                opt(t.frequency_hz, 3),
                opt(t.phase_rad, 2),
                share(t.selected_share),
                t.runs_selected[0],
                t.runs_selected[1]
            );
        }
        h.push_str("</table>\n");
        let _ = writeln!(
            h,
            "<p>Held-out error cost {:.4} → {:.4}; held-out NMAE {} → {}.</p>",
            c.validation_cost_before,
            c.validation_cost_after,
            nmae(&c.validation_nmae_before),
            nmae(&c.validation_nmae_after)
        );
    }
}

/// The model's parameters re-estimated on the training runs, when they were.
fn reestimated_parameters(h: &mut String, d: &Diagnosis) {
    if !d.baseline.parameters_reestimated {
        return;
    }
    h.push_str("<p>Re-estimated parameters:</p><table><tr>");
    for p in &d.baseline.reestimated.parameters {
        let _ = write!(h, "<th>{}</th>", esc(&p.name));
    }
    h.push_str("</tr><tr>");
    for p in &d.baseline.reestimated.parameters {
        let _ = write!(h, "<td>{:.3} ± {:.3}</td>", p.value, p.stderr);
    }
    h.push_str("</tr></table>\n");
}

/// Where the model misses on the held-out runs: per run and DOF, the share of the error and
/// the worst windows.
fn mismatch_table(h: &mut String, d: &Diagnosis) {
    h.push_str("<h3>Where the model misses (held-out runs)</h3>\n<table><tr><th>run</th><th>DOF</th><th>share of the error</th><th>worst windows (s)</th></tr>\n");
    for m in &d.mismatch {
        let w = m
            .windows_s
            .iter()
            .map(|w| format!("{:.1}–{:.1}", w[0], w[1]))
            .collect::<Vec<_>>()
            .join(", ");
        let _ = writeln!(
            h,
            "<tr><td>{}</td><td>{}</td><td>{:.0} %</td><td>{}</td></tr>",
            esc(&m.run),
            m.dof,
            100.0 * m.share_of_error,
            w
        );
    }
    h.push_str("</table>\n");
}

/// The error per regime of motion against the time spent in it. A share under 1 % reads
/// "< 1 %", and a concentration over so little time is not given (a ratio of two shares that
/// both print as 0 % would contradict them).
fn regimes_table(h: &mut String, d: &Diagnosis) {
    h.push_str("<table><tr><th>regime</th><th>share of the error</th><th>share of the time</th><th>concentration</th></tr>\n");
    for r in &d.regimes {
        let _ = writeln!(
            h,
            "<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>",
            esc(&r.label),
            share(r.share_of_error),
            share(r.share_of_time),
            concentration(r.share_of_error, r.share_of_time)
        );
    }
    h.push_str("</table>\n");
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
fn hypotheses(h: &mut String, d: &Diagnosis) {
    h.push_str("<details><summary>Every hypothesis tested</summary><table><tr><th>round</th><th>effect</th><th>parameters</th><th>training cost</th><th>held-out cost</th><th>gain</th><th>score (ln before/after − penalty)</th><th>kept</th></tr>\n");
    for t in &d.hypotheses {
        let _ = writeln!(
            h,
            "<tr><td>{}</td><td><code>{}</code></td><td>{}</td><td>{:.4}</td><td>{:.4}</td><td>{:+.1} %</td><td>{:+.3}</td><td>{}</td></tr>",
            t.round,
            esc(&t.name),
            esc(&parameters(&t.parameters)),
            t.train_cost,
            t.validation_cost,
            100.0 * t.gain,
            t.score,
            kept(t)
        );
    }
    h.push_str("</table></details>\n");
}

/// Whether a hypothesis was kept, and if not because of a bound, which parameters hit it.
fn kept(t: &crate::diagnose::Tested) -> String {
    if t.accepted {
        "yes".to_string()
    } else if !t.at_bound.is_empty() {
        format!(
            "no: {} pushed to the bound (the data want more than this effect can give)",
            esc(&t.at_bound.join(", "))
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
