//! The gain of the logged command (`thrust_gain: fit`): the factor between the force the
//! pool runs' logged command says (a thrust curve at another battery voltage, a datasheet's
//! bollard thrust, a lever arm measured wrong) and the force the vehicle got.
//!
//! From pool runs alone the gain cannot be identified: a model whose every force is scaled
//! by the gain's inverse fits the same runs (seed 004 identifies its actuator parameters only
//! up to such a scale, its nullspace). The CFD cases fix the scale: their force is known. So
//! the added mass and drag are first fitted on the CFD cases alone (least squares with signs,
//! seed 001 eq. 14), then, per DOF of the pool runs, the force that model needs along each
//! run (`M nu_dot + C nu + D nu`, from the fused velocity) is regressed on the logged command,
//! `f = k tau + c`, with an intercept for a constant force the CFD lacks (net buoyancy, a
//! tether's pull). The noise of the differentiated velocity is in `f` only, so `k` is not
//! biased by it. A command lag shifts the force after the command and biases `k` low: the
//! command is passed through a first-order lag chosen from a grid by the least residual.
//! The DOFs' gains are pooled by their inverse variances; DOFs that disagree beyond their
//! errors are said (a thruster layout or lever arm, or an effect the CFD lacks).

use super::Regression;
use super::normal::Normal;
use crate::core::dof::Dof;
use crate::core::model::Vehicle;
use crate::core::model::dynamics::lagged;
use crate::core::response::Response;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// Whether the fit identifies the command's gain.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ThrustGain {
    /// The logged command is the force (through `vehicle.thrusters` and its `gain`).
    #[default]
    Fixed,
    /// Identified against the CFD cases' force scale.
    Fit,
}

/// The identified gain: the force delivered per unit of logged command.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct GainEstimate {
    pub value: f64,
    /// Standard error, widened for the residuals' correlation from sample to sample (an AR(1)
    /// factor); still optimistic where the CFD model itself is off.
    pub stderr: f64,
    /// Per DOF: (gain, standard error).
    pub per_dof: BTreeMap<Dof, (f64, f64)>,
    /// The command lag the gain was regressed with (s).
    pub lag_s: f64,
    /// Whether the DOFs' gains agree within three standard errors of their difference.
    pub consistent: bool,
}

/// Lags tried between the logged command and the force (s).
const LAGS: [f64; 8] = [0.0, 0.05, 0.1, 0.15, 0.2, 0.3, 0.4, 0.6];

impl GainEstimate {
    /// The sentence the fit's notes and the report give.
    pub fn sentence(&self) -> String {
        let dofs: Vec<String> = self
            .per_dof
            .iter()
            .map(|(d, (k, se))| format!("{d} {k:.3} ± {se:.3}"))
            .collect();
        let agree = if self.consistent {
            "the DOFs agree".to_string()
        } else {
            "the DOFs disagree beyond their errors: check the thruster layout and lever arms, \
             or look for an effect the CFD lacks (the diagnosis)"
                .to_string()
        };
        format!(
            "thrust gain {:.3} ± {:.3} (the regression's error; the CFD model's own adds to \
             it): the vehicle got {:.1} % of the force its logged command says, against the CFD \
             cases' force scale (per DOF: {}; command lag {:.2} s in the regression; {agree}); \
             the pool runs' command is scaled by it in this fit and in every simulation of its \
             model",
            self.value,
            self.stderr,
            100.0 * self.value,
            dofs.join(", "),
            self.lag_s
        )
    }
}

/// What the gain is estimated from: the CFD cases' regression rows, and the pool runs.
pub struct Sources<'a> {
    pub vehicle: &'a Vehicle,
    pub cfd: Regression,
    pub pool: &'a [&'a Response],
    pub skip_start_s: f64,
}

/// Estimates the gain from the CFD cases and the pool runs (see the module's text).
pub fn estimate(data: &Sources) -> anyhow::Result<GainEstimate> {
    anyhow::ensure!(
        data.cfd.rows() > 0 && !data.pool.is_empty(),
        "thrust_gain: fit needs CFD cases and pool runs in this fit's `from`: from pool runs \
         alone the gain trades one for one against the mass and drag (every force scaled \
         alike fits the same runs), and only the CFD cases' known force fixes the scale"
    );
    let cfd = &data.cfd;
    let ones: BTreeMap<Dof, f64> = cfd.row_dof.iter().map(|d| (*d, 1.0)).collect();
    let (theta, _) = super::ols::solve_signed(cfd, &ones, Normal::for_problem(cfd).as_ref())
        .map_err(|e| anyhow::anyhow!("thrust_gain: the CFD cases alone give no model: {e}"))?;
    let without: Vec<Response> = data.pool.iter().map(|r| scaled(r, 0.0)).collect();
    let refs: Vec<&Response> = without.iter().collect();
    let rigid = Regression::build(data.vehicle, &refs, data.skip_start_s);
    // The force the CFD model needs at each row: Phi theta + the rigid-body part (-y0).
    let need: Vec<f64> = (0..rigid.rows())
        .map(|i| dot(rigid.row(i), &theta) - rigid.y[i])
        .collect();
    let best = LAGS
        .iter()
        .filter_map(|&lag| {
            let tau = command_rows(data, lag);
            let per_dof = per_dof(&need, &tau, &rigid.row_dof);
            let cost: f64 = per_dof.values().map(|f| f.cost).sum();
            (!per_dof.is_empty()).then_some((lag, per_dof, cost))
        })
        .min_by(|a, b| a.2.total_cmp(&b.2));
    let Some((lag_s, fits, _)) = best else {
        anyhow::bail!(
            "thrust_gain: no DOF of the pool runs has a varying command to regress the force on"
        );
    };
    Ok(pooled(lag_s, &fits))
}

/// `r` with its applied force times `k`.
pub fn scaled(r: &Response, k: f64) -> Response {
    let mut out = r.clone();
    for s in out.dofs.values_mut() {
        s.force.iter_mut().for_each(|f| *f *= k);
    }
    out
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// The logged command at each regression row (in [`Regression::build`]'s order), passed
/// through a first-order lag of `lag_s`.
fn command_rows(data: &Sources, lag_s: f64) -> Vec<f64> {
    let mut out = Vec::new();
    for r in data.pool {
        let tau: Vec<[f64; 6]> = (0..r.len()).map(|k| r.tau(k)).collect();
        let tau = lagged(&r.t, &tau, lag_s);
        let dofs: Vec<Dof> = r
            .dofs
            .keys()
            .copied()
            .filter(|d| data.vehicle.dofs.contains(d))
            .collect();
        for k in (0..r.len()).filter(|&k| r.t[k] >= data.skip_start_s) {
            out.extend(dofs.iter().map(|d| tau[k][d.index()]));
        }
    }
    out
}

/// One DOF's regression `need = k tau + c`.
struct DofFit {
    k: f64,
    se: f64,
    /// Residual sum of squares over the DOF's force variance (comparable across DOFs).
    cost: f64,
}

/// Per DOF with a varying command, the regression of the needed force on the command.
fn per_dof(need: &[f64], tau: &[f64], row_dof: &[Dof]) -> BTreeMap<Dof, DofFit> {
    let mut rows: BTreeMap<Dof, Vec<(f64, f64)>> = BTreeMap::new();
    for ((f, t), d) in need.iter().zip(tau).zip(row_dof) {
        if f.is_finite() && t.is_finite() {
            rows.entry(*d).or_default().push((*t, *f));
        }
    }
    rows.into_iter()
        .filter_map(|(d, xy)| Some((d, line(&xy)?)))
        .collect()
}

/// Least squares `y = k x + c` with the standard error of `k`; `None` for a constant `x`.
fn line(xy: &[(f64, f64)]) -> Option<DofFit> {
    let n = xy.len() as f64;
    if n < 10.0 {
        return None;
    }
    let (mx, my) = xy
        .iter()
        .fold((0.0, 0.0), |(a, b), (x, y)| (a + x / n, b + y / n));
    let sxx: f64 = xy.iter().map(|(x, _)| (x - mx).powi(2)).sum();
    let sxy: f64 = xy.iter().map(|(x, y)| (x - mx) * (y - my)).sum();
    let syy: f64 = xy.iter().map(|(_, y)| (y - my).powi(2)).sum();
    if sxx <= 1e-12 * n || syy <= 0.0 {
        return None;
    }
    let k = sxy / sxx;
    let rss = (syy - k * sxy).max(0.0);
    // Residuals of a smoothed, differentiated velocity are correlated from sample to sample:
    // the white-noise standard error is widened by the AR(1) factor sqrt((1 + rho) / (1 - rho)).
    let e: Vec<f64> = xy.iter().map(|(x, y)| (y - my) - k * (x - mx)).collect();
    let lag1: f64 = e.windows(2).map(|w| w[0] * w[1]).sum();
    let rho = (lag1 / e.iter().map(|x| x * x).sum::<f64>().max(1e-300)).clamp(0.0, 0.999);
    let se = (rss / (n - 2.0) / sxx).sqrt() * ((1.0 + rho) / (1.0 - rho)).sqrt();
    Some(DofFit {
        k,
        se,
        cost: rss / syy,
    })
}

/// The DOFs' gains pooled by inverse variance, and whether they agree.
fn pooled(lag_s: f64, fits: &BTreeMap<Dof, DofFit>) -> GainEstimate {
    let w: f64 = fits.values().map(|f| 1.0 / f.se.max(1e-12).powi(2)).sum();
    let value = fits
        .values()
        .map(|f| f.k / f.se.max(1e-12).powi(2))
        .sum::<f64>()
        / w;
    let stderr = (1.0 / w).sqrt();
    let consistent = fits.values().all(|f| {
        (f.k - value).abs()
            <= 3.0
                * (f.se.powi(2) + stderr.powi(2))
                    .sqrt()
                    .max(0.02 * value.abs())
    });
    GainEstimate {
        value,
        stderr,
        per_dof: fits.iter().map(|(d, f)| (*d, (f.k, f.se))).collect(),
        lag_s,
        consistent,
    }
}
