//! Simulated time: whole minutes since the start of a trial (minute 0 is
//! 00:00 of day 1). Days are numbered from 1 as in the paper (D1..D98).

use serde::{Deserialize, Serialize};

/// Minutes in one day.
pub const MINUTES_PER_DAY: i64 = 1440;

/// A point in time, in whole minutes since 00:00 of the first day.
#[derive(
    Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Default, Serialize, Deserialize,
)]
#[serde(transparent)]
pub struct Timestamp(pub i64);

impl Timestamp {
    /// The time `minute_of_day` minutes after midnight of the day with 0-based index `day_index`.
    pub fn from_day_and_minute(day_index: i64, minute_of_day: i64) -> Self {
        Self(day_index * MINUTES_PER_DAY + minute_of_day)
    }
    /// Minutes since the start.
    pub fn minutes(self) -> i64 {
        self.0
    }
    /// 0-based day index (day 1 of the paper is index 0).
    pub fn day_index(self) -> i64 {
        self.0.div_euclid(MINUTES_PER_DAY)
    }
    /// 1-based day number, as the paper counts days (D1, D2, ...).
    pub fn day_number(self) -> i64 {
        self.day_index() + 1
    }
    /// Minutes since the most recent midnight, in 0..1440.
    pub fn minute_of_day(self) -> i64 {
        self.0.rem_euclid(MINUTES_PER_DAY)
    }
    /// Hours since the most recent midnight, as a fraction.
    pub fn hour_of_day(self) -> f64 {
        self.minute_of_day() as f64 / 60.0
    }
    /// This time shifted by `minutes` (which may be negative).
    pub fn plus(self, minutes: i64) -> Self {
        Self(self.0 + minutes)
    }
}

impl std::fmt::Display for Timestamp {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let m = self.minute_of_day();
        write!(f, "D{} {:02}:{:02}", self.day_number(), m / 60, m % 60)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn day_and_minute_helpers_agree() {
        let t = Timestamp::from_day_and_minute(8, 18 * 60 + 30);
        assert_eq!(t.day_index(), 8);
        assert_eq!(t.day_number(), 9);
        assert_eq!(t.minute_of_day(), 1110);
        assert_eq!(t.to_string(), "D9 18:30");
        assert_eq!(Timestamp(-1).day_index(), -1);
        assert_eq!(Timestamp(-1).minute_of_day(), 1439);
    }
}
