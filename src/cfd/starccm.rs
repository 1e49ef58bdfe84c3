//! STAR-CCM+ DFBI exports: `"<monitor>: <quantity> (<unit>)"` headers, unit conversion,
//! column mapping, repeated inner-iteration rows collapsed to the last (docs/formats.md).

mod columns;
pub mod stage;
#[cfg(test)]
mod tests;

use crate::core::diag::InputError;
use crate::core::dof::Dof;
use crate::core::input::{PLAUSIBLE, clip};
use crate::core::response::{Response, Series, Source, differentiate};
use columns::{Header, Mapped, Role, check_dofs, map_columns, parse_header};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// Which monitor holds which quantity. DOFs not named here use the default monitor names
/// (`Applied Force X Monitor`, `Body Angular Velocity Z Monitor`, ...).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ColumnMap {
    /// Monitor of the time column; default `Physical Time`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub time: Option<String>,
    #[serde(skip_serializing_if = "BTreeMap::is_empty")]
    pub force: BTreeMap<Dof, String>,
    #[serde(skip_serializing_if = "BTreeMap::is_empty")]
    pub velocity: BTreeMap<Dof, String>,
    #[serde(skip_serializing_if = "BTreeMap::is_empty")]
    pub acceleration: BTreeMap<Dof, String>,
}

/// Splits a CSV line into (1-based column, field) pairs; double quotes may wrap a field.
fn split_fields(line: &str) -> Vec<(usize, String)> {
    let mut out = Vec::new();
    let mut cur = String::new();
    let mut start = 1;
    let mut quoted = false;
    let chars: Vec<char> = line.chars().collect();
    let mut i = 0;
    while i < chars.len() {
        let c = chars[i];
        if quoted {
            if c == '"' && chars.get(i + 1) == Some(&'"') {
                cur.push('"');
                i += 1;
            } else if c == '"' {
                quoted = false;
            } else {
                cur.push(c);
            }
        } else if c == '"' {
            quoted = true;
        } else if c == ',' {
            out.push((start, std::mem::take(&mut cur)));
            start = i + 2;
        } else {
            cur.push(c);
        }
        i += 1;
    }
    out.push((start, cur));
    out
}

/// What the importer needs besides the file.
#[derive(Debug, Clone)]
pub struct ImportOptions<'a> {
    pub columns: &'a ColumnMap,
    /// The vehicle's DOFs: columns of other DOFs are ignored (and listed as such).
    pub dofs: &'a [Dof],
    /// Applied force for DOFs whose force column is missing (from `pipeline.yaml`).
    pub configured_force: BTreeMap<Dof, f64>,
}

#[derive(Debug, Clone, PartialEq)]
pub struct Imported {
    pub response: Response,
    pub rows_read: usize,
    pub rows_kept: usize,
    /// Human-readable notes: unit conversions, ignored columns, derived quantities.
    pub notes: Vec<String>,
}

/// Parses one export. `path` is only used in messages.
pub fn parse(path: &str, text: &str, opts: &ImportOptions) -> Result<Imported, InputError> {
    let whole = crate::core::input::Text::new(text);
    let (text, torn) = whole.complete_lines(path);
    let mut lines = text
        .lines()
        .enumerate()
        .map(|(i, l)| (i + 1, l))
        .filter(|(_, l)| !l.trim().is_empty());
    let Some((hline, header_text)) = lines.next() else {
        return Err(InputError::file(
            path,
            "the file is empty",
            "export the DFBI run again from STAR-CCM+ (File > Export, or the plot's Export to CSV)",
        ));
    };
    let headers = read_header(path, text, hline, header_text)?;
    let mapped = map_columns(path, &headers, opts).map_err(|e| e.with_source(text))?;
    let dofs = check_dofs(path, &mapped, &headers, opts).map_err(|e| e.with_source(text))?;
    let reader = RowReader::new(path, text, &headers, &mapped);
    let table = reader.read(lines)?;
    if table.t.len() < 3 {
        return Err(InputError::file(
            path,
            format!(
                "{} data rows after the header; a DFBI response needs at least 3 time steps",
                table.t.len()
            ),
            "export the whole run (all time steps)",
        )
        .at(hline, None));
    }
    let (response, mut notes) = build_response(&table, mapped, dofs, opts);
    notes.extend(torn);
    Ok(Imported {
        response,
        rows_read: table.rows_read,
        rows_kept: table.t.len(),
        notes,
    })
}

/// The header's cells; a header in one cell that holds another delimiter is an error.
fn read_header(
    path: &str,
    text: &str,
    hline: usize,
    header_text: &str,
) -> Result<Vec<Header>, InputError> {
    let hfields = split_fields(header_text);
    if hfields.len() == 1
        && let Some(d) = [';', '\t', '|']
            .into_iter()
            .find(|c| header_text.contains(*c))
    {
        let shown = if d == '\t' {
            "a tab".to_string()
        } else {
            format!("'{d}'")
        };
        return Err(InputError::file(
            path,
            format!("the header is separated by {shown}, not commas"),
            "STAR-CCM+ exports are comma-separated: export again with ',' as the delimiter, or replace the delimiter",
        )
        .at(hline, None)
        .with_source(text));
    }
    Ok(hfields
        .iter()
        // A name is only shown and matched: a damaged header's megabyte "name" is clipped.
        .map(|(c, n)| parse_header(&clip(n.trim(), 300), *c))
        .collect())
}

/// The data rows: one per physical time, the mapped columns in SI units.
struct Table {
    t: Vec<f64>,
    /// The mapped columns' values, in the order of [`Mapped::cols`].
    rows: Vec<Vec<f64>>,
    /// Rows in the file, inner iterations included.
    rows_read: usize,
}

/// Reads the data rows of one export against its header.
struct RowReader<'a> {
    path: &'a str,
    text: &'a str,
    headers: &'a [Header],
    /// Index in `headers` of the time column.
    time_idx: usize,
    /// Index in `headers` and SI factor of each mapped column.
    wanted: Vec<(usize, f64)>,
}

impl<'a> RowReader<'a> {
    /// Finds the time column and the mapped columns among `headers`.
    fn new(path: &'a str, text: &'a str, headers: &'a [Header], mapped: &Mapped) -> Self {
        let time_idx = headers
            .iter()
            .position(|h| h.name == mapped.time.name)
            .unwrap_or(0);
        let wanted: Vec<(usize, f64)> = mapped
            .cols
            .values()
            .map(|(h, f)| (headers.iter().position(|x| x.col == h.col).unwrap_or(0), *f))
            .collect();
        RowReader {
            path,
            text,
            headers,
            time_idx,
            wanted,
        }
    }

    /// An error located at `line` (and `col`) with that line of the file shown.
    fn err(&self, line: usize, col: Option<usize>, what: String, fix: &str) -> InputError {
        InputError::file(self.path, what, fix)
            .at(line, col)
            .with_source(self.text)
    }

    /// Reads every row; repeated inner iterations of one physical time keep the last.
    fn read<'t>(&self, lines: impl Iterator<Item = (usize, &'t str)>) -> Result<Table, InputError> {
        let mut table = Table {
            t: Vec::new(),
            rows: Vec::new(),
            rows_read: 0,
        };
        for (ln, line) in lines {
            table.rows_read += 1;
            let fields = split_fields(line);
            if fields.len() != self.headers.len() {
                return Err(self.err(
                    ln,
                    None,
                    format!(
                        "expected {} fields like the header, found {}",
                        self.headers.len(),
                        fields.len()
                    ),
                    "a row was cut short or has an extra delimiter: fix or delete this line",
                ));
            }
            let ti = self.number(ln, &fields, self.time_idx)?;
            let vals = self
                .wanted
                .iter()
                .map(|(i, f)| self.number(ln, &fields, *i).map(|v| v * f))
                .collect::<Result<Vec<_>, _>>()?;
            self.push(&mut table, ln, fields[self.time_idx].0, ti, vals)?;
        }
        Ok(table)
    }

    /// Field `i` of a row as a finite number.
    fn number(&self, ln: usize, fields: &[(usize, String)], i: usize) -> Result<f64, InputError> {
        let (col, raw) = &fields[i];
        let headers = self.headers;
        let v: f64 = raw.trim().parse().map_err(|_| {
            self.err(ln, Some(*col), format!("cannot read \"{}\" in column \"{}\" as a number", clip(raw.trim(), 40), clip(&headers[i].name, 80)), "fix or delete this row (the export may have been written while the run was still going)")
        })?;
        if !v.is_finite() {
            return Err(self.err(
                ln,
                Some(*col),
                format!("{} in column \"{}\"", raw.trim(), clip(&headers[i].name, 80)),
                "the solver diverged or the export is corrupt: rerun the case, or cut the export before this row",
            ));
        }
        if i != self.time_idx && v.abs() > PLAUSIBLE {
            return Err(self.err(
                ln,
                Some(*col),
                format!(
                    "{} in column \"{}\" is beyond any force, velocity or acceleration of a DFBI run (|x| > {PLAUSIBLE:e})",
                    raw.trim(),
                    clip(&headers[i].name, 80)
                ),
                "the value is damaged (a cut-off or merged number) or the solver diverged: fix or delete this row, or cut the export before it",
            ));
        }
        Ok(v)
    }

    /// Adds the row of time `ti` (at column `tcol`): a repeat of the last time replaces it,
    /// an earlier time is an error.
    fn push(
        &self,
        table: &mut Table,
        ln: usize,
        tcol: usize,
        ti: f64,
        vals: Vec<f64>,
    ) -> Result<(), InputError> {
        match table.t.last() {
            // Inner iterations written out: the last row of a physical time is the converged one.
            Some(&last) if ti == last => *table.rows.last_mut().expect("rows follow t") = vals,
            Some(&last) if ti < last => {
                return Err(self.err(
                    ln,
                    Some(tcol),
                    format!("time goes backwards: {ti} s after {last} s"),
                    "the export mixes two runs or was appended to: export the run again",
                ));
            }
            _ => {
                table.t.push(ti);
                table.rows.push(vals);
            }
        }
        Ok(())
    }
}

/// The response of each DOF from the table, with the notes of the mapping and of what was
/// configured or derived.
fn build_response(
    table: &Table,
    mapped: Mapped,
    dofs: Vec<Dof>,
    opts: &ImportOptions,
) -> (Response, Vec<String>) {
    let Mapped {
        cols, mut notes, ..
    } = mapped;
    let t = &table.t;
    let col_of = |role: Role, d: Dof| cols.keys().position(|k| *k == (role, d));
    let column = |j: usize| table.rows.iter().map(|r| r[j]).collect::<Vec<f64>>();
    let mut response = Response {
        t: t.clone(),
        dofs: BTreeMap::new(),
        attitude: Vec::new(),
    };
    for d in dofs {
        let velocity = column(col_of(Role::Velocity, d).expect("checked"));
        let (force, force_source) = match col_of(Role::Force, d) {
            Some(j) => (column(j), Source::Column),
            None => {
                let f = opts.configured_force[&d];
                notes.push(format!(
                    "{d} applied force {f} {} from pipeline.yaml",
                    d.force_unit()
                ));
                (vec![f; t.len()], Source::Configured)
            }
        };
        let (accel, accel_source) = match col_of(Role::Accel, d) {
            Some(j) => (column(j), Source::Column),
            None => {
                notes.push(format!(
                    "{d} acceleration by central differences of the velocity"
                ));
                (differentiate(t, &velocity), Source::Differentiated)
            }
        };
        response.dofs.insert(
            d,
            Series {
                force,
                velocity,
                accel,
                force_source,
                accel_source,
            },
        );
    }
    (response, notes)
}
