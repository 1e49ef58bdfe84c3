//! `actuators.csv`: the actuator command log of a vehicle steered by control surfaces and
//! propeller speed rather than by commanded forces (a stern plane or elevator angle, fin
//! angles, a propeller's rpm). Columns are `t` and any number of `<name>_<unit>`: the unit
//! suffix says how to read the value, and the actuator is known by `<name>` in the settings
//! of the field-trial stages (`input: stern`).
//!
//! | suffix | read as | stored as |
//! |---|---|---|
//! | `_deg` | an angle in degrees | radians |
//! | `_rad` | an angle in radians | radians |
//! | `_rpm` | a shaft speed in rev/min | rad/s |
//! | `_rad_s` | a shaft speed in rad/s | rad/s |
//! | `_pct` | a command in percent of full scale | fraction (0.01 per %) |
//! | `_N`, `_Nm` | a force or moment command | N, N m |

use crate::core::diag::InputError;
use crate::pool::import::csvlog::{self, Log};

/// The unit suffixes an actuator column may carry, with the factor to SI.
const UNITS: [(&str, f64); 7] = [
    ("_rad_s", 1.0),
    ("_deg", std::f64::consts::PI / 180.0),
    ("_rad", 1.0),
    ("_rpm", std::f64::consts::PI / 30.0),
    ("_pct", 0.01),
    ("_Nm", 1.0),
    ("_N", 1.0),
];

/// The actuator log: `log.cols[j]` is the actuator `names[j]`, in SI units; `units[j]` is
/// the suffix its column was logged with (`_deg`), whose factor to SI is `factors[j]`.
#[derive(Debug, Clone)]
pub struct Actuators {
    pub names: Vec<String>,
    pub units: Vec<&'static str>,
    pub factors: Vec<f64>,
    pub log: Log,
}

/// The actuator's name, unit suffix and factor to SI of a column header, or why it cannot
/// be read.
fn split_unit(col: &str) -> Option<(&str, &'static str, f64)> {
    UNITS.iter().find_map(|(suffix, f)| {
        let name = col.strip_suffix(suffix)?;
        (!name.is_empty()).then_some((name, *suffix, *f))
    })
}

/// Why a column heading cannot name an actuator: which heading (0 for the first actuator's),
/// what is wrong and how to fix it.
#[derive(Debug)]
pub struct HeadError {
    pub at: usize,
    pub what: String,
    pub fix: &'static str,
}

/// The actuators named by their headings (`fin_top_deg`), no samples yet: every heading with
/// a unit suffix and a name of its own. `actuators.csv`'s header and a log's `columns` alike.
pub fn heads<S: AsRef<str>>(cols: &[S]) -> Result<Actuators, HeadError> {
    let mut a = Actuators {
        names: Vec::new(),
        units: Vec::new(),
        factors: Vec::new(),
        log: Log::default(),
    };
    for (at, c) in cols.iter().enumerate() {
        let c = c.as_ref();
        let Some((name, unit, f)) = split_unit(c) else {
            let shown: String = c.chars().take(60).collect();
            return Err(HeadError {
                at,
                what: format!("column `{shown}` has no unit suffix"),
                fix: "end each actuator column with its unit: _deg, _rad, _rpm, _rad_s, _pct, _N or _Nm",
            });
        };
        if a.names.iter().any(|n| n == name) {
            return Err(HeadError {
                at,
                what: format!("actuator `{name}` appears twice"),
                fix: "give each actuator column its own name",
            });
        }
        a.names.push(name.to_string());
        a.units.push(unit);
        a.factors.push(f);
    }
    Ok(a)
}

/// Reads `actuators.csv` at `path` with contents `text`.
pub fn parse(path: &str, text: &str) -> Result<Actuators, InputError> {
    let header = text
        .lines()
        .find(|l| !l.trim().is_empty())
        .unwrap_or("")
        .trim_start_matches('\u{feff}');
    let cols: Vec<&str> = header.split(',').map(|c| c.trim()).collect();
    if cols.first() != Some(&"t") || cols.len() < 2 {
        return Err(InputError::file(
            path,
            "the actuator log needs `t` first and at least one actuator column",
            "write a header such as `t,stern_deg,rpm_rpm` (name and unit: _deg, _rad, _rpm, _rad_s, _pct, _N, _Nm)",
        )
        .at(1, Some(1)));
    }
    let mut a = heads(&cols[1..]).map_err(|e| {
        // The heading's first character (`t` and each heading before it with its comma).
        let col: usize = header.split(',').take(e.at + 1).map(|s| s.len() + 1).sum();
        InputError::file(path, e.what, e.fix).at(1, Some(col + 1))
    })?;
    a.log = csvlog::parse_subset(path, text, &cols, "actuator log", 10)?;
    for (c, f) in a.log.cols.iter_mut().zip(&a.factors) {
        c.iter_mut().for_each(|x| *x *= f);
    }
    Ok(a)
}

/// The actuator commands of a fin-steered run: `actuators.csv` (`csv`: its path and text), or
/// the actuators of its log (`log.actuators`); both is an error.
pub fn of_run(
    csv: Option<(String, String)>,
    from_log: Option<Actuators>,
) -> Result<Option<Actuators>, InputError> {
    match (csv, from_log) {
        (Some((p, _)), Some(_)) => Err(InputError::file(
            p,
            "the run has both actuators.csv and the actuators in its log",
            "keep one: remove actuators.csv, or `actuators` from run.yaml's `log:`",
        )),
        (Some((p, text)), None) => parse(&p, &text).map(Some),
        (None, from_log) => Ok(from_log),
    }
}

/// The actuator values at times `t`, held from the last logged row (a command stays until
/// the next one); before the first row, the first value.
pub fn hold_at(log: &Log, col: usize, t: &[f64]) -> Vec<f64> {
    let mut j = 0usize;
    t.iter()
        .map(|&ti| {
            while j + 1 < log.t.len() && log.t[j + 1] <= ti {
                j += 1;
            }
            log.cols[col][j]
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn units_from_suffixes_and_clear_errors() {
        let mut text = String::from("t,stern_deg,prop_rpm,rudder_rad\n");
        for k in 0..12 {
            text.push_str(&format!("{},{},{},0.1\n", k as f64 * 0.1, 10.0, 60.0));
        }
        let a = parse("a.csv", &text).unwrap();
        assert_eq!(a.names, ["stern", "prop", "rudder"]);
        assert!((a.log.cols[0][0] - 10f64.to_radians()).abs() < 1e-12);
        assert!((a.log.cols[1][0] - 2.0 * std::f64::consts::PI).abs() < 1e-12);
        let e = parse("a.csv", "t,stern\n0,1\n").unwrap_err().to_string();
        assert!(e.contains("no unit suffix"), "{e}");
        let e = parse("a.csv", "t,s_deg,s_rad\n0,1,1\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("appears twice"), "{e}");
        let held = hold_at(&a.log, 2, &[-1.0, 0.05, 0.55, 9.0]);
        assert_eq!(held, [0.1; 4]);
    }
}
