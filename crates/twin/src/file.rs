//! Where twins are kept: one JSON file per person in a folder beside the
//! store, `<store file>.twins/<person>.json` (the person's name with every
//! byte outside `A-Z a-z 0-9 . _ -` written as `%XX`). Written atomically
//! (a temporary file renamed over the old one), so a reader never sees half
//! a twin. The store itself is never touched.
//!
//! **The refit rule** ([`refit`]), the same for `abba twin fit` and for the
//! service's background refit: a stored twin fitted on exactly this log
//! (same events hash) with the same window, held-out days and population
//! is kept as it is; otherwise the twin is fitted again and stored as the
//! next revision (1 for the first), whatever its grade: a "not usable"
//! twin of the current log says so beside the advice, which is truer than
//! a usable twin of older data. A fit that fails stores nothing, so the
//! old file stays.

use crate::error::TwinError;
use crate::twin::{Twin, TwinOptions, FORMAT};
use abba_core::Event;
use std::io::Write;
use std::path::{Path, PathBuf};

/// The folder of twins beside `store`.
pub fn folder(store: &Path) -> PathBuf {
    let mut name = store.as_os_str().to_owned();
    name.push(".twins");
    PathBuf::from(name)
}

/// The file of `person`'s twin beside `store`.
pub fn path(store: &Path, person: &str) -> PathBuf {
    let mut name = String::new();
    for b in person.bytes() {
        if b.is_ascii_alphanumeric() || b"._-".contains(&b) {
            name.push(char::from(b));
        } else {
            name.push_str(&format!("%{b:02X}"));
        }
    }
    folder(store).join(format!("{name}.json"))
}

/// The stored twin of `person`, if there is one.
pub fn load(store: &Path, person: &str) -> Result<Option<Twin>, TwinError> {
    let p = path(store, person);
    let text = match std::fs::read_to_string(&p) {
        Ok(t) => t,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(e) => {
            return Err(TwinError::File {
                path: p.display().to_string(),
                reason: e.to_string(),
            })
        }
    };
    let twin: Twin = serde_json::from_str(&text).map_err(|e| TwinError::File {
        path: p.display().to_string(),
        reason: format!(
            "not a twin file: {e} (line {}, column {})",
            e.line(),
            e.column()
        ),
    })?;
    if twin.format != FORMAT {
        return Err(TwinError::File {
            path: p.display().to_string(),
            reason: format!(
                "twin format {} is not the {FORMAT} this build reads: refit with `abba twin fit`",
                twin.format
            ),
        });
    }
    Ok(Some(twin))
}

/// Stores `twin` beside `store`; returns the file.
pub fn save(store: &Path, twin: &Twin) -> Result<PathBuf, TwinError> {
    let p = path(store, &twin.person);
    let err = |reason: String| TwinError::File {
        path: p.display().to_string(),
        reason,
    };
    let dir = folder(store);
    std::fs::create_dir_all(&dir).map_err(|e| err(format!("cannot create the folder: {e}")))?;
    let text = serde_json::to_string_pretty(twin).map_err(|e| err(e.to_string()))?;
    let mut tmp =
        tempfile::NamedTempFile::new_in(&dir).map_err(|e| err(format!("cannot write: {e}")))?;
    tmp.write_all(text.as_bytes())
        .and_then(|()| tmp.write_all(b"\n"))
        .map_err(|e| err(format!("cannot write: {e}")))?;
    tmp.persist(&p)
        .map_err(|e| err(format!("cannot write: {e}")))?;
    Ok(p)
}

/// What [`refit`] did.
#[derive(Debug, Clone, PartialEq)]
pub enum Refit {
    /// The stored twin was fitted on this log with these options: kept.
    Unchanged(Twin),
    /// A new revision, stored in the file.
    Stored {
        /// The twin.
        twin: Twin,
        /// Its file.
        path: PathBuf,
    },
}

/// Refits `person`'s twin on `events` (their whole log) by the rule of the
/// module doc; `force` refits an unchanged log too.
pub fn refit(
    store: &Path,
    person: &str,
    events: &[Event],
    options: &TwinOptions,
    force: bool,
) -> Result<Refit, TwinError> {
    let stored = load(store, person)?;
    let hash = crate::twin::events_hash(events);
    if let Some(t) = stored.as_ref().filter(|t| {
        !force
            && t.data.events_hash == hash
            && t.data.days == options.days
            && t.data.held_out_days == options.held_out_days
            && t.prior.population == options.population
    }) {
        return Ok(Refit::Unchanged(t.clone()));
    }
    let mut twin = Twin::fit(person, events, options)?;
    twin.revision = stored.map_or(1, |p| p.revision + 1);
    let path = save(store, &twin)?;
    Ok(Refit::Stored { twin, path })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_person_name_becomes_a_safe_file_name() {
        let p = path(Path::new("/x/abba.db"), "Anna/../ü 1");
        assert_eq!(
            p,
            PathBuf::from("/x/abba.db.twins/Anna%2F..%2F%C3%BC%201.json")
        );
    }
}
