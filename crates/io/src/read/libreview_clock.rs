//! A device clock set back inside one LibreView export. LibreView writes
//! each row at the device's own wall time with no offset; a person who
//! flies west and lets the phone (or sets the reader) follow the new zone
//! writes the next hours at the wall times of hours already written. Read
//! in the person's zone, the two stretches land on the same instants: two
//! different readings of one sensor at one time, which would count the
//! stretch twice. (The autumn change of the person's own zone is not this:
//! [`crate::time::WallClock`] places its repeated hour by the rows' order.)
//!
//! A historic reading of the device read as CGM that falls within half the
//! series' sampling period of one written earlier in the file (a lower
//! line) with another value is counted, not read as CGM, and the stretch
//! is reported with its lines and times: its true time is not known.

use jiff::tz::TimeZone;

use crate::record::{content_id, OriginAt, Record, RecordKind, SourceId};

/// What a historic reading written after its device's clock was set back,
/// at the time of an earlier one, is counted as.
pub const CLOCK_SET_BACK: &str =
    "historic glucose at the time of an earlier reading of the same device (its clock set back)";

/// Marks the readings of `records` (one LibreView file's) written at the
/// times of earlier ones (see the module's words) as
/// [`CLOCK_SET_BACK`]; returns the note that says so, if any.
pub fn mark(records: &mut [Record], tz: &TimeZone) -> Option<String> {
    // (instant, line, index) of every CGM reading.
    let mut cgm: Vec<(jiff::Timestamp, u32, usize)> = records
        .iter()
        .enumerate()
        .filter_map(|(i, r)| match (&r.kind, r.origin.at) {
            (RecordKind::Cgm { .. }, OriginAt::Line(l)) => Some((r.at, l, i)),
            _ => None,
        })
        .collect();
    cgm.sort();
    let mut gaps: Vec<i64> = cgm
        .windows(2)
        .map(|w| w[1].0.duration_since(w[0].0).as_secs())
        .filter(|&g| g > 0)
        .collect();
    if gaps.is_empty() {
        return None;
    }
    gaps.sort_unstable();
    let period = gaps[gaps.len() / 2];
    let mut marked: Vec<(u32, usize)> = Vec::new();
    let mut kept = cgm.first().copied()?;
    for &next in &cgm[1..] {
        let close = 2 * next.0.duration_since(kept.0).as_secs() < period;
        if close && records[kept.2].kind != records[next.2].kind {
            // The later line was written after the earlier one's: it is
            // the one whose clock was set back.
            let (early, late) = if next.1 > kept.1 {
                (kept, next)
            } else {
                (next, kept)
            };
            marked.push((late.1, late.2));
            kept = early;
        } else {
            kept = next;
        }
    }
    if marked.is_empty() {
        return None;
    }
    let (mut first, mut last) = (u32::MAX, 0);
    let (mut from, mut to) = (jiff::Timestamp::MAX, jiff::Timestamp::MIN);
    for &(line, i) in &marked {
        let r = &mut records[i];
        (first, last) = (first.min(line), last.max(line));
        (from, to) = (from.min(r.at), to.max(r.at));
        let value = serde_json::to_string(&r.kind).unwrap_or_default();
        r.kind = RecordKind::Ignored {
            kind: CLOCK_SET_BACK.into(),
        };
        // Its identity: the reading's content, so that the same row of a
        // re-export is the same record.
        let SourceId::Hash(h) = content_id(r.source, r.at, &r.kind) else {
            continue;
        };
        r.id = SourceId::Hash(crate::record::content_hash([
            h.to_string().as_bytes(),
            value.as_bytes(),
        ]));
    }
    let local = |t: jiff::Timestamp| {
        t.to_zoned(tz.clone())
            .strftime("%Y-%m-%d %H:%M")
            .to_string()
    };
    Some(format!(
        "{} historic glucose rows (lines {first}-{last}, {} to {} in {}) fall within half the \
         sensor's {}-minute period of other readings the same device wrote on earlier lines: \
         its clock was set back (a trip to a zone further west, or set by hand), and LibreView \
         writes no offset, so their true times are not known; they are counted, not read as \
         CGM. Readings written while the clock was off are placed by it.",
        marked.len(),
        local(from),
        local(to),
        tz.iana_name().unwrap_or("the given zone"),
        period / 60,
    ))
}
