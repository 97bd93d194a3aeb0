//! For test suites: where a test's store lives, on the backend the run
//! asks for.
//!
//! A test's store is an SQLite file in the test's folder, unless the run
//! sets `ABBA_TEST_BACKEND=postgres`: then each store is a fresh schema of
//! the database `ABBA_TEST_POSTGRES=postgres://...` names (a server the
//! run started, see `.ci/run`), reached by a URL whose `options` set the
//! search path, so the same tests run unchanged on PostgreSQL. Tests of
//! PostgreSQL itself run whenever `ABBA_TEST_POSTGRES` is set.

use crate::backend::postgres::is_url;
use std::path::{Path, PathBuf};

/// The variable naming the PostgreSQL server of a test run.
pub const POSTGRES_VAR: &str = "ABBA_TEST_POSTGRES";

/// The server's base URL when the run asks for PostgreSQL.
pub fn postgres_url() -> Option<String> {
    std::env::var(POSTGRES_VAR).ok().filter(|u| !u.is_empty())
}

/// A fresh, empty schema on the server at `base`; the URL of a store in it.
pub fn fresh_schema(base: &str) -> String {
    use std::sync::atomic::{AtomicU64, Ordering};
    static N: AtomicU64 = AtomicU64::new(0);
    let nanos = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.subsec_nanos());
    let name = format!(
        "t{}_{}_{}",
        std::process::id(),
        nanos,
        N.fetch_add(1, Ordering::Relaxed)
    );
    // (On a thread of its own: the synchronous client may not block a
    // thread that drives async tasks, as a `#[tokio::test]` does.)
    off_async(|| {
        let mut c = postgres::Client::connect(base, postgres::NoTls)
            .unwrap_or_else(|e| panic!("{POSTGRES_VAR}={base}: cannot connect: {e}"));
        c.batch_execute(&format!("CREATE SCHEMA {name}"))
            .unwrap_or_else(|e| panic!("creating schema {name}: {e}"));
    });
    let sep = if base.contains('?') { '&' } else { '?' };
    format!("{base}{sep}options=-csearch_path%3D{name}")
}

/// The variable that puts every test store on PostgreSQL
/// (`ABBA_TEST_BACKEND=postgres`, with the server in [`POSTGRES_VAR`]).
pub const BACKEND_VAR: &str = "ABBA_TEST_BACKEND";

/// Where a test's store lives: `dir/file` (SQLite), or a fresh schema on
/// the run's server when `ABBA_TEST_BACKEND=postgres`.
pub fn store_location(dir: &Path, file: &str) -> PathBuf {
    match std::env::var(BACKEND_VAR).as_deref() {
        Ok("postgres") => {
            let base = postgres_url().unwrap_or_else(|| {
                panic!("{BACKEND_VAR}=postgres needs the server in {POSTGRES_VAR}")
            });
            PathBuf::from(fresh_schema(&base))
        }
        Ok("sqlite") | Ok("") | Err(_) => dir.join(file),
        Ok(other) => panic!("{BACKEND_VAR}={other}: expected sqlite or postgres"),
    }
}

/// True when `db` is a PostgreSQL store (tests that read an SQLite file
/// directly skip it).
pub fn is_postgres(db: &Path) -> bool {
    db.to_str().is_some_and(is_url)
}

/// The rows of `table`, counted by the database itself on a connection of
/// its own (a test's look behind the store).
pub fn count_rows(db: &Path, table: &str) -> i64 {
    let sql = format!("SELECT count(*) FROM {table}");
    match db.to_str().filter(|d| is_url(d)) {
        Some(url) => off_async(|| {
            postgres::Client::connect(url, postgres::NoTls)
                .and_then(|mut c| c.query_one(sql.as_str(), &[]))
                .map(|r| r.get::<_, i64>(0))
                .unwrap_or_else(|e| panic!("counting {table}: {e}"))
        }),
        None => rusqlite::Connection::open(db)
            .and_then(|c| c.query_row(&sql, [], |r| r.get(0)))
            .unwrap_or_else(|e| panic!("counting {table}: {e}")),
    }
}

/// Runs `f` on a thread of its own (a panic goes on in the caller).
fn off_async<R: Send>(f: impl FnOnce() -> R + Send) -> R {
    std::thread::scope(|s| {
        s.spawn(f)
            .join()
            .unwrap_or_else(|p| std::panic::resume_unwind(p))
    })
}

/// A twin's prediction for tests of its words: the recorded days'
/// (time in range %, time below 70 %) and the suggestion's, each figure
/// within ± `spread` (its band), the change their difference; the check's
/// outcome as given, a margin of 1 point.
pub fn predicted_effect(
    in_force: (f64, f64),
    suggested: (f64, f64),
    spread: f64,
    check: crate::effect::CheckOutcome,
) -> crate::effect::SettingEffect {
    use crate::effect::{Band, Effect, Figures, Predicted, SettingEffect};
    let band = |v: f64| Band {
        value: v,
        low: v - spread,
        high: v + spread,
    };
    let figures = |(tir, below): (f64, f64)| Figures {
        tir_pct: band(tir),
        below_70_pct: band(below),
    };
    SettingEffect {
        effect: Effect::Predicted(Predicted {
            days: 7,
            twin_revision: 2,
            grade: "good".into(),
            in_force: figures(in_force),
            suggested: figures(suggested),
            change: figures((suggested.0 - in_force.0, suggested.1 - in_force.1)),
        }),
        check,
        margin_pp: 1.0,
    }
}
