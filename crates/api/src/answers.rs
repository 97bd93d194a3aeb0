//! The person's answers to suggestions.

use crate::views::{Setting, Suggestion};
use serde::{Deserialize, Serialize};
use utoipa::ToSchema;

/// What the person did with a suggestion.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, ToSchema)]
#[serde(rename_all = "snake_case")]
pub enum AnswerKind {
    /// Put the suggested value in force.
    Accept,
    /// Kept the previous value.
    Reject,
    /// Put their own value (`value`) in force.
    Override,
}

/// One answer.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct AnswerItem {
    /// The suggestion answered (it must be open: the latest of its setting,
    /// with an update, not answered yet).
    pub suggestion_id: u64,
    /// What the person did.
    pub answer: AnswerKind,
    /// The value put in force: required with `override`, refused otherwise;
    /// positive, within the clinician's bounds and the advisor's limits.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub value: Option<f64>,
}

/// `POST /v1/persons/{id}/answers` (one transaction: all or nothing).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct AnswerBody {
    /// The answers (1 to 4, at most one per suggestion).
    pub answers: Vec<AnswerItem>,
}

/// One stored answer.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct Answered {
    /// The suggestion answered.
    pub suggestion_id: u64,
    /// The setting.
    pub parameter: Setting,
    /// What the person did.
    pub answer: AnswerKind,
    /// The value now in force.
    pub in_force: f64,
}

/// The acknowledgement of answers, sent after they were committed.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct AnswersAck {
    /// The notice: abba is research software, not a medical device.
    pub notice: String,
    /// What was stored.
    pub answered: Vec<Answered>,
    /// Later suggestions whose value changed because the advisor now starts
    /// from the answered value (empty when the answer is to the latest
    /// decision, the usual case).
    pub changed: Vec<Suggestion>,
}
