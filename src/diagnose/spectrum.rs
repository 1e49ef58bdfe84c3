//! Periodograms pooled over runs: the lines of a residual that discovery fits as sines, and
//! the test that a held-out residual has a line no command explains (then it is never
//! "within noise", [`super::verdict`]).

use super::Run;
use crate::diagnose::SLOTS;
use std::cell::OnceCell;

/// A periodogram value this many times its neighbours' median is a line (the discovery's
/// threshold for a sine).
pub const LINE_RATIO: f64 = 25.0;

/// The periodogram at frequencies `f` (Hz) of each segment's `(times, values)`, its mean
/// removed, summed over the segments.
pub fn pooled(segments: &[(Vec<f64>, Vec<f64>)], f: &[f64]) -> Vec<f64> {
    let mut p = vec![0.0; f.len()];
    for (times, y) in segments {
        let mean = y.iter().sum::<f64>() / y.len().max(1) as f64;
        for (pi, &fi) in f.iter().enumerate() {
            let (mut re, mut im) = (0.0, 0.0);
            for (yq, tq) in y.iter().zip(times) {
                let (s, c) = (std::f64::consts::TAU * fi * tq).sin_cos();
                re += (yq - mean) * c;
                im += (yq - mean) * s;
            }
            p[pi] += (re * re + im * im) / y.len() as f64;
        }
    }
    p
}

/// The lines of held-out residuals against the runs' commands, on one frequency grid
/// (0.05-2 Hz, a quarter of the longest run's resolution); the commands' periodograms are
/// computed once, when a residual first has a line.
pub struct Lines<'a> {
    runs: &'a [Run],
    df: f64,
    grid: Vec<f64>,
    commands: OnceCell<Vec<Vec<f64>>>,
}

impl<'a> Lines<'a> {
    pub fn new(runs: &'a [Run]) -> Lines<'a> {
        let span = runs
            .iter()
            .map(|r| r.t.last().unwrap_or(&0.0) - r.t.first().unwrap_or(&0.0))
            .fold(1.0, f64::max);
        let df = 0.25 / span;
        let grid = (0..)
            .map(|i| 0.05 + i as f64 * df)
            .take_while(|f| *f <= 2.0)
            .collect();
        Lines {
            runs,
            df,
            grid,
            commands: OnceCell::new(),
        }
    }

    /// The frequency (Hz) of a line no command has in DOF `j`'s residual `res` (per run, per
    /// DOF), pooled over the runs: its largest periodogram value over [`LINE_RATIO`] times its
    /// neighbours' median ([`local_ratio`]), at a frequency where no command's periodogram
    /// stands out the same way (a manoeuvre repeated at a frequency leaves the model's error
    /// at that frequency: that is the model's response, not a force of its own).
    pub fn uncommanded(&self, res: &[[Vec<f64>; SLOTS]], j: usize) -> Option<f64> {
        let p = self.periodogram(|r, k| res[r][j].get(k).copied().unwrap_or(f64::NAN));
        let peak = argmax(&p)?;
        if local_ratio(&p, peak, self.df) <= LINE_RATIO {
            return None;
        }
        let commands = self.commands.get_or_init(|| {
            (0..SLOTS)
                .map(|q| self.periodogram(|r, k| self.runs[r].cmd[k][q]))
                .collect()
        });
        let commanded = commands
            .iter()
            .any(|pc| local_ratio(pc, peak, self.df) > LINE_RATIO);
        (!commanded).then(|| self.grid[peak])
    }

    /// The pooled periodogram of the signal `x(run, sample)`, NaN samples left out, runs
    /// with fewer than 20 samples too.
    fn periodogram(&self, x: impl Fn(usize, usize) -> f64) -> Vec<f64> {
        let segments: Vec<(Vec<f64>, Vec<f64>)> = self
            .runs
            .iter()
            .enumerate()
            .map(|(ri, r)| {
                (0..r.t.len())
                    .map(|k| (r.t[k], x(ri, k)))
                    .filter(|(_, v)| v.is_finite())
                    .unzip()
            })
            .filter(|(t, _): &(Vec<f64>, Vec<f64>)| t.len() >= 20)
            .collect();
        pooled(&segments, &self.grid)
    }
}

/// The periodogram `p` (bins `df` apart) at bin `at` (or a bin beside it) over its median
/// around it, 0.15 Hz either side with the line's own lobe (0.02 Hz either side) left out:
/// a residual's errors are coloured, so low frequencies stand above the median of the whole
/// band without any line, but not above their neighbours.
fn local_ratio(p: &[f64], at: usize, df: f64) -> f64 {
    let (lobe, wide) = ((0.02 / df).ceil() as usize, (0.15 / df).ceil() as usize);
    let mut around: Vec<f64> = (at.saturating_sub(wide)..(at + wide + 1).min(p.len()))
        .filter(|&i| i.abs_diff(at) > lobe)
        .map(|i| p[i])
        .collect();
    around.sort_by(f64::total_cmp);
    let median = around.get(around.len() / 2).copied().unwrap_or(0.0);
    let top = (at.saturating_sub(1)..=(at + 1).min(p.len() - 1))
        .map(|i| p[i])
        .fold(0.0, f64::max);
    top / median.max(1e-300)
}

/// The index of the largest value.
fn argmax(p: &[f64]) -> Option<usize> {
    p.iter()
        .enumerate()
        .max_by(|a, b| a.1.total_cmp(b.1))
        .map(|(i, _)| i)
}
