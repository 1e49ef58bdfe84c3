//! Real-log timing (docs/formats.md): logs written by receive time arrive in bursts (many rows
//! within a millisecond, then a stall) and start and stop at different times. The command log
//! of a periodic controller gets a regular clock fitted to it; every log is cut to the span all
//! of them cover. Each repair is returned as a sentence for the report.

use crate::pool::import::csvlog::Log;

/// Share of intervals under 1 ms above which a log counts as written in bursts.
const BURSTY_SHARE: f64 = 0.2;
/// Longest receive latency a fitted clock may imply, s: beyond it rows were lost, not late.
const MAX_LATENCY_S: f64 = 3.0;

/// Replaces bursty receive times of a periodic log by a regular clock `t0 + k T` (every row is
/// one controller period, none lost): the lower envelope of the receive times, since a row is
/// received no earlier than it was sent and the rows released first after a stall were
/// barely delayed. Returns what was done, or None when the times were
/// regular already. When the fit would imply latencies over [`MAX_LATENCY_S`] (rows lost), the
/// receive times are kept and the note says so.
pub fn repair_command_clock(log: &mut Log) -> Option<String> {
    let n = log.len();
    if n < 10 {
        return None;
    }
    let gaps: Vec<f64> = log.t.windows(2).map(|w| w[1] - w[0]).collect();
    let tiny = gaps.iter().filter(|g| **g < 1e-3).count() as f64 / gaps.len() as f64;
    let longest = gaps.iter().copied().fold(0.0, f64::max);
    if tiny < BURSTY_SHARE {
        return None;
    }
    let mut period = (log.t[n - 1] - log.t[0]) / (n - 1) as f64;
    // The envelope's slope: through the least-delayed row of each half, twice.
    for _ in 0..2 {
        let least = |r: std::ops::Range<usize>| {
            r.min_by(|&a, &b| {
                (log.t[a] - a as f64 * period).total_cmp(&(log.t[b] - b as f64 * period))
            })
            .expect("n >= 10")
        };
        let (a, b) = (least(0..n / 2), least(n / 2..n));
        period = (log.t[b] - log.t[a]) / (b - a) as f64;
    }
    let t0 = (0..n)
        .map(|k| log.t[k] - k as f64 * period)
        .fold(f64::INFINITY, f64::min);
    let latency: Vec<f64> = (0..n)
        .map(|k| log.t[k] - (t0 + k as f64 * period))
        .collect();
    let worst = latency.iter().copied().fold(0.0, f64::max);
    let what = format!(
        "{:.0} % of its intervals are under 1 ms and the longest is {longest:.2} s (rows written by receive time, in bursts)",
        100.0 * tiny
    );
    if worst > MAX_LATENCY_S {
        return Some(format!(
            "{what}; a regular clock would put rows {worst:.1} s late, so rows were lost: the receive times are kept"
        ));
    }
    let mut sorted = latency.clone();
    sorted.sort_by(f64::total_cmp);
    for (k, t) in log.t.iter_mut().enumerate() {
        *t = t0 + k as f64 * period;
    }
    Some(format!(
        "{what}; fitted a regular {:.2} Hz command clock (receive latency median {:.0} ms, longest {:.0} ms)",
        1.0 / period,
        1e3 * sorted[n / 2],
        1e3 * worst
    ))
}

/// Cuts the command log to the span where every velocity sensor has data: the fusion has nothing
/// to say before the first sensor row or after the last. Returns what was cut, if anything.
pub fn trim_to_overlap(command: &mut Log, sensors: &[&Log]) -> Option<String> {
    if sensors.is_empty() {
        return None;
    }
    let start = sensors
        .iter()
        .map(|l| l.t[0])
        .fold(f64::NEG_INFINITY, f64::max);
    let end = sensors
        .iter()
        .map(|l| l.t[l.len() - 1])
        .fold(f64::INFINITY, f64::min);
    let log = command;
    let (first, last) = (log.t[0], log.t[log.len() - 1]);
    if start <= first && end >= last {
        return None;
    }
    let keep: Vec<usize> = (0..log.len())
        .filter(|&k| log.t[k] >= start && log.t[k] <= end)
        .collect();
    if keep.len() < 10 {
        return Some(format!(
            "the sensor logs overlap the command log only from {start:.2} to {end:.2} s ({} command rows): kept as is",
            keep.len()
        ));
    }
    log.t = keep.iter().map(|&k| log.t[k]).collect();
    for c in &mut log.cols {
        *c = keep.iter().map(|&k| c[k]).collect();
    }
    Some(format!(
        "the logs start and stop at different times: only their overlap {start:.2}-{end:.2} s is used ({:.2} s of command before it and {:.2} s after it dropped)",
        (start - first).max(0.0),
        (last - end).max(0.0)
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn log(t: Vec<f64>) -> Log {
        let n = t.len();
        Log {
            t,
            cols: vec![vec![0.0; n]],
            notes: vec![],
            present: vec![true],
        }
    }

    /// A 50 Hz controller whose rows reach the logger in bursts: every 0.5-1.5 s a stall, then
    /// the queued rows within a millisecond. The fitted clock must land within a millisecond
    /// of the true send times.
    #[test]
    fn bursty_receive_times_get_the_controller_clock_back() {
        let mut rng = crate::core::rng::Rng::new(7);
        let period = 0.02;
        let n = 3000;
        let send: Vec<f64> = (0..n).map(|k| 3.0 + k as f64 * period).collect();
        let mut recv = Vec::with_capacity(n);
        let mut release = 3.0;
        for &s in &send {
            if s > release {
                release = s + 0.3 + 1.2 * rng.uniform();
            }
            // Queued until the next release, then written 20 us apart.
            let r = release.max(s) + 2e-5 * (recv.len() % 50) as f64;
            recv.push(if recv.last().is_some_and(|p| r < *p) {
                *recv.last().unwrap()
            } else {
                r
            });
        }
        let mut l = log(recv);
        let note = repair_command_clock(&mut l).expect("bursts are repaired");
        assert!(note.contains("regular 50.00 Hz"), "{note}");
        let worst =
            l.t.iter()
                .zip(&send)
                .map(|(a, b)| (a - b).abs())
                .fold(0.0, f64::max);
        // The lower envelope is set by the rows released earliest after their send time.
        assert!(worst < 0.025, "clock off by {worst} s");
        // A regular log is left alone.
        let mut l = log(send.clone());
        assert!(repair_command_clock(&mut l).is_none());
        assert_eq!(l.t, send);
    }

    #[test]
    fn lost_rows_keep_the_receive_times() {
        // 50 Hz for 10 s, a 5 s outage in which rows are lost, then bursty again.
        let mut t: Vec<f64> = (0..500).map(|k| (k / 25) as f64 * 0.5).collect();
        t.extend((0..500).map(|k| 15.0 + (k / 25) as f64 * 0.5));
        let before = t.clone();
        let mut l = log(t);
        let note = repair_command_clock(&mut l).unwrap();
        assert!(note.contains("rows were lost"), "{note}");
        assert_eq!(l.t, before);
    }
}
