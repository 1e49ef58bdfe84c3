//! What the named effects leave: whether a DOF's held-out residual is structured and above its
//! noise, and the `unexplained` entry the verdict reports for it.

use super::result::{Found, pct};
use super::{self as dx, Augmentation, Criteria, Data, Mismatch};
use crate::core::dof::Dof;
use crate::core::model::Plant;
use crate::diagnose::SLOTS;
use std::collections::BTreeMap;
use std::fmt::Write as _;

/// The structured residual no effect explains, as an `unexplained` entry: its DOFs, where it
/// is and the regime it concentrates in.
pub(super) fn unexplained_residual(
    plant: &Plant,
    data: &Data,
    selected: &dx::Selection,
    explained_cost: f64,
    left: &[Structured],
    crit: &Criteria,
) -> Found {
    let after_aug = dx::augmentation(selected);
    let res_after = dx::residuals(plant, &after_aug, &data.validate);
    let loc = dx::locate(&data.validate, &res_after, &data.scale);
    let regs = dx::regime_shares(&data.validate, &res_after, &data.scale);
    let s = data.eval(plant, &after_aug, true);
    let dofs = unexplained_dofs(data, &s, left, crit);
    // Where it is, in the DOFs it is reported in when they hold any of it.
    let worst = loc.iter().find(|m| dofs.contains(&m.dof)).or(loc.first());
    let top = regs
        .iter()
        .filter(|r| r.share_of_time > 0.05)
        .max_by(|a, b| {
            (a.share_of_error / a.share_of_time).total_cmp(&(b.share_of_error / b.share_of_time))
        });
    let ev = unexplained_evidence(explained_cost, data.noise_cost, left, worst, top);
    let nm = dx::nmae_map(&s, &data.slots);
    Found {
        name: "unexplained".into(),
        dofs,
        parameters: BTreeMap::new(),
        evidence: ev,
        validation_nmae_before: nm.clone(),
        validation_nmae_after: nm,
        validation_cost_before: explained_cost,
        validation_cost_after: explained_cost,
        alike: Vec::new(),
        possibly_beside: Vec::new(),
        candidate: None,
    }
}

/// The DOFs whose held-out residual after the effects is above the noise, and those found
/// structured (`left`).
fn unexplained_dofs(data: &Data, s: &dx::Sums, left: &[Structured], crit: &Criteria) -> Vec<Dof> {
    let per_dof: Vec<f64> = (0..SLOTS)
        .map(|j| s.sse[j] / s.n[j].max(1.0) / data.scale[j])
        .collect();
    let noise_dof = dx::noise_per_dof(&data.validate, &data.scale);
    let mut dofs: Vec<Dof> = (0..SLOTS)
        .filter(|&j| per_dof[j] > crit.within_noise * noise_dof[j])
        .map(|j| data.slots.dof(j))
        .collect();
    for d in left.iter().map(|l| l.dof) {
        if !dofs.contains(&d) {
            dofs.push(d);
        }
    }
    dofs
}

/// The evidence sentence of the `unexplained` entry: its size against the noise floor, the
/// DOFs found structured with the figures that decided it, where most of it is, and the
/// regime it concentrates in.
fn unexplained_evidence(
    explained_cost: f64,
    noise_cost: f64,
    left: &[Structured],
    worst: Option<&Mismatch>,
    top: Option<&dx::RegimeShare>,
) -> String {
    let mut ev = format!(
        "After the effects above the held-out error cost is {explained_cost:.4}, {:.1} times the noise floor",
        explained_cost / noise_cost
    );
    if !left.is_empty() {
        let _ = write!(ev, "; the residual is structured in {}", describe(left));
    }
    ev.push_str("; no effect of the table lowers it significantly");
    if let Some(m) = worst {
        let _ = write!(
            ev,
            "; most of it is in {} {} ({} of the error, windows {:?} s)",
            m.run,
            m.dof,
            pct(m.share_of_error),
            m.windows_s
        );
    }
    if let Some(r) = top {
        let _ = write!(
            ev,
            "; it concentrates {} ({} of the error in {} of the time)",
            r.label,
            pct(r.share_of_error),
            pct(r.share_of_time)
        );
    }
    ev.push('.');
    ev
}

/// A DOF whose held-out residual is structured and above its noise, with the figures that
/// decided it ([`structured_left`]).
#[derive(Debug, Clone, PartialEq)]
pub(super) struct Structured {
    pub dof: Dof,
    /// The residual's sum of squares over the fused velocities' noise variance summed alike.
    pub multiple: f64,
    /// The mean share over the runs of autocorrelation lags up to 5 s outside the 95 % band.
    pub acf_outside: f64,
    /// The line no command has (Hz), when it is the line that decided it.
    pub line_hz: Option<f64>,
}

impl Structured {
    /// "yaw: 6.2 times its noise, autocorrelated (outside the 95 % band at 45 % of the lags
    /// up to 5 s)", or "... with a line at 0.42 Hz that no command has".
    fn phrase(&self) -> String {
        let why = match self.line_hz {
            Some(f) => format!("with a line at {f:.2} Hz that no command has"),
            None => format!(
                "autocorrelated (outside the 95 % band at {} of the lags up to 5 s)",
                pct(self.acf_outside)
            ),
        };
        format!(
            "{}: {} times its noise, {why}",
            self.dof,
            multiple_in_words(self.multiple)
        )
    }
}

/// A multiple of the noise with one decimal, or more where one would round it to a whole
/// number or to [`LINE_NOISE_MULTIPLE`]: the thresholds it was compared with are those (1.5
/// and 5 times), and 5.04 read as "5.0" would say it is at the threshold rather than above it.
fn multiple_in_words(x: f64) -> String {
    (1..=3)
        .map(|d| format!("{x:.d$}"))
        .find(|s| {
            s.parse::<f64>()
                .is_ok_and(|r| r.fract() != 0.0 && r != LINE_NOISE_MULTIPLE)
        })
        .unwrap_or_else(|| format!("{x:.1}"))
}

/// The structured DOFs in words, joined by "; " (empty when there are none).
pub(super) fn describe(left: &[Structured]) -> String {
    left.iter()
        .map(Structured::phrase)
        .collect::<Vec<_>>()
        .join("; ")
}

/// The DOFs whose held-out residual, after the effects in `aug`, is structured and above its
/// noise: what is left there is physics the model lacks, however much the named effects
/// already explained. Structured is either
/// - over `unexplained_noise_multiple` times the fused variance, with its autocorrelation
///   outside the 95 % band at more than a fifth of the lags up to 5 s (seed 000), or
/// - over [`LINE_NOISE_MULTIPLE`] times the fused variance, with a line in its pooled
///   periodogram that no command has ([`super::spectrum::Lines::uncommanded`]): a periodic force is never
///   "within noise" (the fused velocities' own errors are coloured, so their
///   autocorrelation alone tells little below the higher multiple, but they make no line).
///
/// The pooled held-out cost may be within its noise floor while one DOF is not: the verdict
/// then quotes these figures, the ones that decided it.
pub(super) fn structured_left(
    plant: &Plant,
    data: &Data,
    aug: &Augmentation,
    crit: &Criteria,
) -> Vec<Structured> {
    let res = dx::residuals(plant, aug, &data.validate);
    let lines = super::spectrum::Lines::new(&data.validate);
    (0..SLOTS)
        .filter_map(|j| {
            let (mut sse, mut var, mut outside, mut runs) = (0.0, 0.0, 0.0, 0.0);
            for (r, e) in data.validate.iter().zip(&res) {
                let e: Vec<f64> = e[j].iter().copied().filter(|x| x.is_finite()).collect();
                if e.len() < 20 {
                    continue;
                }
                let dt = (r.t[r.t.len() - 1] - r.t[0]) / (r.t.len() - 1) as f64;
                sse += e.iter().map(|x| x * x).sum::<f64>();
                var += r.noise_sum(j);
                outside += crate::validate::whiteness(&e, dt, (5.0 / dt).round() as usize).outside;
                runs += 1.0;
            }
            if runs == 0.0 {
                return None;
            }
            let (multiple, acf_outside) = (sse / var.max(1e-300), outside / runs);
            let line_hz = || {
                (multiple > LINE_NOISE_MULTIPLE)
                    .then(|| lines.uncommanded(&res, j))
                    .flatten()
            };
            let correlated = multiple > crit.unexplained_noise_multiple && acf_outside > 0.2;
            let line_hz = if correlated { None } else { line_hz() };
            (correlated || line_hz.is_some()).then(|| Structured {
                dof: data.slots.dof(j),
                multiple,
                acf_outside,
                line_hz,
            })
        })
        .collect()
}

/// A residual at this multiple of its noise with a spectral line is structured.
pub(super) const LINE_NOISE_MULTIPLE: f64 = 1.5;

#[cfg(test)]
mod tests {
    #[test]
    fn a_multiple_above_a_whole_threshold_never_reads_as_the_threshold() {
        assert_eq!(super::multiple_in_words(6.21), "6.2");
        assert_eq!(super::multiple_in_words(5.04), "5.04");
        assert_eq!(super::multiple_in_words(2.001), "2.001");
        assert_eq!(super::multiple_in_words(12.0), "12.0");
        assert_eq!(super::multiple_in_words(1.504), "1.504");
        assert_eq!(super::multiple_in_words(1.56), "1.6");
    }
}
