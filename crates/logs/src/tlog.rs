//! MAVLink telemetry logs (`.tlog`, what QGroundControl and MAVProxy record): each record
//! is the time it was received (µs since the Unix epoch, big-endian) and one MAVLink packet.
//!
//! - MAVLink is not self-describing: the messages ArduSub users need are compiled in
//!   (`defs.rs`); packets of other message ids are counted and skipped, as are packets whose
//!   checksum (with the message's CRC_EXTRA) is wrong.
//! - A topic is a message name (`ATTITUDE`); where more than one system/component sends the
//!   same message, one topic per sender, `NAME[sys:comp]` (`HEARTBEAT[1:1]`).
//! - `log_time_s` is the record's receive time in seconds since the Unix epoch; `stamp_s` is
//!   `None` (the messages' own `time_boot_ms` are fields).
//! - Damage is stepped over as in DataFlash logs and told by [`Tlog::notes`]; a file whose
//!   first record does not parse, or that is mostly damaged, is an error.

mod defs;
mod layout;
mod packet;
mod writer;

pub use writer::Writer;

use crate::{LogError, Message, Topic};
use layout::Catalog;
use packet::{Damage, Scan};
use std::collections::HashMap;
use std::path::Path;

/// A message from one sender: (message id, system id, component id).
type Key = (u32, u8, u8);

/// An open tlog: its bytes, the compiled-in layouts and which topic each sender goes to.
#[derive(Debug)]
pub struct Tlog {
    data: Vec<u8>,
    catalog: Catalog,
    routes: HashMap<Key, usize>,
    notes: Vec<String>,
}

/// Counts per sender while scanning: (count, first time, last time), in order first seen.
struct Seen {
    keys: Vec<Key>,
    stats: HashMap<Key, (u64, f64, f64)>,
}

impl Tlog {
    /// Scans the whole log once: senders, counts and time spans.
    pub fn open(path: &Path, data: Vec<u8>) -> Result<(Tlog, Vec<Topic>), LogError> {
        if !packet::starts_record(&data, 0) {
            return Err(LogError::new(
                path,
                "not a MAVLink telemetry log: the first record is not a time (µs since 1970) \
                 followed by a whole MAVLink packet",
            )
            .at(0)
            .fix(
                "give a .tlog as QGroundControl or MAVProxy record it, or the autopilot's .BIN log",
            ));
        }
        let catalog = Catalog::new();
        let mut seen = Seen {
            keys: Vec::new(),
            stats: HashMap::new(),
        };
        let mut scan = Scan::new(&data, &catalog);
        while let Some(p) = scan.next_packet() {
            let key = (p.msgid, p.sys, p.comp);
            let t = p.time_us as f64 / 1e6;
            let s = seen.stats.entry(key).or_insert_with(|| {
                seen.keys.push(key);
                (0, t, t)
            });
            s.0 += 1;
            s.2 = t;
        }
        let damage = scan.damage;
        check(path, data.len(), &damage)?;
        let (topics, routes) = topics(&catalog, &seen);
        let notes = notes(&damage);
        let tlog = Tlog {
            data,
            catalog,
            routes,
            notes,
        };
        Ok((tlog, topics))
    }

    /// What was stepped over: damaged bytes, a record cut at the end, packets with a bad
    /// checksum, packets of messages not compiled in. Empty for a clean log.
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
        let mut scan = Scan::new(&self.data, &self.catalog);
        while let Some(p) = scan.next_packet() {
            let Some(&topic) = self.routes.get(&(p.msgid, p.sys, p.comp)) else {
                continue;
            };
            let Some(layout) = self.catalog.get(p.msgid).filter(|_| want[topic]) else {
                continue;
            };
            each(&Message {
                topic,
                log_time_s: p.time_us as f64 / 1e6,
                stamp_s: None,
                value: layout.decode(p.payload),
            })?;
        }
        Ok(())
    }
}

/// One topic per message, or per sender where a message has several.
fn topics(catalog: &Catalog, seen: &Seen) -> (Vec<Topic>, HashMap<Key, usize>) {
    let mut senders: HashMap<u32, usize> = HashMap::new();
    for k in &seen.keys {
        *senders.entry(k.0).or_default() += 1;
    }
    let mut topics = Vec::new();
    let mut routes = HashMap::new();
    for key in &seen.keys {
        let (Some(layout), Some(&(count, first_s, last_s))) =
            (catalog.get(key.0), seen.stats.get(key))
        else {
            continue;
        };
        let name = layout.def.name;
        routes.insert(*key, topics.len());
        topics.push(Topic {
            name: match senders.get(&key.0) {
                Some(1) => name.to_string(),
                _ => format!("{name}[{}:{}]", key.1, key.2),
            },
            type_name: name.to_string(),
            count,
            first_s,
            last_s,
            schema: layout.schema.clone(),
        });
    }
    (topics, routes)
}

/// A log of which more than half is damage is not worth reading.
fn check(path: &Path, len: usize, d: &Damage) -> Result<(), LogError> {
    if d.skipped > len as u64 / 2 {
        return Err(LogError::new(
            path,
            format!(
                "{} of its {len} bytes are not tlog records: the log is mostly damaged",
                d.skipped
            ),
        )
        .at(d.first_skip.unwrap_or(0))
        .fix("record the telemetry again, or read the autopilot's own .BIN log of the dive"));
    }
    Ok(())
}

fn notes(d: &Damage) -> Vec<String> {
    let mut out = Vec::new();
    if d.skipped > 0 {
        out.push(format!(
            "skipped {} damaged bytes in {} places (first at byte {})",
            d.skipped,
            d.runs,
            d.first_skip.unwrap_or(0)
        ));
    }
    if let Some(at) = d.cut_at {
        out.push(format!(
            "the last record (byte {at}, {} bytes) is cut off by the end of the file; it was dropped",
            d.cut_bytes
        ));
    }
    if let Some(at) = d.first_bad_crc {
        out.push(format!(
            "{} packets with a bad checksum were skipped (first at byte {at})",
            d.bad_crc
        ));
    }
    if !d.unknown.is_empty() {
        let n: u64 = d.unknown.values().sum();
        let ids: Vec<String> = d.unknown.keys().take(12).map(|k| k.to_string()).collect();
        let more = if d.unknown.len() > 12 { ", ..." } else { "" };
        out.push(format!(
            "{n} packets of {} message types not compiled in were skipped (ids {}{more})",
            d.unknown.len(),
            ids.join(", ")
        ));
    }
    out
}
