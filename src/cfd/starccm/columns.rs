//! The header of a STAR-CCM+ export mapped to the quantities of the vehicle's DOFs: which
//! monitor gives what, in which unit, and whether every DOF has what the import needs.

use super::{ColumnMap, ImportOptions};
use crate::core::diag::InputError;
use crate::core::dof::Dof;
use std::collections::BTreeMap;
use std::f64::consts::PI;

/// Which quantity of a DOF a column gives.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub(super) enum Role {
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
pub(super) struct Header {
    pub(super) name: String,
    monitor: String,
    unit: Option<String>,
    pub(super) col: usize,
}

/// Splits a header cell `"<monitor>: <quantity> (<unit>)"` found at column `col`.
pub(super) fn parse_header(name: &str, col: usize) -> Header {
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

/// The export's columns as the import uses them.
pub(super) struct Mapped {
    pub(super) time: Header,
    /// The column and SI factor of each quantity found.
    pub(super) cols: BTreeMap<(Role, Dof), (Header, f64)>,
    /// Columns ignored or converted.
    pub(super) notes: Vec<String>,
}

/// Finds the time column and the column of each quantity of the vehicle's DOFs.
pub(super) fn map_columns(
    path: &str,
    headers: &[Header],
    opts: &ImportOptions,
) -> Result<Mapped, InputError> {
    let mut mapped = Mapped {
        time: time_column(path, headers, opts)?,
        cols: BTreeMap::new(),
        notes: Vec::new(),
    };
    for h in headers {
        for role in [Role::Force, Role::Velocity, Role::Accel] {
            for d in Dof::ALL {
                if h.monitor
                    .eq_ignore_ascii_case(&wanted_monitor(opts.columns, role, d))
                {
                    mapped.add(path, h, role, d, opts)?;
                }
            }
        }
    }
    Ok(mapped)
}

/// The time column (monitor `Physical Time` unless mapped), which must be in seconds.
fn time_column(path: &str, headers: &[Header], opts: &ImportOptions) -> Result<Header, InputError> {
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
    Ok(time)
}

/// The monitor that gives `role` of DOF `d`: the one mapped in `columns`, or the default.
fn wanted_monitor(columns: &ColumnMap, role: Role, d: Dof) -> String {
    match role {
        Role::Force => columns.force.get(&d),
        Role::Velocity => columns.velocity.get(&d),
        Role::Accel => columns.acceleration.get(&d),
    }
    .cloned()
    .unwrap_or_else(|| role.default_monitor(d))
}

impl Mapped {
    /// Takes header `h` as `role` of DOF `d`: ignored (with a note) for a DOF the vehicle
    /// lacks, converted to SI, and an error when another column already gave it.
    fn add(
        &mut self,
        path: &str,
        h: &Header,
        role: Role,
        d: Dof,
        opts: &ImportOptions,
    ) -> Result<(), InputError> {
        if !opts.dofs.contains(&d) {
            self.notes.push(format!(
                "ignored \"{}\": {d} is not one of the vehicle's DOFs",
                h.name
            ));
            return Ok(());
        }
        let unit = h.unit.clone().unwrap_or_default();
        let factor = unit_factor(path, h, role, d, &unit)?;
        if factor != 1.0 {
            self.notes
                .push(format!("converted \"{}\" from {unit} to SI", h.name));
        }
        if let Some((prev, _)) = self.cols.insert((role, d), (h.clone(), factor)) {
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
        Ok(())
    }
}

/// The SI factor of column `h` (`unit` as written), or an error naming the units accepted.
fn unit_factor(path: &str, h: &Header, role: Role, d: Dof, unit: &str) -> Result<f64, InputError> {
    role.factor(d.is_angular(), unit).map_err(|expected| {
        InputError::file(
            path,
            format!(
                "column \"{}\" is the {d} {} but its unit is ({unit}), expected {expected}",
                h.name,
                role.describe()
            ),
            "export the monitor in one of the expected units",
        )
        .at(1, Some(h.col))
    })
}

/// The DOFs the export has a velocity for; every other column must belong to one of them,
/// and each needs its applied force (a column, or configured).
pub(super) fn check_dofs(
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
