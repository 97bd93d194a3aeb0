//! Bearer tokens of the service, stored only as SHA-256 hashes.
//!
//! The store never sees a token itself: the service hashes it and asks for
//! the rows whose hash starts with the same 8 bytes (an index look-up that
//! tells nothing useful about a token), then compares the whole hash in
//! constant time.

use crate::error::StoreError;
use rusqlite::{params, Connection, OptionalExtension};

/// Who a token speaks for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Role {
    /// The clinic: creates persons, sets bounds, issues and revokes tokens,
    /// and may act for any person.
    Admin,
    /// One person (by row id).
    Person(i64),
}

/// A stored token.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct StoredToken {
    /// Row id.
    pub id: i64,
    /// SHA-256 of the token.
    pub hash: [u8; 32],
    /// Its role.
    pub role: Role,
    /// True once revoked.
    pub revoked: bool,
}

/// The index key of a hash: its first 8 bytes.
pub fn prefix(hash: &[u8; 32]) -> i64 {
    let mut b = [0u8; 8];
    b.copy_from_slice(&hash[..8]);
    i64::from_le_bytes(b)
}

/// Compares a stored hash with a presented one without an early exit
/// (the time taken says nothing about where they differ).
pub fn same_hash(stored: &[u8], presented: &[u8; 32]) -> bool {
    bool::from(subtle::ConstantTimeEq::ct_eq(stored, &presented[..]))
}

/// Stores a new token's hash; returns its id.
pub fn insert(conn: &Connection, hash: &[u8; 32], role: Role) -> Result<i64, StoreError> {
    let (name, person) = match role {
        Role::Admin => ("admin", None),
        Role::Person(id) => ("person", Some(id)),
    };
    if let Some(id) = person {
        crate::person::load_by_id(conn, id)?;
    }
    conn.execute(
        "INSERT INTO token (hash_prefix, hash, role, person_id, created_at) VALUES (?1, ?2, ?3, ?4, ?5)",
        params![
            prefix(hash),
            &hash[..],
            name,
            person,
            jiff::Timestamp::now().to_string()
        ],
    )?;
    Ok(conn.last_insert_rowid())
}

/// The tokens whose hash has the same first 8 bytes as `hash`.
pub fn candidates(conn: &Connection, hash: &[u8; 32]) -> Result<Vec<StoredToken>, StoreError> {
    let mut st = conn.prepare_cached(
        "SELECT id, hash, role, person_id, revoked_at IS NOT NULL FROM token WHERE hash_prefix = ?1",
    )?;
    let rows = st.query_map(params![prefix(hash)], |r| {
        Ok((
            r.get::<_, i64>(0)?,
            r.get::<_, Vec<u8>>(1)?,
            r.get::<_, String>(2)?,
            r.get::<_, Option<i64>>(3)?,
            r.get::<_, bool>(4)?,
        ))
    })?;
    let mut out = Vec::new();
    for row in rows {
        let (id, h, role, person, revoked) = row?;
        let hash: [u8; 32] = h
            .try_into()
            .map_err(|_| StoreError::corrupt("token hash", "not 32 bytes"))?;
        let role = match (role.as_str(), person) {
            ("admin", None) => Role::Admin,
            ("person", Some(p)) => Role::Person(p),
            _ => return Err(StoreError::corrupt("token role", role)),
        };
        out.push(StoredToken {
            id,
            hash,
            role,
            revoked,
        });
    }
    Ok(out)
}

/// A token as the clinic's page lists it (never its hash).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct TokenRow {
    /// Row id.
    pub id: i64,
    /// Issued at (RFC 3339).
    pub created_at: String,
    /// Revoked at, if revoked.
    pub revoked_at: Option<String>,
}

/// The tokens of a role, newest first.
pub fn list(conn: &Connection, role: Role) -> Result<Vec<TokenRow>, StoreError> {
    let (name, person) = match role {
        Role::Admin => ("admin", None),
        Role::Person(id) => ("person", Some(id)),
    };
    let mut st = conn.prepare_cached(
        "SELECT id, created_at, revoked_at FROM token WHERE role = ?1 AND person_id IS ?2 ORDER BY id DESC",
    )?;
    let rows = st.query_map(params![name, person], |r| {
        Ok(TokenRow {
            id: r.get(0)?,
            created_at: r.get(1)?,
            revoked_at: r.get(2)?,
        })
    })?;
    Ok(rows.collect::<Result<_, _>>()?)
}

/// Revokes a token (revoking twice is fine).
pub fn revoke(conn: &Connection, id: i64) -> Result<(), StoreError> {
    let found: Option<(String, bool)> = conn
        .query_row(
            "SELECT role, revoked_at IS NOT NULL FROM token WHERE id = ?1",
            params![id],
            |r| Ok((r.get(0)?, r.get(1)?)),
        )
        .optional()?;
    let Some((role, revoked)) = found else {
        return Err(StoreError::NoToken(id));
    };
    if role == "admin" && !revoked {
        let others: i64 = conn.query_row(
            "SELECT count(*) FROM token WHERE role = 'admin' AND revoked_at IS NULL AND id != ?1",
            params![id],
            |r| r.get(0),
        )?;
        if others == 0 {
            return Err(StoreError::LastAdmin(id));
        }
    }
    conn.execute(
        "UPDATE token SET revoked_at = ?1 WHERE id = ?2 AND revoked_at IS NULL",
        params![jiff::Timestamp::now().to_string(), id],
    )?;
    Ok(())
}
