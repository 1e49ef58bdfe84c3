//! The pool part of the report: how each fused run was made, how accurate the fusion is where
//! a twin's truth exists, and each model against each recording (tables and plots).

use super::html::esc;
use crate::dof::Dof;
use crate::fusion::run::FusedRun;
use crate::fusion::run::POOL_DOFS;
use crate::fusion::{Fused, interp};
use crate::io::csvlog;
use crate::plot::{self as plots, PoolTrace};
use crate::validate::pool::{ModelScore, RunScore, Scores, Simulated};
use serde::Serialize;
use std::collections::BTreeMap;
use std::fmt::Write as _;

/// Fusion error against a twin's true velocities, per DOF (m/s, rad/s).
#[derive(Debug, Clone, Serialize)]
pub struct FusionAccuracy {
    pub run: String,
    pub truth: String,
    pub rmse: BTreeMap<Dof, f64>,
    /// RMS of error / stated standard deviation (1 when the uncertainty is honest).
    pub error_over_std: BTreeMap<Dof, f64>,
    pub rmse_without_sonar: Option<BTreeMap<Dof, f64>>,
}

fn rmse_against(truth: &csvlog::Log, f: &Fused) -> (BTreeMap<Dof, f64>, BTreeMap<Dof, f64>) {
    let mut rmse = BTreeMap::new();
    let mut z = BTreeMap::new();
    let rp = &f.roll_pitch;
    let channels = POOL_DOFS
        .iter()
        .enumerate()
        .map(|(j, d)| (*d, j, &f.vel[j], &f.std[j]))
        .chain([
            (Dof::Roll, 4, &rp.rate[0], &rp.rate_std[0]),
            (Dof::Pitch, 5, &rp.rate[1], &rp.rate_std[1]),
        ]);
    for (d, j, v, s) in channels {
        let (Some(v), Some(s), true) = (v, s, truth.has(j)) else {
            continue;
        };
        let (mut se, mut sz) = (0.0, 0.0);
        for (k, &t) in f.t.iter().enumerate() {
            let e = v[k] - interp(&truth.t, &truth.cols[j], t);
            se += e * e;
            sz += (e / s[k]).powi(2);
        }
        let n = f.t.len().max(1) as f64;
        rmse.insert(d, (se / n).sqrt());
        z.insert(d, (sz / n).sqrt());
    }
    (rmse, z)
}

/// Compares each run with the truth file of the same name (`<run>.csv`: t,u,v,w,r,...).
pub fn fusion_accuracy(
    root: &std::path::Path,
    truth_files: &[String],
    runs: &[FusedRun],
) -> anyhow::Result<Vec<FusionAccuracy>> {
    let mut out = Vec::new();
    for run in runs {
        let Some(path) = truth_files
            .iter()
            .find(|p| p.rsplit('/').next() == Some(&format!("{}.csv", run.meta.run)))
        else {
            continue;
        };
        let text = std::fs::read_to_string(root.join(path))?;
        let cols = ["t", "u", "v", "w", "r", "p", "q"];
        let truth = csvlog::parse_subset(path, &text, &cols, "truth file", 2)?;
        let (rmse, z) = rmse_against(&truth, &run.fused);
        let rmse_without_sonar = run
            .without_sonar
            .as_ref()
            .map(|f| rmse_against(&truth, f).0);
        out.push(FusionAccuracy {
            run: run.meta.run.clone(),
            truth: path.clone(),
            rmse,
            error_over_std: z,
            rmse_without_sonar,
        });
    }
    Ok(out)
}

fn unit(d: Dof) -> &'static str {
    d.velocity_unit()
}

/// The HTML of the pool sections, plots included.
pub fn section(
    runs: &[FusedRun],
    scores: Option<&Scores>,
    sims: &[Simulated],
    accuracy: &[FusionAccuracy],
) -> anyhow::Result<String> {
    let mut h = String::new();
    if runs.is_empty() {
        return Ok(h);
    }
    fusion_table(&mut h, runs);
    repairs(&mut h, runs);
    accuracy_table(&mut h, accuracy);
    let Some(scores) = scores else { return Ok(h) };
    h.push_str("<h2 id=\"pool-validation\">Pool runs: the model against the recordings</h2>\n<p>Each model simulated (RK4, 0.01 s) under the run's logged thrust from the fused initial state; where the model is locally unstable along a run (a perturbation grows, as an open-frame vehicle's sway and yaw do at speed), the simulation is re-anchored to the fused state each time an error would have doubled since the last anchor (a pilot or autopilot kept the real vehicle on course), and stable stretches are simulated in one piece. Residual whiteness (seed 000): share of autocorrelation lags up to 5 s outside the 95 % band ±1.96/√N — about 5 % for a model that explains everything but noise. σ̄ is the mean standard deviation of the fused velocity, the floor no model can beat.</p>\n");
    for m in &scores.models {
        model_table(&mut h, m);
        stability(&mut h, m);
        mean_nmae_summary(&mut h, m);
        shortfalls(&mut h, m);
    }
    for b in &scores.baselines {
        h.push_str(
            "<p>Baseline: <b>predicting rest</b> scores NMAE 1.000 in every DOF by definition. ",
        );
        let _ = write!(
            h,
            "<b>{}</b> (added mass, linear drag and a constant force in each DOF, the restoring moment in roll and pitch; fitted by the prediction-error method on the same training runs). ",
            esc(&b.model)
        );
        mean_nmae_summary(&mut h, b);
    }
    if !scores.cross.is_empty() {
        cross_validation(&mut h, runs, scores);
    }
    run_figures(&mut h, runs, scores, sims)?;
    Ok(h)
}

/// The fusion heading and its table: per run, the sensors used, the fixes kept and rejected,
/// the gyro bias, the UWB noise and the DOFs the fusion knows.
fn fusion_table(h: &mut String, runs: &[FusedRun]) {
    h.push_str("<h2 id=\"fusion\">Pool runs: sensor fusion</h2>\n<p>UWB, sonar, depth and IMU fused by a Kalman filter with a Rauch-Tung-Striebel smoother (heading with gyro bias; position and velocity driven by the accelerometers, UWB fixes screened by a median filter and a chi-square gate). Noise levels estimated from each log unless set.</p>\n");
    h.push_str("<table><tr><th>run</th><th>role</th><th>sensors</th><th>UWB fixes (multipath rejected)</th><th>sonar fixes</th><th>gyro bias (°/s)</th><th>UWB σ (m)</th><th>DOFs known</th></tr>\n");
    for r in runs {
        let s = &r.meta.stats;
        let known: Vec<&str> = POOL_DOFS
            .iter()
            .enumerate()
            .filter(|(j, _)| r.meta.known[*j])
            .map(|(_, d)| d.name())
            .collect();
        let _ = writeln!(
            h,
            "<tr><td>{}</td><td>{}</td><td>{}</td><td>{} ({} + {})</td><td>{}</td><td>{}</td><td>{:.3}</td><td>{}</td></tr>",
            esc(&r.meta.run),
            r.meta.role.as_str(),
            r.meta.sensors.join(", "),
            s.uwb_fixes,
            s.uwb_rejected_median,
            s.uwb_rejected_gate,
            s.sonar_fixes,
            s.gyro_bias_dps.map_or("–".into(), |b| format!("{b:.3}")),
            s.noise.uwb_m[0],
            known.join(", ")
        );
    }
    h.push_str("</table>\n");
}

/// The list of timing repairs and navigation-log noise, for the runs that have any.
fn repairs(h: &mut String, runs: &[FusedRun]) {
    let repaired: Vec<&FusedRun> = runs
        .iter()
        .filter(|r| !r.meta.repairs.is_empty() || !r.meta.stats.nav.is_empty())
        .collect();
    if repaired.is_empty() {
        return;
    }
    h.push_str("<h3 id=\"repairs\">Timing repairs and navigation-log noise</h3>\n<ul>\n");
    for r in repaired {
        for rep in &r.meta.repairs {
            let _ = writeln!(
                h,
                "<li><code>{}</code>: {}</li>",
                esc(&r.meta.run),
                esc(rep)
            );
        }
        for (ch, n) in &r.meta.stats.nav {
            let _ = writeln!(
                h,
                "<li><code>{}</code> nav <code>{ch}</code>: noise σ {:.4} m/s (lag-1 estimate {:.4}); errors correlated over {:.1} samples{}</li>",
                esc(&r.meta.run),
                n.sigma,
                n.sigma_lag1,
                n.correlated_samples,
                if n.correlated_samples > 2.0 {
                    " — the log was filtered before it was written, so its samples count for less"
                } else {
                    ""
                }
            );
        }
    }
    h.push_str("</ul>\n");
}

/// The fusion's accuracy against the twin's truth, per run and DOF (nothing without truth).
fn accuracy_table(h: &mut String, accuracy: &[FusionAccuracy]) {
    if accuracy.is_empty() {
        return;
    }
    h.push_str("<h3 id=\"fusion-accuracy\">Fusion accuracy against the twin's truth</h3>\n<p>These runs are synthetic: their true velocities are in the truth files named below (outside <code>cases/</code>, never read by the fusion). RMSE of the fused velocity, with and without the sonar; error/σ is the RMS of the error divided by the stated standard deviation (near 1 when the uncertainty is honest).</p>\n<table><tr><th>run</th><th>DOF</th><th>RMSE</th><th>RMSE without sonar</th><th>error/σ</th><th>truth</th></tr>\n");
    for a in accuracy {
        for (d, e) in &a.rmse {
            let ns = a
                .rmse_without_sonar
                .as_ref()
                .and_then(|m| m.get(d))
                .map_or("no sonar in run".into(), |x| format!("{x:.4} {}", unit(*d)));
            let _ = writeln!(
                h,
                "<tr><td>{}</td><td>{d}</td><td>{e:.4} {}</td><td>{ns}</td><td>{:.2}</td><td><code>{}</code></td></tr>",
                esc(&a.run),
                unit(*d),
                a.error_over_std[d],
                esc(&a.truth)
            );
        }
    }
    h.push_str("</table>\n");
}

/// Model `m`'s scores on each pool run and DOF: errors, residual whiteness and the noise floor.
fn model_table(h: &mut String, m: &ModelScore) {
    let _ = writeln!(
        h,
        "<table><tr><th>model <code>{}</code>: run</th><th>role</th><th>DOF</th><th>MAE</th><th>NMAE</th><th>NMAE 1 / 10 / 100 samples ahead</th><th>RMSE % of peak</th><th>residual ACF outside band</th><th>σ̄</th></tr>",
        esc(&m.model)
    );
    for r in &m.runs {
        for (d, s) in &r.dofs {
            let flag = if r.diverged {
                " <span class=\"warn\">diverged</span>"
            } else {
                ""
            };
            let short = r.role == "validate" && m.shortfalls.iter().any(|x| x.dof == *d);
            let dof_flag = if short {
                " <span class=\"warn\">below baseline</span>"
            } else {
                ""
            };
            let ahead: Vec<String> = crate::validate::pool::AHEAD
                .iter()
                .map(|k| {
                    s.nmae_ahead
                        .get(k)
                        .map_or("–".into(), |x| format!("{x:.3}"))
                })
                .collect();
            let _ = writeln!(
                h,
                "<tr><td>{}{flag}</td><td>{}</td><td>{d}{dof_flag}</td><td>{:.4}</td><td>{:.3}</td><td>{}</td><td>{:.2}</td><td>{:.0} %</td><td>{:.4}</td></tr>",
                esc(&r.run),
                r.role,
                s.metrics.mae,
                s.metrics.nmae,
                ahead.join(" / "),
                s.metrics.rmse_pct,
                100.0 * s.whiteness.outside,
                s.measurement_std
            );
        }
    }
    h.push_str("</table>\n");
}

/// Model `m`'s local stability along each run, for the runs where it was assessed.
fn stability(h: &mut String, m: &ModelScore) {
    let stab: String = m
        .runs
        .iter()
        .filter_map(|r| {
            r.stability.as_ref().map(|s| {
                format!(
                    "<li><code>{}</code>: {}</li>",
                    esc(&r.run),
                    esc(&crate::model::stability::describe(s))
                )
            })
        })
        .collect();
    if !stab.is_empty() {
        let _ = writeln!(
            h,
            "<p>Local stability of model <code>{}</code> along each run (eigenvalues of the model linearised at the recorded velocity):</p><ul class=\"small\" id=\"stability-{}\">{stab}</ul>",
            esc(&m.model),
            esc(&m.model)
        );
    }
}

/// The DOFs in which model `m` does not beat both baselines on the held-out runs.
fn shortfalls(h: &mut String, m: &ModelScore) {
    for s in &m.shortfalls {
        let _ = writeln!(h, "<p class=\"warn\">{}</p>", esc(&s.sentence(&m.model)));
    }
}

/// Model `m`'s mean NMAE per DOF, one entry per run role.
fn mean_nmae_summary(h: &mut String, m: &ModelScore) {
    h.push_str("<p>Cross-validation summary, mean NMAE per DOF: ");
    for (role, per) in &m.mean_nmae {
        let v: Vec<String> = per.iter().map(|(d, x)| format!("{d} {x:.3}")).collect();
        let _ = write!(h, "<b>{role}</b> runs: {}; ", v.join(", "));
    }
    h.push_str("</p>\n");
}

/// The cross-validation matrix (fitted on one run, scored on each other) and its notes.
fn cross_validation(h: &mut String, runs: &[FusedRun], scores: &Scores) {
    let names: Vec<&str> = runs.iter().map(|r| r.meta.run.as_str()).collect();
    h.push_str("<h3 id=\"cross-validation\">Cross-validation across runs</h3>\n<p>The diagonal model re-estimated by least squares on one training run alone (equation error on the fused velocities and their derivative), then simulated on every other run: mean NMAE over the DOFs. Rows: the run it was fitted on; columns: the run it is scored on. A model that only fits its own run, or parameters that drift from run to run, show here.</p>\n<table><tr><th>fitted on \\ scored on</th>");
    for n in &names {
        let _ = write!(h, "<th>{}</th>", esc(n));
    }
    h.push_str("</tr>\n");
    for c in &scores.cross {
        let _ = write!(h, "<tr><td>{}</td>", esc(&c.trained_on));
        for n in &names {
            let cell = c
                .runs
                .iter()
                .find(|r| r.run == *n)
                .map_or("–".to_string(), cross_cell);
            let _ = write!(h, "<td>{cell}</td>");
        }
        h.push_str("</tr>\n");
    }
    h.push_str("</table>\n");
    for n in &scores.notes {
        let _ = writeln!(h, "<p class=\"small\">{}</p>", esc(n));
    }
}

/// One cell of the cross-validation matrix: the mean finite NMAE over the DOFs, or "diverged".
fn cross_cell(r: &RunScore) -> String {
    if r.diverged {
        "diverged".into()
    } else {
        let v: Vec<f64> = r
            .dofs
            .values()
            .map(|s| s.metrics.nmae)
            .filter(|x| x.is_finite())
            .collect();
        format!("{:.3}", v.iter().sum::<f64>() / v.len().max(1) as f64)
    }
}

/// One figure per run the first model was simulated on: its fused velocities against the model.
fn run_figures(
    h: &mut String,
    runs: &[FusedRun],
    scores: &Scores,
    sims: &[Simulated],
) -> anyhow::Result<()> {
    let first = scores
        .models
        .first()
        .map(|m| m.model.clone())
        .unwrap_or_default();
    for r in runs {
        let Some(sim) = sims
            .iter()
            .find(|s| s.model == first && s.run == r.meta.run)
        else {
            continue;
        };
        let tr = traces(r, sim);
        let svg = plots::pool_run(&r.meta.run, &first, &tr)?;
        let _ = writeln!(
            h,
            "<figure id=\"pool-{}\">{svg}<figcaption>Run <code>{}</code> ({}): per DOF, the fused velocity (blue) with its ±2σ band (shaded, σ the fusion's standard deviation) and model <code>{}</code> simulated under the logged thrust (dashed); beneath, the error model − fused (red) against the same band around zero: {}.</figcaption></figure>",
            esc(&r.meta.run),
            esc(&r.meta.run),
            r.meta.role.as_str(),
            esc(&first),
            within_band(&tr)
        );
    }
    Ok(())
}

/// Where the error lies against the ±2σ band, DOF by DOF, as the figure shows it: "inside it
/// 12 % of the time in surge, 40 % in sway, ..." (computed, never assumed).
fn within_band(traces: &[PoolTrace]) -> String {
    let parts: Vec<String> = traces
        .iter()
        .filter_map(|tr| {
            let (inside, n) = tr
                .simulated
                .iter()
                .zip(tr.measured)
                .zip(tr.std)
                .map(|((s, m), sd)| (s - m, *sd))
                .filter(|(e, sd)| e.is_finite() && sd.is_finite())
                .fold((0usize, 0usize), |(i, n), (e, sd)| {
                    (i + usize::from(e.abs() <= 2.0 * sd), n + 1)
                });
            (n > 0).then(|| (100.0 * inside as f64 / n as f64, tr.dof))
        })
        .enumerate()
        .map(|(k, (pct, dof))| {
            let of = if k == 0 { " of the time" } else { "" };
            format!("{pct:.0} %{of} in {dof}")
        })
        .collect();
    if parts.is_empty() {
        "no sample has both".into()
    } else {
        format!("inside it {}", parts.join(", "))
    }
}

/// The traces of run `r`'s figure: each DOF with a fused velocity, its σ and a simulation.
fn traces<'a>(r: &'a FusedRun, sim: &'a Simulated) -> Vec<PoolTrace<'a>> {
    Dof::ALL
        .iter()
        .filter_map(|d| {
            let (v, s, m) = (r.velocity(*d)?, r.velocity_std(*d)?, sim.nu.get(d)?);
            Some(PoolTrace {
                dof: *d,
                t: &r.fused.t,
                measured: v,
                std: s,
                simulated: m,
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_band_caption_counts_the_error_inside_the_band() {
        let t = [0.0, 1.0, 2.0, 3.0];
        let measured = [0.0; 4];
        let std = [0.1; 4];
        // Errors 0.05, 0.3, -0.15, 0.19 against 2σ = 0.2: three of four inside.
        let surge = [0.05, 0.3, -0.15, 0.19];
        // Errors all far outside.
        let sway = [1.0, -1.0, 0.5, f64::NAN];
        let tr = [
            PoolTrace {
                dof: Dof::Surge,
                t: &t,
                measured: &measured,
                std: &std,
                simulated: &surge,
            },
            PoolTrace {
                dof: Dof::Sway,
                t: &t,
                measured: &measured,
                std: &std,
                simulated: &sway,
            },
        ];
        assert_eq!(
            within_band(&tr),
            "inside it 75 % of the time in surge, 0 % in sway"
        );
    }
}
