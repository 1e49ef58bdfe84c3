//! PX4 ULog files (`.ulg`, what PX4 writes to its SD card): topics from the subscriptions,
//! messages decoded through their `F` formats, damage stepped over.
//!
//! - Each logged uORB topic is a topic named as PX4 names it (`vehicle_local_position`); a
//!   second or later instance of a topic (`multi_id` 1, 2, ...) is `name[1]`, `name[2]`, as
//!   `ulog2csv` numbers its files (`_1`, `_2`). Only topics with messages are listed, as pyulog
//!   lists them.
//! - `log_time_s` is the message's own `timestamp` (microseconds since the autopilot booted)
//!   / 1e6; a message without one, or with a zero one (a topic never published), takes the
//!   time of the message before it; one stamped before the logging started (a topic's last
//!   value, written when the logger subscribed) takes the start (the header's time).
//!   `stamp_s` is always `None`.
//! - Padding the logger leaves off the end of a message is read as zeros. Data appended after
//!   the log was closed (the `B` record's appended offsets) is read where it starts.
//! - Damage: a record of unknown type is skipped up to the next sync marker (`S` record); a
//!   last record cut by the end of the file is dropped; both are counted in [`Ulog::notes`],
//!   with the logger's own dropouts (`O` records). A file of which more than half is skipped
//!   is an error.
//!
//! Source: PX4's "ULog File Format" (docs.px4.io); counts and values are checked against
//! pyulog on its own BSD-licensed test logs (`tests/ulog.rs`).

mod layout;

use crate::{LogError, Message, Topic};
use layout::Plan;
use std::collections::HashMap;
use std::path::Path;

/// The first bytes of a ULog file (then its version and its start time).
pub const MAGIC: &[u8] = b"ULog\x01\x12\x35";
/// The sync marker's payload (`S` record).
const SYNC: [u8; 8] = [0x2F, 0x73, 0x13, 0x20, 0x25, 0x0C, 0xBB, 0x12];
/// The record types of the format: flag bits, format, info, multi info, parameter, default
/// parameter, subscription, unsubscription, data, logged string, tagged string, sync, dropout.
const KINDS: &[u8] = b"BFIMPQARDLCSO";
/// The header: magic (7), version (1), start time (8).
const HEADER: usize = 16;

/// An open ULog file: its bytes, and each topic's decoding plan.
#[derive(Debug)]
pub struct Ulog {
    data: Vec<u8>,
    /// (format name, multi_id) -> topic.
    keys: HashMap<(String, u8), usize>,
    plans: Vec<Plan>,
    notes: Vec<String>,
}

/// What a scan of the records stepped over.
#[derive(Debug, Default)]
struct Damage {
    skipped: u64,
    runs: u64,
    first_skip: Option<usize>,
    cut: Option<(usize, usize)>,
    dropouts: u64,
    dropped_ms: u64,
}

/// One record: its type and body (after the 3-byte header).
struct Rec<'a> {
    kind: u8,
    body: &'a [u8],
}

/// The records of a file in order, with appended data followed and damage stepped over.
struct Scan<'a> {
    data: &'a [u8],
    pos: usize,
    appended: Vec<usize>,
    damage: Damage,
}

impl<'a> Scan<'a> {
    fn new(data: &'a [u8]) -> Scan<'a> {
        Scan {
            data,
            pos: HEADER.min(data.len()),
            appended: Vec::new(),
            damage: Damage::default(),
        }
    }

    fn next_rec(&mut self) -> Option<Rec<'a>> {
        let d = self.data;
        loop {
            if self.pos + 3 > d.len() {
                if self.pos < d.len() {
                    self.damage.cut = Some((self.pos, d.len() - self.pos));
                    self.pos = d.len();
                }
                return None;
            }
            let size = u16::from_le_bytes([d[self.pos], d[self.pos + 1]]) as usize;
            let kind = d[self.pos + 2];
            let end = self.pos + 3 + size;
            // The main data stops where the appended data starts (a record may be cut there).
            if let Some(&a) = self.appended.first()
                && (self.pos >= a || end > a)
            {
                self.pos = self.pos.max(a);
                self.appended.remove(0);
                continue;
            }
            if !KINDS.contains(&kind) {
                self.resync();
                continue;
            }
            if end > d.len() {
                self.damage.cut = Some((self.pos, d.len() - self.pos));
                self.pos = d.len();
                return None;
            }
            let body = &d[self.pos + 3..end];
            self.pos = end;
            if kind == b'B' {
                self.appended = appended_offsets(body, d.len());
            } else if kind == b'O' && body.len() >= 2 {
                self.damage.dropouts += 1;
                self.damage.dropped_ms += u16::from_le_bytes([body[0], body[1]]) as u64;
            }
            return Some(Rec { kind, body });
        }
    }

    /// Skips to the next sync record (or the end), counting the bytes skipped.
    fn resync(&mut self) {
        let d = self.data;
        let from = self.pos;
        let found = (d[from + 1..].windows(SYNC.len()))
            .position(|w| w == SYNC)
            .map(|k| from + 1 + k)
            .filter(|&m| m >= from + 3 && d[m - 1] == b'S');
        self.pos = found.map_or(d.len(), |m| m - 3);
        self.damage.skipped += (self.pos - from) as u64;
        self.damage.runs += 1;
        self.damage.first_skip.get_or_insert(from);
    }
}

/// The `B` record's appended-data offsets, when its incompatible flag says there are some.
fn appended_offsets(body: &[u8], len: usize) -> Vec<usize> {
    if body.len() < 40 || body[8] & 1 == 0 {
        return Vec::new();
    }
    (0..3)
        .map(|k| u64::from_le_bytes(body[16 + 8 * k..24 + 8 * k].try_into().unwrap()) as usize)
        .filter(|&o| o > 0 && o < len)
        .collect()
}

/// Topics and plans, built while `open` scans.
#[derive(Default)]
struct Index {
    formats: HashMap<String, Vec<(String, String)>>,
    /// msg_id -> (format name, multi_id), as subscribed.
    subs: HashMap<u16, (String, u8)>,
    keys: HashMap<(String, u8), usize>,
    topics: Vec<Topic>,
    plans: Vec<Plan>,
    /// Formats that could not be compiled: why, and how many messages were not decoded.
    broken: HashMap<String, (String, u64)>,
    bad_formats: Vec<String>,
    short: u64,
}

impl Ulog {
    /// Scans the whole file once: formats, subscriptions, topics, counts and time spans.
    pub fn open(path: &Path, data: Vec<u8>) -> Result<(Ulog, Vec<Topic>), LogError> {
        if !data.starts_with(MAGIC) || data.len() < HEADER {
            return Err(LogError::new(path, "not a ULog file (no ULog header)")
                .at(0)
                .fix("give the .ulg file PX4 wrote"));
        }
        let mut idx = Index::default();
        let mut scan = Scan::new(&data);
        let start = start_s(&data);
        let mut clock = start;
        while let Some(rec) = scan.next_rec() {
            match rec.kind {
                b'F' => idx.format(rec.body),
                b'A' => idx.subscribe(rec.body),
                b'R' if rec.body.len() >= 2 => {
                    idx.subs
                        .remove(&u16::from_le_bytes([rec.body[0], rec.body[1]]));
                }
                b'D' => idx.data(rec.body, start, &mut clock),
                _ => {}
            }
        }
        let damage = scan.damage;
        if damage.skipped > data.len() as u64 / 2 {
            return Err(LogError::new(
                path,
                format!(
                    "{} of its {} bytes are not ULog records: the file is mostly damaged",
                    damage.skipped,
                    data.len()
                ),
            )
            .at(damage.first_skip.unwrap_or(0) as u64)
            .fix("copy the .ulg from the SD card again"));
        }
        let notes = notes(&damage, &idx);
        let ulog = Ulog {
            data,
            keys: idx.keys,
            plans: idx.plans,
            notes,
        };
        Ok((ulog, idx.topics))
    }

    /// What was stepped over while reading, one sentence each; empty for an undamaged log.
    pub fn notes(&self) -> Vec<String> {
        self.notes.clone()
    }

    /// Calls `each` with every message of the `wanted` topics, in file order.
    pub fn read(
        &self,
        path: &Path,
        topics: &[Topic],
        wanted: &[usize],
        each: &mut dyn FnMut(&Message) -> Result<(), LogError>,
    ) -> Result<(), LogError> {
        let want = crate::wanted_set(path, topics.len(), wanted)?;
        let mut subs: HashMap<u16, usize> = HashMap::new();
        let mut scan = Scan::new(&self.data);
        let start = start_s(&self.data);
        let mut clock = start;
        while let Some(rec) = scan.next_rec() {
            match rec.kind {
                b'A' => {
                    if let Some((id, name, multi)) = subscription(rec.body) {
                        match self.keys.get(&(name, multi)) {
                            Some(&t) => subs.insert(id, t),
                            None => subs.remove(&id),
                        };
                    }
                }
                b'R' if rec.body.len() >= 2 => {
                    subs.remove(&u16::from_le_bytes([rec.body[0], rec.body[1]]));
                }
                b'D' if rec.body.len() >= 2 => {
                    let id = u16::from_le_bytes([rec.body[0], rec.body[1]]);
                    let Some(&t) = subs.get(&id) else { continue };
                    let plan = &self.plans[t];
                    let Some(bytes) = padded(plan, &rec.body[2..]) else {
                        continue;
                    };
                    clock = time_of(plan, &bytes).map_or(clock, |x| x.max(start));
                    if want[t] {
                        each(&Message {
                            topic: t,
                            log_time_s: clock,
                            stamp_s: None,
                            value: plan.decode(&bytes),
                        })?;
                    }
                }
                _ => {}
            }
        }
        Ok(())
    }
}

impl Index {
    fn format(&mut self, body: &[u8]) {
        match layout::parse(&String::from_utf8_lossy(body)) {
            Ok((name, fields)) => {
                self.formats.insert(name, fields);
            }
            Err(e) => self.bad_formats.push(e),
        }
    }

    fn subscribe(&mut self, body: &[u8]) {
        if let Some((id, name, multi)) = subscription(body) {
            self.subs.insert(id, (name, multi));
        }
    }

    fn data(&mut self, body: &[u8], start: f64, clock: &mut f64) {
        if body.len() < 2 {
            return;
        }
        let id = u16::from_le_bytes([body[0], body[1]]);
        let Some(key) = self.subs.get(&id).cloned() else {
            return;
        };
        let Some(t) = self.topic(&key) else { return };
        let Some(bytes) = padded(&self.plans[t], &body[2..]) else {
            self.short += 1;
            return;
        };
        *clock = time_of(&self.plans[t], &bytes).map_or(*clock, |x| x.max(start));
        let topic = &mut self.topics[t];
        if topic.count == 0 {
            topic.first_s = *clock;
        }
        topic.count += 1;
        topic.last_s = *clock;
    }

    /// The topic of subscription `key`, made at its first message; `None` when its format
    /// cannot be compiled (counted).
    fn topic(&mut self, key: &(String, u8)) -> Option<usize> {
        if let Some(&t) = self.keys.get(key) {
            return Some(t);
        }
        let (name, multi) = key;
        let plan = match layout::compile(name, &self.formats) {
            Ok(p) => p,
            Err(why) => {
                self.broken.entry(name.clone()).or_insert((why, 0)).1 += 1;
                return None;
            }
        };
        self.topics.push(Topic {
            name: match multi {
                0 => name.clone(),
                k => format!("{name}[{k}]"),
            },
            type_name: name.clone(),
            count: 0,
            first_s: 0.0,
            last_s: 0.0,
            schema: plan.schema(),
        });
        self.plans.push(plan);
        self.keys.insert(key.clone(), self.topics.len() - 1);
        Some(self.topics.len() - 1)
    }
}

/// An `A` record: msg_id, format name, multi_id.
fn subscription(body: &[u8]) -> Option<(u16, String, u8)> {
    if body.len() < 4 {
        return None;
    }
    let id = u16::from_le_bytes([body[1], body[2]]);
    let name = String::from_utf8_lossy(&body[3..])
        .trim_end_matches('\0')
        .to_string();
    Some((id, name, body[0]))
}

/// A data record's bytes, the trailing padding the logger leaves off put back as zeros;
/// `None` when shorter than that.
fn padded<'b>(plan: &Plan, b: &'b [u8]) -> Option<std::borrow::Cow<'b, [u8]>> {
    let size = plan.size();
    if b.len() >= size {
        return Some(std::borrow::Cow::Borrowed(b));
    }
    if b.len() + plan.trailing_padding() < size {
        return None;
    }
    let mut v = b.to_vec();
    v.resize(size, 0);
    Some(std::borrow::Cow::Owned(v))
}

/// When the logging started (the header's time), seconds since boot.
fn start_s(data: &[u8]) -> f64 {
    data.get(8..16).map_or(0.0, |b| {
        u64::from_le_bytes(b.try_into().unwrap()) as f64 / 1e6
    })
}

/// The message's `timestamp` in seconds, when it has a non-zero one.
fn time_of(plan: &Plan, b: &[u8]) -> Option<f64> {
    let at = plan.u64_field("timestamp")?;
    let us = u64::from_le_bytes(b[at..at + 8].try_into().ok()?);
    (us > 0).then(|| us as f64 / 1e6)
}

/// The damage and the undecodable messages, in words.
fn notes(d: &Damage, idx: &Index) -> Vec<String> {
    let mut out = Vec::new();
    if d.skipped > 0 {
        out.push(format!(
            "skipped {} damaged bytes in {} places (first at byte {})",
            d.skipped,
            d.runs,
            d.first_skip.unwrap_or(0)
        ));
    }
    if let Some((at, n)) = d.cut {
        out.push(format!(
            "the last record (byte {at}, {n} bytes) is cut off by the end of the file, as when \
             logging stopped mid-write; it was dropped"
        ));
    }
    if d.dropouts > 0 {
        out.push(format!(
            "the logger dropped messages {} times ({} ms in all: its buffer was full)",
            d.dropouts, d.dropped_ms
        ));
    }
    if let Some(first) = idx.bad_formats.first() {
        let n = idx.bad_formats.len();
        out.push(format!(
            "{n} format records could not be read (first: {first})"
        ));
    }
    let mut broken: Vec<_> = idx.broken.iter().collect();
    broken.sort();
    for (name, (why, n)) in broken {
        out.push(format!("{n} {name} messages not decoded: {why}"));
    }
    if idx.short > 0 {
        out.push(format!(
            "{} messages shorter than their format were not decoded",
            idx.short
        ));
    }
    out
}
