//! The loop's evidence in a site's device status (`/api/v1/devicestatus`):
//! Loop's `loop`, OpenAPS', AndroidAPS', iAPS' and Trio's `openaps` with
//! `suggested` and, when a dose was set, `enacted` (Trio uploads `enacted`
//! only with closed loop on). A file import of the same documents counts
//! them with [`abba_io::automation::Evidence::from_file`]; the link counts
//! them with it too, page by page, and keeps only the counts.
//!
//! Device status is large (a document every loop cycle, 5 minutes, with
//! the loop's predictions) and holds no record abba reads, so it is read
//! apart from the paging of entries and treatments:
//!
//! - only what is new: from the link's `devicestatus` mark (the newest
//!   document's time) on; a first sync from [`LOOP_RECENT_DAYS`] before
//!   the newest entry or treatment, the days whose loop marks tell;
//! - one page from there (`count` as the other reads ask): when it is
//!   shorter than the longest page the site served in the sync, it holds
//!   everything new, which is what a sync every few minutes finds;
//! - else by one UTC day at a time ([`crate::by_time`]: `$gte` the day's
//!   start, `$lt` the next day's, so no stored form of `created_at` falls
//!   between two days; a day fuller than the longest page the site served
//!   is split until each part is read whole): at most one day's documents
//!   are held, then counted and dropped;
//! - Nightscout's API v1 has no projection (`lib/server/devicestatus.js`
//!   of cgm-remote-monitor lists whole documents), so whole documents come;
//!   what a server serves outside the asked bounds fails the sync as the
//!   other reads do ([`crate::fetch::Pages::unproven`]).
//!
//! A document is counted once: when its time is after the mark (each
//! sync moves the mark to the newest counted). One uploaded so late that
//! its time is before the mark is not counted (its uploader sent newer
//! ones first), nor is one whose `created_at` carries an offset west of
//! UTC that reads as before the mark (Loop, Trio, AndroidAPS and Nightscout
//! itself write UTC).

use crate::client::Client;
use crate::error::NsError;
use crate::fetch::{list, Collection, Collector};
use abba_io::automation::{Evidence, LOOP_RECENT_DAYS};
use serde_json::Value;

const DAY_MS: i64 = 86_400_000;

/// What a read of the device status brought.
#[derive(Debug, Clone, Default)]
pub struct DeviceStatusRead {
    /// The loop's evidence of the documents counted (new since the mark).
    pub evidence: Evidence,
    /// The next mark: the newest document counted (or the last mark; on
    /// a first sync without any, just before where it started).
    pub mark: i64,
    /// Pages asked for.
    pub pages: usize,
    /// Documents received, repeats included.
    pub received: usize,
    /// Documents counted.
    pub documents: usize,
    /// What could not be proven read whole (the sync fails with it).
    pub unproven: Vec<String>,
}

/// Where a sync starts reading the device status: after the link's mark,
/// or on a first sync [`LOOP_RECENT_DAYS`] before `newest_data` (the
/// newest entry or treatment the sync holds; `now` without one).
pub fn start(mark: Option<i64>, newest_data: Option<i64>, now: i64) -> i64 {
    match mark {
        Some(m) => m.saturating_add(1),
        None => newest_data
            .unwrap_or(now)
            .min(now)
            .saturating_sub(LOOP_RECENT_DAYS * DAY_MS)
            .max(0),
    }
}

/// Reads the device status from `from` (ms) on, counting the documents
/// dated after `mark` and not after `future` (later ones are counted when
/// their time has come). `largest`: the longest page the site served in
/// this sync (a page shorter than it holds all its bounds admit).
///
/// First one page from `from`, open above: the usual sync (a few loop
/// cycles since the last) ends there. A full one (a first sync, or a
/// site back after days) is put aside and the device status read one UTC
/// day at a time instead.
pub fn read(
    client: &Client,
    from: i64,
    mark: Option<i64>,
    future: i64,
    page: usize,
    largest: usize,
    now: i64,
) -> Result<DeviceStatusRead, NsError> {
    let c = Collection::DeviceStatus;
    let mut out = DeviceStatusRead {
        mark: mark.unwrap_or(from.saturating_sub(1)),
        ..DeviceStatusRead::default()
    };
    let lower = c.lower(from);
    let q = [
        (format!("find[{}][$gte]", c.field()), lower.query()),
        ("count".to_string(), page.to_string()),
    ];
    let q: Vec<(&str, String)> = q.iter().map(|(k, v)| (k.as_str(), v.clone())).collect();
    let docs = list(client, c.path(), &q)?;
    out.pages += 1;
    out.received += docs.len();
    if docs.len() < largest.max(1) {
        // Whole: what the server served must be in its bound.
        if let Some(k) = docs
            .iter()
            .filter_map(|d| c.keys_of(d))
            .find(|(_, hi)| *hi < lower)
        {
            out.unproven.push(format!(
                "asked for devicestatus with created_at from {}, got one keyed {}: the \
                 server ignores find[created_at]",
                lower.query(),
                k.0.query()
            ));
            return Ok(out);
        }
        let mut col = Collector::default();
        for d in docs {
            col.take(d);
        }
        count(client, &col.finish(c).docs, mark, future, &mut out)?;
        return Ok(out);
    }
    drop(docs);
    let mut largest = largest;
    let mut lo = from;
    loop {
        // The last day is open above: what is dated later is read too
        // (and counted when its time has come).
        let hi = (lo.saturating_add(DAY_MS) <= now).then(|| lo + DAY_MS);
        let mut col = Collector::default();
        crate::by_time::range_below(
            client,
            c,
            &c.lower(lo),
            hi.map(|h| c.lower(h)).as_ref(),
            page,
            largest,
            &mut col,
        )?;
        let pages = col.finish(c);
        largest = largest.max(pages.largest);
        out.pages += pages.pages;
        out.received += pages.received;
        out.unproven.extend(pages.unproven);
        count(client, &pages.docs, mark, future, &mut out)?;
        match hi {
            Some(h) => lo = h,
            None => break,
        }
    }
    Ok(out)
}

/// Counts `docs` dated after `mark` and not after `future` into `out`
/// ([`Evidence::from_file`], as a file import counts them) and moves the
/// mark to the newest.
fn count(
    client: &Client,
    docs: &[Value],
    mark: Option<i64>,
    future: i64,
    out: &mut DeviceStatusRead,
) -> Result<(), NsError> {
    let c = Collection::DeviceStatus;
    let counted: Vec<&Value> = docs
        .iter()
        .filter(|d| {
            c.time_of(d)
                .is_some_and(|t| mark.is_none_or(|m| t > m) && t <= future)
        })
        .collect();
    if counted.is_empty() {
        return Ok(());
    }
    let bytes = serde_json::to_vec(&counted).map_err(|e| NsError::Protocol {
        site: client.site().to_string(),
        call: format!("GET {}", c.path()),
        problem: e.to_string(),
    })?;
    out.evidence.add_file(&Evidence::from_file(&bytes));
    out.documents += counted.len();
    if let Some(newest) = counted.iter().filter_map(|d| c.time_of(d)).max() {
        out.mark = out.mark.max(newest);
    }
    Ok(())
}
