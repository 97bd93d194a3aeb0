//! Saving and resuming an advisor: its whole state as JSON inside a
//! versioned envelope.
//!
//! ```json
//! {"format": "abba-advisor-state", "version": 1, "advisor": "abba", "state": {...}}
//! ```
//!
//! `advisor` is the arm ([`ArmKind`]); `state` is the advisor's own serde
//! form. Loading checks the format name, the version (a state written by
//! another format version is refused: nothing is guessed or migrated
//! silently) and the arm, then re-validates the state. Any advisor's state
//! can be loaded by its own type or by [`AnyAdvisor`](crate::AnyAdvisor).
//!
//! Bump [`STATE_FORMAT_VERSION`] whenever the serialised state of any
//! advisor changes shape.

use crate::error::AdvisorError;
use crate::ArmKind;
use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};

/// The format version of saved advisor states written by this build (the
/// only one it reads).
pub const STATE_FORMAT_VERSION: u32 = 1;

/// The `format` field of every saved state.
pub const STATE_FORMAT_NAME: &str = "abba-advisor-state";

#[derive(Serialize)]
struct EnvelopeOut<'a, T> {
    format: &'static str,
    version: u32,
    advisor: ArmKind,
    state: &'a T,
}

/// Just the header, read before the state itself.
#[derive(Deserialize)]
struct Header {
    format: Option<String>,
    version: Option<serde_json::Value>,
    advisor: Option<serde_json::Value>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct EnvelopeIn<T> {
    #[allow(dead_code)]
    format: String,
    #[allow(dead_code)]
    version: u32,
    #[allow(dead_code)]
    advisor: ArmKind,
    state: T,
}

fn state_err(msg: impl Into<String>) -> AdvisorError {
    AdvisorError::State(msg.into())
}

/// Writes `state` of advisor `arm` in the versioned envelope.
pub(crate) fn save<T: Serialize>(arm: ArmKind, state: &T) -> Result<String, AdvisorError> {
    serde_json::to_string(&EnvelopeOut {
        format: STATE_FORMAT_NAME,
        version: STATE_FORMAT_VERSION,
        advisor: arm,
        state,
    })
    .map_err(|e| state_err(e.to_string()))
}

/// Reads the envelope's header: checks format and version, returns the arm.
pub fn saved_arm(json: &str) -> Result<ArmKind, AdvisorError> {
    let h: Header = serde_json::from_str(json)
        .map_err(|e| state_err(format!("not a saved advisor state (a JSON object): {e}")))?;
    match h.format.as_deref() {
        Some(STATE_FORMAT_NAME) => {}
        Some(other) => {
            return Err(state_err(format!(
                "field `format` is \"{other}\", expected \"{STATE_FORMAT_NAME}\""
            )))
        }
        None => {
            return Err(state_err(format!(
                "no field `format` (expected \"{STATE_FORMAT_NAME}\"); states saved before \
                 format version 1 cannot be read"
            )))
        }
    }
    match h.version {
        Some(v) if v.as_u64() == Some(u64::from(STATE_FORMAT_VERSION)) => {}
        Some(v) => {
            return Err(state_err(format!(
                "format version {v}, but this build reads only version {STATE_FORMAT_VERSION}"
            )))
        }
        None => return Err(state_err("no field `version`")),
    }
    let arm = h
        .advisor
        .ok_or_else(|| state_err("no field `advisor` (abba, standard or r2r)"))?;
    serde_json::from_value(arm.clone()).map_err(|_| {
        state_err(format!(
            "field `advisor` is {arm}, expected abba, standard or r2r"
        ))
    })
}

/// Reads a state of advisor `arm` written by [`save`].
pub(crate) fn load<T: DeserializeOwned>(arm: ArmKind, json: &str) -> Result<T, AdvisorError> {
    let saved = saved_arm(json)?;
    if saved != arm {
        return Err(state_err(format!(
            "this is the state of a {saved} advisor, not of a {arm} advisor"
        )));
    }
    let e: EnvelopeIn<T> = serde_json::from_str(json).map_err(|e| state_err(e.to_string()))?;
    Ok(e.state)
}
