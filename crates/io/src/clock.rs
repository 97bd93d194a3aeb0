//! The advisor's clock for a real person: days counted from the person's
//! first day, minutes of local wall time. This is the one place where
//! wall-clock instants meet [`abba_core::Timestamp`].
//!
//! Daylight saving: a 23-hour day simply has no minutes in its skipped
//! hour. On a 25-hour day the repeated hour's 120 real minutes are mapped
//! at half speed onto its 60 wall minutes (first pass onto the first half,
//! second pass onto the second), so no reading is lost, duplicated or
//! reordered.

use abba_core::time::MINUTES_PER_DAY;
use abba_core::Timestamp;
use jiff::civil::{Date, DateTime};
use jiff::tz::{AmbiguousOffset, TimeZone};

use crate::error::IoError;
use crate::time::epoch_day;

/// Instants ↔ advisor time for one person.
#[derive(Debug, Clone)]
pub struct AdvisorClock {
    tz: TimeZone,
    first_day: Date,
}

impl AdvisorClock {
    /// Day 1 (index 0) is `first_day` in `tz`.
    pub fn new(tz: TimeZone, first_day: Date) -> Self {
        Self { tz, first_day }
    }
    /// The person's zone.
    pub fn tz(&self) -> &TimeZone {
        &self.tz
    }
    /// The first day.
    pub fn first_day(&self) -> Date {
        self.first_day
    }
    /// The local date of an instant.
    pub fn local_date(&self, at: jiff::Timestamp) -> Date {
        self.tz.to_datetime(at).date()
    }

    /// The advisor's time of an instant (may be negative before day 1).
    pub fn timestamp(&self, at: jiff::Timestamp) -> Timestamp {
        let dt = self.tz.to_datetime(at);
        let day = epoch_day(dt.date()) - epoch_day(self.first_day);
        let wall = i64::from(dt.hour()) * 60 + i64::from(dt.minute());
        let minute = match self.tz.to_ambiguous_timestamp(dt).offset() {
            AmbiguousOffset::Fold { before, after } => {
                let len = i64::from((before.seconds() - after.seconds()) / 60).max(1);
                let start = self.fold_start(dt.date(), wall);
                let second_pass = self.tz.to_offset(at) == after;
                start + (wall - start + if second_pass { len } else { 0 }) / 2
            }
            _ => wall,
        };
        Timestamp::from_day_and_minute(day, minute)
    }

    /// The first wall minute of the fold containing wall minute `wall` of `date`.
    fn fold_start(&self, date: Date, wall: i64) -> i64 {
        let mut m = wall;
        while m > 0 {
            let dt = date.at(((m - 1) / 60) as i8, ((m - 1) % 60) as i8, 0, 0);
            if !matches!(
                self.tz.to_ambiguous_timestamp(dt).offset(),
                AmbiguousOffset::Fold { .. }
            ) {
                break;
            }
            m -= 1;
        }
        m
    }

    /// The instant of an advisor time (the inverse of [`Self::timestamp`]
    /// wherever the wall minute exists; a minute in the spring gap is
    /// moved forward by the gap's length).
    pub fn instant(&self, t: Timestamp) -> Result<jiff::Timestamp, IoError> {
        let date = self
            .first_day
            .checked_add(jiff::Span::new().days(t.day_index()))
            .map_err(|e| IoError::Settings(format!("{t} is outside the calendar: {e}")))?;
        let m = t.minute_of_day();
        debug_assert!(m < MINUTES_PER_DAY);
        let civil = |m: i64| -> DateTime { date.at((m / 60) as i8, (m % 60) as i8, 0, 0) };
        let dt = civil(m);
        let bad = |e: jiff::Error| IoError::Settings(format!("{t}: {e}"));
        match self.tz.to_ambiguous_timestamp(dt).offset() {
            AmbiguousOffset::Fold { before, after } => {
                let len = i64::from((before.seconds() - after.seconds()) / 60).max(1);
                let start = self.fold_start(date, m);
                let real = 2 * (m - start);
                if real < len {
                    before.to_timestamp(civil(start + real)).map_err(bad)
                } else {
                    after.to_timestamp(civil(start + real - len)).map_err(bad)
                }
            }
            _ => self.tz.to_ambiguous_timestamp(dt).compatible().map_err(bad),
        }
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    #[test]
    fn the_repeated_hour_maps_at_half_speed_and_back() {
        let tz = TimeZone::get("Europe/Zurich").unwrap();
        let clock = AdvisorClock::new(tz, jiff::civil::date(2024, 10, 27));
        // 02:00 CEST = 00:00Z (first pass), 02:00 CET = 01:00Z (second pass).
        let at = |s: &str| s.parse::<jiff::Timestamp>().unwrap();
        assert_eq!(clock.timestamp(at("2024-10-27T00:00:00Z")), Timestamp(120));
        assert_eq!(clock.timestamp(at("2024-10-27T00:30:00Z")), Timestamp(135));
        assert_eq!(clock.timestamp(at("2024-10-27T01:00:00Z")), Timestamp(150));
        assert_eq!(clock.timestamp(at("2024-10-27T01:58:00Z")), Timestamp(179));
        assert_eq!(clock.timestamp(at("2024-10-27T02:00:00Z")), Timestamp(180));
        for m in [120, 135, 150, 179, 180, 0, 1439] {
            assert_eq!(
                clock.timestamp(clock.instant(Timestamp(m)).unwrap()),
                Timestamp(m),
                "{m}"
            );
        }
        // Spring: 02:00-02:59 does not exist on 31 March; 03:00 CEST is minute 180.
        let spring = AdvisorClock::new(
            TimeZone::get("Europe/Zurich").unwrap(),
            jiff::civil::date(2024, 3, 31),
        );
        assert_eq!(spring.timestamp(at("2024-03-31T01:00:00Z")), Timestamp(180));
        assert_eq!(spring.timestamp(at("2024-03-31T00:59:00Z")), Timestamp(119));
    }
}
