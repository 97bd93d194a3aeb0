//! Cost of one advisor over a 97-day event stream (D2-D98), per arm and mode.
//! The stream is open-loop (fixed readings), which is what the advisor's
//! cost depends on. Run: `cargo bench -p abba-advisor --bench observe`.
#![allow(missing_docs, clippy::unwrap_used, clippy::expect_used)]

use abba_advisor::{AbbaConfig, Advisor, AdvisorSpec, Mode, R2rConfig};
use abba_core::{
    Event, EventKind, Grams, GramsPerUnit, MealSlot, MgDl, TherapySettings, Timestamp, Units,
    UnitsPerHour,
};
use criterion::{criterion_group, criterion_main, Criterion};

fn stream(mode: Mode) -> Vec<Event> {
    let mut v = Vec::new();
    for day in 1..98i64 {
        for minute in 0..1440i64 {
            let at = Timestamp::from_day_and_minute(day, minute);
            let g = 130.0 + 60.0 * ((minute as f64) / 229.0 + day as f64).sin();
            if minute % 5 == 0 && (mode == Mode::Cgm || day < 8) {
                v.push(Event::new(at, EventKind::Cgm(MgDl(g))));
            }
            if mode == Mode::Cgm && minute == 0 && day > 1 {
                v.push(Event::new(at, EventKind::DayClosed));
            }
            if mode == Mode::Smbg && [400, 700, 1090, 1380].contains(&minute) {
                v.push(Event::new(at, EventKind::Smbg(MgDl(g.round()))));
            }
            for (i, m) in [(0usize, 420i64), (1, 720), (2, 1110)] {
                if minute == m {
                    v.push(Event::new(
                        at,
                        EventKind::MealAnnounced {
                            carbs: Grams(50.0),
                            slot: MealSlot::MAIN[i],
                        },
                    ));
                    v.push(Event::new(at, EventKind::Bolus(Units(5.0))));
                }
            }
            if mode == Mode::Smbg && minute == 1380 {
                v.push(Event::new(at, EventKind::DayClosed));
            }
        }
    }
    v
}

fn bench(c: &mut Criterion) {
    let start = TherapySettings::new(UnitsPerHour(1.0), GramsPerUnit(10.0)).unwrap();
    for mode in [Mode::Cgm, Mode::Smbg] {
        let events = stream(mode);
        let specs = [
            ("abba", AdvisorSpec::Abba(AbbaConfig::new(mode, 0))),
            ("r2r", AdvisorSpec::RunToRun(R2rConfig::new(mode))),
        ];
        for (name, spec) in specs {
            c.bench_function(&format!("{name}_{}_97_days", mode.name()), |b| {
                b.iter(|| {
                    let mut a = spec.build(start, 1).unwrap();
                    let mut n = 0usize;
                    for e in &events {
                        if a.observe(e).unwrap().is_some() {
                            n += 1;
                        }
                    }
                    n += a.take_decisions().len();
                    n
                })
            });
        }
    }
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(20);
    targets = bench
}
criterion_main!(benches);
