//! The link and the sync: check a site (its status and a read), store the
//! link, and pull what is new into the person's store by the same import
//! as files.
//!
//! A sync fetches every collection completely before it writes, then
//! imports all of it in one transaction that also removes the records of
//! deleted documents and advances the marks: killed, cut off or refused at
//! any point before the commit, the store is as before and the next sync
//! fetches the same again; after the commit, it is complete. Each v1
//! collection is fetched again from [`SyncOptions::overlap`] before its
//! mark, so a document rewritten within that window (AndroidAPS rewrites
//! a temporary basal it cut short) is seen in its newer version.

use crate::client::{Client, ClientOptions};
use crate::error::NsError;
use crate::fetch::{self, Collection};
use crate::site::SiteUrl;
use abba_store::link::{Credential, Fetched, Link, SyncImport};
use abba_store::{ProfileResolution, Store};
use serde::Serialize;
use serde_json::Value;

/// How to sync.
#[derive(Debug, Clone)]
pub struct SyncOptions {
    /// Documents asked per page (Nightscout's API v3 maximum is 1,000; v1
    /// servers may cap lower).
    pub page: usize,
    /// How far before a mark each collection is fetched again (ms).
    pub overlap_ms: i64,
    /// When the export's profile differs from the store's therapy.
    pub resolve: ProfileResolution,
    /// The time of import (`None`: now).
    pub now: Option<jiff::Timestamp>,
    /// The HTTP client's timeouts and retries.
    pub client: ClientOptions,
}

impl Default for SyncOptions {
    fn default() -> Self {
        Self {
            page: 1000,
            overlap_ms: 24 * 3_600_000,
            resolve: ProfileResolution::Stop,
            now: None,
            client: ClientOptions::default(),
        }
    }
}

/// What a sync did.
#[derive(Debug, Clone, Serialize)]
pub struct SyncReport {
    /// The person.
    pub person: String,
    /// The site.
    pub site: String,
    /// Per collection: (name, documents received with repeats, kept once, pages).
    pub collections: Vec<CollectionReport>,
    /// Whether API v3 was used for deletions.
    pub v3: bool,
    /// The import.
    pub import: SyncImport,
    /// What the write-back did (when the link has it).
    pub write_back: Option<crate::write_back::WriteReport>,
    /// `_id`s of documents whose records the store holds but which the
    /// site no longer serves in the window read again (deleted through
    /// API v1, which leaves no trace): their records are kept, and said.
    pub gone: Vec<String>,
    /// What the sync could not look for, in words (late uploads on a
    /// server that cannot be read by `_id`): what it read is imported.
    pub warnings: Vec<String>,
}

/// One collection of a sync.
#[derive(Debug, Clone, Serialize)]
pub struct CollectionReport {
    /// `entries`, `treatments`, `devicestatus`, `profile`.
    pub name: &'static str,
    /// Documents received (repeats across pages included).
    pub received: usize,
    /// Distinct documents.
    pub documents: usize,
    /// Pages asked for.
    pub pages: usize,
    /// abba's own Notes (write-back), left out.
    pub own: usize,
    /// Treatments without a `created_at` string, found by `_id`.
    pub without_created_at: usize,
    /// Documents dated before the window read again that were inserted
    /// or changed since (uploaded late): found by their ObjectId's time,
    /// or named by API v3's history.
    pub late: usize,
}

/// What a check of a site found.
#[derive(Debug, Clone, Serialize)]
pub struct Check {
    /// The site's name (`status.name`) and version, as it says.
    pub name: String,
    /// Its version.
    pub version: String,
    /// Whether it offers API v3.
    pub v3: bool,
    /// The newest entry's time, if any (the read).
    pub newest_entry: Option<String>,
    /// With `--write-back`: why the right to write could not be checked
    /// (`None`: checked, or not asked).
    pub write_unverified: Option<String>,
}

/// A client of the person's link.
pub fn client_of(link: &Link, opts: &ClientOptions) -> Result<Client, NsError> {
    Ok(Client::new(
        SiteUrl::parse(&link.url)?,
        link.credential.clone(),
        opts.clone(),
    ))
}

/// Checks a site with a credential: `/api/v1/status.json` and a read of
/// the newest entry (which a wrong credential does not pass).
pub fn check_link(client: &Client) -> Result<Check, NsError> {
    let status = client.get("/api/v1/status.json", &[])?;
    let s = |k: &str| {
        status
            .get(k)
            .and_then(Value::as_str)
            .unwrap_or("?")
            .to_string()
    };
    // With a bound on `date`: without one Nightscout looks at 4 days only.
    let newest = fetch::list(
        client,
        Collection::Entries.path(),
        &[("find[date][$gte]", "0".into()), ("count", "1".into())],
    )?;
    let newest_entry = newest
        .first()
        .and_then(|d| Collection::Entries.time_of(d))
        .map(fetch::iso_ms);
    // A server that does not filter by time is refused here, before the
    // link is stored, rather than at every sync.
    for c in [Collection::Entries, Collection::Treatments] {
        fetch::check_time_filter(client, c)?;
    }
    Ok(Check {
        name: s("name"),
        version: s("version"),
        // API v3 takes a JWT only (a site without API v2 authorization
        // gets the token in the query, which v3 refuses).
        v3: client.has_jwt() && fetch::has_v3(client),
        newest_entry,
        write_unverified: None,
    })
}

/// What the write-back writes, as Nightscout's permissions name it: Notes
/// created and updated, the profile document updated.
pub const WRITE_PERMISSIONS: [(&str, &str); 3] = [
    ("api:treatments:create", "create treatments"),
    ("api:treatments:update", "update treatments"),
    ("api:profile:update", "update the profile"),
];

/// Whether the link's credential may write what the write-back writes:
/// `Ok(None)` yes; `Ok(Some(why))` it could not be told (said, not
/// refused); an error when it may not. The API secret may do everything;
/// an access token's permissions are those its exchange named, else asked
/// of `/api/v2/authorization/debug/check/<permission>`.
pub fn check_write(client: &Client) -> Result<Option<String>, NsError> {
    if !client.has_token() {
        return Ok(None);
    }
    let mut missing = Vec::new();
    let mut unknown = Vec::new();
    match client.grants() {
        Some(grants) => {
            for (p, what) in WRITE_PERMISSIONS {
                if !grants.iter().any(|g| crate::client::permits(g, p)) {
                    missing.push((p, what));
                }
            }
        }
        None => {
            for (p, what) in WRITE_PERMISSIONS {
                match client.get(&format!("/api/v2/authorization/debug/check/{p}"), &[]) {
                    Ok(_) => {}
                    Err(NsError::Unauthorized { .. })
                    | Err(NsError::Status {
                        status: 401 | 403, ..
                    }) => missing.push((p, what)),
                    Err(_) => unknown.push(p),
                }
            }
        }
    }
    if !missing.is_empty() {
        return Err(NsError::CannotWrite {
            site: client.site().to_string(),
            what: missing
                .iter()
                .map(|(_, w)| *w)
                .collect::<Vec<_>>()
                .join(", "),
            missing: missing
                .iter()
                .map(|(p, _)| *p)
                .collect::<Vec<_>>()
                .join(", "),
        });
    }
    Ok((!unknown.is_empty()).then(|| {
        format!(
            "the site did not say whether the access token may write ({}): the first write-back will tell",
            unknown.join(", ")
        )
    }))
}

/// Checks the site and stores the link for `person` (with `write_back`,
/// only when the credential may write what it writes).
pub fn link(
    store: &mut Store,
    person: &str,
    url: &str,
    credential: Credential,
    write_back: bool,
    opts: &ClientOptions,
) -> Result<(Link, Check), NsError> {
    // The person first: no call to the site for a name that is wrong.
    store.person(person)?;
    let site = SiteUrl::parse(url)?;
    let client = Client::new(site.clone(), credential.clone(), opts.clone());
    let mut check = check_link(&client)?;
    if write_back {
        check.write_unverified = check_write(&client)?;
    }
    let link = store.set_link(person, site.as_str(), &credential, write_back)?;
    Ok((link, check))
}

/// A sync's result, and whether its outcome could be recorded on the link.
#[derive(Debug)]
pub struct Attempt {
    /// What the sync did, or why it failed.
    pub result: Result<SyncReport, NsError>,
    /// Whether the outcome is on the link (`abba link --list`, the API).
    pub recorded: Result<(), abba_store::StoreError>,
}

/// Syncs `person` and records the outcome on the link (the end time, the
/// error, the failures in a row), saying whether that record was written.
pub fn sync_and_record(store: &mut Store, person: &str, opts: &SyncOptions) -> Attempt {
    let result = match store.link(person) {
        Ok(Some(link)) => sync_link(store, &link, opts),
        Ok(None) => {
            return Attempt {
                result: Err(NsError::NoLink(person.to_string())),
                recorded: Ok(()),
            }
        }
        Err(e) => Err(e.into()),
    };
    let end = jiff::Timestamp::now();
    let recorded = match &result {
        Ok(r) => store.record_success(person, end, &r.warnings),
        Err(e) => store.record_sync(person, end, Some(&e.to_string())),
    };
    Attempt { result, recorded }
}

/// Syncs `person`: fetches what is new, imports it, records the outcome
/// on the link, then writes back when the link says so.
pub fn sync(store: &mut Store, person: &str, opts: &SyncOptions) -> Result<SyncReport, NsError> {
    let a = sync_and_record(store, person, opts);
    match (a.result, a.recorded) {
        // The sync's own failure says more than a failure to record it.
        (Err(e), _) => Err(e),
        (Ok(_), Err(e)) => Err(e.into()),
        (Ok(r), Ok(())) => Ok(r),
    }
}

fn sync_link(store: &mut Store, link: &Link, opts: &SyncOptions) -> Result<SyncReport, NsError> {
    let client = client_of(link, &opts.client)?;
    // The site is there (a 404 from a read of documents is taken as
    // none, which only a site that answers its status may say), and its
    // glucose unit, which a BG Check without its own `units` is in.
    let status = client.get("/api/v1/status.json", &[])?;
    let units = site_units(&status);
    let now = opts.now.unwrap_or_else(jiff::Timestamp::now);
    let marks = store.link_marks(&link.person)?;
    let future = abba_io::read::future_limit(now).as_millisecond();
    let mut fetched = Fetched {
        units,
        ..Fetched::default()
    };
    let mut reports = Vec::new();
    let mut gone = Vec::new();
    let mut unproven = Vec::new();
    let mut warnings = Vec::new();
    let mut fetched_pages = Vec::new();
    // API v3 first: what changed since the last sync, so the v1 reads
    // reach back to the earliest valid document changed (one uploaded or
    // edited long after its time, which the window alone would miss).
    // What was deleted since (a first sync starts from the site's
    // lastModified: what it fetched is what is valid), and the treatments
    // without `created_at` changed since, which the `_id` probe reaches
    // only when they were inserted lately.
    // (The profiles first: the first call exchanges a token for the JWT
    // that API v3 takes.)
    let profiles = fetch::profiles(&client, opts.page)?;
    let v3 = client.has_jwt() && fetch::has_v3(&client);
    let mut histories: Vec<(&str, fetch::History)> = Vec::new();
    if v3 {
        let last = fetch::v3_last_modified(&client)?;
        for col in ["entries", "treatments", "profile"] {
            let key = format!("v3:{col}");
            match marks.get(&key) {
                Some(&m) => histories.push((col, fetch::v3_history(&client, col, m, opts.page)?)),
                None => {
                    fetched
                        .marks
                        .insert(key, last.get(col).copied().unwrap_or(0));
                }
            }
        }
    }
    // A first sync (no mark yet) that fails part-way keeps what it read
    // whole, from a local midnight on, without importing it (no day is
    // advised on before the whole history is read, and the person's day 1
    // is the oldest reading's); the next reads what is new since and the
    // rest below that midnight (`backfill`, kept negated: marks only
    // rise), then imports all at once.
    let first = [Collection::Entries, Collection::Treatments]
        .iter()
        .all(|c| !marks.contains_key(c.name()));
    let pending = marks
        .get(BACKFILL)
        .copied()
        .filter(|&m| first && m < 0)
        .map(|m| -m);
    let mut staged: Vec<(String, Vec<Value>)> = Vec::new();
    if pending.is_some() {
        for (c, bytes) in store.staged(&link.person)? {
            let docs: Vec<Value> = serde_json::from_slice(&bytes).map_err(|e| {
                NsError::Store(abba_store::StoreError::corrupt("staged documents", e))
            })?;
            staged.push((c, docs));
        }
    }
    let tz = store.person(&link.person)?.tz;
    let mut resume = Resume::default();
    let mut backfilled: Vec<(Collection, Vec<Value>)> = Vec::new();
    for c in [Collection::Entries, Collection::Treatments] {
        let mark = marks.get(c.name()).copied();
        // What was kept is read again from its newest document on.
        let staged_mark = marks
            .get(&staged_key(c))
            .copied()
            .filter(|_| pending.is_some());
        // Always a lower bound: without one, Nightscout answers only the
        // last 4 days (`deltaAgo` in `lib/server/query.js`).
        let window = mark
            .or(staged_mark)
            .map_or(0, |m| m.saturating_sub(opts.overlap_ms));
        let changed: Vec<i64> = histories
            .iter()
            .filter(|(col, _)| *col == c.name())
            .flat_map(|(_, h)| h.times.iter().copied())
            .collect();
        // A treatment's `created_at` with an offset is compared as its
        // string: the bound goes as far below as an offset may read.
        let slack = if c.keyed_by_text() {
            fetch::OFFSET_SLACK_MS
        } else {
            0
        };
        let since = changed
            .iter()
            .map(|t| t.saturating_sub(slack).max(0))
            .min()
            .map_or(window, |e| e.min(window));
        // Read from that much earlier still, so every document whose time
        // is in the window is served whatever offset its string carries,
        // and the whole window can be compared with the store (`gone`).
        let read_from = since.saturating_sub(slack).max(0);
        // After the first collection's read failed part-way, only what is
        // above its cut.
        let read_from = match resume.cut {
            Some(cut) if pending.is_none() => read_from.max(cut.saturating_sub(slack)),
            _ => read_from,
        };
        let undated = if first { 0 } else { read_from };
        let mut pages =
            match fetch::fetch_range(&client, c, Some(read_from), None, Some(undated), opts.page) {
                Ok(p) => p,
                Err(p) if first && pending.is_none() => {
                    resume.failed(&client, c, *p, undated, opts.page, &tz)?
                }
                Err(p) => return Err(p.error),
            };
        pages.late += changed.iter().filter(|&&t| t < window).count();
        // The rest of an interrupted first sync: below its midnight.
        if let Some(b) = pending {
            let from = resume.cut.map(|cut| cut.saturating_sub(slack));
            let undated = (c == Collection::Treatments).then_some(0);
            let before = b.saturating_add(slack);
            let older = match fetch::fetch_range(&client, c, from, Some(before), undated, opts.page)
            {
                Ok(p) => p,
                Err(p) => resume.failed(&client, c, *p, 0, opts.page, &tz)?,
            };
            pages.pages += older.pages;
            pages.received += older.received;
            let below: Vec<Value> = older
                .docs
                .into_iter()
                .filter(|d| c.time_of(d).is_some_and(|t| t < b))
                .collect();
            backfilled.push((c, below));
        }
        fetched_pages.push((c, mark, Some(since), pages));
    }
    for (col, h) in histories {
        let key = format!("v3:{col}");
        let c = match col {
            "entries" => Some(Collection::Entries),
            "treatments" => Some(Collection::Treatments),
            _ => None,
        };
        for identifier in h.deleted {
            match c {
                // v3 keys by `identifier`, the import by `_id`.
                Some(c) => {
                    fetched
                        .deleted
                        .extend(fetch::ids_of_identifier(&client, c, &identifier)?)
                }
                None => fetched.deleted.push(identifier),
            }
        }
        if let Some((c, _, _, pages)) = fetched_pages
            .iter_mut()
            .find(|(c, ..)| *c == Collection::Treatments && col == "treatments")
        {
            changed_without_created_at(&client, *c, pages, &h.without_created_at)?;
        }
        fetched.marks.insert(key, h.mark);
    }
    // What was kept and what came now, each document once (the newer
    // read wins; one deleted since is left out).
    for (c, _, _, pages) in &mut fetched_pages {
        let mut deleted: std::collections::HashSet<String> =
            fetched.deleted.iter().cloned().collect();
        deleted.extend(pages.deleted.iter().cloned());
        let held: std::collections::HashSet<String> =
            pages.docs.iter().map(fetch::doc_key).collect();
        let kept = staged
            .iter_mut()
            .find(|(x, _)| x == c.name())
            .map(|(_, d)| std::mem::take(d))
            .unwrap_or_default();
        let older = backfilled
            .iter_mut()
            .find(|(x, _)| x == c)
            .map(|(_, d)| std::mem::take(d))
            .unwrap_or_default();
        let earlier: Vec<Value> = kept
            .into_iter()
            .chain(older)
            .filter(|d| {
                let k = fetch::doc_key(d);
                !held.contains(&k) && !deleted.contains(&k)
            })
            .collect();
        pages.add(*c, earlier);
    }
    if let (Some(cut), Some(error)) = (resume.cut, resume.error) {
        let staged = Staged {
            fetched: &fetched,
            pages: &fetched_pages,
            pending,
            cut,
            future,
        };
        return Err(staged.keep(store, &link.person, &client, error));
    }
    if pending.is_some() {
        // Read whole: nothing is left below.
        fetched.marks.insert(BACKFILL.to_string(), 0);
    }
    let largest = fetched_pages
        .iter()
        .map(|(.., pages)| pages.largest)
        .max()
        .unwrap_or(0);
    // The device status, for the loop's evidence only (see
    // [`crate::device_status`]): from its mark, or on a first sync from
    // the last days of the data this sync holds. A first sync it fails
    // keeps what it read, all of it whole, for the next.
    let ds = Collection::DeviceStatus;
    let ds_mark = marks.get(ds.name()).copied();
    let newest_data = fetched_pages
        .iter()
        .flat_map(|(c, _, _, p)| p.docs.iter().filter_map(|d| c.time_of(d)))
        .filter(|&t| t <= future)
        .chain(
            [Collection::Entries, Collection::Treatments]
                .iter()
                .filter_map(|c| marks.get(c.name()).copied()),
        )
        .max();
    let now_ms = now.as_millisecond();
    let status = match crate::device_status::read(
        &client,
        crate::device_status::start(ds_mark, newest_data, now_ms),
        ds_mark,
        future,
        opts.page,
        largest,
        now_ms,
    ) {
        Ok(s) => s,
        Err(error) if first => {
            let staged = Staged {
                fetched: &fetched,
                pages: &fetched_pages,
                pending,
                cut: ALL_READ,
                future,
            };
            return Err(staged.keep(store, &link.person, &client, error));
        }
        Err(e) => return Err(e),
    };
    for (c, mark, since, mut pages) in fetched_pages {
        gone.extend(gone_from(store, &link.person, &client, c, since, &pages)?);
        // abba's own Notes (write-back) are not the person's data.
        let before = pages.docs.len();
        pages.docs.retain(|d| !crate::write_back::is_ours(d));
        let own = before - pages.docs.len();
        reports.push(CollectionReport {
            name: c.name(),
            received: pages.received,
            documents: pages.docs.len(),
            pages: pages.pages,
            own,
            without_created_at: pages.without_created_at,
            late: pages.late,
        });
        unproven.append(&mut pages.unproven);
        warnings.append(&mut pages.warnings);
        // The mark: the newest document that is not in the future (those
        // are refused by the import and fetched again until their time).
        let newest = pages
            .docs
            .iter()
            .filter_map(|d| c.time_of(d))
            .filter(|&t| t <= future)
            .max();
        if let Some(n) = newest {
            fetched
                .marks
                .insert(c.name().to_string(), n.max(mark.unwrap_or(i64::MIN)));
        }
        let fresh: Vec<&Value> = pages
            .docs
            .iter()
            .filter(|d| match (mark, c.time_of(d)) {
                (Some(m), Some(t)) => t > m && t <= future,
                (None, Some(t)) => t <= future,
                (_, None) => false,
            })
            .collect();
        fetched
            .fresh
            .push((c.name().to_string(), json_bytes(&fresh)?));
        fetched.deleted.extend(pages.deleted);
        if !pages.docs.is_empty() {
            let docs: Vec<&Value> = pages.docs.iter().collect();
            fetched
                .contents
                .push((client.site().join(c.path()), json_bytes(&docs)?));
        }
    }
    reports.push(CollectionReport {
        name: ds.name(),
        received: status.received,
        documents: status.documents,
        pages: status.pages,
        own: 0,
        without_created_at: 0,
        late: 0,
    });
    unproven.extend(status.unproven);
    fetched.marks.insert(ds.name().to_string(), status.mark);
    fetched
        .evidence
        .push((ds.name().to_string(), status.evidence));
    reports.push(CollectionReport {
        name: "profile",
        received: profiles.len(),
        documents: profiles.len(),
        pages: 1,
        own: 0,
        without_created_at: 0,
        late: 0,
    });
    if !profiles.is_empty() {
        let docs: Vec<&Value> = profiles.iter().collect();
        let bytes = json_bytes(&docs)?;
        fetched.profile = Some(bytes.clone());
        fetched
            .contents
            .push((client.site().join("/api/v1/profile.json"), bytes));
    }
    // What the paging could not prove complete (a server that does not
    // page by `_id` as Nightscout does, see [`crate::by_id`]) fails the
    // sync before anything is imported: no advice on a day that may lack
    // records, and the next sync reads the same again.
    if !unproven.is_empty() {
        return Err(NsError::Incomplete {
            site: client.site().to_string(),
            what: unproven,
        });
    }
    fetched.deleted.sort();
    fetched.deleted.dedup();
    gone.retain(|id| fetched.deleted.binary_search(id).is_err());
    let import = store.import_synced(&link.person, &fetched, opts.resolve, now)?;
    let write_back = if link.write_back {
        Some(
            crate::write_back::write_back(store, &client, &link.person)
                .map_err(|e| NsError::WriteBack(Box::new(e)))?,
        )
    } else {
        None
    };
    Ok(SyncReport {
        person: link.person.clone(),
        site: link.url.clone(),
        collections: reports,
        v3,
        import,
        write_back,
        gone,
        warnings,
    })
}

/// The mark of an interrupted first sync: the local midnight below which
/// the rest is to be read, negated (marks only rise: the next cut is
/// earlier); 0 or none: nothing.
pub const BACKFILL: &str = "backfill";

/// The cut of a first sync interrupted after its entries and treatments
/// were read whole: everything is kept, nothing is left below.
const ALL_READ: i64 = 1;

/// The mark of the newest document of `c` an interrupted first sync kept.
fn staged_key(c: Collection) -> String {
    format!("staged:{}", c.name())
}

/// What an interrupted first sync read whole.
struct Staged<'a> {
    fetched: &'a Fetched,
    pages: &'a [(Collection, Option<i64>, Option<i64>, fetch::Pages)],
    /// The cut of an earlier interruption of the same first sync.
    pending: Option<i64>,
    cut: i64,
    future: i64,
}

impl Staged<'_> {
    /// Keeps the documents dated from the cut (a local midnight: whole
    /// days; an earlier cut of the same first sync, the earlier), the
    /// marks of how far they reach and the API v3 marks (what changes
    /// after, history brings) in one transaction; the error that stopped
    /// the sync, saying so.
    fn keep(&self, store: &mut Store, person: &str, client: &Client, error: NsError) -> NsError {
        let cut = self.pending.map_or(self.cut, |p| p.min(self.cut));
        let mut marks: std::collections::BTreeMap<String, i64> = self
            .fetched
            .marks
            .iter()
            .filter(|(k, _)| k.starts_with("v3:"))
            .map(|(k, v)| (k.clone(), *v))
            .collect();
        marks.insert(BACKFILL.to_string(), -cut);
        let mut kept = Vec::new();
        for (c, _, _, p) in self.pages {
            let docs: Vec<&Value> = p
                .docs
                .iter()
                .filter(|d| c.time_of(d).is_some_and(|t| t >= cut))
                .collect();
            if let Some(n) = docs
                .iter()
                .filter_map(|d| c.time_of(d))
                .filter(|&t| t <= self.future)
                .max()
            {
                marks.insert(staged_key(*c), n);
            }
            match json_bytes(&docs) {
                Ok(b) => kept.push((c.name().to_string(), b)),
                Err(e) => return e,
            }
        }
        if let Err(e) = store.stage_synced(person, &kept, &marks) {
            return e.into();
        }
        NsError::Resumable {
            site: client.site().to_string(),
            from: if cut <= ALL_READ {
                "the first".to_string()
            } else {
                fetch::iso_ms(cut)
            },
            error: Box::new(error),
        }
    }
}

/// A read of a first sync (or of its rest) that failed part-way: why,
/// and from when what was read is whole in every collection (a local
/// midnight, so every day imported is whole).
#[derive(Default)]
struct Resume {
    error: Option<NsError>,
    cut: Option<i64>,
}

impl Resume {
    /// Takes a read of `c` that failed part-way: its documents read whole
    /// (with, for treatments, those without a `created_at` string since
    /// `undated`), the cut raised to cover them. A failure that proves
    /// nothing, or a second one, ends the sync with nothing imported;
    /// so does a failure of the undated read.
    fn failed(
        &mut self,
        client: &Client,
        c: Collection,
        p: fetch::Partial,
        undated: i64,
        page: usize,
        tz: &jiff::tz::TimeZone,
    ) -> Result<fetch::Pages, NsError> {
        let (Some(proven), None) = (p.proven_from, &self.error) else {
            return Err(self.error.take().unwrap_or(p.error));
        };
        let mut pages = p.pages;
        if c == Collection::Treatments {
            let undated = fetch::undated_treatments(client, undated, page)?;
            pages.pages += undated.pages;
            pages.received += undated.received;
            pages.without_created_at += pages.add(c, undated.docs);
        }
        let cut = midnight_at_or_after(proven, tz);
        self.cut = Some(self.cut.map_or(cut, |k| k.max(cut)));
        self.error = Some(p.error);
        Ok(pages)
    }
}

/// The first local midnight in `tz` at or after `ms`.
fn midnight_at_or_after(ms: i64, tz: &jiff::tz::TimeZone) -> i64 {
    let Ok(t) = jiff::Timestamp::from_millisecond(ms) else {
        return ms;
    };
    let z = t.to_zoned(tz.clone());
    match z.start_of_day() {
        Ok(d) if d.timestamp() == t => ms,
        _ => z
            .tomorrow()
            .and_then(|n| n.start_of_day())
            .map_or(ms, |n| n.timestamp().as_millisecond()),
    }
}

/// The glucose unit a site's `status.json` names (`settings.units`:
/// `mg/dl` or `mmol`), if it names one abba reads.
pub fn site_units(status: &Value) -> Option<abba_io::units::GlucoseUnit> {
    status
        .pointer("/settings/units")
        .and_then(Value::as_str)
        .and_then(abba_io::units::GlucoseUnit::parse)
}

/// The treatments API v3's history names as changed and valid without a
/// `created_at` string that the v1 pages do not hold: their v1 documents
/// (with the `_id` the import keys by) join the pages; one v1 does not
/// serve is said in the report.
fn changed_without_created_at(
    client: &Client,
    c: Collection,
    pages: &mut fetch::Pages,
    identifiers: &[String],
) -> Result<(), NsError> {
    let held: std::collections::HashSet<String> = pages
        .docs
        .iter()
        .filter_map(fetch::doc_id)
        .chain(pages.docs.iter().filter_map(|d| {
            d.get("identifier")
                .and_then(Value::as_str)
                .map(String::from)
        }))
        .collect();
    for identifier in identifiers.iter().filter(|i| !held.contains(*i)) {
        let docs = fetch::treatments_of_identifier(client, identifier)?;
        pages.pages += 1;
        pages.received += docs.len();
        if docs.is_empty() {
            pages.unproven.push(format!(
                "API v3's history names treatment {identifier} as changed, which API v1 does not serve"
            ));
            continue;
        }
        pages.without_created_at += pages.add(c, docs);
    }
    Ok(())
}

/// The documents of `c` whose records the store holds from this site in
/// the window just read again (from `since`) but which the site no
/// longer serves: deleted through API v1, which removes a document and
/// leaves nothing to sync. The whole window is compared: treatments are
/// read from 14 hours before it (a `created_at` written with an offset is
/// compared by its string, which may read up to that much earlier).
fn gone_from(
    store: &Store,
    person: &str,
    client: &Client,
    c: Collection,
    since: Option<i64>,
    pages: &fetch::Pages,
) -> Result<Vec<String>, NsError> {
    let from = since.unwrap_or(i64::MIN);
    let served: std::collections::HashSet<String> = pages
        .docs
        .iter()
        .filter_map(fetch::doc_id)
        .chain(pages.deleted.iter().cloned())
        .collect();
    Ok(store
        .synced_documents(person, &client.site().join(c.path()), from)?
        .into_iter()
        .filter(|id| !served.contains(id))
        .collect())
}

fn json_bytes(docs: &[&Value]) -> Result<Vec<u8>, NsError> {
    serde_json::to_vec(docs).map_err(|e| NsError::Protocol {
        site: String::new(),
        call: String::new(),
        problem: e.to_string(),
    })
}
