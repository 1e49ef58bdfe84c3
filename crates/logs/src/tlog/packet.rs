//! Walks a `.tlog` record by record: an 8-byte big-endian time (µs since the Unix epoch),
//! then one MAVLink 1 or 2 packet, checksummed with its message's CRC_EXTRA.
//!
//! Packet layouts (MAVLink serialization spec): v1 `FE len seq sys comp id payload crc2`;
//! v2 `FD len incompat compat seq sys comp id(3, LE) payload crc2 [signature 13]`, the
//! signature there when `incompat & 1`. The checksum covers the bytes after the start
//! marker, up to the payload's end, then CRC_EXTRA.
//!
//! A tlog has no sync marker of its own, so after damage a record start is recognised by a
//! start marker after a time between the years 2000 and 2100.

use super::layout::{Catalog, crc};
use std::collections::BTreeMap;

/// The times a resynchronising scan accepts: 2000-01-01 to 2100-01-01, in µs.
const TIME_MIN_US: u64 = 946_684_800_000_000;
const TIME_MAX_US: u64 = 4_102_444_800_000_000;

/// What the scan had to step over.
#[derive(Debug, Clone, Default)]
pub(crate) struct Damage {
    pub skipped: u64,
    pub runs: u64,
    pub first_skip: Option<u64>,
    pub cut_at: Option<u64>,
    pub cut_bytes: u64,
    pub bad_crc: u64,
    pub first_bad_crc: Option<u64>,
    /// Packets of message ids not compiled in, per id.
    pub unknown: BTreeMap<u32, u64>,
}

/// One packet of a known message with a good checksum.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Packet<'a> {
    pub time_us: u64,
    pub sys: u8,
    pub comp: u8,
    pub msgid: u32,
    pub payload: &'a [u8],
}

/// A record's framing: its total length (time included) and header fields.
struct Frame {
    len: usize,
    /// Bytes after the start marker up to the payload's end: what the checksum covers.
    crc_span: (usize, usize),
    sys: u8,
    comp: u8,
    msgid: u32,
    payload: (usize, usize),
}

pub(crate) struct Scan<'a> {
    data: &'a [u8],
    pos: usize,
    catalog: &'a Catalog,
    resyncing: bool,
    pub damage: Damage,
}

impl<'a> Scan<'a> {
    pub(crate) fn new(data: &'a [u8], catalog: &'a Catalog) -> Scan<'a> {
        Scan {
            data,
            pos: 0,
            catalog,
            resyncing: false,
            damage: Damage::default(),
        }
    }

    /// The next good packet of a known message, or `None` at the end. Every pass of the
    /// loop moves forward at least one byte.
    pub(crate) fn next_packet(&mut self) -> Option<Packet<'a>> {
        while self.pos < self.data.len() {
            let pos = self.pos;
            let Some(fr) = frame(self.data, pos) else {
                self.not_a_record(pos);
                continue;
            };
            if self.resyncing && !(plausible(self.data, pos) && self.next_ok(pos + fr.len)) {
                self.skip_to(pos + 1);
                continue;
            }
            if let Some(p) = self.check(pos, &fr) {
                return Some(p);
            }
        }
        None
    }

    /// Bytes at `pos` that do not frame a record: a record cut by the end of the file when
    /// no record follows, else damage to skip.
    fn not_a_record(&mut self, pos: usize) {
        let starts = self
            .data
            .get(pos + 8)
            .is_none_or(|&b| b == 0xFE || b == 0xFD);
        match self.find_record(pos + 1) {
            None if starts && !self.resyncing => {
                self.damage.cut_at = Some(pos as u64);
                self.damage.cut_bytes = (self.data.len() - pos) as u64;
                self.pos = self.data.len();
            }
            None => self.skip_to(self.data.len()),
            Some(q) => self.skip_to(q),
        }
    }

    /// Checks a framed record's message id and checksum; moves past it.
    fn check(&mut self, pos: usize, fr: &Frame) -> Option<Packet<'a>> {
        let end = pos + fr.len;
        let Some(layout) = self.catalog.get(fr.msgid) else {
            *self.damage.unknown.entry(fr.msgid).or_default() += 1;
            self.accept(end);
            return None;
        };
        let sum = crc(&self.data[fr.crc_span.0..fr.crc_span.1], 0xffff);
        let sum = crc(&[layout.def.crc_extra], sum);
        let at = fr.crc_span.1;
        if sum.to_le_bytes() != self.data[at..at + 2] {
            self.damage.bad_crc += 1;
            self.damage.first_bad_crc.get_or_insert(pos as u64);
            // A bad length byte also fails the checksum: step over the packet only where
            // another record follows it, else search byte by byte.
            match self.next_ok(end) {
                true => self.accept(end),
                false => self.skip_to(pos + 1),
            }
            return None;
        }
        self.accept(end);
        Some(Packet {
            time_us: u64::from_be_bytes(self.data[pos..pos + 8].try_into().ok()?),
            sys: fr.sys,
            comp: fr.comp,
            msgid: fr.msgid,
            payload: &self.data[fr.payload.0..fr.payload.1],
        })
    }

    fn accept(&mut self, end: usize) {
        self.resyncing = false;
        self.pos = end;
    }

    /// Whether `end` is the end of the data, a record start, or too near the end to tell.
    fn next_ok(&self, end: usize) -> bool {
        end + 9 > self.data.len() || plausible(self.data, end)
    }

    fn find_record(&self, from: usize) -> Option<usize> {
        (from..self.data.len()).find(|&p| starts_record(self.data, p))
    }

    fn skip_to(&mut self, to: usize) {
        if !self.resyncing {
            self.damage.runs += 1;
            self.damage.first_skip.get_or_insert(self.pos as u64);
        }
        self.damage.skipped += (to - self.pos) as u64;
        self.resyncing = true;
        self.pos = to;
    }
}

/// Whether a whole record, with a time in range, starts at `p`.
pub(crate) fn starts_record(data: &[u8], p: usize) -> bool {
    plausible(data, p) && frame(data, p).is_some()
}

/// Whether a record could start at `p`: a start marker after a time in range.
fn plausible(data: &[u8], p: usize) -> bool {
    let (Some(t), Some(&stx)) = (data.get(p..p + 8), data.get(p + 8)) else {
        return false;
    };
    let t = u64::from_be_bytes([t[0], t[1], t[2], t[3], t[4], t[5], t[6], t[7]]);
    (stx == 0xFE || stx == 0xFD) && (TIME_MIN_US..TIME_MAX_US).contains(&t)
}

/// The record at `p` if its header is whole and the packet fits in the data.
fn frame(data: &[u8], p: usize) -> Option<Frame> {
    let h = data.get(p + 8..)?;
    let (hdr, sig, sys, comp, msgid) = match *h.first()? {
        0xFE => {
            let h = h.get(..6)?;
            (6, 0, h[3], h[4], h[5] as u32)
        }
        0xFD => {
            let h = h.get(..10)?;
            // Incompatibility flags other than "signed" mean a layout this reader cannot
            // know; the spec says to drop such packets.
            if h[2] & !1 != 0 {
                return None;
            }
            let sig = if h[2] & 1 != 0 { 13 } else { 0 };
            (
                10,
                sig,
                h[5],
                h[6],
                u32::from_le_bytes([h[7], h[8], h[9], 0]),
            )
        }
        _ => return None,
    };
    let n = h.get(1).copied()? as usize;
    let len = 8 + hdr + n + 2 + sig;
    if p + len > data.len() {
        return None;
    }
    let payload = (p + 8 + hdr, p + 8 + hdr + n);
    Some(Frame {
        len,
        crc_span: (p + 9, payload.1),
        sys,
        comp,
        msgid,
        payload,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tlog::Writer;

    const T: u64 = 1_683_220_541_000_000;

    /// Two ATTITUDE records, the first re-flagged with `incompat` (its checksum redone) and,
    /// when signed, followed by a 13-byte signature.
    fn flagged(incompat: u8) -> Vec<u8> {
        let mut w = Writer::new(true);
        w.write(T, (1, 1), "ATTITUDE", &[1.0; 7]).unwrap();
        let mut b = w.bytes().to_vec();
        b[10] = incompat;
        let n = b.len();
        let sum = crc(&[39], crc(&b[9..n - 2], 0xffff));
        b[n - 2..].copy_from_slice(&sum.to_le_bytes());
        if incompat & 1 != 0 {
            b.extend_from_slice(&[0x55; 13]);
        }
        let mut w = Writer::new(true);
        w.write(T + 1, (1, 1), "ATTITUDE", &[2.0; 7]).unwrap();
        b.extend_from_slice(w.bytes());
        b
    }

    #[test]
    fn signed_packets_are_read() {
        let cat = Catalog::new();
        let data = flagged(1);
        let mut s = Scan::new(&data, &cat);
        assert_eq!(s.next_packet().map(|p| p.time_us), Some(T));
        assert_eq!(s.next_packet().map(|p| p.time_us), Some(T + 1));
        assert!(s.next_packet().is_none());
        assert_eq!(s.damage.skipped, 0);
    }

    #[test]
    fn unknown_incompatibility_flags_drop_the_packet() {
        let cat = Catalog::new();
        let data = flagged(2);
        let mut s = Scan::new(&data, &cat);
        assert_eq!(s.next_packet().map(|p| p.time_us), Some(T + 1));
        assert!(s.next_packet().is_none());
        assert_eq!(s.damage.runs, 1);
    }
}
