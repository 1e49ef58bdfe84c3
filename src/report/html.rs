//! `index.html`: one self-contained page (inline CSS and SVG; a CSP forbids any fetch).

use super::json::{Parameter, Parameters, Validation};
use crate::core::model::Vehicle;
use crate::identify::result::FitResult;
use maud::{DOCTYPE, Markup, PreEscaped, html};

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

/// The page's content security policy: nothing is fetched, styles and images are inline.
const CSP: &str = "default-src 'none'; style-src 'unsafe-inline'; img-src data:";

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
    /// The sections after the CFD ones (parameter sets, field identifiers, comparison,
    /// designed runs, diagnosis, fusion, validation against recordings).
    pub pool_html: Markup,
    /// Sections on CFD test bodies other than the vehicle (the OpenFOAM cylinder).
    pub bodies: Vec<Markup>,
}

impl Page<'_> {
    pub fn render(&self) -> String {
        let v = self.vehicle;
        let dofs: Vec<&str> = v.dofs.iter().map(|d| d.name()).collect();
        html! {
            (DOCTYPE)
            html lang="en" {
                head {
                    meta charset="utf-8";
                    meta http-equiv="Content-Security-Policy" content=(CSP);
                    title { "hydrofit report: " (v.name) }
                    style { (PreEscaped(STYLE)) }
                }
                body {
                    h1 { "Hydrodynamic model of " (v.name) }
                    p class="small" {
                        "hydrofit " (env!("CARGO_PKG_VERSION")) ". Mass " (v.mass_kg) " kg, DOFs "
                        (dofs.join(", ")) ", " (v.structure.label()) " structure. Every value below \
                         links to the files it was computed from (blake3 of their contents)."
                    }
                    @if !self.failed.is_empty() {
                        div class="warn" id="failed" {
                            p {
                                b { "Left out of this report because they failed" }
                                " (fix them and build again; everything else below is complete without them):"
                            }
                            ul { @for f in &self.failed { li { (f) } } }
                        }
                    }
                    (self.shortfalls())
                    @for f in self.fits { (self.parameter_table(f)) }
                    @if !self.plots.is_empty() {
                        h2 id="plots" { "CFD responses and the identified model" }
                        @for (dof, svg) in &self.plots {
                            figure id=(format!("plot-{dof}")) {
                                (PreEscaped(svg))
                                figcaption {
                                    (dof) ": velocity of each CFD case (colour; the legend lists the cases in the \
                                     order their curves end, top to bottom) and of the identified model simulated \
                                     under the same applied force from the same initial state (dashed black)."
                                }
                            }
                        }
                        (self.validation_table())
                    }
                    (self.pool_html)
                    @for b in &self.bodies { (b) }
                    (self.provenance())
                }
            }
        }
        .into_string()
    }

    /// Every model that does not beat both baselines on the held-out pool runs, DOF by DOF,
    /// before anything else: no one should ship such a model unaware.
    fn shortfalls(&self) -> Markup {
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
        html! {
            @if !lines.is_empty() {
                div class="warn" id="below-baselines" {
                    p {
                        b { "Models that do not beat the baselines on the held-out runs" }
                        " (predicting rest, NMAE 1, and a first-order model per DOF fitted on the same \
                         training runs; see " a href="#pool-validation" { "the pool validation" } "):"
                    }
                    ul { @for l in &lines { li { (l) } } }
                }
            }
        }
    }

    /// Fit `f`'s table: its heading and notes, then each parameter with its uncertainty.
    fn parameter_table(&self, f: &FitResult) -> Markup {
        let rows = html! {
            table {
                tr {
                    th { "parameter" } th { "value" } th { "± std. error" } th { "unit" }
                    th { "rel. error" } th { "provenance" }
                }
                @for p in self.parameters.parameters.iter().filter(|p| p.model == f.stage) {
                    (parameter_row(f, p))
                }
            }
        };
        html! {
            (fit_heading(f))
            // A coupled set's hundreds of terms are folded away; parameters.json has them all.
            @if f.fit.parameters.len() > FOLD_ABOVE {
                details {
                    summary { "All " (f.fit.parameters.len()) " parameters of " code { (f.stage) } }
                    (rows)
                }
            } @else {
                (rows)
            }
        }
    }

    fn validation_table(&self) -> Markup {
        html! {
            h2 id="validation" { "How well each model reproduces each CFD case" }
            p {
                "Per run and DOF: mean absolute error, normalised MAE (mean |v" sub { "model" } " − v"
                sub { "meas" } "| / mean |v" sub { "meas" } "|) and RMSE as a percentage of the run's peak \
                 speed. " code { "train" } " runs were used in the fit."
            }
            @for m in &self.validation.models {
                table {
                    tr {
                        th { "model " code { (m.model) } ": run" } th { "role" } th { "DOF" }
                        th { "MAE" } th { "NMAE" } th { "RMSE % of peak" }
                    }
                    // Pool runs have their own section below (with whiteness and plots).
                    @for r in &m.runs {
                        @for (dof, x) in r.dofs.iter().filter(|(_, x)| x.residual_acf_outside_band.is_none()) {
                            tr {
                                td { (r.run) } td { (r.role) } td { (dof) } td { (num(x.metrics.mae)) }
                                td { (num(x.metrics.nmae)) } td { (format!("{:.3}", x.metrics.rmse_pct)) }
                            }
                        }
                    }
                }
            }
        }
    }

    fn provenance(&self) -> Markup {
        let noted: Vec<&(String, Vec<String>)> =
            self.notes.iter().filter(|(_, n)| !n.is_empty()).collect();
        html! {
            h2 id="provenance" { "Provenance" }
            @for p in &self.parameters.parameters {
                details id=(format!("prov-{}-{}", p.stage, p.name)) {
                    summary {
                        code { (p.name) } " = " (num(p.value)) " " (p.unit) " ← stage " code { (p.stage) }
                        ", method " code { (p.method) } ", settings " code { (p.settings.to_string()) }
                        " ← " (p.inputs.len()) " input files"
                    }
                    table {
                        tr { th { "file" } th { "blake3" } }
                        @for i in &p.inputs { tr { td { (i.path) } td { code { (i.blake3) } } } }
                    }
                }
            }
            @if !noted.is_empty() {
                h3 { "Import notes" }
                ul { @for (case, notes) in noted { li { code { (case) } ": " (notes.join("; ")) } } }
            }
        }
    }
}

/// The heading of fit `f`'s parameter table: method, objective, data and conditioning, its
/// notes, whether the search was cut short, and the correlations of a prediction-error fit.
fn fit_heading(f: &FitResult) -> Markup {
    html! {
        h2 id=(format!("model-{}", f.stage)) { "Parameters — model " code { (f.stage) } }
        p {
            "Method " code { (f.method) } ", objective " (f.objective.label()) ", " (f.structure.label())
            " structure (" (f.fit.parameters.len()) " terms), " (f.fit.samples) " equation rows from "
            (f.cases.len()) " CFD cases and " (f.runs.len()) " pool runs; regressor condition number "
            (num(f.fit.condition_number)) "."
        }
        @if !f.notes.is_empty() {
            ul class="small" { @for n in &f.notes { li { (n) } } }
        }
        @if let Some(why) = &f.fit.stopped_early {
            p class="warn" {
                "The search was cut short: " (why) ". These values depend on the machine's speed, not \
                 only on the seed."
            }
        }
        @if let Some(r) = &f.fit.refinement { (refinement(r)) }
        @if let Some(e) = f.fit.evaluations {
            p class="small" {
                (e) " objective evaluations; ± is the standard deviation over seeded restarts, the \
                 interval their range (see parameters.json)."
            }
        }
    }
}

/// Correlations above this in magnitude are said in words: the runs cannot separate the pair.
const CORRELATED: f64 = 0.9;

/// A prediction-error fit's correlations: the pairs the runs cannot separate, in words (and
/// which manoeuvre would), then the whole matrix folded away.
fn refinement(r: &crate::identify::Refinement) -> Markup {
    let n = r.names.len().min(r.correlation.len());
    let mut pairs = Vec::new();
    for i in 0..n {
        for j in i + 1..n {
            let c = r.correlation[i][j];
            if c.abs() > CORRELATED {
                pairs.push((i, j, c));
            }
        }
    }
    html! {
        @if !pairs.is_empty() {
            p class="warn" {
                "The training runs cannot separate these coefficients (correlation of their estimates \
                 beyond ±" (CORRELATED) "): "
                @for (k, (i, j, c)) in pairs.iter().enumerate() {
                    @if k > 0 { "; " }
                    code { (r.names[*i]) } " and " code { (r.names[*j]) }
                    " (" (format!("{c:+.2}")) (separating(&r.names[*i], &r.names[*j])) ")"
                }
                ". Their sum is known better than either."
            }
        }
        @if n > 0 {
            details {
                summary { "Correlation matrix of the " (n) " coefficients" }
                table {
                    tr { th {} @for name in &r.names[..n] { th { (name) } } }
                    @for (i, row) in r.correlation.iter().take(n).enumerate() {
                        tr {
                            th { (r.names[i]) }
                            @for c in row.iter().take(n) { td { (format!("{c:+.2}")) } }
                        }
                    }
                }
            }
        }
    }
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
fn parameter_row(f: &FitResult, p: &Parameter) -> Markup {
    let rel = 100.0 * p.stderr / p.value.abs();
    html! {
        tr {
            td {
                code { (p.name) }
                @match (p.identifiable, &p.note) {
                    (true, Some(what)) => { " " span class="small" { (what) } }
                    (true, None) => {}
                    (false, Some(why)) => { " " span class="warn" { "not identifiable: " (why) } }
                    (false, None) => { " " span class="warn" { "not identifiable from these " (f.sources()) } }
                }
            }
            td { (num(p.value)) }
            td {
                (num(p.stderr))
                @if let Some([lo, hi]) = p.interval {
                    br; span class="small" { "range " (num(lo)) " to " (num(hi)) }
                }
            }
            td { (p.unit) }
            td { (format!("{rel:.2} %")) }
            td { a href=(format!("#prov-{}-{}", f.stage, p.name)) { "inputs" } }
        }
    }
}
