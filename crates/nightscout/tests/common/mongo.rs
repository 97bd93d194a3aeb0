//! The part of MongoDB's query language a Nightscout v1 query reaches,
//! as the test site evaluates it (our own code, from MongoDB's documented
//! semantics and cgm-remote-monitor's `lib/server/query.js`):
//!
//! - the query string's `find[a][b]...=v` read into nested objects as
//!   `qs` does, leaves typed as Nightscout types them: a 24-hex leaf under
//!   `_id` an ObjectId (`updateIdQuery`), the collection's `parseInt`
//!   fields numbers (the `walker`), a treatment's `created_at` bounds
//!   rewritten to `toISOString()` form, but only when the query has no
//!   `_id` (`create` skips `enforceDateFilter` then, with its default
//!   4-day filter);
//! - `$eq $ne $gt $gte $lt $lte` with MongoDB's type bracketing (a string
//!   never compares with an ObjectId or a number; `$ne` matches a missing
//!   field and one of another type), `$type` by alias, `$not`;
//! - `sort[field]=1|-1` (the node driver's `prepareDirection` takes the
//!   strings), across types in BSON order (null < numbers < strings <
//!   ObjectIds), missing fields as null, ties in stored order.
//!
//! A document's `_id` of 24 hex digits is an ObjectId, any other a string
//! (Loop's UUIDs written before Nightscout moved them to `identifier`).

use serde_json::{Map, Value};
use std::cmp::Ordering;

/// A stored or query value, with BSON's type.
#[derive(Debug, Clone, PartialEq)]
pub enum Bson {
    Null,
    Num(f64),
    Str(String),
    Oid(String),
    /// Objects, arrays, booleans: only their rank matters here.
    Other(u8),
}

impl Bson {
    /// BSON's comparison order of types.
    fn rank(&self) -> u8 {
        match self {
            Bson::Null => 1,
            Bson::Num(_) => 2,
            Bson::Str(_) => 3,
            Bson::Oid(_) => 7,
            Bson::Other(r) => *r,
        }
    }

    /// Compares within one type (`None`: different types, which no
    /// comparison operator matches).
    fn same_type_cmp(&self, other: &Bson) -> Option<Ordering> {
        match (self, other) {
            (Bson::Null, Bson::Null) => Some(Ordering::Equal),
            (Bson::Num(a), Bson::Num(b)) => a.partial_cmp(b),
            (Bson::Str(a), Bson::Str(b)) | (Bson::Oid(a), Bson::Oid(b)) => {
                Some(a.as_bytes().cmp(b.as_bytes()))
            }
            _ => None,
        }
    }

    /// The sort order (across types by rank).
    fn sort_cmp(&self, other: &Bson) -> Ordering {
        match self.rank().cmp(&other.rank()) {
            Ordering::Equal => self.same_type_cmp(other).unwrap_or(Ordering::Equal),
            o => o,
        }
    }
}

/// Whether `s` is 24 hex digits (an ObjectId's form).
pub fn is_hex24(s: &str) -> bool {
    s.len() == 24 && s.bytes().all(|b| b.is_ascii_hexdigit())
}

/// A stored field's value (`None`: the field is missing).
pub fn stored(doc: &Value, field: &str) -> Option<Bson> {
    let v = doc.get(field)?;
    Some(match v {
        Value::Null => Bson::Null,
        Value::Number(n) => Bson::Num(n.as_f64().unwrap_or(f64::NAN)),
        Value::String(s) if field == "_id" && is_hex24(s) => Bson::Oid(s.to_ascii_lowercase()),
        Value::String(s) => Bson::Str(s.clone()),
        Value::Object(_) => Bson::Other(4),
        Value::Array(_) => Bson::Other(5),
        Value::Bool(_) => Bson::Other(8),
    })
}

/// `find[a][b]=v` pairs (with `find` stripped) into nested objects, as
/// `qs` parses a query string.
pub fn nest(pairs: &[(String, String)], root: &str) -> Result<Map<String, Value>, String> {
    let mut out = Map::new();
    for (k, v) in pairs {
        let Some(rest) = k.strip_prefix(root) else {
            continue;
        };
        let Some(rest) = rest.strip_prefix('[') else {
            continue;
        };
        let path: Vec<&str> = rest.trim_end_matches(']').split("][").collect();
        let mut at = &mut out;
        for (i, p) in path.iter().enumerate() {
            if i + 1 == path.len() {
                if at
                    .insert((*p).to_string(), Value::String(v.clone()))
                    .is_some()
                {
                    return Err(format!("{k} given twice"));
                }
            } else {
                let next = at
                    .entry((*p).to_string())
                    .or_insert_with(|| Value::Object(Map::new()));
                at = match next {
                    Value::Object(m) => m,
                    _ => return Err(format!("{k}: a value and operators at once")),
                };
            }
        }
    }
    Ok(out)
}

/// How Nightscout types a query leaf of `field` (see the module doc).
fn typed(col: &str, field: &str, raw: &str, has_id: bool) -> Result<Bson, String> {
    if field == "_id" {
        return Ok(if is_hex24(raw) {
            Bson::Oid(raw.to_ascii_lowercase())
        } else {
            Bson::Str(raw.to_string())
        });
    }
    let ints: &[&str] = match col {
        "entries" => &[
            "date",
            "sgv",
            "filtered",
            "unfiltered",
            "rssi",
            "noise",
            "mbg",
        ],
        "treatments" => &["insulin", "carbs", "glucose"],
        _ => &[],
    };
    if ints.contains(&field) {
        // JavaScript's parseInt: the leading integer, else NaN.
        let t = raw.trim_start();
        let end = t
            .char_indices()
            .find(|&(i, c)| !(c.is_ascii_digit() || (i == 0 && (c == '-' || c == '+'))))
            .map_or(t.len(), |(i, _)| i);
        return Ok(Bson::Num(t[..end].parse::<f64>().unwrap_or(f64::NAN)));
    }
    let by_created_at = col == "treatments" || col == "devicestatus";
    if by_created_at && field == "created_at" && !has_id && raw.parse::<f64>().is_err() {
        let t = raw
            .replace(' ', "+")
            .parse::<jiff::Timestamp>()
            .map_err(|_| format!("Cannot parse {raw} as a valid ISO-8601 date"))?;
        return Ok(Bson::Str(super::server::iso(t.as_millisecond())));
    }
    Ok(Bson::Str(raw.to_string()))
}

/// A parsed `find`: per field, its expression (a leaf for equality, or an
/// object of operators).
pub struct Find {
    col: String,
    has_id: bool,
    fields: Map<String, Value>,
}

impl Find {
    /// Reads the query's `find[...]` parameters for collection `col`.
    pub fn parse(col: &str, pairs: &[(String, String)]) -> Result<Find, String> {
        let fields = nest(pairs, "find")?;
        let has_id = fields.contains_key("_id");
        if (col == "treatments" || col == "devicestatus") && !has_id {
            // `enforceDateFilter` rewrites every value under `created_at`
            // with string methods: an operator object there fails.
            if let Some(Value::Object(ops)) = fields.get("created_at") {
                if ops.values().any(|v| !v.is_string()) {
                    return Err("dateString.replace is not a function".into());
                }
            }
        }
        Ok(Find {
            col: col.to_string(),
            has_id,
            fields,
        })
    }

    /// Whether the query names `_id` (so no default date filter).
    pub fn has_id(&self) -> bool {
        self.has_id
    }

    /// Whether the query bounds `field`.
    pub fn names(&self, field: &str) -> bool {
        self.fields.contains_key(field)
    }

    /// Whether `doc` matches.
    pub fn matches(&self, doc: &Value) -> Result<bool, String> {
        for (field, expr) in &self.fields {
            let v = stored(doc, field);
            let ok = match expr {
                Value::String(raw) => {
                    let want = typed(&self.col, field, raw, self.has_id)?;
                    v.as_ref()
                        .and_then(|v| v.same_type_cmp(&want))
                        .is_some_and(|o| o == Ordering::Equal)
                }
                Value::Object(ops) => self.ops(field, v.as_ref(), ops)?,
                _ => return Err(format!("find[{field}]: unsupported")),
            };
            if !ok {
                return Ok(false);
            }
        }
        Ok(true)
    }

    fn ops(&self, field: &str, v: Option<&Bson>, ops: &Map<String, Value>) -> Result<bool, String> {
        for (op, arg) in ops {
            let ok = match (op.as_str(), arg) {
                ("$not", Value::Object(inner)) => !self.ops(field, v, inner)?,
                ("$type", Value::String(alias)) => {
                    let rank = match alias.as_str() {
                        "null" => 1,
                        "number" | "double" | "int" | "long" => 2,
                        "string" => 3,
                        "object" => 4,
                        "array" => 5,
                        "objectId" => 7,
                        "bool" => 8,
                        other => return Err(format!("unknown type name alias: {other}")),
                    };
                    v.is_some_and(|v| v.rank() == rank)
                }
                (cmp, Value::String(raw)) => {
                    let want = typed(&self.col, field, raw, self.has_id)?;
                    let o = v.and_then(|v| v.same_type_cmp(&want));
                    match cmp {
                        "$eq" => o == Some(Ordering::Equal),
                        "$ne" => o != Some(Ordering::Equal),
                        "$gt" => o == Some(Ordering::Greater),
                        "$gte" => matches!(o, Some(Ordering::Greater | Ordering::Equal)),
                        "$lt" => o == Some(Ordering::Less),
                        "$lte" => matches!(o, Some(Ordering::Less | Ordering::Equal)),
                        other => return Err(format!("unknown operator: {other}")),
                    }
                }
                (other, _) => return Err(format!("unsupported operator: {other}")),
            };
            if !ok {
                return Ok(false);
            }
        }
        Ok(true)
    }
}

/// The query's `sort[field]=dir` (in order), else `default`; a direction
/// the node driver refuses is an error.
pub fn sort_of(
    pairs: &[(String, String)],
    default: (&str, i8),
) -> Result<Vec<(String, i8)>, String> {
    let mut out = Vec::new();
    for (k, v) in pairs {
        let Some(f) = k.strip_prefix("sort[").and_then(|r| r.strip_suffix(']')) else {
            continue;
        };
        let dir = match v.to_ascii_lowercase().as_str() {
            "1" | "asc" | "ascending" => 1,
            "-1" | "desc" | "descending" => -1,
            _ => return Err(format!("Invalid sort direction: \"{v}\"")),
        };
        out.push((f.to_string(), dir));
    }
    if out.is_empty() {
        out.push((default.0.to_string(), default.1));
    }
    Ok(out)
}

/// Sorts `docs` as MongoDB does (stable: ties keep the stored order).
pub fn sort(docs: &mut Vec<Value>, by: &[(String, i8)]) {
    // Each document's sort keys typed once (a stable sort of the keys, as
    // comparing the documents themselves would be).
    let mut keyed: Vec<(Vec<Bson>, Value)> = std::mem::take(docs)
        .into_iter()
        .map(|d| {
            let keys = by
                .iter()
                .map(|(f, _)| stored(&d, f).unwrap_or(Bson::Null))
                .collect();
            (keys, d)
        })
        .collect();
    keyed.sort_by(|(a, _), (b, _)| {
        for ((x, y), (_, dir)) in a.iter().zip(b).zip(by) {
            let o = x.sort_cmp(y);
            let o = if *dir < 0 { o.reverse() } else { o };
            if o != Ordering::Equal {
                return o;
            }
        }
        Ordering::Equal
    });
    *docs = keyed.into_iter().map(|(_, d)| d).collect();
}
