//! What oref0 0.7.1 reads insulin from in a Nightscout treatment: the rules
//! of its `lib/iob/history.js`, the first that matches (carbs are read from
//! any treatment that has them, by `lib/meal/history.js`). Choice 1 of the
//! module's doc: on Nightscout files, insulin in other treatments is left
//! out as oref0 leaves it out.
use serde_json::{Map, Value};

/// What oref0 reads a treatment's insulin as.
#[derive(Debug, Clone, PartialEq)]
pub enum Oref0Reads {
    /// A bolus: a pump record (`_type` "Bolus"), eventType "Meal Bolus",
    /// "Correction Bolus", "Snack Bolus" or "Bolus Wizard", or any
    /// treatment entered by "xdrip" (or by "HAPP_App" with insulin).
    Bolus,
    /// A temporary basal: eventType exactly "Temp Basal".
    Temp,
    /// No insulin: any other treatment (Trio's "Bolus", Careportal's
    /// "Combo Bolus" and "<none>", "Temp Basal Start" ...), named by its
    /// eventType.
    Neither(String),
}

impl Oref0Reads {
    /// The rule that matches the treatment `obj`.
    pub fn of(obj: &Map<String, Value>) -> Self {
        let text = |k: &str| obj.get(k).and_then(Value::as_str);
        let pump_bolus = text("_type") == Some("Bolus")
            || obj
                .get("bolus")
                .and_then(|b| b.get("_type"))
                .and_then(Value::as_str)
                == Some("Bolus");
        let event = text("eventType");
        let entered_by = text("enteredBy");
        let has_insulin = obj.get("insulin").is_some_and(|v| {
            v.as_f64().is_some_and(|u| u != 0.0) || v.as_str().is_some_and(|s| !s.is_empty())
        });
        if pump_bolus
            || matches!(
                event,
                Some("Meal Bolus" | "Correction Bolus" | "Snack Bolus" | "Bolus Wizard")
            )
            || entered_by == Some("xdrip")
            || (entered_by == Some("HAPP_App") && has_insulin)
        {
            Oref0Reads::Bolus
        } else if event == Some("Temp Basal") {
            Oref0Reads::Temp
        } else {
            Oref0Reads::Neither(event.unwrap_or("no eventType").to_string())
        }
    }

    /// How a report names it.
    pub fn name(&self) -> String {
        match self {
            Oref0Reads::Neither(e) => e.clone(),
            Oref0Reads::Bolus => "a bolus".into(),
            Oref0Reads::Temp => "Temp Basal".into(),
        }
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::Oref0Reads;

    fn of(v: serde_json::Value) -> Oref0Reads {
        Oref0Reads::of(v.as_object().unwrap())
    }

    #[test]
    fn each_rule_of_history_js() {
        use serde_json::json;
        for e in [
            "Meal Bolus",
            "Correction Bolus",
            "Snack Bolus",
            "Bolus Wizard",
        ] {
            assert_eq!(
                of(json!({"eventType": e, "insulin": 1})),
                Oref0Reads::Bolus,
                "{e}"
            );
        }
        assert_eq!(
            of(json!({"_type": "Bolus", "amount": 1})),
            Oref0Reads::Bolus
        );
        assert_eq!(of(json!({"bolus": {"_type": "Bolus"}})), Oref0Reads::Bolus);
        assert_eq!(
            of(json!({"enteredBy": "xdrip", "eventType": "Bolus"})),
            Oref0Reads::Bolus
        );
        assert_eq!(
            of(json!({"enteredBy": "HAPP_App", "insulin": 2})),
            Oref0Reads::Bolus
        );
        assert_eq!(
            of(json!({"enteredBy": "HAPP_App", "insulin": 0})),
            Oref0Reads::Neither("no eventType".into())
        );
        assert_eq!(of(json!({"eventType": "Temp Basal"})), Oref0Reads::Temp);
        for e in ["Bolus", "Combo Bolus", "<none>", "Temp Basal Start"] {
            assert_eq!(
                of(json!({"eventType": e, "insulin": 1})),
                Oref0Reads::Neither(e.into())
            );
        }
    }
}
