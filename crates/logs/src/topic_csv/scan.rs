//! One pass over a topic file's rows at opening: how many, the last, the earliest and latest
//! time, the largest step back of its time, and the rows that repeat its header.

use super::cells;
use crate::csv_clock::{self, Clock};

/// The largest step back of a file's time from one row to the next.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Back {
    /// How far back, seconds.
    pub by_s: f64,
    /// The time it stepped back from, seconds after the file's earliest row.
    pub at_s: f64,
}

/// What one pass over a file's rows finds: how many rows, the last, the earliest and latest
/// time and the largest step back (the rows of a file whose clock was set back, or of two
/// recordings appended, are not in time order).
pub(super) struct Scan<'a> {
    pub count: usize,
    pub last: Option<&'a str>,
    pub first_s: f64,
    pub last_s: f64,
    pub back: Option<Back>,
    /// Rows that repeat the header, and the first of them (0 after the header).
    pub repeats: usize,
    pub first_repeat: usize,
}

/// A step back shorter than this (a logger's threads writing out of turn) is not said, as in
/// a bag or an MCAP file.
const STEP_BACK_SAID_S: f64 = 1e-3;

/// One pass over a file's rows (after its `header`), reading only the time cell; a row that
/// repeats the header is counted, any other whose time is not a number is left to
/// [`TopicCsv::read`], which refuses it.
pub(super) fn scan<'a>(
    rows: impl Iterator<Item = &'a str>,
    clock: &Clock,
    header: &[String],
) -> Scan<'a> {
    let (mut first_s, mut last_s) = (f64::INFINITY, f64::NEG_INFINITY);
    let (mut prev, mut worst): (Option<f64>, Option<(f64, f64)>) = (None, None);
    let (mut repeats, mut first_repeat) = (0, 0);
    let (mut count, mut last) = (0, None);
    for (k, line) in rows.enumerate() {
        (count, last) = (k + 1, Some(line));
        let t = (line.split(',').nth(clock.column))
            .and_then(|c| csv_clock::seconds(csv_clock::bare(c), clock.unit_s))
            .filter(|t| t.is_finite());
        let Some(t) = t else {
            if is_header(&cells(line), header) {
                first_repeat = if repeats == 0 { k } else { first_repeat };
                repeats += 1;
            }
            continue;
        };
        if let Some(p) = prev
            && p - t >= STEP_BACK_SAID_S
            && worst.is_none_or(|(by, _)| p - t > by)
        {
            worst = Some((p - t, p));
        }
        (first_s, last_s, prev) = (first_s.min(t), last_s.max(t), Some(t));
    }
    if prev.is_none() {
        (first_s, last_s) = (f64::NAN, f64::NAN);
    }
    let back = worst.map(|(by_s, from)| Back {
        by_s,
        at_s: from - first_s,
    });
    Scan {
        count,
        last,
        first_s,
        last_s,
        back,
        repeats,
        first_repeat,
    }
}

/// Whether a row's cells are the header's: a second recording appended to the file.
pub(super) fn is_header<S: AsRef<str>>(row: &[S], header: &[String]) -> bool {
    row.len() == header.len() && row.iter().zip(header).all(|(a, b)| a.as_ref() == b)
}
