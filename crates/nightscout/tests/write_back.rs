//! Write-back against the test server: exactly one Note per suggestion
//! (enteredBy abba), updated when answered and not written twice; the
//! `abba` profile beside the default one, which stays untouched, and no
//! Profile Switch; abba's own Notes are not read back as the person's
//! data; removing what abba wrote leaves the site as it was.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::common;

use abba_nightscout::site::credential;
use abba_nightscout::{link, sync, write_back};
use abba_store::AnswerRequest;
use common::*;
use serde_json::Value;

fn abba_notes(srv: &common::server::Server) -> Vec<Value> {
    srv.with(|s| s.valid("treatments"))
        .into_iter()
        .filter(|t| t["enteredBy"] == "abba")
        .collect()
}

#[test]
fn one_note_per_suggestion_and_a_profile_beside_the_default() {
    let dir = tempfile::tempdir().unwrap();
    let d = data(5);
    let files = export(dir.path(), &d);
    let srv = server(&d, 1000);
    let profile_before = srv.with(|s| s.valid("profile"));
    let treatments_before = srv.with(|s| s.valid("treatments")).len();
    let (_, mut store) = store_with_person(dir.path(), "wb.db", &files);
    let token = credential(Some("admin-0123456789abcdef"), None).unwrap();
    link(&mut store, "ana", &srv.url, token, true, &fast_client()).unwrap();
    let r = sync(&mut store, "ana", &sync_opts()).unwrap();
    let w = r.write_back.unwrap();
    // What a person can act on: the open suggestions (none is answered yet).
    let suggestions: Vec<_> = store
        .history("ana")
        .unwrap()
        .into_iter()
        .filter(|v| v.status == "open")
        .collect();
    assert!(
        !suggestions.is_empty(),
        "15 days give the advisor decisions"
    );
    assert_eq!(w.notes_created, suggestions.len());
    let notes = abba_notes(&srv);
    assert_eq!(notes.len(), suggestions.len());
    for n in &notes {
        assert_eq!(n["eventType"], "Note");
        let text = n["notes"].as_str().unwrap();
        assert!(
            text.contains("abba suggests") && text.contains("not a medical device"),
            "{text}"
        );
    }
    // The abba profile sits beside the default, which is unchanged.
    assert!(w.profile_written, "{w:?}");
    let after = srv.with(|s| s.valid("profile"));
    assert_eq!(after.len(), profile_before.len());
    let newest = after
        .iter()
        .find(|p| p["_id"] == profile_before[0]["_id"])
        .unwrap();
    assert_eq!(
        newest["defaultProfile"],
        profile_before[0]["defaultProfile"]
    );
    let default = newest["defaultProfile"].as_str().unwrap();
    assert_eq!(
        newest["store"][default],
        profile_before[0]["store"][default]
    );
    let ours = &newest["store"]["abba"];
    assert!(
        ours["basal"].is_array() && ours["carbratio"].is_array(),
        "{ours}"
    );
    assert!(srv
        .with(|s| s.valid("treatments"))
        .iter()
        .all(|t| t["eventType"] != "Profile Switch"));

    // Again: nothing written twice, nothing read back.
    let again = sync(&mut store, "ana", &sync_opts()).unwrap();
    let wa = again.write_back.unwrap();
    assert_eq!(
        (wa.notes_created, wa.notes_updated, wa.profile_written),
        (0, 0, false)
    );
    let ia = again.import.import.unwrap();
    assert_eq!(
        (ia.added, ia.updated),
        (0, 0),
        "abba's own Notes are not the person's data"
    );
    assert_eq!(abba_notes(&srv).len(), suggestions.len());

    // Answered: the open suggestions' Notes are updated, no new one.
    let open = store
        .history("ana")
        .unwrap()
        .iter()
        .filter(|v| v.status == "open")
        .count();
    assert!(open > 0);
    store.answer("ana", &AnswerRequest::Accept).unwrap();
    let answered = sync(&mut store, "ana", &sync_opts())
        .unwrap()
        .write_back
        .unwrap();
    assert_eq!(answered.notes_created, 0);
    assert_eq!(answered.notes_updated, open);
    assert!(abba_notes(&srv)
        .iter()
        .any(|n| n["notes"].as_str().unwrap().contains("status: accepted")));

    // Removing what abba wrote leaves the site as before.
    let client =
        abba_nightscout::sync::client_of(&store.link("ana").unwrap().unwrap(), &fast_client())
            .unwrap();
    let n = write_back::delete_written(&mut store, &client, "ana").unwrap();
    assert_eq!(n, suggestions.len() + 1);
    assert!(abba_notes(&srv).is_empty());
    assert_eq!(srv.with(|s| s.valid("treatments")).len(), treatments_before);
    assert_eq!(srv.with(|s| s.valid("profile")), profile_before);
}

#[test]
fn a_token_that_may_not_write_is_refused_at_link_time() {
    let dir = tempfile::tempdir().unwrap();
    let d = data(1);
    let files = export(dir.path(), &d);
    let srv = server(&d, 1000);
    let (_, mut store) = store_with_person(dir.path(), "ro.db", &files);
    for grants_in_exchange in [true, false] {
        srv.with(|s| s.grants_in_exchange = grants_in_exchange);
        // Readable only; careportal may create treatments but not update
        // them or the profile.
        for (token, missing) in [
            ("reader-0123456789abcdef", "api:treatments:create"),
            ("care-0123456789abcdef", "api:treatments:update"),
        ] {
            let cred = credential(Some(token), None).unwrap();
            let e = link(
                &mut store,
                "ana",
                &srv.url,
                cred.clone(),
                true,
                &fast_client(),
            )
            .unwrap_err();
            let text = e.to_string();
            assert!(
                matches!(e, abba_nightscout::NsError::CannotWrite { .. }),
                "{text}"
            );
            assert!(
                text.contains(missing) && text.contains("--write-back") && !text.contains(token),
                "{text}"
            );
            assert!(store.link("ana").unwrap().is_none(), "not stored");
            // Without write-back the same token links.
            link(&mut store, "ana", &srv.url, cred, false, &fast_client()).unwrap();
            assert!(store.remove_link("ana").unwrap());
        }
        // An admin token may.
        let admin = credential(Some("admin-0123456789abcdef"), None).unwrap();
        let (_, check) = link(&mut store, "ana", &srv.url, admin, true, &fast_client()).unwrap();
        assert_eq!(check.write_unverified, None);
        assert!(store.remove_link("ana").unwrap());
    }
    // A site that tells neither way: linked, and said.
    srv.with(|s| {
        s.grants_in_exchange = false;
        s.v2_auth = false;
    });
    let reader = credential(Some("reader-0123456789abcdef"), None).unwrap();
    let (_, check) = link(&mut store, "ana", &srv.url, reader, true, &fast_client()).unwrap();
    assert!(check.write_unverified.is_some(), "{check:?}");
}

#[test]
fn a_token_whose_rights_were_taken_away_fails_the_write_back_and_says_why() {
    let dir = tempfile::tempdir().unwrap();
    let d = data(5);
    let files = export(dir.path(), &d);
    let srv = server(&d, 1000);
    let (_, mut store) = store_with_person(dir.path(), "ro.db", &files);
    let token = credential(Some("reader-0123456789abcdef"), None).unwrap();
    // (Stored directly: linking would refuse it.)
    store.set_link("ana", &srv.url, &token, true).unwrap();
    let e = sync(&mut store, "ana", &sync_opts()).unwrap_err();
    let text = e.to_string();
    assert!(
        text.contains("401") && text.contains("POST /api/v1/treatments"),
        "{text}"
    );
    // The records of the sync are in: the write-back comes after the import.
    assert!(!store.records("ana").unwrap().is_empty());
    assert!(abba_notes(&srv).is_empty());
}

/// The first write-back of a person with two weeks of decisions: a Note
/// for each suggestion a person can act on (open or answered), not for
/// the superseded ones, the basal not offered or the decisions without an
/// update; each dated at its decision, its values as the CLI shows them.
#[test]
fn the_first_write_back_writes_what_can_be_acted_on_at_its_time() {
    let dir = tempfile::tempdir().unwrap();
    let d = data(5);
    let files = export(dir.path(), &d);
    let srv = server(&d, 1000);
    let (_, mut store) = store_with_person(dir.path(), "wb.db", &files);
    let token = credential(Some("admin-0123456789abcdef"), None).unwrap();
    link(&mut store, "ana", &srv.url, token, true, &fast_client()).unwrap();
    let r = sync(&mut store, "ana", &sync_opts()).unwrap();
    let history = store.history("ana").unwrap();
    let open: Vec<_> = history.iter().filter(|v| v.status == "open").collect();
    assert!(
        history
            .iter()
            .any(|v| v.status == "superseded" || v.status == "not_offered"),
        "the fixture's two weeks hold decisions nobody can act on"
    );
    assert_eq!(r.write_back.unwrap().notes_created, open.len());
    let notes = abba_notes(&srv);
    assert_eq!(notes.len(), open.len());
    let tz = jiff::tz::TimeZone::get(TZ).unwrap();
    for v in &open {
        let at = jiff::civil::DateTime::strptime("%Y-%m-%d %H:%M", &v.decided_at)
            .unwrap()
            .to_zoned(tz.clone())
            .unwrap()
            .timestamp();
        let when = at.strftime("%Y-%m-%dT%H:%M:%S%.3fZ").to_string();
        let n = notes
            .iter()
            .find(|n| n["created_at"] == when.as_str())
            .unwrap_or_else(|| panic!("no Note at {when}: {notes:?}"));
        // The Note's own line (the reasons after "Why:" are the advisor's words).
        let text = n["notes"].as_str().unwrap();
        let head = text.split(" Why:").next().unwrap();
        let shown = format!(
            "{} {:.3} {} (was {:.3},",
            v.setting, v.suggested, v.unit, v.previous
        );
        assert!(head.contains(&shown), "{shown} in {head}");
        assert!(!text.contains(&v.suggested.to_string()), "{text}");
        assert!(
            !head.contains("+0.0 %") && !head.contains("-0.0 %"),
            "{head}"
        );
    }
}

/// Nightscout stores a POSTed treatment without `identifier` or `_id` by
/// a replace keyed by its `created_at` and `eventType` (the test server
/// as `lib/server/treatments.js`): a Note the person entered at a
/// decision's minute is kept, and abba's goes a millisecond later.
#[test]
fn a_note_the_site_holds_at_a_decisions_instant_is_not_replaced() {
    let dir = tempfile::tempdir().unwrap();
    let d = data(5);
    let files = export(dir.path(), &d);
    let srv = server(&d, 1000);
    let (_, mut store) = store_with_person(dir.path(), "wb.db", &files);
    let token = credential(Some("admin-0123456789abcdef"), None).unwrap();
    // A first sync without write-back gives the decisions' times.
    link(
        &mut store,
        "ana",
        &srv.url,
        token.clone(),
        false,
        &fast_client(),
    )
    .unwrap();
    sync(&mut store, "ana", &sync_opts()).unwrap();
    let tz = jiff::tz::TimeZone::get(TZ).unwrap();
    let instant = |decided_at: &str| {
        jiff::civil::DateTime::strptime("%Y-%m-%d %H:%M", decided_at)
            .unwrap()
            .to_zoned(tz.clone())
            .unwrap()
            .timestamp()
    };
    let open: Vec<_> = store
        .history("ana")
        .unwrap()
        .into_iter()
        .filter(|v| v.status == "open")
        .collect();
    assert!(!open.is_empty());
    // The person's own Notes, entered in Careportal at those minutes.
    let theirs: Vec<Value> = open
        .iter()
        .map(|v| {
            let at = instant(&v.decided_at);
            serde_json::json!({
                "_id": object_id(at.as_millisecond(), 7),
                "eventType": "Note",
                "enteredBy": "ana",
                "created_at": at.strftime("%Y-%m-%dT%H:%M:%S%.3fZ").to_string(),
                "notes": format!("my own note for {}", v.setting),
            })
        })
        .collect();
    srv.with(|s| s.add("treatments", theirs.clone()));
    link(&mut store, "ana", &srv.url, token, true, &fast_client()).unwrap();
    let w = sync(&mut store, "ana", &sync_opts())
        .unwrap()
        .write_back
        .unwrap();
    assert_eq!(w.notes_created, open.len(), "{w:?}");
    let held = srv.with(|s| s.valid("treatments"));
    for t in &theirs {
        assert!(held.contains(t), "the person's Note was replaced: {t}");
    }
    let notes = abba_notes(&srv);
    assert_eq!(notes.len(), open.len());
    for v in &open {
        let when = (instant(&v.decided_at) + jiff::SignedDuration::from_millis(1))
            .strftime("%Y-%m-%dT%H:%M:%S%.3fZ")
            .to_string();
        assert!(
            notes.iter().any(|n| n["created_at"] == when.as_str()),
            "no Note of abba at {when}: {notes:?}"
        );
    }
    // Written once: the next sync neither writes nor moves them.
    let again = sync(&mut store, "ana", &sync_opts())
        .unwrap()
        .write_back
        .unwrap();
    assert_eq!((again.notes_created, again.notes_updated), (0, 0));
    assert_eq!(abba_notes(&srv), notes);
}

/// A server that routes PUT by id, as nightscout/nocturne (Nightscout's
/// API rewritten in C#) does: `PUT /api/v1/treatments/{id}` only (405
/// where Nightscout takes it), no profile update. The answered
/// suggestions' Notes are updated there; the profile is said to be not
/// written, and the sync does not fail on it.
#[test]
fn a_server_that_puts_by_id_gets_the_notes_updated_and_says_no_profile() {
    let dir = tempfile::tempdir().unwrap();
    let d = data(5);
    let files = export(dir.path(), &d);
    let srv = server(&d, 1000);
    srv.with(|s| s.put_by_id = true);
    let (_, mut store) = store_with_person(dir.path(), "wb.db", &files);
    let token = credential(Some("admin-0123456789abcdef"), None).unwrap();
    link(&mut store, "ana", &srv.url, token, true, &fast_client()).unwrap();
    let w = sync(&mut store, "ana", &sync_opts())
        .unwrap()
        .write_back
        .unwrap();
    assert!(w.notes_created > 0, "{w:?}");
    assert!(!w.profile_written, "{w:?}");
    let why = w.profile_skipped.unwrap();
    assert!(
        why.contains("PUT /api/v1/profile") && why.contains("405"),
        "{why}"
    );
    store.answer("ana", &AnswerRequest::Accept).unwrap();
    let answered = sync(&mut store, "ana", &sync_opts())
        .unwrap()
        .write_back
        .unwrap();
    assert!(answered.notes_updated > 0, "{answered:?}");
    assert!(abba_notes(&srv)
        .iter()
        .any(|n| n["notes"].as_str().unwrap().contains("status: accepted")));
    assert!(srv.with(|s| s
        .log
        .iter()
        .any(|l| l.starts_with("PUT /api/v1/treatments/"))));
}
