//! A synthetic person's device data (no simulator): CGM every 5 minutes,
//! three meals with boluses, a basal change, written as Nightscout.
#![allow(dead_code)]

use abba_advisor::Mode;
use abba_core::{
    Event, EventKind, Grams, GramsPerUnit, MealSlot, MgDl, TherapySettings, Timestamp, Units,
    UnitsPerHour,
};
use abba_io::clock::AdvisorClock;
use abba_io::read::{read_all, Batch, ReadOptions};
use abba_store::{NewPerson, Store};
use jiff::tz::TimeZone;

/// Starting therapy.
pub fn start() -> TherapySettings {
    let mut s = TherapySettings::new(UnitsPerHour(0.9), GramsPerUnit(12.0)).unwrap();
    s.carb_ratio[2] = GramsPerUnit(10.0);
    s
}

/// `days` days of events from day index 0.
pub fn events(days: i64) -> Vec<Event> {
    let mut v = Vec::new();
    for day in 0..days {
        for m in (0..1440).step_by(5) {
            let at = Timestamp::from_day_and_minute(day, m);
            let g = 120.0 + 50.0 * ((m as f64 / 180.0) + day as f64).sin() + (m % 7) as f64;
            v.push(Event::new(at, EventKind::Cgm(MgDl(g.round()))));
            for (i, meal) in [(0usize, 422i64), (1, 737), (2, 1112)] {
                if m == meal - meal % 5 {
                    let at = Timestamp::from_day_and_minute(day, meal);
                    let carbs = [45.0, 60.0, 75.0][i] + day as f64;
                    v.push(Event::new(
                        at,
                        EventKind::MealAnnounced {
                            carbs: Grams(carbs),
                            slot: MealSlot::MAIN[i],
                        },
                    ));
                    v.push(Event::new(at, EventKind::Bolus(Units(carbs / 11.0))));
                }
            }
        }
        if day == 2 {
            v.push(Event::new(
                Timestamp::from_day_and_minute(day, 1439),
                EventKind::BasalRate(UnitsPerHour(0.95)),
            ));
        }
    }
    v.sort_by_key(|e| e.at);
    v
}

/// The clock: day 1 = 2026-05-04 in Zurich.
pub fn clock() -> AdvisorClock {
    AdvisorClock::new(
        TimeZone::get("Europe/Zurich").unwrap(),
        "2026-05-04".parse().unwrap(),
    )
}

/// Events as the three Nightscout files (name, bytes).
pub fn nightscout(events: &[Event]) -> Vec<(String, Vec<u8>)> {
    let f = abba_io::nightscout_out::write(events, &start(), &clock()).unwrap();
    vec![
        ("entries.json".into(), f.entries.into_bytes()),
        ("treatments.json".into(), f.treatments.into_bytes()),
        ("profile.json".into(), f.profile.into_bytes()),
    ]
}

/// Reads files (Zurich time).
pub fn read(inputs: &[(String, Vec<u8>)]) -> Result<Batch, abba_io::IoError> {
    let opts = ReadOptions {
        tz: Some(TimeZone::get("Europe/Zurich").unwrap()),
        ..ReadOptions::default()
    };
    read_all(inputs, &opts)
}

/// A person in CGM mode.
pub fn person(name: &str) -> NewPerson {
    let mut p = NewPerson::new(name, "Europe/Zurich", Mode::Cgm, start());
    p.first_day = Some("2026-05-04".parse().unwrap());
    p
}

/// A temporary directory removed on drop, and the test's store (a file in
/// it, or a PostgreSQL schema when the run asks: see
/// `abba_store::testing`).
pub struct TempDir(
    pub std::path::PathBuf,
    std::sync::OnceLock<std::path::PathBuf>,
);

impl TempDir {
    /// A new empty directory.
    pub fn new(tag: &str) -> Self {
        use std::sync::atomic::{AtomicU64, Ordering};
        static N: AtomicU64 = AtomicU64::new(0);
        let p = std::env::temp_dir().join(format!(
            "abba-store-{tag}-{}-{}",
            std::process::id(),
            N.fetch_add(1, Ordering::Relaxed)
        ));
        let _ = std::fs::remove_dir_all(&p);
        std::fs::create_dir_all(&p).unwrap();
        TempDir(p, std::sync::OnceLock::new())
    }

    /// Where the test's store is (the same every time).
    pub fn db(&self) -> &std::path::Path {
        self.1
            .get_or_init(|| abba_store::testing::store_location(&self.0, "abba.db"))
    }

    /// The test's store, opened.
    pub fn store(&self) -> Store {
        Store::open(self.db()).unwrap()
    }

    /// The rows of `table`, read by the database itself (the store keeps
    /// its connection to itself).
    #[allow(dead_code)]
    pub fn rows(&self, table: &str) -> i64 {
        abba_store::testing::count_rows(self.db(), table)
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}
