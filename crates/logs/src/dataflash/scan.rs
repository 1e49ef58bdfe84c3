//! Walks a DataFlash log record by record, learning FMT/FMTU records as it goes and
//! resynchronising over damage the way ArduPilot's readers do.
//!
//! A record is `A3 95 type payload`, its length fixed by the type's FMT record
//! (`LogStructure.h`). Where bytes do not start a record of a known type they are skipped up
//! to the next `A3 95` whose type is known (pymavlink `DFReader_binary._parse_next`). While
//! resynchronising, a candidate must also be followed by another `A3 95` (or the end of the
//! file), which keeps a stray `A3 95` inside damaged data from being taken for a record.

use super::format::{Def, FMT_LEN, FMT_TYPE, HEAD, Ty, parse_fmt, text};

/// What the scan had to step over.
#[derive(Debug, Clone, Default)]
pub(crate) struct Damage {
    /// Bytes that were not part of any record, and in how many places.
    pub skipped: u64,
    pub runs: u64,
    pub first_skip: Option<u64>,
    /// A last record cut off by the end of the file: its offset and the bytes dropped.
    pub cut_at: Option<u64>,
    pub cut_bytes: u64,
    /// Record types met (after `A3 95`) that no FMT record had defined, as a bit set.
    pub unknown_types: [u64; 4],
    /// FMT records that could not be used, and the first one's offset and reason.
    pub bad_fmts: u64,
    pub first_bad_fmt: Option<(u64, String)>,
}

/// One record: which definition (index into `Scan::defs`) frames it, and its payload (the
/// bytes after the 3-byte header).
#[derive(Debug, Clone, Copy)]
pub(crate) struct Rec<'a> {
    pub def: usize,
    pub body: &'a [u8],
}

pub(crate) struct Scan<'a> {
    data: &'a [u8],
    pos: usize,
    /// Every definition in the order the FMT records came; a redefinition adds one.
    pub defs: Vec<Def>,
    /// The definition in force for each record type.
    current: [Option<u32>; 256],
    fmtu: Option<u8>,
    resyncing: bool,
    pub damage: Damage,
}

impl<'a> Scan<'a> {
    pub(crate) fn new(data: &'a [u8]) -> Scan<'a> {
        let mut current = [None; 256];
        current[FMT_TYPE as usize] = Some(0);
        Scan {
            data,
            pos: 0,
            defs: vec![Def::fmt()],
            current,
            fmtu: None,
            resyncing: false,
            damage: Damage::default(),
        }
    }

    /// The next record, or `None` at the end of the data. Every pass of the loop moves
    /// forward by at least one byte, so the scan ends on any input.
    pub(crate) fn next_rec(&mut self) -> Option<Rec<'a>> {
        loop {
            let pos = self.pos;
            if self.data.len() - pos < 3 {
                self.tail(pos);
                return None;
            }
            let Some((def, len)) = self.record_at(pos) else {
                self.note_unknown(pos);
                let next = self.next_head(pos + 1);
                self.skip_to(next);
                continue;
            };
            let end = pos + len;
            if end > self.data.len() {
                match self.find_record(pos + 1) {
                    Some(q) => self.skip_to(q),
                    None => {
                        self.cut(pos);
                        return None;
                    }
                }
                continue;
            }
            if self.resyncing && !self.head_or_end(end) {
                self.skip_to(pos + 1);
                continue;
            }
            self.resyncing = false;
            self.pos = end;
            let body = &self.data[pos + 3..end];
            self.learn(def, pos, body);
            return Some(Rec { def, body });
        }
    }

    /// The definition and length of a record of known type starting at `pos`.
    fn record_at(&self, pos: usize) -> Option<(usize, usize)> {
        let h = self.data.get(pos..pos + 3)?;
        if h[..2] != HEAD {
            return None;
        }
        let def = self.current[h[2] as usize]? as usize;
        Some((def, self.defs[def].len))
    }

    /// The next `0xA3` at or after `from` (the end of the data when there is none).
    fn next_head(&self, from: usize) -> usize {
        let from = from.min(self.data.len());
        let rest = &self.data[from..];
        from + rest
            .iter()
            .position(|&b| b == HEAD[0])
            .unwrap_or(rest.len())
    }

    /// The next record start of known type at or after `from`.
    fn find_record(&self, from: usize) -> Option<usize> {
        let mut p = self.next_head(from);
        while p < self.data.len() {
            if self.record_at(p).is_some() {
                return Some(p);
            }
            p = self.next_head(p + 1);
        }
        None
    }

    /// Whether `end` is the end of the data or the start of another record (`A3 95`, cut or not).
    fn head_or_end(&self, end: usize) -> bool {
        let r = &self.data[end..];
        HEAD.starts_with(&r[..r.len().min(2)])
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

    fn note_unknown(&mut self, pos: usize) {
        if let Some(h) = self.data.get(pos..pos + 3)
            && h[..2] == HEAD
        {
            self.damage.unknown_types[h[2] as usize / 64] |= 1 << (h[2] % 64);
        }
    }

    /// Fewer than 3 bytes left: a cut header if they are its start, else skipped bytes.
    fn tail(&mut self, pos: usize) {
        let r = &self.data[pos..];
        if r.is_empty() {
            return;
        }
        if HEAD.starts_with(r) && !self.resyncing {
            self.cut(pos);
        } else {
            self.skip_to(self.data.len());
        }
    }

    fn cut(&mut self, pos: usize) {
        self.damage.cut_at = Some(pos as u64);
        self.damage.cut_bytes = (self.data.len() - pos) as u64;
        self.pos = self.data.len();
    }

    /// Takes in what FMT and FMTU records say, before the record is handed out, so that a
    /// second scan of the same bytes sees the same definitions.
    fn learn(&mut self, def: usize, pos: usize, body: &[u8]) {
        let type_id = self.defs[def].type_id;
        if type_id == FMT_TYPE {
            if let Err(why) = self.define(body) {
                self.damage.bad_fmts += 1;
                self.damage.first_bad_fmt.get_or_insert((pos as u64, why));
            }
        } else if Some(type_id) == self.fmtu {
            self.units(def, body);
        }
    }

    /// Installs the definition a FMT record carries.
    fn define(&mut self, body: &[u8]) -> Result<(), String> {
        let (t, len, name, format, labels) = parse_fmt(body).ok_or("FMT record too short")?;
        if len < 3 {
            return Err(format!(
                "FMT for type {t} gives length {len}, less than a header"
            ));
        }
        if t == FMT_TYPE {
            // FMT describes itself; a different layout can only be damage, and taking it
            // would break the framing of every FMT after it.
            return match (len, format.as_str()) {
                (FMT_LEN, "BBnNZ") => Ok(()),
                _ => Err(format!(
                    "FMT redefines FMT as length {len}, format `{format}`"
                )),
            };
        }
        let old = self.current[t as usize].map(|d| &self.defs[d as usize]);
        if let Some(o) = old
            && (o.name == name && o.len == len && o.format == format && o.labels == labels)
        {
            return Ok(());
        }
        let mut new = Def::new(t, &name, len, &format, &labels);
        // A redefinition keeps the instance field by name, as pymavlink's `oldfmt` does.
        if let Some(o) = old.filter(|o| o.name == name && new.broken.is_none())
            && let Some(i) = o.instance
        {
            let label = &o.schema.fields[i].name;
            new.instance = new.schema.fields.iter().position(|f| &f.name == label);
        }
        if name == "FMTU" {
            self.fmtu = Some(t);
        }
        self.current[t as usize] = Some(self.defs.len() as u32);
        self.defs.push(new);
        Ok(())
    }

    /// An FMTU record (`TimeUS,FmtType,UnitIds,MultIds`, `log_Format_Units`): the field whose
    /// unit is `#` is the type's instance (pymavlink `DFFormat.set_unit_ids`).
    fn units(&mut self, def: usize, body: &[u8]) {
        let d = &self.defs[def];
        if d.broken.is_some() {
            return;
        }
        let field = |n: &str| d.schema.fields.iter().position(|f| f.name == n);
        let (Some(ft), Some(ui)) = (field("FmtType"), field("UnitIds")) else {
            return;
        };
        let (ty, _) = d.fields[ft];
        let target = ty.number(d.field_bytes(body, ft)).as_f64();
        let units = match d.fields[ui].0 {
            Ty::Text(_) => text(d.field_bytes(body, ui)),
            _ => return,
        };
        if !(0.0..256.0).contains(&target) {
            return;
        }
        let Some(t) = self.current[target as usize] else {
            return;
        };
        let t = &mut self.defs[t as usize];
        if t.broken.is_none()
            && let Some(i) = units.find('#').filter(|&i| i < t.fields.len())
        {
            t.instance = Some(i);
        }
    }
}
