//! The position filter: state [x, y, z, vx, vy, vz, accelerometer bias (body x, y, z)] in the
//! pool frame, driven by the IMU's specific force rotated with the smoothed heading and
//! corrected by UWB, sonar and depth fixes, taken in the order of their times.

use super::heading::Heading;
use super::kalman::{Filter, Mat, Update, Vector, white_accel};
use super::numeric::chi2_quantile;
use super::{Noise, Settings, Stats, interp};
use crate::pool::import::csvlog::Log;
use crate::pool::import::{G, PoolRun};
use nalgebra::{SMatrix, SVector};

/// Neighbours each side for the UWB median screen (seed 003 uses median filters the same way).
const MEDIAN_HALF_WINDOW: usize = 5;
/// Probability kept by the chi-square gate on every position fix.
const GATE_PROBABILITY: f64 = 0.999;
/// UWB fixes rejected in a row after which the filter, not the fixes, is taken to be wrong.
const REACQUIRE_AFTER: usize = 10;

/// The logs a fusion uses: the run's, less those the settings exclude.
pub(super) struct Sensors<'a> {
    pub(super) imu: Option<&'a Log>,
    pub(super) uwb: Option<&'a Log>,
    pub(super) sonar: Option<&'a Log>,
    pub(super) depth: Option<&'a Log>,
    pub(super) nav: Option<&'a Log>,
}

impl<'a> Sensors<'a> {
    /// The run's logs that `s.exclude` does not name.
    pub(super) fn of(run: &'a PoolRun, s: &Settings) -> Sensors<'a> {
        let use_ = |name: &str| !s.exclude.iter().any(|e| e == name);
        Sensors {
            imu: run.imu.as_ref().filter(|_| use_("imu")),
            uwb: run.uwb.as_ref().filter(|_| use_("uwb")),
            sonar: run.sonar.as_ref().filter(|_| use_("sonar")),
            depth: run.depth.as_ref().filter(|_| use_("depth")),
            nav: run.nav.as_ref().filter(|_| use_("nav")),
        }
    }

    /// The IMU when it has accelerometers: only such an IMU drives the position filter.
    fn imu_accel(&self) -> Option<&'a Log> {
        self.imu.filter(|l| (6..9).all(|c| l.has(c)))
    }

    /// Whether any sensor fixes the horizontal position (UWB or sonar).
    pub(super) fn horizontal(&self) -> bool {
        self.uwb.is_some() || self.sonar.is_some()
    }

    /// Whether any sensor fixes the depth (a depth gauge or UWB with heights).
    pub(super) fn vertical(&self) -> bool {
        self.depth.is_some() || self.uwb.is_some_and(|l| l.has(2))
    }
}

/// One sample of one log, or an output time, on the merged time line.
#[derive(Clone, Copy)]
enum Event {
    Imu(usize),
    Uwb(usize),
    Sonar(usize),
    Depth(usize),
    Out(usize),
}

/// Every sample of the used logs and every output time, in time order: at equal times the IMU
/// first, then the fixes, then the output.
fn events(sensors: &Sensors, out_t: &[f64]) -> Vec<(f64, u8, Event)> {
    let mut events: Vec<(f64, u8, Event)> = Vec::new();
    let mut add = |log: Option<&Log>, order: u8, event: fn(usize) -> Event| {
        if let Some(l) = log {
            events.extend(l.t.iter().enumerate().map(|(k, &t)| (t, order, event(k))));
        }
    };
    add(sensors.imu_accel(), 0, Event::Imu);
    add(sensors.uwb, 1, Event::Uwb);
    add(sensors.sonar, 1, Event::Sonar);
    add(sensors.depth, 1, Event::Depth);
    events.extend(
        out_t
            .iter()
            .enumerate()
            .map(|(k, &t)| (t, 2, Event::Out(k))),
    );
    events.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
    events
}

/// The filter at the first fixes there are, at rest, with the accelerometer bias unknown to
/// about 0.02 g.
fn initial_filter(sensors: &Sensors) -> Filter<9> {
    let first = |l: Option<&Log>, c: usize| l.map(|l| l.cols[c][0]);
    let (uwb, sonar, depth) = (sensors.uwb, sensors.sonar, sensors.depth);
    let x0 = Vector::<9>::from_column_slice(&[
        first(sonar, 0).or(first(uwb, 0)).unwrap_or(0.0),
        first(sonar, 1).or(first(uwb, 1)).unwrap_or(0.0),
        first(depth, 0).or(first(uwb, 2)).unwrap_or(0.0),
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
    ]);
    let ab = 0.02 * G;
    let p0 = Mat::<9>::from_diagonal(&Vector::<9>::from_column_slice(&[
        1.0,
        1.0,
        1.0,
        0.25,
        0.25,
        0.25,
        ab * ab,
        ab * ab,
        ab * ab,
    ]));
    Filter::<9>::new(x0, p0)
}

/// Marks UWB fixes that stray from the median of their neighbours (multipath).
fn median_screen(uwb: &Log, half: usize, limit: f64) -> Vec<bool> {
    let n = uwb.len();
    (0..n)
        .map(|k| {
            let (a, b) = (k.saturating_sub(half), (k + half + 1).min(n));
            (0..3).all(|c| {
                let mut w: Vec<f64> = uwb.cols[c][a..b].to_vec();
                w.sort_by(f64::total_cmp);
                (uwb.cols[c][k] - w[w.len() / 2]).abs() <= limit * if c == 2 { 2.0 } else { 1.0 }
            })
        })
        .collect()
}

/// The position filter's forward pass and what it keeps between events.
pub(super) struct PositionFilter<'a> {
    kf: Filter<9>,
    sensors: &'a Sensors<'a>,
    imu_accel: Option<&'a Log>,
    heading: Option<&'a Heading>,
    noise: &'a Noise,
    /// Per UWB fix: whether it passed the median screen.
    good_uwb: Vec<bool>,
    /// Chi-square gates for fixes of 1, 2 and 3 components.
    gate1: f64,
    gate2: f64,
    gate3: f64,
    uwb_rejected_in_row: usize,
}

impl<'a> PositionFilter<'a> {
    /// The filter at its initial state, with the UWB fixes screened.
    pub(super) fn new(
        sensors: &'a Sensors<'a>,
        s: &Settings,
        noise: &'a Noise,
        heading: Option<&'a Heading>,
    ) -> PositionFilter<'a> {
        let kf = initial_filter(sensors);
        let good_uwb = sensors.uwb.map_or(vec![], |l| {
            median_screen(l, MEDIAN_HALF_WINDOW, s.uwb_outlier_m.unwrap_or(0.4))
        });
        PositionFilter {
            kf,
            sensors,
            imu_accel: sensors.imu_accel(),
            heading,
            noise,
            good_uwb,
            gate3: chi2_quantile(GATE_PROBABILITY, 3),
            gate2: chi2_quantile(GATE_PROBABILITY, 2),
            gate1: chi2_quantile(GATE_PROBABILITY, 1),
            uwb_rejected_in_row: 0,
        }
    }

    /// Runs the filter forward over every event up to the output times `out_t` and smooths it:
    /// the smoothed state of every step and the step of each output time.
    pub(super) fn run(
        mut self,
        out_t: &[f64],
        stats: &mut Stats,
    ) -> (Vec<(Vector<9>, Mat<9>)>, Vec<usize>) {
        let events = events(self.sensors, out_t);
        let mut out_step = vec![0usize; out_t.len()];
        let mut last_t = events.first().map_or(0.0, |e| e.0);
        let mut last_imu: Option<usize> = None;
        for &(t, _, ev) in &events {
            let dt = t - last_t;
            if dt > 0.0 {
                self.predict(dt, last_imu);
                last_t = t;
            }
            match ev {
                Event::Imu(k) => last_imu = Some(k),
                Event::Uwb(k) => self.uwb_fix(k, stats),
                Event::Sonar(k) => self.sonar_fix(k, stats),
                Event::Depth(k) => self.depth_fix(k, stats),
                Event::Out(k) => out_step[k] = self.kf.len() - 1,
            }
        }
        (self.kf.smooth(), out_step)
    }

    /// A step of `dt`, driven by the IMU sample `last_imu` when there is one.
    fn predict(&mut self, dt: f64, last_imu: Option<usize>) {
        let (fm, u, q) = transition(
            dt,
            last_imu.and_then(|k| Some((self.imu_accel?, self.heading?, k))),
            self.noise,
        );
        self.kf.predict(fm, u, q);
    }

    /// UWB fix `k`: screened by the median, then gated (the gate opens after a run of
    /// rejections, to re-acquire).
    fn uwb_fix(&mut self, k: usize, stats: &mut Stats) {
        let l = self.sensors.uwb.unwrap();
        stats.uwb_fixes += 1;
        if !self.good_uwb[k] {
            stats.uwb_rejected_median += 1;
            return;
        }
        // A UWB log without heights gives the horizontal position only.
        let z = SVector::<f64, 3>::new(
            l.cols[0][k],
            l.cols[1][k],
            if l.has(2) { l.cols[2][k] } else { 0.0 },
        );
        let mut h = SMatrix::<f64, 3, 9>::zeros();
        h[(0, 0)] = 1.0;
        h[(1, 1)] = 1.0;
        h[(2, 2)] = 1.0;
        let r = SMatrix::<f64, 3, 3>::from_diagonal(&SVector::<f64, 3>::from_iterator(
            self.noise.uwb_m.iter().map(|x| x * x),
        ));
        if !l.has(2) {
            h[(2, 2)] = 0.0;
        }
        // After a second of rejections the filter, not the fixes, is wrong: re-acquire.
        let gate = if self.uwb_rejected_in_row >= REACQUIRE_AFTER {
            f64::INFINITY
        } else {
            self.gate3
        };
        match self.kf.update(z, h, r, gate, |_| {}) {
            Update::Accepted => self.uwb_rejected_in_row = 0,
            Update::Gated(_) => {
                self.uwb_rejected_in_row += 1;
                stats.uwb_rejected_gate += 1;
            }
        }
    }

    /// Sonar fix `k` (horizontal position), gated.
    fn sonar_fix(&mut self, k: usize, stats: &mut Stats) {
        let l = self.sensors.sonar.unwrap();
        let z = SVector::<f64, 2>::new(l.cols[0][k], l.cols[1][k]);
        let mut h = SMatrix::<f64, 2, 9>::zeros();
        h[(0, 0)] = 1.0;
        h[(1, 1)] = 1.0;
        let r = SMatrix::<f64, 2, 2>::identity() * self.noise.sonar_m.powi(2);
        match self.kf.update(z, h, r, self.gate2, |_| {}) {
            Update::Accepted => stats.sonar_fixes += 1,
            Update::Gated(_) => stats.sonar_rejected_gate += 1,
        }
    }

    /// Depth fix `k`, behind a wide gate.
    fn depth_fix(&mut self, k: usize, stats: &mut Stats) {
        let l = self.sensors.depth.unwrap();
        let mut h = SMatrix::<f64, 1, 9>::zeros();
        h[(0, 2)] = 1.0;
        if self.kf.update(
            SVector::<f64, 1>::new(l.cols[0][k]),
            h,
            SMatrix::<f64, 1, 1>::new(self.noise.depth_m.powi(2)),
            self.gate1 * 4.0,
            |_| {},
        ) == Update::Accepted
        {
            stats.depth_fixes += 1;
        }
    }
}

/// Transition of the position filter over `dt`, driven by the IMU sample `k` when there is one.
fn transition(
    dt: f64,
    imu: Option<(&Log, &Heading, usize)>,
    n: &Noise,
) -> (Mat<9>, Vector<9>, Mat<9>) {
    let mut f = Mat::<9>::identity();
    let mut u = Vector::<9>::zeros();
    let mut q = Mat::<9>::zeros();
    for i in 0..3 {
        f[(i, i + 3)] = dt;
    }
    match imu {
        Some((l, hd, k)) => {
            let psi = interp(&hd.t, &hd.psi, l.t[k]);
            let level = |x: f64| if x.is_finite() { x } else { 0.0 };
            let (phi, theta) = (level(l.cols[0][k]), level(l.cols[1][k]));
            let rot = nalgebra::Rotation3::from_euler_angles(phi, theta, psi);
            let fb = nalgebra::Vector3::new(l.cols[6][k], l.cols[7][k], l.cols[8][k]);
            let a = rot * fb + nalgebra::Vector3::new(0.0, 0.0, G);
            let rm = rot.matrix();
            for i in 0..3 {
                u[i] = 0.5 * dt * dt * a[i];
                u[i + 3] = dt * a[i];
                for j in 0..3 {
                    f[(i, 6 + j)] = -0.5 * dt * dt * rm[(i, j)];
                    f[(i + 3, 6 + j)] = -dt * rm[(i, j)];
                }
            }
            // White accelerometer noise of sigma per sample at the IMU's rate.
            let imu_dt = if l.len() > 1 {
                (l.t[l.len() - 1] - l.t[0]) / (l.len() - 1) as f64
            } else {
                0.02
            };
            let qa = n.accel_m_s2.powi(2) * imu_dt + 1e-4;
            let w = white_accel(qa, dt);
            for i in 0..3 {
                q[(i, i)] = w[0][0];
                q[(i, i + 3)] = w[0][1];
                q[(i + 3, i)] = w[1][0];
                q[(i + 3, i + 3)] = w[1][1];
                q[(6 + i, 6 + i)] = (1e-4 * G).powi(2) * dt;
            }
        }
        None => {
            // No IMU: constant velocity driven by the accelerations a pool ROV reaches (~1 m/s^2).
            let w = white_accel(1.0, dt);
            for i in 0..3 {
                q[(i, i)] = w[0][0];
                q[(i, i + 3)] = w[0][1];
                q[(i + 3, i)] = w[1][0];
                q[(i + 3, i + 3)] = w[1][1];
            }
        }
    }
    (f, u, q)
}
