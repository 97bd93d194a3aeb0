//! A MiniMed pump's clock across a daylight-saving change. The pump keeps
//! the time it was set to: it does not follow the clocks' change, the
//! person sets it by hand, and CareLink writes each setting as rows with
//! `New Device Time` (the first of them, in the pump's order, at the old
//! clock's time: `1:32:01` with New Device Time `1:30`, as in real
//! exports). Until that setting the pump writes its rows on the offset it
//! kept, so read on the zone's new offset they would be an hour off: an
//! hour repeated in autumn, an hour that does not exist in spring.
//!
//! A setting by the zone's shift (within [`SHIFT_TOLERANCE_S`]) made
//! within [`SETTING_WINDOW_S`] after a change (or before one: set the
//! evening before) is such a correction: the rows written on the pump's
//! clock between the change and the setting are placed at the offset
//! that clock kept, and the file's note says which.
//!
//! A setting by the zone's shift made later (weeks after the change,
//! before the next one) is a correction too when the section shows the
//! pump's clock across the change: its rows begin before the change, no
//! other setting of 30 minutes or more came between the change and this
//! one (the pump kept the old offset all along), and none after it sets
//! the clock back the other way before the next change (a trip there and
//! back, not a correction). Any other setting (a trip, a clock set right
//! by minutes) changes nothing here.

use jiff::civil::DateTime;
use jiff::tz::{Offset, TimeZone};
use jiff::{SignedDuration, Timestamp};

/// How far a setting may differ from the zone's shift (s): set by hand,
/// to the minute.
pub const SHIFT_TOLERANCE_S: i64 = 600;

/// How long before or after the zone's change the pump's clock may be set
/// for the setting to be taken as the change (s): a week.
pub const SETTING_WINDOW_S: i64 = 7 * 86_400;

/// A setting of the pump's clock: the row (line) at the old clock's time
/// and the time it was set to.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Setting {
    /// The line of the row at the old clock's time.
    pub line: u64,
    /// The old clock's time of the setting (the row's date and time).
    pub from: DateTime,
    /// The time it was set to (`New Device Time`).
    pub to: DateTime,
}

/// A setting that followed (or anticipated) a change of the zone's clocks.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Shift {
    setting: Setting,
    /// The zone's change.
    transition: Timestamp,
    /// The zone's offset before and after it.
    before: Offset,
    after: Offset,
    /// The instant of the setting (the old clock, on `before`).
    at: Timestamp,
}

/// How long after a change (s) a setting by its shift may still be its
/// correction: half a year (clocks change twice a year).
const LATE_MAX_S: i64 = 183 * 86_400;

/// How far (s) a setting moves the clock to be more than one set right
/// by minutes.
const LARGE_S: i64 = 1800;

/// The settings among `settings` (oldest first) that are a daylight-saving
/// change of `tz` (see the module documentation); `first_row` is the wall
/// time of the section's oldest row.
pub fn shifts(tz: &TimeZone, settings: &[Setting], first_row: Option<DateTime>) -> Vec<Shift> {
    let mut out = Vec::new();
    for (i, &s) in settings.iter().enumerate() {
        let delta = s.to.duration_since(s.from).as_secs();
        if delta.abs() < LARGE_S {
            continue; // a clock set right by minutes
        }
        // The zone's changes within the window around the old clock's time.
        let Ok(rough) = tz.to_timestamp(s.from) else {
            continue;
        };
        let window = SignedDuration::from_secs(SETTING_WINDOW_S + 86_400);
        let (Ok(lo), Ok(hi)) = (rough.checked_sub(window), rough.checked_add(window)) else {
            continue;
        };
        let found = tz
            .following(lo)
            .take_while(|t| t.timestamp() <= hi)
            .find_map(|t| {
                let transition = t.timestamp();
                let before =
                    tz.to_offset(transition.checked_sub(SignedDuration::from_secs(1)).ok()?);
                let after = t.offset();
                let shift = i64::from(after.seconds() - before.seconds());
                let at = before.to_timestamp(s.from).ok()?;
                let near = at.duration_since(transition).as_secs().abs() <= SETTING_WINDOW_S;
                ((delta - shift).abs() <= SHIFT_TOLERANCE_S && shift != 0 && near).then_some(
                    Shift {
                        setting: s,
                        transition,
                        before,
                        after,
                        at,
                    },
                )
            });
        match found {
            Some(shift) => out.push(shift),
            None => out.extend(late(tz, settings, i, first_row)),
        }
    }
    out
}

/// The setting `settings[i]` as a correction made more than
/// [`SETTING_WINDOW_S`] after the zone's latest change before it, when the
/// section shows the pump's clock kept the old offset until then (see the
/// module documentation).
fn late(
    tz: &TimeZone,
    settings: &[Setting],
    i: usize,
    first_row: Option<DateTime>,
) -> Option<Shift> {
    let s = settings[i];
    let delta = s.to.duration_since(s.from).as_secs();
    let rough = tz.to_timestamp(s.from).ok()?;
    let t = tz.preceding(rough).next()?;
    let transition = t.timestamp();
    let before = tz.to_offset(transition.checked_sub(SignedDuration::from_secs(1)).ok()?);
    let after = t.offset();
    let shift = i64::from(after.seconds() - before.seconds());
    if shift == 0 || (delta - shift).abs() > SHIFT_TOLERANCE_S {
        return None;
    }
    // On the old clock (the offset kept), after the change.
    let at = before.to_timestamp(s.from).ok()?;
    // After the change, and within half a year of it (a zone that stopped
    // changing its clocks has no next change to bound it).
    if at <= transition || at.duration_since(transition).as_secs() > LATE_MAX_S {
        return None;
    }
    // The section's rows begin before the change.
    let first = before.to_timestamp(first_row?).ok()?;
    if first >= transition {
        return None;
    }
    let large = |o: &Setting| o.to.duration_since(o.from).as_secs().abs() >= LARGE_S;
    let on_old_clock = |o: &Setting| before.to_timestamp(o.from).ok();
    // No other large setting between the change and this one.
    if settings[..i]
        .iter()
        .any(|o| large(o) && on_old_clock(o).is_some_and(|a| a > transition))
    {
        return None;
    }
    // None after it sets the clock back the other way before the next
    // change (a trip there and back).
    let next = tz.following(transition).next().map(|n| n.timestamp());
    let back = settings[i + 1..].iter().any(|o| {
        let d = o.to.duration_since(o.from).as_secs();
        (d + delta).abs() <= SHIFT_TOLERANCE_S
            && after
                .to_timestamp(o.from)
                .is_ok_and(|a| next.is_none_or(|n| a < n))
    });
    (!back).then_some(Shift {
        setting: s,
        transition,
        before,
        after,
        at,
    })
}

/// Places one section's rows (in the pump's order, oldest first) by the
/// shifts: `Some(instant)` for a row written on the offset the pump's
/// clock kept, `None` for a row the zone places.
pub struct Placer<'s> {
    shifts: &'s [Shift],
    state: Vec<State>,
}

/// Where one shift's rows are in a section.
#[derive(Debug, Clone, Default)]
struct State {
    /// The setting was passed (a row on the new clock was seen).
    passed: bool,
    /// The latest instant read on the old clock.
    latest: Option<Timestamp>,
    /// Rows placed at the offset the pump kept: count, first and last line.
    placed: usize,
    lines: Option<(u64, u64)>,
}

impl<'s> Placer<'s> {
    /// A placer of one section by `shifts`.
    pub fn new(shifts: &'s [Shift]) -> Self {
        Self {
            shifts,
            state: vec![State::default(); shifts.len()],
        }
    }

    /// The instant of a row written at `wall` (line `line`) on the pump's
    /// clock, when a shift places it.
    pub fn place(&mut self, wall: DateTime, line: u64) -> Option<Timestamp> {
        for (s, st) in self.shifts.iter().zip(self.state.iter_mut()) {
            let (Ok(old), Ok(new)) = (s.before.to_timestamp(wall), s.after.to_timestamp(wall))
            else {
                continue;
            };
            let first = s.transition.min(s.at);
            let day = SignedDuration::from_hours(24);
            if first.checked_sub(day).is_ok_and(|lo| old < lo) && !st.passed {
                continue; // long before the change and the setting
            }
            let half = SignedDuration::from_secs(
                (s.after.seconds() - s.before.seconds()).unsigned_abs() as i64 / 2,
            );
            if !st.passed {
                // On the new clock: past the setting's instant, or back by
                // more than half the shift (the autumn's repeated hour).
                let ahead = s.at.checked_add(half).is_ok_and(|a| old > a);
                let back = st
                    .latest
                    .and_then(|l| l.checked_sub(half).ok())
                    .is_some_and(|l| old < l);
                st.passed = ahead || back;
            }
            let placed = if st.passed {
                (new < s.transition).then_some(new)
            } else {
                st.latest = st.latest.max(Some(old));
                (old >= s.transition).then_some(old)
            };
            if let Some(t) = placed {
                st.placed += 1;
                st.lines = Some(
                    st.lines
                        .map_or((line, line), |(a, b)| (a.min(line), b.max(line))),
                );
                return Some(t);
            }
        }
        None
    }

    /// What was placed, in words (one note a shift that placed rows).
    pub fn notes(&self, tz: &TimeZone, section: &str) -> Vec<String> {
        let zone = tz.iana_name().unwrap_or("the zone");
        self.shifts
            .iter()
            .zip(&self.state)
            .filter(|(_, st)| st.placed > 0)
            .map(|(s, st)| {
                let (a, b) = st.lines.unwrap_or((0, 0));
                let lines = if a == b {
                    format!("line {a}")
                } else {
                    format!("lines {a}-{b}")
                };
                let (kept, when) = if s.at >= s.transition {
                    (s.before, "after")
                } else {
                    (s.after, "before")
                };
                format!(
                    "the pump's clock was set from {} to {} (line {}, New Device Time), {when} \
                     {zone}'s clocks changed from {} to {} ({}): {} rows of {section} written on \
                     the pump's clock between the two ({lines}) were placed at the offset it kept \
                     ({}), not an hour off",
                    s.setting.from,
                    s.setting.to,
                    s.setting.line,
                    utc(s.before),
                    utc(s.after),
                    s.transition,
                    st.placed,
                    utc(kept)
                )
            })
            .collect()
    }
}

/// An offset as `UTC+02:00`.
fn utc(o: Offset) -> String {
    let s = o.seconds();
    let sign = if s < 0 { '-' } else { '+' };
    let m = s.unsigned_abs() / 60;
    format!("UTC{sign}{:02}:{:02}", m / 60, m % 60)
}

#[cfg(test)]
mod tests {
    use super::*;
    use jiff::civil::datetime;

    fn zurich() -> TimeZone {
        TimeZone::get("Europe/Zurich").unwrap()
    }

    #[test]
    fn a_setting_by_the_shift_after_the_autumn_change_is_one() {
        // 2026-10-25 03:00 CEST -> 02:00 CET; the pump set back at 09:00.
        let s = Setting {
            line: 10,
            from: datetime(2026, 10, 25, 9, 0, 0, 0),
            to: datetime(2026, 10, 25, 8, 0, 0, 0),
        };
        let shifts = shifts(&zurich(), &[s], None);
        assert_eq!(shifts.len(), 1);
        let mut p = Placer::new(&shifts);
        // Before the change: the zone places it.
        assert_eq!(p.place(datetime(2026, 10, 25, 1, 30, 0, 0), 1), None);
        // 05:00 on the pump's summer clock is 04:00 CET (03:00 UTC).
        let t = p.place(datetime(2026, 10, 25, 5, 0, 0, 0), 2).unwrap();
        assert_eq!(t.to_string(), "2026-10-25T03:00:00Z");
        // 08:59 on the old clock, then 08:00 on the new one: the zone's.
        assert!(p.place(datetime(2026, 10, 25, 8, 59, 0, 0), 3).is_some());
        assert_eq!(p.place(datetime(2026, 10, 25, 8, 0, 5, 0), 4), None);
        assert_eq!(p.place(datetime(2026, 10, 25, 8, 30, 0, 0), 5), None);
    }

    #[test]
    fn a_setting_the_evening_before_the_change_places_the_rows_after_it() {
        // Set back at 22:00 CEST on the 24th, before the change at 01:00
        // UTC on the 25th: the pump runs on winter time while Zurich is
        // still on summer time.
        let s = Setting {
            line: 10,
            from: datetime(2026, 10, 24, 22, 0, 0, 0),
            to: datetime(2026, 10, 24, 21, 0, 0, 0),
        };
        let shifts = shifts(&zurich(), &[s], None);
        assert_eq!(shifts.len(), 1);
        let mut p = Placer::new(&shifts);
        assert_eq!(p.place(datetime(2026, 10, 24, 21, 55, 0, 0), 1), None);
        // 21:00:05 on the new clock (UTC+01:00) is 22:00:05 CEST.
        let t = p.place(datetime(2026, 10, 24, 21, 0, 5, 0), 2).unwrap();
        assert_eq!(t.to_string(), "2026-10-24T20:00:05Z");
        let t = p.place(datetime(2026, 10, 25, 1, 30, 0, 0), 3).unwrap();
        assert_eq!(t.to_string(), "2026-10-25T00:30:00Z");
        // From the change on, the pump's clock is the zone's.
        assert_eq!(p.place(datetime(2026, 10, 25, 2, 0, 0, 0), 4), None);
        assert_eq!(p.notes(&zurich(), "the Pump section").len(), 1);
    }

    #[test]
    fn a_trip_or_a_clock_set_by_minutes_is_not() {
        let minutes = Setting {
            line: 1,
            from: datetime(2026, 10, 25, 9, 2, 0, 0),
            to: datetime(2026, 10, 25, 9, 0, 0, 0),
        };
        let months_later = Setting {
            line: 2,
            from: datetime(2026, 12, 25, 9, 0, 0, 0),
            to: datetime(2026, 12, 25, 8, 0, 0, 0),
        };
        let six_hours = Setting {
            line: 3,
            from: datetime(2026, 10, 25, 9, 0, 0, 0),
            to: datetime(2026, 10, 25, 3, 0, 0, 0),
        };
        assert!(shifts(&zurich(), &[minutes, months_later, six_hours], None).is_empty());
    }

    #[test]
    fn a_setting_by_the_shift_weeks_after_the_change_is_one_when_the_rows_show_it() {
        // Zurich went back on 2026-10-25; the pump is set back only on
        // 2026-11-10 at 09:00 on its summer clock.
        let late = Setting {
            line: 10,
            from: datetime(2026, 11, 10, 9, 0, 0, 0),
            to: datetime(2026, 11, 10, 8, 0, 0, 0),
        };
        let before_change = Some(datetime(2026, 10, 20, 0, 0, 0, 0));
        let found = shifts(&zurich(), &[late], before_change);
        assert_eq!(found.len(), 1);
        let mut p = Placer::new(&found);
        assert_eq!(p.place(datetime(2026, 10, 24, 12, 0, 0, 0), 1), None);
        // A week after the change, 12:00 on the pump's summer clock is
        // 10:00 UTC, not 11:00.
        let t = p.place(datetime(2026, 11, 1, 12, 0, 0, 0), 2).unwrap();
        assert_eq!(t.to_string(), "2026-11-01T10:00:00Z");
        let t = p.place(datetime(2026, 11, 10, 8, 59, 0, 0), 3).unwrap();
        assert_eq!(t.to_string(), "2026-11-10T06:59:00Z");
        // Set: the zone's clock from here on.
        assert_eq!(p.place(datetime(2026, 11, 10, 8, 0, 5, 0), 4), None);
        assert_eq!(p.place(datetime(2026, 11, 10, 9, 30, 0, 0), 5), None);
        // The rows begin after the change: the pump may have been set
        // before them, so this may be a trip.
        let after_change = Some(datetime(2026, 10, 28, 0, 0, 0, 0));
        assert!(shifts(&zurich(), &[late], after_change).is_empty());
        assert!(shifts(&zurich(), &[late], None).is_empty());
        // Set back the other way later (a trip there and back): none.
        let back = Setting {
            line: 20,
            from: datetime(2026, 11, 17, 18, 0, 0, 0),
            to: datetime(2026, 11, 17, 19, 0, 0, 0),
        };
        assert!(shifts(&zurich(), &[late, back], before_change).is_empty());
        // Another setting between the change and this one: the pump's
        // clock was not left on the old offset all along.
        let earlier = Setting {
            line: 5,
            from: datetime(2026, 11, 2, 9, 0, 0, 0),
            to: datetime(2026, 11, 2, 11, 0, 0, 0),
        };
        assert!(shifts(&zurich(), &[earlier, late], before_change)
            .iter()
            .all(|s| s.setting != late));
        // Set forward by the shift after the autumn change: not the
        // change's correction.
        let forward = Setting {
            line: 10,
            from: datetime(2026, 11, 10, 9, 0, 0, 0),
            to: datetime(2026, 11, 10, 10, 0, 0, 0),
        };
        assert!(shifts(&zurich(), &[forward], before_change).is_empty());
    }

    #[test]
    fn a_late_setting_after_the_spring_change_is_one() {
        // Zurich went forward on 2026-03-29; the pump, on winter time, is
        // set forward on 2026-04-12 at 07:00.
        let late = Setting {
            line: 10,
            from: datetime(2026, 4, 12, 7, 0, 0, 0),
            to: datetime(2026, 4, 12, 8, 0, 0, 0),
        };
        let found = shifts(&zurich(), &[late], Some(datetime(2026, 3, 20, 0, 0, 0, 0)));
        assert_eq!(found.len(), 1);
        let mut p = Placer::new(&found);
        // 12:00 on the pump's winter clock on 2026-04-05 is 11:00 UTC.
        let t = p.place(datetime(2026, 4, 5, 12, 0, 0, 0), 1).unwrap();
        assert_eq!(t.to_string(), "2026-04-05T11:00:00Z");
        assert_eq!(p.place(datetime(2026, 4, 12, 8, 0, 5, 0), 2), None);
    }
}
