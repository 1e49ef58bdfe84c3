//! A linear Kalman filter over irregular time steps with a Rauch-Tung-Striebel smoother.
//! The caller supplies each step's transition (it may vary, e.g. with heading) and measurements.

use nalgebra::{SMatrix, SVector};

pub type Mat<const N: usize> = SMatrix<f64, N, N>;
pub type Vector<const N: usize> = SVector<f64, N>;

struct Step<const N: usize> {
    /// Transition from the previous step into this one.
    f: Mat<N>,
    x_prior: Vector<N>,
    p_prior: Mat<N>,
    x: Vector<N>,
    p: Mat<N>,
}

/// Forward pass state plus everything the smoother needs.
pub struct Filter<const N: usize> {
    x: Vector<N>,
    p: Mat<N>,
    steps: Vec<Step<N>>,
}

/// Outcome of offering a measurement to the filter.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Update {
    Accepted,
    /// Rejected by the gate; the squared Mahalanobis distance of the innovation.
    Gated(f64),
}

impl<const N: usize> Filter<N> {
    pub fn new(x0: Vector<N>, p0: Mat<N>) -> Filter<N> {
        let mut f = Filter {
            x: x0,
            p: p0,
            steps: Vec::new(),
        };
        f.steps.push(Step {
            f: Mat::identity(),
            x_prior: x0,
            p_prior: p0,
            x: x0,
            p: p0,
        });
        f
    }

    /// Starts a new step: x <- F x + u, P <- F P F^T + Q.
    pub fn predict(&mut self, f: Mat<N>, u: Vector<N>, q: Mat<N>) {
        self.x = f * self.x + u;
        self.p = f * self.p * f.transpose() + q;
        self.p = (self.p + self.p.transpose()) * 0.5;
        self.steps.push(Step {
            f,
            x_prior: self.x,
            p_prior: self.p,
            x: self.x,
            p: self.p,
        });
    }

    /// Measurement z = H x + noise(R), with the innovation optionally wrapped (angles) and
    /// rejected when its squared Mahalanobis distance exceeds `gate`.
    pub fn update<const M: usize>(
        &mut self,
        z: SVector<f64, M>,
        h: SMatrix<f64, M, N>,
        r: SMatrix<f64, M, M>,
        gate: f64,
        wrap: impl Fn(&mut SVector<f64, M>),
    ) -> Update {
        let mut nu = z - h * self.x;
        wrap(&mut nu);
        let s = h * self.p * h.transpose() + r;
        let Some(s_inv) = s.try_inverse() else {
            return Update::Gated(f64::INFINITY);
        };
        let d2 = (nu.transpose() * s_inv * nu)[(0, 0)];
        if d2 > gate {
            return Update::Gated(d2);
        }
        let k = self.p * h.transpose() * s_inv;
        self.x += k * nu;
        // Joseph form keeps P symmetric and positive through thousands of updates.
        let i_kh = Mat::<N>::identity() - k * h;
        self.p = i_kh * self.p * i_kh.transpose() + k * r * k.transpose();
        let last = self.steps.last_mut().expect("a step exists");
        last.x = self.x;
        last.p = self.p;
        Update::Accepted
    }

    pub fn state(&self) -> (&Vector<N>, &Mat<N>) {
        (&self.x, &self.p)
    }

    pub fn len(&self) -> usize {
        self.steps.len()
    }

    pub fn is_empty(&self) -> bool {
        self.steps.is_empty()
    }

    /// Rauch-Tung-Striebel: the smoothed mean and covariance of every step, in order.
    pub fn smooth(&self) -> Vec<(Vector<N>, Mat<N>)> {
        let n = self.steps.len();
        let mut out = vec![(Vector::<N>::zeros(), Mat::<N>::zeros()); n];
        out[n - 1] = (self.steps[n - 1].x, self.steps[n - 1].p);
        for k in (0..n - 1).rev() {
            let (cur, next) = (&self.steps[k], &self.steps[k + 1]);
            // A singular prior means a state no noise reaches: regularise it slightly.
            let inv = next
                .p_prior
                .try_inverse()
                .or_else(|| (next.p_prior + Mat::<N>::identity() * 1e-12).try_inverse())
                .unwrap_or_else(Mat::<N>::zeros);
            let c = cur.p * next.f.transpose() * inv;
            let (xs, ps) = &out[k + 1];
            let x = cur.x + c * (xs - next.x_prior);
            let p = cur.p + c * (ps - next.p_prior) * c.transpose();
            out[k] = (x, (p + p.transpose()) * 0.5);
        }
        out
    }
}

/// Process noise of a position-velocity pair driven by white acceleration of spectral density `q`.
pub fn white_accel(q: f64, dt: f64) -> [[f64; 2]; 2] {
    [
        [q * dt.powi(3) / 3.0, q * dt.powi(2) / 2.0],
        [q * dt.powi(2) / 2.0, q * dt],
    ]
}

/// Process noise of a position-velocity pair driven by white acceleration of density `q`, with
/// a third state, independent of them, of variance `third` over the step.
pub fn white_accel_and(q: f64, dt: f64, third: f64) -> Mat<3> {
    let a = white_accel(q, dt);
    Mat::<3>::new(
        a[0][0], a[0][1], 0.0, a[1][0], a[1][1], 0.0, 0.0, 0.0, third,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn smoother_recovers_a_constant_velocity_track_better_than_the_filter() {
        // x = 0.5 t observed with sigma 0.1 every 0.1 s: the smoothed velocity at the start
        // knows about the whole track, the filtered one only about the first sample.
        let mut rng = crate::core::rng::Rng::new(3);
        let mut f = Filter::<2>::new(
            Vector::<2>::zeros(),
            Mat::<2>::from_diagonal(&Vector::<2>::new(1.0, 1.0)),
        );
        let dt = 0.1;
        let mut filtered_v0 = None;
        for k in 1..=200 {
            let q = white_accel(1e-6, dt);
            f.predict(
                Mat::<2>::new(1.0, dt, 0.0, 1.0),
                Vector::<2>::zeros(),
                Mat::<2>::new(q[0][0], q[0][1], q[1][0], q[1][1]),
            );
            let z = SVector::<f64, 1>::new(0.5 * k as f64 * dt + 0.1 * rng.normal());
            let h = SMatrix::<f64, 1, 2>::new(1.0, 0.0);
            assert_eq!(
                f.update(z, h, SMatrix::<f64, 1, 1>::new(0.01), 1e9, |_| {}),
                Update::Accepted
            );
            if k == 1 {
                filtered_v0 = Some(f.state().0[1]);
            }
        }
        let s = f.smooth();
        assert!((s[1].0[1] - 0.5).abs() < 0.02, "smoothed v {}", s[1].0[1]);
        assert!((filtered_v0.unwrap() - 0.5).abs() > (s[1].0[1] - 0.5).abs());
        let sd = s[1].1[(1, 1)].sqrt();
        assert!(sd > 0.001 && sd < 0.02, "{sd}");
        // A gross outlier is gated.
        let z = SVector::<f64, 1>::new(0.5 * 20.0 + 3.0);
        assert!(matches!(
            f.update(
                z,
                SMatrix::<f64, 1, 2>::new(1.0, 0.0),
                SMatrix::<f64, 1, 1>::new(0.01),
                16.0,
                |_| {}
            ),
            Update::Gated(_)
        ));
    }
}
