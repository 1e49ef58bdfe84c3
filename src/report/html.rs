//! `index.html`: one self-contained page (inline CSS and SVG; a CSP forbids any fetch).

use super::json::{Parameter, Parameters, Validation};
use crate::core::html::esc;
use crate::core::model::Vehicle;
use crate::identify::result::FitResult;
use std::fmt::Write as _;

/// Significant-figure formatting for tables.
fn num(v: f64) -> String {
    if !v.is_finite() {
        return format!("not finite ({})", crate::core::finite::word(v));
    }
    let a = v.abs();
    if a != 0.0 && !(1e-3..1e5).contains(&a) {
        format!("{v:.3e}")
    } else {
        format!("{v:.4}")
    }
}

const STYLE: &str = "body{font-family:sans-serif;max-width:1100px;margin:2em auto;padding:0 1em;color:#222}
table{border-collapse:collapse;margin:1em 0;display:block;max-width:100%;overflow-x:auto}td,th{border:1px solid #ccc;padding:.25em .6em;text-align:right}
th{background:#f3f3f3}td:first-child,th:first-child{text-align:left}.warn{color:#b00}
figure{margin:1em 0}figure svg{max-width:100%;height:auto;border:1px solid #eee}
code{background:#f6f6f6;padding:0 .2em}.small{font-size:.85em;color:#555}details{margin:.3em 0}summary code{overflow-wrap:anywhere}";

pub struct Page<'a> {
    pub vehicle: &'a Vehicle,
    pub fits: &'a [FitResult],
    pub parameters: &'a Parameters,
    pub validation: &'a Validation,
    /// (DOF name, SVG) per plot.
    pub plots: Vec<(String, String)>,
    /// Import notes per case (unit conversions, derived columns).
    pub notes: Vec<(String, Vec<String>)>,
    /// Upstream instances that failed and that the report was built without.
    pub failed: Vec<String>,
    /// The pool sections (fusion, validation against recordings), already rendered.
    pub pool_html: String,
    /// Sections on CFD test bodies other than the vehicle (the OpenFOAM cylinder).
    pub body_html: String,
}

impl Page<'_> {
    pub fn render(&self) -> String {
        let mut h = String::new();
        let _ = write!(
            h,
            "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">\
             <meta http-equiv=\"Content-Security-Policy\" content=\"default-src 'none'; style-src 'unsafe-inline'; img-src data:\">\
             <title>hydrofit report: {name}</title><style>{STYLE}</style></head><body>\n\
             <h1>Hydrodynamic model of {name}</h1>\n<p class=\"small\">hydrofit {ver}. Mass {m} kg, DOFs {dofs}, {st} structure. \
             Every value below links to the files it was computed from (blake3 of their contents).</p>\n",
            name = esc(&self.vehicle.name),
            ver = env!("CARGO_PKG_VERSION"),
            m = self.vehicle.mass_kg,
            dofs = self
                .vehicle
                .dofs
                .iter()
                .map(|d| d.name())
                .collect::<Vec<_>>()
                .join(", "),
            st = self.vehicle.structure.label(),
        );
        if !self.failed.is_empty() {
            h.push_str("<div class=\"warn\" id=\"failed\"><p><b>Left out of this report because they failed</b> (fix them and build again; everything else below is complete without them):</p><ul>\n");
            for f in &self.failed {
                let _ = writeln!(h, "<li>{}</li>", esc(f));
            }
            h.push_str("</ul></div>\n");
        }
        self.shortfalls(&mut h);
        self.parameter_table(&mut h);
        if !self.plots.is_empty() {
            h.push_str("<h2 id=\"plots\">CFD responses and the identified model</h2>\n");
            for (dof, svg) in &self.plots {
                let _ = writeln!(
                    h,
                    "<figure id=\"plot-{dof}\">{svg}<figcaption>{dof}: velocity of each CFD case (colour; the legend lists the cases in the order their curves end, top to bottom) and of the identified model simulated under the same applied force from the same initial state (dashed black).</figcaption></figure>"
                );
            }
            self.validation_table(&mut h);
        }
        h.push_str(&self.pool_html);
        h.push_str(&self.body_html);
        self.provenance(&mut h);
        h.push_str("</body></html>\n");
        h
    }

    /// Every model that does not beat both baselines on the held-out pool runs, DOF by DOF,
    /// before anything else: no one should ship such a model unaware.
    fn shortfalls(&self, h: &mut String) {
        let lines: Vec<String> = self
            .validation
            .models
            .iter()
            .flat_map(|m| {
                m.below_baselines
                    .iter()
                    .map(|s| s.sentence(&m.model))
                    .chain(m.behind_identified.iter().map(|b| b.sentence(&m.model)))
            })
            .collect();
        if lines.is_empty() {
            return;
        }
        h.push_str("<div class=\"warn\" id=\"below-baselines\"><p><b>Models that do not beat the baselines on the held-out runs</b> (predicting rest, NMAE 1, and a first-order model per DOF fitted on the same training runs; see <a href=\"#pool-validation\">the pool validation</a>):</p><ul>\n");
        for l in lines {
            let _ = writeln!(h, "<li>{}</li>", esc(&l));
        }
        h.push_str("</ul></div>\n");
    }

    /// One table per fit: its heading and notes, then each parameter with its uncertainty.
    fn parameter_table(&self, h: &mut String) {
        for f in self.fits {
            fit_heading(h, f);
            for p in self
                .parameters
                .parameters
                .iter()
                .filter(|p| p.model == f.stage)
            {
                parameter_row(h, f, p);
            }
            h.push_str("</table>\n");
            if f.fit.parameters.len() > FOLD_ABOVE {
                h.push_str("</details>\n");
            }
        }
    }

    fn validation_table(&self, h: &mut String) {
        h.push_str("<h2 id=\"validation\">How well each model reproduces each CFD case</h2>\n<p>Per run and DOF: mean absolute error, normalised MAE (mean |v<sub>model</sub> − v<sub>meas</sub>| / mean |v<sub>meas</sub>|) and RMSE as a percentage of the run's peak speed. <code>train</code> runs were used in the fit.</p>\n");
        for m in &self.validation.models {
            let _ = writeln!(
                h,
                "<table><tr><th>model <code>{}</code>: run</th><th>role</th><th>DOF</th><th>MAE</th><th>NMAE</th><th>RMSE % of peak</th></tr>",
                esc(&m.model)
            );
            // Pool runs have their own section below (with whiteness and plots).
            for r in &m.runs {
                for (dof, x) in r
                    .dofs
                    .iter()
                    .filter(|(_, x)| x.residual_acf_outside_band.is_none())
                {
                    let x = &x.metrics;
                    let _ = writeln!(
                        h,
                        "<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{:.3}</td></tr>",
                        esc(&r.run),
                        r.role,
                        dof,
                        num(x.mae),
                        num(x.nmae),
                        x.rmse_pct
                    );
                }
            }
            h.push_str("</table>\n");
        }
    }

    fn provenance(&self, h: &mut String) {
        h.push_str("<h2 id=\"provenance\">Provenance</h2>\n");
        for p in &self.parameters.parameters {
            let _ = write!(
                h,
                "<details id=\"prov-{s}-{n}\"><summary><code>{n}</code> = {v} {u} ← stage <code>{s}</code>, method <code>{m}</code>, settings <code>{set}</code> ← {k} input files</summary><table><tr><th>file</th><th>blake3</th></tr>",
                s = esc(&p.stage),
                n = esc(&p.name),
                v = num(p.value),
                u = esc(&p.unit),
                m = esc(&p.method),
                set = esc(&p.settings.to_string()),
                k = p.inputs.len(),
            );
            for i in &p.inputs {
                let _ = write!(
                    h,
                    "<tr><td>{}</td><td><code>{}</code></td></tr>",
                    esc(&i.path),
                    &i.blake3
                );
            }
            h.push_str("</table></details>\n");
        }
        if self.notes.iter().any(|(_, n)| !n.is_empty()) {
            h.push_str("<h3>Import notes</h3><ul>\n");
            for (case, notes) in self.notes.iter().filter(|(_, n)| !n.is_empty()) {
                let _ = writeln!(
                    h,
                    "<li><code>{}</code>: {}</li>",
                    esc(case),
                    esc(&notes.join("; "))
                );
            }
            h.push_str("</ul>\n");
        }
    }
}

/// The heading of fit `f`'s parameter table: method, objective, data and conditioning, its
/// notes, whether the search was cut short, and the table's header row.
fn fit_heading(h: &mut String, f: &FitResult) {
    let _ = write!(
        h,
        "<h2 id=\"model-{s}\">Parameters — model <code>{s}</code></h2>\n<p>Method <code>{m}</code>, objective {o}, {st} structure ({p} terms), {n} equation rows from {c} CFD cases and {r} pool runs; regressor condition number {k}.</p>\n",
        st = f.structure.label(),
        p = f.fit.parameters.len(),
        s = esc(&f.stage),
        m = esc(&f.method),
        o = f.objective.label(),
        n = f.fit.samples,
        c = f.cases.len(),
        r = f.runs.len(),
        k = num(f.fit.condition_number),
    );
    if !f.notes.is_empty() {
        let _ = writeln!(
            h,
            "<ul class=\"small\">{}</ul>",
            f.notes
                .iter()
                .map(|n| format!("<li>{}</li>", esc(n)))
                .collect::<String>()
        );
    }
    if let Some(why) = &f.fit.stopped_early {
        let _ = writeln!(
            h,
            "<p class=\"warn\">The search was cut short: {}. These values depend on the machine's speed, not only on the seed.</p>",
            esc(why)
        );
    }
    if let Some(r) = &f.fit.refinement {
        refinement(h, r);
    }
    if let Some(e) = f.fit.evaluations {
        let _ = writeln!(
            h,
            "<p class=\"small\">{e} objective evaluations; ± is the standard deviation over seeded restarts, the interval their range (see parameters.json).</p>"
        );
    }
    // A coupled set's hundreds of terms are folded away; parameters.json has them all.
    if f.fit.parameters.len() > FOLD_ABOVE {
        let _ = writeln!(
            h,
            "<details><summary>All {} parameters of <code>{}</code></summary>",
            f.fit.parameters.len(),
            esc(&f.stage)
        );
    }
    h.push_str("<table><tr><th>parameter</th><th>value</th><th>± std. error</th><th>unit</th><th>rel. error</th><th>provenance</th></tr>\n");
}

/// Correlations above this in magnitude are said in words: the runs cannot separate the pair.
const CORRELATED: f64 = 0.9;

/// A prediction-error fit's correlations: the pairs the runs cannot separate, in words (and
/// which manoeuvre would), then the whole matrix folded away.
fn refinement(h: &mut String, r: &crate::identify::Refinement) {
    let n = r.names.len().min(r.correlation.len());
    let mut pairs = Vec::new();
    for i in 0..n {
        for j in i + 1..n {
            let c = r.correlation[i][j];
            if c.abs() > CORRELATED {
                pairs.push(format!(
                    "<code>{}</code> and <code>{}</code> ({c:+.2}{})",
                    esc(&r.names[i]),
                    esc(&r.names[j]),
                    separating(&r.names[i], &r.names[j])
                ));
            }
        }
    }
    if !pairs.is_empty() {
        let _ = writeln!(
            h,
            "<p class=\"warn\">The training runs cannot separate these coefficients (correlation of their estimates beyond ±{CORRELATED}): {}. Their sum is known better than either.</p>",
            pairs.join("; ")
        );
    }
    if n == 0 {
        return;
    }
    let _ = write!(
        h,
        "<details><summary>Correlation matrix of the {n} coefficients</summary><table><tr><th></th>"
    );
    for name in &r.names[..n] {
        let _ = write!(h, "<th>{}</th>", esc(name));
    }
    h.push_str("</tr>\n");
    for (i, row) in r.correlation.iter().take(n).enumerate() {
        let _ = write!(h, "<tr><th>{}</th>", esc(&r.names[i]));
        for c in row.iter().take(n) {
            let _ = write!(h, "<td>{c:+.2}</td>");
        }
        h.push_str("</tr>\n");
    }
    h.push_str("</table></details>\n");
}

/// Which manoeuvre separates two coefficients, when the pair is a familiar one.
fn separating(a: &str, b: &str) -> &'static str {
    let kind = |n: &str| {
        if n.ends_with("dot") {
            'm'
        } else if n == "T_cmd" {
            'l'
        } else if n.ends_with("_0") {
            'c'
        } else if n.starts_with("eta_") || n == "W-B" {
            'b'
        } else {
            'd'
        }
    };
    match (kind(a), kind(b)) {
        ('c', 'b') | ('b', 'c') => {
            ": a constant force against the weight and buoyancy's; runs held at other attitudes separate them"
        }
        ('m', 'd') | ('d', 'm') => {
            ": inertia against damping; steps or a PRBS of the command, whose fast changes load the inertia alone, separate them"
        }
        ('c', 'd') | ('d', 'c') => {
            ": a constant force against damping; runs in both directions of the DOF separate them"
        }
        ('l', 'm') | ('m', 'l') => {
            ": a command lag against inertia; steps of the command separate them, since a lag delays the whole response and an inertia only slows its start"
        }
        ('l', _) | (_, 'l') => {
            ": a command lag against the rest of the model; runs at more than one frequency of the command (a chirp or a PRBS) separate them"
        }
        ('d', 'd') => {
            ": linear against quadratic damping; runs at both low and high speed separate them"
        }
        _ => "",
    }
}

/// Parameter tables longer than this are folded (a `<details>` element, open on a click).
const FOLD_ABOVE: usize = 40;

/// One parameter of fit `f`: value, standard error, unit, relative error, whether it is
/// identifiable, and a link to its provenance.
fn parameter_row(h: &mut String, f: &FitResult, p: &Parameter) {
    let rel = 100.0 * p.stderr / p.value.abs();
    let flag = match (p.identifiable, &p.note) {
        (true, Some(what)) => format!(" <span class=\"small\">{}</span>", esc(what)),
        (true, None) => String::new(),
        (false, Some(why)) => format!(
            " <span class=\"warn\">not identifiable: {}</span>",
            esc(why)
        ),
        (false, None) => " <span class=\"warn\">not identifiable from these cases</span>".into(),
    };
    let _ = writeln!(
        h,
        "<tr><td><code>{n}</code>{flag}</td><td>{v}</td><td>{e}</td><td>{u}</td><td>{r:.2} %</td><td><a href=\"#prov-{s}-{n}\">inputs</a></td></tr>",
        n = esc(&p.name),
        v = num(p.value),
        e = match p.interval {
            Some([lo, hi]) => format!(
                "{}<br><span class=\"small\">range {} to {}</span>",
                num(p.stderr),
                num(lo),
                num(hi)
            ),
            None => num(p.stderr),
        },
        u = esc(&p.unit),
        r = rel,
        s = esc(&f.stage),
    );
}
