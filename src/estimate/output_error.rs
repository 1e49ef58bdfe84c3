//! The output-error objective (seed 001 eq. 9): every candidate model simulated under each
//! case's force and compared with the recorded velocities. The population methods minimise
//! its cost; the local refinement ([`super::refine`]) its residuals.

/// The cases an output-error objective simulates, and the plant's rigid-body side.
pub struct OutputError<'a> {
    pub vehicle: &'a crate::model::Vehicle,
    pub responses: &'a [&'a crate::io::Response],
    /// Per case and DOF, 1 / its mean square velocity: every case counts by its relative
    /// error, so the slow cases that pin the linear drag weigh as much as the fast ones.
    pub weight: Vec<[f64; 6]>,
}

impl<'a> OutputError<'a> {
    pub fn new(
        vehicle: &'a crate::model::Vehicle,
        responses: &'a [&'a crate::io::Response],
    ) -> OutputError<'a> {
        let weight = responses
            .iter()
            .map(|r| {
                let mut w = [0.0; 6];
                for (d, s) in &r.dofs {
                    let ms = s.velocity.iter().map(|v| v * v).sum::<f64>()
                        / s.velocity.len().max(1) as f64;
                    w[d.index()] = if ms > 1e-12 { 1.0 / ms } else { 0.0 };
                }
                w
            })
            .collect();
        OutputError {
            vehicle,
            responses,
            weight,
        }
    }

    /// The weighted velocity errors of the model `theta`, case by case, DOF by DOF, sample by
    /// sample (a diverged simulation counts as a large error).
    pub fn residuals(&self, layout: &crate::model::ParamLayout, theta: &[f64]) -> Vec<f64> {
        let plant = crate::model::Plant::new(self.vehicle, layout.to_hydro(theta));
        let mut out = Vec::new();
        for (r, w) in self.responses.iter().zip(&self.weight) {
            let sim = r.simulate(&plant);
            for (d, series) in &r.dofs {
                let i = d.index();
                let sw = w[i].sqrt();
                out.extend(series.velocity.iter().enumerate().map(|(k, v)| {
                    let e = sim[k][i] - v;
                    if e.is_finite() { sw * e } else { 1e3 }
                }));
            }
        }
        out
    }

    /// Mean weighted squared velocity error of the model `theta` over every case.
    pub(crate) fn cost(&self, layout: &crate::model::ParamLayout, theta: &[f64]) -> f64 {
        let plant = crate::model::Plant::new(self.vehicle, layout.to_hydro(theta));
        let (mut s, mut n) = (0.0, 0usize);
        for (r, w) in self.responses.iter().zip(&self.weight) {
            let sim = r.simulate(&plant);
            for (d, series) in &r.dofs {
                let i = d.index();
                for (k, v) in series.velocity.iter().enumerate() {
                    let e = sim[k][i] - v;
                    s += w[i] * if e.is_finite() { e * e } else { 1e6 };
                }
                n += series.velocity.len();
            }
        }
        s / n.max(1) as f64
    }
}
