//! Times as exports write them: instants with an offset, and local wall
//! times without one, read in the person's zone with the autumn fold
//! resolved by the device's order.

use jiff::civil::DateTime;
use jiff::tz::{AmbiguousOffset, TimeZone};
use jiff::Timestamp;

use crate::error::{IoError, Location};

/// Serialises an instant as RFC 3339 in UTC (for `--json` outputs).
pub fn serialize_instant<S: serde::Serializer>(t: &Timestamp, s: S) -> Result<S::Ok, S::Error> {
    s.collect_str(t)
}

/// Looks up an IANA time zone (the tz database is compiled in, so the
/// result does not depend on the machine).
pub fn zone(name: &str) -> Result<TimeZone, IoError> {
    TimeZone::get(name).map_err(|e| {
        IoError::Settings(format!(
            "unknown time zone \"{name}\" ({e}); use an IANA name such as Europe/Zurich or America/New_York"
        ))
    })
}

/// An instant written with an offset or `Z` (RFC 3339 / ISO 8601, `T` or
/// space between date and time).
pub fn parse_instant(text: &str) -> Option<Timestamp> {
    let t = text.trim();
    if t.len() < 17 {
        return None;
    }
    if t.as_bytes().get(10) == Some(&b' ') {
        let mut s = t.to_string();
        s.replace_range(10..11, "T");
        return s.parse().ok();
    }
    t.parse().ok()
}

/// Whether `text` ends with an offset or `Z` (so it is an instant, not a
/// wall time): `Z`, or `±hh:mm` / `±hhmm` after the time of day.
pub fn has_offset(text: &str) -> bool {
    let b = text.trim().as_bytes();
    if matches!(b.last(), Some(b'Z' | b'z')) {
        return true;
    }
    if b.len() <= 16 {
        return false;
    }
    let tail = &b[b.len() - 6..];
    tail[0] == b'+' || tail[0] == b'-' || tail[1] == b'+' || tail[1] == b'-'
}

/// Order of day and month in a numeric date.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DateOrder {
    /// 2024-05-01 (ISO).
    YearFirst,
    /// 01-05-2024, 01.05.2024, 01/05/2024 (most of Europe).
    DayFirst,
    /// 05-01-2024, 05/01/2024 (the United States).
    MonthFirst,
}

/// Parses a wall time: a date in `order` (separators `-`, `.` or `/`), a
/// space or `T`, `HH:MM` with optional `:SS` and fraction, and an optional
/// `AM`/`PM`. Day, month and hour may be written without a leading zero
/// (`8/1/18 9:05`); a day-first or month-first date may have a two-digit
/// year, which is 20YY (`8/1/18` is 2018, as the FreeStyle Libre software
/// and CareLink write it); a year-first date has four. Returns `None` for
/// anything else, including impossible dates.
pub fn parse_wall(text: &str, order: DateOrder) -> Option<DateTime> {
    let t = text.trim();
    let (date, rest) = t.split_at(t.find([' ', 'T'])?);
    let rest = rest[1..].trim();
    let mut parts = date.split(['-', '.', '/']);
    let (a, b, c) = (parts.next()?, parts.next()?, parts.next()?);
    if parts.next().is_some() {
        return None;
    }
    let num = |s: &str| -> Option<i32> {
        if s.is_empty() || s.len() > 4 || !s.bytes().all(|b| b.is_ascii_digit()) {
            return None;
        }
        s.parse().ok()
    };
    // A two-digit year is 20YY.
    let year = |s: &str| match s.len() {
        4 => num(s),
        2 => num(s).map(|y| 2000 + y),
        _ => None,
    };
    let day_or_month = |s: &str| if s.len() <= 2 { num(s) } else { None };
    let (y, m, d) = match order {
        DateOrder::YearFirst if a.len() == 4 => (num(a)?, day_or_month(b)?, day_or_month(c)?),
        DateOrder::DayFirst => (year(c)?, day_or_month(b)?, day_or_month(a)?),
        DateOrder::MonthFirst => (year(c)?, day_or_month(a)?, day_or_month(b)?),
        DateOrder::YearFirst => return None,
    };
    let (clock, meridiem) = match rest.rsplit_once(' ') {
        Some((clock, ampm)) => (clock.trim(), Some(ampm.to_ascii_uppercase())),
        None => (rest, None),
    };
    let mut hms = clock.split(':');
    let h = num(hms.next()?)?;
    let mi = num(hms.next()?)?;
    let (s, nanos) = match hms.next() {
        None => (0, 0),
        Some(sec) => {
            let (whole, frac) = sec.split_once('.').unwrap_or((sec, ""));
            let nanos = if frac.is_empty() {
                0
            } else {
                if frac.len() > 9 || !frac.bytes().all(|b| b.is_ascii_digit()) {
                    return None;
                }
                frac.parse::<i32>().ok()? * 10i32.pow(9 - frac.len() as u32)
            };
            (num(whole)?, nanos)
        }
    };
    if hms.next().is_some() {
        return None;
    }
    let h = match meridiem.as_deref() {
        None => h,
        Some("AM") if (1..=12).contains(&h) => h % 12,
        Some("PM") if (1..=12).contains(&h) => h % 12 + 12,
        Some(_) => return None,
    };
    DateTime::new(
        i16::try_from(y).ok()?,
        i8::try_from(m).ok()?,
        i8::try_from(d).ok()?,
        i8::try_from(h).ok()?,
        i8::try_from(mi).ok()?,
        i8::try_from(s).ok()?,
        nanos,
    )
    .ok()
}

/// Turns wall times of one file, in file order, into instants. A wall
/// time in the autumn fold (the repeated hour) is placed by the device's
/// order: the earlier instant unless that would put it before a record
/// already read, then the later one; if both would, it is an error. A wall
/// time in the spring gap does not exist and is an error.
#[derive(Debug)]
pub struct WallClock {
    tz: TimeZone,
    last: Option<Timestamp>,
}

impl WallClock {
    /// Wall times in `tz`.
    pub fn new(tz: TimeZone) -> Self {
        Self { tz, last: None }
    }

    /// Both instants of `dt` (earlier, later) when it falls in the autumn
    /// fold; `None` for any other wall time.
    pub fn fold(&self, dt: DateTime) -> Option<(Timestamp, Timestamp)> {
        match self.tz.to_ambiguous_timestamp(dt).offset() {
            AmbiguousOffset::Fold { before, after } => {
                Some((before.to_timestamp(dt).ok()?, after.to_timestamp(dt).ok()?))
            }
            _ => None,
        }
    }

    /// Records an instant placed by other evidence (a transmitter's
    /// clock), so that the order rule of [`WallClock::resolve`] counts it.
    pub fn place(&mut self, ts: Timestamp) {
        if self.last.is_none_or(|l| ts > l) {
            self.last = Some(ts);
        }
    }

    /// The zone's name (for messages).
    pub fn zone_name(&self) -> &str {
        self.tz.iana_name().unwrap_or("the given zone")
    }

    /// The instant of `dt`, read at `at` (for errors) in `field`.
    pub fn resolve(
        &mut self,
        dt: DateTime,
        at: &Location,
        field: &str,
    ) -> Result<Timestamp, IoError> {
        let amb = self.tz.to_ambiguous_timestamp(dt);
        let zone = self.tz.iana_name().unwrap_or("the given zone");
        let ts = match amb.offset() {
            AmbiguousOffset::Unambiguous { offset } => offset.to_timestamp(dt),
            AmbiguousOffset::Gap { .. } => {
                return Err(IoError::invalid(
                    at.clone(),
                    field,
                    format!(
                        "{dt} does not exist in {zone} (clocks skip that hour at the spring \
                         transition); the device clock and --tz disagree"
                    ),
                ))
            }
            AmbiguousOffset::Fold { before, after } => {
                let early = before.to_timestamp(dt);
                let late = after.to_timestamp(dt);
                match (early, late, self.last) {
                    (Ok(e), _, Some(last)) if e > last => Ok(e),
                    (Ok(e), _, None) => Ok(e),
                    (_, Ok(l), Some(last)) if l > last => Ok(l),
                    _ => {
                        return Err(IoError::invalid(
                            at.clone(),
                            field,
                            format!(
                                "{dt} occurs twice in {zone} (the autumn transition) and the \
                                 records around it do not say which: neither instant follows \
                                 the previous record"
                            ),
                        ))
                    }
                }
            }
        }
        .map_err(|e| IoError::invalid(at.clone(), field, format!("{dt}: {e}")))?;
        if self.last.is_none_or(|l| ts > l) {
            self.last = Some(ts);
        }
        Ok(ts)
    }
}

/// Days since 1970-01-01 of a civil date (proleptic Gregorian).
pub fn epoch_day(date: jiff::civil::Date) -> i64 {
    let (y, m, d) = (
        i64::from(date.year()),
        i64::from(date.month()),
        i64::from(date.day()),
    );
    let y = if m <= 2 { y - 1 } else { y };
    let era = y.div_euclid(400);
    let yoe = y - era * 400;
    let mp = (m + 9) % 12;
    let doy = (153 * mp + 2) / 5 + d - 1;
    let doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
    era * 146_097 + doe - 719_468
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    #[test]
    fn wall_times_in_every_date_order() {
        let want = DateTime::new(2024, 5, 1, 0, 3, 0, 0).unwrap();
        assert_eq!(
            parse_wall("2024-05-01 00:03", DateOrder::YearFirst),
            Some(want)
        );
        assert_eq!(
            parse_wall("2024-05-01T00:03:00", DateOrder::YearFirst),
            Some(want)
        );
        assert_eq!(
            parse_wall("01-05-2024 00:03", DateOrder::DayFirst),
            Some(want)
        );
        assert_eq!(
            parse_wall("01.05.2024 00:03", DateOrder::DayFirst),
            Some(want)
        );
        assert_eq!(
            parse_wall("05-01-2024 12:03 AM", DateOrder::MonthFirst),
            Some(want)
        );
        assert_eq!(
            parse_wall("05/01/2024 12:03 am", DateOrder::MonthFirst),
            Some(want)
        );
        assert_eq!(
            parse_wall("05/01/2024 12:03 PM", DateOrder::MonthFirst).map(|d| d.hour()),
            Some(12)
        );
        // Without leading zeros, and with a two-digit year (20YY).
        let august = DateTime::new(2018, 8, 1, 9, 5, 0, 0).unwrap();
        for (text, order) in [
            ("8/1/18 9:05", DateOrder::MonthFirst),
            ("8/1/2018 09:05", DateOrder::MonthFirst),
            ("08/01/18 9:05", DateOrder::MonthFirst),
            ("1-8-18 09:05 AM", DateOrder::DayFirst),
            ("1.8.2018 9:05", DateOrder::DayFirst),
        ] {
            assert_eq!(parse_wall(text, order), Some(august), "{text}");
        }
        // A year-first date needs its four digits.
        assert_eq!(parse_wall("18-08-01 09:05", DateOrder::YearFirst), None);
        for bad in [
            "",
            "2024-05-01",
            "8/1/018 09:05",
            "008/1/2018 09:05",
            "31-02-2024 00:00",
            "2024-05-01 25:00",
            "x y",
        ] {
            assert_eq!(parse_wall(bad, DateOrder::DayFirst), None, "{bad}");
            assert_eq!(parse_wall(bad, DateOrder::YearFirst), None, "{bad}");
        }
    }

    #[test]
    fn instants_with_every_offset_spelling() {
        let want: Timestamp = "2023-11-17T02:32:37.089Z".parse().unwrap();
        for text in [
            "2023-11-17T03:32:37.089+01:00",
            "2023-11-17T03:32:37.089+0100",
            "2023-11-17 03:32:37.089+01:00",
            "2023-11-17T02:32:37.089Z",
        ] {
            assert_eq!(parse_instant(text), Some(want), "{text}");
            assert!(has_offset(text), "{text}");
        }
        assert!(!has_offset("2023-11-17T03:32:37"));
        assert!(!has_offset("2023-11-17 03:32é"));
        assert_eq!(parse_instant("2023-11-17T03:32:37"), None);
    }

    #[test]
    fn epoch_days_agree_with_jiff() {
        for (y, m, d) in [(1970, 1, 1), (1961, 4, 12), (2000, 2, 29), (2026, 12, 31)] {
            let date = jiff::civil::date(y, m, d);
            let ts = date.to_zoned(TimeZone::UTC).unwrap().timestamp();
            assert_eq!(epoch_day(date) * 86_400, ts.as_second());
        }
    }
}
