//! History sync: which sequence numbers the service holds.

use serde::{Deserialize, Serialize};
use utoipa::ToSchema;

/// A range of held sequence numbers, both ends included.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct SeqRange {
    /// First held number.
    pub first: u64,
    /// Last held number.
    pub last: u64,
}

/// `GET /v1/persons/{id}/sync?from=N`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct SyncResponse {
    /// The `from` asked (0 when not given).
    pub from: u64,
    /// Held numbers ≥ `from`, as maximal ranges, ascending (at most
    /// [`SyncResponse::MAX_RANGES`]; `truncated` says when there are more:
    /// ask again from after the last range).
    pub held: Vec<SeqRange>,
    /// True when more ranges follow the last one given.
    pub truncated: bool,
    /// The highest number held (any `from`), if any.
    pub last_seq: Option<u64>,
    /// The id of the latest suggestion, if any (fetch newer ones with
    /// `GET .../suggestions?after=ID`).
    pub last_suggestion_id: Option<u64>,
}

impl SyncResponse {
    /// Most ranges in one response.
    pub const MAX_RANGES: usize = 10_000;
}
