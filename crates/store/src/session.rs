//! The web pages' sign-in links and sessions (issue 24), stored only as
//! SHA-256 hashes of their secrets.
//!
//! A sign-in link is made by the clinic (or `abba token --signin`) for a
//! person or the admin: it lives 15 minutes and works once (consuming it
//! and checking it is one IMMEDIATE transaction, so two browsers racing
//! with the same link get one session). A web session is what a consumed
//! link becomes: its cookie's secret is kept as SHA-256, with the
//! session's own CSRF token, an idle and an absolute expiry, and it can be
//! revoked (the clinic's page lists them). The service makes the secrets;
//! this module only keeps their hashes.

use crate::backend::{args, Db, Q};
use crate::error::StoreError;
use crate::store::Store;
use crate::token::Role;

/// How long a sign-in link works (ms): 15 minutes.
pub const LINK_LIFE_MS: i64 = 15 * 60 * 1000;
/// A session unused this long ends (ms): 30 days.
pub const IDLE_MS: i64 = 30 * 24 * 3600 * 1000;
/// A session ends this long after sign-in whatever its use (ms): 90 days.
pub const ABSOLUTE_MS: i64 = 90 * 24 * 3600 * 1000;
/// A session's last use is written at most this often (ms).
const TOUCH_MS: i64 = 60 * 1000;

/// Why a sign-in link was refused.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LinkRefused {
    /// No such link.
    Unknown,
    /// It was used already.
    Used,
    /// Its 15 minutes are over.
    Expired,
}

/// A live web session.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct WebSession {
    /// Row id.
    pub id: i64,
    /// Who it speaks for.
    pub role: Role,
    /// The session's CSRF token (the hidden `csrf` field of its forms).
    pub csrf: String,
}

/// A session as the clinic's page lists it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SessionRow {
    /// Row id.
    pub id: i64,
    /// Who it speaks for.
    pub role: Role,
    /// Signed in at (ms since the Unix epoch).
    pub created_ms: i64,
    /// Last used at (ms).
    pub seen_ms: i64,
    /// Ends at (ms), unless used again (idle) or revoked.
    pub ends_ms: i64,
}

fn role_cols(role: Role) -> (&'static str, Option<i64>) {
    match role {
        Role::Admin => ("admin", None),
        Role::Person(id) => ("person", Some(id)),
    }
}

fn role_of(name: &str, person: Option<i64>) -> Result<Role, StoreError> {
    match (name, person) {
        ("admin", None) => Ok(Role::Admin),
        ("person", Some(p)) => Ok(Role::Person(p)),
        _ => Err(StoreError::corrupt("session role", name)),
    }
}

impl Store {
    /// Stores a new sign-in link's hash (valid [`LINK_LIFE_MS`] from
    /// `now_ms`); returns its id. A person's link needs the person.
    pub fn insert_signin_link(
        &mut self,
        hash: &[u8; 32],
        role: Role,
        now_ms: i64,
    ) -> Result<i64, StoreError> {
        let (name, person) = role_cols(role);
        if let Some(id) = person {
            crate::person::load_by_id(&self.conn, id)?;
        }
        self.conn.insert_id(
            Q::SigninLinkPut,
            args![&hash[..], name, person, now_ms, now_ms + LINK_LIFE_MS],
        )
    }

    /// What a sign-in link would give now, without using it (a GET of the
    /// link's page never consumes it).
    pub fn peek_signin_link(
        &self,
        hash: &[u8; 32],
        now_ms: i64,
    ) -> Result<Result<Role, LinkRefused>, StoreError> {
        link_state(&self.conn, hash, now_ms)
    }

    /// Uses a sign-in link and opens a session for its role in one
    /// transaction: the session's cookie secret is kept as `session_hash`,
    /// with its CSRF token. A link works once.
    pub fn consume_signin_link(
        &mut self,
        hash: &[u8; 32],
        session_hash: &[u8; 32],
        csrf: &str,
        now_ms: i64,
    ) -> Result<Result<(Role, i64), LinkRefused>, StoreError> {
        let tx = self.conn.transaction()?;
        let role = match link_state(&tx, hash, now_ms)? {
            Ok(r) => r,
            Err(e) => return Ok(Err(e)),
        };
        tx.execute(Q::SigninLinkUse, args![now_ms, &hash[..]])?;
        let (name, person) = role_cols(role);
        let id = tx.insert_id(
            Q::WebSessionPut,
            args![
                &session_hash[..],
                name,
                person,
                csrf,
                now_ms,
                now_ms + ABSOLUTE_MS
            ],
        )?;
        tx.commit()?;
        Ok(Ok((role, id)))
    }

    /// The live session whose cookie secret hashes to `hash` (not revoked,
    /// used within [`IDLE_MS`], younger than [`ABSOLUTE_MS`]); notes its
    /// use, at most every [`TOUCH_MS`] and only when no other writer holds
    /// the store: a read-only page must not wait (nor fail) because an
    /// import writes. A use not noted is noted at the next request; a
    /// session used at all within the idle period is used far more often
    /// than the store is busy.
    pub fn web_session(
        &mut self,
        hash: &[u8; 32],
        now_ms: i64,
    ) -> Result<Option<WebSession>, StoreError> {
        let row: Option<SessionTuple> =
            match self.conn.row(Q::WebSessionByHash, args![&hash[..]])? {
                Some(r) => Some((
                    r.int(0)?,
                    r.blob(1)?,
                    r.text(2)?,
                    r.opt_int(3)?,
                    r.text(4)?,
                    r.int(5)?,
                    r.int(6)?,
                )),
                None => None,
            };
        let Some((id, stored, role, person, csrf, seen, expires)) = row else {
            return Ok(None);
        };
        // The index found it; the whole hash is compared all the same.
        if !crate::token::same_hash(&stored, hash) {
            return Ok(None);
        }
        if now_ms >= expires || now_ms - seen >= IDLE_MS {
            return Ok(None);
        }
        if now_ms - seen >= TOUCH_MS {
            // Best effort: skipped when the store is busy.
            self.conn
                .try_execute(Q::WebSessionSeen, args![now_ms, id])?;
        }
        Ok(Some(WebSession {
            id,
            role: role_of(&role, person)?,
            csrf,
        }))
    }

    /// Revokes a session (revoking twice is fine); `NoToken` for none.
    pub fn revoke_web_session(&mut self, id: i64, now_ms: i64) -> Result<(), StoreError> {
        let n = self.conn.one(Q::WebSessionCount, args![id])?.int(0)?;
        if n == 0 {
            return Err(StoreError::NoToken(id));
        }
        self.conn.execute(Q::WebSessionRevoke, args![now_ms, id])?;
        Ok(())
    }

    /// The live sessions (of one person, or the admin's with `None`),
    /// newest first.
    pub fn web_sessions(&self, role: Role, now_ms: i64) -> Result<Vec<SessionRow>, StoreError> {
        let (name, person) = role_cols(role);
        let rows = self.conn.rows(
            Q::WebSessionsOf,
            args![name, person, now_ms, now_ms - IDLE_MS],
        )?;
        let mut out = Vec::new();
        for r in rows {
            let (id, role, person, created_ms, seen_ms, expires_ms) = (
                r.int(0)?,
                r.text(1)?,
                r.opt_int(2)?,
                r.int(3)?,
                r.int(4)?,
                r.int(5)?,
            );
            out.push(SessionRow {
                id,
                role: role_of(&role, person)?,
                created_ms,
                seen_ms,
                ends_ms: expires_ms.min(seen_ms + IDLE_MS),
            });
        }
        Ok(out)
    }
}

/// A `web_session` row: id, hash, role, person, CSRF token, seen, expires.
type SessionTuple = (i64, Vec<u8>, String, Option<i64>, String, i64, i64);
/// A `signin_link` row: hash, role, person, expires, used.
type LinkRow = (Vec<u8>, String, Option<i64>, i64, Option<i64>);

fn link_state(
    conn: &dyn Db,
    hash: &[u8; 32],
    now_ms: i64,
) -> Result<Result<Role, LinkRefused>, StoreError> {
    let row: Option<LinkRow> = match conn.row(Q::SigninLinkByHash, args![&hash[..]])? {
        Some(r) => Some((
            r.blob(0)?,
            r.text(1)?,
            r.opt_int(2)?,
            r.int(3)?,
            r.opt_int(4)?,
        )),
        None => None,
    };
    let Some((stored, role, person, expires, used)) = row else {
        return Ok(Err(LinkRefused::Unknown));
    };
    if !crate::token::same_hash(&stored, hash) {
        return Ok(Err(LinkRefused::Unknown));
    }
    if used.is_some() {
        return Ok(Err(LinkRefused::Used));
    }
    if now_ms >= expires {
        return Ok(Err(LinkRefused::Expired));
    }
    Ok(Ok(role_of(&role, person)?))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn store() -> (tempfile::TempDir, Store) {
        let dir = tempfile::tempdir().unwrap();
        let s = Store::open(&dir.path().join("s.db")).unwrap();
        (dir, s)
    }

    #[test]
    fn a_link_works_once_and_not_after_its_fifteen_minutes() {
        let (_d, mut s) = store();
        let (a, b, c) = ([1u8; 32], [2u8; 32], [3u8; 32]);
        s.insert_signin_link(&a, Role::Admin, 1_000).unwrap();
        assert_eq!(s.peek_signin_link(&a, 2_000).unwrap(), Ok(Role::Admin));
        let (role, id) = s.consume_signin_link(&a, &b, "x", 2_000).unwrap().unwrap();
        assert_eq!(role, Role::Admin);
        assert_eq!(
            s.consume_signin_link(&a, &c, "y", 3_000).unwrap(),
            Err(LinkRefused::Used)
        );
        assert_eq!(s.web_session(&b, 3_000).unwrap().unwrap().id, id);
        assert!(s.web_session(&c, 3_000).unwrap().is_none());
        s.insert_signin_link(&c, Role::Admin, 10_000).unwrap();
        assert_eq!(
            s.consume_signin_link(&c, &[4u8; 32], "z", 10_000 + LINK_LIFE_MS)
                .unwrap(),
            Err(LinkRefused::Expired)
        );
        assert_eq!(
            s.peek_signin_link(&[9u8; 32], 0).unwrap(),
            Err(LinkRefused::Unknown)
        );
    }

    #[test]
    fn a_session_is_found_without_waiting_while_another_writer_holds_the_store() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("s.db");
        let mut s = Store::open_service(&path, std::time::Duration::from_secs(5)).unwrap();
        let (l, k) = ([7u8; 32], [8u8; 32]);
        s.insert_signin_link(&l, Role::Admin, 0).unwrap();
        s.consume_signin_link(&l, &k, "t", 0).unwrap().unwrap();
        let other = rusqlite::Connection::open(&path).unwrap();
        other.execute_batch("BEGIN IMMEDIATE").unwrap();
        let t = std::time::Instant::now();
        // Its use would be noted now (older than TOUCH_MS): skipped, not waited for.
        assert!(s.web_session(&k, 10 * TOUCH_MS).unwrap().is_some());
        assert!(
            t.elapsed() < std::time::Duration::from_secs(1),
            "{:?}",
            t.elapsed()
        );
        other.execute_batch("ROLLBACK").unwrap();
        let seen = |s: &Store| s.web_sessions(Role::Admin, 20 * TOUCH_MS).unwrap()[0].seen_ms;
        assert_eq!(seen(&s), 0, "not noted while busy");
        s.web_session(&k, 11 * TOUCH_MS).unwrap().unwrap();
        assert_eq!(seen(&s), 11 * TOUCH_MS, "noted once the store is free");
        // The connection's busy timeout is back: a write waits again.
        let wait: i64 = match &s.conn {
            crate::backend::Conn::Sqlite(c) => c.busy_timeout_ms().unwrap(),
            crate::backend::Conn::Postgres(_) => unreachable!(),
        };
        assert_eq!(wait, 5000);
    }

    #[test]
    fn sessions_end_when_idle_revoked_or_too_old() {
        let (_d, mut s) = store();
        let (l, k) = ([5u8; 32], [6u8; 32]);
        s.insert_signin_link(&l, Role::Admin, 0).unwrap();
        let (_, id) = s.consume_signin_link(&l, &k, "t", 0).unwrap().unwrap();
        assert!(s.web_session(&k, IDLE_MS - 1).unwrap().is_some());
        // Used at IDLE_MS - 1: alive until one idle period later.
        assert!(s.web_session(&k, 2 * IDLE_MS - 2).unwrap().is_some());
        assert!(s.web_session(&k, ABSOLUTE_MS).unwrap().is_none());
        assert_eq!(s.web_sessions(Role::Admin, 2 * IDLE_MS).unwrap().len(), 1);
        s.revoke_web_session(id, 1).unwrap();
        assert!(s.web_session(&k, 2 * IDLE_MS).unwrap().is_none());
        assert!(s.web_sessions(Role::Admin, 2 * IDLE_MS).unwrap().is_empty());
        assert!(matches!(
            s.revoke_web_session(99, 1),
            Err(StoreError::NoToken(99))
        ));
    }
}
