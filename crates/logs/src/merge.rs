//! Messages in log-time order across chunks. Both ROS 1 bags and MCAP files store messages in
//! compressed chunks, each indexed by time; chunks may overlap in time. The reader sorts the
//! index entries by time once, then walks them, inflating each chunk when its first message is
//! due (on other threads, a few chunks ahead) and dropping it after its last.

use crate::LogError;
use std::borrow::Cow;
use std::collections::HashMap;
use std::collections::hash_map::Entry;
use std::sync::mpsc;

/// Where one message is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Slot {
    /// Log time, nanoseconds.
    pub time_ns: u64,
    /// Offset of the message's record in its chunk's inflated bytes.
    pub offset: u64,
    /// Index of the chunk in the reader's chunk table.
    pub chunk: u32,
    /// Index of the connection (ROS 1) or channel (MCAP) in the reader's table.
    pub conn: u32,
}

impl Slot {
    /// Time order; ties in file order, as `rosbag` plays them.
    pub(crate) fn key(&self) -> (u64, u32, u64) {
        (self.time_ns, self.chunk, self.offset)
    }
}

/// Where a connection's (channel's) log time steps back in file order, as when the recording
/// machine's clock was set back or a simulator restarted under `use_sim_time`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct StepBack {
    /// The connection (channel) index, as [`Slot::conn`].
    pub conn: u32,
    /// How far back, seconds.
    pub by_s: f64,
    /// The time it stepped back from, seconds after the log's first message.
    pub at_s: f64,
}

/// A step back shorter than this (clock jitter between a recorder's threads) is not said.
const STEP_BACK_SAID_S: f64 = 1e-3;

/// The largest step back of any connection's log time, walking each connection's messages in
/// file order (`chunk_pos` gives a chunk's offset in the file); `None` when every connection's
/// time only goes forward there. Reading sorts by time, so what was recorded after such a step
/// is read interleaved with what came before it.
pub(crate) fn step_back(slots: &[Slot], chunk_pos: impl Fn(u32) -> u64) -> Option<StepBack> {
    let first = slots.iter().map(|s| s.time_ns).min()?;
    let mut order: Vec<&Slot> = slots.iter().collect();
    order.sort_unstable_by_key(|s| (s.conn, chunk_pos(s.chunk), s.offset));
    let mut worst: Option<StepBack> = None;
    for w in order.windows(2) {
        let (a, b) = (w[0], w[1]);
        if a.conn != b.conn || b.time_ns >= a.time_ns {
            continue;
        }
        let by_s = crate::wire::ns_to_s(a.time_ns - b.time_ns);
        if by_s >= STEP_BACK_SAID_S && worst.is_none_or(|x| by_s > x.by_s) {
            let at_s = crate::wire::ns_to_s(a.time_ns - first);
            worst = Some(StepBack {
                conn: a.conn,
                by_s,
                at_s,
            });
        }
    }
    worst
}

impl StepBack {
    /// The sentence a run's notes give, naming the topic the connection carries.
    pub(crate) fn note(&self, topic: &str) -> String {
        format!(
            "the log's clock steps back by {:.3} s on {topic} at {:.3} s after the log's first message (a clock set back while recording, or two recordings in one file): messages are read in time order, so those recorded after the step are interleaved with those before it; if the file holds two runs, split it at the step",
            self.by_s, self.at_s
        )
    }
}

/// Inflates one chunk: borrowed when it is stored uncompressed.
pub(crate) type Load<'d> = dyn Fn(u32) -> Result<Cow<'d, [u8]>, LogError> + Sync + 'd;

/// Takes one message: its slot and the bytes of its inflated chunk.
pub(crate) type Visit<'v> = dyn FnMut(&Slot, &[u8]) -> Result<(), LogError> + 'v;

/// The slots of the topics `wanted` (indices into the `n_topics` topics the log was opened
/// with; `topic_of` gives a slot's topic), in their order. Reading with another topic list
/// than the log's own (`given` topics), or an index past them, is an error.
pub(crate) fn wanted(
    path: &std::path::Path,
    slots: &[Slot],
    (n_topics, given): (usize, usize),
    wanted: &[usize],
    topic_of: impl Fn(&Slot) -> usize,
) -> Result<Vec<Slot>, LogError> {
    if given != n_topics {
        return Err(LogError::new(
            path,
            "read with other topics than the log's own",
        ));
    }
    let want = crate::wanted_set(path, n_topics, wanted)?;
    Ok(slots
        .iter()
        .filter(|s| want[topic_of(s)])
        .copied()
        .collect())
}

/// Calls `visit` with each of `slots` (sorted) and the bytes of its chunk. Stops at the first
/// error, from `load` or from `visit`; messages before it have been visited.
pub(crate) fn run<'d>(slots: &[Slot], load: &Load<'d>, visit: &mut Visit) -> Result<(), LogError> {
    let mut left: HashMap<u32, usize> = HashMap::new();
    let mut order = Vec::new();
    for s in slots {
        let n = left.entry(s.chunk).or_insert(0);
        if *n == 0 {
            order.push(s.chunk);
        }
        *n += 1;
    }
    if order.len() <= 1 {
        return walk(slots, left, &mut order.into_iter().map(load), visit);
    }
    // Inflating (bz2 above all) is the slow part: loaders on other threads, each taking every
    // `n`-th chunk of the order and at most two chunks ahead, so the walk gets them in order.
    let n = std::thread::available_parallelism()
        .map_or(1, |n| n.get())
        .clamp(1, MAX_LOADERS);
    let n = n.min(order.len());
    std::thread::scope(|scope| {
        let mut inboxes = Vec::with_capacity(n);
        for k in 0..n {
            let (tx, rx) = mpsc::sync_channel(1);
            let mine: Vec<u32> = order.iter().skip(k).step_by(n).copied().collect();
            scope.spawn(move || {
                for c in mine {
                    let r = load(c);
                    let failed = r.is_err();
                    if tx.send(r).is_err() || failed {
                        break;
                    }
                }
            });
            inboxes.push(rx);
        }
        let mut turn = 0;
        let mut next = std::iter::from_fn(|| {
            let r = inboxes[turn % n].recv().ok();
            turn += 1;
            r
        });
        walk(slots, left, &mut next, visit)
        // Returning drops the inboxes: loaders still running stop at their next send.
    })
}

/// At most this many threads inflate chunks.
const MAX_LOADERS: usize = 4;

/// The walk itself: `loaded` yields the chunks in the order their first slot comes.
fn walk<'d>(
    slots: &[Slot],
    mut left: HashMap<u32, usize>,
    loaded: &mut dyn Iterator<Item = Result<Cow<'d, [u8]>, LogError>>,
    visit: &mut Visit,
) -> Result<(), LogError> {
    let mut live: HashMap<u32, Cow<'d, [u8]>> = HashMap::new();
    for s in slots {
        let bytes = match live.entry(s.chunk) {
            Entry::Occupied(e) => e.into_mut(),
            Entry::Vacant(e) => {
                let next = loaded.next();
                e.insert(next.expect("the loader yields one chunk per first use")?)
            }
        };
        visit(s, bytes)?;
        let n = left
            .get_mut(&s.chunk)
            .expect("every slot's chunk is counted");
        *n -= 1;
        if *n == 0 {
            live.remove(&s.chunk);
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn slot(t: u64, chunk: u32, offset: u64) -> Slot {
        Slot {
            time_ns: t,
            offset,
            chunk,
            conn: 0,
        }
    }

    /// Time that steps back in one connection's file order is found, the largest step named;
    /// chunks that overlap in time but each go forward, and jitter under a millisecond, are not.
    #[test]
    fn a_clock_stepping_back_is_found_in_file_order() {
        let ms = 1_000_000;
        let forward = [
            slot(10 * ms, 0, 0),
            slot(30 * ms, 0, 1),
            slot(20 * ms, 1, 0),
        ];
        assert_eq!(step_back(&forward[..2], |c| c as u64), None);
        // Chunk 1 sits before chunk 0 in the file: connection 0 goes 20, 10, 30 ms.
        let pos = |c: u32| if c == 1 { 0 } else { 100 };
        let found = step_back(&forward, pos).unwrap();
        assert_eq!(found.conn, 0);
        assert!((found.by_s - 0.010).abs() < 1e-12 && (found.at_s - 0.010).abs() < 1e-12);
        let mut jitter = forward.to_vec();
        jitter[2].time_ns = 10 * ms + ms / 2;
        assert_eq!(step_back(&jitter, pos), None);
        let mut both = forward.to_vec();
        both.extend([slot(9_000 * ms, 2, 0), slot(2_000 * ms, 2, 1)]);
        both[3].conn = 1;
        both[4].conn = 1;
        let worst = step_back(&both, |c| c as u64 * 10).unwrap();
        assert_eq!((worst.conn, worst.by_s), (1, 7.0));
    }

    #[test]
    fn merges_overlapping_chunks_and_stops_at_errors() {
        let chunks: Vec<Vec<u8>> = vec![vec![10, 30, 50], vec![20, 40], vec![60]];
        let mut slots = Vec::new();
        for (c, bytes) in chunks.iter().enumerate() {
            for (i, &t) in bytes.iter().enumerate() {
                slots.push(slot(t as u64, c as u32, i as u64));
            }
        }
        slots.sort_by_key(Slot::key);
        let load = |c: u32| -> Result<Cow<'_, [u8]>, LogError> {
            if c == 2 {
                return Err(LogError::new("x", "bad chunk"));
            }
            Ok(Cow::Borrowed(&chunks[c as usize][..]))
        };
        let mut seen = Vec::new();
        let r = run(&slots, &load, &mut |s, b| {
            seen.push(b[s.offset as usize]);
            Ok(())
        });
        assert_eq!(seen, [10, 20, 30, 40, 50]);
        assert_eq!(r.unwrap_err().what, "bad chunk");
    }
}
