//! Bearer tokens of the service, stored only as SHA-256 hashes.
//!
//! The store never sees a token itself: the service hashes it and asks for
//! the rows whose hash starts with the same 8 bytes (an index look-up that
//! tells nothing useful about a token), then compares the whole hash in
//! constant time.

use crate::backend::{args, Db, Q};
use crate::error::StoreError;

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
pub fn insert(conn: &dyn Db, hash: &[u8; 32], role: Role) -> Result<i64, StoreError> {
    let (name, person) = match role {
        Role::Admin => ("admin", None),
        Role::Person(id) => ("person", Some(id)),
    };
    if let Some(id) = person {
        crate::person::load_by_id(conn, id)?;
    }
    conn.insert_id(
        Q::TokenPut,
        args![
            prefix(hash),
            &hash[..],
            name,
            person,
            jiff::Timestamp::now().to_string()
        ],
    )
}

/// The tokens whose hash has the same first 8 bytes as `hash`.
pub fn candidates(conn: &dyn Db, hash: &[u8; 32]) -> Result<Vec<StoredToken>, StoreError> {
    let mut out = Vec::new();
    for r in conn.rows(Q::TokensByPrefix, args![prefix(hash)])? {
        let (id, h, role, person, revoked) =
            (r.int(0)?, r.blob(1)?, r.text(2)?, r.opt_int(3)?, r.bool(4)?);
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
pub fn list(conn: &dyn Db, role: Role) -> Result<Vec<TokenRow>, StoreError> {
    let (name, person) = match role {
        Role::Admin => ("admin", None),
        Role::Person(id) => ("person", Some(id)),
    };
    conn.rows(Q::TokensOf, args![name, person])?
        .into_iter()
        .map(|r| {
            Ok(TokenRow {
                id: r.int(0)?,
                created_at: r.text(1)?,
                revoked_at: r.opt_text(2)?,
            })
        })
        .collect()
}

/// Revokes a token (revoking twice is fine).
pub fn revoke(conn: &dyn Db, id: i64) -> Result<(), StoreError> {
    let found = match conn.row(Q::TokenState, args![id])? {
        Some(r) => Some((r.text(0)?, r.bool(1)?)),
        None => None,
    };
    let Some((role, revoked)) = found else {
        return Err(StoreError::NoToken(id));
    };
    if role == "admin" && !revoked {
        let others = conn.one(Q::TokenOtherAdmins, args![id])?.int(0)?;
        if others == 0 {
            return Err(StoreError::LastAdmin(id));
        }
    }
    conn.execute(
        Q::TokenRevoke,
        args![jiff::Timestamp::now().to_string(), id],
    )?;
    Ok(())
}
