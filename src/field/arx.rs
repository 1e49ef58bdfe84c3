//! ARX models (seed 002 eq. 2.2-2.6): `A(q) y(t) = B(q) u(t-k) + v(t)` with
//! `A = 1 + a_1 q^-1 + ... + a_na q^-na`, `B = b_1 + b_2 q^-1 + ... + b_nb q^-(nb-1)`, estimated
//! by least squares on the one-step prediction error; the order and delay chosen over a grid
//! by a stated criterion (AIC, FPE, or the loss on held-out runs, as MATLAB's `arxstruc` /
//! `selstruc`); simulated (not only predicted) on held-out runs as `compare` does.

pub mod stage;

use nalgebra::{DMatrix, DVector};
use serde::{Deserialize, Serialize};

/// One record: input and output on a uniform grid, detrended as the caller chose.
#[derive(Debug, Clone)]
pub struct Record {
    pub name: String,
    pub u: Vec<f64>,
    pub y: Vec<f64>,
}

/// The structure of an ARX model: orders of A and B, delay in samples.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
pub struct Orders {
    pub na: usize,
    pub nb: usize,
    pub k: usize,
}

impl Orders {
    pub fn params(self) -> usize {
        self.na + self.nb
    }
    /// The first sample whose regressor is complete.
    fn start(self) -> usize {
        self.na.max(self.k + self.nb - 1)
    }
    /// The regressor of sample `t` (seed 002 eq. 2.6, A's coefficients with a minus sign).
    fn phi(self, r: &Record, t: usize, out: &mut Vec<f64>) {
        out.clear();
        out.extend((1..=self.na).map(|i| -r.y[t - i]));
        out.extend((0..self.nb).map(|j| r.u[t - self.k - j]));
    }
}

impl std::fmt::Display for Orders {
    fn fmt(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        write!(f, "na={} nb={} k={}", self.na, self.nb, self.k)
    }
}

/// A least-squares ARX estimate.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Arx {
    pub orders: Orders,
    pub a: Vec<f64>,
    pub b: Vec<f64>,
    pub a_std: Vec<f64>,
    pub b_std: Vec<f64>,
    /// Mean squared one-step prediction error on the estimation records (seed 002 eq. 2.6).
    pub loss: f64,
    /// Number of equations.
    pub n: usize,
    /// Akaike's criterion `N ln V + 2 d`, Rissanen's minimum description length
    /// `N ln V + d ln N`, and the final prediction error `V (1 + d/N)/(1 - d/N)`.
    pub aic: f64,
    pub mdl: f64,
    pub fpe: f64,
}

/// Estimates an ARX model of `orders` from `records` (rows stacked), or None when there are
/// too few equations or the regressor is singular.
pub fn estimate(records: &[Record], orders: Orders) -> Option<Arx> {
    estimate_from(records, orders, orders.start())
}

/// As [`estimate`], with the equations from sample `first` of each record on (a grid of
/// structures compared on the same equations, as `arxstruc` does).
pub fn estimate_from(records: &[Record], orders: Orders, first: usize) -> Option<Arx> {
    let d = orders.params();
    let mut rows: Vec<f64> = Vec::new();
    let mut ys: Vec<f64> = Vec::new();
    let mut phi = Vec::with_capacity(d);
    for r in records {
        for t in first.max(orders.start())..r.y.len() {
            orders.phi(r, t, &mut phi);
            rows.extend_from_slice(&phi);
            ys.push(r.y[t]);
        }
    }
    let n = ys.len();
    if n <= d + 1 || d == 0 {
        return None;
    }
    let a = DMatrix::from_row_slice(n, d, &rows);
    let y = DVector::from_vec(ys);
    let gram = a.transpose() * &a;
    let chol = gram.clone().cholesky()?;
    let theta = chol.solve(&(a.transpose() * &y));
    let resid = &y - &a * &theta;
    let loss = resid.norm_squared() / n as f64;
    if !(loss.is_finite() && loss > 0.0) {
        return None;
    }
    let sigma2 = resid.norm_squared() / (n - d) as f64;
    let inv = chol.inverse();
    let std: Vec<f64> = (0..d).map(|i| (sigma2 * inv[(i, i)]).sqrt()).collect();
    let (nf, df) = (n as f64, d as f64);
    Some(Arx {
        orders,
        a: theta.iter().take(orders.na).copied().collect(),
        b: theta.iter().skip(orders.na).copied().collect(),
        a_std: std[..orders.na].to_vec(),
        b_std: std[orders.na..].to_vec(),
        loss,
        n,
        aic: nf * loss.ln() + 2.0 * df,
        mdl: nf * loss.ln() + df * nf.ln(),
        fpe: loss * (1.0 + df / nf) / (1.0 - df / nf),
    })
}

impl Arx {
    /// One-step predictions of `r.y` (NaN before the regressor is complete).
    pub fn predict(&self, r: &Record) -> Vec<f64> {
        let o = self.orders;
        let mut phi = Vec::new();
        let theta: Vec<f64> = self.a.iter().chain(&self.b).copied().collect();
        (0..r.y.len())
            .map(|t| {
                if t < o.start() {
                    return f64::NAN;
                }
                o.phi(r, t, &mut phi);
                phi.iter().zip(&theta).map(|(p, c)| p * c).sum()
            })
            .collect()
    }

    /// The model simulated from the input alone, started from the measured output over its
    /// first `start` samples (MATLAB `compare` with measured initial conditions).
    pub fn simulate(&self, r: &Record) -> Vec<f64> {
        let o = self.orders;
        let mut ys: Vec<f64> = r.y.iter().take(o.start()).copied().collect();
        for t in o.start()..r.y.len() {
            let ar: f64 = (1..=o.na).map(|i| self.a[i - 1] * ys[t - i]).sum();
            let x: f64 = (0..o.nb).map(|j| self.b[j] * r.u[t - o.k - j]).sum();
            let v = x - ar;
            ys.push(if v.is_finite() { v } else { f64::NAN });
        }
        ys
    }

    /// Poles: the roots of `z^na + a_1 z^(na-1) + ... + a_na`.
    pub fn poles(&self) -> Vec<[f64; 2]> {
        roots(&self.a, 1.0)
    }

    /// Zeros: the roots of `b_1 z^(nb-1) + ... + b_nb`.
    pub fn zeros(&self) -> Vec<[f64; 2]> {
        match self.b.split_first() {
            Some((&lead, rest)) if lead != 0.0 => roots(rest, lead),
            _ => Vec::new(),
        }
    }

    /// Whether every pole is inside the unit circle.
    pub fn stable(&self) -> bool {
        self.poles().iter().all(|p| p[0].hypot(p[1]) < 1.0)
    }

    /// Steady-state gain `B(1)/A(1)`.
    pub fn gain(&self) -> f64 {
        self.b.iter().sum::<f64>() / (1.0 + self.a.iter().sum::<f64>())
    }
}

/// Roots of `lead z^n + c_1 z^(n-1) + ... + c_n` as (re, im), by the companion matrix.
pub fn roots(c: &[f64], lead: f64) -> Vec<[f64; 2]> {
    let n = c.len();
    if n == 0 {
        return Vec::new();
    }
    let mut m = DMatrix::<f64>::zeros(n, n);
    for (j, cj) in c.iter().enumerate() {
        m[(0, j)] = -cj / lead;
    }
    for i in 1..n {
        m[(i, i - 1)] = 1.0;
    }
    // A non-finite polynomial has no roots to show (its coefficients are reported as such).
    let Some(eig) = crate::core::numerics::complex_eigenvalues(m) else {
        return Vec::new();
    };
    let mut r: Vec<[f64; 2]> = eig.iter().map(|z| [z.re, z.im]).collect();
    r.sort_by(|a, b| b[0].hypot(b[1]).total_cmp(&a[0].hypot(a[1])));
    r
}

/// `100 (1 - |y - yhat| / |y - mean(y)|)` over the samples where `yhat` is finite (MATLAB's
/// NRMSE fit); minus infinity when the simulation diverged.
pub fn fit_percent(y: &[f64], yhat: &[f64]) -> f64 {
    let pairs: Vec<(f64, f64)> = y
        .iter()
        .zip(yhat)
        .filter(|(_, h)| !h.is_nan())
        .map(|(a, b)| (*a, *b))
        .collect();
    if pairs.is_empty() || pairs.iter().any(|(_, h)| !h.is_finite() || h.abs() > 1e12) {
        return f64::NEG_INFINITY;
    }
    let mean = pairs.iter().map(|p| p.0).sum::<f64>() / pairs.len() as f64;
    let e: f64 = pairs
        .iter()
        .map(|(a, b)| (a - b).powi(2))
        .sum::<f64>()
        .sqrt();
    let s: f64 = pairs
        .iter()
        .map(|(a, _)| (a - mean).powi(2))
        .sum::<f64>()
        .sqrt();
    100.0 * (1.0 - e / s.max(f64::MIN_POSITIVE))
}

/// Mean squared difference over the samples where `yhat` is a number (infinite if it is not
/// finite anywhere it should be).
pub fn mean_square(y: &[f64], yhat: &[f64]) -> f64 {
    let mut s = 0.0;
    let mut n = 0usize;
    for (a, b) in y.iter().zip(yhat) {
        if b.is_nan() {
            continue;
        }
        s += (a - b).powi(2);
        n += 1;
    }
    if n == 0 || !s.is_finite() {
        f64::INFINITY
    } else {
        s / n as f64
    }
}

/// How a structure is chosen from the grid.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Criterion {
    /// Rissanen's minimum description length on the estimation runs: consistent (picks the
    /// generating order as the data grow), the default.
    Mdl,
    /// Akaike's information criterion on the estimation runs.
    Aic,
    /// Akaike's final prediction error on the estimation runs.
    Fpe,
    /// The one-step prediction loss on the validation runs (MATLAB `arxstruc`).
    Prediction,
    /// The simulation loss on the validation runs (seed 002: the second run).
    Simulation,
}

/// One structure of the grid with its figures.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Scored {
    pub orders: Orders,
    pub loss: f64,
    pub aic: f64,
    pub mdl: f64,
    pub fpe: f64,
    /// Mean one-step prediction and simulation losses on the validation records.
    pub prediction_loss: Option<f64>,
    pub simulation_loss: Option<f64>,
}

impl Scored {
    pub fn of(m: &Arx, validation: &[Record]) -> Scored {
        let mean = |f: &dyn Fn(&Record) -> f64| {
            (!validation.is_empty())
                .then(|| validation.iter().map(f).sum::<f64>() / validation.len() as f64)
        };
        Scored {
            orders: m.orders,
            loss: m.loss,
            aic: m.aic,
            mdl: m.mdl,
            fpe: m.fpe,
            prediction_loss: mean(&|r| mean_square(&r.y, &m.predict(r))),
            simulation_loss: mean(&|r| mean_square(&r.y, &m.simulate(r))),
        }
    }

    /// The value `c` ranks by (lower is better); infinite when it cannot be computed.
    pub fn by(&self, c: Criterion) -> f64 {
        let v = match c {
            Criterion::Mdl => Some(self.mdl),
            Criterion::Aic => Some(self.aic),
            Criterion::Fpe => Some(self.fpe),
            Criterion::Prediction => self.prediction_loss,
            Criterion::Simulation => self.simulation_loss,
        };
        v.filter(|x| x.is_finite()).unwrap_or(f64::INFINITY)
    }
}

/// Every structure of `grid` estimated on `est` (the same equations for all) and scored
/// (validation figures on `val`), best first by `c`; ties go to fewer parameters, then the
/// shorter delay.
pub fn select(est: &[Record], val: &[Record], grid: &[Orders], c: Criterion) -> Vec<Scored> {
    let first = grid.iter().map(|o| o.start()).max().unwrap_or(0);
    let mut out: Vec<Scored> = grid
        .iter()
        .filter_map(|o| estimate_from(est, *o, first))
        .map(|m| Scored::of(&m, val))
        .collect();
    out.sort_by(|x, y| {
        x.by(c)
            .total_cmp(&y.by(c))
            .then(x.orders.params().cmp(&y.orders.params()))
            .then(x.orders.k.cmp(&y.orders.k))
    });
    out
}

/// The structures `na in na_range`, `nb in nb_range`, `k in k_range` (inclusive).
pub fn grid(na: [usize; 2], nb: [usize; 2], k: [usize; 2]) -> Vec<Orders> {
    let mut g = Vec::new();
    for na in na[0]..=na[1] {
        for nb in nb[0].max(1)..=nb[1] {
            for k in k[0]..=k[1] {
                g.push(Orders { na, nb, k });
            }
        }
    }
    g
}

/// Normalised autocorrelation of `e` at lags `0..=max_lag`, NaNs skipped (MATLAB `resid`);
/// the 99 % band of a white sequence is `2.58 / sqrt(N)`.
pub fn autocorrelation(e: &[f64], max_lag: usize) -> (Vec<f64>, f64) {
    let x: Vec<f64> = e.iter().copied().filter(|v| v.is_finite()).collect();
    let n = x.len();
    if n < 2 {
        return (Vec::new(), f64::NAN);
    }
    let mean = x.iter().sum::<f64>() / n as f64;
    let c = |l: usize| -> f64 {
        (l..n)
            .map(|t| (x[t] - mean) * (x[t - l] - mean))
            .sum::<f64>()
            / n as f64
    };
    let c0 = c(0).max(f64::MIN_POSITIVE);
    let acf = (0..=max_lag.min(n - 1)).map(|l| c(l) / c0).collect();
    (acf, 2.58 / (n as f64).sqrt())
}

/// A model of the stage with its figures on every validation run.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Model {
    pub name: String,
    pub selected: bool,
    #[serde(flatten)]
    pub arx: Arx,
    pub poles: Vec<[f64; 2]>,
    pub zeros: Vec<[f64; 2]>,
    pub stable: bool,
    pub gain: f64,
    pub validation: Vec<RunFit>,
}

#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct RunFit {
    pub run: String,
    /// MATLAB `compare`'s NRMSE fit of the simulation, %; None when the simulation diverged.
    pub fit_pct: Option<f64>,
    pub simulation_loss: Option<f64>,
    pub prediction_loss: Option<f64>,
}

/// A run with the measured output and each model's simulation, for the plot.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Simulation {
    pub run: String,
    pub t: Vec<f64>,
    pub input: Vec<f64>,
    pub measured: Vec<f64>,
    pub models: Vec<(String, Vec<f64>)>,
}

/// What `arx` stores in `detail`.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Detail {
    pub input: String,
    pub output: String,
    pub input_unit: String,
    pub output_unit: String,
    pub sample_s: f64,
    pub criterion: Criterion,
    pub models: Vec<Model>,
    /// The best structures of the grid by the criterion, best first.
    pub ranking: Vec<Scored>,
    pub grid_size: usize,
    pub simulations: Vec<Simulation>,
    /// Autocorrelation of the chosen model's one-step prediction error on the first validation
    /// run (the estimation run when there is none), with its 99 % band.
    pub residual_run: String,
    pub residual_acf: Vec<f64>,
    pub residual_band: f64,
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::core::rng::Rng;

    /// A record generated by a known ARX model with white equation noise.
    fn generate(o: Orders, a: &[f64], b: &[f64], n: usize, noise: f64, seed: u64) -> Record {
        let mut rng = Rng::new(seed);
        // A PRBS-like input: +-1 held for a random 1-6 samples.
        let mut u = Vec::with_capacity(n);
        let mut level = 1.0;
        while u.len() < n {
            let hold = 1 + (rng.uniform() * 6.0) as usize;
            u.extend(std::iter::repeat_n(level, hold));
            level = -level;
        }
        u.truncate(n);
        let mut y = vec![0.0; n];
        for t in o.start()..n {
            let ar: f64 = (1..=o.na).map(|i| a[i - 1] * y[t - i]).sum();
            let x: f64 = (0..o.nb).map(|j| b[j] * u[t - o.k - j]).sum();
            y[t] = x - ar + noise * rng.normal();
        }
        Record {
            name: format!("seed{seed}"),
            u,
            y,
        }
    }

    const TRUE: Orders = Orders { na: 2, nb: 2, k: 3 };
    const A: [f64; 2] = [-1.5, 0.7];
    const B: [f64; 2] = [0.5, 0.3];

    #[test]
    fn noise_free_arx_is_recovered_exactly_with_its_poles() {
        let r = generate(TRUE, &A, &B, 400, 0.0, 1);
        let m = estimate(std::slice::from_ref(&r), TRUE).unwrap();
        for (x, t) in m.a.iter().chain(&m.b).zip(A.iter().chain(&B)) {
            assert!((x - t).abs() < 1e-9, "{x} vs {t}");
        }
        // z^2 - 1.5 z + 0.7: 0.75 +- 0.3708i, |z| = 0.8367.
        let p = m.poles();
        assert!((p[0][0] - 0.75).abs() < 1e-9 && (p[0][1].abs() - 0.370_81).abs() < 1e-4);
        assert!(m.stable());
        // Zero of 0.5 z + 0.3 at -0.6.
        assert!((m.zeros()[0][0] + 0.6).abs() < 1e-9);
        let sim = m.simulate(&r);
        assert!(fit_percent(&r.y, &sim) > 99.999);
    }

    #[test]
    fn selection_picks_the_generating_order_and_delay() {
        let g = grid([1, 5], [1, 4], [0, 5]);
        assert_eq!(g.len(), 120);
        for seed in 0..6 {
            let est = generate(TRUE, &A, &B, 1500, 0.05, 2 * seed);
            let val = generate(TRUE, &A, &B, 1500, 0.05, 2 * seed + 1);
            let (e, v) = (std::slice::from_ref(&est), std::slice::from_ref(&val));
            let ranked = select(e, v, &g, Criterion::Mdl);
            assert_eq!(ranked[0].orders, TRUE, "seed {seed}: {:?}", &ranked[..3]);
            // AIC, FPE and the held-out losses may add parameters (they are not consistent),
            // but their choice contains the truth: no lag of A or B dropped.
            for c in [Criterion::Aic, Criterion::Fpe, Criterion::Prediction] {
                let best = select(e, v, &g, c)[0].orders;
                assert!(
                    best.na >= TRUE.na && best.nb + best.k >= TRUE.nb + TRUE.k && best.k <= TRUE.k,
                    "seed {seed} {c:?}: {best}"
                );
            }
        }
        let est = generate(TRUE, &A, &B, 1500, 0.05, 2);
        // Noisy estimate within 5 standard errors of the truth, and the errors are small.
        let m = estimate(&[est], TRUE).unwrap();
        for ((x, s), t) in
            m.a.iter()
                .chain(&m.b)
                .zip(m.a_std.iter().chain(&m.b_std))
                .zip(A.iter().chain(&B))
        {
            assert!((x - t).abs() < 5.0 * s && *s < 0.02, "{x} +- {s} vs {t}");
        }
    }

    #[test]
    fn residuals_of_the_right_model_are_white_and_of_a_wrong_one_are_not() {
        let r = generate(TRUE, &A, &B, 2000, 0.05, 4);
        let right = estimate(std::slice::from_ref(&r), TRUE).unwrap();
        let wrong = estimate(std::slice::from_ref(&r), Orders { na: 1, nb: 1, k: 1 }).unwrap();
        let e = |m: &Arx| {
            let p = m.predict(&r);
            r.y.iter().zip(&p).map(|(y, p)| y - p).collect::<Vec<_>>()
        };
        let (acf, band) = autocorrelation(&e(&right), 20);
        let outside = acf[1..].iter().filter(|x| x.abs() > band).count();
        assert!(outside <= 2, "{outside} lags outside {band}");
        let (acf, band) = autocorrelation(&e(&wrong), 20);
        assert!(acf[1..].iter().filter(|x| x.abs() > band).count() > 5);
    }
}
