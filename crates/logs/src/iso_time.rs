//! Date-time cells in a CSV log's time column. Spreadsheets, pandas (`to_csv` of a
//! `DatetimeIndex`), QGroundControl's telemetry CSV and many loggers write the time as a date
//! and a time of day (ISO 8601 and its common relaxations) rather than a number:
//! `2023-04-18 11:03:34.123`, `2023-04-18T11:03:34.123456Z`, `2023/04/18 11:03:34+02:00`.
//! Such a cell is read as seconds since 1970-01-01 00:00 UTC (the Unix epoch every other log
//! here is timed on), in the zone the cell gives, UTC where it gives none.

/// Seconds since the Unix epoch of a date-time cell, or `None` when the cell is not one: a
/// date `YYYY-MM-DD` (or `YYYY/MM/DD`), `T` or a blank, a time `hh:mm[:ss[.fraction]]`, and a
/// zone `Z`, `±hh:mm`, `±hhmm` or `±hh`, or none.
pub fn epoch_seconds(cell: &str) -> Option<f64> {
    let cell = cell.trim();
    let split = cell.find(['T', 't', ' '])?;
    let (date, rest) = (&cell[..split], cell[split + 1..].trim_start());
    let days = days_of(date)?;
    let (clock, offset_s) = zone(rest)?;
    let (whole_s, fraction) = time_of_day(clock)?;
    let whole = days * 86_400 + whole_s - offset_s;
    Some(whole as f64 + fraction)
}

/// Days since 1970-01-01 of a date `YYYY-MM-DD` or `YYYY/MM/DD`.
fn days_of(date: &str) -> Option<i64> {
    let sep = if date.contains('/') { '/' } else { '-' };
    let mut parts = date.split(sep);
    let year: i64 = digits(parts.next()?, 4)?;
    let month: i64 = digits(parts.next()?, 2)?;
    let day: i64 = digits(parts.next()?, 2)?;
    if parts.next().is_some() || !(1..=12).contains(&month) {
        return None;
    }
    let leap = (year % 4 == 0 && year % 100 != 0) || year % 400 == 0;
    let length = match month {
        2 if leap => 29,
        2 => 28,
        4 | 6 | 9 | 11 => 30,
        _ => 31,
    };
    (1..=length)
        .contains(&day)
        .then(|| days_from_civil(year, month, day))
}

/// Days since 1970-01-01 of a date in the proleptic Gregorian calendar (H. Hinnant's
/// `days_from_civil`, exact for every year).
fn days_from_civil(year: i64, month: i64, day: i64) -> i64 {
    let y = if month <= 2 { year - 1 } else { year };
    let era = y.div_euclid(400);
    let year_of_era = y - era * 400;
    let march_based = (month + 9) % 12;
    let day_of_year = (153 * march_based + 2) / 5 + day - 1;
    let day_of_era = year_of_era * 365 + year_of_era / 4 - year_of_era / 100 + day_of_year;
    era * 146_097 + day_of_era - 719_468
}

/// The time of day and the zone's offset east of UTC, s, of what follows the date.
fn zone(rest: &str) -> Option<(&str, i64)> {
    let rest = rest.trim();
    if let Some(clock) = rest.strip_suffix(['Z', 'z']) {
        return Some((clock.trim_end(), 0));
    }
    // A sign after the time's first character starts a zone (a time has no sign of its own).
    let sign_at = rest
        .char_indices()
        .skip(1)
        .find(|(_, c)| matches!(c, '+' | '-'));
    let Some((at, _)) = sign_at else {
        return Some((rest, 0));
    };
    let (clock, zone) = (rest[..at].trim_end(), &rest[at..]);
    let sign = if zone.starts_with('-') { -1 } else { 1 };
    let zone = zone[1..].replace(':', "");
    if !zone.bytes().all(|b| b.is_ascii_digit()) {
        return None;
    }
    let (hours, minutes): (i64, i64) = match zone.len() {
        2 => (digits(&zone, 2)?, 0),
        4 => (digits(&zone[..2], 2)?, digits(&zone[2..], 2)?),
        _ => return None,
    };
    (hours <= 18 && minutes < 60).then_some((clock, sign * (hours * 3600 + minutes * 60)))
}

/// Whole seconds since midnight and the fraction of a second of `hh:mm[:ss[.fraction]]`.
fn time_of_day(clock: &str) -> Option<(i64, f64)> {
    let mut parts = clock.split(':');
    let hours: i64 = digits(parts.next()?, 2)?;
    let minutes: i64 = digits(parts.next()?, 2)?;
    let (seconds, fraction) = match parts.next() {
        None => (0, 0.0),
        Some(s) => {
            let (whole, fraction) = s.split_once(['.', ',']).unwrap_or((s, ""));
            let fraction = match fraction {
                "" => 0.0,
                f if f.bytes().all(|b| b.is_ascii_digit()) => format!("0.{f}").parse().ok()?,
                _ => return None,
            };
            (digits(whole, 2)?, fraction)
        }
    };
    let valid = parts.next().is_none() && hours < 24 && minutes < 60 && seconds <= 60;
    valid.then_some((hours * 3600 + minutes * 60 + seconds, fraction))
}

/// A field of exactly `width` ASCII digits.
fn digits(field: &str, width: usize) -> Option<i64> {
    (field.len() == width && field.bytes().all(|b| b.is_ascii_digit()))
        .then(|| field.parse().ok())
        .flatten()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dates_and_times_are_seconds_since_1970_in_utc() {
        assert_eq!(epoch_seconds("1970-01-01 00:00:00"), Some(0.0));
        // `date -u -d '2023-04-18 11:03:34' +%s` = 1681815814
        assert_eq!(epoch_seconds("2023-04-18 11:03:34"), Some(1_681_815_814.0));
        assert_eq!(epoch_seconds("2023-04-18T11:03:34Z"), Some(1_681_815_814.0));
        assert_eq!(epoch_seconds("2023/04/18 11:03:34"), Some(1_681_815_814.0));
        assert_eq!(epoch_seconds("2023-04-18T11:03"), Some(1_681_815_780.0));
        let ms = epoch_seconds("2023-04-18 11:03:34.123").unwrap();
        assert!((ms - 1_681_815_814.123).abs() < 1e-6, "{ms}");
        let us = epoch_seconds("2023-04-18T11:03:34.000250Z").unwrap();
        assert!((us - 1_681_815_814.000_25).abs() < 1e-6, "{us}");
        // A zone east of UTC is earlier in UTC; one west of it later.
        for zoned in ["2023-04-18T13:03:34+02:00", "2023-04-18 13:03:34 +0200"] {
            assert_eq!(epoch_seconds(zoned), Some(1_681_815_814.0), "{zoned}");
        }
        assert_eq!(
            epoch_seconds("2023-04-18T06:03:34-05"),
            Some(1_681_815_814.0)
        );
        // Leap days (2000 is one: a century divisible by 400), and a time before 1970.
        assert_eq!(epoch_seconds("2024-02-29 00:00:00"), Some(1_709_164_800.0));
        assert_eq!(epoch_seconds("2000-03-01 00:00:00"), Some(951_868_800.0));
        assert_eq!(epoch_seconds("1969-12-31 23:59:59"), Some(-1.0));
    }

    #[test]
    fn what_is_no_date_and_time_is_none() {
        for cell in [
            "1681815814.5",
            "2023-04-18",
            "2023-02-29 00:00:00",
            "2023-13-01 00:00:00",
            "2023-04-18 25:00:00",
            "2023-04-18 11:61:00",
            "23-04-18 11:03:34",
            "2023-04-18 11:03:34.12x",
            "2023-04-18 11:03:34+2",
            "18/04/2023 11:03:34",
            "2023-04-18 µ",
            "2023-04-18 11:03:34+aµb",
            "",
        ] {
            assert_eq!(epoch_seconds(cell), None, "{cell}");
        }
    }
}
