//! Reading 10 years of 5-minute CGM (1,051,920 rows) from one file: a
//! plain CSV with UTC times and a Dexcom Clarity export with local wall
//! times in Europe/Zurich (time-zone and DST resolution on every row).
//! Run: `cargo bench -p abba-io --bench read_cgm`. Memory: see
//! `examples/read_file.rs` (BENCHMARKS.md has both figures).
#![allow(missing_docs, clippy::unwrap_used, clippy::expect_used)]

use abba_io::{read_all, ReadOptions};
use criterion::{criterion_group, criterion_main, Criterion};

#[path = "../examples/ten_years.rs"]
mod ten_years;

fn bench(c: &mut Criterion) {
    let mut group = c.benchmark_group("read_10_years_5min_cgm");
    group.sample_size(10);
    for (name, bytes, tz) in [
        ("plain_csv_utc", ten_years::plain_csv(), None),
        (
            "clarity_zurich",
            ten_years::clarity(),
            Some("Europe/Zurich"),
        ),
    ] {
        let opts = ReadOptions {
            tz: tz.map(|z| abba_io::time::zone(z).unwrap()),
            ..ReadOptions::default()
        };
        let input = vec![(name.to_string(), bytes)];
        let n = read_all(&input, &opts).unwrap().records.len();
        assert_eq!(n, ten_years::ROWS);
        group.bench_function(name, |b| {
            b.iter(|| read_all(&input, &opts).unwrap().records.len())
        });
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
