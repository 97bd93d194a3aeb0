//! The pump's own identity of a dose AndroidAPS uploaded to Nightscout,
//! kept with the stored record so that a later import can tell a copy of
//! a dose from a second dose.
//!
//! AndroidAPS writes beside each bolus, temporary basal and extended bolus
//! it read from the pump the pump's `pumpType`, `pumpSerial` and `pumpId`
//! (the pump history record's number): NSClient (API v1) in
//! `plugins/sync/.../nsclient/extensions/BolusExtension.kt`,
//! `TemporaryBasalExtension.kt` and `ExtendedBolusExtension.kt` (from the
//! record's `interfaceIDs`), NSClientV3 in
//! `core/nssdk/.../mapper/TreatmentMapper.kt`. The same dose uploaded
//! again (by both clients, or after an NSClient reset) comes under a new
//! `_id` with a date seconds apart but the same three; two doses the pump
//! gave never share them. So when both doses carry an identity, it alone
//! says whether they are one dose, whatever their dates within the copy
//! window: a person who gives 1 U twice in a row has two doses. A dose
//! without one (Nightscout's Careportal, Loop, xDrip+) keeps the window
//! rule ([`super::copy_elsewhere_window_ms`]).
//!
//! The identity is stored at the end of the record's origin (its place in
//! words), as `, pump event {"pumpType":…,"pumpSerial":…,"pumpId":…}`: no
//! column is added, and a record stored before it simply has none.

use serde::{Deserialize, Serialize};

/// A pump's identity of one dose: the pump's type and serial number and
/// its history record's number, as AndroidAPS uploads them.
#[derive(Debug, Clone, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct PumpIdentity {
    /// AndroidAPS's name of the pump's type (`pumpType`, e.g. `DANA_RS`).
    #[serde(rename = "pumpType")]
    pub pump_type: String,
    /// The pump's serial number (`pumpSerial`).
    #[serde(rename = "pumpSerial")]
    pub serial: String,
    /// The pump history record's number (`pumpId`).
    #[serde(rename = "pumpId")]
    pub id: i64,
}

/// What comes between a record's origin and its pump identity.
const MARK: &str = ", pump event ";

impl PumpIdentity {
    /// `origin` with this identity at its end (what the store keeps).
    pub fn in_origin(&self, origin: &str) -> String {
        // Three strings and a number: serializing cannot fail.
        let json = serde_json::to_string(self).unwrap_or_default();
        format!("{origin}{MARK}{json}")
    }

    /// The identity at the end of a stored origin, if it has one (a record
    /// stored without one, or before abba kept them, has none).
    pub fn of_origin(origin: &str) -> Option<PumpIdentity> {
        // A file's name may hold the mark too: the identity is the part
        // after a mark that reads whole as one.
        origin
            .match_indices(MARK)
            .find_map(|(at, _)| serde_json::from_str(&origin[at + MARK.len()..]).ok())
    }

    /// Whether a dose with identity `a` and a stored one of the same kind
    /// and values within the copy window with identity `b` are one dose:
    /// with both identities, iff they are equal; else yes (the window rule).
    pub fn same_dose(a: Option<&PumpIdentity>, b: Option<&PumpIdentity>) -> bool {
        match (a, b) {
            (Some(a), Some(b)) => a == b,
            _ => true,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_origin_keeps_its_identity() {
        let p = PumpIdentity {
            pump_type: "DANA_RS".into(),
            serial: "x, pump event {\"".into(),
            id: 99001,
        };
        let origin = p.in_origin("a, pump event b.json: $[3]");
        assert_eq!(PumpIdentity::of_origin(&origin), Some(p));
        assert_eq!(PumpIdentity::of_origin("treatments.json: $[3]"), None);
    }
}
