//! Person names a clinician can tell apart on a list: characters that
//! show nothing, reorder text or are not letters of any script are
//! refused (with the character's place and code point); names are stored
//! composed (NFC), so one name typed two ways is one name; a name that
//! looks like another person's (confusable skeletons of UTS #39: another
//! script's or width's look-alike letters, ignoring case) is refused, in
//! the creation's write transaction, and on stores made before the check.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::common::{person, TempDir};
use abba_store::schema::{current_version, Step, STEPS};
use abba_store::{Store, StoreError};

/// The problem of a refused name (panics when it was not refused as
/// invalid).
fn refused(store: &mut Store, name: &str) -> String {
    match store.create_person(&person(name)) {
        Err(StoreError::Invalid { field, problem }) => {
            assert_eq!(field, "--name", "{name:?}");
            problem
        }
        other => panic!("{name:?}: expected a refusal, got {other:?}"),
    }
}

/// The existing person a name was refused for looking like.
fn looks_like(store: &mut Store, name: &str) -> String {
    match store.create_person(&person(name)) {
        Err(e @ StoreError::PersonLookAlike { .. }) => {
            let text = e.to_string();
            let StoreError::PersonLookAlike { existing, .. } = e else {
                unreachable!()
            };
            assert!(
                text.contains(&format!("\"{existing}\"")) && text.contains("looks like"),
                "{text}"
            );
            existing
        }
        other => panic!("{name:?}: expected a look-alike refusal, got {other:?}"),
    }
}

#[test]
fn invisible_format_and_blank_characters_are_refused_with_their_place_and_code_point() {
    let dir = TempDir::new("names-chars");
    let mut store = dir.store();
    store.create_person(&person("bob")).unwrap();
    store.create_person(&person("ana")).unwrap();
    // (name, place of the refused character, its code point)
    let cases = [
        // A tag character, a soft hyphen, a combining grapheme joiner
        // beside names that exist.
        ("bob\u{E0020}", 4, "\\u{e0020}"),
        ("ana\u{00AD}", 4, "\\u{ad}"),
        ("ana\u{034F}", 4, "\\u{34f}"),
        // The Arabic letter mark (a bidirectional control).
        ("x\u{061C}ALM", 2, "\\u{61c}"),
        // Names that show as nothing.
        ("\u{3164}", 1, "\\u{3164}"),
        ("\u{00AD}", 1, "\\u{ad}"),
        ("\u{2800}", 1, "\\u{2800}"),
        ("\u{115F}\u{1160}", 1, "\\u{115f}"),
        ("\u{FFA0}ana", 1, "\\u{ffa0}"),
        // Line and paragraph separators, other white space.
        ("x\u{2028}y", 2, "\\u{2028}"),
        ("x\u{2029}y", 2, "\\u{2029}"),
        ("ana\u{00A0}maria", 4, "\\u{a0}"),
        ("ana\u{2003}maria", 4, "\\u{2003}"),
        ("ana\u{3000}maria", 4, "\\u{3000}"),
        // Other format characters, variation selectors.
        ("x\u{FFF9}y", 2, "\\u{fff9}"),
        ("x\u{180E}y", 2, "\\u{180e}"),
        ("x\u{FE0F}y", 2, "\\u{fe0f}"),
        ("ana\u{E0100}", 4, "\\u{e0100}"),
        ("ana\u{180B}", 4, "\\u{180b}"),
        ("ana\u{17B4}", 4, "\\u{17b4}"),
        ("ana\u{200B}", 4, "\\u{200b}"),
        ("ana\u{2064}", 4, "\\u{2064}"),
        ("ana\u{1BCA0}", 4, "\\u{1bca0}"),
        ("\u{E0001}ana", 1, "\\u{e0001}"),
        // Private use; unassigned.
        ("ana\u{E000}", 4, "\\u{e000}"),
        ("ana\u{F0000}", 4, "\\u{f0000}"),
        ("ana\u{0378}", 4, "\\u{378}"),
        ("ana\u{10FFFF}", 4, "\\u{10ffff}"),
        // A combining mark first.
        ("\u{0301}ana", 1, "\\u{301}"),
        ("\u{20DD}", 1, "\\u{20dd}"),
        // Control characters, as before.
        ("ana\u{1b}[31m", 4, "\\u{1b}"),
        ("ana\u{85}bob", 4, "\\u{85}"),
    ];
    for (name, place, code) in cases {
        let p = refused(&mut store, name);
        assert!(
            p.contains(&format!("character {place} is {code}:")),
            "{name:?}: {p}"
        );
    }
    // Places count in the name as given, spaces at either end trimmed.
    let p = refused(&mut store, "  ab\u{00AD}");
    assert!(p.contains("character 3 is \\u{ad}"), "{p}");
    // At least one letter or digit.
    for name in ["-", "'", "...", "--- ---", "\u{2605}", "(\u{00B7})"] {
        let p = refused(&mut store, name);
        assert!(p.contains("at least one letter or digit"), "{name:?}: {p}");
    }
    // Blank names, as before.
    for name in ["", "   ", "\u{3000}", "\u{2028}"] {
        let p = refused(&mut store, name);
        assert!(p.contains("expected 1 to 200 characters"), "{name:?}: {p}");
    }
    assert_eq!(store.persons().unwrap(), ["ana", "bob"]);
}

#[test]
fn ordinary_names_of_many_scripts_are_accepted_as_written() {
    let dir = TempDir::new("names-scripts");
    let mut store = dir.store();
    let names = [
        "Zoë",
        "José María",
        "O'Brien",
        "李小龍",
        "Mateusz Żółw",
        "محمد",
        "Ελένη",
        "Сергей Иванов",
        "Nguyễn Thị Minh Khai",
        "Þórunn Ólafsdóttir",
        "Søren Kierkegaard",
        "Chloé-Anne",
        "Jean\u{2011}Luc",
        "श्रीनिवास",
        "김민준",
        "小林 さくら",
        "דוד",
        "สมชาย",
        "Ngũgĩ wa Thiong'o",
        "Anna 2",
        "ana",
        "Ana Maria",
        "Ana María",
        "Emoji \u{1F600}",
    ];
    for name in names {
        let p = store.create_person(&person(name)).unwrap();
        assert_eq!(p.name, name);
        assert_eq!(store.person(name).unwrap().name, name);
    }
    let mut want: Vec<String> = names.iter().map(|n| n.to_string()).collect();
    want.sort();
    assert_eq!(store.persons().unwrap(), want);
}

#[test]
fn names_are_stored_composed_so_one_name_typed_two_ways_is_one() {
    let dir = TempDir::new("names-nfc");
    let mut store = dir.store();
    let nfc = "An\u{00E1}";
    let nfd = "Ana\u{0301}";
    // Through NewPerson::new (which stores what the seed was made of) ...
    let p = store.create_person(&person(nfd)).unwrap();
    assert_eq!(p.name, nfc);
    assert_eq!(store.persons().unwrap(), [nfc]);
    // ... and with the name set by hand.
    let mut other = person("x");
    other.name = "Jos\u{0065}\u{0301}".into();
    assert_eq!(store.create_person(&other).unwrap().name, "Jos\u{00E9}");
    // The other spelling, any case, is the same name.
    for same in [nfc, nfd, "ANA\u{0301}", "an\u{00E1}"] {
        assert!(
            matches!(
                store.create_person(&person(same)),
                Err(StoreError::PersonExists(ref n)) if n == nfc
            ),
            "{same:?}"
        );
    }
    // Found by either spelling.
    assert_eq!(store.person(nfd).unwrap().name, nfc);
    assert_eq!(store.person(nfc).unwrap().id, p.id);
}

#[test]
fn a_name_that_looks_like_another_persons_is_refused_and_names_it() {
    let dir = TempDir::new("names-confusable");
    let mut store = dir.store();
    for name in ["ana", "O'Brien", "Carmen", "Ian", "BOB", "ana maria"] {
        store.create_person(&person(name)).unwrap();
    }
    let cases = [
        // Cyrillic a, fullwidth a, fullwidth capitals, Greek capitals.
        ("\u{0430}na", "ana"),
        ("\u{FF41}na", "ana"),
        ("\u{FF21}\u{FF2E}\u{FF21}", "ana"),
        ("\u{0391}NA", "ana"),
        // A right single quotation mark for the apostrophe.
        ("O\u{2019}Brien", "O'Brien"),
        // "rn" for "m".
        ("Carrnen", "Carmen"),
        // A small l for a capital I; a digit zero for a capital O.
        ("lan", "Ian"),
        ("B0B", "BOB"),
        // Two spaces for one (a web page shows them as one).
        ("ana  maria", "ana maria"),
        // Mathematical letters.
        ("\u{1D41A}na", "ana"),
    ];
    for (name, existing) in cases {
        assert_eq!(looks_like(&mut store, name), existing, "{name:?}");
    }
    // The message spells both names' code points beyond ASCII.
    let e = store.create_person(&person("\u{0430}na")).unwrap_err();
    assert!(e.to_string().contains("\\u{430}na"), "{e}");
    // Names that only resemble each other are different names.
    for name in ["anna", "Ana María", "Obrien", "Carmen 2", "Ivan", "bo"] {
        store.create_person(&person(name)).unwrap();
    }
}

#[test]
fn two_creations_at_once_of_look_alike_names_do_not_both_pass() {
    let dir = TempDir::new("names-race");
    drop(dir.store());
    for round in 0..5 {
        let a = format!("p{round}a");
        let b = format!("p{round}\u{0430}");
        let barrier = std::sync::Barrier::new(2);
        let results: Vec<Result<_, StoreError>> = std::thread::scope(|s| {
            let hs: Vec<_> = [a, b]
                .into_iter()
                .map(|name| {
                    let barrier = &barrier;
                    let db = dir.db().to_path_buf();
                    s.spawn(move || {
                        let mut store = Store::open(&db).unwrap();
                        barrier.wait();
                        store.create_person(&person(&name))
                    })
                })
                .collect();
            hs.into_iter().map(|h| h.join().unwrap()).collect()
        });
        let ok = results.iter().filter(|r| r.is_ok()).count();
        assert_eq!(ok, 1, "round {round}: {results:?}");
        assert!(
            results
                .iter()
                .any(|r| matches!(r, Err(StoreError::PersonLookAlike { .. }))),
            "round {round}: {results:?}"
        );
    }
    assert_eq!(dir.store().persons().unwrap().len(), 5);
}

#[test]
fn a_copy_of_a_store_keeps_what_names_look_like() {
    let dir = TempDir::new("names-copy");
    let mut from = dir.store();
    from.create_person(&person("ana")).unwrap();
    let mut to = Store::open(&dir.0.join("copy.db")).unwrap();
    from.copy_into(&mut to).unwrap();
    assert_eq!(looks_like(&mut to, "\u{0430}na"), "ana");
}

/// A store at schema version 8 (before names were compared as they
/// look) holding `names` as written, made by the steps' own DDL.
fn store_at_version_8(path: &std::path::Path, names: &[&str]) {
    let c = rusqlite::Connection::open(path).unwrap();
    let steps = STEPS.iter().position(|s| *s == Step::NameLooks).unwrap();
    assert_eq!(steps, 8);
    for s in &STEPS[..steps] {
        c.execute_batch(abba_store::backend::sqlite::schema::ddl(*s))
            .unwrap();
    }
    c.pragma_update(None, "user_version", 8i64).unwrap();
    let p = person("x");
    let settings = serde_json::to_string(&p.settings).unwrap();
    for name in names {
        c.execute(
            "INSERT INTO person (name, tz, mode, first_day, settings, created_at) VALUES (?1, 'Europe/Zurich', 'cgm', '2026-05-04', ?2, '2026-05-04T00:00:00Z')",
            rusqlite::params![name, settings],
        )
        .unwrap();
    }
}

#[test]
fn a_store_whose_persons_already_look_alike_migrates_and_keeps_them() {
    let dir = TempDir::new("names-migrate");
    let path = dir.0.join("v8.db");
    // Stored before the checks: look-alikes, an NFD name beside its NFC
    // spelling, a blank-looking name.
    let old = [
        "ana",
        "\u{0430}na",
        "An\u{00E1}",
        "Ana\u{0301}",
        "\u{3164}",
        "ben",
    ];
    store_at_version_8(&path, &old);
    let mut store = Store::open(&path).unwrap();
    let v: i64 = rusqlite::Connection::open(&path)
        .unwrap()
        .pragma_query_value(None, "user_version", |r| r.get(0))
        .unwrap();
    assert_eq!(v, current_version());
    // Every person kept as stored, each found by the name as stored.
    let mut want: Vec<String> = old.iter().map(|n| n.to_string()).collect();
    want.sort();
    assert_eq!(store.persons().unwrap(), want);
    for name in old {
        assert_eq!(store.person(name).unwrap().name, name);
    }
    assert_eq!(
        abba_store::testing::count_rows(
            &path,
            "person WHERE skeleton_folded IS NULL OR skeleton_cased IS NULL"
        ),
        0
    );
    // New look-alikes of any of them are refused; other names go on.
    assert_eq!(looks_like(&mut store, "\u{FF41}na"), "ana");
    assert_eq!(looks_like(&mut store, "b\u{0435}n"), "ben");
    assert!(matches!(
        store.create_person(&person("AN\u{00C1}")),
        Err(StoreError::PersonExists(_))
    ));
    store.create_person(&person("cleo")).unwrap();
    // Opened again: nothing more to migrate.
    drop(store);
    assert_eq!(Store::open(&path).unwrap().persons().unwrap().len(), 7);
}

#[test]
fn a_store_made_by_an_earlier_release_migrates_with_its_persons() {
    // The CLI's migration fixture (schema 8, written by release 090b9aa).
    let fixture = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../cli/tests/data/migration/v8-090b9aa/store.db");
    let dir = TempDir::new("names-fixture");
    let path = dir.0.join("store.db");
    std::fs::copy(&fixture, &path).unwrap();
    let mut store = Store::open(&path).unwrap();
    assert_eq!(store.persons().unwrap(), ["ana", "ben"]);
    assert_eq!(looks_like(&mut store, "\u{0430}na"), "ana");
    assert_eq!(looks_like(&mut store, "b\u{0435}n"), "ben");
}

#[test]
fn a_postgresql_store_whose_persons_already_look_alike_migrates_and_keeps_them() {
    let Some(base) = abba_store::testing::postgres_url() else {
        assert!(
            !std::env::var("CI").is_ok_and(|v| v == "true"),
            "CI=true but {} is not set",
            abba_store::testing::POSTGRES_VAR
        );
        eprintln!(
            "skipped: no PostgreSQL server ({} is not set)",
            abba_store::testing::POSTGRES_VAR
        );
        return;
    };
    let url = abba_store::testing::fresh_schema(&base);
    let old = ["ana", "\u{0430}na", "An\u{00E1}", "Ana\u{0301}", "ben"];
    {
        let mut c = postgres::Client::connect(&url, postgres::NoTls).unwrap();
        c.batch_execute("CREATE TABLE abba_schema (version BIGINT NOT NULL); INSERT INTO abba_schema VALUES (8);")
            .unwrap();
        for s in &STEPS[..8] {
            c.batch_execute(abba_store::backend::postgres::schema::ddl(*s))
                .unwrap();
        }
        let settings = serde_json::to_string(&person("x").settings).unwrap();
        for name in old {
            c.execute(
                "INSERT INTO person (name, tz, mode, first_day, settings, created_at) VALUES ($1, 'Europe/Zurich', 'cgm', '2026-05-04', $2, '2026-05-04T00:00:00Z')",
                &[&name, &settings],
            )
            .unwrap();
        }
    }
    let path = std::path::PathBuf::from(&url);
    let mut store = Store::open(&path).unwrap();
    let mut want: Vec<String> = old.iter().map(|n| n.to_string()).collect();
    want.sort();
    assert_eq!(store.persons().unwrap(), want);
    assert_eq!(
        abba_store::testing::count_rows(
            &path,
            "person WHERE skeleton_folded IS NULL OR skeleton_cased IS NULL"
        ),
        0
    );
    assert_eq!(looks_like(&mut store, "\u{FF41}na"), "ana");
    assert_eq!(looks_like(&mut store, "b\u{0435}n"), "ben");
    store.create_person(&person("cleo")).unwrap();
}
