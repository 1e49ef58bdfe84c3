//! How late a navigation log's velocity is against the depth gauge. A DVL's ping, a navigation
//! filter's low-pass and its transport latency put the logged velocity behind the motion; a
//! model fitted to it takes that as a lag between the command and the force, and a diagnosis
//! names it a thruster lag or a sensor delay. The depth gauge is usually a separate, prompt
//! sensor, and its depth is the integral of the vehicle's vertical velocity: the log's
//! vertical velocity read `d` seconds later, integrated, follows the depth best at the log's
//! latency `d`. Measured per run where the run changes depth enough to tell.
//!
//! The fusion measures it but does not apply it: a run that holds its depth cannot be
//! measured, and runs of one vehicle corrected by different amounts would give its fit two
//! lags. The report gathers the runs' figures; the diagnosis takes their median out of every
//! run it reads ([`crate::diagnose`]'s `latency`), and `fusion: {nav_latency_s: ...}` in the
//! pool stage's settings takes a latency out of every run alike before anything reads it.

use crate::pool::import::csvlog::Log;
use serde::{Deserialize, Serialize};

/// A navigation log's latency against the depth gauge, as measured on one run.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct NavLatency {
    /// s; positive: the navigation log is late.
    pub value_s: f64,
    /// The depth's misfit (mean square, m^2) with the log read at the latency, and at none.
    pub misfit_m2: f64,
    pub misfit_at_zero_m2: f64,
    /// The depth's spread over the run (standard deviation about its trend), m.
    pub depth_spread_m: f64,
}

/// The grid the log and the gauge are compared on, s: twice the latencies' step.
const DT: f64 = 0.02;

/// The latencies tried, s: a depth gauge later than the log (negative) to a slow navigation
/// filter.
const LATENCIES: (f64, f64, f64) = (-0.3, 1.0, 0.01);

/// The least spread of depth about its trend that tells a latency, m: a run holding its depth
/// within a few centimetres moves the gauge by its own noise.
const MIN_SPREAD_M: f64 = 0.05;

/// The misfit at the latency must be at most this share of the misfit without it: otherwise
/// the depth's noise or an unmodelled vertical drift decides the minimum.
const MAX_MISFIT_SHARE: f64 = 0.7;

/// The navigation log's latency against the depth gauge on this run, when the run changes
/// depth enough and the log has a vertical velocity; roll and pitch (where logged) turn the
/// body velocity into the vertical one.
pub fn measure(nav: &Log, depth: &Log) -> Option<NavLatency> {
    let (u, v, w) = (nav.col(0), nav.col(1), nav.col(2)?);
    let z = depth.col(0)?;
    let (t0, t1) = (
        nav.t.first()?.max(*depth.t.first()?),
        nav.t.last()?.min(*depth.t.last()?),
    );
    let n = ((t1 - t0) / DT).floor() as usize;
    if n < 100 {
        return None;
    }
    let grid: Vec<f64> = (0..n).map(|k| t0 + k as f64 * DT).collect();
    let at = |c: Option<&[f64]>, t: f64| c.map_or(0.0, |c| super::interp(&nav.t, c, t));
    // The vertical (down) velocity the log says, at time t of its own clock.
    let down = |t: f64| {
        let (phi, theta) = (at(nav.col(3), t), at(nav.col(4), t));
        let (u, v) = (at(u, t), at(v, t));
        let w = super::interp(&nav.t, w, t);
        -theta.sin() * u + theta.cos() * phi.sin() * v + theta.cos() * phi.cos() * w
    };
    let depth_at: Vec<f64> = grid
        .iter()
        .map(|&t| super::interp(&depth.t, z, t))
        .collect();
    if depth_at.iter().any(|x| !x.is_finite()) {
        return None;
    }
    let spread = detrended(&grid, &depth_at).sqrt();
    if spread < MIN_SPREAD_M {
        return None;
    }
    // The log's vertical velocity once, on a grid of the latencies' step (half the
    // comparison grid's), from t0 + lo to t1 + hi: read at grid time k and latency i, it is
    // sample 2k + i.
    let (lo, hi, step) = LATENCIES;
    let steps = ((hi - lo) / step).round() as usize;
    let fine: Vec<f64> = (0..2 * n + steps)
        .map(|k| down(t0 + lo + k as f64 * step))
        .map(|x| if x.is_finite() { x } else { 0.0 })
        .collect();
    let misfit = |i: usize| {
        let mut acc = 0.0;
        let mut integrated = Vec::with_capacity(n);
        for (k, z) in depth_at.iter().enumerate() {
            // The log's reading at t + d is what the vehicle did at t.
            acc += fine[2 * k + i] * DT;
            integrated.push(z - acc);
        }
        detrended(&grid, &integrated)
    };
    let (best, best_misfit) = (0..=steps)
        .map(|i| (lo + i as f64 * step, misfit(i)))
        .min_by(|a, b| a.1.total_cmp(&b.1))?;
    let at_zero = misfit((-lo / step).round() as usize);
    // A minimum on the edge of the range is no measurement.
    let interior = best > lo + step / 2.0 && best < hi - step / 2.0;
    (interior && best_misfit <= MAX_MISFIT_SHARE * at_zero).then_some(NavLatency {
        value_s: best,
        misfit_m2: best_misfit,
        misfit_at_zero_m2: at_zero,
        depth_spread_m: spread,
    })
}

/// The largest latency `nav_latency_s` takes out, s.
pub const MAX_SETTING_S: f64 = 2.0;

/// The run's navigation log read `d` seconds earlier (its latency taken out), said in its
/// timing repairs; an error for a `d` no navigation log has.
pub fn take_out(run: &mut crate::pool::import::PoolRun, d: f64) -> anyhow::Result<()> {
    if !(d.is_finite() && (0.0..=MAX_SETTING_S).contains(&d)) {
        anyhow::bail!(
            "fusion.nav_latency_s = {d}: the navigation log's latency is seconds from 0 to {MAX_SETTING_S}\n  help: the runs' reports measure it against the depth gauge (\"runs ... s behind the depth gauge\")"
        );
    }
    let Some(nav) = run.nav.as_mut() else {
        run.notes.push(format!(
            "fusion.nav_latency_s = {d} s: this run has no navigation log to take it out of"
        ));
        return Ok(());
    };
    nav.t.iter_mut().for_each(|t| *t -= d);
    run.repairs.push(format!(
        "the navigation log read {d:.3} s earlier (fusion.nav_latency_s): its latency taken out"
    ));
    // Its last `d` seconds now end before the command log does.
    run.trim_command_to_sensors();
    Ok(())
}

/// The mean square of `y` about its least-squares line over `t` (a velocity log's bias
/// integrates to a drift of depth, which the latency does not explain).
fn detrended(t: &[f64], y: &[f64]) -> f64 {
    let n = y.len() as f64;
    let (mt, my) = (t.iter().sum::<f64>() / n, y.iter().sum::<f64>() / n);
    let (mut stt, mut sty) = (0.0, 0.0);
    for (a, b) in t.iter().zip(y) {
        stt += (a - mt) * (a - mt);
        sty += (a - mt) * (b - my);
    }
    let slope = if stt > 0.0 { sty / stt } else { 0.0 };
    t.iter()
        .zip(y)
        .map(|(a, b)| (b - my - slope * (a - mt)).powi(2))
        .sum::<f64>()
        / n
}

/// The runs' measurements together: the median, least and greatest latency, and how many of
/// `of` runs told it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Summary {
    pub median_s: f64,
    pub range_s: [f64; 2],
    pub runs: usize,
    pub of: usize,
}

impl Summary {
    /// Of the runs' measurements (`None` where a run did not tell it); `None` when no run did.
    pub fn of<'a>(measured: impl Iterator<Item = Option<&'a NavLatency>>) -> Option<Summary> {
        let mut of = 0;
        let mut xs: Vec<f64> = measured
            .inspect(|_| of += 1)
            .flatten()
            .map(|m| m.value_s)
            .collect();
        if xs.is_empty() {
            return None;
        }
        xs.sort_by(f64::total_cmp);
        Some(Summary {
            median_s: match xs.len() % 2 {
                1 => xs[xs.len() / 2],
                _ => 0.5 * (xs[xs.len() / 2 - 1] + xs[xs.len() / 2]),
            },
            range_s: [xs[0], xs[xs.len() - 1]],
            runs: xs.len(),
            of,
        })
    }

    /// Of the fused runs' measurements.
    pub fn of_runs(runs: &[crate::pool::fusion::run::FusedRun]) -> Option<Summary> {
        Summary::of(runs.iter().map(|r| r.meta.stats.nav_latency.as_ref()))
    }

    /// What the report and the fit's and diagnosis's notes say of it.
    pub fn sentence(&self) -> String {
        if self.median_s < 0.0 {
            return format!(
                "the depth gauge runs {:.2} s behind the navigation log (median of {} of {} runs, {:.2}-{:.2} s): the gauge is the late one, so nothing is taken out of the log",
                -self.median_s, self.runs, self.of, self.range_s[0], self.range_s[1]
            );
        }
        format!(
            "the navigation log runs {:.2} s behind the depth gauge (median of {} of {} runs, {:.2}-{:.2} s; the others hold their depth too well to tell): a lag of the log that a model takes as a command lag, and that the diagnosis of a model without one takes out; where the gauge is prompt, `fusion: {{nav_latency_s: {:.2}}}` in the pool stage's settings takes it out of every run before the fit",
            self.median_s, self.runs, self.of, self.range_s[0], self.range_s[1], self.median_s
        )
    }
}

/// The sentence a run's notes carry for `m`.
pub fn sentence(m: &NavLatency) -> String {
    if m.value_s < 0.0 {
        return format!(
            "the depth gauge runs {:.2} s behind the navigation log (the log's vertical velocity, integrated, follows the depth {:.2} s earlier): the gauge is the late one",
            -m.value_s, -m.value_s
        );
    }
    format!(
        "the navigation log's velocity runs {:.2} s behind the depth gauge (its vertical velocity, integrated, follows the depth {:.2} s later: misfit {:.2e} m^2 against {:.2e} at none, depth spread {:.2} m): a latency of the log, which a fit takes as a command lag; where the gauge is prompt, `fusion: {{nav_latency_s: ...}}` in the pool stage's settings takes it out of every run",
        m.value_s, m.value_s, m.misfit_m2, m.misfit_at_zero_m2, m.depth_spread_m
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A log whose vertical velocity is the truth read `late` s late, beside a prompt gauge.
    fn logs(late: f64, amplitude_m: f64) -> (Log, Log) {
        let depth =
            |t: f64| 2.0 + amplitude_m * (0.3 * t).sin() + 0.1 * amplitude_m * (1.1 * t).sin();
        let rate = |t: f64| amplitude_m * (0.3 * (0.3 * t).cos() + 0.11 * (1.1 * t).cos());
        let mut rng = crate::core::rng::Rng::derive(7, "latency");
        let nt: Vec<f64> = (0..600)
            .map(|k| 0.2 * k as f64 + 0.05 * rng.uniform())
            .collect();
        let w: Vec<f64> = nt
            .iter()
            .map(|&t| rate(t - late) + 0.01 * rng.normal())
            .collect();
        let zero = vec![0.0; nt.len()];
        let nav = Log {
            cols: vec![zero.clone(), zero.clone(), w, zero.clone(), zero],
            t: nt,
            notes: Vec::new(),
            present: vec![true; 5],
        };
        let dt: Vec<f64> = (0..1200).map(|k| 0.1 * k as f64).collect();
        let z: Vec<f64> = dt
            .iter()
            .map(|&t| depth(t) + 0.005 * rng.normal())
            .collect();
        let gauge = Log {
            t: dt,
            cols: vec![z],
            notes: Vec::new(),
            present: vec![true],
        };
        (nav, gauge)
    }

    /// A log 0.4 s late is measured within two hundredths of a second; a prompt one near zero.
    #[test]
    fn a_late_navigation_log_is_measured_against_the_depth_gauge() {
        for late in [0.0, 0.15, 0.4] {
            let (nav, gauge) = logs(late, 0.5);
            let m = measure(&nav, &gauge);
            match late == 0.0 {
                // No latency: no minimum clear of the misfit at zero, or one at zero.
                true => assert!(m.is_none_or(|m| m.value_s.abs() <= 0.02), "{m:?}"),
                false => {
                    let m = m.expect("a latency measured");
                    assert!((m.value_s - late).abs() <= 0.02, "{late}: {m:?}");
                }
            }
        }
    }

    /// A gauge later than the log reads as a negative latency, and is said as the gauge's.
    #[test]
    fn a_late_depth_gauge_reads_as_a_negative_latency() {
        let (nav, gauge) = logs(-0.2, 0.5);
        let m = measure(&nav, &gauge).expect("measured");
        assert!((m.value_s + 0.2).abs() <= 0.02, "{m:?}");
        assert!(sentence(&m).starts_with("the depth gauge runs 0.20 s behind"));
        let s = Summary::of([Some(&m)].into_iter()).unwrap();
        assert!(
            s.sentence().contains("nothing is taken out"),
            "{}",
            s.sentence()
        );
    }

    /// A run that holds its depth within centimetres is not measured.
    #[test]
    fn a_run_at_constant_depth_is_not_measured() {
        let (nav, gauge) = logs(0.4, 0.02);
        assert_eq!(measure(&nav, &gauge), None);
    }
}
