//! One source per local day for each kind of data: what keeps one pump's
//! insulin from being counted twice when it reaches the log by two routes
//! (a CareLink or Tidepool export beside the same days in Nightscout, a
//! Dexcom Clarity export beside the Dexcom readings Nightscout holds).
//!
//! Two routes never carry one datum alike: the same bolus comes seconds or
//! minutes apart (the pump's clock, an uploader's, a share bridge's), a
//! reading comes as mg/dL from one and rounded mmol/L from the other, and
//! neither carries an identifier the other knows. Matching copies across
//! routes would guess. So the import stores every record of every source,
//! and this module chooses, whenever events are derived from the log, one
//! source for each kind of data ([`DataClass`]: CGM glucose, meter glucose,
//! insulin delivery, carbohydrate) on each local day of the person (in
//! their zone): a day with one source is that source's; on a day with
//! several, the one that covers it best is used and the others' records of
//! that kind are kept in the log but set aside, counted and said (with the
//! import and with the advice).
//!
//! The rule, the fuller source of a kind on a day:
//! 1. the most records of that kind that day: an export that ends at 10:00,
//!    or two doses typed into the Dexcom app, has fewer than the pump's or
//!    the uploader's whole day, and a gap of an hour costs twelve readings;
//! 2. on a tie, the widest span between its first and last record of that
//!    kind that day (the one that reaches further into the day);
//! 3. on a tie again, a fixed order: the device makers' own exports first
//!    (CareLink, Tidepool, Clarity, LibreView: read from the device's
//!    memory), then Nightscout (a relay of what uploaders sent), then
//!    plain CSV.
//!
//! The rule reads only the stored records, never the order in which they
//! came, so the same files imported in any order give the same choice, the
//! same events and the same advice; a later, fuller export takes a day
//! over from a partial one without anything being lost. Records dropped
//! by an earlier version of this rule (which stored only the first source
//! of each day) cannot come back: import that file again.
//!
//! Other tools do not merge across routes either: Tidepool deduplicates a
//! later upload of one device against that device's earlier upload
//! sessions (tidepool-org/TidepoolApi, `docs/quick-start/uploading-device-data.md`),
//! and Nightscout merges only documents of the same `identifier`, `_id`,
//! or `created_at` and `eventType` (cgm-remote-monitor,
//! `lib/server/treatments.js`); one device's data reaching either by a
//! second route is kept twice.

use crate::backend::{args, Db, Q};
use crate::error::StoreError;
use abba_io::{Record, RecordKind, Source};
use jiff::civil::Date;
use jiff::tz::TimeZone;
use jiff::Timestamp;
use serde::Serialize;
use std::cmp::Ordering;
use std::collections::{BTreeMap, BTreeSet, HashSet};

/// A kind of data taken from one source per day.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum DataClass {
    /// CGM readings.
    Glucose,
    /// Meter (finger-stick) readings: a linked meter's reading reaches a
    /// pump's export and Nightscout alike.
    Meter,
    /// Insulin delivery: boluses, extended boluses, temporary basals,
    /// suspends and resumes, long-acting injections.
    Insulin,
    /// Carbohydrate.
    Carbs,
}

impl DataClass {
    /// The kind of data in words.
    pub fn words(self) -> &'static str {
        match self {
            DataClass::Glucose => "CGM glucose",
            DataClass::Meter => "meter glucose",
            DataClass::Insulin => "insulin",
            DataClass::Carbs => "carbohydrate",
        }
    }
    /// The class of a record's kind, if it is taken from one source per day
    /// (every kind named: a new one must be placed here).
    pub fn of(kind: &RecordKind) -> Option<DataClass> {
        match kind {
            RecordKind::Cgm { .. } => Some(DataClass::Glucose),
            RecordKind::Smbg { .. } => Some(DataClass::Meter),
            RecordKind::Bolus { .. }
            | RecordKind::ExtendedBolus { .. }
            | RecordKind::TempBasal { .. }
            | RecordKind::Suspend { .. }
            | RecordKind::Resume
            | RecordKind::LongActing { .. } => Some(DataClass::Insulin),
            RecordKind::Carbs { .. } => Some(DataClass::Carbs),
            RecordKind::Schedule { .. } | RecordKind::Ignored { .. } => None,
        }
    }
    /// The class of a kind by its short name ([`RecordKind::name`], which
    /// is also its stored `type`).
    fn of_name(name: &str) -> Option<DataClass> {
        match name {
            "cgm" => Some(DataClass::Glucose),
            "smbg" => Some(DataClass::Meter),
            "bolus" | "extended_bolus" | "temp_basal" | "suspend" | "resume" | "long_acting" => {
                Some(DataClass::Insulin)
            }
            "carbs" => Some(DataClass::Carbs),
            _ => None,
        }
    }
}

/// Every source, each once (checked against [`rank`], which names each).
const ALL_SOURCES: [Source; 6] = [
    Source::CareLink,
    Source::Tidepool,
    Source::Clarity,
    Source::LibreView,
    Source::Nightscout,
    Source::PlainCsv,
];

/// The fixed order of the rule's last tie (see the module documentation):
/// lower first.
fn rank(s: Source) -> u8 {
    // A new source is placed here and in `ALL_SOURCES`.
    match s {
        Source::CareLink => 0,
        Source::Tidepool => 1,
        Source::Clarity => 2,
        Source::LibreView => 3,
        Source::Nightscout => 4,
        Source::PlainCsv => 5,
    }
}

/// What one source holds of one kind on one day.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Cover {
    count: usize,
    first_ms: i64,
    last_ms: i64,
}

impl Cover {
    fn new(at_ms: i64) -> Cover {
        Cover {
            count: 0,
            first_ms: at_ms,
            last_ms: at_ms,
        }
    }
    fn add(&mut self, at_ms: i64) {
        self.count += 1;
        self.first_ms = self.first_ms.min(at_ms);
        self.last_ms = self.last_ms.max(at_ms);
    }
}

/// `Greater` when `a` covers its day better than `b` (the rule).
fn fuller(a: (Source, Cover), b: (Source, Cover)) -> Ordering {
    a.1.count
        .cmp(&b.1.count)
        .then_with(|| (a.1.last_ms - a.1.first_ms).cmp(&(b.1.last_ms - b.1.first_ms)))
        .then_with(|| rank(b.0).cmp(&rank(a.0)))
}

/// Records of one kind from one source, kept in the log but not used on
/// their days because another source covers those days better.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct SetAside {
    /// The kind of data.
    pub class: DataClass,
    /// The source of the records set aside.
    pub source: Source,
    /// The source used on their days instead.
    pub used: Source,
    /// How many records.
    pub count: usize,
    /// On how many local days.
    pub days: usize,
    /// The first of those days (local).
    pub first_day: String,
    /// The last of those days (local).
    pub last_day: String,
    /// The instant of the first record set aside.
    pub first_at: String,
}

/// The local day of instants that mostly come in order: the day's bounds
/// are kept, so the zone is asked only when an instant leaves them.
struct Days<'a> {
    tz: &'a TimeZone,
    from_ms: i64,
    to_ms: i64,
    date: Date,
}

impl<'a> Days<'a> {
    fn new(tz: &'a TimeZone) -> Days<'a> {
        Days {
            tz,
            from_ms: 0,
            to_ms: 0,
            date: Date::default(),
        }
    }
    fn of(&mut self, at: Timestamp) -> Date {
        let ms = at.as_millisecond();
        if ms >= self.from_ms && ms < self.to_ms {
            return self.date;
        }
        let date = self.tz.to_datetime(at).date();
        let start = |d: Date| {
            d.to_zoned(self.tz.clone())
                .map(|z| z.timestamp().as_millisecond())
        };
        match (start(date), date.tomorrow().map(start)) {
            (Ok(from), Ok(Ok(to))) if from <= ms && ms < to => {
                (self.from_ms, self.to_ms) = (from, to);
            }
            // Out of the zone's range: ask again next time.
            _ => (self.from_ms, self.to_ms) = (0, 0),
        }
        self.date = date;
        date
    }
}

/// What each source holds of each kind on each local day.
#[derive(Default)]
struct Tally {
    by: BTreeMap<(DataClass, Date), BTreeMap<Source, Cover>>,
    /// For each kind, the run of records of one day and source being
    /// counted (a log comes in order: a map look-up per run, not per
    /// record).
    run: [Option<(Date, Source, Cover)>; 4],
}

impl Tally {
    fn add(&mut self, class: DataClass, day: Date, source: Source, at_ms: i64) {
        let run = &mut self.run[class as usize];
        match run {
            Some((d, s, c)) if *d == day && *s == source => c.add(at_ms),
            _ => {
                if let Some((d, s, c)) = run.take() {
                    Self::put(&mut self.by, class, d, s, c);
                }
                let mut c = Cover::new(at_ms);
                c.add(at_ms);
                *run = Some((day, source, c));
            }
        }
    }

    fn put(
        by: &mut BTreeMap<(DataClass, Date), BTreeMap<Source, Cover>>,
        class: DataClass,
        day: Date,
        source: Source,
        c: Cover,
    ) {
        let e = by
            .entry((class, day))
            .or_default()
            .entry(source)
            .or_insert_with(|| Cover::new(c.first_ms));
        e.count += c.count;
        e.first_ms = e.first_ms.min(c.first_ms);
        e.last_ms = e.last_ms.max(c.last_ms);
    }

    /// Every run counted (call once all records are added).
    fn close(&mut self) {
        for (i, class) in [
            DataClass::Glucose,
            DataClass::Meter,
            DataClass::Insulin,
            DataClass::Carbs,
        ]
        .into_iter()
        .enumerate()
        {
            if let Some((d, s, c)) = self.run[i].take() {
                Self::put(&mut self.by, class, d, s, c);
            }
        }
    }

    /// The source used for each (kind, day) that more than one source holds.
    fn used(&self) -> BTreeMap<(DataClass, Date), Source> {
        self.by
            .iter()
            .filter(|(_, s)| s.len() > 1)
            .filter_map(|(k, s)| {
                let best = s
                    .iter()
                    .map(|(s, c)| (*s, *c))
                    .max_by(|a, b| fuller(*a, *b))?;
                Some((*k, best.0))
            })
            .collect()
    }

    /// What is set aside on the days `only` names (all when `None`), by
    /// kind, source and the source used.
    fn set_aside(&self, only: Option<&HashSet<(DataClass, Date)>>) -> Vec<SetAside> {
        let mut out: BTreeMap<(DataClass, Source, Source), SetAside> = BTreeMap::new();
        for (key, used) in self.used() {
            if only.is_some_and(|o| !o.contains(&key)) {
                continue;
            }
            let (class, day) = key;
            for (source, cover) in &self.by[&key] {
                if *source == used {
                    continue;
                }
                let first_at = Timestamp::from_millisecond(cover.first_ms)
                    .map(|t| t.to_string())
                    .unwrap_or_default();
                let e = out
                    .entry((class, *source, used))
                    .or_insert_with(|| SetAside {
                        class,
                        source: *source,
                        used,
                        count: 0,
                        days: 0,
                        first_day: day.to_string(),
                        last_day: day.to_string(),
                        first_at,
                    });
                // Days come in order: the first seen is the first.
                e.count += cover.count;
                e.days += 1;
                e.last_day = day.to_string();
            }
        }
        out.into_values().collect()
    }
}

/// The records used for events, and what was set aside.
#[derive(Debug, Clone, Default)]
pub struct Chosen {
    /// The records used, in the order given.
    pub records: Vec<Record>,
    /// What was set aside, by kind, source and the source used.
    pub set_aside: Vec<SetAside>,
    /// Records left out as dated before the person's day 1, and day 1
    /// ([`crate::day_1::used`]; `None` from [`choose`] alone).
    pub before_day_1: Option<(usize, Date)>,
}

impl Chosen {
    /// A sentence for each [`SetAside`], then one for the records before
    /// day 1.
    pub fn notes(&self) -> Vec<String> {
        self.set_aside
            .iter()
            .map(sentence)
            .chain(self.before_day_1.map(|(n, d)| crate::day_1::sentence(n, d)))
            .collect()
    }
}

/// The records of `records` used for events, one source for each kind of
/// data on each local day in `tz` (see the module documentation), and what
/// was set aside. The order of `records` is kept.
pub fn choose(tz: &TimeZone, mut records: Vec<Record>) -> Chosen {
    let mut days = Days::new(tz);
    let mut tally = Tally::default();
    for r in &records {
        if let Some(class) = DataClass::of(&r.kind) {
            tally.add(class, days.of(r.at), r.source, r.at.as_millisecond());
        }
    }
    tally.close();
    let used = tally.used();
    if used.is_empty() {
        return Chosen {
            records,
            ..Chosen::default()
        };
    }
    records.retain(
        |r| match DataClass::of(&r.kind).and_then(|c| used.get(&(c, days.of(r.at)))) {
            Some(s) => *s == r.source,
            None => true,
        },
    );
    Chosen {
        records,
        set_aside: tally.set_aside(None),
        before_day_1: None,
    }
}

/// What the log holds set aside, now, on the days (in `tz`) that
/// `records` (an import's) fall on: said with that import.
pub fn set_aside_on_days(
    db: &dyn Db,
    person: i64,
    tz: &TimeZone,
    records: &[&Record],
) -> Result<Vec<SetAside>, StoreError> {
    let mut days = Days::new(tz);
    let mut wanted: HashSet<(DataClass, Date)> = HashSet::new();
    let (mut from, mut to) = (i64::MAX, i64::MIN);
    for r in records {
        if let Some(class) = DataClass::of(&r.kind) {
            wanted.insert((class, days.of(r.at)));
            from = from.min(r.at.as_millisecond());
            to = to.max(r.at.as_millisecond());
        }
    }
    if wanted.is_empty() {
        return Ok(Vec::new());
    }
    // One source in the import and none other in the log (a person's usual
    // case): nothing can be set aside, and a long import is not read again.
    let sources: BTreeSet<Source> = records.iter().map(|r| r.source).collect();
    if sources.len() == 1 {
        let mut others = false;
        for s in ALL_SOURCES.iter().filter(|s| !sources.contains(s)) {
            let name = crate::log::source_text(*s)?;
            others |= db.row(Q::RecordOfSource, args![person, name])?.is_some();
        }
        if !others {
            return Ok(Vec::new());
        }
    }
    let wanted_days: BTreeSet<Date> = wanted.iter().map(|k| k.1).collect();
    // A day of a zone is at most 26 h: a margin of two days each side
    // takes in every stored record of the days touched.
    let margin = 2 * 86_400_000;
    let mut tally = Tally::default();
    db.each_row(
        Q::RecordKindsInWindow,
        args![person, from - margin, to + margin],
        &mut |row| {
            let Some(class) = stored_type(row.str(1)?).and_then(DataClass::of_name) else {
                return Ok(());
            };
            let at_ms = row.int(2)?;
            let at = Timestamp::from_millisecond(at_ms)
                .map_err(|e| StoreError::corrupt("record instant", e))?;
            let day = days.of(at);
            if wanted_days.contains(&day) {
                let source = crate::log::parse_source(row.str(0)?)?;
                tally.add(class, day, source, at_ms);
            }
            Ok(())
        },
    )?;
    tally.close();
    Ok(tally.set_aside(Some(&wanted)))
}

/// The stored `type` of a record's kind, from the start of its JSON text.
fn stored_type(prefix: &str) -> Option<&str> {
    let rest = prefix.strip_prefix("{\"type\":\"")?;
    rest.split('"').next()
}

/// A sentence for one [`SetAside`] of the log: "stored, not used".
pub fn sentence(o: &SetAside) -> String {
    sentence_as(o, "stored")
}

/// A sentence for one [`SetAside`], the records `held` ("stored" in the
/// log, "read" from files that are not imported), not used.
pub fn sentence_as(o: &SetAside, held: &str) -> String {
    let (days, those) = if o.days == 1 {
        (o.first_day.clone(), "that day")
    } else {
        (
            format!("{} days, {} to {}", o.days, o.first_day, o.last_day),
            "those days",
        )
    };
    format!(
        "{} {} record{} from {} ({days}) {held}, not used: on {those} {} covers the {} more \
         fully and is used (one source per day for each kind of data, so that one pump's doses \
         or one sensor's readings reaching abba by two routes are not counted twice); the \
         first: {}.",
        o.count,
        o.class.words(),
        if o.count == 1 { "" } else { "s" },
        o.source.name(),
        o.used.name(),
        o.class.words(),
        o.first_at
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use abba_core::Units;
    use abba_io::record::{Origin, OriginAt};
    use abba_io::SourceId;

    fn zone() -> TimeZone {
        TimeZone::get("America/Chicago").unwrap()
    }

    /// A record of `source` at local `at` (Chicago).
    fn rec(source: Source, at: &str, kind: RecordKind) -> Record {
        let at = at
            .parse::<jiff::civil::DateTime>()
            .unwrap()
            .to_zoned(zone())
            .unwrap()
            .timestamp();
        Record {
            id: abba_io::record::content_id(source, at, &kind),
            at,
            kind,
            source,
            origin: Origin {
                file: 0,
                at: OriginAt::Item(0),
            },
        }
    }

    fn bolus(source: Source, at: &str) -> Record {
        rec(source, at, RecordKind::Bolus { units: Units(1.0) })
    }

    fn sorted(mut r: Vec<Record>) -> Vec<(Timestamp, Source, SourceId)> {
        let mut v: Vec<_> = r.drain(..).map(|r| (r.at, r.source, r.id)).collect();
        v.sort();
        v
    }

    #[test]
    fn a_day_goes_to_the_source_with_more_records_of_that_kind_whatever_the_order() {
        let records = vec![
            bolus(Source::CareLink, "2025-03-14T08:00"),
            bolus(Source::CareLink, "2025-03-14T12:00"),
            bolus(Source::CareLink, "2025-03-15T07:50"),
            bolus(Source::Nightscout, "2025-03-15T07:51"),
            bolus(Source::Nightscout, "2025-03-15T11:45"),
            bolus(Source::Nightscout, "2025-03-15T18:00"),
        ];
        let mut reversed = records.clone();
        reversed.reverse();
        let a = choose(&zone(), records);
        let b = choose(&zone(), reversed);
        assert_eq!(sorted(a.records.clone()), sorted(b.records));
        assert_eq!(a.set_aside, b.set_aside);
        // The export's other day stays; its one bolus of the 15th gives
        // way to Nightscout's three.
        let used: Vec<(Source, String)> = a
            .records
            .iter()
            .map(|r| (r.source, zone().to_datetime(r.at).date().to_string()))
            .collect();
        assert_eq!(used.len(), 5);
        assert!(!used.contains(&(Source::CareLink, "2025-03-15".into())));
        assert_eq!(
            a.set_aside,
            [SetAside {
                class: DataClass::Insulin,
                source: Source::CareLink,
                used: Source::Nightscout,
                count: 1,
                days: 1,
                first_day: "2025-03-15".into(),
                last_day: "2025-03-15".into(),
                first_at: "2025-03-15T12:50:00Z".into(),
            }]
        );
    }

    #[test]
    fn a_tie_goes_to_the_wider_span_then_to_the_device_makers_export() {
        // Two each: Nightscout's reach further into the day.
        let wider = choose(
            &zone(),
            vec![
                bolus(Source::CareLink, "2025-03-15T08:00"),
                bolus(Source::CareLink, "2025-03-15T09:00"),
                bolus(Source::Nightscout, "2025-03-15T08:00:30"),
                bolus(Source::Nightscout, "2025-03-15T20:00"),
            ],
        );
        assert!(wider.records.iter().all(|r| r.source == Source::Nightscout));
        // The same count and span: CareLink, before Nightscout.
        let same = choose(
            &zone(),
            vec![
                bolus(Source::Nightscout, "2025-03-15T08:00:30"),
                bolus(Source::Nightscout, "2025-03-15T12:00:30"),
                bolus(Source::CareLink, "2025-03-15T08:00"),
                bolus(Source::CareLink, "2025-03-15T12:00"),
            ],
        );
        assert!(same.records.iter().all(|r| r.source == Source::CareLink));
        assert_eq!(same.set_aside[0].count, 2);
    }

    #[test]
    fn each_kind_of_data_is_chosen_apart() {
        let glucose = |s, at| {
            rec(
                s,
                at,
                RecordKind::Cgm {
                    glucose: abba_io::record::Glucose::exact(120.0),
                },
            )
        };
        let chosen = choose(
            &zone(),
            vec![
                glucose(Source::Clarity, "2025-03-15T08:00"),
                glucose(Source::Nightscout, "2025-03-15T08:01"),
                glucose(Source::Nightscout, "2025-03-15T08:06"),
                bolus(Source::Nightscout, "2025-03-15T08:02"),
                bolus(Source::CareLink, "2025-03-15T08:02"),
                bolus(Source::CareLink, "2025-03-15T12:02"),
                // A record of no kind chosen: always kept.
                rec(
                    Source::Nightscout,
                    "2025-03-15T00:00",
                    RecordKind::Ignored {
                        kind: "note".into(),
                    },
                ),
            ],
        );
        let used: Vec<(&str, Source)> = chosen
            .records
            .iter()
            .map(|r| (r.kind.name(), r.source))
            .collect();
        assert_eq!(
            used,
            [
                ("cgm", Source::Nightscout),
                ("cgm", Source::Nightscout),
                ("bolus", Source::CareLink),
                ("bolus", Source::CareLink),
                ("ignored", Source::Nightscout),
            ]
        );
        assert_eq!(chosen.set_aside.len(), 2);
    }

    #[test]
    fn a_kind_has_one_class_read_from_the_record_or_from_its_stored_text() {
        let units = Units(1.0);
        let g = abba_io::record::Glucose::exact(100.0);
        for kind in [
            RecordKind::Cgm { glucose: g },
            RecordKind::Smbg { glucose: g },
            RecordKind::Carbs {
                grams: abba_core::Grams(10.0),
            },
            RecordKind::Bolus { units },
            RecordKind::Resume,
            RecordKind::Ignored {
                kind: "note".into(),
            },
        ] {
            let text = serde_json::to_string(&kind).unwrap();
            let stored = stored_type(&text[..text.len().min(24)]).and_then(DataClass::of_name);
            assert_eq!(DataClass::of(&kind), stored, "{text}");
        }
    }

    #[test]
    fn local_days_are_the_zones_across_its_clock_changes() {
        let tz = zone();
        let mut days = Days::new(&tz);
        let start: Timestamp = "2025-03-08T00:00:00Z".parse().unwrap();
        for k in 0..(4 * 24 * 60 / 7) {
            let at = start + jiff::SignedDuration::from_mins(7 * k);
            assert_eq!(days.of(at), tz.to_datetime(at).date(), "{at}");
        }
        // Out of order too.
        for at in [
            "2025-03-09T07:59:00Z",
            "2025-03-08T06:00:00Z",
            "2025-03-09T08:01:00Z",
        ] {
            let at: Timestamp = at.parse().unwrap();
            assert_eq!(days.of(at), tz.to_datetime(at).date(), "{at}");
        }
    }
}
