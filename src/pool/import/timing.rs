//! Real-log timing (docs/formats.md): logs written by receive time arrive in bursts (many rows
//! within a millisecond, then a stall) and start and stop at different times. The command log
//! of a periodic controller gets a regular clock fitted to it; every log is cut to the span all
//! of them cover; a sensor log's bursts are spread over the time the rows were queued. Each
//! repair is returned as a sentence for the report.

use crate::pool::import::csvlog::Log;

/// Share of intervals under 1 ms above which a log counts as written in bursts.
const BURSTY_SHARE: f64 = 0.2;
/// Share of a sensor log's intervals under 1 ms above which its rows are spread: a sensor
/// writing every few milliseconds or slower does not measure twice within one, so a few such
/// pairs already mean receive times (on the TAUV navigation logs, 8-50 % of them).
const SENSOR_BURSTY_SHARE: f64 = 0.02;
/// The mean interval a sensor log must have for its sub-millisecond intervals to count as
/// bursts, s: a kilohertz IMU's rows are a millisecond apart by design.
const SENSOR_PERIOD_S: f64 = 0.005;
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
    let (tiny, longest) = burstiness(&log.t);
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

/// The share of a log's intervals under 1 ms, and its longest interval, s.
fn burstiness(t: &[f64]) -> (f64, f64) {
    let gaps = t.windows(2).map(|w| w[1] - w[0]);
    let tiny = gaps.clone().filter(|g| *g < 1e-3).count() as f64 / (t.len() - 1).max(1) as f64;
    (tiny, gaps.fold(0.0, f64::max))
}

/// Spreads the rows of a sensor log written by receive time in bursts over the time they were
/// queued: each burst's rows (intervals under 1 ms) evenly from just after the previous
/// burst's release to its own, the last row at its release; the first burst's rows a mean row
/// period apart before it. A sensor's rows, unlike a controller's, are not periodic (a
/// navigation filter writes when a DVL ping or an AHRS update arrives), so no regular clock is
/// fitted; rows stacked within a millisecond would otherwise read as motion in microseconds.
/// The latency every row keeps (rows are received after they are measured) is not known from
/// receive times and stays. Returns what was done, or None when the log is not bursty.
pub fn spread_bursts(log: &mut Log) -> Option<String> {
    let n = log.len();
    if n < 10 {
        return None;
    }
    let (tiny, longest) = burstiness(&log.t);
    let mean_period = (log.t[n - 1] - log.t[0]) / (n - 1) as f64;
    if tiny < SENSOR_BURSTY_SHARE || mean_period < SENSOR_PERIOD_S {
        return None;
    }
    let starts: Vec<usize> = std::iter::once(0)
        .chain((1..n).filter(|&k| log.t[k] - log.t[k - 1] >= 1e-3))
        .collect();
    let release: Vec<f64> = starts.iter().map(|&s| log.t[s]).collect();
    for (j, &s) in starts.iter().enumerate() {
        let end = starts.get(j + 1).copied().unwrap_or(n);
        let k = end - s;
        let from = match j {
            0 => release[0] - k as f64 * mean_period,
            _ => release[j - 1],
        };
        for i in 0..k {
            log.t[s + i] = from + (release[j] - from) * (i + 1) as f64 / k as f64;
        }
    }
    Some(format!(
        "{:.0} % of its intervals are under 1 ms and the longest is {longest:.2} s (rows written by receive time, in bursts): each burst's {:.1} rows on average spread evenly over the time since the previous burst (the receive latency of every row stays)",
        100.0 * tiny,
        n as f64 / starts.len() as f64
    ))
}

/// Shortest stop of the command log that cuts a run, s, and in the log's median intervals.
const STALL_S: f64 = 10.0;
const STALL_INTERVALS: f64 = 100.0;

/// Cuts the command log to its longest stretch without a stop of [`STALL_S`] and
/// [`STALL_INTERVALS`] median intervals or more: a logger that stalled, a controller
/// restarted, or a clock set during the recording (a computer without a battery-backed clock
/// that synchronises mid-log jumps by days). No command is known over such a stop, and a
/// simulation held the last one across it (over a clock's jump of days it did not finish).
/// Returns what was cut, if anything.
pub fn cut_at_stops(log: &mut Log) -> Option<String> {
    let n = log.len();
    if n < 3 {
        return None;
    }
    let mut dt: Vec<f64> = log.t.windows(2).map(|w| w[1] - w[0]).collect();
    let stop = |d: f64| d >= STALL_S;
    dt.sort_by(f64::total_cmp);
    let limit = STALL_INTERVALS * dt[dt.len() / 2];
    let cuts: Vec<usize> = (1..n)
        .filter(|&k| {
            let d = log.t[k] - log.t[k - 1];
            stop(d) && d >= limit
        })
        .collect();
    if cuts.is_empty() {
        return None;
    }
    let bounds: Vec<usize> = std::iter::once(0)
        .chain(cuts.iter().copied())
        .chain([n])
        .collect();
    let (a, b) = bounds
        .windows(2)
        .map(|w| (w[0], w[1]))
        .max_by(|x, y| {
            let span = |(a, b): (usize, usize)| log.t[b - 1] - log.t[a];
            span(*x).total_cmp(&span(*y))
        })
        .expect("at least one stretch");
    let stops: Vec<String> = cuts
        .iter()
        .map(|&k| format!("{:.1} s at {:.2} s", log.t[k] - log.t[k - 1], log.t[k - 1]))
        .collect();
    let (from, to) = (log.t[a], log.t[b - 1]);
    log.keep_rows(&(a..b).collect::<Vec<_>>());
    Some(format!(
        "the command log stops for {} (a logger that stalled, or a clock set during the recording): only its longest stretch without a stop, {from:.2}-{to:.2} s, is used; to use the others, give each its own run folder with `span_s` (a log) or its own rows",
        stops.join(", ")
    ))
}

/// Keeps the rows of a sensor log within `margin_s` of the command log's span `from`-`to`:
/// after the command was cut at a stop ([`cut_at_stops`]), a sensor's rows across the stop
/// would have its smoother predict over it (days, for a clock set mid-log). Returns whether
/// rows were dropped.
pub fn keep_near(log: &mut Log, (from, to): (f64, f64), margin_s: f64) -> bool {
    let keep = |t: f64| t >= from - margin_s && t <= to + margin_s;
    if log.t.iter().all(|&t| keep(t)) {
        return false;
    }
    let rows: Vec<usize> = (0..log.len()).filter(|&k| keep(log.t[k])).collect();
    log.keep_rows(&rows);
    true
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
    log.keep_rows(&keep);
    Some(format!(
        "the logs start and stop at different times: only their overlap {start:.2}-{end:.2} s is used ({:.2} s of command before it and {:.2} s after it dropped)",
        (start - first).max(0.0),
        (last - end).max(0.0)
    ))
}

/// The median interval above which a command read from a vehicle's log (a periodic stream,
/// not a table of changes) is too coarse, s: an ROV's fastest time constants are 0.3-1 s, and a
/// change of command seen only at the next sample, up to this late, blurs what drives them.
const SLOW_COMMAND_S: f64 = 0.25;

/// A sentence when a logged command stream is slower than [`SLOW_COMMAND_S`] (median interval):
/// ArduSub's telemetry log carries `SERVO_OUTPUT_RAW` at 2 Hz unless its stream rate is raised.
pub fn slow_command_note(log: &Log) -> Option<String> {
    if log.len() < 3 {
        return None;
    }
    let m = crate::core::interp::median_step(&log.t);
    (m > SLOW_COMMAND_S).then(|| {
        format!(
            "the command is logged at {:.1} Hz (a sample every {m:.2} s, median): a change of command is seen only at the next sample, up to {m:.2} s late, which blurs dynamics of 0.3-1 s; log it faster where the vehicle is driven (a MAVLink telemetry log's SERVO_OUTPUT_RAW follows the RC channels' stream rate, `SR0_RC_CHAN`, 2 Hz by default in ArduSub)",
            1.0 / m
        )
    })
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

    /// A 20 Hz command log whose clock jumps by 11.6 days after 30 s (a computer that set its
    /// clock mid-log), then runs 50 s more: the longer stretch is kept and the stop said; a
    /// log with a 2 s pause (40 intervals) is left whole.
    #[test]
    fn a_command_log_that_stops_is_cut_to_its_longest_stretch() {
        let mut t: Vec<f64> = (0..600).map(|k| k as f64 * 0.05).collect();
        t.extend((0..1000).map(|k| 1e6 + k as f64 * 0.05));
        let mut l = log(t);
        let said = cut_at_stops(&mut l).expect("a cut");
        assert_eq!(l.len(), 1000);
        assert_eq!(l.t[0], 1e6);
        assert_eq!(l.cols[0].len(), 1000);
        assert!(said.contains("stops for 999970.1 s at 29.95 s"), "{said}");
        assert!(
            said.contains("stretch without a stop, 1000000.00-1000049.95 s"),
            "{said}"
        );
        let mut t: Vec<f64> = (0..600).map(|k| k as f64 * 0.05).collect();
        t.extend((0..600).map(|k| 32.0 + k as f64 * 0.05));
        let mut l = log(t);
        assert_eq!(cut_at_stops(&mut l), None);
        assert_eq!(l.len(), 1200);
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

    /// A navigation log measured at an irregular 5-15 Hz whose rows reach the logger in bursts
    /// (stalls of 0.3-1.3 s, then the queue within a millisecond): spread, no two rows are
    /// within a millisecond, the order is kept, and the rows sit far nearer their measured
    /// times than their receive times did.
    #[test]
    fn a_sensor_logs_bursts_are_spread_over_their_stalls() {
        let mut rng = crate::core::rng::Rng::new(3);
        let mut send = vec![1.0];
        while send.len() < 600 {
            let last = send[send.len() - 1];
            send.push(last + 1.0 / 15.0 + (1.0 / 5.0 - 1.0 / 15.0) * rng.uniform());
        }
        let mut recv: Vec<f64> = Vec::with_capacity(send.len());
        let mut release = 1.0;
        for &s in &send {
            if s > release {
                release = s + 0.3 + rng.uniform();
            }
            let r = release.max(s) + 2e-5 * (recv.len() % 40) as f64;
            recv.push(recv.last().map_or(r, |p| p.max(r)));
        }
        let late = |t: &[f64]| {
            t.iter().zip(&send).map(|(a, b)| (a - b).abs()).sum::<f64>() / send.len() as f64
        };
        let before = late(&recv);
        let mut l = log(recv);
        let note = spread_bursts(&mut l).expect("bursts are spread");
        assert!(note.contains("spread evenly"), "{note}");
        assert!(
            l.t.windows(2).all(|w| w[1] - w[0] >= 1e-3),
            "rows still stacked"
        );
        let after = late(&l.t);
        assert!(
            after < 0.5 * before,
            "mean error {after} s, receive times {before} s"
        );
        // A regular log, and a kilohertz IMU, are left alone.
        for period in [0.1, 0.001] {
            let t: Vec<f64> = (0..500).map(|k| k as f64 * period).collect();
            let mut l = log(t.clone());
            assert!(spread_bursts(&mut l).is_none());
            assert_eq!(l.t, t);
        }
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

    /// A 2 Hz or 3.3 Hz command stream is said, with its rate; a 5 Hz one (SMaRC's binned
    /// runs, 6.4 Hz on average) is not.
    #[test]
    fn a_slow_command_stream_is_said() {
        let log = |dt: f64| Log {
            t: (0..40).map(|k| k as f64 * dt).collect(),
            cols: vec![vec![0.0; 40]],
            notes: Vec::new(),
            present: vec![true],
        };
        let note = slow_command_note(&log(0.5)).expect("2 Hz is slow");
        assert!(
            note.starts_with("the command is logged at 2.0 Hz (a sample every 0.50 s"),
            "{note}"
        );
        assert!(slow_command_note(&log(0.3)).is_some());
        assert_eq!(slow_command_note(&log(0.2)), None);
        assert_eq!(slow_command_note(&log(0.01)), None);
    }
}
