//! Day 1 and the records before it: the one place that decides which
//! stored records the advisor uses.
//!
//! A person's day 1 is the local date of the first glucose reading of the
//! first import that brought one (or the date given when the person was
//! created), and it never moves once set: the advisor's day index, its
//! suggestions and the person's answers hang on it. A later import may
//! bring records dated before it (a pump's export starting two days before
//! the sensor's, imported second): they are stored like any record, so
//! that nothing the person gave is lost and the log does not depend on the
//! order of the imports, but the advisor does not use them. A profile
//! (basal schedule) before day 1 is the one exception: it is in force on
//! day 1 and is used.
//!
//! Every reader that derives the person's events, days or settings from
//! the log takes its records through [`used`]: the records on or after
//! day 1, then one source for each kind of data and day
//! ([`crate::one_source::choose`]). The twin's fit, autotune `--db`, the
//! reports and the Nightscout write-back read the same records: abba's
//! history of a person starts on day 1, as its advice does.

use crate::one_source::Chosen;
use crate::person::Person;
use abba_io::{Record, RecordKind};
use jiff::civil::Date;
use jiff::tz::TimeZone;

/// True when `r` is dated (in `tz`) before `day_1` and is not a profile
/// (a profile before day 1 is in force on day 1).
pub fn is_before(tz: &TimeZone, day_1: Date, r: &Record) -> bool {
    !matches!(r.kind, RecordKind::Schedule { .. }) && tz.to_datetime(r.at).date() < day_1
}

/// The records of `records` that the advisor uses: those on or after the
/// person's day 1 (all of them while day 1 is not set), profiles before it
/// included, then one source for each kind of data and day. How many were
/// left out as before day 1 is counted in the result
/// ([`Chosen::before_day_1`]). The order of `records` is kept.
pub fn used(person: &Person, mut records: Vec<Record>) -> Chosen {
    let mut before = 0usize;
    if let Some(d) = person.first_day {
        records.retain(|r| {
            let out = is_before(&person.tz, d, r);
            before += usize::from(out);
            !out
        });
    }
    let mut chosen = crate::one_source::choose(&person.tz, records);
    if before > 0 {
        chosen.before_day_1 = Some((before, person.first_day.unwrap_or_default()));
    }
    chosen
}

/// What [`used`] left out as before day 1, in a sentence.
pub fn sentence(count: usize, day_1: Date) -> String {
    format!(
        "{count} record{} dated before day 1 ({day_1}) {} stored, not used by the advisor.",
        if count == 1 { "" } else { "s" },
        if count == 1 { "is" } else { "are" }
    )
}
