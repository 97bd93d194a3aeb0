//! Bearer tokens: made from 256 random bits of the operating system's
//! CSPRNG, shown once, stored only as SHA-256, compared in constant time.

use crate::error::{ApiError, ServiceError};
use abba_store::token::Role;
use abba_store::Store;
use sha2::{Digest, Sha256};
use subtle::ConstantTimeEq;

/// The prefix of every token.
pub const PREFIX: &str = "abba_";

/// Who is calling.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Caller {
    /// The clinic.
    Admin,
    /// One person (row id).
    Person(i64),
}

/// What an endpoint needs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Need {
    /// Any valid token.
    Any,
    /// An admin token.
    Admin,
    /// This person's token or an admin token.
    Person(i64),
}

/// SHA-256 of a token.
pub fn hash(token: &str) -> [u8; 32] {
    Sha256::digest(token.as_bytes()).into()
}

/// A new token: `abba_` and 64 lower-case hex digits.
pub fn new_token() -> Result<String, ServiceError> {
    let mut bytes = [0u8; 32];
    getrandom::getrandom(&mut bytes).map_err(|e| ServiceError::Random(e.to_string()))?;
    let mut s = String::with_capacity(PREFIX.len() + 64);
    s.push_str(PREFIX);
    for b in bytes {
        s.push_str(&format!("{b:02x}"));
    }
    Ok(s)
}

/// Issues a token for `role`: stores its hash, returns (id, token).
pub fn issue(store: &mut Store, role: Role) -> Result<(i64, String), ServiceError> {
    let token = new_token()?;
    let id = store.insert_token(&hash(&token), role)?;
    Ok((id, token))
}

/// Makes a one-time sign-in link for `role`: returns its secret (64 hex
/// digits, the last part of `/signin/<secret>`); the store keeps its
/// SHA-256 for 15 minutes, and it works once.
pub fn issue_signin(store: &mut Store, role: Role) -> Result<String, ServiceError> {
    let token = new_token()?;
    let secret = token.trim_start_matches(PREFIX).to_string();
    store.insert_signin_link(
        &hash(&secret),
        role,
        jiff::Timestamp::now().as_millisecond(),
    )?;
    Ok(secret)
}

/// The token of an `Authorization` header value, if it has the right form.
pub fn parse(header: &str) -> Option<&str> {
    let (scheme, token) = header.split_once(' ')?;
    if !scheme.eq_ignore_ascii_case("bearer") {
        return None;
    }
    let token = token.trim();
    let hex = token.strip_prefix(PREFIX)?;
    (hex.len() == 64
        && hex
            .bytes()
            .all(|b| b.is_ascii_digit() || (b'a'..=b'f').contains(&b)))
    .then_some(token)
}

/// Checks the `Authorization` header against the store and what the
/// endpoint needs: 401 for a missing, malformed, unknown or revoked token,
/// 403 for a person's token on an admin endpoint, 404 for another person.
pub fn authorize(store: &Store, header: Option<&str>, need: Need) -> Result<Caller, ApiError> {
    let header = header.ok_or_else(|| {
        ApiError::unauthorized("missing token: send Authorization: Bearer abba_<64 hex digits>")
    })?;
    let token = parse(header).ok_or_else(|| {
        ApiError::unauthorized(
            "malformed token: expected Authorization: Bearer abba_<64 hex digits>",
        )
    })?;
    let h = hash(token);
    let mut found = None;
    for t in store.token_candidates(&h)? {
        if bool::from(t.hash.ct_eq(&h)) {
            found = Some(t);
        }
    }
    // One answer for a token never issued and one revoked: the caller
    // learns nothing about which tokens exist.
    let t = found
        .filter(|t| !t.revoked)
        .ok_or_else(|| ApiError::unauthorized("unknown or revoked token"))?;
    let caller = match t.role {
        Role::Admin => Caller::Admin,
        Role::Person(p) => Caller::Person(p),
    };
    match (need, caller) {
        (Need::Any, c) | (Need::Admin, c @ Caller::Admin) => Ok(c),
        (Need::Admin, Caller::Person(_)) => Err(ApiError::forbidden()),
        (Need::Person(id), Caller::Person(p)) if p == id => Ok(caller),
        (Need::Person(_), Caller::Person(_)) => Err(ApiError::no_person()),
        (Need::Person(id), Caller::Admin) => {
            store.person_by_id(id)?;
            Ok(caller)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tokens_have_the_documented_form_and_differ() {
        let a = new_token().unwrap();
        let b = new_token().unwrap();
        assert_ne!(a, b);
        assert_eq!(parse(&format!("Bearer {a}")), Some(a.as_str()));
        assert_eq!(parse(&format!("bearer {a}")), Some(a.as_str()));
        assert_eq!(parse(&a), None);
        assert_eq!(parse(&format!("Basic {a}")), None);
        assert_eq!(parse(&format!("Bearer {}", &a[..a.len() - 1])), None);
        assert_eq!(parse(&format!("Bearer {}", a.to_uppercase())), None);
    }
}
