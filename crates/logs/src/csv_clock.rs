//! The time column of a CSV log and its unit. A `rostopic echo -p` file is timed by `%time`
//! (receive time, nanoseconds). Any other CSV a vehicle, a simulator or an analysis tool wrote
//! is a log too when one column is a time: `time`, `timestamp(s)`, `t`, `stamp`, `__time`
//! (PlotJuggler's export), `TimeUS` (ArduPilot's, as `mavlogdump` writes it), `seconds`, each
//! in any case. The unit is the name's where it gives one (`time_s`, `timestamp_us`,
//! `time (ms)`, `t[ns]`, `TimeUS`); otherwise it is read from the values: fractional values
//! are seconds; whole numbers whose median step is 1-999 are milliseconds, 1000-999999
//! microseconds (PX4's `ulog2csv`), larger nanoseconds, and the log's notes say so. A column
//! of dates and times (`2023-04-18 11:03:34.123`, ISO 8601) is read as seconds since 1970 in
//! UTC, in the zone a cell gives ([`crate::iso_time`]), and the notes say so too.

/// The header cell of `rostopic echo -p`'s time.
const ROSTOPIC_TIME: &str = "%time";

/// Column names that are a time, before any unit suffix.
const TIME_NAMES: [&str; 11] = [
    "time",
    "datetime",
    "date_time",
    "times",
    "timestamp",
    "timestamps",
    "t",
    "stamp",
    "__time",
    "sim_time",
    "elapsed",
];

/// How a column of dates and times is read, for the log's notes.
const DATES_READ_AS: &str = "read as seconds since 1970, in UTC where a cell gives no zone";

/// Unit suffixes and their length in seconds.
const UNITS: [(&str, f64); 5] = [
    ("s", 1.0),
    ("ms", 1e-3),
    ("us", 1e-6),
    ("µs", 1e-6),
    ("ns", 1e-9),
];

/// How a CSV file's rows are timed.
#[derive(Debug, Clone, PartialEq)]
pub struct Clock {
    /// The column holding the time.
    pub column: usize,
    /// Seconds per unit of that column.
    pub unit_s: f64,
    /// Whether the file is `rostopic echo -p`'s (fields under `field.`, a `header.stamp`).
    pub rostopic: bool,
    /// How the unit was read from whole numbers, for the log's notes (empty when the name
    /// gives it or the values are fractional seconds).
    pub inferred: String,
}

/// A header cell as written: without a byte-order mark, surrounding quotes or blanks.
pub fn bare(cell: &str) -> &str {
    cell.trim()
        .trim_start_matches('\u{feff}')
        .trim()
        .trim_matches('"')
        .trim()
}

/// Whether a header cell names a time, and its unit when the name gives one.
fn time_name(cell: &str) -> Option<Option<f64>> {
    let n = bare(cell).to_lowercase();
    if n == ROSTOPIC_TIME {
        return Some(Some(1e-9));
    }
    match n.as_str() {
        "seconds" | "secs" | "sec" => return Some(Some(1.0)),
        "timeus" => return Some(Some(1e-6)),
        "timems" => return Some(Some(1e-3)),
        _ => {}
    }
    for (suffix, unit) in UNITS {
        for written in [
            format!("_{suffix}"),
            format!(" ({suffix})"),
            format!("({suffix})"),
            format!(" [{suffix}]"),
            format!("[{suffix}]"),
        ] {
            if let Some(base) = n.strip_suffix(written.as_str())
                && TIME_NAMES.contains(&base)
            {
                return Some(Some(unit));
            }
        }
    }
    TIME_NAMES.contains(&n.as_str()).then_some(None)
}

/// Whether a header row names a time in one of its columns.
pub fn names_a_time(header: &[String]) -> bool {
    header.iter().any(|h| time_name(h).is_some())
}

/// Whether a table whose header names no time is timed by its first column all the same: a
/// column with no name whose first cell is a date and time, as pandas writes a
/// `DatetimeIndex` it was given no name for (`,depth_m` over `2023-04-18 11:03:34.1,1.5`).
pub fn unnamed_dates(header: &[String], first_cell: Option<&str>) -> bool {
    header.len() > 1
        && header.first().is_some_and(|h| bare(h).is_empty())
        && first_cell.is_some_and(|c| crate::iso_time::epoch_seconds(bare(c)).is_some())
}

/// The time column of a header row (the first that names a time) and its unit, or `None`
/// when no column does. Where the name gives no unit, `given` (seconds per unit, the user's)
/// is taken, else the unit is read from `rows`, the first rows of the file.
pub fn clock<'a>(
    header: &[String],
    rows: impl Iterator<Item = &'a [String]>,
    given: Option<f64>,
) -> Option<Clock> {
    let mut rows = rows.peekable();
    let named = header
        .iter()
        .enumerate()
        .find_map(|(c, h)| Some((c, time_name(h)?)));
    let Some((column, unit)) = named else {
        let first = rows.peek().and_then(|r| r.first()).map(String::as_str);
        return unnamed_dates(header, first).then(|| Clock {
            column: 0,
            unit_s: 1.0,
            rostopic: false,
            inferred: format!(
                "the first column, unnamed, holds dates and times (a pandas index): {DATES_READ_AS}"
            ),
        });
    };
    let rostopic = bare(&header[column]) == ROSTOPIC_TIME;
    let (unit_s, inferred) = match unit.or(given) {
        Some(u) => (u, String::new()),
        None => inferred_unit(&header[column], rows.filter_map(|r| r.get(column))),
    };
    Some(Clock {
        column,
        unit_s,
        rostopic,
        inferred,
    })
}

/// The unit of a time column named without one, from its values (see the module's notes).
fn inferred_unit<'a>(name: &str, cells: impl Iterator<Item = &'a String>) -> (f64, String) {
    let cells: Vec<&String> = cells.take(2000).collect();
    let values: Vec<f64> = cells.iter().filter_map(|c| c.trim().parse().ok()).collect();
    let name = bare(name);
    let dated: Vec<&&String> = (cells.iter())
        .filter(|c| !c.trim().is_empty())
        .take(10)
        .collect();
    if values.is_empty()
        && !dated.is_empty()
        && dated
            .iter()
            .all(|c| crate::iso_time::epoch_seconds(c).is_some())
    {
        return (
            1.0,
            format!("time column `{name}` holds dates and times: {DATES_READ_AS}"),
        );
    }
    let whole = !values.is_empty() && values.iter().all(|v: &f64| v.fract() == 0.0);
    let mut steps: Vec<f64> = values
        .windows(2)
        .map(|w| w[1] - w[0])
        .filter(|d| *d > 0.0)
        .collect();
    steps.sort_by(f64::total_cmp);
    let median = steps.get(steps.len() / 2).copied().unwrap_or(0.0);
    let (unit, what) = match (whole, median) {
        (true, m) if m >= 1e6 => (1e-9, "nanoseconds"),
        (true, m) if m >= 1e3 => (1e-6, "microseconds"),
        (true, m) if m >= 1.0 => (1e-3, "milliseconds"),
        _ => (1.0, "seconds"),
    };
    // Fractional values are seconds beyond doubt: only a unit other than seconds read from
    // whole numbers is said.
    let said = match whole && unit != 1.0 {
        true => format!(
            "time column `{name}` read as {what} (whole numbers, median step {median}); name it `{name}_s`, `{name}_ms`, `{name}_us` or `{name}_ns` to say its unit"
        ),
        false => String::new(),
    };
    (unit, said)
}

/// A time cell in seconds: whole numbers are split before they become a float (nanoseconds
/// since the Unix epoch, 1.7e18, are held by an f64 only to 256 ns); a date and time is
/// seconds since 1970, whatever the unit.
pub fn seconds(cell: &str, unit_s: f64) -> Option<f64> {
    let cell = cell.trim();
    let per = (1.0 / unit_s).round();
    match cell.parse::<u64>() {
        Ok(n) if unit_s < 1.0 && per >= 1.0 => {
            let per = per as u64;
            Some((n / per) as f64 + (n % per) as f64 * unit_s)
        }
        _ => (cell.parse::<f64>().ok().map(|x| x * unit_s))
            .or_else(|| crate::iso_time::epoch_seconds(cell)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn header(names: &[&str]) -> Vec<String> {
        names.iter().map(|s| s.to_string()).collect()
    }

    fn rows(values: &[&str]) -> Vec<Vec<String>> {
        values
            .iter()
            .map(|v| vec![v.to_string(), "1".into()])
            .collect()
    }

    fn of(name: &str, values: &[&str]) -> Option<Clock> {
        let r = rows(values);
        clock(&header(&[name, "x"]), r.iter().map(|r| r.as_slice()), None)
    }

    #[test]
    fn the_unit_is_the_names_where_it_gives_one() {
        for (name, unit) in [
            ("%time", 1e-9),
            ("time_us", 1e-6),
            ("Timestamp (ms)", 1e-3),
            ("t[ns]", 1e-9),
            ("TimeUS", 1e-6),
            ("\u{feff}time_s", 1.0),
            ("\"seconds\"", 1.0),
        ] {
            let c = of(name, &["1", "2"]).unwrap_or_else(|| panic!("{name} is a time"));
            assert_eq!(c.unit_s, unit, "{name}");
            assert!(c.inferred.is_empty(), "{name}: {}", c.inferred);
            assert_eq!(c.rostopic, name == "%time");
        }
        for name in ["x", "time_of_flight", "timer", "speed_s"] {
            assert_eq!(of(name, &["1"]), None, "{name} is no time");
        }
    }

    #[test]
    fn a_unit_the_name_does_not_give_is_read_from_the_values_and_said() {
        let unit = |name: &str, v: &[&str]| of(name, v).unwrap().unit_s;
        assert_eq!(
            unit("timestamp", &["1284.956", "1285.006", "1285.056"]),
            1.0
        );
        assert_eq!(unit("timestamp", &["1000000", "1004000", "1008000"]), 1e-6);
        assert_eq!(
            unit("time", &["1669909208877428140", "1669909208977451040"]),
            1e-9
        );
        assert_eq!(unit("t", &["0", "20", "40"]), 1e-3);
        assert_eq!(unit("__time", &["0.0", "0.5"]), 1.0);
        let c = of("timestamp", &["1000000", "1004000"]).unwrap();
        assert!(c.inferred.contains("microseconds") && c.inferred.contains("timestamp_us"));
        // The time column need not be the first (a pandas index before it).
        let h = header(&["", "x", "Time"]);
        let r = [vec!["0".to_string(), "1".into(), "0.25".into()]];
        let c = clock(&h, r.iter().map(|r| r.as_slice()), None).unwrap();
        assert_eq!((c.column, c.unit_s), (2, 1.0));
        // A unit the user gives is taken where the name gives none, and said by no note.
        let r = rows(&["0", "1000", "2000"]);
        let at = |name: &str| {
            clock(
                &header(&[name, "x"]),
                r.iter().map(|r| r.as_slice()),
                Some(1e-3),
            )
        };
        assert_eq!(
            of("timestamp", &["0", "1000", "2000"]).unwrap().unit_s,
            1e-6
        );
        assert_eq!(
            (
                at("timestamp").unwrap().unit_s,
                at("timestamp").unwrap().inferred
            ),
            (1e-3, String::new())
        );
        assert_eq!(at("time_s").unwrap().unit_s, 1.0, "the name's unit stands");
    }

    #[test]
    fn whole_nanoseconds_keep_their_precision() {
        let s = seconds("1669909208877428140", 1e-9).unwrap();
        assert!((s - 1_669_909_208.877_428).abs() < 1e-6);
        assert_eq!(seconds("1500", 1e-3), Some(1.5));
        assert_eq!(seconds("2.5", 1.0), Some(2.5));
        assert_eq!(seconds("x", 1.0), None);
    }

    #[test]
    fn a_column_of_dates_and_times_is_seconds_since_1970_and_said() {
        let cells = ["2023-04-18 11:03:34.100", "2023-04-18 11:03:34.200"];
        for name in ["timestamp", "datetime", "Time"] {
            let c = of(name, &cells).unwrap_or_else(|| panic!("{name} is a time"));
            assert_eq!(c.unit_s, 1.0, "{name}");
            assert!(c.inferred.contains("dates and times"), "{}", c.inferred);
            let (a, b) = (seconds(cells[0], c.unit_s), seconds(cells[1], c.unit_s));
            let step = b.unwrap() - a.unwrap();
            assert!((step - 0.1).abs() < 1e-6, "{step}");
            assert!((a.unwrap() - 1_681_815_814.1).abs() < 1e-6);
        }
        // Whatever unit the name gives, a date and time is seconds since 1970.
        assert_eq!(seconds("1970-01-01T00:00:02Z", 1e-3), Some(2.0));
        // An unnamed first column of dates (pandas' index) is the time; of numbers, it is not.
        let h = header(&["", "depth_m"]);
        let r = [vec!["2023-04-18 11:03:34.1".to_string(), "1.5".into()]];
        let c = clock(&h, r.iter().map(|r| r.as_slice()), None).unwrap();
        assert_eq!((c.column, c.unit_s), (0, 1.0));
        assert!(c.inferred.contains("pandas"), "{}", c.inferred);
        let r = [vec!["0".to_string(), "1.5".into()]];
        assert_eq!(clock(&h, r.iter().map(|r| r.as_slice()), None), None);
        // A column of numbers with one date among them is not read as dates.
        let c = of("time", &["0.5", "2023-04-18 11:03:34"]).unwrap();
        assert!(c.inferred.is_empty(), "{}", c.inferred);
    }
}
