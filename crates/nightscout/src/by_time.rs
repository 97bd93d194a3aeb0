//! Reading a window by ranges of time, for a server whose pages are not
//! in time order (oldest first, or in the order it stored them): paging
//! from the newest down stands on that order, ranges need none. They need
//! only what every read already needs, the date field's bounds (`$gte`,
//! `$lte`, and `$lt` between two ranges, so no stored form of
//! `created_at` falls between them).
//!
//! A range whose page is shorter than the longest the server served
//! holds all of it; a full one is split in two at the middle of its times
//! (of the times it brought, when it has no upper bound), until every
//! range is read whole. A full page at one key (more documents at one
//! time than a page holds) is read by `_id` ([`crate::by_id`]). What the
//! server serves outside a range's bounds (it ignores the date field's
//! filter) proves nothing and fails the sync
//! ([`crate::fetch::Pages::unproven`]).

use crate::client::Client;
use crate::error::NsError;
use crate::fetch::{iso_ms, list, Collection, Collector, Key, MAX_PAGES};

/// The top of a range.
#[derive(Debug, Clone)]
enum Upper {
    /// No bound.
    Open,
    /// `$lte` this key.
    AtOrBelow(Key),
    /// `$lt` this key.
    Below(Key),
}

impl Upper {
    fn admits(&self, key: &Key) -> bool {
        match self {
            Upper::Open => true,
            Upper::AtOrBelow(u) => key <= u,
            Upper::Below(u) => key < u,
        }
    }
}

/// A key's time (ms): entries' keys are times; treatments' keys here are
/// bounds in `toISOString()` form, whose order is their times' order.
fn ms_of(k: &Key) -> Option<i64> {
    match k {
        Key::Ms(ms) => Some(*ms),
        Key::Text(s) => abba_io::time::parse_instant(s).map(|t| t.as_millisecond()),
    }
}

/// The key of time `ms` in `c`'s form.
fn key_at(c: Collection, ms: i64) -> Key {
    match c {
        Collection::Entries => Key::Ms(ms),
        Collection::Treatments | Collection::DeviceStatus => Key::Text(iso_ms(ms)),
    }
}

/// Every document of `c` with keys from `from` to `to` (inclusive; `None`:
/// no upper bound), read by ranges of time; `largest` is the longest page
/// the server served so far.
pub(crate) fn window(
    client: &Client,
    c: Collection,
    from: &Key,
    to: Option<&Key>,
    page: usize,
    largest: usize,
    col: &mut Collector,
) -> Result<(), NsError> {
    let top = to.map_or(Upper::Open, |t| Upper::AtOrBelow(t.clone()));
    ranges(client, c, from, top, page, largest, col)
}

/// Every document of `c` with keys from `from` and below `below` (`None`:
/// no upper bound), read by ranges of time as [`window`] reads: two such
/// ranges, the second from the first's `below`, leave no stored form of
/// the date field between them.
pub(crate) fn range_below(
    client: &Client,
    c: Collection,
    from: &Key,
    below: Option<&Key>,
    page: usize,
    largest: usize,
    col: &mut Collector,
) -> Result<(), NsError> {
    let top = below.map_or(Upper::Open, |t| Upper::Below(t.clone()));
    ranges(client, c, from, top, page, largest, col)
}

fn ranges(
    client: &Client,
    c: Collection,
    from: &Key,
    top: Upper,
    page: usize,
    mut largest: usize,
    col: &mut Collector,
) -> Result<(), NsError> {
    let field = c.field();
    let gte = format!("find[{field}][$gte]");
    let lte = format!("find[{field}][$lte]");
    let lt = format!("find[{field}][$lt]");
    let mut ranges: Vec<(Key, Upper)> = vec![(from.clone(), top)];
    let mut pages = 0;
    while let Some((lo, hi)) = ranges.pop() {
        if pages >= MAX_PAGES {
            return Err(NsError::Protocol {
                site: client.site().to_string(),
                call: format!("GET {}", c.path()),
                problem: format!(
                    "more than {MAX_PAGES} pages of {} by ranges of time",
                    c.name()
                ),
            });
        }
        let mut q: Vec<(&str, String)> = vec![(&gte, lo.query())];
        match &hi {
            Upper::Open => {}
            Upper::AtOrBelow(u) => q.push((&lte, u.query())),
            Upper::Below(u) => q.push((&lt, u.query())),
        }
        q.push(("count", page.to_string()));
        let docs = list(client, c.path(), &q)?;
        pages += 1;
        col.out.pages += 1;
        col.out.received += docs.len();
        let full = !docs.is_empty() && docs.len() >= largest;
        largest = largest.max(docs.len());
        col.largest = col.largest.max(largest);
        let mut greatest: Option<Key> = None;
        let mut outside = None;
        for d in docs {
            if let Some((k_lo, k_hi)) = c.keys_of(&d) {
                // The server compared one of the document's possible keys.
                if k_hi < lo || !hi.admits(&k_lo) {
                    outside.get_or_insert_with(|| {
                        format!(
                            "asked for {} with {field} from {} ({}), got one keyed {}: the \
                             server ignores find[{field}]",
                            c.name(),
                            lo.query(),
                            match &hi {
                                Upper::Open => "no upper bound".to_string(),
                                Upper::AtOrBelow(u) => format!("at or below {}", u.query()),
                                Upper::Below(u) => format!("below {}", u.query()),
                            },
                            k_lo.query()
                        )
                    });
                }
                greatest = Some(greatest.map_or(k_hi.clone(), |g| g.max(k_hi)));
            }
            col.take(d);
        }
        if let Some(p) = outside {
            col.out.unproven.push(p);
            return Ok(());
        }
        if !full {
            continue;
        }
        // Split at the middle of the range's times; an open range at the
        // middle of the times it brought (those above come in its upper
        // half).
        let lo_ms = ms_of(&lo);
        let hi_ms = match &hi {
            Upper::AtOrBelow(u) => ms_of(u),
            Upper::Below(u) => ms_of(u).map(|m| m - 1),
            Upper::Open => greatest
                .as_ref()
                .and_then(|g| g.at_or_above())
                .as_ref()
                .and_then(ms_of),
        };
        match (lo_ms, hi_ms) {
            (Some(a), Some(b)) if b > a => {
                let mid = key_at(c, a + (b - a + 1) / 2);
                ranges.push((mid.clone(), hi));
                ranges.push((lo, Upper::Below(mid)));
            }
            (Some(a), Some(_)) => {
                // One time, more documents than a page holds: by `_id`
                // (to the range's top, or the next millisecond's key: no
                // stored form between them is left out).
                let to = match &hi {
                    Upper::AtOrBelow(u) | Upper::Below(u) => u.clone(),
                    Upper::Open => key_at(c, a + 1),
                };
                crate::by_id::range(client, c, &lo, Some(&to), page, col)?;
                if matches!(hi, Upper::Open) {
                    ranges.push((key_at(c, a + 1), Upper::Open));
                }
            }
            _ => {
                col.out.unproven.push(format!(
                    "{}: a full page from {} whose times cannot be split; more may be on the site",
                    c.name(),
                    lo.query()
                ));
                return Ok(());
            }
        }
    }
    Ok(())
}
