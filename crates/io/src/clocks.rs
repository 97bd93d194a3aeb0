//! The device's own UTC offsets, where an export carries them, against
//! the person's zone: the one home of that comparison.
//!
//! abba reads a person's local times (meal slots, days) in the zone
//! stored for them, never in the zone a device was set to. Some exports
//! say what offset the device was at: Nightscout's `utcOffset` (minutes,
//! written by xDrip+, AndroidAPS and Loop on entries and treatments; 0
//! says nothing, Nightscout writes it for every time sent in UTC) or a
//! `dateString` / `created_at` written with a non-zero offset; Tidepool's
//! `timezoneOffset` (minutes). (A time written in UTC, `Z` or `+00:00`,
//! says nothing of the device's zone. Tidepool's `conversionOffset` is
//! the device clock's error, not a zone.) The readers note each offset
//! seen ([`crate::read::Ctx::clock`]); a file's offsets become
//! [`ClockStretch`]es (runs of one offset in time order), and
//! [`away`] names the stretches whose offset is not the person's zone's
//! at the time: a trip, a device set to another zone. Nothing is
//! shifted: the words say that meal slots and days there follow the
//! stored zone.

use jiff::tz::TimeZone;
use jiff::Timestamp;
use serde::{Deserialize, Serialize};

/// A run of a file's data (in time order) written at one device offset.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct ClockStretch {
    /// The first instant (ms since the epoch).
    pub first_ms: i64,
    /// The last instant (ms since the epoch).
    pub last_ms: i64,
    /// The device's offset from UTC (seconds east).
    pub offset_s: i32,
    /// How many data carried it.
    pub count: usize,
}

/// The stretches of one file's offsets seen (instant, seconds east; any
/// order): runs of one offset in time order.
pub fn stretches(mut seen: Vec<(Timestamp, i32)>) -> Vec<ClockStretch> {
    seen.sort_by_key(|s| s.0);
    let mut out: Vec<ClockStretch> = Vec::new();
    for (at, offset_s) in seen {
        let ms = at.as_millisecond();
        match out.last_mut() {
            Some(s) if s.offset_s == offset_s => {
                s.last_ms = ms;
                s.count += 1;
            }
            _ => out.push(ClockStretch {
                first_ms: ms,
                last_ms: ms,
                offset_s,
                count: 1,
            }),
        }
    }
    out
}

/// The offset a time written as text carries, in seconds east, when it
/// is not UTC (`None` for `Z`, `+00:00`, no offset or text that is no
/// time).
pub fn text_offset_s(text: &str) -> Option<i32> {
    let t = text.trim();
    if !crate::time::has_offset(t) || t.ends_with(['Z', 'z']) {
        return None;
    }
    let b = t.as_bytes();
    // `±hh:mm` or `±hhmm` at the end, after the time of day.
    let (sign_at, digits) = if b.len() >= 6 && matches!(b[b.len() - 6], b'+' | b'-') {
        (
            b.len() - 6,
            format!("{}{}", &t[b.len() - 5..b.len() - 3], &t[b.len() - 2..]),
        )
    } else if b.len() >= 5 && matches!(b[b.len() - 5], b'+' | b'-') {
        (b.len() - 5, t[b.len() - 4..].to_string())
    } else {
        return None;
    };
    if sign_at <= 10 || !digits.bytes().all(|c| c.is_ascii_digit()) {
        return None;
    }
    let hh: i32 = digits[..2].parse().ok()?;
    let mm: i32 = digits[2..].parse().ok()?;
    let s = (hh * 60 + mm) * 60;
    let s = if b[sign_at] == b'-' { -s } else { s };
    (s != 0).then_some(s)
}

/// Minutes east of UTC as exports write them (`utcOffset`,
/// `timezoneOffset`), when plausible (within ±18 h, as time zones are):
/// seconds east.
pub fn minutes_offset_s(minutes: f64) -> Option<i32> {
    (minutes.is_finite() && minutes.fract() == 0.0 && minutes.abs() <= 18.0 * 60.0)
        .then(|| minutes as i32 * 60)
}

/// A stretch whose device offset is not the person's zone's.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Away {
    /// The stretch.
    pub stretch: ClockStretch,
    /// The zone's offset at its first instant (seconds east).
    pub zone_first_s: i32,
    /// The zone's offset at its last instant (seconds east).
    pub zone_last_s: i32,
}

/// The stretches (of any files, any order) whose device offset differs
/// from `tz`'s at their first or last instant, in time order; stretches
/// of one offset that overlap (two imports of overlapping exports) are
/// one.
pub fn away(stretches: &[ClockStretch], tz: &TimeZone) -> Vec<Away> {
    let zone_s = |ms: i64| {
        Timestamp::from_millisecond(ms)
            .map(|t| tz.to_offset(t).seconds())
            .unwrap_or(0)
    };
    let mut out: Vec<Away> = stretches
        .iter()
        .map(|s| Away {
            stretch: *s,
            zone_first_s: zone_s(s.first_ms),
            zone_last_s: zone_s(s.last_ms),
        })
        .filter(|a| a.stretch.offset_s != a.zone_first_s || a.stretch.offset_s != a.zone_last_s)
        .collect();
    // Two imports of overlapping exports: one stretch.
    out.sort_by_key(|a| (a.stretch.offset_s, a.stretch.first_ms));
    let mut merged: Vec<Away> = Vec::with_capacity(out.len());
    for a in out {
        match merged.last_mut() {
            Some(m)
                if m.stretch.offset_s == a.stretch.offset_s
                    && a.stretch.first_ms <= m.stretch.last_ms =>
            {
                if a.stretch.last_ms > m.stretch.last_ms {
                    m.stretch.last_ms = a.stretch.last_ms;
                    m.zone_last_s = a.zone_last_s;
                }
                m.stretch.count = m.stretch.count.max(a.stretch.count);
            }
            _ => merged.push(a),
        }
    }
    merged.sort_by_key(|a| (a.stretch.first_ms, a.stretch.offset_s));
    merged
}

/// `UTC+02:00`, `UTC-05:00`.
pub fn offset_name(seconds: i32) -> String {
    let sign = if seconds < 0 { '-' } else { '+' };
    let m = seconds.unsigned_abs() / 60;
    format!("UTC{sign}{:02}:{:02}", m / 60, m % 60)
}

/// The sentences for the stretches of `stretches` away from `tz` (see
/// [`away`]): each with its first and last instant (UTC), the offset the
/// device was at and the zone's, and that meal slots and days there
/// follow the stored zone.
pub fn notes(stretches: &[ClockStretch], tz: &TimeZone) -> Vec<String> {
    let zone = tz.iana_name().unwrap_or("the stored zone");
    let away = away(stretches, tz);
    let mut out: Vec<String> = away
        .iter()
        .take(MAX_NOTES)
        .map(|a| {
            let at = |ms: i64| local(ms, tz);
            let zone_offset = if a.zone_first_s == a.zone_last_s {
                offset_name(a.zone_first_s)
            } else {
                format!(
                    "{} to {}",
                    offset_name(a.zone_first_s),
                    offset_name(a.zone_last_s)
                )
            };
            format!(
                "from {} to {} the device's clock was at {}, {zone}'s at {zone_offset} \
                 (a trip, or a device set to another zone?): abba does not shift these times; \
                 their meal slots and days follow {zone}",
                at(a.stretch.first_ms),
                at(a.stretch.last_ms),
                offset_name(a.stretch.offset_s),
            )
        })
        .collect();
    // Offsets that change back and forth (two uploaders set to different
    // zones writing into one collection) would make a sentence each.
    if let Some(last) = away.last().filter(|_| away.len() > MAX_NOTES) {
        let until = local(last.stretch.last_ms, tz);
        out.push(format!(
            "and {} more stretches away from {zone}'s offset, until {until}",
            away.len() - MAX_NOTES
        ));
    }
    out
}

/// A Unix-ms instant as the person reads it: local date and minute in
/// their zone (as every time the advice shows).
fn local(ms: i64, tz: &TimeZone) -> String {
    Timestamp::from_millisecond(ms)
        .map(|t| {
            t.round(jiff::Unit::Minute)
                .unwrap_or(t)
                .to_zoned(tz.clone())
                .strftime("%Y-%m-%d %H:%M")
                .to_string()
        })
        .unwrap_or_else(|_| ms.to_string())
}

/// At most this many stretches are said one by one; the rest are counted.
pub const MAX_NOTES: usize = 5;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn offsets_written_as_text() {
        assert_eq!(text_offset_s("2024-05-01T10:00:00.000+02:00"), Some(7200));
        assert_eq!(text_offset_s("2024-05-01T10:00:00-0500"), Some(-18000));
        assert_eq!(text_offset_s("2024-05-01T10:00:00+05:30"), Some(19800));
        assert_eq!(text_offset_s("2024-05-01T10:00:00Z"), None);
        assert_eq!(text_offset_s("2024-05-01T10:00:00+00:00"), None);
        assert_eq!(text_offset_s("2024-05-01T10:00:00"), None);
        assert_eq!(minutes_offset_s(-240.0), Some(-14400));
        assert_eq!(minutes_offset_s(2000.0), None);
    }

    #[test]
    fn a_week_in_new_york_is_named_and_home_is_not() {
        let berlin = TimeZone::get("Europe/Berlin").unwrap();
        let t = |s: &str| s.parse::<Timestamp>().unwrap();
        let mut seen = Vec::new();
        // Home in Berlin (summer: +02:00), New York (-04:00), home again.
        for h in 0..48 {
            seen.push((
                t("2024-06-01T00:00:00Z") + jiff::SignedDuration::from_hours(h),
                7200,
            ));
            seen.push((
                t("2024-06-10T00:00:00Z") + jiff::SignedDuration::from_hours(h),
                -14400,
            ));
            seen.push((
                t("2024-06-20T00:00:00Z") + jiff::SignedDuration::from_hours(h),
                7200,
            ));
        }
        let s = stretches(seen);
        assert_eq!(s.len(), 3);
        let a = away(&s, &berlin);
        assert_eq!(a.len(), 1, "{a:?}");
        assert_eq!(a[0].stretch.offset_s, -14400);
        assert_eq!(a[0].zone_first_s, 7200);
        let n = notes(&s, &berlin);
        assert!(
            // In the person's zone, as every time the advice shows.
            n[0].contains("from 2024-06-10 02:00 to 2024-06-12 01:00"),
            "{n:?}"
        );
        assert!(
            n[0].contains("UTC-04:00") && n[0].contains("Europe/Berlin's at UTC+02:00"),
            "{n:?}"
        );
        // In New York's zone, only the two stretches at home are away.
        let ny = TimeZone::get("America/New_York").unwrap();
        assert_eq!(away(&s, &ny).len(), 2);
    }

    #[test]
    fn offsets_changing_back_and_forth_are_said_five_times_then_counted() {
        let berlin = TimeZone::get("Europe/Berlin").unwrap();
        let t0: Timestamp = "2024-06-01T00:00:00Z".parse().unwrap();
        // Two uploaders, one at home (+02:00), one at UTC-05:00, in turn.
        let seen: Vec<(Timestamp, i32)> = (0..40)
            .map(|k| {
                let off = if k % 2 == 0 { 7200 } else { -18000 };
                (t0 + jiff::SignedDuration::from_mins(5 * k), off)
            })
            .collect();
        let n = notes(&stretches(seen), &berlin);
        assert_eq!(n.len(), MAX_NOTES + 1, "{n:?}");
        assert_eq!(
            n[MAX_NOTES],
            "and 15 more stretches away from Europe/Berlin's offset, until 2024-06-01 05:15"
        );
    }
}
