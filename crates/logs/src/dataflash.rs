//! ArduPilot DataFlash binary logs (`.BIN`, what ArduSub writes to its SD card): topics from
//! the FMT records, messages decoded into [`Value`](crate::Value)s, damage stepped over.
//!
//! - Each message type is a topic named as FMT names it (`ATT`); where an FMTU record marks an
//!   instance field (unit `#`), the type is split into `NAME[i]` topics (`IMU[0]`, `IMU[1]`),
//!   as pymavlink/MAVExplorer name them. Every type with messages is a topic, FMT, FMTU,
//!   PARM and MSG included (so counts agree with pymavlink's).
//! - `log_time_s` is `TimeUS / 1e6` (older logs: `TimeMS / 1e3`), seconds since boot. A
//!   message without a time field (FMT, replay records, PARM and MSG of old logs) gets the
//!   time of the last timed message before it (0 before the first), which keeps messages in
//!   file order also in time and is what pymavlink does. `stamp_s` is always `None`.
//! - Damage: bytes that do not start a record of a known type are skipped up to the next
//!   `A3 95` of a known type; a last record cut by the end of the file (power lost while
//!   logging) is dropped. Both are counted and told by [`Bin::notes`]; a file of which more
//!   than half is skipped is an error, as is one without any FMT record.

mod format;
mod scan;
mod writer;

pub(crate) use format::text;
pub(crate) use writer::int;
pub use writer::{ToField, Writer};

use crate::{LogError, Message, Topic};
use format::{Def, FMT_TYPE};
use scan::{Damage, Scan};
use std::collections::HashMap;
use std::path::Path;

/// An open DataFlash log: its bytes and which topic each (type, instance) goes to.
#[derive(Debug)]
pub struct Bin {
    data: Vec<u8>,
    /// Per definition (in the order of the FMT records), the topics its messages go to.
    routes: Vec<Route>,
    notes: Vec<String>,
}

/// The topics one definition's messages go to: one, or one per instance value.
#[derive(Debug, Default, Clone)]
struct Route {
    plain: Option<usize>,
    by_instance: Vec<(Vec<u8>, usize)>,
}

impl Route {
    fn find(&self, def: &Def, body: &[u8]) -> Option<usize> {
        match def.instance {
            None => self.plain,
            Some(i) => {
                let key = def.field_bytes(body, i);
                self.by_instance.iter().find(|(k, _)| k == key).map(|x| x.1)
            }
        }
    }

    fn topics(&self) -> impl Iterator<Item = usize> + '_ {
        self.plain
            .into_iter()
            .chain(self.by_instance.iter().map(|x| x.1))
    }
}

impl Bin {
    /// Scans the whole log once: definitions, topics, counts and time spans.
    pub fn open(path: &Path, data: Vec<u8>) -> Result<(Bin, Vec<Topic>), LogError> {
        let mut idx = Index::default();
        let mut scan = Scan::new(&data);
        let mut clock = 0.0;
        let mut fmts = 0u64;
        while let Some(rec) = scan.next_rec() {
            let def = &scan.defs[rec.def];
            fmts += (def.type_id == FMT_TYPE) as u64;
            if def.broken.is_some() {
                *idx.undecoded.entry(rec.def).or_default() += 1;
                continue;
            }
            if let Some(t) = def.time_s(rec.body) {
                clock = t;
            }
            let topic = idx.topic_for(rec.def, def, rec.body);
            idx.count(topic, clock);
        }
        let (defs, damage) = (scan.defs, scan.damage);
        check(path, data.len(), fmts, &damage)?;
        let notes = notes(&damage, &defs, &idx.undecoded);
        let bin = Bin {
            data,
            routes: idx.routes,
            notes,
        };
        Ok((bin, idx.topics))
    }

    /// What was stepped over while reading: skipped damaged bytes, a record cut off at the
    /// end, FMT records that could not be used, message types that could not be decoded.
    /// Empty for an undamaged log.
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
        let def_wanted: Vec<bool> = (self.routes.iter())
            .map(|r| r.topics().any(|t| want[t]))
            .collect();
        // The same scan as `open`, so definitions come out with the same indices.
        let mut scan = Scan::new(&self.data);
        let mut clock = 0.0;
        while let Some(rec) = scan.next_rec() {
            let def = &scan.defs[rec.def];
            if def.broken.is_some() {
                continue;
            }
            if let Some(t) = def.time_s(rec.body) {
                clock = t;
            }
            if !def_wanted.get(rec.def).copied().unwrap_or(false) {
                continue;
            }
            let Some(topic) = self.routes[rec.def].find(def, rec.body) else {
                continue;
            };
            if want[topic] {
                each(&Message {
                    topic,
                    log_time_s: clock,
                    stamp_s: None,
                    value: def.decode(rec.body),
                })?;
            }
        }
        Ok(())
    }
}

/// Topics, counts and routes, built while `open` scans.
#[derive(Default)]
struct Index {
    topics: Vec<Topic>,
    routes: Vec<Route>,
    by_name: HashMap<String, usize>,
    /// Messages of types that could not be decoded, per definition.
    undecoded: HashMap<usize, u64>,
}

impl Index {
    fn topic_for(&mut self, d: usize, def: &Def, body: &[u8]) -> usize {
        if self.routes.len() <= d {
            self.routes.resize(d + 1, Route::default());
        }
        if let Some(t) = self.routes[d].find(def, body) {
            return t;
        }
        let name = match def.instance {
            None => def.name.clone(),
            Some(i) => format!(
                "{}[{}]",
                def.name,
                def.instance_label(def.field_bytes(body, i))
            ),
        };
        let t = self.new_topic(name, def);
        let route = &mut self.routes[d];
        match def.instance {
            None => route.plain = Some(t),
            Some(i) => route
                .by_instance
                .push((def.field_bytes(body, i).to_vec(), t)),
        }
        t
    }

    /// The topic `name`; a redefinition with the same layout shares it, one with another
    /// layout gets `name~2` (a schema is one per topic).
    fn new_topic(&mut self, base: String, def: &Def) -> usize {
        let mut name = base.clone();
        let mut k = 1;
        while let Some(&t) = self.by_name.get(&name) {
            if self.topics[t].schema == def.schema {
                return t;
            }
            k += 1;
            name = format!("{base}~{k}");
        }
        self.by_name.insert(name.clone(), self.topics.len());
        self.topics.push(Topic {
            name,
            type_name: def.name.clone(),
            count: 0,
            first_s: 0.0,
            last_s: 0.0,
            schema: def.schema.clone(),
        });
        self.topics.len() - 1
    }

    fn count(&mut self, t: usize, time: f64) {
        let topic = &mut self.topics[t];
        if topic.count == 0 {
            topic.first_s = time;
        }
        topic.count += 1;
        topic.last_s = time;
    }
}

/// The errors a scanned log can have: no FMT at all, or mostly damage.
fn check(path: &Path, len: usize, fmts: u64, d: &Damage) -> Result<(), LogError> {
    if fmts == 0 {
        return Err(LogError::new(
            path,
            "the log has no FMT record, so none of its messages can be decoded",
        )
        .at(0)
        .fix("the start of the log is missing or damaged: download the whole .BIN again (from the SD card, or with the ground station's log download)"));
    }
    if d.skipped > len as u64 / 2 {
        return Err(LogError::new(
            path,
            format!(
                "{} of its {len} bytes are not DataFlash records: the log is mostly damaged",
                d.skipped
            ),
        )
        .at(d.first_skip.unwrap_or(0))
        .fix(
            "download the log again (from the SD card, or with the ground station's log download)",
        ));
    }
    Ok(())
}

/// The damage a scan stepped over, in words.
fn notes(d: &Damage, defs: &[Def], undecoded: &HashMap<usize, u64>) -> Vec<String> {
    let mut out = Vec::new();
    if d.skipped > 0 {
        out.push(format!(
            "skipped {} damaged bytes in {} places (first at byte {})",
            d.skipped,
            d.runs,
            d.first_skip.unwrap_or(0)
        ));
    }
    let unknown: Vec<String> = (0..256u32)
        .filter(|&t| d.unknown_types[t as usize / 64] & (1 << (t % 64)) != 0)
        .map(|t| t.to_string())
        .collect();
    if !unknown.is_empty() {
        out.push(format!(
            "records of type {} have no FMT record and were skipped",
            unknown.join(", ")
        ));
    }
    if let Some(at) = d.cut_at {
        out.push(format!(
            "the last record (byte {at}, {} bytes) is cut off by the end of the file, as when \
             logging stopped mid-write; it was dropped",
            d.cut_bytes
        ));
    }
    if let Some((at, why)) = &d.first_bad_fmt {
        out.push(format!(
            "{} FMT records could not be used (first at byte {at}: {why})",
            d.bad_fmts
        ));
    }
    let mut broken: Vec<(&usize, &u64)> = undecoded.iter().collect();
    broken.sort();
    for (&def, n) in broken {
        let def = &defs[def];
        let why = def.broken.as_deref().unwrap_or_default();
        out.push(format!("{n} {} messages not decoded: {why}", def.name));
    }
    out
}
