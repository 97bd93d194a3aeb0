//! PostgreSQL's text of the store's statements: SQLite's text with its
//! `?N` placeholders renumbered as `$N`, except where the dialects differ
//! (upserts, `IS` against a parameter, SQLite's `GLOB` and `INDEXED BY`,
//! `max` of two values, the order of text, generated ids).

use super::super::sqlite::sql as lite;
use super::super::Q;
use std::borrow::Cow;

/// The ids of inserted rows are returned by the insert itself.
pub fn returning_id(q: Q) -> bool {
    matches!(
        q,
        Q::ImportPut | Q::PersonPut | Q::TokenPut | Q::SigninLinkPut | Q::WebSessionPut
    )
}

/// PostgreSQL's own text of a statement, where it is not SQLite's.
fn own(q: Q) -> Option<&'static str> {
    Some(match q {
        Q::SnapshotPut => {
            "INSERT INTO snapshot (person_id, events, events_hash, answers, unused, state) VALUES ($1, $2, $3, $4, $5, $6)
             ON CONFLICT (person_id) DO UPDATE SET events = excluded.events, events_hash = excluded.events_hash, answers = excluded.answers, unused = excluded.unused, state = excluded.state"
        }
        Q::SuggestionPut => {
            "INSERT INTO suggestion (person_id, at_min, parameter, old, new, skipped, decision) VALUES ($1, $2, $3, $4, $5, $6, $7)
             ON CONFLICT (person_id, at_min, parameter) DO UPDATE SET old = excluded.old, new = excluded.new, skipped = excluded.skipped, decision = excluded.decision"
        }
        Q::FileEvidencePut => {
            "INSERT INTO file_evidence (person_id, file_hash, file, evidence) VALUES ($1, $2, $3, $4)
             ON CONFLICT (person_id, file_hash) DO UPDATE SET file = excluded.file, evidence = excluded.evidence"
        }
        Q::NightscoutWrittenPut => {
            "INSERT INTO nightscout_written (person_id, what, key, remote_id, content, written_at) VALUES ($1, $2, $3, $4, $5, $6)
             ON CONFLICT (person_id, what, key) DO UPDATE SET remote_id = excluded.remote_id, content = excluded.content, written_at = excluded.written_at"
        }
        Q::NightscoutMarkPut => {
            "INSERT INTO nightscout_mark (person_id, collection, mark_ms) VALUES ($1, $2, $3)
             ON CONFLICT (person_id, collection) DO UPDATE SET mark_ms = greatest(nightscout_mark.mark_ms, excluded.mark_ms)"
        }
        Q::PersonRevBump => {
            "INSERT INTO person_rev VALUES ($1, 1) ON CONFLICT (person_id) DO UPDATE SET rev = person_rev.rev + 1"
        }
        // The planner has statistics: no index hint (nor the syntax).
        Q::AppEventProducers => {
            "SELECT seq, kind FROM app_event WHERE person_id = $1 AND at_min = $2 AND tag IN ('day_closed', 'meal_announced') ORDER BY seq"
        }
        Q::PersonNamesNotAscii => "SELECT name FROM person WHERE name ~ '[^ -~]'",
        Q::WebSessionsOf => {
            "SELECT id, role, person_id, created_ms, seen_ms, expires_ms FROM web_session
             WHERE role = $1 AND person_id IS NOT DISTINCT FROM $2 AND revoked_ms IS NULL AND expires_ms > $3 AND seen_ms > $4
             ORDER BY id DESC"
        }
        Q::TokensOf => {
            "SELECT id, created_at, revoked_at FROM token WHERE role = $1 AND person_id IS NOT DISTINCT FROM $2 ORDER BY id DESC"
        }
        // Identity columns continue after the ids a copy wrote.
        Q::CopyResetIds => "SELECT setval(pg_get_serial_sequence('person', 'id'), (SELECT coalesce(max(id), 0) + 1 FROM person), false), setval(pg_get_serial_sequence('import', 'id'), (SELECT coalesce(max(id), 0) + 1 FROM import), false), setval(pg_get_serial_sequence('answer', 'id'), (SELECT coalesce(max(id), 0) + 1 FROM answer), false), setval(pg_get_serial_sequence('token', 'id'), (SELECT coalesce(max(id), 0) + 1 FROM token), false), setval(pg_get_serial_sequence('therapy_change', 'id'), (SELECT coalesce(max(id), 0) + 1 FROM therapy_change), false), setval(pg_get_serial_sequence('signin_link', 'id'), (SELECT coalesce(max(id), 0) + 1 FROM signin_link), false), setval(pg_get_serial_sequence('web_session', 'id'), (SELECT coalesce(max(id), 0) + 1 FROM web_session), false)",
        _ => return None,
    })
}

/// `?N` → `$N` (the store's statements hold no `?` in a literal).
fn renumber(sql: &str) -> String {
    sql.replace('?', "$")
}

/// PostgreSQL's text of a statement.
pub fn text(q: Q) -> Cow<'static, str> {
    let base: Cow<'static, str> = match own(q) {
        Some(t) => Cow::Borrowed(t),
        None => Cow::Owned(renumber(lite::text(q))),
    };
    if returning_id(q) {
        Cow::Owned(format!("{base} RETURNING id"))
    } else {
        base
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn no_statement_keeps_a_sqlite_placeholder_or_hint() {
        for q in lite::ALL {
            let t = text(*q);
            assert!(!t.contains('?'), "{q:?}: {t}");
            for word in ["INSERT OR", "INDEXED BY", "GLOB", " IS ?", " IS $"] {
                assert!(!t.contains(word), "{q:?} has {word}: {t}");
            }
        }
    }
}
