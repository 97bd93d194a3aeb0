//! The person's answers: what they put in force for a suggestion. Each
//! answer becomes an event of the log (`SuggestionAccepted`,
//! `SuggestionRejected`, `SuggestionOverridden`) placed right after the
//! decision it answers, so the advisor's next update starts from the value
//! in force.

use crate::backend::{args, Db, Q};
use crate::error::StoreError;
use abba_advisor::Parameter;
use abba_core::{EventKind, GramsPerUnit, MealSlot, SettingValue, UnitsPerHour};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// What the person did with a suggestion.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum AnswerKind {
    /// Put the suggested value in force.
    Accepted,
    /// Kept the previous value.
    Rejected,
    /// Put their own value in force.
    Overridden,
}

impl AnswerKind {
    /// Stored name.
    pub fn name(self) -> &'static str {
        match self {
            AnswerKind::Accepted => "accepted",
            AnswerKind::Rejected => "rejected",
            AnswerKind::Overridden => "overridden",
        }
    }

    fn parse(s: &str) -> Option<Self> {
        match s {
            "accepted" => Some(AnswerKind::Accepted),
            "rejected" => Some(AnswerKind::Rejected),
            "overridden" => Some(AnswerKind::Overridden),
            _ => None,
        }
    }
}

/// Stored name of a parameter (`basal`, `breakfast`, `lunch`, `dinner`).
pub fn param_key(p: Parameter) -> &'static str {
    match p {
        Parameter::Basal => "basal",
        Parameter::CarbRatio(s) => s.name(),
    }
}

/// The parameter of a stored name (also the names `--set` takes).
pub fn parse_param(s: &str) -> Option<Parameter> {
    match s.trim().to_ascii_lowercase().as_str() {
        "basal" => Some(Parameter::Basal),
        "breakfast" => Some(Parameter::CarbRatio(MealSlot::Breakfast)),
        "lunch" => Some(Parameter::CarbRatio(MealSlot::Lunch)),
        "dinner" => Some(Parameter::CarbRatio(MealSlot::Dinner)),
        _ => None,
    }
}

/// One stored answer.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Answer {
    /// The decision answered: its advisor minute.
    pub at_min: i64,
    /// The setting.
    pub parameter: Parameter,
    /// What the person did.
    pub kind: AnswerKind,
    /// The advisor's suggestion.
    pub suggested: f64,
    /// The value before the suggestion.
    pub previous: f64,
    /// The value put in force.
    pub in_force: f64,
    /// When the person answered (UTC).
    pub answered_at: String,
}

impl Answer {
    /// The log event of this answer.
    pub fn event_kind(&self) -> EventKind {
        let v = match self.parameter {
            Parameter::Basal => SettingValue::Basal {
                rate: UnitsPerHour(self.in_force),
            },
            Parameter::CarbRatio(slot) => SettingValue::CarbRatio {
                slot,
                ratio: GramsPerUnit(self.in_force),
            },
        };
        match self.kind {
            AnswerKind::Accepted => EventKind::SuggestionAccepted(v),
            AnswerKind::Rejected => EventKind::SuggestionRejected(v),
            AnswerKind::Overridden => EventKind::SuggestionOverridden(v),
        }
    }
}

/// Answers by (decision minute, parameter key).
pub type Answers = BTreeMap<(i64, &'static str), Answer>;

/// Every answer of a person.
pub fn load(conn: &dyn Db, person: i64) -> Result<Answers, StoreError> {
    let mut out = Answers::new();
    for r in conn.rows(Q::AnswersOf, args![person])? {
        let (at_min, p, kind, suggested, previous, in_force, answered_at) = (
            r.int(0)?,
            r.text(1)?,
            r.text(2)?,
            r.real(3)?,
            r.real(4)?,
            r.real(5)?,
            r.text(6)?,
        );
        let parameter =
            parse_param(&p).ok_or_else(|| StoreError::corrupt("answer", format!("setting {p}")))?;
        let kind = AnswerKind::parse(&kind)
            .ok_or_else(|| StoreError::corrupt("answer", format!("kind {kind}")))?;
        out.insert(
            (at_min, param_key(parameter)),
            Answer {
                at_min,
                parameter,
                kind,
                suggested,
                previous,
                in_force,
                answered_at,
            },
        );
    }
    Ok(out)
}

/// Stores answers (inside the caller's transaction).
pub fn insert(conn: &dyn Db, person: i64, answers: &[Answer]) -> Result<(), StoreError> {
    for a in answers {
        conn.execute(
            Q::AnswerPut,
            args![
                person,
                a.at_min,
                param_key(a.parameter),
                a.kind.name(),
                a.suggested,
                a.previous,
                a.in_force,
                &a.answered_at
            ],
        )?;
    }
    Ok(())
}
