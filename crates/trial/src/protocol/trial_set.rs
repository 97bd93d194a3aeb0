//! Serde adapters that leave out the knobs the trial sets itself: they are
//! not written, and a configuration that sets one is refused with a message
//! saying who sets it.

use serde::de::{DeserializeOwned, Error as _};
use serde::ser::Error as _;
use serde::{Deserialize, Deserializer, Serialize, Serializer};
use serde_json::{Map, Value};

fn ser<T: Serialize, S: Serializer>(v: &T, keys: &[(&str, &str)], s: S) -> Result<S::Ok, S::Error> {
    let Value::Object(mut m) = serde_json::to_value(v).map_err(S::Error::custom)? else {
        return Err(S::Error::custom("expected an object"));
    };
    for (k, _) in keys {
        m.remove(*k);
    }
    m.serialize(s)
}

fn de<'de, T: DeserializeOwned, D: Deserializer<'de>>(
    d: D,
    section: &str,
    keys: &[(&str, &str)],
    placeholders: Value,
) -> Result<T, D::Error> {
    let mut m = Map::deserialize(d)?;
    for (k, who) in keys {
        if m.contains_key(*k) {
            return Err(D::Error::custom(format!(
                "{section}.{k} is set by the trial ({who}); remove it from the configuration"
            )));
        }
    }
    if let Value::Object(p) = placeholders {
        for (k, v) in p {
            m.insert(k, v);
        }
    }
    serde_json::from_value(Value::Object(m))
        .map_err(|e| D::Error::custom(format!("{section}: {e}")))
}

const ADVISOR_KEYS: [(&str, &str); 2] = [
    (
        "mode",
        "CGM mode in scenarios that wear the CGM throughout, SMBG otherwise",
    ),
    ("init_days", "the top-level init_days"),
];

pub mod abba {
    use super::*;
    use abba_advisor::AbbaConfig;

    const KEYS: [(&str, &str); 3] = [
        ADVISOR_KEYS[0],
        ADVISOR_KEYS[1],
        (
            "exploration_seed",
            "derived per patient from the trial seed",
        ),
    ];

    pub fn serialize<S: Serializer>(v: &AbbaConfig, s: S) -> Result<S::Ok, S::Error> {
        ser(v, &KEYS, s)
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<AbbaConfig, D::Error> {
        de(
            d,
            "abba",
            &KEYS,
            serde_json::json!({"mode": "cgm", "init_days": 7, "exploration_seed": 0}),
        )
    }
}

pub mod r2r {
    use super::*;
    use abba_advisor::R2rConfig;

    const KEYS: [(&str, &str); 3] = [
        ADVISOR_KEYS[0],
        ADVISOR_KEYS[1],
        (
            "cgm_interval_min",
            "the CGM's sample time, devices.cgm.sample_time_min",
        ),
    ];

    pub fn serialize<S: Serializer>(v: &R2rConfig, s: S) -> Result<S::Ok, S::Error> {
        ser(v, &KEYS, s)
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<R2rConfig, D::Error> {
        de(
            d,
            "r2r",
            &KEYS,
            serde_json::json!({"mode": "cgm", "init_days": 7, "cgm_interval_min": 5.0}),
        )
    }
}

/// The autotune arm's knobs (an optional section: absent when the arm
/// does not run).
pub mod autotune {
    use super::*;
    use abba_advisor::AutotuneConfig;

    const KEYS: [(&str, &str); 2] = ADVISOR_KEYS;

    pub fn serialize<S: Serializer>(v: &Option<AutotuneConfig>, s: S) -> Result<S::Ok, S::Error> {
        match v {
            Some(v) => ser(v, &KEYS, s),
            None => s.serialize_none(),
        }
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(
        d: D,
    ) -> Result<Option<AutotuneConfig>, D::Error> {
        de(
            d,
            "autotune",
            &KEYS,
            serde_json::json!({"mode": "cgm", "init_days": 7}),
        )
        .map(Some)
    }
}
