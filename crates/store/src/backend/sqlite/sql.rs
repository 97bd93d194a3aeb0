//! SQLite's text of every statement the store runs, by name ([`Q`]).
//!
//! The names are the seam: the logic asks for `Q::AppEventPut`, each
//! backend says how its dialect spells it. Placeholders are `?1`, `?2`...
//! (numbered, so one value may be used twice).

/// Declares [`Q`] and [`text`] from one list of `Name = "SQL";`.
macro_rules! statements {
    ($($(#[$doc:meta])* $name:ident = $sql:expr;)*) => {
        /// A statement of the store, by name (see each backend's text).
        #[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
        pub enum Q {
            $($(#[$doc])* $name,)*
        }

        /// SQLite's text of a statement.
        pub fn text(q: Q) -> &'static str {
            match q {
                $(Q::$name => $sql,)*
            }
        }

        /// Every statement (a test prepares each one on every backend).
        pub const ALL: &[Q] = &[$(Q::$name),*];
    };
}

statements! {
    // store
    /// Ping.
    Ping = "SELECT count(*) FROM person";
    /// Snapshot get.
    SnapshotGet = "SELECT events, events_hash, answers, unused, state FROM snapshot WHERE person_id = ?1";
    /// Snapshot put.
    SnapshotPut = "INSERT OR REPLACE INTO snapshot (person_id, events, events_hash, answers, unused, state) VALUES (?1, ?2, ?3, ?4, ?5, ?6)";
    /// Suggestion decisions.
    SuggestionDecisions = "SELECT decision FROM suggestion WHERE person_id = ?1 ORDER BY at_min, parameter";
    /// Suggestion delete all.
    SuggestionDeleteAll = "DELETE FROM suggestion WHERE person_id = ?1";
    /// Suggestion put.
    SuggestionPut = "INSERT OR REPLACE INTO suggestion (person_id, at_min, parameter, old, new, skipped, decision) VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7)";
    /// Record count and last import.
    RecordCountAndLastImport = "SELECT count(*), coalesce(max(import_id), 0) FROM record WHERE person_id = ?1";
    /// Record first glucose at or after ?2 (ms: the start of day 1).
    RecordFirstGlucose = "SELECT min(at_ms) FROM record WHERE person_id = ?1 AND at_ms >= ?2 AND (kind LIKE '{\"type\":\"cgm\"%' OR kind LIKE '{\"type\":\"smbg\"%')";
    // answer
    /// Answers of.
    AnswersOf = "SELECT at_min, parameter, answer, suggested, previous, in_force, answered_at FROM answer WHERE person_id = ?1";
    /// Answer put.
    AnswerPut = "INSERT INTO answer (person_id, at_min, parameter, answer, suggested, previous, in_force, answered_at) VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8)";
    // app
    /// App event count.
    AppEventCount = "SELECT count(*) FROM app_event WHERE person_id = ?1";
    /// Record count.
    RecordCount = "SELECT count(*) FROM record WHERE person_id = ?1";
    /// App event hash.
    AppEventHash = "SELECT hash FROM app_event WHERE person_id = ?1 AND seq = ?2";
    /// App event put.
    AppEventPut = "INSERT INTO app_event (person_id, seq, at_ms, at_min, tag, kind, hash, received_at) VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8)";
    /// App events of.
    AppEventsOf = "SELECT seq, at_min, kind FROM app_event WHERE person_id = ?1 ORDER BY at_min, seq";
    /// App events after (minute, seq), in the advisor's order.
    AppEventsAfter = "SELECT seq, at_min, kind FROM app_event WHERE person_id = ?1 AND (at_min, seq) > (?2, ?3) ORDER BY at_min, seq";
    /// App event one.
    AppEventOne = "SELECT at_min, kind FROM app_event WHERE person_id = ?1 AND seq = ?2";
    /// App event seqs from.
    AppEventSeqsFrom = "SELECT seq FROM app_event WHERE person_id = ?1 AND seq >= ?2 ORDER BY seq";
    /// App event last seq.
    AppEventLastSeq = "SELECT max(seq) FROM app_event WHERE person_id = ?1";
    /// INDEXED BY: without statistics SQLite's planner takes the primary key's (person_id) prefix and scans the person's whole log, ~10 ms per call on a year of data (a history page asks this once per suggestion).
    AppEventProducers = "SELECT seq, kind FROM app_event INDEXED BY app_event_by_time WHERE person_id = ?1 AND at_min = ?2 AND tag IN ('day_closed', 'meal_announced') ORDER BY seq";
    // check
    /// Future app events.
    FutureAppEvents = "SELECT p.name, a.person_id, a.seq, a.tag, a.at_ms FROM app_event a JOIN person p ON p.id = a.person_id WHERE a.at_ms > ?1 ORDER BY p.name, a.at_ms, a.seq";
    /// Future records.
    FutureRecords = "SELECT p.name, r.person_id, r.source, r.source_id, r.kind, r.at_ms FROM record r JOIN person p ON p.id = r.person_id WHERE r.at_ms > ?1 ORDER BY p.name, r.at_ms, r.source, r.source_id";
    /// App event delete after.
    AppEventDeleteAfter = "DELETE FROM app_event WHERE person_id = ?1 AND at_ms > ?2";
    /// Record delete after.
    RecordDeleteAfter = "DELETE FROM record WHERE person_id = ?1 AND at_ms > ?2";
    /// Answer delete after.
    AnswerDeleteAfter = "DELETE FROM answer WHERE person_id = ?1 AND at_min > ?2";
    /// Snapshot delete.
    SnapshotDelete = "DELETE FROM snapshot WHERE person_id = ?1";
    // import
    /// Import put.
    ImportPut = "INSERT INTO import (person_id, imported_at, files, formats, records_read, records_added, records_known) VALUES (?1, ?2, ?3, ?4, ?5, 0, 0)";
    /// Record held.
    RecordHeld = "SELECT at_ms, kind FROM record WHERE person_id = ?1 AND source = ?2 AND source_id = ?3";
    /// Record replace.
    RecordReplace = "UPDATE record SET at_ms = ?4, kind = ?5, origin = ?6, import_id = ?7 WHERE person_id = ?1 AND source = ?2 AND source_id = ?3";
    /// Record same content.
    RecordSameContent = "SELECT 1 FROM record WHERE person_id = ?1 AND at_ms BETWEEN ?2 AND ?3 AND source = ?4 AND kind = ?5 LIMIT 1";
    /// The origins of the records of the same source, kind and values
    /// within a window stored by another import (copies uploaded again
    /// under another id, unless their pump identities differ).
    RecordCopyElsewhere = "SELECT origin FROM record WHERE person_id = ?1 AND at_ms BETWEEN ?2 AND ?3 AND source = ?4 AND kind = ?5 AND import_id <> ?6";
    /// The source, the start of the kind (its `type`) and the instant of
    /// each record in a window (`abba_store::one_source`: what an import
    /// says was set aside on its days).
    RecordKindsInWindow = "SELECT source, substr(kind, 1, 24), at_ms FROM record WHERE person_id = ?1 AND at_ms BETWEEN ?2 AND ?3";
    /// Whether the log holds any record of a source (the primary key's
    /// prefix: no scan).
    RecordOfSource = "SELECT 1 FROM record WHERE person_id = ?1 AND source = ?2 LIMIT 1";
    /// The records of one source at one instant stored by other imports
    /// (`abba_store::edited`).
    RecordsAtInstant = "SELECT source_id, kind FROM record WHERE person_id = ?1 AND source = ?2 AND at_ms = ?3 AND import_id <> ?4";
    /// The instants at which the log holds a glucose reading of one
    /// source within a window (`abba_store::other_unit`).
    RecordGlucoseInstants = "SELECT at_ms FROM record WHERE person_id = ?1 AND source = ?2 AND at_ms BETWEEN ?3 AND ?4 AND (kind LIKE '{\"type\":\"cgm\"%' OR kind LIKE '{\"type\":\"smbg\"%')";
    /// Record put.
    RecordPut = "INSERT INTO record (person_id, source, source_id, at_ms, kind, origin, import_id) VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7)";
    /// Import delete.
    ImportDelete = "DELETE FROM import WHERE id = ?1";
    /// Import counts.
    ImportCounts = "UPDATE import SET records_added = ?1, records_known = ?2 WHERE id = ?3";
    /// Imports of.
    ImportsOf = "SELECT id, imported_at, files, records_read, records_added FROM import WHERE person_id = ?1 ORDER BY id";
    // in_force
    /// Therapy changes of.
    TherapyChangesOf = "SELECT change FROM therapy_change WHERE person_id = ?1 ORDER BY at_ms, id";
    /// Therapy change put.
    TherapyChangePut = "INSERT INTO therapy_change (person_id, at_ms, change, recorded_at) VALUES (?1, ?2, ?3, ?4)";
    /// Person rev bump.
    PersonRevBump = "INSERT INTO person_rev VALUES (?1, 1) ON CONFLICT (person_id) DO UPDATE SET rev = rev + 1";
    /// File evidence of.
    FileEvidenceOf = "SELECT evidence FROM file_evidence WHERE person_id = ?1";
    /// File evidence put.
    FileEvidencePut = "INSERT OR REPLACE INTO file_evidence (person_id, file_hash, file, evidence) VALUES (?1, ?2, ?3, ?4)";
    // link
    /// File evidence one.
    FileEvidenceOne = "SELECT evidence FROM file_evidence WHERE person_id = ?1 AND file_hash = ?2";
    /// Nightscout record delete.
    NightscoutRecordDelete = "DELETE FROM record WHERE person_id = ?1 AND source = 'nightscout' AND source_id = ?2";
    /// Nightscout record parts delete.
    NightscoutRecordPartsDelete = "DELETE FROM record WHERE person_id = ?1 AND source = 'nightscout' AND substr(source_id, 1, ?3) = ?2";
    /// Nightscout mark put.
    NightscoutMarkPut = "INSERT INTO nightscout_mark (person_id, collection, mark_ms) VALUES (?1, ?2, ?3) ON CONFLICT (person_id, collection) DO UPDATE SET mark_ms = max(mark_ms, excluded.mark_ms)";
    /// Nightscout link url.
    NightscoutLinkUrl = "SELECT url FROM nightscout_link WHERE person_id = ?1";
    /// Nightscout marks delete.
    NightscoutMarksDelete = "DELETE FROM nightscout_mark WHERE person_id = ?1";
    /// Nightscout written delete all.
    NightscoutWrittenDeleteAll = "DELETE FROM nightscout_written WHERE person_id = ?1";
    /// Nightscout link put.
    NightscoutLinkPut = "INSERT INTO nightscout_link (person_id, url, credential_kind, credential, write_back, created_at) VALUES (?1, ?2, ?3, ?4, ?5, ?6) ON CONFLICT (person_id) DO UPDATE SET url = excluded.url, credential_kind = excluded.credential_kind, credential = excluded.credential, write_back = excluded.write_back";
    /// Nightscout link of.
    NightscoutLinkOf = "SELECT p.name, l.url, l.credential_kind, l.credential, l.write_back, l.created_at, l.last_sync_at, l.last_success_at, l.last_error, l.failures, l.last_warnings FROM nightscout_link l JOIN person p ON p.id = l.person_id WHERE l.person_id = ?1";
    /// Nightscout links.
    NightscoutLinks = "SELECT p.name, l.url, l.credential_kind, l.credential, l.write_back, l.created_at, l.last_sync_at, l.last_success_at, l.last_error, l.failures, l.last_warnings FROM nightscout_link l JOIN person p ON p.id = l.person_id ORDER BY p.name";
    /// Nightscout link delete.
    NightscoutLinkDelete = "DELETE FROM nightscout_link WHERE person_id = ?1";
    /// Nightscout marks of.
    NightscoutMarksOf = "SELECT collection, mark_ms FROM nightscout_mark WHERE person_id = ?1";
    /// Nightscout sync succeeded.
    NightscoutSyncSucceeded = "UPDATE nightscout_link SET last_sync_at = ?2, last_success_at = ?2, last_error = NULL, failures = 0, last_warnings = ?3 WHERE person_id = ?1";
    /// Nightscout sync failed.
    NightscoutSyncFailed = "UPDATE nightscout_link SET last_sync_at = ?2, last_error = ?3, failures = failures + 1 WHERE person_id = ?1";
    /// Nightscout staged put.
    NightscoutStagedPut = "INSERT INTO nightscout_staged (person_id, collection, docs) VALUES (?1, ?2, ?3) ON CONFLICT (person_id, collection) DO UPDATE SET docs = excluded.docs";
    /// Nightscout staged of.
    NightscoutStagedOf = "SELECT collection, docs FROM nightscout_staged WHERE person_id = ?1 ORDER BY collection";
    /// Nightscout staged delete.
    NightscoutStagedDelete = "DELETE FROM nightscout_staged WHERE person_id = ?1";
    /// Nightscout documents.
    NightscoutDocuments = "SELECT source_id FROM record WHERE person_id = ?1 AND source = 'nightscout' AND at_ms >= ?2 AND substr(origin, 1, ?4) = ?3";
    /// Nightscout written of.
    NightscoutWrittenOf = "SELECT what, key, remote_id, content FROM nightscout_written WHERE person_id = ?1 ORDER BY what, key";
    /// Nightscout written put.
    NightscoutWrittenPut = "INSERT OR REPLACE INTO nightscout_written (person_id, what, key, remote_id, content, written_at) VALUES (?1, ?2, ?3, ?4, ?5, ?6)";
    /// Nightscout written delete.
    NightscoutWrittenDelete = "DELETE FROM nightscout_written WHERE person_id = ?1 AND what = ?2 AND key = ?3";
    // live
    /// App event last key.
    AppEventLastKey = "SELECT at_min, seq FROM app_event WHERE person_id = ?1 ORDER BY at_min DESC, seq DESC LIMIT 1";
    /// Person rev.
    PersonRev = "SELECT rev FROM person_rev WHERE person_id = ?1";
    /// Suggestion latest id.
    SuggestionLatestId = "SELECT max(at_min * 4 + CASE parameter WHEN 'basal' THEN 0 WHEN 'breakfast' THEN 1 WHEN 'lunch' THEN 2 ELSE 3 END) FROM suggestion WHERE person_id = ?1";
    // log
    /// Records keyed by index.
    RecordsKeyedByIndex = "SELECT person_id, source, source_id, at_ms, kind FROM record WHERE source_id LIKE '{\"index\":%'";
    /// Record rekey.
    RecordRekey = "UPDATE record SET source_id = ?1 WHERE person_id = ?2 AND source = ?3 AND source_id = ?4";
    /// Record delete.
    RecordDelete = "DELETE FROM record WHERE person_id = ?1 AND source = ?2 AND source_id = ?3";
    /// A scan of the primary key (no per-row index look-ups), sorted by the caller.
    RecordsOf = "SELECT source, source_id, at_ms, kind, import_id FROM record WHERE person_id = ?1";
    // person
    /// Person names folded.
    PersonNamesFolded = "SELECT name FROM person WHERE lower(name) = ?1";
    /// Person names not ascii.
    PersonNamesNotAscii = "SELECT name FROM person WHERE name GLOB '*[^ -~]*'";
    /// Person put.
    PersonPut = "INSERT INTO person (name, tz, mode, first_day, settings, created_at, skeleton_folded, skeleton_cased) VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8)";
    /// The oldest person whose name looks like one with these keys (by the indexes of schema step 9).
    PersonNameLookAlike = "SELECT name FROM person WHERE skeleton_folded = ?1 OR skeleton_cased = ?2 ORDER BY id LIMIT 1";
    /// Every person's id and name (schema step 9).
    PersonIdsAndNames = "SELECT id, name FROM person ORDER BY id";
    /// The keys of what a person's name looks like (schema step 9).
    PersonNameLooksPut = "UPDATE person SET skeleton_folded = ?1, skeleton_cased = ?2 WHERE id = ?3";
    /// Person settings put.
    PersonSettingsPut = "UPDATE person SET settings = ?1 WHERE id = ?2";
    /// Person by name.
    PersonByName = "SELECT id, tz, first_day, settings FROM person WHERE name = ?1";
    /// Person by id.
    PersonById = "SELECT name, tz, first_day, settings FROM person WHERE id = ?1";
    /// Person first day put.
    PersonFirstDayPut = "UPDATE person SET first_day = ?1 WHERE id = ?2 AND first_day IS NULL";
    /// Person names.
    PersonNames = "SELECT name FROM person ORDER BY name";
    // session
    /// Signin link put.
    SigninLinkPut = "INSERT INTO signin_link (hash, role, person_id, created_ms, expires_ms) VALUES (?1, ?2, ?3, ?4, ?5)";
    /// Signin link use.
    SigninLinkUse = "UPDATE signin_link SET used_ms = ?1 WHERE hash = ?2 AND used_ms IS NULL";
    /// Web session put.
    WebSessionPut = "INSERT INTO web_session (hash, role, person_id, csrf, created_ms, seen_ms, expires_ms) VALUES (?1, ?2, ?3, ?4, ?5, ?5, ?6)";
    /// Web session by hash.
    WebSessionByHash = "SELECT id, hash, role, person_id, csrf, seen_ms, expires_ms FROM web_session WHERE hash = ?1 AND revoked_ms IS NULL";
    /// Web session seen.
    WebSessionSeen = "UPDATE web_session SET seen_ms = ?1 WHERE id = ?2";
    /// Web session count.
    WebSessionCount = "SELECT count(*) FROM web_session WHERE id = ?1";
    /// Web session revoke.
    WebSessionRevoke = "UPDATE web_session SET revoked_ms = ?1 WHERE id = ?2 AND revoked_ms IS NULL";
    /// Web sessions of.
    WebSessionsOf = "SELECT id, role, person_id, created_ms, seen_ms, expires_ms FROM web_session WHERE role = ?1 AND person_id IS ?2 AND revoked_ms IS NULL AND expires_ms > ?3 AND seen_ms > ?4 ORDER BY id DESC";
    /// A web form's submission: its outcome.
    WebSubmissionGet = "SELECT outcome FROM web_submission WHERE person_id = ?1 AND key = ?2";
    /// A web form's submission put (a second one of the same key is ignored).
    WebSubmissionPut = "INSERT INTO web_submission (person_id, key, outcome, at_ms) VALUES (?1, ?2, ?3, ?4) ON CONFLICT (person_id, key) DO NOTHING";
    /// A person's web form submissions older than ?2 removed.
    WebSubmissionPrune = "DELETE FROM web_submission WHERE person_id = ?1 AND at_ms < ?2";
    /// Signin link by hash.
    SigninLinkByHash = "SELECT hash, role, person_id, expires_ms, used_ms FROM signin_link WHERE hash = ?1";
    // token
    /// Token put.
    TokenPut = "INSERT INTO token (hash_prefix, hash, role, person_id, created_at) VALUES (?1, ?2, ?3, ?4, ?5)";
    /// Tokens by prefix.
    TokensByPrefix = "SELECT id, hash, role, person_id, revoked_at IS NOT NULL FROM token WHERE hash_prefix = ?1";
    /// Tokens of.
    TokensOf = "SELECT id, created_at, revoked_at FROM token WHERE role = ?1 AND person_id IS ?2 ORDER BY id DESC";
    /// Token state.
    TokenState = "SELECT role, revoked_at IS NOT NULL FROM token WHERE id = ?1";
    /// Token other admins.
    TokenOtherAdmins = "SELECT count(*) FROM token WHERE role = 'admin' AND revoked_at IS NULL AND id != ?1";
    /// Token revoke.
    TokenRevoke = "UPDATE token SET revoked_at = ?1 WHERE id = ?2 AND revoked_at IS NULL";
    // copy
    /// Every row of `person`, in key order (`abba store copy`).
    CopyReadPerson = "SELECT id, name, tz, mode, first_day, settings, created_at, skeleton_folded, skeleton_cased FROM person ORDER BY id";
    /// One row of `person` as read by `CopyReadPerson`.
    CopyWritePerson = "INSERT INTO person (id, name, tz, mode, first_day, settings, created_at, skeleton_folded, skeleton_cased) VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9)";
    /// Every row of `import`, in key order (`abba store copy`).
    CopyReadImport = "SELECT id, person_id, imported_at, files, formats, records_read, records_added, records_known FROM import ORDER BY id";
    /// One row of `import` as read by `CopyReadImport`.
    CopyWriteImport = "INSERT INTO import (id, person_id, imported_at, files, formats, records_read, records_added, records_known) VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8)";
    /// Every row of `record`, in key order (`abba store copy`).
    CopyReadRecord = "SELECT person_id, source, source_id, at_ms, kind, origin, import_id FROM record ORDER BY person_id, source, source_id";
    /// One row of `record` as read by `CopyReadRecord`.
    CopyWriteRecord = "INSERT INTO record (person_id, source, source_id, at_ms, kind, origin, import_id) VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7)";
    /// Every row of `suggestion`, in key order (`abba store copy`).
    CopyReadSuggestion = "SELECT person_id, at_min, parameter, old, new, skipped, decision FROM suggestion ORDER BY person_id, at_min, parameter";
    /// One row of `suggestion` as read by `CopyReadSuggestion`.
    CopyWriteSuggestion = "INSERT INTO suggestion (person_id, at_min, parameter, old, new, skipped, decision) VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7)";
    /// Every row of `answer`, in key order (`abba store copy`).
    CopyReadAnswer = "SELECT id, person_id, at_min, parameter, answer, suggested, previous, in_force, answered_at FROM answer ORDER BY id";
    /// One row of `answer` as read by `CopyReadAnswer`.
    CopyWriteAnswer = "INSERT INTO answer (id, person_id, at_min, parameter, answer, suggested, previous, in_force, answered_at) VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9)";
    /// Every row of `snapshot`, in key order (`abba store copy`).
    CopyReadSnapshot = "SELECT person_id, events, events_hash, answers, unused, state FROM snapshot ORDER BY person_id";
    /// One row of `snapshot` as read by `CopyReadSnapshot`.
    CopyWriteSnapshot = "INSERT INTO snapshot (person_id, events, events_hash, answers, unused, state) VALUES (?1, ?2, ?3, ?4, ?5, ?6)";
    /// Every row of `token`, in key order (`abba store copy`).
    CopyReadToken = "SELECT id, hash_prefix, hash, role, person_id, created_at, revoked_at FROM token ORDER BY id";
    /// One row of `token` as read by `CopyReadToken`.
    CopyWriteToken = "INSERT INTO token (id, hash_prefix, hash, role, person_id, created_at, revoked_at) VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7)";
    /// Every row of `app_event`, in key order (`abba store copy`).
    CopyReadAppEvent = "SELECT person_id, seq, at_ms, at_min, tag, kind, hash, received_at FROM app_event ORDER BY person_id, seq";
    /// One row of `app_event` as read by `CopyReadAppEvent`.
    CopyWriteAppEvent = "INSERT INTO app_event (person_id, seq, at_ms, at_min, tag, kind, hash, received_at) VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8)";
    /// Every row of `therapy_change`, in key order (`abba store copy`).
    CopyReadTherapyChange = "SELECT id, person_id, at_ms, change, recorded_at FROM therapy_change ORDER BY id";
    /// One row of `therapy_change` as read by `CopyReadTherapyChange`.
    CopyWriteTherapyChange = "INSERT INTO therapy_change (id, person_id, at_ms, change, recorded_at) VALUES (?1, ?2, ?3, ?4, ?5)";
    /// Every row of `file_evidence`, in key order (`abba store copy`).
    CopyReadFileEvidence = "SELECT person_id, file_hash, file, evidence FROM file_evidence ORDER BY person_id, file_hash";
    /// One row of `file_evidence` as read by `CopyReadFileEvidence`.
    CopyWriteFileEvidence = "INSERT INTO file_evidence (person_id, file_hash, file, evidence) VALUES (?1, ?2, ?3, ?4)";
    /// Every row of `nightscout_link`, in key order (`abba store copy`).
    CopyReadNightscoutLink = "SELECT person_id, url, credential_kind, credential, write_back, created_at, last_sync_at, last_success_at, last_error, failures, last_warnings FROM nightscout_link ORDER BY person_id";
    /// One row of `nightscout_link` as read by `CopyReadNightscoutLink`.
    CopyWriteNightscoutLink = "INSERT INTO nightscout_link (person_id, url, credential_kind, credential, write_back, created_at, last_sync_at, last_success_at, last_error, failures, last_warnings) VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10, ?11)";
    /// Every row of `nightscout_mark`, in key order (`abba store copy`).
    CopyReadNightscoutMark = "SELECT person_id, collection, mark_ms FROM nightscout_mark ORDER BY person_id, collection";
    /// One row of `nightscout_mark` as read by `CopyReadNightscoutMark`.
    CopyWriteNightscoutMark = "INSERT INTO nightscout_mark (person_id, collection, mark_ms) VALUES (?1, ?2, ?3)";
    /// Every row of `nightscout_staged`.
    CopyReadNightscoutStaged = "SELECT person_id, collection, docs FROM nightscout_staged ORDER BY person_id, collection";
    /// One row of `nightscout_staged` as read by `CopyReadNightscoutStaged`.
    CopyWriteNightscoutStaged = "INSERT INTO nightscout_staged (person_id, collection, docs) VALUES (?1, ?2, ?3)";
    /// Every row of `nightscout_written`, in key order (`abba store copy`).
    CopyReadNightscoutWritten = "SELECT person_id, what, key, remote_id, content, written_at FROM nightscout_written ORDER BY person_id, what, key";
    /// One row of `nightscout_written` as read by `CopyReadNightscoutWritten`.
    CopyWriteNightscoutWritten = "INSERT INTO nightscout_written (person_id, what, key, remote_id, content, written_at) VALUES (?1, ?2, ?3, ?4, ?5, ?6)";
    /// Every row of `signin_link`, in key order (`abba store copy`).
    CopyReadSigninLink = "SELECT id, hash, role, person_id, created_ms, expires_ms, used_ms FROM signin_link ORDER BY id";
    /// One row of `signin_link` as read by `CopyReadSigninLink`.
    CopyWriteSigninLink = "INSERT INTO signin_link (id, hash, role, person_id, created_ms, expires_ms, used_ms) VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7)";
    /// Every row of `web_session`, in key order (`abba store copy`).
    CopyReadWebSession = "SELECT id, hash, role, person_id, csrf, created_ms, seen_ms, expires_ms, revoked_ms FROM web_session ORDER BY id";
    /// One row of `web_session` as read by `CopyReadWebSession`.
    CopyWriteWebSession = "INSERT INTO web_session (id, hash, role, person_id, csrf, created_ms, seen_ms, expires_ms, revoked_ms) VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9)";
    /// Every row of `web_submission`.
    CopyReadWebSubmission = "SELECT person_id, key, outcome, at_ms FROM web_submission ORDER BY person_id, key";
    /// One row of `web_submission` as read by `CopyReadWebSubmission`.
    CopyWriteWebSubmission = "INSERT INTO web_submission (person_id, key, outcome, at_ms) VALUES (?1, ?2, ?3, ?4)";
    /// After a copy: generated ids continue after the copied ones (nothing to do on SQLite, whose next id is the largest plus one).
    CopyResetIds = "SELECT 1";
}
