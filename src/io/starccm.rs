//! STAR-CCM+ DFBI exports: `"<monitor>: <quantity> (<unit>)"` headers, unit conversion,
//! column mapping, repeated inner-iteration rows collapsed to the last (docs/formats.md).

use super::response::{Response, Series, Source, differentiate};
use crate::diag::InputError;
use crate::dof::Dof;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::f64::consts::PI;

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

#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
enum Role {
    Force,
    Velocity,
    Accel,
}

impl Role {
    fn describe(self) -> &'static str {
        match self {
            Role::Force => "applied force",
            Role::Velocity => "velocity",
            Role::Accel => "acceleration",
        }
    }

    fn default_monitor(self, d: Dof) -> String {
        let a = d.axis();
        match (self, d.is_angular()) {
            (Role::Force, false) => format!("Applied Force {a} Monitor"),
            (Role::Force, true) => format!("Applied Moment {a} Monitor"),
            (Role::Velocity, false) => format!("Body Velocity {a} Monitor"),
            (Role::Velocity, true) => format!("Body Angular Velocity {a} Monitor"),
            (Role::Accel, false) => format!("Body Acceleration {a} Monitor"),
            (Role::Accel, true) => format!("Body Angular Acceleration {a} Monitor"),
        }
    }

    /// SI factor for a unit written in the header, or the units that would be accepted.
    fn factor(self, angular: bool, unit: &str) -> Result<f64, &'static str> {
        let u = unit.replace(' ', "");
        let ok = match (self, angular) {
            (Role::Force, false) => matches!(u.as_str(), "N").then_some(1.0),
            (Role::Force, true) => {
                matches!(u.as_str(), "N-m" | "Nm" | "N*m" | "N.m").then_some(1.0)
            }
            (Role::Velocity, false) => (u == "m/s").then_some(1.0),
            (Role::Velocity, true) => match u.as_str() {
                "rad/s" => Some(1.0),
                "deg/s" => Some(PI / 180.0),
                _ => None,
            },
            (Role::Accel, false) => (u == "m/s^2").then_some(1.0),
            (Role::Accel, true) => match u.as_str() {
                "rad/s^2" => Some(1.0),
                "deg/s^2" => Some(PI / 180.0),
                _ => None,
            },
        };
        ok.ok_or(match (self, angular) {
            (Role::Force, false) => "(N)",
            (Role::Force, true) => "(N-m)",
            (Role::Velocity, false) => "(m/s)",
            (Role::Velocity, true) => "(rad/s) or (deg/s)",
            (Role::Accel, false) => "(m/s^2)",
            (Role::Accel, true) => "(rad/s^2) or (deg/s^2)",
        })
    }
}

/// A header cell split into its parts.
#[derive(Debug, Clone, PartialEq)]
struct Header {
    name: String,
    monitor: String,
    unit: Option<String>,
    col: usize,
}

fn parse_header(name: &str, col: usize) -> Header {
    let monitor = name
        .split_once(": ")
        .map_or(name, |(m, _)| m)
        .trim()
        .to_string();
    let unit = name
        .strip_suffix(')')
        .and_then(|s| s.rfind(" (").map(|i| s[i + 2..].to_string()));
    Header {
        name: name.to_string(),
        monitor,
        unit,
        col,
    }
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

struct Mapped {
    time: Header,
    cols: BTreeMap<(Role, Dof), (Header, f64)>,
    notes: Vec<String>,
}

fn map_columns(path: &str, headers: &[Header], opts: &ImportOptions) -> Result<Mapped, InputError> {
    let time_monitor = opts
        .columns
        .time
        .clone()
        .unwrap_or_else(|| "Physical Time".into());
    let found = || {
        headers
            .iter()
            .map(|h| format!("\"{}\"", h.name))
            .collect::<Vec<_>>()
            .join(", ")
    };
    let time = headers
        .iter()
        .find(|h| h.monitor.eq_ignore_ascii_case(&time_monitor))
        .cloned()
        .ok_or_else(|| {
            InputError::file(
                path,
                format!("no time column: expected \"{time_monitor}: Physical Time (s)\"; the header has {}", found()),
                "export the Physical Time with the monitors, or name the time monitor under settings.columns.time",
            )
            .at(1, None)
        })?;
    if time.unit.as_deref().is_some_and(|u| u != "s") {
        return Err(InputError::file(
            path,
            format!(
                "time column \"{}\" is in ({}), expected (s)",
                time.name,
                time.unit.as_deref().unwrap_or("")
            ),
            "export Physical Time in seconds",
        )
        .at(1, Some(time.col)));
    }
    let mut cols = BTreeMap::new();
    let mut notes = Vec::new();
    for h in headers {
        for role in [Role::Force, Role::Velocity, Role::Accel] {
            for d in Dof::ALL {
                let wanted = match role {
                    Role::Force => opts.columns.force.get(&d),
                    Role::Velocity => opts.columns.velocity.get(&d),
                    Role::Accel => opts.columns.acceleration.get(&d),
                }
                .cloned()
                .unwrap_or_else(|| role.default_monitor(d));
                if !h.monitor.eq_ignore_ascii_case(&wanted) {
                    continue;
                }
                if !opts.dofs.contains(&d) {
                    notes.push(format!(
                        "ignored \"{}\": {d} is not one of the vehicle's DOFs",
                        h.name
                    ));
                    continue;
                }
                let unit = h.unit.clone().unwrap_or_default();
                let factor = role.factor(d.is_angular(), &unit).map_err(|expected| {
                    InputError::file(
                        path,
                        format!("column \"{}\" is the {d} {} but its unit is ({unit}), expected {expected}", h.name, role.describe()),
                        "export the monitor in one of the expected units",
                    )
                    .at(1, Some(h.col))
                })?;
                if factor != 1.0 {
                    notes.push(format!("converted \"{}\" from {unit} to SI", h.name));
                }
                if let Some((prev, _)) = cols.insert((role, d), (h.clone(), factor)) {
                    return Err(InputError::file(
                        path,
                        format!(
                            "two columns give the {d} {}: \"{}\" and \"{}\"",
                            role.describe(),
                            prev.name,
                            h.name
                        ),
                        "remove one from the export, or map the right one under settings.columns",
                    )
                    .at(1, Some(h.col)));
                }
            }
        }
    }
    Ok(Mapped { time, cols, notes })
}

fn check_dofs(
    path: &str,
    m: &Mapped,
    headers: &[Header],
    opts: &ImportOptions,
) -> Result<Vec<Dof>, InputError> {
    let dofs: Vec<Dof> = opts
        .dofs
        .iter()
        .copied()
        .filter(|d| m.cols.contains_key(&(Role::Velocity, *d)))
        .collect();
    if dofs.is_empty() {
        let names: Vec<String> = opts
            .dofs
            .iter()
            .map(|d| format!("\"{}\"", Role::Velocity.default_monitor(*d)))
            .collect();
        let found: Vec<String> = headers.iter().map(|h| format!("\"{}\"", h.name)).collect();
        return Err(InputError::file(
            path,
            format!("no velocity column for any of the vehicle's DOFs: expected one of {}; the header has {}", names.join(", "), found.join(", ")),
            "export the body velocity monitor, or map your monitor's name under settings.columns.velocity (e.g. `surge: \"My Velocity Monitor\"`)",
        )
        .at(1, None));
    }
    for ((role, d), (h, _)) in &m.cols {
        if *role != Role::Velocity && !dofs.contains(d) {
            return Err(InputError::file(
                path,
                format!(
                    "column \"{}\" gives the {d} {} but there is no {d} velocity column",
                    h.name,
                    role.describe()
                ),
                format!(
                    "export \"{}\" too, or map its monitor under settings.columns.velocity",
                    Role::Velocity.default_monitor(*d)
                ),
            )
            .at(1, Some(h.col)));
        }
    }
    for d in &dofs {
        if !m.cols.contains_key(&(Role::Force, *d)) && !opts.configured_force.contains_key(d) {
            return Err(InputError::file(
                path,
                format!("no applied-force column for {d} (expected \"{}\") and no configured force for this file", Role::Force.default_monitor(*d)),
                format!("export the applied force, or add to the stage's settings: `applied_force: [{{files: \"{path}\", force: {{{d}: <value in {}>}}}}]`", d.force_unit()),
            )
            .at(1, None));
        }
    }
    Ok(dofs)
}

/// Parses one export. `path` is only used in messages.
pub fn parse(path: &str, text: &str, opts: &ImportOptions) -> Result<Imported, InputError> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let err = |line: usize, col: Option<usize>, what: String, fix: &str| {
        InputError::file(path, what, fix)
            .at(line, col)
            .with_source(text)
    };
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
        return Err(err(
            hline,
            None,
            format!("the header is separated by {shown}, not commas"),
            "STAR-CCM+ exports are comma-separated: export again with ',' as the delimiter, or replace the delimiter",
        ));
    }
    let headers: Vec<Header> = hfields
        .iter()
        .map(|(c, n)| parse_header(n.trim(), *c))
        .collect();
    let mapped = map_columns(path, &headers, opts).map_err(|e| e.with_source(text))?;
    let dofs = check_dofs(path, &mapped, &headers, opts).map_err(|e| e.with_source(text))?;

    let time_idx = headers
        .iter()
        .position(|h| h.name == mapped.time.name)
        .unwrap_or(0);
    let wanted: Vec<(usize, f64)> = mapped
        .cols
        .values()
        .map(|(h, f)| (headers.iter().position(|x| x.col == h.col).unwrap_or(0), *f))
        .collect();
    let mut t: Vec<f64> = Vec::new();
    let mut rows: Vec<Vec<f64>> = Vec::new();
    let mut rows_read = 0;
    for (ln, line) in lines {
        rows_read += 1;
        let fields = split_fields(line);
        if fields.len() != headers.len() {
            return Err(err(
                ln,
                None,
                format!(
                    "expected {} fields like the header, found {}",
                    headers.len(),
                    fields.len()
                ),
                "a row was cut short or has an extra delimiter: fix or delete this line",
            ));
        }
        let num = |i: usize| -> Result<f64, InputError> {
            let (col, raw) = &fields[i];
            let v: f64 = raw.trim().parse().map_err(|_| {
                err(ln, Some(*col), format!("cannot read \"{}\" in column \"{}\" as a number", raw.trim(), headers[i].name), "fix or delete this row (the export may have been written while the run was still going)")
            })?;
            if !v.is_finite() {
                return Err(err(
                    ln,
                    Some(*col),
                    format!("{} in column \"{}\"", raw.trim(), headers[i].name),
                    "the solver diverged or the export is corrupt: rerun the case, or cut the export before this row",
                ));
            }
            Ok(v)
        };
        let ti = num(time_idx)?;
        let vals = wanted
            .iter()
            .map(|(i, f)| num(*i).map(|v| v * f))
            .collect::<Result<Vec<_>, _>>()?;
        match t.last() {
            // Inner iterations written out: the last row of a physical time is the converged one.
            Some(&last) if ti == last => *rows.last_mut().expect("rows follow t") = vals,
            Some(&last) if ti < last => {
                return Err(err(
                    ln,
                    Some(fields[time_idx].0),
                    format!("time goes backwards: {ti} s after {last} s"),
                    "the export mixes two runs or was appended to: export the run again",
                ));
            }
            _ => {
                t.push(ti);
                rows.push(vals);
            }
        }
    }
    if t.len() < 3 {
        return Err(InputError::file(
            path,
            format!(
                "{} data rows after the header; a DFBI response needs at least 3 time steps",
                t.len()
            ),
            "export the whole run (all time steps)",
        )
        .at(hline, None));
    }
    let col_of = |role: Role, d: Dof| mapped.cols.keys().position(|k| *k == (role, d));
    let column = |j: usize| rows.iter().map(|r| r[j]).collect::<Vec<f64>>();
    let mut response = Response {
        t: t.clone(),
        dofs: BTreeMap::new(),
    };
    let mut notes = mapped.notes;
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
                (differentiate(&t, &velocity), Source::Differentiated)
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
    Ok(Imported {
        response,
        rows_read,
        rows_kept: t.len(),
        notes,
    })
}

#[cfg(test)]
mod tests;
